//! The operations against the simulated contract node (node 1, modules 0
//! and 1), every frame sent recorded.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::tests::{recorded_bench, Recorded};
use crate::proto::CanFrame;
use crate::session::ErrorKind;
use crate::sim::bench::Bench;
use crate::sim::shared::lock;

struct Rig {
    clock: VirtualClock,
    bench: Bench,
    node: Node,
    sent: Arc<Mutex<Vec<CanFrame>>>,
}

fn rig() -> Rig {
    let Recorded { clock, shared, bench, link, sent } = recorded_bench();
    let s = Cdios::new(Box::new(link)).with_clock(shared);
    Rig { clock, bench, node: Node::new(s, NodeId::new(1).unwrap(), RetryPolicy::default()), sent }
}

fn id(m: u8) -> ModuleId {
    ModuleId::new(m).unwrap()
}

impl Rig {
    /// NMT start straight to the simulated node: it runs before the test.
    fn start_sim_node(&self) {
        let start = crate::proto::cdios::transport::nmt_start(NodeId::new(1).unwrap());
        lock(&self.bench.cdios).handle_can(self.clock.now(), &start, &mut Vec::new());
    }

    fn motor(&self, m: u8) -> (bool, f64) {
        let mut node = lock(&self.bench.cdios);
        node.poll(self.clock.now(), &mut Vec::new());
        let motor = node.module(m).unwrap();
        (motor.running(), motor.speed_rpm())
    }

    /// Enabled, and on a goto long enough to be running for a while.
    fn long_goto(&mut self, m: u8) {
        self.node.send(id(m), &enable_commands(false)).unwrap();
        let cmds = goto_commands(GotoMode::Absolute, 1_000_000, None).unwrap();
        self.node.send(id(m), &cmds).unwrap();
        self.clock.advance(Duration::from_millis(200));
        assert!(self.motor(m).0, "motor {m} running");
    }
}

#[test]
fn values_outside_the_table_send_nothing() {
    let mut r = rig();
    for e in [
        goto_commands(GotoMode::Absolute, 3_000_000_000, None).unwrap_err(),
        goto_commands(GotoMode::Absolute, 0, Some(40_000)).unwrap_err(),
        start_command(Direction::Forward, StartOption::ToSpeed, Some(40_000), false).unwrap_err(),
        traject_command(2, false).unwrap_err(),
        check_position("goto", 3e9).unwrap_err(),
    ] {
        assert!(matches!(e, Error::Invalid(ValidationError::OutOfRange { .. })), "{e:?}");
        assert_eq!(e.kind(), ErrorKind::Usage);
        assert!(e.to_string().ends_with("; nothing was sent"), "{e}");
    }
    assert!(matches!(check_position("goto", 1.5), Err(Error::Refused(_))));
    assert!(start_command(Direction::Forward, StartOption::ToSpeed, None, false).is_err());
    assert!(start_command(Direction::Forward, StartOption::Accelerate, Some(10), false).is_err());
    // A batch with one bad command: not even the good ones go out.
    let batch = [
        Command::SetNextGotoSpeed { speed: 100 },
        Command::Start {
            sync: false,
            direction: Direction::Forward,
            option: StartOption::ToSpeed,
            motor_speed: 40_000,
        },
    ];
    let e = r.node.send(id(0), &batch).unwrap_err();
    assert!(e.nothing_sent(), "{e:?}");
    assert!(lock(&r.sent).is_empty(), "{:?}", lock(&r.sent));
}

#[test]
fn halt_all_stops_every_running_motor() {
    let mut r = rig();
    r.long_goto(0);
    r.long_goto(1);
    let report = r.node.halt_all(&[id(0), id(1)]);
    assert_eq!(report.len(), 2);
    for (m, res) in &report {
        assert!(matches!(res, Ok(Stopped::FastStop { confirmed: true })), "module {m}: {res:?}");
    }
    r.clock.advance(Duration::from_millis(500));
    for m in [0, 1] {
        let (running, rpm) = r.motor(m);
        assert!(!running && rpm == 0.0, "motor {m}: running {running}, {rpm} rpm");
    }
    // A second halt-all finds nothing running: no failure either way.
    for (m, res) in r.node.halt_all(&[id(0), id(1)]) {
        assert!(res.is_ok(), "module {m}: {res:?}");
    }
    // The stop itself is refused, for that reason alone; another refusal
    // (a goto to a disabled motor) is no stopped motor.
    let stop = r.node.send(id(0), &[FAST_STOP]).unwrap_err();
    assert!(refused_as_not_running(&stop), "{stop:?}");
    r.node.send(id(1), &[stop_command(StopOption::Disable, false)]).unwrap();
    let goto = r.node.send(id(1), &goto_commands(GotoMode::Absolute, 10, None).unwrap()).unwrap_err();
    assert!(goto.refusal().is_some() && !refused_as_not_running(&goto), "{goto:?}");
}

