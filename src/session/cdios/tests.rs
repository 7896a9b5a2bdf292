//! The session against a scripted node on a [`MemBus`], on virtual time.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use proptest::prelude::*;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::link::mem::{CanDevice, MemBus};
use crate::proto::cdios::{GotoMode, StartOption, StopOption};
use crate::session::RetryPolicy;

type Respond = Box<dyn FnMut(&CanFrame) -> Vec<CanFrame> + Send>;

/// Records every frame it sees and answers with whatever the script says.
struct Scripted {
    seen: Arc<Mutex<Vec<CanFrame>>>,
    respond: Respond,
}

impl CanDevice for Scripted {
    fn on_frame(&mut self, _now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        self.seen.lock().unwrap().push(*frame);
        out.extend((self.respond)(frame));
    }
}

struct Rig {
    clock: Arc<VirtualClock>,
    seen: Arc<Mutex<Vec<CanFrame>>>,
    session: Cdios,
}

impl Rig {
    fn new(respond: impl FnMut(&CanFrame) -> Vec<CanFrame> + Send + 'static) -> Self {
        let clock = Arc::new(VirtualClock::new());
        let bus = MemBus::new(clock.clone());
        let seen = Arc::new(Mutex::new(Vec::new()));
        bus.attach(Box::new(Scripted { seen: Arc::clone(&seen), respond: Box::new(respond) }));
        let session = Cdios::new(Box::new(bus.open())).with_clock(clock.clone());
        Self { clock, seen, session }
    }

    fn sent(&self) -> Vec<String> {
        self.seen.lock().unwrap().iter().map(|f| f.to_string()).collect()
    }
}

fn f(s: &str) -> CanFrame {
    s.parse().unwrap()
}

fn node1() -> NodeId {
    NodeId::new(1).unwrap()
}

fn m(id: u8) -> Address {
    Address::Module(ModuleId::new(id).unwrap())
}

fn on_command(frame: &CanFrame) -> Option<[u8; 8]> {
    (frame.id() == 0x201).then(|| transport::padded(frame.data()).unwrap())
}

/// A node that confirms everything and answers reads with fixed values.
fn plain_node(frame: &CanFrame) -> Vec<CanFrame> {
    let Some(d) = on_command(frame) else { return vec![] };
    let reply = match (d[0], d[2]) {
        (0x21, s) => [0x21, d[1], s, 0x50, 0xFB, 0xFF, 0xFF, 0], // -1200
        (0x26, 0) => [0x26, d[1], 0, 0x81, 0x00, 0x80, 0x10, 0],
        (0x10, 0x80) => [0x11, d[1], 0, 0x05, 0, 0, 0, 0],
        (c, _) => [c, d[1], 0, 0, 0, 0, 0, 0],
    };
    vec![CanFrame::new(0x181, &reply).unwrap()]
}

#[test]
fn nmt_once_then_settle_then_the_command() {
    let mut rig = Rig::new(plain_node);
    let t0 = rig.clock.now();
    let goto = Command::Goto { mode: GotoMode::Absolute, position: 5000 };
    let a = rig.session.transact(node1(), m(1), &goto).unwrap().unwrap();
    assert_eq!(a.data, [0x23, 1, 0, 0, 0, 0, 0, 0]);
    assert!(rig.clock.now() - t0 >= Duration::from_millis(100), "100 ms settle after NMT start");
    rig.session.read_status(node1(), ModuleId::new(0).unwrap()).unwrap();
    // CLI contract / specs README: NMT `000#0101`, then the goto on 0x201.
    assert_eq!(rig.sent(), ["000#0101", "201#2301008813000000", "201#2600000000000000"]);
}

#[test]
fn no_nmt_when_told() {
    let mut rig = Rig::new(plain_node);
    rig.session.set_nmt(false);
    let t0 = rig.clock.now();
    rig.session.read_position(node1(), ModuleId::new(0).unwrap(), PositionSource::Current).unwrap();
    assert_eq!(rig.sent(), ["201#2100000000000000"]);
    assert!(rig.clock.now() - t0 < Duration::from_millis(100));
}

