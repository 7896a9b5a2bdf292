//! The halts of what a run of many commands moved, against the simulated
//! contract bench (PowerCube modules 3, 5, 17; Cdios node 1 modules 0 and
//! 1; a PA-CONTROL) on virtual time.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::cdios::{enable_commands, goto_commands, Node};
use crate::device::pac::Controller;
use crate::device::powercube::Cubes;
use crate::device::powercube::Move;
use crate::device::tests::{recorded_bench, Recorded, Recording};
use crate::link::mem::{ByteDevice, MemByteLink};
use crate::link::SerialFormat;
use crate::proto::cdios::NodeId;
use crate::proto::cdios::{GotoMode, ModuleId as CdiosModule};
use crate::proto::powercube::can::{classify, CanMessage};
use crate::proto::powercube::flags::state;
use crate::proto::powercube::ModuleId;
use crate::proto::powercube::Request;
use crate::proto::CanFrame;
use crate::session::cdios::Cdios;
use crate::session::pac::Pac;
use crate::session::powercube::PowerCube;
use crate::session::RetryPolicy;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

/// The bench, handles of its own that set the devices moving, and the
/// opening of the halts' devices, each on a link of its own onto the same
/// bench (the PowerCube one records what it sends). `unreachable` families
/// fail to open; a `silent` controller never answers.
struct Rig {
    clock: VirtualClock,
    shared: Arc<dyn Clock>,
    bench: Bench,
    sent: Arc<Mutex<Vec<CanFrame>>>,
    cubes: Cubes,
    ctl: Controller,
    node: Node,
    unreachable: Vec<&'static str>,
    silent: bool,
    /// What was opened, in order: `powercube`, `pac`, `node N`.
    opened: Vec<String>,
}

fn rig() -> Rig {
    let Recorded { clock, shared, bench, link, sent } = recorded_bench();
    let cubes = Cubes::new(PowerCube::over_can(link.inner).with_clock(Arc::clone(&shared)));
    Rig {
        clock,
        shared: Arc::clone(&shared),
        cubes,
        ctl: Controller::new(pac_on(Box::new(bench.pac_link(Arc::clone(&shared))), &shared)),
        node: Node::new(Cdios::new(Box::new(bench.bus.open())).with_clock(shared), node(1), RetryPolicy::default()),
        bench,
        sent,
        unreachable: Vec::new(),
        silent: false,
        opened: Vec::new(),
    }
}

fn pac_on(link: Box<dyn crate::link::ByteLink>, clock: &Arc<dyn Clock>) -> Pac {
    Pac::new(link, 9600, SerialFormat::F7N1).with_clock(Arc::clone(clock))
}

fn retries(n: u32) -> RetryPolicy {
    RetryPolicy { read_retries: n }
}

impl Reach for Rig {
    fn face(&mut self, family: Family, node: Option<u8>) -> Result<Box<RunFace>, String> {
        Ok(match (family, node.and_then(NodeId::new)) {
            (Family::PowerCube, _) => Box::new(self.cubes()?),
            (Family::Pac, _) => Box::new(self.controller()?),
            (Family::Cdios, Some(n)) => Box::new(self.node(n)?),
            (Family::Cdios, None) => return Err("no node".into()),
        })
    }
}

impl Rig {
    fn cubes(&mut self) -> Result<Cubes, String> {
        self.opened.push("powercube".into());
        if self.unreachable.contains(&"powercube") {
            return Err("no PowerCube link".into());
        }
        let link = Recording { inner: Box::new(self.bench.bus.open()), sent: Arc::clone(&self.sent) };
        Ok(Cubes::new(PowerCube::over_can(Box::new(link)).with_clock(Arc::clone(&self.shared))))
    }

    fn controller(&mut self) -> Result<Controller, String> {
        self.opened.push("pac".into());
        if self.unreachable.contains(&"pac") {
            return Err("no PA-CONTROL link".into());
        }
        let link: Box<dyn crate::link::ByteLink> = match self.silent {
            true => Box::new(MemByteLink::new(Box::new(Silent), Arc::clone(&self.shared))),
            false => Box::new(self.bench.pac_link(Arc::clone(&self.shared))),
        };
        Ok(Controller::new(pac_on(link, &self.shared)))
    }

    fn node(&mut self, n: NodeId) -> Result<Node, String> {
        self.opened.push(format!("node {n}"));
        if self.unreachable.contains(&"cdios") {
            return Err("no Cdios link".into());
        }
        let s = Cdios::new(Box::new(self.bench.bus.open())).with_clock(Arc::clone(&self.shared));
        Ok(Node::new(s, n, RetryPolicy::default()))
    }
}

