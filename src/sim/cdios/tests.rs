//! Cdios node tests on virtual time. Frames are the manual's byte tables
//! (section per command code) on the README's ids: commands to 0x201,
//! answers from 0x181, NMT on 0.

use std::time::{Duration, Instant};

use super::*;
use crate::proto::CanFrame;

fn f(s: &str) -> CanFrame {
    s.parse().unwrap()
}

struct Rig {
    node: CdiosNode,
    now: Instant,
}

impl Rig {
    fn new() -> Self {
        let now = Instant::now();
        Self { node: CdiosNode::contract(now), now }
    }

    fn started() -> Self {
        let mut r = Self::new();
        assert!(r.send("000#0101").is_empty(), "NMT is not answered");
        r
    }

    fn send(&mut self, frame: &str) -> Vec<String> {
        let mut out = Vec::new();
        self.node.handle_can(self.now, &f(frame), &mut out);
        out.iter().map(ToString::to_string).collect()
    }

    fn wait(&mut self, d: Duration) -> Vec<String> {
        self.now += d;
        let mut out = Vec::new();
        self.node.poll(self.now, &mut out);
        out.iter().map(ToString::to_string).collect()
    }
}

// Specs README: commands only after NMT start `000#0101`.
#[test]
fn nmt_start_required() {
    let mut r = Rig::new();
    assert!(r.send("201#2600000000000000").is_empty());
    r.send("000#0101");
    assert_eq!(
        r.send("201#2600000000000000"),
        ["181#2600000000009000"],
        "ready input active, position not initialised"
    );
}

use crate::proto::cdios::{
    Address, AnalogOutput, Command, Direction as Dir, GotoMode, ModuleId, ServoConfig, StartOption, StopOption, Timers,
    Traject,
};
use proptest::prelude::*;

impl Rig {
    fn cmd(&mut self, c: Command, module: u8) -> Vec<String> {
        let frame = c.frame(NodeId::FACTORY, Address::Module(ModuleId::new(module).unwrap())).unwrap();
        self.send(&frame.to_string())
    }

    /// Polls every 10 ms for `d`, collecting what the node sends.
    fn run(&mut self, d: Duration) -> Vec<String> {
        let end = self.now + d;
        let mut all = Vec::new();
        while self.now < end {
            all.extend(self.wait(Duration::from_millis(10).min(end - self.now)));
        }
        all
    }

    fn m(&self, id: u8) -> &Motor6168 {
        self.node.module(id).unwrap()
    }

    fn enable(&mut self, module: u8) {
        let start =
            Command::Start { sync: false, direction: Dir::Forward, option: StartOption::Enable, motor_speed: 0 };
        assert_eq!(self.cmd(start, module), [format!("181#24{module:02X}000000000000")]);
        assert!(self.m(module).enabled());
    }

    /// min 50, max 1050 RPM, slope 1 s: 1000 RPM/s; 500 pulses per revolution.
    fn round_speeds(&mut self, module: u8) {
        let c = ServoConfig::Speeds { minimum_speed: 50, maximum_speed: 1050, slope: 10 };
        assert_eq!(self.cmd(Command::SetServoConfig(c), module), [format!("181#20{module:02X}000000000000")]);
    }
}

const S1_FORWARD: u8 = 0x01;
const S1_REVERSE: u8 = 0x02;
const S1_MIN: u8 = 0x08;
const S1_MAX: u8 = 0x10;
const S1_ACC: u8 = 0x20;
const S1_DEC: u8 = 0x40;
const S1_GOTO: u8 = 0x80;

#[test]
fn nmt_states_and_broadcast_start() {
    let mut r = Rig::new();
    r.send("000#0102"); // another node
    assert!(r.send("201#2600").is_empty());
    r.send("000#0100"); // all nodes
    assert_eq!(r.send("201#2600").len(), 1);
    r.send("000#0201"); // stop
    assert!(r.send("201#2600").is_empty());
    assert_eq!(r.node.nmt_state(), NmtState::Stopped);
    r.send("000#0101");
    // Foreign ids (PowerCube requests and acks, other nodes) are not answered.
    for other in ["0E3#0A", "0C3#0A3C", "0A3#0A3C00000000", "202#2600", "181#2600", "100#0700"] {
        assert!(r.send(other).is_empty(), "{other}");
    }
    // Short (variable length) frames read as zero-padded.
    assert_eq!(r.send("201#2600"), r.send("201#2600000000000000"));
}

// Manual 10h: set direct (reply 10h, zeros), get with selector 80h answered with 11h.
#[test]
fn digital_outputs() {
    let mut r = Rig::started();
    assert_eq!(r.send("201#1000000A00000000"), ["181#1000000000000000"]);
    assert_eq!(r.send("201#1000800000000000"), ["181#1100000A00000000"]);
    // Data out of range (4 outputs): error 90h, error status bit 1.
    assert_eq!(r.send("201#1000001000000000"), ["181#9000000002000000"]);
    // Selector out of range: bit 0.
    assert_eq!(r.send("201#1000020000000000"), ["181#9000000001000000"]);
    // Latched: unchanged until SYNC (CANopen SYNC, id 080).
    assert_eq!(r.send("201#1000010500000000"), ["181#1000000000000000"]);
    assert_eq!(r.m(0).digital_outputs(), 0x0A);
    r.send("080#");
    assert_eq!(r.m(0).digital_outputs(), 0x05);
    assert_eq!(r.m(1).digital_outputs(), 0x00);
}