#[test]
fn typed_reads_decode() {
    let mut rig = Rig::new(plain_node);
    let m0 = ModuleId::new(0).unwrap();
    assert_eq!(rig.session.read_position(node1(), m0, PositionSource::Setpoint).unwrap(), -1200);
    let st = rig.session.read_status(node1(), m0).unwrap();
    assert_eq!(st.status, [0x81, 0, 0x80, 0x10]);
    assert_eq!(st.flags, ["RUNNING_FORWARD", "GOTO_ACTIVE", "ENABLED", "READY_INPUT_ACTIVE"]);
    // 10h selector 80h is answered with 11h.
    let r = rig.session.read(node1(), m(0), &Command::GetDigitalOutputs).unwrap();
    assert_eq!(r.get("state"), Some(5));
}

#[test]
fn events_are_queued_never_taken_for_replies() {
    let mut rig = Rig::new(|frame| {
        let Some(d) = on_command(frame) else { return vec![] };
        if d[0] != 0x26 {
            return vec![];
        }
        vec![
            // Status change event (26h | 40h) of the same module, then a position event.
            f("181#6600000000800000"),
            f("181#6100007b00000000"),
            CanFrame::new(0x181, &[0x26, d[1], 0, 0x01, 0, 0x80, 0, 0]).unwrap(),
        ]
    });
    let st = rig.session.read_status(node1(), ModuleId::new(0).unwrap()).unwrap();
    assert_eq!(st.status, [0x01, 0, 0x80, 0]);
    let evs = rig.session.take_events();
    assert_eq!(evs.len(), 2);
    assert_eq!(evs[0].answer.command, 0x26);
    assert_eq!(evs[1].decoded().unwrap().get("position"), Some(123));
    assert!(rig.session.take_events().is_empty());
}

#[test]
fn foreign_frames_other_nodes_modules_and_selectors_are_ignored() {
    let mut rig = Rig::new(|frame| {
        let Some(d) = on_command(frame) else { return vec![] };
        vec![
            f("0A3#0b0464"),           // a PowerCube acknowledge
            f("182#2100020100000000"), // node 2
            f("181#2101020100000000"), // module 1
            f("181#2100000200000000"), // selector 0 is not the setpoint read
            f("181#23000000"),         // another command's confirmation
            CanFrame::new(0x181, &[0x21, d[1], 2, 9, 0, 0, 0, 0]).unwrap(),
        ]
    });
    let pos = rig.session.read_position(node1(), ModuleId::new(0).unwrap(), PositionSource::Setpoint).unwrap();
    assert_eq!(pos, 9);
}

#[test]
fn error_reply_is_a_device_error_with_general_text_and_bits() {
    let mut rig = Rig::new(|frame| {
        let Some(d) = on_command(frame) else { return vec![] };
        let e = match d[1] {
            1 => ErrorReply::new(d[0], 1, 0, 0x82, 0),
            _ => ErrorReply::new(d[0], d[1], 1, 0, 0),
        };
        vec![transport::answer_frame(node1(), &e.to_data())]
    });
    let goto = Command::Goto { mode: GotoMode::Absolute, position: 10 };
    let e = rig.session.transact(node1(), m(1), &goto).unwrap_err();
    assert_eq!(e.kind(), crate::session::ErrorKind::Device);
    let text = e.to_string();
    // Manual 23h error A3h: bit 1 emergency, bit 7 motor not enabled.
    assert!(text.contains("EMERGENCY") && text.contains("MOTOR_NOT_ENABLED"), "{text}");
    let e = rig.session.read_status(node1(), ModuleId::new(7).unwrap()).unwrap_err();
    assert!(e.to_string().contains("no module at that module id"), "{e}");
    assert_eq!(e.kind(), crate::session::ErrorKind::Device);
}

#[test]
fn analog_error_as_printed_56h() {
    let mut rig = Rig::new(|frame| {
        if on_command(frame).is_none() {
            return vec![];
        }
        // Manual 16h error as printed: 56h, error status bit 7 (motor enabled).
        vec![f("181#5600000080000000")]
    });
    let cmd =
        Command::SetAnalogOutput { output: crate::proto::cdios::AnalogOutput::One, latched: false, millivolts: 2500 };
    let e = rig.session.transact(node1(), m(0), &cmd).unwrap_err();
    assert!(e.to_string().contains("MOTOR_ENABLED"), "{e}");
    assert!(rig.session.take_events().is_empty(), "56h is the error, not an event");
}