#[test]
fn an_error_bit_during_a_wait_stops_the_motor_and_is_a_device_fault() {
    let mut r = rig();
    r.long_goto(0);
    lock(&r.bench.cdios).module_mut(0).unwrap().set_emergency(true);
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(5), stop_attempts: 1 };
    let e = r.node.wait(id(0), Goal::Goto, spec, &|| false, &mut |_, _| {}).unwrap_err();
    assert!(matches!(e, Error::Faulted { .. }), "{e:?}");
    assert_eq!(e.kind(), ErrorKind::Device);
    assert!(!r.motor(0).0);
}

#[test]
fn an_interrupted_wait_fast_stops_the_motor() {
    let mut r = rig();
    r.long_goto(1);
    let spec = WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(5), stop_attempts: 1 };
    let e = r.node.wait(id(1), Goal::Goto, spec, &|| true, &mut |_, _| {}).unwrap_err();
    assert_eq!(e.to_string(), "interrupted: node 1 module 1 stopped (fast stop)");
    assert_eq!(e.kind(), ErrorKind::Interrupted);
    r.clock.advance(Duration::from_millis(500));
    assert!(!r.motor(1).0);
}

#[test]
fn a_scan_finds_the_node_modules_and_keeps_the_retry_policy() {
    let mut r = rig();
    assert_eq!(r.node.scan().unwrap(), [id(0), id(1)]);
    assert_eq!(r.node.poll(id(0)).unwrap().position, 0);
}

#[test]
fn config_assignments_are_resolved_and_checked_before_sending() {
    use config::Request;
    assert!(matches!(Request::parse(&[]).unwrap(), Request::Show(g) if g.len() == config::GROUPS.len()));
    assert!(Request::parse(&["speeds".into(), "maximum_speed=1".into()]).is_err());
    assert!(Request::parse(&["no_such_field=1".into()]).is_err());
    assert!(matches!(Request::parse(&["maximum_speed=99999999".into()]), Err(Error::Invalid(_))));
    let Request::Set(changes) = Request::parse(&["speeds.maximum_speed=1000".into()]).unwrap() else { panic!() };
    let mut r = rig();
    let groups = r.node.write_config(id(0), &changes).unwrap();
    assert_eq!(groups, ["speeds"]);
    let read = r.node.read_config(id(0), &groups).unwrap();
    assert_eq!(read[0].1.get("maximum_speed"), Some(1000));
}

/// A link that loses every Cdios answer (the commands arrive).
struct LosesAnswers(crate::device::tests::Recording);

