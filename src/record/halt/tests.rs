//! The decision against a fake device, and each family's look and halt
//! against the simulated contract bench on virtual time.

use std::cell::RefCell;
use std::sync::Arc;
use std::time::Duration;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::cdios::{enable_commands, goto_commands, Node};
use crate::device::pac::Controller;
use crate::device::powercube::{self as cube_dev, Cubes, Move};
use crate::link::SerialFormat;
use crate::proto::cdios::{GotoMode, ModuleId as CdiosModule, NodeId};
use crate::proto::powercube::flags::state;
use crate::proto::powercube::table::ids;
use crate::proto::powercube::ModuleId;
use crate::record::cdios::{CdiosSampler, CdiosValue};
use crate::record::pac::{PacSampler, PacValue};
use crate::record::powercube::CubeSampler;
use crate::record::Channel;
use crate::session::cdios::Cdios;
use crate::session::pac::Pac;
use crate::session::powercube::PowerCube;
use crate::session::RetryPolicy;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

#[test]
fn only_the_end_asked_for_may_leave_the_device_alone() {
    assert_eq!(HaltWhen::after(&Ok(End::Done)), HaltWhen::IfMoving);
    // A signal, a closed or full stdout, a panic elsewhere.
    assert_eq!(HaltWhen::after(&Ok(End::Stopped)), HaltWhen::Always);
    // A failed read: where the device is, is not known.
    let failed = RecordError::from(crate::device::pac::Error::Refused("no answer".into()));
    assert_eq!(HaltWhen::after(&Err(failed)), HaltWhen::Always);
}

/// A device that says whether it moves, and counts the looks and halts.
struct Fake {
    moving: Option<bool>,
    halt: Result<String, String>,
    calls: RefCell<Vec<&'static str>>,
}

impl Sampler for Fake {
    fn channels(&self) -> &[Channel] {
        &[]
    }
    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        Ok(Vec::new())
    }
}

impl HaltMotion for Fake {
    fn face(&mut self) -> &mut dyn Face {
        unreachable!("the fake answers its looks and halts itself")
    }
    fn still_moving(&mut self, at: Address) -> Option<bool> {
        assert_eq!(at, Address::PowerCube { module: 17 });
        self.calls.borrow_mut().push("look");
        self.moving
    }
    fn halt(&mut self, at: Address, attempts: u32) -> Result<String, String> {
        assert_eq!((at, attempts), (Address::PowerCube { module: 17 }, 3));
        self.calls.borrow_mut().push("halt");
        self.halt.clone()
    }
}

fn fake(moving: Option<bool>) -> Fake {
    Fake { moving, halt: Ok("halted".into()), calls: RefCell::new(Vec::new()) }
}

#[test]
fn at_the_end_asked_for_a_device_is_halted_unless_it_is_seen_standing() {
    let at = Address::PowerCube { module: 17 };
    let mut standing = fake(Some(false));
    assert_eq!(halt_motion(&mut standing, at, HaltWhen::IfMoving, 3), None);
    assert_eq!(*standing.calls.borrow(), ["look"], "a device that stands is left alone");
    let mut moving = fake(Some(true));
    assert_eq!(halt_motion(&mut moving, at, HaltWhen::IfMoving, 3), Some(Ok("halted".into())));
    assert_eq!(*moving.calls.borrow(), ["look", "halt"]);
    let mut unknown = fake(None);
    assert_eq!(halt_motion(&mut unknown, at, HaltWhen::IfMoving, 3), Some(Ok("halted".into())));
    assert_eq!(*unknown.calls.borrow(), ["look", "halt"], "a device that cannot be read is halted");
}

#[test]
fn any_other_end_halts_without_a_look_and_reports_a_failed_halt() {
    let at = Address::PowerCube { module: 17 };
    for moving in [Some(false), Some(true), None] {
        let mut f = fake(moving);
        f.halt = Err("HALT FAILED: no answer".into());
        assert_eq!(halt_motion(&mut f, at, HaltWhen::Always, 3), Some(Err("HALT FAILED: no answer".into())));
        assert_eq!(*f.calls.borrow(), ["halt"], "{moving:?}: no look, whatever it would say");
    }
}

struct Rig {
    clock: VirtualClock,
    shared: Arc<dyn Clock>,
    bench: Bench,
}

fn rig() -> Rig {
    let clock = VirtualClock::new();
    let shared: Arc<dyn Clock> = Arc::new(clock.clone());
    let bench = Bench::contract(Arc::clone(&shared));
    Rig { clock, shared, bench }
}

impl Rig {
    fn cubes(&self, modules: &[u8]) -> CubeSampler {
        let cubes =
            Cubes::new(PowerCube::over_can(Box::new(self.bench.bus.open())).with_clock(Arc::clone(&self.shared)));
        let modules: Vec<ModuleId> = modules.iter().map(|m| ModuleId::new(*m).unwrap()).collect();
        CubeSampler::new(cubes, &modules, &[cube_dev::param(ids::ACT_POS)]).unwrap()
    }

    fn pac(&self) -> PacSampler {
        let pac = Pac::new(Box::new(self.bench.pac_link(Arc::clone(&self.shared))), 9600, SerialFormat::F7N1);
        PacSampler::new(Controller::new(pac.with_clock(Arc::clone(&self.shared))), &[1, 2], &[PacValue::Position])
    }

