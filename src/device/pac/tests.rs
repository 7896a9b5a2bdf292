//! The device layer against the simulated controller (the modes it has) and
//! a fake one (the modes it lacks, a silent line), which also counts what
//! was sent.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::face::{Face, FaceError, Halt, Manner, MotionTarget, StopHow};
use crate::link::mem::{ByteDevice, MemByteLink};
use crate::link::SerialFormat;
use crate::proto::pac::{table, CheckRule, CommandDecoder, Request};
use crate::session::ErrorKind;
use crate::sim::pac::PacController;

struct Rig {
    clock: VirtualClock,
    sim: Arc<Mutex<PacController>>,
}

impl Rig {
    fn new(axes: u8) -> Self {
        let clock = VirtualClock::new();
        let sim = Arc::new(Mutex::new(PacController::new(axes, clock.now())));
        Self { clock, sim }
    }

    /// A session of its own on the same controller, as a second program would have.
    fn controller(&self) -> Controller {
        let clock: Arc<dyn Clock> = Arc::new(self.clock.clone());
        let link = MemByteLink::new(Box::new(Arc::clone(&self.sim)), Arc::clone(&clock));
        Controller::new(Pac::new(Box::new(link), 9600, SerialFormat::F7N1).with_clock(clock))
    }

    fn sim(&self) -> std::sync::MutexGuard<'_, PacController> {
        let mut s = self.sim.lock().unwrap();
        s.advance(self.clock.now());
        s
    }

    fn run(&self, d: Duration) {
        self.clock.advance(d);
    }
}

/// Answers every command with QUIT 0 and a fixed status, except the codes
/// it keeps silent on; records the codes it received.
struct Fake {
    status: u16,
    silent: Vec<u16>,
    /// Codes answered with BE = 0 (still running); polls are never answered
    /// unless `refuse_polls`.
    running: Vec<u16>,
    /// Polls are answered with QUIT 0x14 (inadmissible).
    refuse_polls: bool,
    seen: Arc<Mutex<Vec<u16>>>,
    decoder: CommandDecoder,
}

impl ByteDevice for Fake {
    fn on_bytes(&mut self, _now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.decoder.push(bytes);
        while let Some(Ok(req)) = self.decoder.next() {
            let Request::Command { command, .. } = req else {
                if self.refuse_polls {
                    let ack = Ack {
                        quit: 0x14,
                        be: true,
                        status: self.status,
                        error: 0,
                        q_par: Par2::Int(0),
                        check_rule: CheckRule::Strict,
                    };
                    out.extend(ack.encode().unwrap());
                }
                continue;
            };
            self.seen.lock().unwrap().push(command.code);
            if !self.silent.contains(&command.code) {
                let ack = Ack {
                    quit: 0,
                    be: !self.running.contains(&command.code),
                    status: self.status,
                    error: 0,
                    // In the command's own type, as the controller answers.
                    q_par: match table::command(command.code).map(|d| d.data_type) {
                        Some(table::DataType::Float) => Par2::Float(0.0),
                        _ => Par2::Int(0),
                    },
                    check_rule: CheckRule::Strict,
                };
                out.extend(ack.encode().unwrap());
            }
        }
    }
}

fn fake(status: u16, silent: &[u16]) -> (Controller, Arc<Mutex<Vec<u16>>>) {
    fake_running(status, silent, &[])
}

fn fake_running(status: u16, silent: &[u16], running: &[u16]) -> (Controller, Arc<Mutex<Vec<u16>>>) {
    fake_with(status, silent, running, false)
}

fn fake_with(status: u16, silent: &[u16], running: &[u16], refuse_polls: bool) -> (Controller, Arc<Mutex<Vec<u16>>>) {
    let clock = VirtualClock::new();
    let seen = Arc::new(Mutex::new(Vec::new()));
    let dev = Fake {
        status,
        silent: silent.to_vec(),
        running: running.to_vec(),
        refuse_polls,
        seen: Arc::clone(&seen),
        decoder: CommandDecoder::new(),
    };
    let clock: Arc<dyn Clock> = Arc::new(clock);
    let link = MemByteLink::new(Box::new(dev), Arc::clone(&clock));
    let mut pac = Pac::new(Box::new(link), 9600, SerialFormat::F7N1).with_clock(clock);
    pac.set_retry(crate::session::RetryPolicy { read_retries: 0 });
    let mut ctl = Controller::new(pac);
    ctl.set_axes(vec![1, 2]);
    (ctl, seen)
}

