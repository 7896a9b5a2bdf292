//! Behaviour of the simulated bench, on virtual time.

use std::time::{Duration, Instant};

use proptest::prelude::*;

use super::*;
use crate::proto::powercube::can::request_frame;
use crate::proto::powercube::flags::{config, short, state};
use crate::proto::powercube::frame::{Payload, Value};
use crate::proto::powercube::rs232::Decoder;
use crate::proto::powercube::table::{self, ids};
use crate::proto::powercube::{Motion, MotionValue, Request, Response};

fn mid(n: u8) -> ModuleId {
    ModuleId::new(n).unwrap()
}

fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s)
}

/// The contract bench on a virtual clock.
struct Bench {
    bus: PowerCubeBus,
    start: Instant,
    now: Instant,
}

impl Bench {
    fn new() -> Self {
        let start = Instant::now();
        Self { bus: PowerCubeBus::contract_bench(start), start, now: start }
    }

    fn at(&mut self, s: f64) -> &mut Self {
        self.now = self.start + secs(s);
        self.bus.advance(self.now);
        self
    }

    fn wait(&mut self, s: f64) -> &mut Self {
        self.now += secs(s);
        self.bus.advance(self.now);
        self
    }

    fn t(&self) -> f64 {
        (self.now - self.start).as_secs_f64()
    }

    /// One CAN frame in candump form; the answers, in candump form.
    fn can(&mut self, frame: &str) -> Vec<String> {
        let mut out = Vec::new();
        self.bus.handle_can(self.now, &frame.parse().unwrap(), &mut out);
        out.iter().map(|f| f.to_string()).collect()
    }

    fn req(&mut self, m: u8, req: Request) -> Option<Response> {
        let mut out = Vec::new();
        self.bus.handle_can(self.now, &request_frame(mid(m), &req), &mut out);
        assert!(out.len() <= 1);
        out.first().map(|f| Response::decode(f.data()).unwrap())
    }

    fn set(&mut self, m: u8, param: u8, v: Value) {
        assert_eq!(self.req(m, Request::set(param, v)), Some(Response::SetAck { param }));
    }

    fn motion(&mut self, m: u8, id: u8, value: MotionValue, time_ms: Option<u16>) -> Option<Response> {
        self.req(m, Request::SetMotion(Motion { id, value, time_ms }))
    }

    fn ramp(&mut self, m: u8, pos: f32) {
        assert_eq!(self.motion(m, 4, MotionValue::Float(pos), None), Some(Response::MotionAck { motion: 4 }));
    }

    fn broadcast(&mut self, b: Broadcast) {
        let mut out = Vec::new();
        self.bus.handle_can(self.now, &b.frame(), &mut out);
        assert!(out.is_empty(), "broadcasts are never answered");
    }

    fn state(&self, m: u8) -> u32 {
        self.bus.module(m).unwrap().cube_state()
    }

    fn pos(&self, m: u8) -> f64 {
        self.bus.module(m).unwrap().position().into()
    }

    fn get(&self, m: u8, param: u8) -> Value {
        self.bus.module(m).unwrap().get(param).unwrap()
    }

    /// The exact widened value: these tests compare against f32 arithmetic.
    fn getf(&self, m: u8, param: u8) -> f64 {
        match self.get(m, param) {
            Value::Float(v) => f64::from(v),
            other => other.as_f64().unwrap(),
        }
    }

    /// Homes module `m` and waits until it is done.
    fn homed(&mut self, m: u8) -> &mut Self {
        assert_eq!(self.req(m, Request::Home), Some(Response::Simple(table::CommandId::Home)));
        self.wait(5.0);
        assert_eq!(self.state(m) & (state::HOME_OK | state::MOTION), state::HOME_OK);
        self
    }
}

fn has(s: u32, bits: u32) -> bool {
    s & bits == bits
}

#[test]
fn power_on_state_and_identity() {
    let b = Bench::new();
    assert_eq!(b.bus.modules().map(|m| m.id().get()).collect::<Vec<_>>(), [3, 5, 17]);
    assert_eq!(b.state(17), 0, "not homed, nothing moving");
    assert_eq!(b.pos(17), 0.0, "manual 12: the position after power on is the default home offset");
    assert_eq!(b.get(17, ids::DEF_CUBE_VERSION), Value::UInt16(13592));
    assert_eq!(b.get(17, ids::DEF_CUBE_SERIAL), Value::UInt32(12345));
    assert_eq!(b.get(17, ids::DEF_ADDRESS), Value::UInt8(17));
    assert_eq!(b.bus.module(17).unwrap().kind(), ModuleKind::Linear);
    let linear = |m| b.get(m, ids::CONFIG).as_f64().unwrap() as u32 & config::LINEAR != 0;
    assert!(linear(17) && !linear(3));
    assert_eq!(b.get(3, ids::DEF_CONFIG), b.get(3, ids::CONFIG));
    let setup = b.get(3, ids::SETUP).as_f64().unwrap() as u32;
    assert_ne!(setup & crate::proto::powercube::flags::setup::CAN, 0);
    assert_eq!(b.getf(3, ids::MAX_POS), f64::from(3.1f32));
    assert_eq!(b.getf(17, ids::MAX_VEL), f64::from(0.1f32));
    assert_eq!(b.getf(3, ids::ACT_F_TEMP), 35.0);
    assert_eq!(b.getf(3, ids::ACT_F_MOTOR_SUPPLY), 48.0);
    // IncRatio is consistent with the encoder and the gear.
    let inc = b.getf(3, ids::INC_RATIO);
    let expect = b.getf(3, ids::DEF_PULSES_PER_TURN) * b.getf(3, ids::DEF_GEAR_RATIO) / std::f64::consts::TAU;
    assert!((inc - expect).abs() < 0.01 * expect);
}

#[test]
fn every_parameter_answers_in_its_table_type() {
    let b = Bench::new();
    for m in [3, 17] {
        let version = b.bus.module(m).unwrap().spec().version;
        for def in table::PARAMS.iter().filter(|d| table::firmware_has(version, d.id)) {
            let v = b.bus.module(m).unwrap().get(def.id).unwrap_or_else(|| panic!("{} unanswered", def.name));
            assert_eq!(v.ty(), def.ty, "{}", def.name);
            assert_eq!(v.to_payload().len(), def.ty.size());
        }
    }
    // Ids outside the table are not answered at all.
    let mut b = Bench::new();
    assert_eq!(b.req(17, Request::GetExtended { param: 0x11 }), None);
    assert_eq!(b.req(17, Request::SetExtended { param: 0x11, data: Payload::new(&[1, 2, 3, 4]).unwrap() }), None);
}

// Manual section 8: Home to module 17 and its acknowledge.
#[test]
fn can_home_is_acknowledged_as_in_section_8() {
    let mut b = Bench::new();
    assert_eq!(b.can("0F1#01"), ["0B1#01"]);
    assert_eq!(b.can("0F1#00"), ["0B1#00"]);
    // Section 8, set acceleration / velocity and ramp, simple acknowledges.
    assert_eq!(b.can("0F1#08500000003F"), ["0B1#085064"]);
    assert_eq!(b.can("0F1#084F0AD7A33D"), ["0B1#084F64"]);
    assert_eq!(b.can("0F1#0B040000403F"), ["0B1#0B0464"]);
    // Section 8 reads, answered on 0x0B1.
    let st = b.can("0D1#0A27");
    assert_eq!(st.len(), 1);
    assert!(st[0].starts_with("0B1#0A27") && st[0].len() == "0B1#0A2700000000".len());
    assert_eq!(b.can("0D1#0A3C").len(), 1);
}

