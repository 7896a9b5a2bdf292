//! The operations against the simulated contract bench (modules 3 and 5
//! rotary, 17 linear with MaxPos 1), every frame sent recorded.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::tests::{recorded_bench, Recorded, Recording};
use crate::link::{CanLink, LinkError};
use crate::proto::powercube::can::{classify, CanMessage};
use crate::proto::powercube::flags::state;
use crate::proto::powercube::limits::LimitError;
use crate::proto::CanFrame;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

struct Rig {
    clock: VirtualClock,
    bench: Bench,
    cubes: Cubes,
    sent: Arc<Mutex<Vec<CanFrame>>>,
}

fn rig() -> Rig {
    let Recorded { clock, shared, bench, link, sent } = recorded_bench();
    let cubes = Cubes::new(PowerCube::over_can(Box::new(link)).with_clock(shared));
    Rig { clock, bench, cubes, sent }
}

fn id(m: u8) -> ModuleId {
    ModuleId::new(m).unwrap()
}

impl Rig {
    /// The requests and broadcasts sent since the last call.
    fn take_sent(&self) -> Vec<CanMessage> {
        lock(&self.sent).drain(..).filter_map(|f| classify(&f).ok().flatten()).collect()
    }

    fn motions_sent(&self) -> usize {
        self.take_sent()
            .iter()
            .filter(|m| matches!(m, CanMessage::Request { request: Request::SetMotion(_), .. }))
            .count()
    }

    fn module(&self, m: u8) -> (u32, f32) {
        let mut pc = lock(&self.bench.powercube);
        pc.advance(self.clock.now());
        let module = pc.module(m).unwrap();
        (module.cube_state(), module.velocity())
    }
}

#[test]
fn a_target_beyond_max_pos_sends_no_motion() {
    let mut r = rig();
    let e = r.cubes.move_module(id(17), Move::Ramp { pos: 5.0, vel: None, acc: None }, false, false).unwrap_err();
    assert!(matches!(e, Error::Limit(LimitError::Exceeds { limit_name: "MaxPos", .. })), "{e:?}");
    assert_eq!(e.to_string(), "target position 5 exceeds module 17's MaxPos = 1; nothing was sent");
    assert_eq!(e.kind(), crate::session::ErrorKind::Usage);
    assert_eq!(r.motions_sent(), 0);
    // The same through the dashboard's ramp, and for velocity and current.
    assert!(matches!(r.cubes.ramp(id(17), Target::To(-1.0)), Err(Error::Limit(LimitError::Exceeds { .. }))));
    assert!(r.cubes.move_module(id(3), Move::Vel(1e6), false, false).is_err());
    assert!(r.cubes.move_module(id(3), Move::Cur(1e6), false, false).is_err());
    assert_eq!(r.motions_sent(), 0);
    assert_eq!(r.module(17).1, 0.0);
}

#[test]
fn values_that_do_not_fit_the_wire_send_nothing_at_all() {
    let mut r = rig();
    for (mv, ticks) in [
        (Move::Ramp { pos: 1.5, vel: None, acc: None }, true),
        (Move::Ramp { pos: 0.5, vel: Some(0.0), acc: None }, false),
        (Move::Step { pos: f64::NAN, time_ms: 10 }, false),
        (Move::Step { pos: 0.1, time_ms: 0 }, false),
        (Move::Step { pos: 100.0, time_ms: 0 }, true),
        (Move::Vel(3e9), true),
        (Move::Cur(f64::INFINITY), false),
    ] {
        assert!(mv.check(ticks).is_err(), "{mv:?}");
        let e = r.cubes.move_module(id(3), mv, ticks, true).unwrap_err();
        assert!(e.nothing_sent() && matches!(e, Error::Limit(_)), "{e:?}");
    }
    assert!(matches!(r.cubes.ramp(id(3), Target::By(f64::NAN)), Err(Error::Limit(LimitError::NotFinite { .. }))));
    assert!(lock(&r.sent).is_empty(), "not even a read went out");
}

#[test]
fn a_faulted_module_takes_no_motion_even_forced() {
    let mut r = rig();
    lock(&r.bench.powercube).module_mut(5).unwrap().inject_error(state::TOW_ERROR);
    let e = r.cubes.move_module(id(5), Move::Vel(0.1), false, true).unwrap_err();
    let Error::NotReady { module, why } = &e else { panic!("{e:?}") };
    assert_eq!(module.get(), 5);
    assert!(why.contains(&"STATE_TOW_ERROR"), "{why:?}");
    assert_eq!(e.kind(), crate::session::ErrorKind::Device);
    assert_eq!(r.motions_sent(), 0);
    r.cubes.simple(Some(id(5)), Simple::Reset).unwrap();
    r.cubes.move_module(id(5), Move::Vel(0.1), false, false).unwrap();
    assert_eq!(r.motions_sent(), 1);
}