impl Rig {
    fn cube_moving(&self, m: u8) -> bool {
        let mut pc = lock(&self.bench.powercube);
        pc.advance(self.clock.now());
        let module = pc.module(m).unwrap();
        module.cube_state() & state::MOTION != 0 || module.velocity() != 0.0
    }

    fn axis_speed(&self, axis: u8) -> Option<f64> {
        let mut pac = lock(&self.bench.pac);
        pac.advance(self.clock.now());
        pac.axis_speed(axis)
    }

    fn motor_running(&self, m: u8) -> bool {
        let mut node = lock(&self.bench.cdios);
        node.poll(self.clock.now(), &mut Vec::new());
        node.module(m).unwrap().running()
    }

    fn start_cube(&mut self, m: u8) {
        self.cubes.move_module(cube(m), Move::Vel(0.1), false, false).unwrap();
    }

    fn start_axis(&mut self, axis: u8) {
        self.ctl.online().unwrap();
        self.ctl.send(0x0A83, axis.into(), None).unwrap();
        self.ctl.start_move(axis, 5000.0, false, true).unwrap();
    }

    fn start_motor(&mut self, m: u8) {
        let id = motor(m);
        lock(&self.bench.cdios).handle_can(
            self.clock.now(),
            &crate::proto::cdios::transport::nmt_start(node(1)),
            &mut Vec::new(),
        );
        self.node.send(id, &enable_commands(false)).unwrap();
        self.node.send(id, &goto_commands(GotoMode::Absolute, 1_000_000, None).unwrap()).unwrap();
    }

    fn run(&self, d: Duration) {
        self.clock.advance(d);
    }
}

fn cube(m: u8) -> ModuleId {
    ModuleId::new(m).unwrap()
}

fn node(n: u8) -> NodeId {
    NodeId::new(n).unwrap()
}

fn motor(m: u8) -> CdiosModule {
    CdiosModule::new(m).unwrap()
}

fn cdios_target(n: u8, m: u8) -> MotionTarget {
    MotionTarget::Cdios { node: node(n), module: motor(m) }
}

#[test]
fn each_device_is_kept_once_in_the_order_it_first_moved() {
    let mut r = rig();
    let mut moved = MovedDevices::new(retries(0));
    assert!(moved.is_empty());
    for t in [
        MotionTarget::Cube(cube(17)),
        MotionTarget::PacAxis(2),
        MotionTarget::Cube(cube(3)),
        MotionTarget::Cube(cube(17)),
        MotionTarget::PacAxis(2),
        MotionTarget::PacController,
        cdios_target(1, 0),
        cdios_target(1, 0),
        cdios_target(2, 0),
        MotionTarget::CubeBus,
        MotionTarget::CubeBus,
    ] {
        moved.arm(&mut r, t);
    }
    assert!(!moved.is_empty());
    assert_eq!(
        moved.targets(),
        [
            MotionTarget::Cube(cube(17)),
            MotionTarget::PacAxis(2),
            MotionTarget::Cube(cube(3)),
            MotionTarget::PacController,
            cdios_target(1, 0),
            cdios_target(2, 0),
            MotionTarget::CubeBus,
        ]
    );
}

#[test]
fn each_halt_is_named_by_the_command_that_stops_the_device_by_hand() {
    let named: Vec<String> = [
        MotionTarget::Cube(cube(17)),
        MotionTarget::CubeBus,
        MotionTarget::PacAxis(2),
        MotionTarget::PacController,
        cdios_target(1, 0),
    ]
    .iter()
    .map(ToString::to_string)
    .collect();
    assert_eq!(
        named,
        ["halt -m 17", "halt --all", "pac-stop-axis 2", "pac-stop", "cdios-stop --node 1 -m 0 --option fast"]
    );
}