#[test]
fn foreign_and_malformed_frames_are_ignored() {
    let mut b = Bench::new();
    for f in [
        "201#2301008813000000", // Cdios command
        "181#2301008813000000", // Cdios reply
        "0B1#01",               // an acknowledge
        "0F2#01",               // no module 18
        "0F1#0A27",             // GetExtended on the put id
        "0F1#55",               // unknown command
        "0F1#",                 // empty
        "100#55",               // unknown broadcast
        "12345678#01",          // extended id
    ] {
        assert!(b.can(f).is_empty(), "{f}");
    }
    assert_eq!(b.state(17), 0);
    assert_eq!(b.state(3), 0);
}

#[test]
fn homing_takes_time_and_sets_home_ok() {
    let mut b = Bench::new();
    b.ramp(3, 0.5);
    b.wait(3.0);
    assert!(has(b.state(3), state::RAMP_END));
    let start = b.t();
    assert_eq!(b.req(3, Request::Home), Some(Response::Simple(table::CommandId::Home)));
    b.wait(0.5);
    let s = b.state(3);
    assert!(has(s, state::MOTION) && s & (state::HOME_OK | state::RAMP_END) == 0, "{s:#x}");
    let mid_pos = b.pos(3);
    assert!(mid_pos < 0.5, "moves towards the switch (negative DefHomeVel)");
    // The switch is 0.3 rad below the power-on position, that is 0.8 rad away:
    // 0.8 / 0.2 + 0.2 / 1.0 s of travel, then 0.2 s onto the edge.
    let total = 0.8 / 0.2 + 0.2 / 1.0 + 0.2;
    b.at(start + total - 0.01);
    assert!(has(b.state(3), state::MOTION));
    b.at(start + total + 0.01);
    assert_eq!(b.state(3), state::HOME_OK | state::RAMP_END, "homed, at rest, switch edge not active");
    assert_eq!(b.pos(3), 0.0, "ActPos = HomeOffset at the switch");
    // The raw counter did not jump: it reads the physical travel.
    let inc = b.getf(3, ids::INC_RATIO);
    assert!((b.getf(3, ids::POS_COUNT) - (-0.3 * inc)).abs() <= 1.0);
    assert_eq!(b.get(3, ids::REF_POS_COUNT), b.get(3, ids::POS_COUNT));
    // A second homing starts by clearing HOME_OK again.
    b.req(3, Request::Home);
    assert_eq!(b.state(3) & state::HOME_OK, 0);
}

#[test]
fn zero_move_after_homing() {
    let mut b = Bench::new();
    b.set(3, ids::HOME_OFFSET, Value::Float(0.25));
    let cfg = b.getf(3, ids::CONFIG) as u32 | config::ZERO_MOVE_AFTER_HOK;
    b.set(3, ids::CONFIG, Value::UInt32(cfg));
    b.req(3, Request::Home);
    b.wait(1.95);
    // At the edge the position reads HomeOffset, then the module ramps to 0.
    assert!(has(b.state(3), state::HOME_OK | state::MOTION));
    b.wait(3.0);
    assert!(has(b.state(3), state::HOME_OK | state::RAMP_END));
    assert_eq!(b.pos(3), 0.0);
}

#[test]
fn ramp_to_075_runs_acc_steady_dec_and_ends_there() {
    let mut b = Bench::new();
    b.homed(17);
    // Manual section 8 values: acceleration 0.5, velocity 0.08, ramp to 0.75.
    b.set(17, ids::TARGET_ACC, Value::Float(0.5));
    b.set(17, ids::TARGET_VEL, Value::Float(0.08));
    let t0 = b.t();
    b.ramp(17, 0.75);
    let v = f64::from(0.08f32);
    let duration = 0.75 / v + v / 0.5;
    let mut phases = Vec::new();
    let mut t = t0;
    while t < t0 + duration + 0.5 {
        t += 0.01;
        b.at(t);
        let s = b.state(17);
        let ph = s & (state::RAMP_ACC | state::RAMP_STEADY | state::RAMP_DEC);
        assert!(ph.count_ones() <= 1, "{s:#x}");
        assert_eq!(s & state::MOTION != 0, ph != 0 || t < t0 + duration, "{t} {s:#x}");
        if ph != 0 && phases.last() != Some(&ph) {
            phases.push(ph);
        }
    }
    assert_eq!(phases, [state::RAMP_ACC, state::RAMP_STEADY, state::RAMP_DEC]);
    assert_eq!(b.state(17), state::HOME_OK | state::RAMP_END);
    assert_eq!(b.pos(17), 0.75f32 as f64);
    assert_eq!(b.getf(17, ids::ACT_VEL), 0.0);
    // Timing of the profile: the analytic duration to the millisecond.
    let mut b = Bench::new();
    b.homed(17);
    b.set(17, ids::TARGET_ACC, Value::Float(0.5));
    b.set(17, ids::TARGET_VEL, Value::Float(0.08));
    let t0 = b.t();
    b.ramp(17, 0.75);
    b.at(t0 + 0.16 - 0.001);
    assert!(has(b.state(17), state::RAMP_ACC));
    b.at(t0 + 0.16 + 0.001);
    assert!(has(b.state(17), state::RAMP_STEADY));
    assert!((b.getf(17, ids::ACT_VEL) - v).abs() < 1e-6);
    b.at(t0 + duration - 0.16 + 0.001);
    assert!(has(b.state(17), state::RAMP_DEC));
    b.at(t0 + duration - 0.001);
    assert!(has(b.state(17), state::MOTION | state::RAMP_DEC));
    b.at(t0 + duration + 0.001);
    assert_eq!(b.state(17) & (state::MOTION | state::RAMP_END), state::RAMP_END);
}

#[test]
fn targets_are_limited() {
    let mut b = Bench::new();
    b.homed(17);
    b.set(17, ids::TARGET_VEL, Value::Float(5.0));
    assert_eq!(b.getf(17, ids::TARGET_VEL), f64::from(0.1f32), "limited to MaxVel");
    b.set(17, ids::MAX_VEL, Value::Float(7.0));
    assert_eq!(b.getf(17, ids::MAX_VEL), f64::from(0.1f32), "limited to DefMaxVel");
    b.set(17, ids::MAX_VEL, Value::Float(0.05));
    assert_eq!(b.getf(17, ids::MAX_VEL), f64::from(0.05f32));
    // A ramp beyond MaxPos ends at MaxPos, without tripping the soft limit.
    b.ramp(17, 3.0);
    b.wait(60.0);
    assert_eq!(b.state(17), state::HOME_OK | state::RAMP_END);
    assert_eq!(b.pos(17), 1.0);
    // Read-only parameters are not acknowledged, and unchanged.
    for (param, value) in [(ids::DEF_MAX_VEL, 9.0), (ids::ACT_POS, 0.3)] {
        assert_eq!(b.req(17, Request::set(param, Value::Float(value))), None, "{param:#x}");
    }
    assert_eq!(b.getf(17, ids::DEF_MAX_VEL), f64::from(0.1f32));
    assert_eq!(b.pos(17), 1.0);
    // LINEAR is hardware.
    b.set(17, ids::CONFIG, Value::UInt32(0));
    assert_ne!(b.getf(17, ids::CONFIG) as u32 & config::LINEAR, 0);
    // Tick views of the limits.
    b.set(17, ids::ACT_I_MAX_POS, Value::Int32(500_000));
    assert_eq!(b.getf(17, ids::MAX_POS), 0.5);
    assert_eq!(b.get(17, ids::ACT_I_MAX_POS), Value::Int32(500_000));
}