#[test]
fn within_limits_the_move_goes_out_once() {
    let mut r = rig();
    let moved = r.cubes.move_module(id(17), Move::Ramp { pos: 0.5, vel: Some(0.05), acc: None }, false, false).unwrap();
    assert_eq!(moved.target, Some(0.5));
    assert_eq!(r.motions_sent(), 1);
    r.clock.advance(Duration::from_millis(200));
    assert_ne!(r.module(17).1, 0.0, "moving");
}

#[test]
fn halt_all_broadcasts_first_then_halts_each_known_module() {
    let mut r = rig();
    for m in [3, 17] {
        r.cubes.move_module(id(m), Move::Vel(0.05), false, false).unwrap();
    }
    r.clock.advance(Duration::from_millis(100));
    assert_ne!(r.module(3).1, 0.0);
    r.take_sent();
    let report = r.cubes.halt_all(&[id(3), id(5), id(17)]);
    assert!(report.broadcast.is_ok());
    assert_eq!(
        report.modules.iter().map(|(m, res)| (m.get(), res.is_ok())).collect::<Vec<_>>(),
        [(3, true), (5, true), (17, true)]
    );
    let sent = r.take_sent();
    assert_eq!(sent[0], CanMessage::Broadcast(Broadcast::Halt), "{sent:?}");
    let halts: Vec<u8> = sent[1..]
        .iter()
        .filter_map(|s| match s {
            CanMessage::Request { module, request: Request::Halt } => Some(module.get()),
            _ => None,
        })
        .collect();
    assert_eq!(halts, [3, 5, 17]);
    for m in [3, 5, 17] {
        let (cube, vel) = r.module(m);
        assert_ne!(cube & state::HALTED, 0, "module {m} halted");
        assert_eq!(vel, 0.0);
    }
}

#[test]
fn a_fault_during_a_wait_is_a_device_error() {
    let mut r = rig();
    r.cubes.move_module(id(3), Move::Ramp { pos: 2.0, vel: Some(0.2), acc: None }, false, false).unwrap();
    lock(&r.bench.powercube).module_mut(3).unwrap().inject_error(state::TOW_ERROR);
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(5), halt_attempts: 1 };
    let e = r.cubes.wait(id(3), Goal::RampEnd { target: 2.0, ticks: false }, spec, &|| false, &mut |_, _| {});
    let e = e.unwrap_err();
    assert!(matches!(e, Error::Faulted { .. }) && e.kind() == crate::session::ErrorKind::Device, "{e:?}");
    assert!(e.to_string().contains("STATE_TOW_ERROR"), "{e}");
}

#[test]
fn an_interrupted_wait_halts_the_module() {
    let mut r = rig();
    r.cubes.move_module(id(3), Move::Vel(0.1), false, false).unwrap();
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(5), halt_attempts: 1 };
    let e = r.cubes.wait(id(3), Goal::Homed, spec, &|| true, &mut |_, _| {}).unwrap_err();
    assert_eq!(e.to_string(), "interrupted: module 3 halted");
    assert_eq!(e.kind(), crate::session::ErrorKind::Interrupted);
    assert_ne!(r.module(3).0 & state::HALTED, 0);
}

#[test]
fn config_and_param_input_is_checked_before_sending() {
    assert!(ConfigChange::parse(&["brake-present".into()], None).is_err());
    assert!(ConfigChange::parse(&["+no-such-flag".into()], None).is_err());
    assert!(ConfigChange::parse(&[], Some("0x1_0000_0000")).is_err());
    assert!(param_write("ActPos", "1.0").is_err(), "read-only");
    assert!(param_write("MaxVel", "fast").is_err());
    assert!(dio_outputs("16").is_err());
    assert_eq!(dio_outputs("0b0101").unwrap(), 5);
}

#[test]
fn a_jog_is_a_checked_ramp_from_where_the_module_stands() {
    let mut r = rig();
    assert_eq!(r.cubes.ramp(id(17), Target::By(0.25)).unwrap(), 0.25);
    assert_eq!(r.motions_sent(), 1);
    r.clock.advance(Duration::from_secs(10));
    assert!(matches!(
        r.cubes.ramp(id(17), Target::By(1.0)),
        Err(Error::Limit(LimitError::Exceeds { limit_name: "MaxPos", .. }))
    ));
    assert_eq!(r.motions_sent(), 0);
}