fn codes(seen: &Arc<Mutex<Vec<u16>>>) -> Vec<u16> {
    seen.lock().unwrap().clone()
}

fn targets(steps: &[HaltStep]) -> Vec<HaltTarget> {
    steps.iter().map(|s| s.target).collect()
}

/// Online, with `axis` released for moves without a reference drive.
fn online(ctl: &mut Controller, axis: u8) {
    ctl.online().unwrap();
    ctl.send(0x0A83, axis.into(), None).unwrap();
}

#[test]
fn halt_all_in_automatic_mode_sends_stop_although_home_was_cached() {
    let rig = Rig::new(3);
    let mut ctl = rig.controller();
    ctl.set_axes(vec![1, 2, 3]);
    assert_eq!(ctl.status().unwrap(), 1, "home position, now cached");
    // pac-auto-start from another program.
    rig.controller().send(0x0602, 0, None).unwrap();
    assert_eq!(rig.sim().status(), 11);
    let steps = ctl.halt_all();
    assert_eq!(targets(&steps), [HaltTarget::Controller]);
    let text = steps[0].result.as_ref().unwrap();
    assert_eq!(text, "automatic mode: STOP (0600) sent");
    assert_eq!(rig.sim().status(), 15, "automatic mode stopped");
}

#[test]
fn halt_all_online_stops_every_axis_and_stays_online() {
    let rig = Rig::new(3);
    let mut ctl = rig.controller();
    ctl.set_axes(vec![1, 2, 3]);
    online(&mut ctl, 1);
    ctl.start_move(1, 5000.0, false, true).unwrap();
    rig.run(Duration::from_millis(300));
    assert_ne!(rig.sim().axis_speed(1), Some(0.0), "axis 1 moving");
    let steps = ctl.halt_all();
    assert_eq!(targets(&steps), [1, 2, 3].map(HaltTarget::Axis));
    assert!(steps.iter().all(|s| s.result.as_deref().ok() == Some("stopped (0A9A)")), "{steps:?}");
    rig.run(Duration::from_secs(10));
    assert_eq!(rig.sim().axis_speed(1), Some(0.0), "axis 1 stands");
    assert_eq!(table::mode_of_status(rig.sim().status()), Some(Mode::Online));
}

#[test]
fn halt_all_gives_up_a_reference_drive_and_stops_its_axis_first() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    ctl.set_axes(vec![1, 2]);
    ctl.online().unwrap();
    let (_, done) = ctl.start_reference(2).unwrap();
    assert!(!done);
    assert!(ctl.ensure_idle().is_err_and(|e| e.kind() == ErrorKind::Usage && e.to_string().contains("only polls")));
    rig.run(Duration::from_millis(300));
    let steps = ctl.halt_all();
    assert_eq!(targets(&steps), [HaltTarget::Axis(2), HaltTarget::Axis(1), HaltTarget::Axis(2)]);
    assert_eq!(steps[0].result.as_deref().unwrap(), "0A84 given up, axis stopped");
    assert!(ctl.busy().is_none());
    assert_eq!(rig.sim().busy(), None);
    rig.run(Duration::from_secs(10));
    assert_eq!(rig.sim().axis_speed(2), Some(0.0));
}

#[test]
fn halt_all_in_home_position_sends_nothing_but_the_status_read() {
    let (mut ctl, seen) = fake(1, &[]);
    let steps = ctl.halt_all();
    assert_eq!(targets(&steps), [HaltTarget::Controller]);
    assert!(steps[0].result.as_ref().unwrap().contains("nothing sent"));
    assert_eq!(codes(&seen), [0x190B]);
}

#[test]
fn halt_all_in_manual_mode_is_a_fault_and_sends_nothing() {
    let (mut ctl, seen) = fake(4, &[]);
    let steps = ctl.halt_all();
    let Err(e) = &steps[0].result else { panic!("{steps:?}") };
    assert!(matches!(e, Error::ManualMode { status: 4 }), "{e:?}");
    assert_eq!(e.kind(), ErrorKind::Device);
    assert_eq!(codes(&seen), [0x190B]);
}