#[test]
fn every_device_of_every_family_is_halted_in_order_and_then_forgotten() {
    let mut r = rig();
    r.start_cube(3);
    r.start_cube(5);
    r.start_axis(2);
    r.start_motor(0);
    r.run(Duration::from_millis(300));
    assert!(r.cube_moving(3) && r.cube_moving(5) && r.motor_running(0));
    assert_ne!(r.axis_speed(2), Some(0.0), "axis 2 moving");
    let mut moved = MovedDevices::new(retries(1));
    for t in [MotionTarget::Cube(cube(3)), MotionTarget::PacAxis(2), cdios_target(1, 0), MotionTarget::CubeBus] {
        moved.arm(&mut r, t);
    }
    let done = moved.halt(&mut r);
    let got: Vec<(MotionTarget, Result<&str, &str>)> =
        done.iter().map(|h| (h.target, h.result.as_deref().map_err(|e| e.as_str()))).collect();
    assert_eq!(got[0], (MotionTarget::Cube(cube(3)), Ok("module 3 halted")));
    assert_eq!(got[1].0, MotionTarget::PacAxis(2));
    assert!(got[1].1.is_ok_and(|t| t.starts_with("axis 2 stopped at ")), "{got:?}");
    assert_eq!(got[2], (cdios_target(1, 0), Ok("node 1 module 0: fast stop sent")));
    assert_eq!(got[3], (MotionTarget::CubeBus, Ok("Halt broadcast sent")));
    assert_eq!(r.opened, ["powercube", "pac", "node 1"], "each family opened once for the stop");
    r.run(Duration::from_secs(10));
    assert!(!r.cube_moving(3), "module 3 stands");
    assert!(!r.cube_moving(5), "module 5 stands: the broadcast reached it");
    assert_eq!(r.axis_speed(2), Some(0.0), "axis 2 stands");
    assert!(!r.motor_running(0), "motor 0 stands");
    assert!(moved.is_empty(), "halted devices are forgotten");
    r.sent.lock().unwrap().clear();
    assert!(moved.halt(&mut r).is_empty());
    assert!(r.sent.lock().unwrap().is_empty(), "a second stop sends nothing");
}

#[test]
fn the_whole_controller_is_halted_by_its_mode_read_fresh() {
    let mut r = rig();
    r.start_axis(1);
    r.run(Duration::from_millis(300));
    let mut moved = MovedDevices::new(retries(0));
    moved.arm(&mut r, MotionTarget::PacController);
    let done = moved.halt(&mut r);
    assert_eq!(done.len(), 1);
    assert_eq!(done[0].result.as_deref(), Ok("online, no axes known: STOP (0600) sent"));
    r.run(Duration::from_secs(10));
    assert_eq!(r.axis_speed(1), Some(0.0), "axis 1 stands");
}

/// A line that never answers.
struct Silent;

impl ByteDevice for Silent {
    fn on_bytes(&mut self, _now: Instant, _bytes: &[u8], _out: &mut Vec<u8>) {}
}

#[test]
fn a_halt_that_fails_says_why_and_the_others_still_go_out() {
    let mut r = rig();
    r.start_cube(3);
    r.start_motor(1);
    r.run(Duration::from_millis(300));
    // A controller that never answers: every step of its halt fails.
    r.silent = true;
    let mut moved = MovedDevices::new(retries(1));
    for t in [
        MotionTarget::PacController,
        MotionTarget::Cube(cube(9)),
        MotionTarget::PacAxis(2),
        cdios_target(1, 1),
        MotionTarget::Cube(cube(3)),
    ] {
        moved.arm(&mut r, t);
    }
    let done = moved.halt(&mut r);
    assert_eq!(done.iter().map(|h| h.target).collect::<Vec<_>>(), moved_order());
    let err = |i: usize| done[i].result.clone().unwrap_err();
    assert!(err(0).contains("no answer") && err(0).contains("; "), "status read and STOP both fail: {}", err(0));
    assert!(err(1).contains("module 9"), "{}", err(1));
    assert!(err(2).contains("no answer"), "{}", err(2));
    assert_eq!(done[3].result.as_deref(), Ok("node 1 module 1: fast stop sent"));
    assert_eq!(done[4].result.as_deref(), Ok("module 3 halted"));
    r.run(Duration::from_secs(10));
    assert!(!r.cube_moving(3) && !r.motor_running(1));
}

fn moved_order() -> Vec<MotionTarget> {
    vec![
        MotionTarget::PacController,
        MotionTarget::Cube(cube(9)),
        MotionTarget::PacAxis(2),
        cdios_target(1, 1),
        MotionTarget::Cube(cube(3)),
    ]
}

#[test]
fn a_device_that_cannot_be_reached_is_a_failed_halt_of_its_own() {
    let mut r = rig();
    r.start_cube(17);
    r.run(Duration::from_millis(100));
    r.unreachable = vec!["pac", "cdios"];
    let mut moved = MovedDevices::new(retries(0));
    for t in [MotionTarget::PacAxis(1), MotionTarget::PacController, cdios_target(1, 0), MotionTarget::Cube(cube(17))] {
        moved.arm(&mut r, t);
    }
    let results: Vec<Result<String, String>> = moved.halt(&mut r).into_iter().map(|h| h.result).collect();
    assert_eq!(
        r.opened,
        ["pac", "pac", "node 1", "powercube", "pac", "pac", "node 1"],
        "a family that failed to open when armed is asked again, and again at the halt"
    );
    assert_eq!(
        results,
        [
            Err("no PA-CONTROL link".into()),
            Err("no PA-CONTROL link".into()),
            Err("no Cdios link".into()),
            Ok("module 17 halted".into())
        ]
    );
    r.unreachable = vec!["powercube"];
    moved.arm(&mut r, MotionTarget::Cube(cube(17)));
    moved.arm(&mut r, MotionTarget::CubeBus);
    let results: Vec<Result<String, String>> = moved.halt(&mut r).into_iter().map(|h| h.result).collect();
    assert_eq!(results, [Err("no PowerCube link".into()), Err("no PowerCube link".into())]);
}