// Manual 16h: -10000..10000 mV; #1 refused while the motor is enabled (bit 7); errors as 56h.
#[test]
fn analog_outputs_and_enable_refusal() {
    let mut r = Rig::started();
    let set1 = |mv| Command::SetAnalogOutput { output: AnalogOutput::One, latched: false, millivolts: mv };
    assert_eq!(r.cmd(set1(-2500), 0), ["181#1600000000000000"]);
    assert_eq!(r.send("201#1600800000000000"), ["181#1600803CF6000000"], "read #1 echoes 80h, -2500 = F63C");
    assert_eq!(r.send("201#16001011270000"), ["181#5600000002000000"], "10001 mV: value out of range");
    assert_eq!(r.send("201#1600200000000000"), ["181#5600000001000000"], "selector out of range");
    r.enable(0);
    assert_eq!(r.cmd(set1(1000), 0), ["181#5600000080000000"], "motor enabled: #1 cannot be modified");
    assert_eq!(r.send("201#1600001127"), ["181#5600000082000000"], "both bits");
    let set2 = Command::SetAnalogOutput { output: AnalogOutput::Two, latched: false, millivolts: 1234 };
    assert_eq!(r.cmd(set2, 0), ["181#1600000000000000"], "#2 is free");
    assert_eq!(r.m(0).analog_outputs(), [0, 1234], "#1 is the regulating voltage, 0 at rest");
    r.cmd(Command::Stop { sync: false, option: StopOption::Disable }, 0);
    assert_eq!(r.cmd(set1(1000), 0), ["181#1600000000000000"]);
    assert_eq!(r.m(0).analog_outputs(), [1000, 1234]);
}

// Manual 20h: set / read every part; read replies echo the selector | 80h.
#[test]
fn servo_configuration_set_and_read() {
    let mut r = Rig::started();
    assert_eq!(r.send("201#2001800000000000"), ["181#2001803200401F0A"], "defaults 50, 8000, 10");
    assert_eq!(r.send("201#2001812A00000000"), ["181#2001811027010100"], "10000 mV, both end switches checked");
    assert_eq!(r.send("201#200100C800D0070F"), ["181#2001000000000000"]);
    assert_eq!(r.send("201#2001800000000000"), ["181#200180C800D0070F"]);
    // Minimum speed 0 and slope 0 are out of range: bits 2 and 4 of status 1; nothing changes.
    assert_eq!(r.send("201#2001000000D00700"), ["181#A001000014000000"]);
    assert_eq!(r.send("201#2001800000000000"), ["181#200180C800D0070F"]);
    // Maximum voltage 999 (bit 0 of status 2), slope profile 2 (bit 1 of status 2).
    assert_eq!(r.send("201#200101E703010100"), ["181#A001000000010000"]);
    assert_eq!(r.send("201#200102F401000002"), ["181#A001000000020000"]);
    // Traject 1 speed 3 at selector 27h, read back at A7h.
    assert_eq!(r.send("201#2001273412000000"), ["181#2001000000000000"]);
    assert_eq!(r.send("201#2001A70000000000"), ["181#2001A73412000000"]);
    assert_eq!(r.send("201#2001850000000000"), ["181#A001000002000000"], "read selector 85h out of range");
    // Not while running.
    r.enable(1);
    r.cmd(
        Command::Start { sync: false, direction: Dir::Forward, option: StartOption::MinimumSpeed, motor_speed: 0 },
        1,
    );
    assert_eq!(r.send("201#200100C800D0070F"), ["181#A001000001000000"]);
}

// Manual 21h / 22h / 23h: set position, read current and setpoint; goto refused while disabled.
#[test]
fn positions_and_goto_refusals() {
    let mut r = Rig::started();
    assert_eq!(r.send("201#2200003930000000"), ["181#2200000000000000"], "set position 12345");
    assert_eq!(r.send("201#2100000000000000"), ["181#2100003930000000"]);
    assert_eq!(r.send("201#2100020000000000"), ["181#2100023930000000"], "setpoint too");
    assert_eq!(r.send("201#2100030000000000"), ["181#A100000001000000"], "selector 3");
    assert_eq!(r.m(0).status()[3] & 0x80, 0, "set position initialises the position");
    // Contract vector `201#2301008813000000` (goto 5000): motor not enabled, bit 7.
    assert_eq!(r.send("201#2300008813000000"), ["181#A300000080000000"]);
    assert_eq!(r.send("201#23000B0000000000"), ["181#A300000004000000"], "selector 11: bit 2");
    assert_eq!(r.send("201#2300080080000000"), ["181#A300000010000000"], "speed 32768: bit 4");
    assert_eq!(r.send("201#2300060100000000"), ["181#A300000088000000"], "traject 1 undefined and not enabled");
    assert_eq!(r.send("201#23000A6400000000"), ["181#A300000020000000"], "no goto running");
}

/// Distance of a ramp between `a` and `b` RPM at 1000 RPM/s, 500 pulses / rev.
fn ramp_pulses(a: f64, b: f64) -> f64 {
    (a + b) / 2.0 * (b - a).abs() / 1000.0 * 500.0 / 60.0
}