impl crate::link::CanLink for LosesAnswers {
    fn send(&mut self, frame: &CanFrame) -> Result<(), crate::link::LinkError> {
        self.0.send(frame)
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), crate::link::LinkError> {
        self.0.send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, crate::link::LinkError> {
        let frame = self.0.recv(timeout)?;
        let answer = |f: &CanFrame| {
            matches!(crate::proto::cdios::session::incoming(f), crate::proto::cdios::session::Incoming::Answer(_))
        };
        Ok(frame.filter(|f| !answer(f)))
    }
}

// A motion under supervision goes out; without its answer the motor may be
// running, so it is fast-stopped before the error; an error reply from the
// node moved nothing and needs no stop.
#[test]
fn a_supervised_motion_that_loses_its_answer_is_fast_stopped_and_a_refused_one_is_not() {
    let mut r = rig();
    let goto = goto_commands(GotoMode::Absolute, 1_000_000, None).unwrap();
    let e = r.node.send_supervised(id(0), &goto, 2).unwrap_err();
    assert!(matches!(e, Error::Session(SessionError::Device { .. })), "not enabled: {e:?}");
    r.node.send(id(0), &enable_commands(false)).unwrap();
    r.node.send_supervised(id(0), &goto, 2).unwrap();
    r.clock.advance(Duration::from_millis(200));
    assert!(r.motor(0).0, "the goto went out");

    r.node.send(id(1), &enable_commands(false)).unwrap();
    let shared: Arc<dyn Clock> = Arc::new(r.clock.clone());
    let link = crate::device::tests::Recording { inner: Box::new(r.bench.bus.open()), sent: Arc::clone(&r.sent) };
    // The node answered before (this link loses answers from now on).
    let mut s = Cdios::new(Box::new(LosesAnswers(link))).with_clock(shared);
    s.mark_running(NodeId::new(1).unwrap());
    let mut blind = Node::new(s, NodeId::new(1).unwrap(), RetryPolicy::default());
    let e = blind.send_supervised(id(1), &goto, 2).unwrap_err();
    assert!(matches!(e, Error::LostTrack { stop_failed: Some(_), .. }), "{e:?}");
    r.clock.advance(Duration::from_millis(500));
    assert!(!r.motor(1).0, "the fast stop reached the motor");
}

fn wait_spec() -> WaitSpec {
    WaitSpec { poll: Duration::from_millis(20), timeout: Duration::from_secs(120), stop_attempts: 1 }
}

// A goto ends when the motor stands at its target, not at the first look.
#[test]
fn a_goto_wait_ends_standing_at_the_target() {
    let mut r = rig();
    r.node.send(id(0), &enable_commands(false)).unwrap();
    r.node.send(id(0), &goto_commands(GotoMode::Absolute, 20_000, None).unwrap()).unwrap();
    let mut looks = 0;
    let end = r.node.wait(id(0), Goal::Goto, wait_spec(), &|| false, &mut |_, _| looks += 1).unwrap();
    assert_eq!(end.target, Some(20_000));
    assert!((i64::from(end.position) - 20_000).abs() <= 100, "{end:?}");
    assert!(looks > 1, "{looks} looks");
    assert!(looks as u128 <= end.elapsed.as_millis() / 20 + 2, "one look per poll: {looks} in {end:?}");
    assert!(!r.motor(0).0);
    // Standing at the target already: done at the first look.
    let mut looks = 0;
    r.node.wait(id(0), Goal::Goto, wait_spec(), &|| false, &mut |_, _| looks += 1).unwrap();
    assert_eq!(looks, 1);
}

// A goto seen running that stops short (another program's stop) ends the
// wait where the motor stands.
#[test]
fn a_goto_wait_ends_when_the_motor_seen_running_stands_short_of_the_target() {
    let mut r = rig();
    r.node.send(id(0), &enable_commands(false)).unwrap();
    r.node.send(id(0), &goto_commands(GotoMode::Absolute, 1_000_000, None).unwrap()).unwrap();
    let shared: Arc<dyn Clock> = Arc::new(r.clock.clone());
    let link = crate::device::tests::Recording { inner: Box::new(r.bench.bus.open()), sent: Arc::clone(&r.sent) };
    let mut other =
        Node::new(Cdios::new(Box::new(link)).with_clock(shared), NodeId::new(1).unwrap(), RetryPolicy::default());
    let mut stopped = false;
    let end = r
        .node
        .wait(id(0), Goal::Goto, wait_spec(), &|| false, &mut |pos, _| {
            if pos > 5_000 && !stopped {
                other.stop_retrying(id(0), 1).unwrap();
                stopped = true;
            }
        })
        .unwrap();
    assert!(stopped && end.position < 500_000, "{end:?}");
}

// A motor never seen running that stands away from its setpoint (pushed
// while disabled, so nothing brings it back) has not reached its goto: the
// wait runs to its timeout instead of taking that position for the target.
#[test]
fn a_wait_on_a_motor_never_seen_running_away_from_its_setpoint_times_out() {
    let mut r = rig();
    r.node.send(id(0), &[Command::SetPosition { position: 10_000 }]).unwrap();
    lock(&r.bench.cdios).module_mut(0).unwrap().push(20_000.0);
    assert_eq!(r.node.position(id(0), PositionSource::Setpoint).unwrap(), 10_000);
    assert_eq!(r.node.position(id(0), PositionSource::Current).unwrap(), 30_000);
    let tolerance = r.node.positioning_error(id(0)).unwrap();
    assert!((3..20_000).contains(&tolerance), "between the ratio 3 and the distance 20000: {tolerance}");
    let spec = WaitSpec { timeout: Duration::from_secs(2), ..wait_spec() };
    let mut looks = 0;
    let e = r.node.wait(id(0), Goal::Goto, spec, &|| false, &mut |_, _| looks += 1).unwrap_err();
    assert!(matches!(e, Error::Session(SessionError::WaitExpired(_))), "{e:?}");
    assert_eq!(e.kind(), crate::session::ErrorKind::WaitTimeout);
    // The motor is disabled as well as at rest: its refusal of the stop is
    // said in full.
    let text = e.to_string();
    assert!(
        text.starts_with(
            "wait timed out after 2 s: node 1 module 0 was still running the goto (it answered every poll); \
             STOP OF NODE 1 MODULE 0 FAILED: node 1 module 0 refused stop"
        ),
        "{text}"
    );
    assert!(looks > 1, "{looks} looks");
    assert!(!r.motor(0).0);
}

// A trajectory has no target to compare with: it ends when the motor, seen
// running, stands again.
#[test]
fn a_traject_wait_ends_when_the_motor_seen_running_stands() {
    let mut r = rig();
    let fields = ["traject1.end_position=20000", "traject1.length=1", "traject1.initial_speed=1000"];
    let config::Request::Set(changes) = config::Request::parse(&fields.map(String::from)).unwrap() else {
        panic!("an assignment")
    };
    r.node.write_config(id(0), &changes).unwrap();
    r.node.send(id(0), &enable_commands(false)).unwrap();
    r.node.send(id(0), &[traject_command(1, false).unwrap()]).unwrap();
    let mut looks = 0;
    let end = r.node.wait(id(0), Goal::Traject, wait_spec(), &|| false, &mut |_, _| looks += 1).unwrap();
    assert_eq!(end.target, None);
    assert!(looks > 1, "{looks} looks");
    assert!((i64::from(end.position) - 20_000).abs() <= 100, "{end:?}");
    assert!(!r.motor(0).0);
}

/// A link that passes the first `keep` Cdios answers and loses the rest.
struct KeepsAnswers {
    inner: crate::device::tests::Recording,
    keep: usize,
}

impl crate::link::CanLink for KeepsAnswers {
    fn send(&mut self, frame: &CanFrame) -> Result<(), crate::link::LinkError> {
        self.inner.send(frame)
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), crate::link::LinkError> {
        self.inner.send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, crate::link::LinkError> {
        let Some(f) = self.inner.recv(timeout)? else { return Ok(None) };
        if !matches!(crate::proto::cdios::session::incoming(&f), crate::proto::cdios::session::Incoming::Answer(_)) {
            return Ok(Some(f));
        }
        if self.keep == 0 {
            return Ok(None);
        }
        self.keep -= 1;
        Ok(Some(f))
    }
}

// A refused fast stop counts as "not running" only when the status read
// says so: with the status unreadable the refusal is reported.
#[test]
fn a_refused_fast_stop_is_no_failure_only_when_the_status_says_not_running() {
    let r = rig();
    let shared: Arc<dyn Clock> = Arc::new(r.clock.clone());
    let inner = crate::device::tests::Recording { inner: Box::new(r.bench.bus.open()), sent: Arc::clone(&r.sent) };
    r.start_sim_node();
    let mut s = Cdios::new(Box::new(KeepsAnswers { inner, keep: 1 })).with_clock(shared);
    s.mark_running(NodeId::new(1).unwrap());
    let mut node = Node::new(s, NodeId::new(1).unwrap(), RetryPolicy::default());
    let report = node.halt_all(&[id(0)]);
    assert!(matches!(&report[0].1, Err(Error::Session(SessionError::Device { .. }))), "{report:?}");
}

fn sent_frames(r: &Rig) -> Vec<String> {
    lock(&r.sent).iter().map(|f| f.to_string()).collect()
}

// A node that does not answer (pre-operational: the simulated node ignores
// commands until started) is asked once, started with NMT, given its 100 ms,
// asked again, and only then sent the command.
#[test]
fn a_silent_node_is_started_then_asked_again_before_the_command() {
    let mut r = rig();
    let t0 = r.clock.now();
    r.node.send(id(0), &enable_commands(false)).unwrap();
    assert_eq!(
        sent_frames(&r),
        ["201#2600000000000000", "000#0101", "201#2600000000000000", "201#2400000005000000"],
        "probe, NMT start, probe, enable"
    );
    assert!(r.clock.now() - t0 >= Duration::from_millis(200), "the probe's timeout, then the settle time");
    // Known to run: the next command goes at once.
    lock(&r.sent).clear();
    r.node.status(id(0)).unwrap();
    assert_eq!(sent_frames(&r), ["201#2600000000000000"]);
}

// A running node answers the first read: no NMT start, and a status read
// is that very read.
#[test]
fn a_running_node_gets_no_nmt_start() {
    let mut r = rig();
    r.start_sim_node();
    let t0 = r.clock.now();
    r.node.status(id(0)).unwrap();
    r.node.speed(id(0)).unwrap();
    r.node.send(id(1), &enable_commands(false)).unwrap();
    assert_eq!(sent_frames(&r), ["201#2600000000000000", "201#2600020000000000", "201#2401000005000000"]);
    assert!(r.clock.now() - t0 < Duration::from_millis(100), "no timeout, no settle time");
    // The controller is asked the same way before an identify.
    let mut r = rig();
    r.node.identify().unwrap();
    assert_eq!(sent_frames(&r)[..3], ["201#01FF000000000000", "000#0101", "201#01FF000000000000"]);
}

// A node that never answers gets no motion at all, supervised or not.
#[test]
fn a_node_that_never_answers_is_sent_no_motion() {
    let r = rig();
    let shared: Arc<dyn Clock> = Arc::new(r.clock.clone());
    let link = crate::device::tests::Recording { inner: Box::new(r.bench.bus.open()), sent: Arc::clone(&r.sent) };
    let mut blind = Node::new(
        Cdios::new(Box::new(LosesAnswers(link))).with_clock(shared),
        NodeId::new(1).unwrap(),
        RetryPolicy::default(),
    );
    let goto = goto_commands(GotoMode::Absolute, 1_000_000, None).unwrap();
    let e = blind.send_supervised(id(0), &goto, 2).unwrap_err();
    assert!(matches!(e, Error::Session(SessionError::Timeout { .. })), "{e:?}");
    let e = blind.send(id(0), &goto).unwrap_err();
    assert!(matches!(e, Error::Session(SessionError::Timeout { .. })), "{e:?}");
    let gotos = lock(&r.sent).iter().filter(|f| f.data().first() == Some(&0x23)).count();
    assert_eq!(gotos, 0, "{:?}", sent_frames(&r));
}

/// `cdios-stop` is idempotent: a motor at rest is the state asked for.
#[test]
fn a_stop_of_a_motor_at_rest_is_no_failure_but_a_refusal_that_stops_nothing_is() {
    let mut r = rig();
    r.long_goto(0);
    assert_eq!(
        r.node.stop(id(0), StopOption::DecelerateAndStop, false).unwrap(),
        Stopped::FastStop { confirmed: true }
    );
    r.clock.advance(Duration::from_secs(2));
    assert!(!r.motor(0).0, "the stop was carried out");
    for option in [StopOption::FastStop, StopOption::DecelerateAndStop, StopOption::DecelerateToMinimum] {
        lock(&r.sent).clear();
        assert_eq!(r.node.stop(id(0), option, false).unwrap(), Stopped::NotRunning, "{option:?}");
        // The refusal alone is not taken for a motor at rest: its status says so.
        let sent = lock(&r.sent).clone();
        assert_eq!(sent.len(), 2, "the stop, then the status read: {sent:?}");
    }
    // A disabled motor at rest refuses to clear a hold: that is an answer to
    // keep, not a stopped motor.
    r.node.send(id(1), &[stop_command(StopOption::Disable, false)]).unwrap();
    let e = r.node.stop(id(1), StopOption::ClearHold, false).unwrap_err();
    assert!(e.refusal().is_some(), "{e:?}");
}