#[test]
fn reads_are_retried_motion_never() {
    let count = Arc::new(Mutex::new(0));
    let c2 = Arc::clone(&count);
    let mut rig = Rig::new(move |frame| {
        if on_command(frame).is_none() {
            return vec![];
        }
        let mut n = c2.lock().unwrap();
        *n += 1;
        // The first answer of all is lost; later reads are answered.
        if *n == 1 {
            vec![]
        } else {
            plain_node(frame)
        }
    });
    let m0 = ModuleId::new(0).unwrap();
    assert_eq!(rig.session.read_position(node1(), m0, PositionSource::Current).unwrap(), -1200);
    assert_eq!(rig.sent().iter().filter(|s| s.starts_with("201#21")).count(), 2);

    let mut silent = Rig::new(|_| vec![]);
    for cmd in [
        Command::Goto { mode: GotoMode::Absolute, position: 1 },
        Command::Start {
            sync: false,
            direction: crate::proto::cdios::Direction::Forward,
            option: StartOption::Enable,
            motor_speed: 0,
        },
        Command::Stop { sync: false, option: StopOption::FastStop },
    ] {
        let e = silent.session.transact(node1(), m(0), &cmd).unwrap_err();
        assert_eq!(e.kind(), crate::session::ErrorKind::Timeout);
    }
    assert_eq!(silent.sent().len(), 4, "NMT and each motion command once: {:?}", silent.sent());
    silent.session.read_status(node1(), m0).unwrap_err();
    assert_eq!(silent.sent().len(), 4 + 3, "a read: 1 + 2 retries");
}

#[test]
fn no_confirm_waits_only_for_errors() {
    let mut rig = Rig::new(|frame| {
        let Some(d) = on_command(frame) else { return vec![] };
        match d[0] {
            0x21 | 0x26 => plain_node(frame),
            0x25 => vec![transport::answer_frame(node1(), &ErrorReply::new(0x25, d[1], 0, 0x04, 0).to_data())],
            _ => vec![],
        }
    });
    rig.session.set_confirm(false);
    rig.session
        .transact(
            node1(),
            m(0),
            &Command::Start {
                sync: false,
                direction: crate::proto::cdios::Direction::Forward,
                option: StartOption::Enable,
                motor_speed: 0,
            },
        )
        .unwrap();
    let t0 = rig.clock.now();
    let r = rig.session.transact(node1(), m(0), &Command::Goto { mode: GotoMode::Absolute, position: 1 }).unwrap();
    assert!(r.is_none());
    assert_eq!(rig.clock.now() - t0, NO_CONFIRM_WINDOW);
    let e =
        rig.session.transact(node1(), m(0), &Command::Stop { sync: false, option: StopOption::DecelerateToMinimum });
    assert!(e.unwrap_err().to_string().contains("MOTOR_NOT_RUNNING"));
    // Reads are always answered.
    assert_eq!(rig.session.read_position(node1(), ModuleId::new(0).unwrap(), PositionSource::Current).unwrap(), -1200);
}

/// The controller programs its EEPROM for 400 ms after 05h, refuses
/// everything with general error 8 meanwhile, then confirms the store.
struct EepromNode {
    seen: Arc<Mutex<Vec<CanFrame>>>,
    busy_until: Option<(Instant, u8)>,
}

impl CanDevice for EepromNode {
    fn on_frame(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        self.seen.lock().unwrap().push(*frame);
        let Some(d) = on_command(frame) else { return };
        if self.busy_until.is_some_and(|(t, _)| now < t) {
            out.push(transport::answer_frame(node1(), &ErrorReply::new(d[0], d[1], 8, 0, 0).to_data()));
        } else if d[0] == 0x05 {
            self.busy_until = Some((now + Duration::from_millis(400), d[1]));
        } else {
            out.extend(plain_node(frame));
        }
    }