#[test]
fn velocity_into_the_soft_limit_stops_with_an_error() {
    let mut b = Bench::new();
    b.homed(3);
    let t0 = b.t();
    assert_eq!(b.motion(3, 7, MotionValue::Float(1.0), None), Some(Response::MotionAck { motion: 7 }));
    // 1/3 s at 3 rad/s² covers 1/6 rad, then 1 rad/s up to 3.1 rad.
    let hit = t0 + 1.0 / 3.0 + (f64::from(3.1f32) - 1.0 / 6.0);
    b.at(hit - 0.005);
    assert_eq!(b.state(3), state::HOME_OK | state::MOTION);
    b.at(hit + 0.005);
    let s = b.state(3);
    assert!(has(s, state::BEYOND_SOFT | state::ERROR | state::HALTED), "{s:#x}");
    assert_eq!(s & state::MOTION, 0);
    assert!((b.pos(3) - 3.1).abs() < 1e-5);
    b.wait(10.0);
    assert!((b.pos(3) - 3.1).abs() < 1e-5, "stays stopped");
    // Motion commands are acknowledged but refused while in error.
    b.motion(3, 7, MotionValue::Float(-0.5), None);
    b.wait(0.5);
    assert!((b.pos(3) - 3.1).abs() < 1e-5);
    assert_eq!(b.short_state(3) & short::NOT_OK, short::NOT_OK);
    b.req(3, Request::Reset);
    assert_eq!(b.state(3), state::HOME_OK);
    // Further out trips at once; back in is allowed.
    b.motion(3, 7, MotionValue::Float(0.5), None);
    b.wait(0.001);
    assert!(has(b.state(3), state::BEYOND_SOFT));
    b.req(3, Request::Reset);
    b.motion(3, 7, MotionValue::Float(-0.5), None);
    b.wait(1.0);
    assert!(b.pos(3) < 3.0);
    assert_eq!(b.state(3), state::HOME_OK | state::MOTION);
}

#[test]
fn soft_limits_only_once_homed() {
    let mut b = Bench::new();
    b.motion(3, 7, MotionValue::Float(-1.5), None);
    b.wait(5.0);
    assert!(b.pos(3) < -3.1);
    assert_eq!(b.state(3), state::MOTION);
}

impl Bench {
    fn short_state(&self, m: u8) -> u8 {
        self.bus.module(m).unwrap().short_state()
    }
}

#[test]
fn halt_and_reset() {
    let mut b = Bench::new();
    b.homed(17);
    b.ramp(17, 0.5);
    b.wait(1.0);
    assert_eq!(b.req(17, Request::Halt), Some(Response::Simple(table::CommandId::Halt)));
    let p = b.pos(17);
    assert!(p > 0.0 && p < 0.5);
    assert_eq!(b.state(17), state::HOME_OK | state::HALTED);
    assert_eq!(b.getf(17, ids::ACT_VEL), 0.0, "stops immediately");
    b.ramp(17, 0.6);
    b.wait(1.0);
    assert_eq!(b.pos(17), p, "a halted module does not move");
    b.req(17, Request::Reset);
    assert_eq!(b.state(17), state::HOME_OK, "Reset keeps HOME_OK");
    b.ramp(17, 0.6);
    b.wait(15.0);
    assert_eq!(b.pos(17), 0.6f32 as f64);
    // Broadcast halt reaches everybody.
    b.ramp(17, 0.1);
    b.motion(3, 7, MotionValue::Float(0.2), None);
    b.wait(0.5);
    b.broadcast(Broadcast::Halt);
    assert!(b.bus.modules().all(|m| m.cube_state() & state::HALTED != 0));
    b.broadcast(Broadcast::Reset);
    assert!(b.bus.modules().all(|m| m.cube_state() & (state::HALTED | state::ERROR) == 0));
}

/// `--fault overshoot=20`: after the ramp's end the module rings about its
/// target, its first swing 20 % of the step past it, in motion until the
/// ring has died out, then on the target exactly.
#[test]
fn the_overshoot_fault_rings_past_the_target_by_its_percentage() {
    let mut b = Bench::new();
    b.homed(17);
    b.bus.module_mut(17).unwrap().set_response_fault(ResponseFault { overshoot: 0.2, halt_time: 0.0 });
    let start = b.pos(17);
    b.ramp(17, 0.1);
    let (mut peak, mut t) = (f64::MIN, 0.0);
    let mut ended_in_motion = None;
    while t < 30.0 {
        t += 0.001;
        b.wait(0.001);
        peak = peak.max(b.pos(17));
        if ended_in_motion.is_none() && b.state(17) & state::MOTION == 0 {
            ended_in_motion = Some(t);
        }
    }
    let step = 0.1f32 as f64 - start;
    let overshoot = (peak - 0.1f32 as f64) / step;
    assert!((overshoot - 0.2).abs() < 1e-3, "overshoot {overshoot}");
    assert_eq!(b.pos(17), 0.1f32 as f64, "at rest on the target");
    assert_eq!(b.state(17) & (state::MOTION | state::RAMP_END), state::RAMP_END);
    // Without the fault the same ramp never passes its target.
    let mut b = Bench::new();
    b.homed(17);
    b.ramp(17, 0.1);
    let mut peak = f64::MIN;
    for _ in 0..30_000 {
        b.wait(0.001);
        peak = peak.max(b.pos(17));
    }
    assert!(peak <= 0.1f32 as f64, "{peak}");
}

/// `--fault slow-halt=300ms`: a moving module told to Halt brakes to rest
/// in 300 ms, in motion until then; a module at rest halts at once.
#[test]
fn the_slow_halt_fault_brakes_over_its_time() {
    let mut b = Bench::new();
    b.homed(17);
    b.bus.module_mut(17).unwrap().set_response_fault(ResponseFault { overshoot: 0.0, halt_time: 0.3 });
    b.ramp(17, 0.5);
    b.wait(1.0);
    let v = b.getf(17, ids::ACT_VEL);
    assert!(v > 0.0);
    b.req(17, Request::Halt);
    let p = b.pos(17);
    b.wait(0.299);
    assert!(has(b.state(17), state::MOTION | state::HALTED), "{:#x}", b.state(17));
    b.wait(0.002);
    assert_eq!(b.state(17) & state::MOTION, 0);
    assert_eq!(b.getf(17, ids::ACT_VEL), 0.0);
    // Constant deceleration: half the speed times the braking time.
    assert!((b.pos(17) - p - v * 0.3 / 2.0).abs() < 1e-5, "{} from {p}", b.pos(17));
    b.ramp(17, 0.6);
    b.wait(1.0);
    assert_eq!(b.state(17) & state::MOTION, 0, "halted: no motion until a Reset");
    b.req(17, Request::Halt);
    assert_eq!(b.state(17) & state::MOTION, 0, "at rest: halted at once");
}

