//! The `Moving` handle on a face that counts its halts, then the faces of
//! the simulated families: a wait that panics halts what it moved.

use std::panic::{self, AssertUnwindSafe};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::cdios::{enable_commands, goto_commands, Node};
use crate::device::pac::{Controller, Follow, MoveProgress};
use crate::device::powercube::{Cubes, Goal, Move, WaitSpec};
use crate::device::registry;
use crate::device::tests::{recorded_bench, Recorded};
use crate::link::mem::MemByteLink;
use crate::link::SerialFormat;
use crate::proto::cdios::{GotoMode, ModuleId as CdiosModule, NodeId};
use crate::proto::powercube::ModuleId;
use crate::session::cdios::Cdios;
use crate::session::pac::Pac;
use crate::session::powercube::PowerCube;
use crate::session::RetryPolicy;
use crate::sim::pac::PacController;
use crate::sim::shared::lock;

/// A face that records which targets it halted.
#[derive(Default)]
struct Counting {
    halted: Vec<MotionTarget>,
}

impl Face for Counting {
    fn family(&self) -> Family {
        Family::PowerCube
    }
    fn discover(&mut self, _: &[u8]) -> Result<Vec<Found>, FaceError> {
        Ok(Vec::new())
    }
    fn identify(&mut self, _: MotionTarget) -> Result<String, FaceError> {
        Ok(String::new())
    }
    fn state(&mut self, _: MotionTarget) -> Result<State, FaceError> {
        Ok(State { moving: true, detail: String::new() })
    }
    fn halt(&mut self, at: MotionTarget, _: u32) -> Result<Halt, FaceError> {
        self.halted.push(at);
        Ok(Halt::Halted)
    }
    fn stop(&mut self, at: MotionTarget) -> Result<Halt, FaceError> {
        self.halt(at, 1)
    }
    fn halt_all(&mut self, _: Option<&[MotionTarget]>) -> Vec<HaltStep> {
        Vec::new()
    }
}

fn cube(m: u8) -> MotionTarget {
    MotionTarget::Cube(ModuleId::new(m).unwrap())
}

#[test]
fn a_dropped_handle_halts_every_target_unless_completed_or_released() {
    let mut f = Counting::default();
    drop(Moving::new(&mut f, vec![cube(3), cube(5)], 1));
    assert_eq!(f.halted, [cube(3), cube(5)], "dropped armed: each target halted");
    let mut f = Counting::default();
    Moving::new(&mut f, vec![cube(3)], 1).completed();
    Moving::new(&mut f, vec![cube(3)], 1).release();
    assert!(f.halted.is_empty(), "completed or released: nothing sent");
    let mut f = Counting::default();
    let halts = Moving::new(&mut f, vec![cube(5)], 1).halt();
    assert_eq!(halts.len(), 1);
    assert_eq!(f.halted, [cube(5)], "an explicit halt, once: the drop after it sends nothing more");
}

#[test]
fn a_panic_in_a_followed_wait_halts_and_goes_on_an_error_does_not_halt_twice() {
    let mut f = Counting::default();
    let r = panic::catch_unwind(AssertUnwindSafe(|| {
        Moving::new(&mut f, vec![cube(3)], 1).follow(|_| -> Result<(), ()> { panic!("bug in a wait") })
    }));
    assert!(r.is_err(), "the panic goes on after the halt");
    assert_eq!(f.halted, [cube(3)]);
    let mut f = Counting::default();
    assert_eq!(
        Moving::new(&mut f, vec![cube(3)], 1).follow(|_| Err::<(), _>("the wait halted")),
        Err("the wait halted")
    );
    assert_eq!(Moving::new(&mut f, vec![cube(3)], 1).follow(|_| Ok::<_, ()>(7)), Ok(7));
    assert!(f.halted.is_empty(), "the family's wait halts on its errors; arrival needs no halt");
}

