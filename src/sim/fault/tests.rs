//! The fault layer itself: parsing, determinism, and what each fault does
//! to a frame, on virtual time.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::link::mem::MemBus;
use crate::link::CanLink;
use crate::proto::powercube::can::ACK_BASE;
use crate::proto::powercube::flags::state;
use crate::proto::powercube::rs232::{self, Decoder, Direction};

fn spec(s: &str) -> FaultSpec {
    s.parse().unwrap()
}

fn inj(s: &str, seed: u64) -> Arc<Mutex<Injector>> {
    Arc::new(Mutex::new(Injector::new(spec(s), seed)))
}

#[test]
fn the_issue_example_parses() {
    let s = spec("drop=0.2,delay=150ms,garbage=0.1,truncate=0.05,duplicate=0.1,wrong-module=0.05");
    assert_eq!(s.drop, 0.2);
    assert_eq!((s.delay, s.delay_p), (Duration::from_millis(150), 1.0));
    assert_eq!((s.garbage, s.truncate, s.duplicate, s.wrong_module), (0.1, 0.05, 0.1, 0.05));
    let s = spec("delay=1.5s@0.25, skip=3,count=2,trip=300ms");
    assert_eq!((s.delay, s.delay_p, s.skip, s.count), (Duration::from_millis(1500), 0.25, 3, Some(2)));
    assert_eq!(s.trip, Some(Duration::from_millis(300)));
    assert_eq!(spec(&s.to_string()), s, "Display reads back");
    assert!(!spec("trip=1s").touches_answers());
    assert!(spec("delay=10ms").touches_answers());
    for bad in ["drop=1.5", "drop", "lose=0.1", "delay=-3ms", "delay=fast", "count=x", "drop=0.1@2"] {
        assert!(bad.parse::<FaultSpec>().is_err(), "{bad}");
    }
}

#[test]
fn a_seed_replays_the_same_faults() {
    let plans = |seed| {
        let mut i = Injector::new(spec("drop=0.3,garbage=0.3,duplicate=0.3"), seed);
        (0..200).map(|_| i.plan()).collect::<Vec<_>>()
    };
    assert_eq!(plans(7), plans(7));
    assert_ne!(plans(7), plans(8));
    let mut i = Injector::new(spec("drop=0.2"), 42);
    for _ in 0..10_000 {
        i.plan();
    }
    let f = i.stats().dropped as f64 / 10_000.0;
    assert!((0.18..0.22).contains(&f), "drop rate {f}");
}

#[test]
fn skip_and_count_bound_the_faults() {
    let mut i = Injector::new(spec("drop=1,skip=2,count=3"), 1);
    let dropped: Vec<bool> = (0..8).map(|_| i.plan().drop).collect();
    assert_eq!(dropped, [false, false, true, true, true, false, false, false]);
    assert_eq!(i.stats().hit, 3);
}

fn can_out(s: &str, frame: CanFrame) -> Vec<Delivery> {
    let mut f = CanFaults::new(inj(s, 3));
    let mut out = Vec::new();
    f.device_frame(frame, &mut out);
    out
}

#[test]
fn can_faults_change_frames_as_named() {
    let ack = CanFrame::new(0x0A3, &[0x0A, 0x3C, 0, 0, 0x40, 0x3F]).unwrap();
    assert!(can_out("drop=1", ack).is_empty());
    let d = can_out("duplicate=1", ack);
    assert_eq!(d.iter().map(|d| d.frame).collect::<Vec<_>>(), [ack, ack]);
    let d = can_out("delay=150ms", ack);
    assert_eq!(d, [Delivery { after: Duration::from_millis(150), frame: ack }]);
    for seed in 0..50 {
        let mut f = CanFaults::new(inj("wrong-module=1,truncate=1,garbage=1", seed));
        let mut out = Vec::new();
        f.device_frame(ack, &mut out);
        let [noise, answer] = &out[..] else { panic!("{out:?}") };
        assert!((0x300..0x600).contains(&noise.frame.id()), "foreign traffic: {}", noise.frame);
        let m = answer.frame.id() - ACK_BASE;
        assert!((1..=31).contains(&m) && m != 3, "another module: {}", answer.frame);
        assert!(answer.frame.data().len() < ack.data().len());
        assert_eq!(answer.frame.data(), &ack.data()[..answer.frame.data().len()]);
    }
    // Cdios: another 6168 module on the same node.
    let reply = CanFrame::new(0x181, &[0x26, 0x00, 0, 0x81, 0, 0x80, 0x10, 0]).unwrap();
    for seed in 0..20 {
        let mut f = CanFaults::new(inj("wrong-module=1", seed));
        let mut out = Vec::new();
        f.device_frame(reply, &mut out);
        assert_eq!(out[0].frame.id(), 0x181);
        assert!(out[0].frame.data()[1] <= 15 && out[0].frame.data()[1] != 0, "{}", out[0].frame);
    }
}

/// Answers 0x10 with 0x11 carrying the same data.
struct Echo;
impl CanDevice for Echo {
    fn on_frame(&mut self, _now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
        if frame.id() == 0x10 {
            out.push(CanFrame::new(0x11, frame.data()).unwrap());
        }
    }
}