#[test]
fn steps_buffer_one_command() {
    let mut b = Bench::new();
    b.homed(3);
    let t0 = b.t();
    b.motion(3, 6, MotionValue::Float(0.1), Some(200));
    assert_eq!(b.state(3) & (state::INPROGRESS | state::FULLBUFFER | state::MOTION), state::INPROGRESS | state::MOTION);
    b.at(t0 + 0.1);
    assert!((b.pos(3) - 0.05).abs() < 1e-6, "constant speed: halfway at half time");
    b.motion(3, 6, MotionValue::Float(0.2), Some(100));
    assert!(has(b.state(3), state::INPROGRESS | state::FULLBUFFER));
    assert_eq!(b.bus.module(3).unwrap().short_state() & short::FULLBUFFER, short::FULLBUFFER);
    b.at(t0 + 0.25);
    let s = b.state(3);
    assert_eq!(s & (state::INPROGRESS | state::FULLBUFFER), state::INPROGRESS, "{s:#x}");
    assert!((b.pos(3) - 0.15).abs() < 1e-5, "{}", b.pos(3));
    b.at(t0 + 0.301);
    assert_eq!(b.state(3) & (state::INPROGRESS | state::MOTION), 0);
    assert!((b.pos(3) - 0.2).abs() < 1e-6);
    // SetIStep (0x0d) is a step in ticks, with a one-byte acknowledge.
    let inc = b.getf(3, ids::INC_RATIO);
    let ticks = (0.3 * inc).round() as i32;
    assert_eq!(
        b.req(3, Request::SetIStep { target: ticks, time_ms: 100 }),
        Some(Response::Simple(table::CommandId::SetIStep))
    );
    assert_eq!(b.get(3, ids::STEP_INC), Value::Int32(ticks));
    b.wait(0.11);
    assert_eq!(b.get(3, ids::ACT_I_POS), Value::Int32(ticks));
    // A step faster than MaxVel takes longer than asked.
    b.motion(3, 6, MotionValue::Float(1.8), Some(10));
    b.wait(0.5);
    assert!(has(b.state(3), state::INPROGRESS));
    b.wait(0.6);
    assert_eq!(b.state(3) & state::INPROGRESS, 0);
}

#[test]
fn current_mode() {
    let mut b = Bench::new();
    assert_eq!(b.motion(5, 8, MotionValue::Float(10.0), None), Some(Response::MotionAck { motion: 8 }));
    assert!(has(b.state(5), state::CURLIMIT | state::MOTION), "limited to the nominal current");
    assert_eq!(b.getf(5, ids::CUR), 2.5);
    assert_eq!(b.get(5, ids::RAW_CUR), Value::Int16(250));
    b.wait(2.0);
    assert!((b.getf(5, ids::ACT_VEL) - 1.5 * 2.5 / 5.0).abs() < 1e-6);
    b.req(5, Request::Reset);
    assert_eq!(b.state(5) & state::CURLIMIT, 0, "Reset clears the warning");
    // ICUR in digits, with full current allowed.
    let cfg = b.getf(5, ids::CONFIG) as u32 | config::ALLOW_FULL_CUR;
    b.set(5, ids::CONFIG, Value::UInt32(cfg));
    b.motion(5, 13, MotionValue::Int16(-400), None);
    assert_eq!(b.getf(5, ids::CUR), f64::from(-4.0f32));
    assert_eq!(b.state(5) & state::CURLIMIT, 0);
}

#[test]
fn watchdog_trips_after_50ms_without_refresh() {
    let mut b = Bench::new();
    b.homed(3);
    let cfg = b.getf(3, ids::CONFIG) as u32 | config::WATCHDOG_ENABLE;
    b.set(3, ids::CONFIG, Value::UInt32(cfg));
    assert_eq!(b.can("0E3#07"), ["0A3#07"]);
    b.motion(3, 7, MotionValue::Float(0.1), None);
    for _ in 0..50 {
        b.wait(0.04);
        b.broadcast(Broadcast::WatchdogRefresh);
        assert_eq!(b.state(3) & state::ERROR, 0);
    }
    let last = b.t();
    b.at(last + 0.049);
    assert_eq!(b.state(3), state::HOME_OK | state::MOTION);
    b.at(last + 0.060);
    let s = b.state(3);
    assert!(has(s, state::COMM_ERROR | state::ERROR | state::HALTED), "{s:#x}");
    let p_trip = b.pos(3);
    b.at(last + 1.0);
    assert_eq!(b.pos(3), p_trip);
    // The other modules have no watchdog.
    assert_eq!(b.state(5) & state::ERROR, 0);
    // Recovery 1 (manual 13): Reset alone does not help while refreshes are missing...
    b.req(3, Request::Reset);
    assert!(has(b.state(3), state::COMM_ERROR | state::HALTED));
    // ... refreshing again and resetting does.
    b.broadcast(Broadcast::WatchdogRefresh);
    b.broadcast(Broadcast::Reset);
    assert_eq!(b.state(3), state::HOME_OK);
    // Recovery 2: switch it offline and reset.
    b.wait(0.2);
    assert!(has(b.state(3), state::COMM_ERROR));
    b.can("0E3#07");
    b.req(3, Request::Reset);
    assert_eq!(b.state(3), state::HOME_OK);
    b.wait(1.0);
    assert_eq!(b.state(3), state::HOME_OK, "offline: no more trips");
}

#[test]
fn watchdog_trip_time_is_exact_whatever_the_call_spacing() {
    // Velocity 0.1 rad/s from rest at 3 rad/s²: after the trip at 50 ms the
    // module stands where the profile was at 50 ms.
    let mut b = Bench::new();
    let cfg = b.getf(3, ids::CONFIG) as u32 | config::WATCHDOG_ENABLE;
    b.set(3, ids::CONFIG, Value::UInt32(cfg));
    let t0 = b.t();
    b.can("0E3#07");
    b.motion(3, 7, MotionValue::Float(0.1), None);
    b.at(t0 + 10.0);
    let acc_t = 0.1 / 3.0;
    let expect = 0.5 * 3.0 * acc_t * acc_t + 0.1 * (0.05 - acc_t);
    assert!((b.pos(3) - expect).abs() < 1e-7, "{} vs {expect}", b.pos(3));
    assert!(has(b.state(3), state::COMM_ERROR));
    // Without WATCHDOG_ENABLE the 0x07 command changes nothing.
    let mut b = Bench::new();
    b.can("0E3#07");
    b.wait(1.0);
    assert_eq!(b.state(3), 0);
}

