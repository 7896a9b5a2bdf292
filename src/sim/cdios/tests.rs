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