fn goto_timing(sin2: bool) {
    let mut r = Rig::started();
    r.round_speeds(0);
    if sin2 {
        let c = ServoConfig::Encoder {
            pulses_per_revolution: 500,
            hold_on_enable: false,
            auto_zero: false,
            sin2_slope: true,
        };
        assert_eq!(r.cmd(Command::SetServoConfig(c), 0), ["181#2000000000000000"]);
    }
    r.enable(0);
    assert_eq!(r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 20000 }, 0), ["181#2300000000000000"]);
    // Up from 50 to 1050 RPM in 1 s, down in 1 s, cruise in between at 8750 pulses/s.
    let cruise_s = (20000.0 - 2.0 * ramp_pulses(50.0, 1050.0)) / (1050.0 * 500.0 / 60.0);
    let total = 2.0 + cruise_s;
    r.run(Duration::from_millis(250));
    let s = r.m(0).status();
    assert_eq!(s[0], S1_FORWARD | S1_ACC | S1_GOTO, "{s:?}");
    let v = r.m(0).desired_rpm();
    let expect = if sin2 { 50.0 + 1000.0 * (std::f64::consts::PI / 8.0).sin().powi(2) } else { 300.0 };
    assert!((v - expect).abs() < 5.0, "speed {v} at 0.25 s, want {expect}");
    assert!(r.m(0).speed_rpm() < v, "the real speed trails while accelerating");
    r.run(Duration::from_millis(1250));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_MAX | S1_GOTO);
    assert!((r.m(0).speed_rpm() - 1050.0).abs() < 1e-6);
    r.run(Duration::from_secs_f64(total - 1.5 - 0.5));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_DEC | S1_GOTO);
    r.run(Duration::from_millis(450));
    assert!(r.m(0).running(), "not yet there at {total} - 0.05 s");
    r.run(Duration::from_millis(100));
    let m = r.m(0);
    assert!(!m.running(), "there by {total} + 0.05 s (position {})", m.position());
    assert_eq!(m.position(), 20000);
    assert_eq!(m.status()[0], 0);
    assert_eq!(m.status()[3] & 0x04, 0x04, "held at the setpoint");
    assert_eq!(r.send("201#2100000000000000"), ["181#210000204E000000"]);
}

#[test]
fn goto_reaches_target_with_linear_profile_timing() {
    goto_timing(false);
}

#[test]
fn goto_reaches_target_with_sin2_profile_timing() {
    goto_timing(true);
}

#[test]
fn goto_speed_is_clamped_and_relative_modes_add() {
    let mut r = Rig::started();
    r.round_speeds(0);
    r.enable(0);
    assert_eq!(r.cmd(Command::SetNextGotoSpeed { speed: 20 }, 0), ["181#2300000000000000"]);
    r.cmd(Command::Goto { mode: GotoMode::Relative, position: -300 }, 0);
    r.run(Duration::from_millis(100));
    assert_eq!(r.m(0).status()[0], S1_REVERSE | S1_MIN | S1_GOTO, "20 RPM clamps to the minimum 50");
    r.run(Duration::from_secs(2));
    assert_eq!(r.m(0).position(), -300);
    r.cmd(Command::Goto { mode: GotoMode::SetpointRelative, position: 100 }, 0);
    assert_eq!(r.send("201#2100020000000000"), ["181#21000238FFFFFF00"], "setpoint -200 at once");
    r.run(Duration::from_secs(2));
    assert_eq!(r.m(0).position(), -200);
}

// Manual 23h: three ways to change the speed of a running goto.
#[test]
fn speed_change_mid_goto() {
    let mut r = Rig::started();
    r.round_speeds(0);
    r.enable(0);
    r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 100_000 }, 0);
    r.run(Duration::from_millis(1500));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_MAX | S1_GOTO);
    // 1. selector 10: now.
    assert_eq!(r.cmd(Command::ChangeGotoSpeed { speed: 550 }, 0), ["181#2300000000000000"]);
    r.run(Duration::from_millis(100));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_DEC | S1_GOTO);
    r.run(Duration::from_millis(500));
    assert!((r.m(0).desired_rpm() - 550.0).abs() < 1e-6);
    // 2. selector 8 then 9: at a position ahead.
    let at = r.m(0).position() + 5000;
    r.cmd(Command::SetNextGotoSpeed { speed: 850 }, 0);
    assert_eq!(r.cmd(Command::SetSpeedChangePosition { position: at }, 0), ["181#2300000000000000"]);
    r.run(Duration::from_millis(50));
    assert!((r.m(0).desired_rpm() - 550.0).abs() < 1e-6, "not before the position");
    while r.m(0).position() < at {
        r.run(Duration::from_millis(10));
    }
    r.run(Duration::from_millis(20));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_ACC | S1_GOTO, "accelerating past {at}");
    r.run(Duration::from_millis(500));
    assert!((r.m(0).desired_rpm() - 850.0).abs() < 1e-6);
    // 3. selector 8 then the goto again: a new target behind turns the motor round.
    r.cmd(Command::SetNextGotoSpeed { speed: 0 }, 0);
    assert_eq!(r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 0 }, 0), ["181#2300000000000000"]);
    r.run(Duration::from_millis(100));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_DEC | S1_GOTO);
    r.run(Duration::from_secs(30));
    assert_eq!(r.m(0).position(), 0);
    assert!(!r.m(0).running());
    // Gotos cannot be interrupted with the sin² profile.
    let c =
        ServoConfig::Encoder { pulses_per_revolution: 500, hold_on_enable: false, auto_zero: false, sin2_slope: true };
    r.cmd(Command::SetServoConfig(c), 0);
    r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 50_000 }, 0);
    r.run(Duration::from_millis(100));
    assert_eq!(r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 0 }, 0), ["181#A300000001000000"]);
    assert_eq!(r.cmd(Command::ChangeGotoSpeed { speed: 100 }, 0), ["181#A300000001000000"]);
}