#[test]
fn a_relative_target_is_read_from_the_position_in_the_unit_of_the_move() {
    let mut r = rig();
    r.cubes.move_module(id(3), Move::Ramp { pos: 0.5, vel: None, acc: None }, false, false).unwrap();
    r.clock.advance(Duration::from_secs(30));
    let here = r.cubes.read_now(id(3), &[ids::ACT_POS, ids::ACT_I_POS]).unwrap();
    assert!((here[0] - 0.5).abs() < 1e-3 && here[1] != here[0], "{here:?}");
    r.take_sent();
    assert_eq!(r.cubes.resolve(id(3), Target::By(-0.1), false).unwrap(), here[0] - 0.1);
    assert_eq!(r.cubes.resolve(id(3), Target::By(100.0), true).unwrap(), here[1] + 100.0);
    assert_eq!(r.cubes.resolve(id(3), Target::To(0.3), false).unwrap(), 0.3);
    assert!(matches!(
        r.cubes.resolve(id(3), Target::By(f64::NAN), true),
        Err(Error::Limit(LimitError::NotFinite { .. }))
    ));
    let sent = r.take_sent();
    assert_eq!(sent.len(), 2, "one read per relative target, none for an absolute one: {sent:?}");
}

#[test]
fn force_skips_the_module_limits_but_not_the_wire_checks() {
    let mut r = rig();
    r.cubes.move_module(id(3), Move::Cur(1e3), false, true).unwrap();
    assert_eq!(r.motions_sent(), 1);
    assert!(r.cubes.move_module(id(3), Move::Cur(f64::NAN), false, true).is_err());
    assert_eq!(r.motions_sent(), 0);
}

/// The requests that change something (writes and motions), by module.
fn changes(sent: &[CanMessage]) -> Vec<(u8, Request)> {
    sent.iter()
        .filter_map(|s| match s {
            CanMessage::Request { module, request } if !request.is_read() => Some((module.get(), *request)),
            _ => None,
        })
        .collect()
}

impl Rig {
    fn sync_mode(&mut self, modules: &[u8]) {
        let change = ConfigChange { set: config::SYNC_MOTION, ..ConfigChange::default() };
        for m in modules {
            self.cubes.write_config(id(*m), change).unwrap();
        }
        self.take_sent();
    }
}

fn three() -> [ModuleId; 3] {
    [id(3), id(5), id(17)]
}

#[test]
fn a_synchronized_ramp_starts_every_module_only_at_the_broadcast() {
    let mut r = rig();
    r.sync_mode(&[3, 5, 17]);
    let plan = SyncRamp::new(&three(), &[0.5, -0.5, 0.25], None, None, false).unwrap();
    let loaded = r.cubes.load_sync(&plan, false, 2).unwrap();
    let sent = r.take_sent();
    assert_eq!(changes(&sent).iter().map(|(m, _)| *m).collect::<Vec<_>>(), [3, 5, 17], "one target each");
    assert!(!sent.iter().any(|s| matches!(s, CanMessage::Broadcast(_))));
    r.clock.advance(Duration::from_millis(300));
    for m in [3, 5, 17] {
        let (cube, vel) = r.module(m);
        assert_eq!((cube & state::MOTION, vel), (0, 0.0), "module {m} holds its target");
    }
    let started = r.cubes.start_sync(loaded).unwrap();
    assert_eq!(started.iter().map(|(m, _)| m.get()).collect::<Vec<_>>(), [3, 5, 17]);
    assert_eq!(r.take_sent(), [CanMessage::Broadcast(Broadcast::StartMotion)]);
    r.clock.advance(Duration::from_millis(100));
    for m in [3, 5, 17] {
        let (cube, vel) = r.module(m);
        assert!(cube & state::MOTION != 0 && vel != 0.0, "module {m} started");
    }
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(30), halt_attempts: 1 };
    let ends = r.cubes.wait_sync(&started, false, spec, &|| false, &mut |_, _, _| {}).unwrap();
    let at: Vec<f32> = ends.iter().map(|e| e.position).collect();
    assert_eq!(at, [0.5, -0.5, 0.25]);
}