#[test]
fn halt_all_with_an_unreadable_mode_sends_stop_anyway() {
    let (mut ctl, seen) = fake(31, &[0x190B]);
    let steps = ctl.halt_all();
    assert_eq!(targets(&steps), [HaltTarget::Controller, HaltTarget::Controller]);
    assert_eq!(steps[0].result.as_ref().unwrap_err().kind(), ErrorKind::Timeout);
    assert_eq!(steps[1].result.as_deref().unwrap(), "operating mode unreadable: STOP (0600) sent");
    assert_eq!(codes(&seen), [0x190B, 0x0600]);
}

#[test]
fn build_checks_the_mode_except_for_mode_changes_and_reads() {
    let (mut ctl, seen) = fake(1, &[]);
    for code in [0x0600, 0x0602, 0x0603, 0x0A41, 0x0A81, 0x190B] {
        ctl.build(code, 0, None).unwrap();
    }
    ctl.build(0x190C, 1, None).unwrap();
    assert!(codes(&seen).is_empty(), "no mode read for these");
    let e = ctl.build(0x0A94, 1, Some(5.0)).unwrap_err();
    assert!(matches!(e, Error::Invalid(validate::ValidationError::NotInMode { .. })), "{e:?}");
    assert!(e.nothing_sent());
    assert!(e.to_string().ends_with("; nothing was sent"), "{e}");
    assert_eq!(codes(&seen), [0x190B], "only the mode was read");
    assert!(valid_in_every_mode(table::command(0x190B).unwrap()));
    assert!(!valid_in_every_mode(table::command(0x0A94).unwrap()));
}

#[test]
fn axes_known_to_the_dashboard_bound_the_axis_numbers() {
    let (mut ctl, seen) = fake(31, &[]);
    let e = ctl.send(0x0A9A, 3, None).unwrap_err();
    assert!(matches!(e, Error::Invalid(validate::ValidationError::Axis { axis: 3, max: 2 })), "{e:?}");
    assert!(!codes(&seen).contains(&0x0A9A));
}

#[test]
fn targets_are_finite_and_inside_the_traverse_area() {
    let area = Some(TraverseArea { min: 0.0, max: 1000.0 });
    assert!(check_target(2, 1000.0, area).is_ok());
    assert!(check_target(2, 5e9, None).is_ok(), "no area known: the controller checks");
    let e = check_target(2, f64::NAN, None).unwrap_err();
    assert_eq!(e.to_string(), "target position NaN is not a finite number; nothing was sent");
    assert!(check_target(2, 0.0, area).is_ok(), "the minimum itself is inside");
    let e = check_target(2, -0.5, area).unwrap_err();
    assert!(matches!(e, Error::OutsideTraverseArea { axis: 2, .. }), "below the minimum: {e:?}");
    let e = check_target(2, 1000.5, area).unwrap_err();
    assert_eq!(
        e.to_string(),
        "target position 1000.5 is outside axis 2's traverse area 0 to 1000 (1913 / 1914); nothing was sent"
    );
    assert_eq!(e.kind(), ErrorKind::Usage);
}

#[test]
fn a_move_outside_the_traverse_area_is_not_sent() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    online(&mut ctl, 1);
    let e = ctl.start_move(1, 99_999.0, false, true).unwrap_err();
    assert!(matches!(e, Error::OutsideTraverseArea { axis: 1, .. }), "{e:?}");
    let e = ctl.start_move(1, 99_999.0, true, true).unwrap_err();
    assert!(matches!(e, Error::OutsideTraverseArea { .. }), "relative, too: {e:?}");
    let e = ctl.start_move(1, -10.0, false, true).unwrap_err();
    assert!(matches!(e, Error::OutsideTraverseArea { axis: 1, .. }), "below the minimum: {e:?}");
    rig.run(Duration::from_millis(500));
    assert_eq!(rig.sim().axis_speed(1), Some(0.0));
    // Unchecked, the controller refuses it itself (QUIT 0x41).
    let e = ctl.start_move(1, 99_999.0, false, false).unwrap_err();
    assert!(matches!(e, Error::Session(SessionError::Device { .. })), "{e:?}");
    assert_eq!(ctl.session().last_quit(), Some(0x41));
}