    fn poll(&mut self, now: Instant, out: &mut Vec<CanFrame>) {
        if let Some((t, module)) = self.busy_until {
            if now >= t {
                out.push(CanFrame::new(0x181, &[0x05, module, 0, 0, 0, 0, 0, 0]).unwrap());
                self.busy_until = None;
            }
        }
    }
}

fn eeprom_rig() -> (Arc<VirtualClock>, MemBus, Arc<Mutex<Vec<CanFrame>>>) {
    let clock = Arc::new(VirtualClock::new());
    let bus = MemBus::new(clock.clone());
    let seen = Arc::new(Mutex::new(Vec::new()));
    bus.attach(Box::new(EepromNode { seen: Arc::clone(&seen), busy_until: None }));
    (clock, bus, seen)
}

#[test]
fn store_is_awaited_past_the_normal_timeout() {
    let (clock, bus, _) = eeprom_rig();
    let mut s = Cdios::new(Box::new(bus.open())).with_clock(clock.clone());
    s.set_nmt(false);
    // Confirmations off: 05h is still always confirmed, and takes 400 ms here.
    s.set_confirm(false);
    let t0 = clock.now();
    let a = s.transact(node1(), m(0), &Command::StoreConfiguration { defaults: false }).unwrap();
    assert_eq!(a.unwrap().data[0], 0x05);
    assert!(clock.now() - t0 >= Duration::from_millis(400));
}

#[test]
fn busy_read_is_retried_until_the_eeprom_is_done_motion_is_refused() {
    let (clock, bus, seen) = eeprom_rig();
    // A second client stores; our session works meanwhile.
    let mut other = bus.open();
    let mut s = Cdios::new(Box::new(bus.open())).with_clock(clock.clone());
    s.set_nmt(false);
    other.send(&f("201#0500004344530000")).unwrap();
    let t0 = clock.now();
    let m0 = ModuleId::new(0).unwrap();
    assert_eq!(s.read_position(node1(), m0, PositionSource::Current).unwrap(), -1200);
    assert!(clock.now() - t0 >= Duration::from_millis(400), "read waited for the EEPROM");
    other.send(&f("201#0500004344530000")).unwrap();
    let e = s.transact(node1(), m(0), &Command::Goto { mode: GotoMode::Absolute, position: 1 }).unwrap_err();
    assert_eq!(e.kind(), crate::session::ErrorKind::Device);
    assert!(e.to_string().contains("EEPROM"), "{e}");
    let gotos = seen.lock().unwrap().iter().filter(|f| f.data().first() == Some(&0x23)).count();
    assert_eq!(gotos, 1, "motion refused as busy is not repeated");
}

#[test]
fn controller_identify_is_matched_by_selector() {
    let mut rig = Rig::new(|frame| {
        let Some(d) = on_command(frame) else { return vec![] };
        vec![
            f("181#01ff010000000000"), // selector 1: not ours
            CanFrame::new(0x181, &[0x01, 0xFF, d[2], 0x44, 0x12, 0x44, 0x13, 0]).unwrap(),
        ]
    });
    let r = rig.session.read(node1(), Address::Controller, &Command::Identify { selector: 0 }).unwrap();
    assert_eq!((r.get("first_type"), r.get("second_version")), (Some(0x44), Some(0x13)));
}

#[test]
fn a_reply_echoing_an_unknown_selector_is_not_a_match() {
    // 21h reply echoing selector 3 answers no read we sent: not a match, so a timeout.
    let mut rig = Rig::new(|frame| if on_command(frame).is_some() { vec![f("181#2100030000000000")] } else { vec![] });
    let e = rig.session.read_position(node1(), ModuleId::new(0).unwrap(), PositionSource::Current).unwrap_err();
    assert_eq!(e.kind(), crate::session::ErrorKind::Timeout);
}