#[test]
fn a_motor_that_came_to_its_end_by_itself_is_no_failure() {
    let mut r = rig();
    r.start_motor(0);
    r.node.halt_all(&[motor(0)]);
    r.run(Duration::from_secs(1));
    assert!(!r.motor_running(0));
    let mut moved = MovedDevices::new(retries(1));
    moved.arm(&mut r, cdios_target(1, 0));
    let done = moved.halt(&mut r);
    assert_eq!(done[0].result.as_deref(), Ok("node 1 module 0: not running"));
}

#[test]
fn a_lost_halt_acknowledge_is_sent_again_up_to_the_attempts() {
    let mut r = rig();
    let mut moved = MovedDevices::new(retries(2));
    let halts = |r: &Rig| {
        let sent = r.sent.lock().unwrap();
        sent.iter()
            .filter(|f| {
                matches!(classify(f), Ok(Some(CanMessage::Request { module, request: Request::Halt })) if module.get() == 9)
            })
            .count()
    };
    moved.arm(&mut r, MotionTarget::Cube(cube(9)));
    assert!(moved.halt(&mut r)[0].result.is_err());
    assert_eq!(halts(&r), 3, "module 9 is absent: three halts, no answer");
}

#[test]
fn each_family_and_each_node_is_opened_once_per_run_of_lines() {
    let mut r = rig();
    r.start_motor(0);
    r.start_motor(1);
    r.start_axis(1);
    r.run(Duration::from_millis(100));
    let mut moved = MovedDevices::new(retries(0));
    for t in [
        MotionTarget::Cube(cube(3)),
        cdios_target(1, 0),
        MotionTarget::PacAxis(1),
        MotionTarget::Cube(cube(5)),
        cdios_target(2, 0),
        MotionTarget::PacController,
        cdios_target(1, 1),
        MotionTarget::CubeBus,
    ] {
        moved.arm(&mut r, t);
    }
    let done = moved.halt(&mut r);
    assert_eq!(r.opened, ["powercube", "node 1", "pac", "node 2"]);
    let ok: Vec<bool> = done.iter().map(|h| h.result.is_ok()).collect();
    // Node 2 is not on the bench: its halt fails; node 1's motor 1 is stopped.
    assert_eq!(ok, [true, true, true, true, false, true, true, true], "{done:?}");
    assert_eq!(done[6].result.as_deref(), Ok("node 1 module 1: fast stop sent"));
    r.run(Duration::from_millis(500));
    assert!(!r.motor_running(1));
}

/// The handles are armed from the line on: a run that ends some other way
/// than a halt or a release (a panic's unwind drops it) halts what it holds.
#[test]
fn dropped_without_a_halt_or_a_release_the_handles_halt_what_moved() {
    let mut r = rig();
    let mut moved = MovedDevices::new(retries(0));
    moved.arm(&mut r, MotionTarget::Cube(cube(3)));
    moved.arm(&mut r, cdios_target(1, 0));
    r.start_cube(3);
    r.start_motor(0);
    r.run(Duration::from_millis(300));
    assert!(r.cube_moving(3) && r.motor_running(0));
    let unwound = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
        let _held = moved;
        panic!("a line panics");
    }));
    assert!(unwound.is_err());
    r.run(Duration::from_secs(10));
    assert!(!r.cube_moving(3), "module 3 halted by its handle");
    assert!(!r.motor_running(0), "motor 0 halted by its handle");
}

/// Released (`--keep-going`, `exit --keep-moving`, a batch run to its
/// end), what moved keeps moving and nothing is sent.
#[test]
fn released_handles_leave_the_motion_running_and_send_nothing() {
    let mut r = rig();
    let mut moved = MovedDevices::new(retries(0));
    moved.arm(&mut r, MotionTarget::Cube(cube(3)));
    r.start_cube(3);
    r.run(Duration::from_millis(300));
    r.sent.lock().unwrap().clear();
    moved.release();
    assert!(moved.is_empty());
    drop(moved);
    r.run(Duration::from_millis(300));
    assert!(r.cube_moving(3), "still moving");
    assert!(r.sent.lock().unwrap().is_empty(), "nothing sent");
}