#[test]
fn a_synchronized_ramp_checks_every_module_before_the_first_frame() {
    let mut r = rig();
    // Module 17 is not in sync mode: it would start on its own.
    r.sync_mode(&[3, 5]);
    let plan = SyncRamp::new(&three(), &[0.5, -0.5, 0.25], None, None, false).unwrap();
    let e = r.cubes.move_sync(&plan, false, 2).unwrap_err();
    assert!(matches!(e, Error::NotSyncMode { module } if module.get() == 17) && e.nothing_sent(), "{e:?}");
    // Module 17's target beyond MaxPos.
    r.sync_mode(&[17]);
    let plan = SyncRamp::new(&three(), &[0.5, -0.5, 2.0], Some(0.05), None, false).unwrap();
    let e = r.cubes.move_sync(&plan, false, 2).unwrap_err();
    assert!(matches!(e, Error::Limit(LimitError::Exceeds { limit_name: "MaxPos", .. })), "{e:?}");
    assert_eq!(changes(&r.take_sent()), [], "not even TargetVel went out");
    // Pairing and values, before the link is touched.
    assert!(SyncRamp::new(&three(), &[0.5, 0.5], None, None, false).is_err());
    assert!(SyncRamp::new(&[id(3), id(3)], &[0.5, 0.5], None, None, false).is_err());
    assert!(SyncRamp::new(&[id(3)], &[f64::NAN], None, None, false).is_err());
}

#[test]
fn waiting_for_a_module_in_sync_mode_without_a_broadcast_is_refused_before_sending() {
    let mut r = rig();
    r.sync_mode(&[3]);
    let e = r.cubes.move_to_wait_for(id(3), Move::Ramp { pos: 0.5, vel: None, acc: None }, false, false).unwrap_err();
    assert!(matches!(e, Error::SyncMode { .. }) && e.nothing_sent(), "{e:?}");
    assert_eq!(e.kind(), crate::session::ErrorKind::Usage);
    assert_eq!(changes(&r.take_sent()), []);
    // Nor does the dashboard's ramp send anything to it.
    assert!(matches!(r.cubes.ramp(id(3), Target::By(0.1)), Err(Error::SyncMode { .. })));
    assert_eq!(changes(&r.take_sent()), []);
    // Not in sync mode: the same call moves.
    r.cubes.move_to_wait_for(id(5), Move::Ramp { pos: 0.5, vel: None, acc: None }, false, false).unwrap();
    assert_eq!(r.motions_sent(), 1);
}

/// A link that loses every SetMotion to one module (as a bus losing a frame).
struct LosesMotionTo {
    inner: Recording,
    module: u8,
}

impl LosesMotionTo {
    fn keeps(&self, frame: &CanFrame) -> bool {
        !matches!(classify(frame), Ok(Some(CanMessage::Request { module, request: Request::SetMotion(_) }))
            if module.get() == self.module)
    }
}

impl CanLink for LosesMotionTo {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        if self.keeps(frame) {
            self.inner.send(frame)
        } else {
            lock(&self.inner.sent).push(*frame);
            Ok(())
        }
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        frames.iter().try_for_each(|f| self.send(f))
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        self.inner.recv(timeout)
    }
}

#[test]
fn a_target_not_taken_halts_the_loaded_modules_and_sends_no_start() {
    let mut r = rig();
    r.sync_mode(&[3, 5, 17]);
    let shared: Arc<dyn Clock> = Arc::new(r.clock.clone());
    let inner = Recording { inner: Box::new(r.bench.bus.open()), sent: Arc::clone(&r.sent) };
    let link = LosesMotionTo { inner, module: 17 };
    let mut cubes = Cubes::new(PowerCube::over_can(Box::new(link)).with_clock(shared));
    let plan = SyncRamp::new(&three(), &[0.5, -0.5, 0.25], None, None, false).unwrap();
    let e = cubes.move_sync(&plan, false, 2).unwrap_err();
    let Error::SyncAborted { module, halted, .. } = &e else { panic!("{e:?}") };
    assert_eq!(module.get(), 17);
    assert_eq!(halted.iter().map(|(m, ok)| (m.get(), *ok)).collect::<Vec<_>>(), [(3, true), (5, true), (17, true)]);
    assert_eq!(
        e.to_string(),
        "the synchronized move was not started: module 17 did not take its target \
         (modules 3, 5, 17 halted, no start broadcast sent)"
    );
    assert_eq!(e.kind(), crate::session::ErrorKind::Timeout);
    let sent = r.take_sent();
    assert!(!sent.iter().any(|s| matches!(s, CanMessage::Broadcast(_))), "{sent:?}");
    // What modules 3 and 5 held was dropped: even a start broadcast moves nothing.
    r.cubes.session().broadcast(Broadcast::StartMotion).unwrap();
    r.clock.advance(Duration::from_millis(200));
    for m in [3, 5, 17] {
        let (cube, vel) = r.module(m);
        assert!(cube & state::HALTED != 0 && vel == 0.0, "module {m}: {cube:#x}");
    }
}