#[test]
fn disable_ack_silences_all_but_get_on_can() {
    let mut b = Bench::new();
    let cfg = b.getf(17, ids::CONFIG) as u32 | config::DISABLE_ACK;
    assert!(b.req(17, Request::set(ids::CONFIG, Value::UInt32(cfg))).is_none(), "already silent for its own ack");
    assert!(b.can("0F1#01").is_empty());
    assert!(b.can("0F1#0B040000403F").is_empty());
    assert_eq!(b.can("0D1#0A1D"), ["0B1#0A1D1835"]);
    assert!(has(b.state(17), state::MOTION), "the silent Home still ran");
    // RS232 is not affected.
    let mut out = Vec::new();
    b.bus.handle_rs232(b.now, &[0x02, 0x06, 0x21, 0x00, 0x27, 0x03], &mut out);
    assert_eq!(out, [0x02, 0x0a, 0x21, 0x00, 0x2b, 0x03]);
}

#[test]
fn sync_motion_waits_for_start_motion() {
    let mut b = Bench::new();
    b.homed(17);
    b.homed(3);
    for m in [3, 17] {
        let cfg = b.getf(m, ids::CONFIG) as u32 | config::SYNC_MOTION;
        b.set(m, ids::CONFIG, Value::UInt32(cfg));
    }
    b.ramp(17, 0.2);
    b.ramp(3, 0.4);
    b.ramp(3, 0.3); // the last command counts
    b.wait(1.0);
    assert_eq!(b.pos(17), 0.0);
    assert_eq!(b.state(17) & state::MOTION, 0);
    assert_eq!(b.can("100#0F00"), Vec::<String>::new());
    assert!(has(b.state(17), state::MOTION) && has(b.state(3), state::MOTION));
    b.wait(10.0);
    assert_eq!(b.pos(17), 0.2f32 as f64);
    assert_eq!(b.pos(3), 0.3f32 as f64);
    // Nothing pending: StartMotion does nothing.
    b.broadcast(Broadcast::StartMotion);
    assert_eq!(b.state(3) & state::MOTION, 0);
}

// Manual section 8: the extended acknowledge example `0B 0E actPos(0.75) 20 11`:
// module at 0.75 after a ramp (RAMP_END, short 0x20), input 0 and output 0 set.
#[test]
fn extended_ack_reproduces_section_8() {
    let mut b = Bench::new();
    b.homed(17);
    b.ramp(17, 0.75);
    b.wait(20.0);
    b.bus.module_mut(17).unwrap().set_inputs(0x01);
    b.set(17, ids::DIO_SETUP, Value::UInt32(0x10));
    assert_eq!(b.get(17, ids::DIO_SETUP), Value::UInt32(0x11));
    // A ramp to where it stands: nothing to move, RAMP_END stays.
    assert_eq!(b.can("0F1#0B0E0000403F"), ["0B1#0B0E0000403F2011"]);
}

#[test]
fn extended_ack_contents() {
    let mut b = Bench::new();
    b.homed(17);
    b.bus.module_mut(17).unwrap().set_inputs(0x0a);
    b.set(17, ids::DIO_SETUP, Value::UInt32(0x50));
    b.set(17, ids::TARGET_VEL, Value::Float(0.1));
    b.wait(0.0);
    // FRAMP_ACK: float position when the command arrived, state after it.
    let r = b.motion(17, 14, MotionValue::Float(0.5), None);
    assert_eq!(
        r,
        Some(Response::MotionAckExt { motion: 14, pos: 0.0f32.to_le_bytes(), short_state: short::MOTION, dio: 0x5a })
    );
    b.wait(1.0);
    let p = b.bus.module(17).unwrap().position();
    let ticks = match b.get(17, ids::ACT_I_POS) {
        Value::Int32(t) => t,
        v => panic!("{v:?}"),
    };
    // IRAMP_ACK: int32 ticks; the new ramp re-plans from the moving state.
    let r = b.motion(17, 19, MotionValue::Int32(0), None).unwrap();
    let Response::MotionAckExt { motion: 19, pos, short_state, dio: 0x5a } = r else { panic!("{r:?}") };
    assert_eq!(i32::from_le_bytes(pos), ticks);
    assert!((f64::from(ticks) / 1e6 - f64::from(p)).abs() < 1e-6);
    assert_eq!(short_state, short::MOTION);
    // Refused (halted): NOT_OK shows it.
    b.req(17, Request::Halt);
    let Some(Response::MotionAckExt { short_state, .. }) = b.motion(17, 17, MotionValue::Float(0.01), None) else {
        panic!()
    };
    assert_eq!(short_state, short::NOT_OK);
    // Before homing NOT_OK is set as well.
    let mut b = Bench::new();
    let Some(Response::MotionAckExt { short_state, .. }) = b.motion(3, 16, MotionValue::Float(0.01), Some(100)) else {
        panic!()
    };
    assert_eq!(short_state, short::NOT_OK | short::MOTION | short::INPROGRESS);
}

#[test]
fn m3_compatible_modules_need_homing() {
    let mut b = Bench::new();
    let cfg = b.getf(5, ids::CONFIG) as u32 | config::M3_COMPATIBLE;
    b.set(5, ids::CONFIG, Value::UInt32(cfg));
    b.ramp(5, 0.5);
    b.wait(2.0);
    assert_eq!(b.pos(5), 0.0);
    b.homed(5);
    b.ramp(5, 0.5);
    b.wait(2.0);
    assert_eq!(b.pos(5), 0.5);
}

#[test]
fn brake_engages_on_halt_and_releases_on_motion() {
    let mut b = Bench::new();
    let cfg = b.getf(5, ids::CONFIG) as u32 | config::BRAKE_PRESENT;
    b.set(5, ids::CONFIG, Value::UInt32(cfg));
    assert_eq!(b.state(5) & state::BRAKEACTIVE, 0);
    b.ramp(5, 0.5);
    b.wait(0.3);
    b.req(5, Request::Halt);
    assert!(has(b.state(5), state::BRAKEACTIVE | state::HALTED));
    b.req(5, Request::Reset);
    assert!(has(b.state(5), state::BRAKEACTIVE), "stays on until the next motion");
    b.ramp(5, 0.5);
    assert_eq!(b.state(5) & state::BRAKEACTIVE, 0);
}

#[test]
fn injected_faults_and_what_reset_clears() {
    let mut b = Bench::new();
    b.homed(3);
    b.ramp(3, 1.0);
    b.wait(0.2);
    b.bus.module_mut(3).unwrap().inject_error(state::POW_FET_TEMP);
    let s = b.state(3);
    assert!(has(s, state::POW_FET_TEMP | state::POWERFAULT | state::ERROR | state::HALTED), "{s:#x}");
    assert_eq!(s & state::MOTION, 0);
    b.req(3, Request::Reset);
    assert!(has(b.state(3), state::POW_FET_TEMP | state::ERROR | state::HALTED), "power off needed");
    // A voltage dip clears with its POWERFAULT.
    b.bus.module_mut(5).unwrap().inject_error(state::POW_VOLT_ERR);
    assert!(has(b.state(5), state::POWERFAULT | state::ERROR));
    b.req(5, Request::Reset);
    assert_eq!(b.state(5), 0);
    // Bit 27 is POW_SETUP_ERR on 3.5.18 (module 17: not resettable),
    // LOGIC_VOLT on others.
    b.bus.module_mut(17).unwrap().inject_error(state::LOGIC_VOLT);
    b.req(17, Request::Reset);
    assert!(has(b.state(17), state::LOGIC_VOLT | state::ERROR));
    b.bus.module_mut(5).unwrap().inject_error(state::LOGIC_VOLT);
    b.req(5, Request::Reset);
    assert_eq!(b.state(5), 0);
    let t = Instant::now();
    let mut newer = Module::new(ModuleSpec { version: 0x3520, ..ModuleSpec::new(mid(9), ModuleKind::Rotary) }, t);
    newer.inject_error(state::LOGIC_VOLT | state::TOW_ERROR);
    assert!(has(newer.cube_state(), state::LOGIC_VOLT | state::TOW_ERROR | state::HALTED));
    newer.handle(t, &Request::Reset);
    assert_eq!(newer.cube_state(), 0);
    // Non-error bits are not injectable.
    newer.inject_error(state::HOME_OK | state::MOTION);
    assert_eq!(newer.cube_state(), 0);
}