#[test]
fn a_start_is_guarded_from_before_its_send_and_a_refused_start_sends_no_halt() {
    let mut f = Counting::default();
    let r = panic::catch_unwind(AssertUnwindSafe(|| {
        let _ = f.start(vec![cube(17)], 1, |_| -> Result<(), ()> { panic!("bug while sending") });
    }));
    assert!(r.is_err());
    assert_eq!(f.halted, [cube(17)], "armed before the first motion byte");
    let mut f = Counting::default();
    assert!(f.start(vec![cube(17)], 1, |_| Err::<(), _>("refused, nothing sent")).is_err());
    assert!(f.halted.is_empty(), "a refused start sends nothing, not even a halt");
    let (moving, said) = f.start(vec![cube(17)], 1, |_| Ok::<_, ()>("started")).unwrap();
    assert_eq!(said, "started");
    drop(moving);
    assert_eq!(f.halted, [cube(17)], "started and dropped: halted");
}

/// A PA-CONTROL simulator on virtual time, online, axis 1 released.
fn pac_rig() -> (VirtualClock, Arc<Mutex<PacController>>, Controller) {
    let clock = VirtualClock::new();
    let sim = Arc::new(Mutex::new(PacController::new(2, clock.now())));
    let shared: Arc<dyn Clock> = Arc::new(clock.clone());
    let link = MemByteLink::new(Box::new(Arc::clone(&sim)), Arc::clone(&shared));
    let mut ctl = Controller::new(Pac::new(Box::new(link), 9600, SerialFormat::F7N1).with_clock(shared));
    ctl.online().unwrap();
    ctl.send(0x0A83, 1, None).unwrap();
    (clock, sim, ctl)
}

fn axis_speed(clock: &VirtualClock, sim: &Arc<Mutex<PacController>>) -> Option<f64> {
    let mut s = sim.lock().unwrap();
    s.advance(clock.now());
    s.axis_speed(1)
}

/// The issue: a PA-CONTROL wait had no unwind guard. A panic in the wait
/// (here in its progress callback) of `pac-move --wait`
/// ([`Controller::move_waited`]) stops the axis; the bare wait of before
/// leaves it moving.
#[test]
fn a_panic_during_a_pa_control_wait_halts_the_axis() {
    let follow = Follow { poll: Duration::from_millis(50), limit: Duration::from_secs(60) };
    let bug = |p: &MoveProgress| {
        assert!(p.elapsed < Duration::from_millis(300), "bug in the progress display");
        true
    };
    let (clock, sim, mut ctl) = pac_rig();
    let mut targets = Vec::new();
    let r = panic::catch_unwind(AssertUnwindSafe(|| {
        let _ = ctl.move_waited((1, 9000.0, false, true), follow, &mut |s| targets.push(s.target), &mut |p| bug(p));
    }));
    assert!(r.is_err(), "the panic went on");
    assert_eq!(targets, [9000.0], "started once");
    assert_eq!(axis_speed(&clock, &sim), Some(0.0), "0A93 polled to standstill");

    // The bare wait, as `pac-move --wait` ran it before: still moving.
    let (clock, sim, mut ctl) = pac_rig();
    let started = ctl.start_move_supervised(1, 9000.0, false, true).unwrap();
    let r = panic::catch_unwind(AssertUnwindSafe(|| {
        let _ = ctl.wait_move(1, started.target, follow.poll, follow.limit, &mut |p| bug(p));
    }));
    assert!(r.is_err());
    assert_ne!(axis_speed(&clock, &sim), Some(0.0), "unguarded: still moving");
}