// Manual 20h: an enabled end switch stops the motor and clears enable; status 2 bits 0 / 3;
// 24h: a start towards the active switch is refused (bit 6); a start clears bit 3.
#[test]
fn end_switch_stops() {
    let mut r = Rig::started();
    r.round_speeds(0);
    r.enable(0);
    r.cmd(Command::Start { sync: false, direction: Dir::Forward, option: StartOption::Accelerate, motor_speed: 0 }, 0);
    r.run(Duration::from_millis(300));
    assert!(r.m(0).running());
    r.node.module_mut(0).unwrap().set_end_switch(Dir::Forward, true);
    r.run(Duration::from_millis(10));
    let m = r.m(0);
    assert!(!m.running() && !m.enabled());
    assert_eq!(m.status()[1], 0x01 | 0x08, "forward switch active, stopped by it");
    assert_eq!(m.status()[2] & 0x80, 0, "enable cleared");
    r.enable(0);
    let fwd =
        Command::Start { sync: false, direction: Dir::Forward, option: StartOption::MinimumSpeed, motor_speed: 0 };
    assert_eq!(r.cmd(fwd, 0), ["181#A400000040000000"], "end switch active, cannot start");
    let rev =
        Command::Start { sync: false, direction: Dir::Reverse, option: StartOption::MinimumSpeed, motor_speed: 0 };
    assert_eq!(r.cmd(rev, 0), ["181#2400000000000000"], "away from the switch is fine");
    assert_eq!(r.m(0).status()[1], 0x01, "start cleared 'stopped by forward end switch'");
    // With checking off, the physical switch at +END_SWITCH_PULSES does not stop a goto.
    r.node.module_mut(0).unwrap().set_end_switch(Dir::Forward, false);
    r.cmd(Command::Stop { sync: false, option: StopOption::FastStop }, 0);
    let off = ServoConfig::Voltage { maximum_voltage: 10000, forward_end_switch: false, reverse_end_switch: true };
    assert_eq!(r.cmd(Command::SetServoConfig(off), 0), ["181#2000000000000000"]);
    r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 120_000 }, 0);
    r.run(Duration::from_secs(20));
    assert_eq!(r.m(0).position(), 120_000);
    assert_eq!(r.m(0).status()[1], 0x01, "beyond the switch, not stopped by it");
}

// Status 2 bit 2 / bit 5: emergency input stops and disables; stop option 3 releases once the input is quiet.
#[test]
fn emergency_stop_and_release() {
    let mut r = Rig::started();
    r.enable(1);
    r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 50_000 }, 1);
    r.run(Duration::from_millis(200));
    r.node.module_mut(1).unwrap().set_emergency(true);
    r.run(Duration::from_millis(10));
    let m = r.m(1);
    assert!(!m.running() && !m.enabled());
    assert_eq!(m.status()[1], 0x04 | 0x20);
    let goto = Command::Goto { mode: GotoMode::Absolute, position: 0 };
    assert_eq!(r.cmd(goto, 1), ["181#A301000082000000"], "emergency and not enabled");
    let enable = Command::Start { sync: false, direction: Dir::Forward, option: StartOption::Enable, motor_speed: 0 };
    assert_eq!(r.cmd(enable, 1), ["181#A401000002000000"]);
    let release = Command::Stop { sync: false, option: StopOption::ReleaseEmergency };
    assert_eq!(r.cmd(release, 1), ["181#A501000002000000"], "input still active");
    r.node.module_mut(1).unwrap().set_emergency(false);
    assert_eq!(
        r.cmd(Command::Stop { sync: false, option: StopOption::FastStop }, 1),
        ["181#A501000086000000"],
        "latched, not enabled, not running"
    );
    assert_eq!(r.cmd(release, 1), ["181#2501000000000000"]);
    assert_eq!(r.m(1).status()[1], 0);
    r.enable(1);
    assert_eq!(r.cmd(goto, 1), ["181#2301000000000000"]);
    // Ready input inactive (checked by default): bits 7 and 5.
    r.run(Duration::from_millis(100));
    r.node.module_mut(1).unwrap().set_ready(false);
    r.run(Duration::from_millis(10));
    assert_eq!(r.m(1).status()[1], 0x80 | 0x20);
    assert_eq!(r.m(1).status()[3] & 0x10, 0);
}

// Manual 05h: 260..750 ms of programming, general error 8 meanwhile, then the (never suppressed) reply.
#[test]
fn store_configuration_busy_then_reply() {
    let mut r = Rig::started();
    r.node.set_confirm(false);
    assert_eq!(r.send("201#2001000A00D00714"), Vec::<String>::new(), "confirmation suppressed");
    assert!(r.send("201#0501004344530000").is_empty(), "the reply waits for the EEPROM");
    assert_eq!(r.send("201#2601000000000000"), ["181#A601000800000000"], "busy, for any module");
    assert_eq!(r.send("201#2100000000000000"), ["181#A100000800000000"]);
    assert!(r.wait(Duration::from_millis(259)).is_empty());
    let mut waited = 259;
    let reply = loop {
        let out = r.wait(Duration::from_millis(1));
        waited += 1;
        if !out.is_empty() {
            break out;
        }
        assert!(waited <= 750, "no reply after 750 ms");
    };
    assert_eq!(reply, ["181#0501000000000000"]);
    assert!(!r.node.eeprom_busy(r.now));
    assert_eq!(r.send("201#2601000000000000").len(), 1);
    r.node.set_confirm(true);
    // The same node takes the same time again (seeded), and a reset restores what was stored.
    let mut again = Rig::started();
    again.send("201#0501004344530000");
    again.wait(Duration::from_millis(waited - 1));
    assert!(again.node.eeprom_busy(again.now));
    assert_eq!(again.wait(Duration::from_millis(1)), ["181#0501000000000000"]);
    r.send("201#2001003200401F0A");
    assert_eq!(r.send("201#2001800000000000"), ["181#2001803200401F0A"]);
    r.send("000#8101");
    r.wait(INIT_TIME);
    r.send("000#0101");
    assert_eq!(r.send("201#2001800000000000"), ["181#2001800A00D00714"], "the stored configuration");
    // Refusals: enabled motor, wrong key.
    r.enable(1);
    assert_eq!(r.send("201#0501004344530000"), ["181#8501000001000000"]);
    assert_eq!(r.send("201#0500004344540000"), ["181#8500000002000000"]);
    // Defaults (selector 1).
    r.send("201#0500014344530000");
    r.wait(Duration::from_millis(750));
    assert_eq!(r.send("201#2000800000000000"), ["181#2000803200401F0A"]);
}