    fn cdios(&self) -> CdiosSampler {
        let s = Cdios::new(Box::new(self.bench.bus.open())).with_clock(Arc::clone(&self.shared));
        let node = Node::new(s, NodeId::new(1).unwrap(), RetryPolicy::default());
        CdiosSampler::new(node, &[CdiosModule::new(0).unwrap()], &[CdiosValue::Position]).unwrap()
    }

    fn run(&self, d: Duration) {
        self.clock.advance(d);
    }

    fn cube_moving(&self, m: u8) -> bool {
        let mut pc = lock(&self.bench.powercube);
        pc.advance(self.clock.now());
        pc.module(m).unwrap().cube_state() & state::MOTION != 0
    }
}

#[test]
fn a_powercube_module_is_seen_moving_and_halted() {
    let r = rig();
    let mut s = r.cubes(&[3]);
    let at = Address::PowerCube { module: 3 };
    assert_eq!(s.still_moving(at), Some(false));
    s.cubes().move_module(ModuleId::new(3).unwrap(), Move::Vel(0.1), false, false).unwrap();
    r.run(Duration::from_millis(100));
    assert_eq!(s.still_moving(at), Some(true));
    assert_eq!(halt_motion(&mut s, at, HaltWhen::IfMoving, 2), Some(Ok("halted".into())));
    r.run(Duration::from_secs(2));
    assert!(!r.cube_moving(3));
    assert_eq!(s.still_moving(at), Some(false));
    // Module 9 is absent: its state cannot be read, its halt fails.
    assert_eq!(s.still_moving(Address::PowerCube { module: 9 }), None);
    let failed = s.halt(Address::PowerCube { module: 9 }, 1).unwrap_err();
    assert!(failed.starts_with("HALT FAILED: ") && failed.contains("module 9"), "{failed}");
}

#[test]
fn a_pac_axis_is_seen_moving_and_stopped() {
    let r = rig();
    let mut s = r.pac();
    let at = Address::Pac { axis: Some(2) };
    let ctl = s.controller();
    ctl.online().unwrap();
    ctl.send(0x0A83, 2, None).unwrap();
    assert_eq!(s.still_moving(at), Some(false));
    s.controller().start_move(2, 5000.0, false, true).unwrap();
    r.run(Duration::from_millis(300));
    assert_eq!(s.still_moving(at), Some(true));
    let said = halt_motion(&mut s, at, HaltWhen::IfMoving, 2).unwrap().unwrap();
    assert!(said.starts_with("stopped at "), "{said}");
    assert_eq!(s.still_moving(at), Some(false));
    // A reference drive runs as a busy command: it moves whatever the
    // axis status says.
    let (_, done) = s.controller().start_reference(1).unwrap();
    assert!(!done);
    assert_eq!(s.still_moving(Address::Pac { axis: Some(1) }), Some(true));
    assert!(s.halt(Address::Pac { axis: Some(1) }, 1).is_ok());
}

#[test]
fn a_cdios_motor_is_seen_running_and_stopped() {
    let r = rig();
    let mut s = r.cdios();
    let at = Address::Cdios { node: 1, module: 0 };
    let m = CdiosModule::new(0).unwrap();
    assert_eq!(s.still_moving(at), Some(false));
    s.node().send(m, &enable_commands(false)).unwrap();
    s.node().send(m, &goto_commands(GotoMode::Absolute, 1_000_000, None).unwrap()).unwrap();
    r.run(Duration::from_millis(100));
    assert_eq!(s.still_moving(at), Some(true));
    assert_eq!(halt_motion(&mut s, at, HaltWhen::IfMoving, 2), Some(Ok("fast stop sent".into())));
    r.run(Duration::from_millis(500));
    assert_eq!(s.still_moving(at), Some(false));
    // Stopped already: the refusal is the state asked for.
    assert_eq!(s.halt(at, 2), Ok("not running (it had come to rest)".into()));
    // Module 5 is not on the node.
    assert_eq!(s.still_moving(Address::Cdios { node: 1, module: 5 }), None);
    let failed = s.halt(Address::Cdios { node: 1, module: 5 }, 1).unwrap_err();
    assert!(failed.starts_with("STOP FAILED: "), "{failed}");
}

#[test]
fn an_address_of_another_family_is_never_taken_for_a_device() {
    let r = rig();
    let (mut cubes, mut pac, mut cdios) = (r.cubes(&[3]), r.pac(), r.cdios());
    let (module, axis, motor) =
        (Address::PowerCube { module: 3 }, Address::Pac { axis: Some(2) }, Address::Cdios { node: 1, module: 0 });
    for at in [axis, motor, Address::PowerCube { module: 0 }] {
        assert_eq!(cubes.still_moving(at), None);
        assert_eq!(cubes.halt(at, 1), Err(format!("HALT FAILED: {} is not a device of this recording", at.column())));
    }
    for at in [module, motor] {
        assert_eq!(pac.still_moving(at), None);
        assert!(pac.halt(at, 1).is_err_and(|e| e.contains("not a device of this recording")));
    }
    for at in [module, axis, Address::Cdios { node: 1, module: 16 }] {
        assert_eq!(cdios.still_moving(at), None);
        assert!(cdios.halt(at, 1).is_err_and(|e| e.contains("not a device of this recording")));
    }
}