/// The same for `pac-ref --wait` ([`Controller::reference_waited`]): a
/// panic while the reference drive runs stops its axis.
#[test]
fn a_panic_during_a_pa_control_reference_drive_halts_the_axis() {
    let (clock, sim, mut ctl) = pac_rig();
    let follow = Follow { poll: Duration::from_millis(50), limit: Duration::from_secs(60) };
    let mut polls = 0;
    let r = panic::catch_unwind(AssertUnwindSafe(|| {
        let _ = ctl.reference_waited(2, follow, &mut |_| {
            polls += 1;
            assert!(polls < 3, "bug in the progress display");
            true
        });
    }));
    assert!(r.is_err(), "the panic went on");
    assert!(polls >= 3, "the drive ran: {polls} polls");
    let mut s = sim.lock().unwrap();
    s.advance(clock.now());
    assert_eq!((s.busy(), s.axis_speed(2)), (None, Some(0.0)), "given up, 0A93 polled to standstill");
}

#[test]
fn a_dropped_powercube_motion_halts_the_module_and_a_completed_one_does_not() {
    let Recorded { clock, shared, bench, link, sent: _ } = recorded_bench();
    let mut cubes = Cubes::new(PowerCube::over_can(Box::new(link)).with_clock(shared));
    let velocity = |m: u8| {
        let mut pc = lock(&bench.powercube);
        pc.advance(clock.now());
        pc.module(m).unwrap().velocity()
    };
    let m = ModuleId::new(3).unwrap();
    {
        let (_moving, _) = cubes.start(vec![cube(3)], 1, |c| c.move_module(m, Move::Vel(0.05), false, false)).unwrap();
        clock.advance(Duration::from_millis(100));
        assert_ne!(velocity(3), 0.0, "moving");
    }
    clock.advance(Duration::from_millis(500));
    assert_eq!(velocity(3), 0.0, "halted when the handle went");
    cubes.simple(Some(m), crate::device::powercube::Simple::Reset).unwrap();

    let (moving, _) = cubes
        .start(vec![cube(3)], 1, |c| {
            c.move_module(m, Move::Ramp { pos: 0.01, vel: Some(0.5), acc: None }, false, false)
        })
        .unwrap();
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(30), halt_attempts: 1 };
    let end = moving
        .follow(|c| c.wait(m, Goal::RampEnd { target: 0.01, ticks: false }, spec, &|| false, &mut |_, _| {}))
        .unwrap();
    assert_eq!(end.module, m);
    assert_eq!(cubes.state(m).unwrap() & crate::proto::powercube::flags::state::HALTED, 0, "not halted after arrival");
}

#[test]
fn the_cdios_face_halts_a_running_motor_and_reports_one_at_rest() {
    let Recorded { clock, shared, bench, .. } = recorded_bench();
    let node = NodeId::new(1).unwrap();
    let mut n = Node::new(Cdios::new(Box::new(bench.bus.open())).with_clock(shared), node, RetryPolicy::default());
    let module = CdiosModule::new(0).unwrap();
    let at = MotionTarget::Cdios { node, module };
    n.send(module, &enable_commands(false)).unwrap();
    assert_eq!(Face::halt(&mut n, at, 1).unwrap(), Halt::AtRest, "enabled, at rest: the state asked for");
    n.send(module, &goto_commands(GotoMode::Absolute, 100_000, None).unwrap()).unwrap();
    clock.advance(Duration::from_millis(50));
    assert!(Face::state(&mut n, at).unwrap().moving);
    assert_eq!(Face::halt(&mut n, at, 1).unwrap(), Halt::FastStop { confirmed: true });
    clock.advance(Duration::from_millis(500));
    assert!(!Face::state(&mut n, at).unwrap().moving, "stands after the fast stop");
    let other = MotionTarget::Cdios { node: NodeId::new(2).unwrap(), module };
    assert!(matches!(Face::halt(&mut n, other, 1), Err(FaceError::NotHere(..))), "another node's module is not here");
}