// General errors: 1 no module, 3 unknown command (or a module command to the controller), 4 initialising.
#[test]
fn general_errors() {
    let mut r = Rig::started();
    assert_eq!(r.send("201#2605000000000000"), ["181#A605000100000000"]);
    assert_eq!(r.send("201#0F00000000000000"), ["181#8F00000300000000"]);
    assert_eq!(r.send("201#26FF000000000000"), ["181#A6FF000300000000"]);
    assert_eq!(r.send("201#0100000000000000"), ["181#8100000300000000"], "identify goes to the controller");
    assert_eq!(r.send("201#2600030000000000"), ["181#A600000600000000"], "26h selector 3: not supported");
    r.send("000#8101");
    r.send("000#0101");
    assert_eq!(r.send("201#2600000000000000"), ["181#A600000400000000"]);
    r.wait(Duration::from_millis(499));
    assert_eq!(r.send("201#2600000000000000"), ["181#A600000400000000"]);
    r.wait(Duration::from_millis(1));
    assert_eq!(r.send("201#2600000000000000"), ["181#2600000000009000"]);
}

// Controller 01h (specs README): the identify table, types and versions of modules 2s, 2s+1.
#[test]
fn identify_table() {
    let mut r = Rig::started();
    let t = format!("{MODULE_TYPE_6168:02X}{MODULE_VERSION:02X}");
    assert_eq!(r.send("201#01FF000000000000"), [format!("181#01FF00{t}{t}00")]);
    assert_eq!(r.send("201#01FF010000000000"), ["181#01FF010000000000"]);
    let serial = r.m(1).serial().to_le_bytes();
    let hex: String = serial.iter().map(|b| format!("{b:02X}")).collect();
    assert_eq!(r.send("201#01FF090000000000"), [format!("181#01FF09{hex}00")]);
    assert_eq!(r.send("201#01FF190000000000"), ["181#81FF000600000000"]);
}

// Confirm = 0 suppresses confirmations only: reads and errors still come.
#[test]
fn confirm_off() {
    let mut r = Rig::started();
    r.node.set_confirm(false);
    assert!(r.send("201#1000000100000000").is_empty());
    assert_eq!(r.send("201#1000800000000000"), ["181#1100000100000000"]);
    assert_eq!(r.send("201#1000001000000000"), ["181#9000000002000000"]);
    assert!(r.send("201#2400000005000000").is_empty(), "enable confirmation");
    assert!(r.m(0).enabled());
}

// Manual 27h: events by mask (code | 40h, the 26h reply layout) and by timer.
#[test]
fn events_by_mask_and_timer() {
    let mut r = Rig::started();
    r.round_speeds(0);
    // Mask: goto active (status 1 bit 7) and enabled (status 3 bit 7); no timers.
    let set = Command::SetEventMask { masks: [0x80, 0, 0x80, 0], timers: Timers::default() };
    assert_eq!(r.cmd(set, 0), ["181#2700000000000000"]);
    assert_eq!(r.send("201#2700800000000000"), ["181#2700808000800000"]);
    assert_eq!(r.send("201#2400000005000000"), ["181#2400000000000000", "181#6600000000809000"]);
    let out = r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 2000 }, 0);
    assert_eq!(out, ["181#2300000000000000", "181#6600008900809000"], "goto, forward, starting at minimum speed");
    // No events while only unmasked bits change (accelerating -> maximum...), one at the end.
    let events = r.run(Duration::from_secs(5));
    assert_eq!(events, ["181#6600000000809400"], "goto over: held, enabled");
    // Module 1 has no mask: nothing from it.
    r.send("201#2401000005000000");
    // Timers: position every 62.5 ms (code 5), speed every 250 ms (code 7), always.
    let timers = Timers { position_interval: 5, position_on_change: false, speed_interval: 7, speed_on_change: false };
    assert_eq!(r.cmd(Command::SetEventMask { masks: [0; 4], timers }, 0), ["181#2700000000000000"]);
    assert_eq!(r.send("201#2700800000000000"), ["181#2700800000000075"]);
    let events = r.run(Duration::from_secs(1));
    let pos: Vec<_> = events.iter().filter(|e| e.starts_with("181#6100")).collect();
    let spd: Vec<_> = events.iter().filter(|e| e.starts_with("181#660002")).collect();
    assert_eq!(pos.len(), 16, "{events:?}");
    assert_eq!(spd.len(), 4);
    assert_eq!(pos[0].as_str(), "181#610000D007000000");
    assert_eq!(spd[0].as_str(), "181#6600020000000000");
    assert_eq!(events.len(), 20);
    // Only on change: one position event at rest.
    let timers = Timers { position_interval: 1, position_on_change: true, speed_interval: 0, speed_on_change: false };
    r.cmd(Command::SetEventMask { masks: [0; 4], timers }, 0);
    assert_eq!(r.run(Duration::from_secs(1)).len(), 1);
}