#[test]
fn a_move_and_its_wait_end_at_the_target() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    online(&mut ctl, 1);
    let start = ctl.start_move(1, 150.0, true, true).unwrap();
    assert_eq!((start.code, start.target), (0x0A95, 250.0), "axis 1 stands at 100 after power-up");
    let mut looks = 0;
    let end = ctl
        .wait_move(1, start.target, Duration::from_millis(50), Duration::from_secs(60), &mut |_| {
            looks += 1;
            true
        })
        .unwrap();
    assert!((end.position - 250.0).abs() < 1e-6 && end.status == 0, "{end:?}");
    assert!(looks > 1);
}

#[test]
fn a_given_up_wait_stops_the_axis() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    online(&mut ctl, 1);
    let start = ctl.start_move(1, 9000.0, false, true).unwrap();
    let mut looks = 0;
    let e = ctl
        .wait_move(1, start.target, Duration::from_millis(50), Duration::from_secs(60), &mut |_| {
            looks += 1;
            looks < 5
        })
        .unwrap_err();
    let Error::Interrupted(halted) = &e else { panic!("{e:?}") };
    assert_eq!(halted.axis, 1);
    assert!(e.to_string().starts_with("interrupted: axis 1 stopped at "), "{e}");
    assert_eq!(rig.sim().axis_speed(1), Some(0.0), "0A93 waits for standstill");
}

#[test]
fn configured_axes_from_the_parameter_or_the_probe() {
    let rig = Rig::new(5);
    let mut ctl = rig.controller();
    assert_eq!(ctl.configured_axes().unwrap(), 5, "system parameter 2 in home position");
    ctl.online().unwrap();
    assert_eq!(ctl.configured_axes().unwrap(), 5, "1910 until QUIT 0x20 online");
}

#[test]
fn stop_axis_gives_up_a_running_command_first() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    ctl.online().unwrap();
    ctl.start_reference(1).unwrap();
    assert_eq!(ctl.stop_axis(1).unwrap(), "running command given up, axis stopped (0A93)");
    ctl.start_reference(1).unwrap();
    let text = ctl.stop_axis(2).unwrap();
    assert!(text.starts_with("0A84 given up, axis 1 stopped (0A93); 0A9A done"), "{text}");
    assert!(ctl.busy().is_none());
}

#[test]
fn an_error_left_after_reset_is_a_fault() {
    let r = Reset {
        ack: Ack { quit: 0, be: true, status: 9, error: 7, q_par: Par2::Int(7), check_rule: CheckRule::Strict },
        left: 7,
    };
    let e = r.check().unwrap_err();
    assert_eq!((e.kind(), e.to_string()), (ErrorKind::Device, "PA-CONTROL error E7 could not be reset".into()));
    assert!(Reset { left: 0, ..r }.check().is_ok());
}

#[test]
fn read_only_elements_and_registers_are_refused_unsent() {
    let (mut ctl, seen) = fake(1, &[]);
    let e = ctl.write_element(Element::SystemFlag, 3, 1, false).unwrap_err();
    assert_eq!(e.to_string(), "system flags SM are read only");
    let e = ctl.write_element(Element::Input, 3, 1, true).unwrap_err();
    assert_eq!(e.to_string(), "inputs cannot be set over the online interface");
    let e = ctl.read_element_word(Element::SystemFlag, 3).unwrap_err();
    assert_eq!(e.to_string(), "system_flags have no word read");
    let sr: Register = "sr2".parse().unwrap();
    assert_eq!((sr.to_string(), sr.is_float()), ("SR2".into(), true));
    let e = ctl.write_register(sr, 1.0).unwrap_err();
    assert_eq!((e.kind(), e.to_string()), (ErrorKind::Usage, "system registers SN / SR are read only".into()));
    assert!(codes(&seen).is_empty());
    assert!("X5".parse::<Register>().is_err_and(|e| e.to_string().contains("expected N<number>")));
    assert!("N".parse::<Register>().is_err_and(|e| e.to_string().contains("bad register number")));
}

#[test]
fn elements_and_registers_on_the_simulator() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    ctl.write_element(Element::Flag, 5, 1, false).unwrap();
    assert_eq!(ctl.read_element(Element::Flag, 5).unwrap(), 1);
    assert_eq!(rig.sim().flag(5), Some(true));
    let r3: Register = "R3".parse().unwrap();
    ctl.write_register(r3, 2.5).unwrap();
    assert_eq!(ctl.read_register(r3).unwrap().as_f64(), 2.5);
}