/// A person's stop through the face sends the stop option the manner
/// names (on the next SYNC when asked), and a manner the Cdios has not is
/// refused before anything leaves.
#[test]
fn the_cdios_face_stops_in_the_manner_asked_for() {
    use crate::proto::cdios::{Command, StopOption};
    let Recorded { clock, shared, link, sent, .. } = recorded_bench();
    let node = NodeId::new(1).unwrap();
    let mut n = Node::new(Cdios::new(Box::new(link)).with_clock(shared), node, RetryPolicy::default());
    let module = CdiosModule::new(0).unwrap();
    let at = MotionTarget::Cdios { node, module };
    let last_stop = || {
        let frames = sent.lock().unwrap();
        frames.iter().rev().find_map(|f| match Command::decode(f.data()) {
            Ok((_, Command::Stop { sync, option })) => Some((option, sync)),
            _ => None,
        })
    };
    for (manner, option) in [
        (Manner::Fast, StopOption::FastStop),
        (Manner::Default, StopOption::FastStop),
        (Manner::Decelerate, StopOption::DecelerateAndStop),
        (Manner::DecelerateToMinimum, StopOption::DecelerateToMinimum),
    ] {
        n.send(module, &enable_commands(false)).unwrap();
        n.send(module, &goto_commands(GotoMode::Relative, 100_000, None).unwrap()).unwrap();
        clock.advance(Duration::from_millis(50));
        let how = StopHow { manner, ..StopHow::default() };
        assert_eq!(Face::stop_with(&mut n, at, how).unwrap(), Halt::FastStop { confirmed: true }, "{how}");
        assert_eq!(last_stop(), Some((option, false)), "{how}");
        for _ in 0..600 {
            if !Face::state(&mut n, at).unwrap().moving {
                break;
            }
            clock.advance(Duration::from_secs(1));
        }
        assert!(!Face::state(&mut n, at).unwrap().moving, "{how}: comes to rest");
    }
    let latched = StopHow { manner: Manner::Fast, on_sync: true, ..StopHow::default() };
    let _ = Face::stop_with(&mut n, at, latched);
    assert_eq!(last_stop(), Some((StopOption::FastStop, true)), "on the next SYNC");
    let before = sent.lock().unwrap().len();
    let e = Face::stop_with(&mut n, at, StopHow { at_standstill: true, ..StopHow::default() }).unwrap_err();
    assert!(matches!(e, FaceError::Unsupported(_)) && e.nothing_sent(), "{e}");
    assert_eq!(sent.lock().unwrap().len(), before, "nothing sent");
}

#[test]
fn the_registry_opens_a_face_for_every_family() {
    struct Sim(crate::sim::bench::Bench, Arc<dyn Clock>);
    impl registry::Sessions for Sim {
        type Error = std::convert::Infallible;
        fn powercube(&mut self) -> Result<PowerCube, Self::Error> {
            Ok(PowerCube::over_can(Box::new(self.0.bus.open())).with_clock(Arc::clone(&self.1)))
        }
        fn pac(&mut self) -> Result<Pac, Self::Error> {
            let link = Box::new(self.0.pac_link(Arc::clone(&self.1)));
            Ok(Pac::new(link, 9600, SerialFormat::F7N1).with_clock(Arc::clone(&self.1)))
        }
        fn cdios(&mut self) -> Result<Cdios, Self::Error> {
            Ok(Cdios::new(Box::new(self.0.bus.open())).with_clock(Arc::clone(&self.1)))
        }
    }
    let Recorded { shared, bench, .. } = recorded_bench();
    let mut sim = Sim(bench, shared);
    let mut found = Vec::new();
    for family in registry::FACES {
        for unit in registry::units(family, &[1]) {
            let mut face = registry::open(family, unit, &mut sim, RetryPolicy::default()).unwrap();
            assert_eq!(face.family(), family);
            found.extend(face.discover(&[]).unwrap().into_iter().map(|f| f.target));
        }
    }
    let cubes: Vec<_> = found.iter().filter(|t| matches!(t, MotionTarget::Cube(_))).collect();
    assert_eq!(cubes, [&cube(3), &cube(5), &cube(17)], "{found:?}");
    assert!(found.contains(&MotionTarget::PacController) && found.contains(&MotionTarget::PacAxis(1)), "{found:?}");
    assert!(found.iter().any(|t| t.family() == Family::Cdios), "{found:?}");
}