// Manual 20h traject settings and 23h selector 6: speed changes at setpoint-relative positions.
#[test]
fn traject_runs_its_speed_changes() {
    let mut r = Rig::started();
    r.round_speeds(0);
    let t = Traject::Zero;
    for c in [
        ServoConfig::TrajectEnd { traject: t, end_position: 20000, length: 3 },
        ServoConfig::TrajectInitialSpeed { traject: t, speed: 550 },
        ServoConfig::TrajectChangePosition { traject: t, step: crate::proto::cdios::Step::First, position: 5000 },
        ServoConfig::TrajectSpeed { traject: t, step: crate::proto::cdios::Step::First, speed: 1050 },
        ServoConfig::TrajectChangePosition { traject: t, step: crate::proto::cdios::Step::Second, position: 12000 },
        ServoConfig::TrajectSpeed { traject: t, step: crate::proto::cdios::Step::Second, speed: 300 },
    ] {
        assert_eq!(r.cmd(Command::SetServoConfig(c), 0), ["181#2000000000000000"]);
    }
    r.enable(0);
    r.send("201#2200001027000000"); // position and setpoint 10000
    assert_eq!(r.cmd(Command::GotoTraject { traject: t, sync: false }, 0), ["181#2300000000000000"]);
    assert_eq!(r.send("201#2100020000000000"), ["181#2100023075000000"], "setpoint 30000");
    r.run(Duration::from_secs(1));
    assert_eq!(r.m(0).status()[3] & 0x08, 0x08, "traject running");
    assert!((r.m(0).desired_rpm() - 550.0).abs() < 1e-6);
    assert_eq!(r.cmd(Command::ChangeGotoSpeed { speed: 100 }, 0), ["181#A300000001000000"], "not during a traject");
    let mut seen_fast = false;
    while r.m(0).running() {
        r.run(Duration::from_millis(10));
        let (p, v) = (r.m(0).position(), r.m(0).desired_rpm());
        if p < 15000 {
            assert!(v <= 550.0 + 1e-6, "{v} RPM at {p}");
        }
        seen_fast |= (v - 1050.0).abs() < 1e-6;
        if (23000..27000).contains(&p) {
            assert!(v <= 300.0 + 1e-6 || r.m(0).status()[0] & S1_DEC != 0, "{v} RPM at {p}");
        }
    }
    assert!(seen_fast);
    assert_eq!(r.m(0).position(), 30000);
    assert_eq!(r.m(0).status()[3] & 0x08, 0);
    // Traject 1 is undefined; the sin² profile refuses trajects.
    assert_eq!(r.cmd(Command::GotoTraject { traject: Traject::One, sync: false }, 0), ["181#A300000008000000"]);
    let c =
        ServoConfig::Encoder { pulses_per_revolution: 500, hold_on_enable: false, auto_zero: false, sin2_slope: true };
    r.cmd(Command::SetServoConfig(c), 0);
    assert_eq!(r.cmd(Command::GotoTraject { traject: t, sync: false }, 0), ["181#A300000040000000"]);
}

// Manual 24h options 4 and 6: index search zeroes the position (status 3 bit 0, cleared by reading).
#[test]
fn index_searches_zero_the_position() {
    let mut r = Rig::started();
    r.enable(0);
    let start = |option| Command::Start { sync: false, direction: Dir::Forward, option, motor_speed: 0 };
    assert_eq!(r.cmd(start(StartOption::UntilIndex), 0), ["181#2400000000000000"]);
    r.run(Duration::from_millis(50));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_MIN);
    r.run(Duration::from_secs(2));
    let m = r.m(0);
    assert!(!m.running());
    assert!((0..10).contains(&m.position()), "a bit past the index: {}", m.position());
    assert_eq!(m.status()[2] & 0x01, 0x01);
    assert_eq!(m.status()[3] & 0x80, 0, "position initialised");
    r.send("201#2600000000000000");
    assert_eq!(r.m(0).status()[2] & 0x01, 0, "cleared by reading the status");
    // Option 6 waits for the index inside the Z window (at 10000 pulses from power on).
    r.cmd(start(StartOption::UntilIndexAndZero), 0);
    r.run(Duration::from_secs(30));
    assert!(!r.m(0).running());
    r.cmd(Command::Goto { mode: GotoMode::Absolute, position: 0 }, 0);
    r.run(Duration::from_secs(5));
    assert_eq!(r.m(0).status()[3] & 0x01, 0x01, "Z active at the new zero");
}

// Manual 24h option 2: runs to the end switch whatever the checking; status 1 bit 2 meanwhile.
#[test]
fn end_switch_search() {
    let mut r = Rig::started();
    r.node.module_mut(0).unwrap().set_end_switch_positions(Some((-1000.0, 1000.0)));
    r.enable(0);
    let c =
        Command::Start { sync: false, direction: Dir::Reverse, option: StartOption::UntilEndSwitch, motor_speed: 0 };
    r.cmd(c, 0);
    r.run(Duration::from_millis(100));
    assert_eq!(r.m(0).status()[0], S1_REVERSE | 0x04 | S1_MIN);
    r.run(Duration::from_secs(3));
    let m = r.m(0);
    assert!(!m.running() && m.enabled(), "found, not a fault");
    assert_eq!(m.position(), 0);
    assert_eq!(m.status()[1], 0x02, "reverse switch active, not 'stopped by'");
    assert_eq!(r.cmd(c, 0), ["181#A400000040000000"], "already on the switch");
}