proptest! {
    // Whatever else is on the bus, the session ends with the genuine answer,
    // a matching error, or (if noise was a matching reply) that reply; it never panics.
    #[test]
    fn noise_never_confuses_the_session(
        noise in prop::collection::vec((0u32..0x800, prop::collection::vec(any::<u8>(), 0..=8)), 0..12),
    ) {
        let noise: Vec<CanFrame> = noise.iter().map(|(id, d)| CanFrame::new(*id, d).unwrap()).collect();
        let n2 = noise.clone();
        let mut rig = Rig::new(move |frame| {
            if on_command(frame).is_none() { return vec![] }
            let mut out = n2.clone();
            out.extend(plain_node(frame));
            out
        });
        rig.session.set_nmt(false);
        let r = rig.session.read_position(node1(), ModuleId::new(0).unwrap(), PositionSource::Current);
        let ours = |fr: &CanFrame| fr.id() == 0x181 && fr.data().get(1).copied().unwrap_or(0) == 0;
        let matching_noise = noise.iter().any(|fr| ours(fr) && matches!(fr.data().first(), Some(0x21 | 0xA1)));
        match r {
            Ok(p) => prop_assert!(p == -1200 || matching_noise),
            Err(e) => prop_assert!(matching_noise, "{e}"),
        }
    }
}

/// Holds back the first answer by 150 ms (beyond the 100 ms timeout).
struct FirstLate(bool);

impl crate::link::mem::Fault for FirstLate {
    fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<crate::link::mem::Delivery>) {
        let after = if std::mem::replace(&mut self.0, false) { Duration::from_millis(150) } else { Duration::ZERO };
        out.push(crate::link::mem::Delivery { after, frame });
    }
}

// The PowerCube session's qemu finding, for Cdios: a late reply to a timed-out
// read must not become the reply to the next read (every later poll one behind).
#[test]
fn a_reply_queued_before_the_command_is_not_taken_for_its_reply() {
    let clock = Arc::new(VirtualClock::new());
    let bus = MemBus::new(clock.clone());
    let n = Arc::new(Mutex::new(0i32));
    let seen = Arc::new(Mutex::new(Vec::new()));
    let counter = Arc::clone(&n);
    bus.attach(Box::new(Scripted {
        seen,
        respond: Box::new(move |frame| {
            let Some(d) = on_command(frame) else { return vec![] };
            let mut c = counter.lock().unwrap();
            *c += 1;
            let v = c.to_le_bytes();
            vec![CanFrame::new(0x181, &[0x21, d[1], d[2], v[0], v[1], v[2], v[3], 0]).unwrap()]
        }),
    }));
    bus.set_fault(Some(Box::new(FirstLate(true))));
    let mut s = Cdios::new(Box::new(bus.open())).with_clock(clock.clone());
    s.set_nmt(false);
    let m0 = ModuleId::new(0).unwrap();
    // Read 1 times out; the retry gets its own reply (2); the late reply (1)
    // arrives afterwards and waits in the queue.
    assert_eq!(s.read_position(node1(), m0, PositionSource::Current).unwrap(), 2);
    clock.advance(Duration::from_millis(100));
    assert_eq!(s.read_position(node1(), m0, PositionSource::Current).unwrap(), 3, "not the stale 1");
}

#[test]
fn read_many_is_one_burst_with_the_same_answers() {
    // This node answers only once all three reads are in: one at a time,
    // the first would time out.
    let mut held: Vec<CanFrame> = Vec::new();
    let mut rig = Rig::new(move |frame| {
        if on_command(frame).is_some_and(|d| d[0] == 0x21 || d[0] == 0x26) {
            held.extend(plain_node(frame));
            if held.len() == 3 {
                return std::mem::take(&mut held);
            }
            return vec![];
        }
        plain_node(frame)
    });
    let reads = [
        Command::ReadStatus(StatusSelector::Status),
        Command::ReadPosition(PositionSource::Current),
        Command::ReadPosition(PositionSource::Setpoint),
    ];
    let t0 = rig.clock.now();
    rig.session.start_node(node1()).unwrap();
    let settled = rig.clock.now();
    let r = rig.session.read_many(node1(), m(0), &reads).unwrap();
    assert_eq!(r[0].get("status1"), Some(0x81));
    assert_eq!((r[1].get("position"), r[2].get("position")), (Some(-1200), Some(-1200)));
    assert_eq!(r[1].selector, 0, "replies matched by their echoed selector");
    assert_eq!(r[2].selector, 2);
    assert!(settled > t0);
    assert_eq!(rig.sent(), ["000#0101", "201#2600000000000000", "201#2100000000000000", "201#2100020000000000"]);
}