#[test]
fn speeds_and_accelerations_must_be_positive() {
    let (mut ctl, seen) = fake(31, &[]);
    for (code, text) in [(0x0A8D, "speed 0 must be greater than 0"), (0x0A8E, "acceleration -1 must be greater than 0")]
    {
        let v = if code == 0x0A8D { 0.0 } else { -1.0 };
        let e = ctl.send(code, 1, Some(v)).unwrap_err();
        assert_eq!((e.kind(), e.to_string()), (ErrorKind::Usage, text.into()));
    }
    assert!(codes(&seen).is_empty(), "refused before the mode read");
    ctl.send(0x0A8D, 1, Some(10.0)).unwrap();
    assert_eq!(codes(&seen), [0x190B, 0x0A8D]);
}

#[test]
fn halt_all_online_without_known_axes_sends_stop() {
    let (mut ctl, seen) = fake(31, &[]);
    ctl.set_axes(Vec::new());
    let steps = ctl.halt_all();
    assert_eq!(targets(&steps), [HaltTarget::Controller]);
    assert_eq!(steps[0].result.as_deref().unwrap(), "online, no axes known: STOP (0600) sent");
    assert_eq!(codes(&seen), [0x190B, 0x0600]);
}

// The axis to stop is the one a start-and-wait motion command (0A84, 0A87,
// 0A89) names; start-and-return moves, stops and reads name none.
#[test]
fn only_start_and_wait_motion_names_an_axis_to_stop() {
    let cmd = |code, par1| Command::new(code, par1, Par2::Float(0.0));
    assert_eq!(stoppable_axis(&cmd(0x0A84, 2)), Some(2));
    assert_eq!(stoppable_axis(&cmd(0x0A87, 3)), Some(3));
    assert_eq!(stoppable_axis(&cmd(0x0A94, 2)), None, "returns at once: nothing to follow");
    assert_eq!(stoppable_axis(&cmd(0x0A93, 2)), None, "the stop itself");
    assert_eq!(stoppable_axis(&cmd(0x190C, 2)), None, "a read");
    assert_eq!(stoppable_axis(&cmd(0x0A84, 300)), None, "no such axis");
}

// A stop after a refused exchange still carries the controller's QUIT.
#[test]
fn a_stopped_error_keeps_the_refusal_of_its_cause() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    online(&mut ctl, 1);
    let e = ctl.start_move(1, 99_999.0, false, false).unwrap_err();
    let refusal = e.refusal();
    assert!(refusal.is_some(), "{e:?}");
    let stopped = Error::Stopped { context: "axis 1 stopped".into(), source: Box::new(e) };
    assert_eq!(stopped.refusal(), refusal);
}

// A move that never shows as started (status 0 far from the target at every
// look) ends the wait only after a grace of four polls.
#[test]
fn a_wait_that_never_sees_the_move_ends_after_four_polls() {
    let (mut ctl, _) = fake(31, &[]);
    let poll = Duration::from_millis(50);
    let mut looks = 0;
    let end = ctl
        .wait_move(1, 100.0, poll, Duration::from_secs(60), &mut |_| {
            looks += 1;
            true
        })
        .unwrap();
    assert!(end.elapsed >= poll * 4, "{end:?}");
    assert!(looks >= 5, "{looks} looks");
}

// Standing at the target (within 1e-6 of it, relative) ends the wait at the
// first look, before any grace.
#[test]
fn a_wait_on_an_axis_standing_at_its_target_ends_at_the_first_look() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    online(&mut ctl, 1);
    for target in [100.0, 100.0 + 5e-5] {
        let mut looks = 0;
        let end = ctl
            .wait_move(1, target, Duration::from_millis(50), Duration::from_secs(60), &mut |_| {
                looks += 1;
                true
            })
            .unwrap();
        assert_eq!((looks, end.status), (1, 0), "axis 1 stands at 100 after power-up; target {target}");
    }
}

// A move seen running ends the wait as soon as the axis stands, wherever it
// stands (a stop, a limit): no grace is waited out.
#[test]
fn a_move_seen_running_ends_the_wait_when_the_axis_stands() {
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    online(&mut ctl, 1);
    ctl.start_move(1, 150.0, true, true).unwrap();
    let mut looks = 0;
    let end = ctl
        .wait_move(1, 9_000.0, Duration::from_secs(5), Duration::from_secs(600), &mut |_| {
            looks += 1;
            true
        })
        .unwrap();
    assert!((end.position - 250.0).abs() < 1e-6, "{end:?}");
    assert_eq!(looks, 2, "moving at the first look, standing at the second");
}