// Manual 24h options 0, 1, 3 and 25h options 0, 1, 2, 4.
#[test]
fn start_and_stop_options() {
    let mut r = Rig::started();
    r.round_speeds(0);
    r.enable(0);
    let start = |option, speed| Command::Start { sync: false, direction: Dir::Forward, option, motor_speed: speed };
    let stop = |option| Command::Stop { sync: false, option };
    assert_eq!(r.cmd(stop(StopOption::FastStop), 0), ["181#A500000004000000"], "not running");
    r.cmd(start(StartOption::MinimumSpeed, 0), 0);
    r.run(Duration::from_millis(100));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_MIN);
    let rev = Command::Start { sync: false, direction: Dir::Reverse, option: StartOption::Accelerate, motor_speed: 0 };
    assert_eq!(r.cmd(rev, 0), ["181#A400000004000000"], "opposite direction");
    assert_eq!(r.cmd(start(StartOption::Accelerate, 0), 0), ["181#2400000000000000"]);
    r.run(Duration::from_millis(1100));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_MAX);
    assert_eq!(r.send("201#2400000003317500"), ["181#A400000080000000"], "MotorSpeed 30001");
    assert_eq!(r.send("201#2400000001317500"), ["181#A400000001000000"], "only 'running': speed checked with option 3");
    assert_eq!(r.cmd(start(StartOption::ToSpeed, 300), 0), ["181#2400000000000000"]);
    r.run(Duration::from_millis(1000));
    assert!((r.m(0).desired_rpm() - 300.0).abs() < 1e-6);
    assert_eq!(r.cmd(stop(StopOption::ClearHold), 0), ["181#A500000001000000"], "running");
    assert_eq!(r.cmd(stop(StopOption::DecelerateToMinimum), 0), ["181#2500000000000000"]);
    r.run(Duration::from_millis(500));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_MIN);
    assert_eq!(r.cmd(start(StartOption::ToSpeed, 800), 0), ["181#2400000000000000"]);
    r.run(Duration::from_millis(1000));
    assert_eq!(r.cmd(stop(StopOption::DecelerateAndStop), 0), ["181#2500000000000000"]);
    r.run(Duration::from_millis(400));
    assert_eq!(r.m(0).status()[0], S1_FORWARD | S1_DEC);
    r.run(Duration::from_millis(500));
    let m = r.m(0);
    assert!(!m.running());
    assert_eq!(m.setpoint(), m.position());
    assert_eq!(m.status()[3] & 0x04, 0, "no hold: 'Hold On Enable' is 0 and it was no goto");
    // A goto stopped is held at the setpoint; 25h option 4 clears the hold.
    r.cmd(Command::Goto { mode: GotoMode::Relative, position: 50_000 }, 0);
    r.run(Duration::from_millis(500));
    assert_eq!(r.cmd(stop(StopOption::FastStop), 0), ["181#2500000000000000"]);
    assert_eq!(r.m(0).status()[3] & 0x04, 0x04);
    assert_eq!(r.cmd(stop(StopOption::ClearHold), 0), ["181#2500000000000000"]);
    assert_eq!(r.m(0).status()[3] & 0x04, 0);
    assert_eq!(r.send("201#2500000600000000"), ["181#A500000010000000"], "option 6");
    assert_eq!(r.send("201#2500020000000000"), ["181#A500000008000000"], "selector 2");
    assert_eq!(r.send("201#2400000007000000"), ["181#A400000020000000"], "option 7");
    assert_eq!(r.send("201#2400000200000000"), ["181#A400000010000000"], "direction 2");
}

// Hold on enable: a held motor pushed beyond Positioning Error (25) comes back at minimum speed.
#[test]
fn hold_corrects_beyond_the_positioning_error() {
    let mut r = Rig::started();
    let c =
        ServoConfig::Encoder { pulses_per_revolution: 500, hold_on_enable: true, auto_zero: false, sin2_slope: false };
    r.cmd(Command::SetServoConfig(c), 0);
    r.enable(0);
    assert_eq!(r.m(0).status()[3] & 0x04, 0x04);
    r.node.module_mut(0).unwrap().push(20.0);
    r.run(Duration::from_millis(100));
    assert_eq!(r.m(0).position(), 20, "inside the window");
    r.node.module_mut(0).unwrap().push(80.0);
    r.run(Duration::from_millis(20));
    assert_eq!(r.m(0).status()[0], S1_REVERSE | S1_MIN);
    r.run(Duration::from_millis(500));
    assert_eq!(r.m(0).position(), 0);
    assert!(!r.m(0).running());
}

// 23h selector 1 and 21h selector 1: latched until SYNC.
#[test]
fn sync_latched_goto_and_position() {
    let mut r = Rig::started();
    r.enable(0);
    assert_eq!(r.cmd(Command::Goto { mode: GotoMode::AbsoluteSync, position: 300 }, 0), ["181#2300000000000000"]);
    r.run(Duration::from_millis(100));
    assert!(!r.m(0).running());
    r.send("080#");
    r.run(Duration::from_millis(100));
    assert!(r.m(0).running());
    r.send("080#");
    let latched = r.m(0).position();
    r.run(Duration::from_secs(1));
    let mut expect = vec![0x21, 0, 1];
    expect.extend(latched.to_le_bytes());
    expect.push(0);
    let hex: String = expect.iter().map(|b| format!("{b:02X}")).collect();
    assert_eq!(r.send("201#2100010000000000"), [format!("181#{hex}")]);
    assert_eq!(r.m(0).position(), 300);
}