#[test]
fn read_many_retries_exactly_like_single_reads() {
    let mut silent = Rig::new(|_| vec![]);
    silent.session.set_nmt(false);
    let reads = [Command::ReadStatus(StatusSelector::Status), Command::ReadPosition(PositionSource::Current)];
    silent.session.read_many(node1(), m(0), &reads).unwrap_err();
    // The burst is the first attempt of both; the first read then gets its 2 retries and fails.
    let status = silent.sent().iter().filter(|s| s.starts_with("201#26")).count();
    assert_eq!(status, 3, "{:?}", silent.sent());
    let mut silent = Rig::new(|_| vec![]);
    silent.session.set_nmt(false);
    silent.session.set_retry(RetryPolicy { read_retries: 0 });
    let e = silent.session.read_many(node1(), m(0), &reads).unwrap_err();
    assert_eq!(e.kind(), crate::session::ErrorKind::Timeout);
    assert_eq!(silent.sent().len(), 2, "--retries 0: the burst only");
}

/// Every reply reaches the bus 1 ms after its command: a burst's replies are
/// still to come when the next burst goes out.
struct OneMsLate;

impl crate::link::mem::Fault for OneMsLate {
    fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<crate::link::mem::Delivery>) {
        out.push(crate::link::mem::Delivery { after: Duration::from_millis(1), frame });
    }
}

/// A running node whose replies come 1 ms late: position reads answer the
/// count of position reads so far plus 100 x the module; the rest as
/// [`plain_node`].
fn late_counting_node() -> Rig {
    let clock = Arc::new(VirtualClock::new());
    let bus = MemBus::new(clock.clone());
    let seen = Arc::new(Mutex::new(Vec::new()));
    let mut count = 0i32;
    let respond = move |frame: &CanFrame| match on_command(frame) {
        Some(d) if d[0] == 0x21 => {
            count += 1;
            let v = (count + 100 * i32::from(d[1])).to_le_bytes();
            vec![CanFrame::new(0x181, &[0x21, d[1], d[2], v[0], v[1], v[2], v[3], 0]).unwrap()]
        }
        _ => plain_node(frame),
    };
    bus.attach(Box::new(Scripted { seen: Arc::clone(&seen), respond: Box::new(respond) }));
    bus.set_fault(Some(Box::new(OneMsLate)));
    let mut session = Cdios::new(Box::new(bus.open())).with_clock(clock.clone());
    session.set_nmt(false);
    Rig { clock, seen, session }
}

const POLL: [Command; 2] =
    [Command::ReadStatus(StatusSelector::Status), Command::ReadPosition(PositionSource::Current)];

// Two modules' bursts go out before either is answered; each takes its own
// replies, whichever is collected first.
#[test]
fn two_bursts_in_flight_take_their_own_replies() {
    let mut rig = late_counting_node();
    let first = rig.session.send_many(node1(), m(0), &POLL).unwrap();
    let second = rig.session.send_many(node1(), m(1), &POLL).unwrap();
    assert_eq!(rig.sent().len(), 4, "both bursts out: {:?}", rig.sent());
    let r1 = rig.session.collect_many(second).unwrap();
    let r0 = rig.session.collect_many(first).unwrap();
    assert_eq!((r0[1].get("position"), r1[1].get("position")), (Some(1), Some(102)));
    assert_eq!(r0[0].get("status1"), Some(0x81));
    assert_eq!(rig.sent().len(), 4, "no read went again on its own: {:?}", rig.sent());
}

// A burst given up before its replies came: they are dropped as they come,
// not taken for the reply of the next read of the same value.
#[test]
fn the_replies_of_an_abandoned_burst_are_not_taken_by_a_later_read() {
    let mut rig = late_counting_node();
    let sent = rig.session.send_many(node1(), m(0), &POLL).unwrap();
    rig.session.abandon_many(sent);
    let pos = rig.session.read_position(node1(), ModuleId::new(0).unwrap(), PositionSource::Current).unwrap();
    assert_eq!(pos, 2, "the abandoned burst's reply was 1");
}