// A reference drive (0A84, start and wait) that stops answering while it
// runs, or whose acknowledge never comes, may be moving: its axis is
// stopped (0A93) before the error. A refusal moved nothing: no stop.
#[test]
fn a_followed_motion_that_loses_its_answers_is_stopped_and_a_refused_one_is_not() {
    let reference = Command::new(0x0A84, 2, Par2::Int(0));
    for (silent, running) in [(&[][..], &[0x0A84][..]), (&[0x0A84][..], &[][..])] {
        let (mut ctl, seen) = fake_running(31, silent, running);
        let e = ctl.follow(&reference, &mut |_| true).unwrap_err();
        assert!(matches!(e, Error::Stopped { .. }), "silent {silent:04X?}, running {running:04X?}: {e:?}");
        assert_eq!(codes(&seen).last(), Some(&0x0A93), "{:04X?}", codes(&seen));
    }
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    ctl.online().unwrap();
    let e = ctl.follow(&Command::new(0x0A84, 9, Par2::Int(0)), &mut |_| true).unwrap_err();
    assert!(matches!(e, Error::Session(SessionError::Device { .. })), "axis 9 is unknown: {e:?}");
}

// Issue 22: a reference drive whose poll is refused (the controller is
// still busy with it, or the answer belongs to something else) has not
// been seen to end: its axis is stopped and the refusal reported with it.
#[test]
fn a_followed_motion_whose_poll_is_refused_is_stopped() {
    let (mut ctl, seen) = fake_with(31, &[], &[0x0A84], true);
    let e = ctl.follow(&Command::new(0x0A84, 2, Par2::Int(0)), &mut |_| true).unwrap_err();
    assert!(matches!(e, Error::Stopped { .. }), "{e:?}");
    assert!(matches!(e.refusal(), Some(crate::proto::Refusal::PaControl(r)) if r.quit == 0x14), "{e:?}");
    assert_eq!(codes(&seen), [0x0A84, 0x0A93]);
}

// Issue 22: on a line whose every answer comes 200 ms late (twice the
// answer timeout) the stop of last resort still stops the axis and polls
// the stop to its end, so the controller is not left busy with it.
#[test]
fn a_halt_on_a_line_of_late_answers_stops_the_axis_and_ends_the_stop() {
    use crate::sim::fault::{ByteFaults, ByteProtocol, FaultyByteDevice, Injector};
    let rig = Rig::new(2);
    let inj = Arc::new(Mutex::new(Injector::new(Default::default(), 1)));
    let dev = FaultyByteDevice::new(Arc::clone(&rig.sim), ByteFaults::new(Arc::clone(&inj), ByteProtocol::Pac));
    let clock: Arc<dyn Clock> = Arc::new(rig.clock.clone());
    let link = MemByteLink::new(Box::new(dev), Arc::clone(&clock));
    let mut ctl = Controller::new(Pac::new(Box::new(link), 9600, SerialFormat::F7N1).with_clock(clock));
    online(&mut ctl, 1);
    ctl.start_move(1, 900.0, false, true).unwrap();
    rig.run(Duration::from_millis(300));
    assert_eq!(rig.sim().axis_status(1), Some(1), "moving");
    *inj.lock().unwrap() = Injector::new("delay=200ms".parse().unwrap(), 1);
    let halted = ctl.halt_axis(1);
    assert!(halted.result.is_ok(), "{halted}");
    assert_eq!(rig.sim().busy(), None, "the stop was polled to its end");
    assert_ne!(rig.sim().axis_status(1), Some(1));
}