#[test]
fn a_delayed_frame_arrives_exactly_that_late_on_the_bus() {
    let clock = Arc::new(VirtualClock::new());
    let bus = MemBus::new(clock.clone());
    bus.attach(Box::new(Echo));
    bus.set_fault(Some(Box::new(CanFaults::new(inj("delay=150ms", 1)))));
    let mut a = bus.open();
    let t0 = clock.now();
    a.send(&CanFrame::new(0x10, &[1]).unwrap()).unwrap();
    assert_eq!(a.recv(Duration::from_millis(100)).unwrap(), None, "not within the timeout");
    assert_eq!(a.recv(Duration::from_millis(100)).unwrap().unwrap().data(), [1]);
    assert_eq!(clock.now() - t0, Duration::from_millis(150));
}

fn pc_answer(module: u8) -> Vec<u8> {
    let mut b = Vec::new();
    rs232::encode(Direction::FromModule, module, &[0x0A, 0x3C, 0, 0, 0x40, 0x3F], &mut b);
    b
}

fn byte_out(s: &str, seed: u64, protocol: ByteProtocol, answer: &[u8]) -> Vec<u8> {
    let mut f = ByteFaults::new(inj(s, seed), protocol);
    let mut out = answer.to_vec();
    f.answer(Instant::now(), &mut out);
    out
}

#[test]
fn byte_faults_change_answers_as_named() {
    let a = pc_answer(3);
    let pc = ByteProtocol::PowerCube;
    assert!(byte_out("drop=1", 1, pc, &a).is_empty());
    assert_eq!(byte_out("duplicate=1", 1, pc, &a), [a.clone(), a.clone()].concat());
    for seed in 0..50 {
        let t = byte_out("truncate=1", seed, pc, &a);
        assert!(t.len() < a.len() && a.starts_with(&t), "{t:02x?}");
        let g = byte_out("garbage=1", seed, pc, &a);
        assert!(g.len() > a.len() && g.ends_with(&a), "{g:02x?}");
        let w = byte_out("wrong-module=1", seed, pc, &a);
        let mut d = Decoder::new();
        d.push(&w);
        let f = d.next_frame().unwrap().unwrap();
        assert!(f.module != 3 && (1..=31).contains(&f.module), "module {}", f.module);
        assert_eq!(f.payload.as_slice(), [0x0A, 0x3C, 0, 0, 0x40, 0x3F]);
    }
    // The PA-CONTROL has no address: wrong-module changes nothing.
    let ack = b"\x01\x020;1;31;0;0;0\x038\x04";
    assert_eq!(byte_out("wrong-module=1", 1, ByteProtocol::Pac, ack), ack);
    // Delayed bytes wait until due.
    let mut f = ByteFaults::new(inj("delay=150ms", 1), pc);
    let t0 = Instant::now();
    let mut out = a.clone();
    f.answer(t0, &mut out);
    assert!(out.is_empty());
    f.due(t0 + Duration::from_millis(149), &mut out);
    assert!(out.is_empty());
    f.due(t0 + Duration::from_millis(150), &mut out);
    assert_eq!(out, a);
}

#[test]
fn trip_faults_a_powercube_module_that_moves_too_long() {
    use crate::proto::powercube::{ModuleId, Motion, MotionValue, Request};
    let clock = Arc::new(VirtualClock::new());
    let bench = crate::sim::bench::Bench::contract(clock.clone());
    bench.inject_faults(spec("trip=300ms"), 1);
    let t0 = clock.now();
    let m3 = ModuleId::new(3).unwrap();
    let mv = Request::SetMotion(Motion { id: 4, value: MotionValue::Float(2.0), time_ms: None });
    let mut link = bench.bus.open();
    link.send(&crate::proto::powercube::can::request_frame(m3, &mv)).unwrap();
    let state_at = |t: Duration, link: &mut crate::link::mem::MemCanLink| {
        clock.advance((t0 + t).saturating_duration_since(clock.now()));
        link.recv(Duration::ZERO).unwrap();
        lock(&bench.powercube).module(3).unwrap().cube_state()
    };
    assert_eq!(state_at(Duration::from_millis(290), &mut link) & state::ERROR, 0);
    let s = state_at(Duration::from_millis(301), &mut link);
    assert_eq!(s & (state::TOW_ERROR | state::ERROR | state::HALTED), state::TOW_ERROR | state::ERROR | state::HALTED);
    assert_eq!(s & state::MOTION, 0, "stopped");
}

#[test]
fn trip_faults_a_moving_pac_axis_with_its_limit_switch() {
    use crate::proto::pac::{Command, Par2};
    let clock = Arc::new(VirtualClock::new());
    let bench = crate::sim::bench::Bench::contract(clock.clone());
    let mut link = bench.pac_link(clock.clone());
    let mut send = |cmd: Command| {
        use crate::link::ByteLink;
        link.write_all(&cmd.encode().unwrap()).unwrap();
        let mut buf = [0u8; 128];
        link.read(&mut buf, Duration::from_millis(100)).unwrap();
    };
    send(Command::new(0x0603, 0, Par2::Int(0)));
    send(Command::new(0x0A96, 3, Par2::Float(0.0)));
    send(Command::new(0x0A94, 3, Par2::Float(5000.0)));
    let mut trip = Trip::new(Duration::from_millis(200)).watch(bench.pac.clone());
    for _ in 0..30 {
        clock.advance(Duration::from_millis(10));
        trip.check(clock.now());
    }
    let pac = lock(&bench.pac);
    assert_eq!(pac.axis_status(3), Some(4), "fault");
    assert_ne!(pac.error(), 0);
    let p = pac.axis_position(3).unwrap();
    assert!(p > 0.0 && p < 5000.0, "stopped on the way at {p}");
}