#[test]
fn save_pos_and_time_stamps() {
    let mut b = Bench::new();
    b.homed(3);
    b.ramp(3, 0.5);
    b.wait(0.4);
    b.broadcast(Broadcast::SavePos);
    let saved = b.getf(3, ids::ACT_F_SAVED_POS);
    assert_eq!(saved, b.pos(3));
    assert!(saved > 0.0);
    b.wait(0.5);
    assert_eq!(b.getf(3, ids::ACT_F_SAVED_POS), saved);
    assert_eq!(b.req(3, Request::ResetTime), Some(Response::Simple(table::CommandId::ResetTime)));
    b.wait(0.25);
    let Value::FloatTime { position, time_ms } = b.get(3, ids::ACT_F_POS_TIME) else { panic!() };
    assert_eq!(time_ms, 250);
    assert_eq!(position, b.bus.module(3).unwrap().position());
    let Value::FloatStateDio { position, short_state, dio } = b.get(3, ids::ACT_F_POS_STATE_DIO) else { panic!() };
    assert_eq!(position, b.bus.module(3).unwrap().position());
    assert_eq!(short_state, b.short_state(3));
    assert_eq!(dio, 0);
}

#[test]
fn loops_keep_moving() {
    let mut b = Bench::new();
    b.homed(3);
    b.set(3, ids::TARGET_VEL, Value::Float(1.0));
    b.set(3, ids::TARGET_ACC, Value::Float(2.0));
    b.motion(3, 25, MotionValue::Float(1.0), None);
    // One leg: 1 s cruise... d = 1, v = 1, a = 2: 1 + 0.5 = 1.5 s.
    b.wait(1.5);
    assert!((b.pos(3) - 1.0).abs() < 1e-6);
    b.wait(1.5);
    assert!(b.pos(3).abs() < 1e-6, "and back");
    b.wait(30.75);
    assert!((b.pos(3) - 0.5).abs() < 1e-6, "{}", b.pos(3));
    assert!(has(b.state(3), state::MOTION | state::RAMP_STEADY));
    b.req(3, Request::Halt);
    b.req(3, Request::Reset);
    // FCOSLOOP to 0.2 with a 1 s half period, from 0.5.
    b.motion(3, 24, MotionValue::Float(0.2), Some(1000));
    b.wait(1.0);
    assert!((b.pos(3) - 0.2).abs() < 1e-6);
    b.wait(1.0);
    assert!((b.pos(3) - 0.5).abs() < 1e-6);
    assert!(has(b.state(3), state::MOTION));
}

#[test]
fn call_spacing_does_not_change_the_result() {
    let script = |steps: u32| {
        let mut b = Bench::new();
        b.homed(17);
        b.ramp(17, 0.6);
        let dt = 3.0 / f64::from(steps);
        for _ in 0..steps {
            b.wait(dt);
        }
        b.ramp(17, 0.1);
        for _ in 0..steps {
            b.wait(dt);
        }
        (b.getf(17, ids::ACT_POS), b.getf(17, ids::ACT_VEL), b.state(17))
    };
    let (p1, v1, s1) = script(1);
    let (p2, v2, s2) = script(997);
    assert!((p1 - p2).abs() < 1e-6 && (v1 - v2).abs() < 1e-6, "{p1} {p2} {v1} {v2}");
    assert_eq!(s1, s2);
}

#[test]
fn time_does_not_run_backwards() {
    let mut b = Bench::new();
    b.ramp(3, 0.5);
    b.wait(0.3);
    let p = b.pos(3);
    b.bus.advance(b.start);
    assert_eq!(b.pos(3), p);
}

fn rs232(b: &mut Bench, bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    b.bus.handle_rs232(b.now, bytes, &mut out);
    out
}

// Manual section 9, module 17.
#[test]
fn rs232_section_9_frames() {
    let mut b = Bench::new();
    // Home, fed one byte at a time: the answer comes with the last byte.
    let home = [0x02, 0x06, 0x21, 0x01, 0x28, 0x03];
    for (i, byte) in home.iter().enumerate() {
        let out = rs232(&mut b, &[*byte]);
        if i + 1 < home.len() {
            assert!(out.is_empty());
        } else {
            assert_eq!(out, [0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03]);
        }
    }
    assert!(has(b.state(17), state::MOTION));
    assert_eq!(rs232(&mut b, &[0x02, 0x06, 0x21, 0x00, 0x27, 0x03]), [0x02, 0x0a, 0x21, 0x00, 0x2b, 0x03]);
    // Set acceleration 0.5 / velocity 0.08 and ramp to 0.75: real modules
    // answer with the length actually sent, 3 (specs README).
    let answers = rs232(
        &mut b,
        &[
            0x02, 0x06, 0x26, 0x08, 0x50, 0x00, 0x00, 0x00, 0x3f, 0xc3, 0x03, //
            0x02, 0x06, 0x26, 0x08, 0x4f, 0x0a, 0xd7, 0xa3, 0x3d, 0x46, 0x03, //
            0x02, 0x06, 0x26, 0x0b, 0x04, 0x00, 0x00, 0x40, 0x3f, 0xba, 0x03,
        ],
    );
    let mut d = Decoder::new();
    d.push(&answers);
    let frames: Vec<_> = std::iter::from_fn(|| d.next_frame()).map(Result::unwrap).collect();
    let payloads: Vec<&[u8]> = frames.iter().map(|f| f.payload.as_slice()).collect();
    assert_eq!(payloads, [&[0x08, 0x50, 0x64][..], &[0x08, 0x4f, 0x64], &[0x0b, 0x04, 0x64]]);
    assert!(frames.iter().all(|f| f.module == 17 && f.declared_len == 3 && f.dir == Direction::FromModule));
    assert_eq!(b.getf(17, ids::TARGET_ACC), 0.5);
    assert_eq!(b.getf(17, ids::TARGET_VEL), f64::from(0.08f32));
    // Halt with DLE escaping of the command byte; the answer is escaped too.
    assert_eq!(rs232(&mut b, &[0x02, 0x06, 0x21, 0x10, 0x82, 0x29, 0x03]), [0x02, 0x0a, 0x21, 0x10, 0x82, 0x2d, 0x03]);
    assert!(has(b.state(17), state::HALTED));
    // The Setup word now names RS232.
    let setup = b.getf(17, ids::SETUP) as u32;
    assert_ne!(setup & crate::proto::powercube::flags::setup::RS232, 0);
}