/// A stop asked for by hand (the face's `stop_with`) is idempotent: in
/// home position nothing moves, so only the status is read and the stop is
/// not sent; in a moving mode the stop goes out: 0600 for the controller,
/// 0A9A for an axis, 0A93 when answered at standstill. Either way the
/// acknowledge stays the session's last, for the command's report.
#[test]
fn a_stop_by_hand_in_home_position_sends_only_the_status_read() {
    let standstill = StopHow { at_standstill: true, ..StopHow::default() };
    for (at, how, code) in [
        (MotionTarget::PacController, StopHow::default(), 0x0600),
        (MotionTarget::PacAxis(2), StopHow::default(), 0x0A9A),
        (MotionTarget::PacAxis(2), standstill, 0x0A93),
    ] {
        let (mut d, seen) = fake(1, &[]);
        assert_eq!(Face::stop_with(&mut d, at, how).unwrap(), Halt::AtRest, "{code:04X}");
        assert_eq!(*seen.lock().unwrap(), [0x190B], "{code:04X}");
        assert_eq!(d.session().last_ack().map(|a| a.status), Some(1), "{code:04X}: the status read is reported");
        let (mut d, seen) = fake(31, &[]);
        assert_ne!(Face::stop_with(&mut d, at, how).unwrap(), Halt::AtRest, "{code:04X}");
        assert_eq!(seen.lock().unwrap().last(), Some(&code), "online: the stop goes out");
        assert_eq!(d.session().last_ack().map(|a| a.status), Some(31), "{code:04X}: its acknowledge is reported");
    }
}

/// A stop the PA-CONTROL has no way to make is refused before anything is sent.
#[test]
fn a_stop_manner_the_pa_control_has_not_is_refused_and_nothing_is_sent() {
    for how in [StopHow { manner: Manner::Fast, ..StopHow::default() }, StopHow { on_sync: true, ..StopHow::default() }]
    {
        let (mut d, seen) = fake(31, &[]);
        let e = Face::stop_with(&mut d, MotionTarget::PacAxis(2), how).unwrap_err();
        assert!(e.nothing_sent() && matches!(e, FaceError::Unsupported(_)), "{how}: {e}");
        assert!(seen.lock().unwrap().is_empty(), "{how}: nothing sent");
    }
}

#[test]
fn online_reads_the_speed_limits_and_refuses_values_outside_them_before_sending() {
    let rig = Rig::new(3);
    let mut ctl = rig.controller();
    ctl.online().unwrap();
    let limits = ctl.online_limits().clone();
    assert_eq!(limits.axes(), [1, 2, 3], "every configured axis");
    assert_eq!(limits.of(0x0A8D, 2), Some((0.1, 50_000.0)), "the simulated controller's 1802 / 1801 of parameter 1");
    assert_eq!(limits.of(0x0A8E, 3), Some((1.0, 100_000.0)), "and of parameter 6");
    for (code, v) in [(0x0A8D, 1e9), (0x0A8D, 0.05), (0x0A8E, 100_001.0)] {
        let e = ctl.send(code, 1, Some(v)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Usage, "{e}");
        assert!(e.nothing_sent() && e.to_string().contains("outside axis 1's limits"), "{e}");
    }
    ctl.send(0x0A8D, 1, Some(50_000.0)).unwrap();

    // Handed to a controller of another process: checked before any frame.
    let (mut other, seen) = fake(31, &[]);
    other.know_online_limits(limits);
    assert!(other.send(0x0A8D, 2, Some(1e9)).is_err());
    assert!(codes(&seen).is_empty(), "nothing sent, not even the mode read");

    ctl.offline().unwrap();
    assert!(ctl.online_limits().is_empty(), "leaving online mode ends the online values and their limits");
}

/// The face's look at a device (what `record` asks before it halts a
/// motion that has ended): a running axis moves, a standing one does not;
/// the controller moves outside home position.
#[test]
fn the_faces_state_says_a_running_axis_moves_and_a_standing_one_does_not() {
    use crate::device::face::Face;
    use crate::device::registry::MotionTarget;
    let rig = Rig::new(2);
    let mut ctl = rig.controller();
    ctl.set_axes(vec![1, 2]);
    assert!(!Face::state(&mut ctl, MotionTarget::PacController).unwrap().moving, "home position");
    online(&mut ctl, 1);
    ctl.start_move(1, 5000.0, false, true).unwrap();
    rig.run(Duration::from_millis(300));
    assert!(Face::state(&mut ctl, MotionTarget::PacAxis(1)).unwrap().moving, "axis 1 runs");
    assert!(!Face::state(&mut ctl, MotionTarget::PacAxis(2)).unwrap().moving, "axis 2 stands");
    assert!(Face::state(&mut ctl, MotionTarget::PacController).unwrap().moving, "online");
}