#[test]
fn a_failed_wait_of_a_synchronized_move_halts_the_other_modules() {
    let mut r = rig();
    r.sync_mode(&[3, 5, 17]);
    let plan = SyncRamp::new(&three(), &[2.0, -2.0, 0.9], Some(0.05), None, false).unwrap();
    let started = r.cubes.move_sync(&plan, false, 2).unwrap();
    r.clock.advance(Duration::from_millis(200));
    lock(&r.bench.powercube).module_mut(3).unwrap().inject_error(state::TOW_ERROR);
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(60), halt_attempts: 1 };
    let e = r.cubes.wait_sync(&started, false, spec, &|| false, &mut |_, _, _| {}).unwrap_err();
    let Error::OthersHalted { source, halted } = &e else { panic!("{e:?}") };
    assert!(matches!(**source, Error::Faulted { module, .. } if module.get() == 3), "{e:?}");
    assert_eq!(halted.iter().map(|(m, ok)| (m.get(), *ok)).collect::<Vec<_>>(), [(5, true), (17, true)]);
    assert!(e.to_string().ends_with("; modules 5, 17 halted too"), "{e}");
    assert_eq!(e.kind(), crate::session::ErrorKind::Device);
    for m in [5, 17] {
        let (cube, vel) = r.module(m);
        assert!(cube & state::HALTED != 0 && vel == 0.0, "module {m} halted with the move: {cube:#x}");
    }
}

/// A link that loses every acknowledge of one module (the requests arrive).
/// Loses every acknowledge of `module` but the answers to reads.
struct LosesAcksOf {
    inner: Recording,
    module: u8,
}

impl CanLink for LosesAcksOf {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.inner.send(frame)
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.inner.send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let frame = self.inner.recv(timeout)?;
        // Reads are answered: a supervised motion reads Config before it.
        let lost = frame.as_ref().is_some_and(|f| {
            matches!(classify(f), Ok(Some(CanMessage::Ack { module, response }))
                if module.get() == self.module && !matches!(response, Response::Get { .. }))
        });
        Ok(if lost { None } else { frame })
    }
}

fn homes_and_halts(sent: &[CanMessage]) -> (usize, usize) {
    let count = |s: Simple| {
        sent.iter().filter(|m| matches!(m, CanMessage::Request { request, .. } if *request == s.request())).count()
    };
    (count(Simple::Home), count(Simple::Halt))
}

#[test]
fn a_supervised_home_is_sent_once_and_a_lost_acknowledge_halts_the_module() {
    let mut r = rig();
    r.cubes.home_supervised(id(3), 2).unwrap();
    assert_eq!(homes_and_halts(&r.take_sent()), (1, 0));

    let r = rig();
    let shared: Arc<dyn Clock> = Arc::new(r.clock.clone());
    let inner = Recording { inner: Box::new(r.bench.bus.open()), sent: Arc::clone(&r.sent) };
    let mut cubes = Cubes::new(PowerCube::over_can(Box::new(LosesAcksOf { inner, module: 3 })).with_clock(shared));
    let e = cubes.home_supervised(id(3), 2).unwrap_err();
    assert!(matches!(&e, Error::MotionUnconfirmed { module, halt_failed: Some(_), .. } if module.get() == 3), "{e:?}");
    assert_eq!(homes_and_halts(&r.take_sent()), (1, 2), "Home never again, Halt until its attempts are used up");
    assert_ne!(r.module(3).0 & state::HALTED, 0, "the Halts reached the module");
}

// Online / offline is the enable flag (read back through the config), never
// a blind 0x07 toggle.
#[test]
fn watchdog_on_sets_its_enable_flag_and_off_clears_it() {
    let mut r = rig();
    let flag = |r: &mut Rig| r.cubes.get_u32(id(5), ids::CONFIG).unwrap() & config::WATCHDOG_ENABLE != 0;
    r.cubes.watchdog_off(id(5)).unwrap();
    assert!(!flag(&mut r));
    assert!(!r.cubes.watchdog_off(id(5)).unwrap(), "already off: nothing written");
    assert!(r.cubes.watchdog_on(id(5)).unwrap());
    assert!(flag(&mut r));
    assert!(!r.cubes.watchdog_on(id(5)).unwrap(), "already on: no second toggle");
    assert!(r.cubes.watchdog_off(id(5)).unwrap());
    assert!(!flag(&mut r));
}