// Maximum Voltage limits the speed (status 3 bit 6, negative RPM error); 26h selectors 1 and 2.
#[test]
fn voltage_limiting() {
    let mut r = Rig::started();
    let c = ServoConfig::Voltage { maximum_voltage: 1000, forward_end_switch: true, reverse_end_switch: true };
    r.cmd(Command::SetServoConfig(c), 0);
    r.enable(0);
    r.cmd(Command::Start { sync: false, direction: Dir::Forward, option: StartOption::Accelerate, motor_speed: 0 }, 0);
    r.run(Duration::from_secs(2));
    let m = r.m(0);
    assert_eq!(m.status()[2] & 0x40, 0x40);
    assert!((m.speed_rpm() - RPM_PER_VOLT).abs() < 1e-6);
    assert_eq!(m.analog_outputs()[0], 1000);
    // 3200 = 0x0C80, error 3200 - 8000 = -4800 = 0xED40.
    assert_eq!(r.send("201#2600010000000000"), ["181#260001800C000000"]);
    assert_eq!(r.send("201#2600020000000000"), ["181#260002800C40ED00"]);
}

// The bench: PowerCube and Cdios frames interleaved on one MemBus, both answered.
#[test]
fn powercube_and_cdios_share_one_bus() {
    use crate::clock::VirtualClock;
    use crate::link::CanLink;
    use crate::sim::bench::Bench;
    use std::sync::Arc;

    let clock = Arc::new(VirtualClock::new());
    let bench = Bench::contract(clock.clone());
    let mut link = bench.bus.open();
    let mut exchange = |frame: &str| {
        link.send(&f(frame)).unwrap();
        let mut got = Vec::new();
        while let Some(fr) = link.recv(Duration::from_millis(5)).unwrap() {
            got.push(fr.to_string());
        }
        got
    };
    assert!(exchange("000#0101").is_empty());
    // PowerCube GetExtended DefCubeVersion (0x1d) of module 3 on 0x0C3, ack on 0x0A3.
    let pc = exchange("0C3#0A1D");
    assert_eq!(pc.len(), 1);
    assert!(pc[0].starts_with("0A3#0A1D"), "{pc:?}");
    assert_eq!(exchange("201#2600000000000000"), ["181#2600000000009000"]);
    assert_eq!(exchange("201#2401000005000000"), ["181#2401000000000000"]);
    assert!(exchange("0C5#0A1D")[0].starts_with("0A5#0A1D"));
    assert_eq!(exchange("201#2301008813000000"), ["181#2301000000000000"], "the contract's goto 5000");
    assert!(exchange("0C3#0A3C")[0].starts_with("0A3#0A3C"), "ActPos of module 3");
    clock.advance(Duration::from_secs(3));
    assert_eq!(exchange("201#2101000000000000"), ["181#2101008813000000"]);
    assert_eq!(bench.cdios.lock().unwrap().module(1).unwrap().position(), 5000);
    // PowerCube module 3 is no Cdios module: general error 1.
    assert_eq!(exchange("201#2603000000000000"), ["181#A603000100000000"]);
}

fn arb_frame() -> impl Strategy<Value = CanFrame> {
    let id = prop_oneof![Just(0x000u32), Just(0x080), Just(0x201), Just(0x181), Just(0x0E3), 0u32..0x800];
    let data = prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..=8),
        // Commands the node knows, with random selectors and values.
        (prop_oneof![Just(0x05u8), Just(0x10), Just(0x16), 0x20u8..=0x27], 0u8..3, any::<[u8; 6]>()).prop_map(
            |(c, m, rest)| {
                let mut v = vec![c, m];
                v.extend(rest);
                v
            }
        ),
    ];
    (id, data).prop_map(|(id, d)| CanFrame::new(id, &d).unwrap())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    // Never panic; answer only from 0x181 with 8 bytes; reserved status bits stay 0.
    #[test]
    fn random_frames_never_panic(
        steps in proptest::collection::vec((arb_frame(), 0u64..400, any::<u8>()), 1..120)
    ) {
        let mut r = Rig::started();
        for (frame, ms, poke) in steps {
            r.now += Duration::from_millis(ms);
            let mut out = Vec::new();
            if let Some(m) = r.node.module_mut(poke & 1) {
                match poke >> 5 {
                    1 => m.set_end_switch(Dir::Forward, poke & 2 != 0),
                    2 => m.set_emergency(poke & 2 != 0),
                    3 => m.push(f64::from(poke) - 128.0),
                    _ => {}
                }
            }
            r.node.handle_can(r.now, &frame, &mut out);
            r.node.poll(r.now + Duration::from_millis(ms / 2), &mut out);
            for a in &out {
                prop_assert_eq!(a.id(), 0x181);
                prop_assert_eq!(a.dlc(), 8);
            }
            for m in r.node.modules() {
                let s = m.status();
                prop_assert_eq!(s[2] & 0x0A, 0, "reserved status 3 bits");
                prop_assert_eq!(s[3] & 0x42, 0, "reserved status 4 bits");
                prop_assert!(m.speed_rpm().is_finite());
                prop_assert!(!m.running() || m.enabled(), "running while disabled");
            }
        }
    }
}