#[test]
fn rs232_broadcasts_and_odd_frames() {
    let mut b = Bench::new();
    // Address 0 is a broadcast: Home to all, no answer.
    let mut home_all = Vec::new();
    rs232::encode(Direction::ToModule, 0, &[0x01], &mut home_all);
    assert!(rs232(&mut b, &home_all).is_empty());
    assert!(b.bus.modules().all(|m| m.cube_state() & state::MOTION != 0));
    // TELID length disagreeing with the data: not interpreted (manual 4.3).
    let mut bad_len = vec![0x02, 0x06, 0x22, 0x02];
    let bcc = rs232::bcc(&bad_len[1..]);
    bad_len.extend([bcc, 0x03]);
    assert!(rs232(&mut b, &bad_len).is_empty());
    assert!(!has(b.state(17), state::HALTED));
    // Frames from a module, garbage, unknown modules and a bad BCC: no answer.
    assert!(rs232(&mut b, &[0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03]).is_empty());
    assert!(rs232(&mut b, &[0x55, 0xff, 0x03, 0x10]).is_empty());
    assert!(rs232(&mut b, &[0x02, 0x06, 0x41, 0x01, 0x48, 0x03]).is_empty());
    assert!(rs232(&mut b, &[0x02, 0x06, 0x21, 0x01, 0x29, 0x03]).is_empty());
    // and the stream recovers.
    assert_eq!(rs232(&mut b, &[0x02, 0x06, 0x21, 0x00, 0x27, 0x03]), [0x02, 0x0a, 0x21, 0x00, 0x2b, 0x03]);
}

#[test]
fn writable_parameters_read_back() {
    let mut b = Bench::new();
    b.homed(3);
    for def in table::PARAMS.iter().filter(|d| d.access.writable()) {
        let before = b.get(3, def.id);
        // Writing back what was read changes nothing observable.
        b.set(3, def.id, before);
        let after = b.get(3, def.id);
        if ![ids::CUBE_STATE].contains(&def.id) {
            assert_eq!(before, after, "{}", def.name);
        }
    }
    b.set(3, ids::ACT_C0, Value::Int16(40));
    assert_eq!(b.get(3, ids::ACT_C0), Value::Int16(40));
    b.set(3, ids::ACT_MAX_TEMP, Value::Float(60.0));
    assert_eq!(b.get(3, ids::ACT_MAX_TEMP), Value::Float(60.0));
    b.set(3, ids::MIN_POS, Value::Float(-1.0));
    assert_eq!(b.get(3, ids::ACT_I_MIN_POS), Value::Int32(-b.get(3, ids::INC_RATIO).as_f64().unwrap().round() as i32));
    b.set(3, ids::TARGET_POS_INC, Value::Int32(-1000));
    assert_eq!(b.get(3, ids::TARGET_POS_INC), Value::Int32(-1000));
    // Wrong data length: acknowledged, ignored.
    assert_eq!(
        b.req(3, Request::SetExtended { param: ids::MAX_VEL, data: Payload::new(&[0, 0]).unwrap() }),
        Some(Response::SetAck { param: ids::MAX_VEL })
    );
    assert_eq!(b.getf(3, ids::MAX_VEL), 1.5);
    // NaN is ignored.
    b.set(3, ids::MAX_VEL, Value::Float(f32::NAN));
    assert_eq!(b.getf(3, ids::MAX_VEL), 1.5);
}

fn arb_request() -> impl Strategy<Value = Request> {
    let motion = (
        prop::sample::select(table::MOTIONS.iter().map(|m| m.id).collect::<Vec<_>>()),
        any::<f32>(),
        any::<i32>(),
        any::<u16>(),
    )
        .prop_map(|(id, f, i, t)| {
            let def = table::motion(id).unwrap();
            let value = match def.arg {
                table::MotionArg::Float => MotionValue::Float(if f.is_finite() { f % 5.0 } else { f }),
                table::MotionArg::Int32 => MotionValue::Int32(i),
                table::MotionArg::Int16 => MotionValue::Int16(i as i16),
            };
            Request::SetMotion(Motion { id, value, time_ms: def.timed.then_some(t % 3000) })
        });
    prop_oneof![
        Just(Request::Reset),
        Just(Request::Home),
        Just(Request::Halt),
        Just(Request::Watchdog),
        Just(Request::ResetTime),
        any::<u8>().prop_map(|param| Request::GetExtended { param }),
        (any::<u8>(), prop::collection::vec(any::<u8>(), 1..=6))
            .prop_map(|(param, d)| Request::SetExtended { param, data: Payload::new(&d).unwrap() }),
        motion.clone(),
        motion,
        (any::<i32>(), any::<u16>()).prop_map(|(target, time_ms)| Request::SetIStep { target, time_ms }),
    ]
}

proptest! {
    #[test]
    fn random_can_frames_never_panic(frames in prop::collection::vec(
        (0u32..0x800, prop::collection::vec(any::<u8>(), 0..=8), 0u64..2_000_000), 0..60)) {
        let mut b = Bench::new();
        let mut out = Vec::new();
        for (id, data, dt_us) in frames {
            b.now += Duration::from_micros(dt_us);
            b.bus.handle_can(b.now, &CanFrame::new(id, &data).unwrap(), &mut out);
        }
        for m in b.bus.modules() {
            prop_assert!(m.position().is_finite());
            for def in table::PARAMS.iter().filter(|d| table::firmware_has(m.spec().version, d.id)) {
                prop_assert!(m.get(def.id).is_some());
            }
        }
    }

    #[test]
    fn random_rs232_bytes_never_panic(chunks in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..40), 0..30)) {
        let mut b = Bench::new();
        let mut out = Vec::new();
        for c in chunks {
            b.now += Duration::from_millis(7);
            b.bus.handle_rs232(b.now, &c, &mut out);
        }
        let mut d = Decoder::new();
        d.push(&out);
        while let Some(f) = d.next_frame() {
            prop_assert!(f.is_ok(), "answers are well formed");
        }
    }

    #[test]
    fn random_commands_keep_the_module_consistent(
        reqs in prop::collection::vec((arb_request(), 0u64..3_000_000, any::<bool>()), 1..80)) {
        let t = Instant::now();
        let mut m = Module::new(ModuleSpec::new(mid(3), ModuleKind::Rotary), t);
        let mut now = t;
        let mut max_vel = 1.5f64;
        for (req, dt_us, as_broadcast) in reqs {
            now += Duration::from_micros(dt_us);
            if as_broadcast {
                m.broadcast(now, Broadcast::WatchdogRefresh);
            }
            if let Some(resp) = m.handle(now, &req) {
                prop_assert!(req.matches(&resp), "{req:?} answered by {resp:?}");
            }
            max_vel = max_vel.max(m.get(ids::MAX_VEL).unwrap().as_f64().unwrap());
            let s = m.cube_state();
            prop_assert!(m.position().is_finite());
            prop_assert!(f64::from(m.velocity().abs()) <= max_vel * 1.0001 + 1e-6, "{} > {max_vel}", m.velocity());
            if s & state::HALTED != 0 {
                prop_assert_eq!(s & state::MOTION, 0);
            }
            if s & state::ERROR != 0 {
                prop_assert_ne!(s & state::HALTED, 0);
            }
        }
    }
}

proptest! {
    // Lazy event handling is exact: polling in between changes nothing.
    #[test]
    fn extra_advance_calls_change_nothing(
        reqs in prop::collection::vec((arb_request(), 0u64..2_000_000, 1u32..20), 1..40)) {
        let t = Instant::now();
        let spec = ModuleSpec::new(mid(17), ModuleKind::Linear);
        let (mut lazy, mut polled) = (Module::new(spec, t), Module::new(spec, t));
        let mut now = t;
        for (req, dt_us, polls) in reqs {
            for i in 1..polls {
                polled.advance(now + Duration::from_micros(dt_us * u64::from(i) / u64::from(polls)));
            }
            now += Duration::from_micros(dt_us);
            let a = lazy.handle(now, &req);
            let b = polled.handle(now, &req);
            prop_assert_eq!(a, b);
            prop_assert_eq!(lazy.cube_state(), polled.cube_state());
            prop_assert!((lazy.position() - polled.position()).abs() <= 1e-5, "{} {}", lazy.position(), polled.position());
        }
    }
}

/// The vendor library's (libm5api's) exact RS232 frames, where it and the
/// manual differ.
mod vendor_library {
    use super::*;

    fn answer(module: u8, resp: Response) -> Vec<u8> {
        let mut out = Vec::new();
        rs232::encode_response(module, &resp, &mut out);
        out
    }

    #[test]
    fn halt_all_of_two_bytes_and_of_one_halt_every_module() {
        for frame in
            [&[0x02, 0x04, 0x10, 0x82, 0x10, 0x82, 0x00, 0x08, 0x03][..], &[0x02, 0x04, 0x01, 0x10, 0x82, 0x07, 0x03]]
        {
            let mut b = Bench::new();
            assert!(rs232(&mut b, frame).is_empty(), "broadcasts are never answered");
            assert!(b.bus.modules().all(|m| m.cube_state() & state::HALTED != 0), "{frame:02x?}");
        }
    }

    #[test]
    fn homing_ends_with_home_ok_and_ramp_end() {
        let mut b = Bench::new();
        // Home module 3: 02 04 61 01 bcc 03.
        let mut home = Vec::new();
        rs232::encode(Direction::ToModule, 3, &[0x01], &mut home);
        assert_eq!(rs232(&mut b, &home), answer(3, Response::Simple(table::CommandId::Home)));
        b.wait(0.5);
        assert_eq!(b.state(3) & (state::HOME_OK | state::RAMP_END), 0, "neither while homing");
        b.wait(10.0);
        assert!(has(b.state(3), state::HOME_OK | state::RAMP_END), "{:#x}", b.state(3));
    }

    #[test]
    fn current_in_digits_as_the_librarys_int32() {
        let mut b = Bench::new();
        let sent = [0x02, 0x04, 0x66, 0x0b, 0x0d, 0x9c, 0xff, 0xff, 0xff, 0x1f, 0x03];
        assert_eq!(rs232(&mut b, &sent), answer(3, Response::MotionAck { motion: 13 }));
        b.wait(0.01);
        let cur = b.getf(3, ids::CUR);
        assert!((cur + 100.0 * b.bus.module(3).unwrap().defaults().cur_ratio).abs() < 1e-6, "-100 digits: {cur}");
        // The manual's Int16 still works.
        let mut b = Bench::new();
        let mut narrow = Vec::new();
        rs232::encode(Direction::ToModule, 3, &[0x0b, 0x0d, 0x9c, 0xff], &mut narrow);
        assert_eq!(rs232(&mut b, &narrow), answer(3, Response::MotionAck { motion: 13 }));
        assert!(has(b.state(3), state::MOTION));
    }

    #[test]
    fn firmware_version_matches_the_measurements_it_answers() {
        let mut b = Bench::new();
        let get = |m: u8, p: u8| {
            let mut out = Vec::new();
            rs232::encode_request(m, &Request::GetExtended { param: p }, &mut out);
            out
        };
        assert_eq!(b.get(3, ids::DEF_CUBE_VERSION), Value::UInt16(table::MEASUREMENTS_SINCE));
        for p in [ids::ACT_F_TEMP, ids::ACT_F_MOTOR_SUPPLY, ids::ACT_F_LOGIC_SUPPLY] {
            assert!(!rs232(&mut b, &get(3, p)).is_empty(), "4.6.01 answers {p:#x}");
            assert!(rs232(&mut b, &get(17, p)).is_empty(), "3.5.18 does not answer {p:#x}");
        }
        assert_eq!(b.get(17, ids::DEF_CUBE_VERSION), Value::UInt16(LEGACY_VERSION));
        assert!(!rs232(&mut b, &get(17, ids::ACT_POS)).is_empty());
    }

    thread_local! {
        static TRACED: std::cell::RefCell<Vec<String>> = const { std::cell::RefCell::new(Vec::new()) };
    }

    #[test]
    fn the_trace_says_why_a_frame_goes_unanswered() {
        let mut b = Bench::new();
        b.bus.set_tracer(Some(|s| TRACED.with(|t| t.borrow_mut().push(s.to_string()))));
        let mut save = Vec::new();
        rs232::encode(Direction::ToModule, 3, &[0x10], &mut save);
        assert!(rs232(&mut b, &save).is_empty());
        assert!(b.can("0E3#10").is_empty());
        assert!(b.can(&format!("0D1#0A{:02X}", ids::ACT_F_TEMP)).is_empty());
        assert!(!b.can("0C3#0A27").is_empty());
        assert!(b.can(&format!("0E3#08{:02X}00000000", ids::ACT_POS)).is_empty());
        let mut traced = TRACED.with(|t| t.take());
        let read_only = traced.pop().unwrap_or_default();
        assert!(
            read_only.starts_with("module 3: SetExtended ActPos")
                && read_only.ends_with("not answered (ActPos is read-only)"),
            "{read_only}"
        );
        assert_eq!(
            traced,
            [
                "module 3: [10] not answered: unknown command id 0x10",
                "module 3: [10] not answered: unknown command id 0x10",
                "module 17: GetExtended ActFTemp not answered (firmware 3.5.18 has no ActFTemp)",
            ]
        );
    }

    #[test]
    fn padded_get_extended_is_answered_and_save_parameters_is_not() {
        let mut b = Bench::new();
        let mut padded = Vec::new();
        rs232::encode(Direction::ToModule, 3, &[0x0a, ids::DEF_A0, 0, 0, 0, 0, 0, 0], &mut padded);
        let want = Response::Get { param: ids::DEF_A0, data: b.get(3, ids::DEF_A0).to_payload() };
        assert_eq!(rs232(&mut b, &padded), answer(3, want));
        let mut save = Vec::new();
        rs232::encode(Direction::ToModule, 3, &[0x10], &mut save);
        assert!(rs232(&mut b, &save).is_empty());
        // and the line goes on.
        assert!(!rs232(&mut b, &padded).is_empty());
    }
}
