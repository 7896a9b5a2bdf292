use std::time::{Duration, Instant};

use proptest::prelude::*;

use super::*;
use crate::proto::pac::frame::{AckDecoder, EncodeOptions};

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

/// A controller on virtual time: `t0` is power-up.
struct Bench {
    c: PacController,
    t0: Instant,
    now: Instant,
}

impl Bench {
    fn new(axes: u8) -> Self {
        let t0 = Instant::now();
        Self { c: PacController::new(axes, t0), t0, now: t0 }
    }

    fn at(&mut self, secs: f64) -> &mut Self {
        self.now = self.t0 + Duration::from_secs_f64(secs);
        self.c.advance(self.now);
        self
    }

    fn wait(&mut self, secs: f64) -> &mut Self {
        self.now += Duration::from_secs_f64(secs);
        self.c.advance(self.now);
        self
    }

    fn raw(&mut self, bytes: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        self.c.handle_bytes(self.now, bytes, &mut out);
        out
    }

    fn acks(&mut self, bytes: &[u8]) -> Vec<Ack> {
        let out = self.raw(bytes);
        let mut d = AckDecoder::new();
        d.push(&out);
        let mut acks = Vec::new();
        while let Some(a) = d.next() {
            acks.push(a.unwrap_or_else(|e| panic!("bad ack {e}: {:?}", String::from_utf8_lossy(&out))));
        }
        acks
    }

    fn one(&mut self, bytes: &[u8]) -> Ack {
        let acks = self.acks(bytes);
        assert_eq!(acks.len(), 1, "{acks:?}");
        acks[0]
    }

    fn cmd(&mut self, code: u16, par1: i64, par2: Par2) -> Ack {
        self.one(&Command::new(code, par1, par2).encode().unwrap())
    }

    fn int(&mut self, code: u16, par1: i64, v: i64) -> Ack {
        self.cmd(code, par1, Par2::Int(v))
    }

    fn float(&mut self, code: u16, par1: i64, v: f64) -> Ack {
        self.cmd(code, par1, Par2::Float(v))
    }

    /// A command that must succeed.
    fn ok(&mut self, code: u16, par1: i64, par2: Par2) -> Ack {
        let a = self.cmd(code, par1, par2);
        assert_eq!(a.quit, 0, "{code:04X};{par1} refused: {a:?}");
        a
    }

    fn poll(&mut self) -> Ack {
        self.one(&[0x04])
    }

    fn online(&mut self) {
        let a = self.int(0x0603, 0, 0);
        assert_eq!((a.quit, a.status), (0, 31));
    }

    /// Online with `axis` referenced at `pos` (0A96).
    fn online_at(&mut self, axis: u8, pos: f64) {
        self.online();
        self.ok(0x0A96, axis.into(), Par2::Float(pos));
    }
}

fn q_f(a: &Ack) -> f64 {
    match a.q_par {
        Par2::Float(v) => v,
        Par2::Int(v) => panic!("expected a float date, got {v}"),
    }
}

fn q_i(a: &Ack) -> i64 {
    match a.q_par {
        Par2::Int(v) => v,
        Par2::Float(v) => panic!("expected an integer date, got {v}"),
    }
}

/// The duration of a rest-to-rest move over `d` at `v`, `a`.
fn profile_time(d: f64, v: f64, a: f64) -> f64 {
    if d >= v * v / a {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}

// Manual 3.4.3, "Complex example 2": start online mode, move axis 2 to
// 5552.0 with 0A87 and poll three times. The acknowledges are the printed
// bytes, CHECK per the rule each printed frame uses (specs README). Axis 2
// starts at 1255.0 (set with 0A96), and the polls come when the default
// profile (1000 AE/s, 2000 AE/s²) passes the printed positions.
#[test]
fn manual_3_4_3_sequence() {
    let mut b = Bench::new(3);
    assert_eq!(b.c.status(), 1);
    let printed = hex("01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04");
    assert_eq!(b.raw(&hex("01 02 30 36 30 33 3B 30 3B 30 3B 30 03 31 34 04")), printed);
    assert_eq!(b.c.status(), 31);
    b.ok(0x0A96, 2, Par2::Float(1255.0));

    let expect = |b: &mut Bench, bytes: &[u8], printed: &str| {
        let printed = hex(printed);
        b.c.set_check_rule(Ack::decode(&printed).unwrap().check_rule);
        assert_eq!(String::from_utf8_lossy(&b.raw(bytes)), String::from_utf8_lossy(&printed));
    };
    let move_frame = Command::new(0x0A87, 2, Par2::Float(5552.0)).encode().unwrap();
    assert_eq!(move_frame, b"\x01\x020A87;2;1;5552.0\x0395\x04");
    let t = 10.0;
    b.at(t);
    expect(&mut b, &move_frame, "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 32 35 35 2E 30 30 30 03 33 38 04");
    assert_eq!(b.c.busy(), Some(0x0A87));
    assert_eq!(b.c.axis_status(2), Some(1));
    // Acceleration to 1000 AE/s takes 0.5 s and 250 AE, then 1000 AE/s.
    b.at(t + 0.5 + 11.95 / 1000.0);
    expect(&mut b, &[0x04], "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 35 31 36 2E 39 35 30 03 34 32 04");
    b.at(t + 0.5 + 1129.75 / 1000.0);
    expect(&mut b, &[0x04], "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 32 36 33 34 2E 37 35 30 03 33 36 04");
    b.at(t + profile_time(5552.0 - 1255.0, 1000.0, 2000.0));
    expect(&mut b, &[0x04], "01 02 30 3B 31 3B 33 31 3B 30 3B 31 3B 35 35 35 32 2E 30 30 30 03 33 35 04");
    assert_eq!(b.c.busy(), None);
    assert_eq!(b.c.axis_status(2), Some(0));
    assert_eq!(b.c.axis_position(2), Some(5552.0));
}

// Manual 3.4.1 and 3.4.2: the acknowledges of the register and input
// examples, byte for byte. The printed command CHECKs of 3.4.1 and of
// 3.4.2 commands 2 and 4 are misprints (specs README), so those commands
// are sent as the encoder writes them.
#[test]
fn manual_3_4_1_and_3_4_2_acknowledges() {
    let mut b = Bench::new(3);
    let expect = |b: &mut Bench, cmd: Vec<u8>, printed: &str| {
        let printed = hex(printed);
        b.c.set_check_rule(Ack::decode(&printed).unwrap().check_rule);
        assert_eq!(b.raw(&cmd), printed, "{}", String::from_utf8_lossy(&cmd));
    };
    // 3.4.1: N5 := 12345.
    let c = Command::new(0x0906, 5, Par2::Int(12345)).encode().unwrap();
    expect(&mut b, c, "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 31 32 33 34 35 03 35 37 04");
    assert_eq!(b.c.int_register(5), Some(12345));
    // 3.4.2 command 1 (printed frame, correct CHECK): input 5 is 1.
    b.c.set_input(5, true);
    expect(
        &mut b,
        hex("01 02 31 39 30 30 3B 35 3B 30 3B 30 03 36 04"),
        "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 31 03 35 37 04",
    );
    // Command 2: N2 holds 222.
    b.int(0x0906, 2, 222);
    let c = Command::new(0x1906, 2, Par2::Int(0)).encode().unwrap();
    expect(&mut b, c, "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 32 32 32 03 35 38 04");
    // Command 3 (printed frame): N3 := 333.
    expect(
        &mut b,
        hex("01 02 30 39 30 36 3B 33 3B 30 3B 33 33 33 03 34 04"),
        "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 33 33 33 03 35 39 04",
    );
    assert_eq!(b.c.int_register(3), Some(333));
    // Command 4: R1 holds 640.0, answered with 4 decimals.
    b.float(0x0907, 1, 640.0);
    let c = Command::new(0x1907, 1, Par2::Float(0.0)).encode().unwrap();
    expect(&mut b, c, "01 02 30 3B 31 3B 31 3B 30 3B 31 3B 36 34 30 2E 30 30 30 30 03 32 31 04");
}

// Manual 5.2.2 / 5.2.3 examples: system and axis parameters in home position.
#[test]
fn parameters_and_limits() {
    let mut b = Bench::new(3);
    // 0700: input 1 as start input, echoed.
    assert_eq!(q_i(&b.ok(0x0700, 3, Par2::Int(1))), 1);
    assert_eq!(b.c.system_param(3), Some(1));
    // 1701 / 1702 of parameter 2: the axes the controller has, and 0.
    assert_eq!(q_i(&b.ok(0x1701, 2, Par2::Int(0))), 3);
    assert_eq!(q_i(&b.ok(0x1702, 2, Par2::Int(0))), 0);
    assert_eq!(b.int(0x0700, 2, 4).quit, 0x29, "more axes than the hardware has");
    assert_eq!(b.int(0x1700, 9, 0).quit, 0x22, "currently not used");
    assert_eq!(b.int(0x1700, 21, 0).quit, 0x22);
    // 0800 774 = axis 3, acceleration: 200.0 echoed, read back.
    assert_eq!(q_f(&b.ok(0x0800, 774, Par2::Float(200.0))), 200.0);
    assert_eq!(q_f(&b.ok(0x1800, 774, Par2::Float(0.0))), 200.0);
    assert_eq!(b.c.axis_param(3, 6), Some(200.0));
    // 1800 543 = axis 2, invert encoder direction: 0.0; a switch is 0..1.
    assert_eq!(q_f(&b.ok(0x1800, 543, Par2::Float(0.0))), 0.0);
    assert_eq!(q_f(&b.ok(0x1801, 543, Par2::Float(0.0))), 1.0);
    assert_eq!(b.float(0x0800, 543, 2.0).quit, 0x29);
    // 1801 769 = axis 3 traverse speed maximum: 50000 as printed.
    assert_eq!(q_f(&b.ok(0x1801, 769, Par2::Float(0.0))), 50_000.0);
    assert!(q_f(&b.ok(0x1802, 1030 - 256, Par2::Float(0.0))) > 0.0);
    assert_eq!(b.float(0x1800, 1030, 0.0).quit, 0x20, "axis 4 of 3");
    assert_eq!(b.float(0x1800, 3 * 256 + 51, 0.0).quit, 0x21);
    assert_eq!(b.float(0x1800, 3 * 256, 0.0).quit, 0x21);
    // Fewer configured axes hide the rest.
    b.ok(0x0700, 2, Par2::Int(2));
    assert_eq!(b.float(0x1800, 774, 0.0).quit, 0x20);
    assert_eq!(b.float(0x190C, 3, 0.0).quit, 0x20);
    // Parameters are for home position only (manual 3.1).
    b.ok(0x0700, 2, Par2::Int(3));
    b.online();
    assert_eq!(b.float(0x0800, 774, 100.0).quit, 0x14);
    assert_eq!(b.int(0x1700, 1, 0).quit, 0x14);
}

#[test]
fn wrong_mode_is_inadmissible() {
    let mut b = Bench::new(3);
    for (code, par1, par2) in [
        (0x0A87, 1, Par2::Float(10.0)),
        (0x0A84, 1, Par2::Int(0)),
        (0x0600, 0, Par2::Int(0)),
        (0x0A81, 0, Par2::Int(0)),
        (0x0A41, 0, Par2::Int(0)),
    ] {
        let a = b.cmd(code, par1, par2);
        assert_eq!((a.quit, a.be, a.status), (0x14, true, 1), "{code:04X}");
    }
    b.online();
    assert_eq!(b.int(0x0603, 0, 0).quit, 0x14, "already online");
    assert_eq!(b.int(0x0602, 0, 0).quit, 0x14);
    assert_eq!(b.int(0x0909, 0, 0).quit, 0x14, "manual 5.2.4.15: home position only");
    assert_eq!(b.int(0x0A41, 0, 0).quit, 0x14);
    // Element access is fine in every mode.
    b.ok(0x0906, 7, Par2::Int(-5));
    assert_eq!(b.int(0x1234, 0, 0).quit, 0x13, "unknown code");
    b.ok(0x0A81, 0, Par2::Int(0));
    assert_eq!(b.c.status(), 1);
}

#[test]
fn reference_drive_takes_time_and_sets_the_flag() {
    let mut b = Bench::new(3);
    b.online();
    assert_eq!(b.float(0x0A87, 1, 50.0).quit, 0x2B, "not referenced");
    b.at(1.0);
    let a = b.int(0x0A84, 1, 0);
    assert_eq!((a.quit, a.be), (0, false));
    assert_eq!(b.c.axis_status(1), Some(1));
    assert_eq!(b.c.axis_referenced(1), Some(false));
    // Axis 1 starts at 100 AE: ramp to the switch at 50 AE/s, 2000 AE/s²,
    // then 1 AE off it at creep speed 5 AE/s.
    let dur = profile_time(100.0, 50.0, 2000.0) + profile_time(1.0, 5.0, 2000.0);
    b.at(1.0 + dur / 2.0);
    let p = b.poll();
    assert!(!p.be && p.q_par == Par2::Int(0), "{p:?}");
    assert!(b.c.axis_position(1).unwrap() < 60.0);
    let t1 = b.float(0x190C, 1, 0.0);
    assert_eq!(t1.quit, 0x14, "only polls while waiting");
    b.at(1.0 + dur - 0.001);
    assert!(!b.poll().be);
    b.at(1.0 + dur);
    let p = b.poll();
    assert!(p.be && p.quit == 0, "{p:?}");
    assert_eq!(b.c.axis_referenced(1), Some(true));
    assert_eq!(b.c.axis_status(1), Some(0));
    assert_eq!(b.c.axis_position(1), Some(0.0));
    assert_eq!(q_i(&b.ok(0x1934, 51, Par2::Int(0))), 1, "SM51: axis 1 referenced");
    assert_eq!(q_i(&b.ok(0x1934, 52, Par2::Int(0))), 0);
    b.ok(0x0A87, 1, Par2::Float(50.0));
}

#[test]
fn move_profiles_follow_speed_and_acceleration() {
    let mut b = Bench::new(3);
    b.online_at(3, 0.0);
    b.ok(0x0A8D, 3, Par2::Float(400.0));
    b.ok(0x0A8E, 3, Par2::Float(800.0));
    // Trapezoid: 1000 AE at 400 AE/s, 800 AE/s².
    let a = b.ok(0x0A94, 3, Par2::Float(1000.0));
    assert!(a.be, "start and return");
    assert_eq!(q_f(&a), 0.0);
    let dur = profile_time(1000.0, 400.0, 800.0);
    assert!((dur - 3.0).abs() < 1e-12);
    b.at(0.25);
    assert!((b.c.axis_position(3).unwrap() - 0.5 * 800.0 * 0.0625).abs() < 1e-9);
    assert!((b.c.axis_speed(3).unwrap() - 200.0).abs() < 1e-9);
    assert!((q_f(&b.ok(0x190D, 3, Par2::Float(0.0))) - 200.0).abs() < 1e-9);
    b.at(1.5);
    assert!((b.c.axis_position(3).unwrap() - 500.0).abs() < 1e-9, "the midpoint at half time");
    assert_eq!(q_i(&b.ok(0x1910, 3, Par2::Int(0))), 1);
    assert_eq!(q_i(&b.ok(0x1911, 0, Par2::Int(0))), 0b100);
    b.at(dur - 1e-6);
    assert_eq!(b.c.axis_status(3), Some(1));
    b.at(dur);
    assert_eq!(b.c.axis_status(3), Some(0));
    assert_eq!(q_f(&b.ok(0x190C, 3, Par2::Float(0.0))), 1000.0);
    assert_eq!(q_i(&b.ok(0x1911, 0, Par2::Int(0))), 0);
    // Triangular: 100 AE relative, too short to reach 400 AE/s.
    let a = b.ok(0x0A95, 3, Par2::Float(100.0));
    assert_eq!(q_f(&a), 1000.0);
    assert_eq!(b.c.axis_target(3), Some(1100.0));
    assert_eq!(b.float(0x0A95, 3, 1.0).quit, 0x2A, "already moving");
    b.wait(profile_time(100.0, 400.0, 800.0) + 1e-6);
    assert_eq!(b.c.axis_position(3), Some(1100.0));
    // The online speed is limited by the parameter's limits.
    assert_eq!(b.float(0x0A8D, 3, 60_000.0).quit, 0x29);
    // Leaving online mode resets it: parameter 1 (1000 AE/s) again.
    b.ok(0x0A81, 0, Par2::Int(0));
    b.online();
    let t = b.wait(0.0).now;
    let a = b.ok(0x0A89, 3, Par2::Float(-1100.0));
    assert!(!a.be);
    b.now = t + Duration::from_secs_f64(profile_time(1100.0, 1000.0, 2000.0));
    let p = b.poll();
    assert!(p.be && q_f(&p) == 0.0, "{p:?}");
}

#[test]
fn targets_outside_the_software_limits_answer_65() {
    let mut b = Bench::new(3);
    b.online_at(1, 5.0);
    let a = b.float(0x0A87, 1, 10_000.5);
    assert_eq!((a.quit, a.be), (65, true));
    assert_eq!(b.float(0x0A94, 1, -0.1).quit, 65);
    assert_eq!(b.float(0x0A89, 1, -6.0).quit, 65);
    assert_eq!(b.c.axis_status(1), Some(0), "nothing moved");
    assert_eq!(b.c.busy(), None);
    assert_eq!(q_f(&b.ok(0x1913, 1, Par2::Float(0.0))), 0.0);
    assert_eq!(q_f(&b.ok(0x1914, 1, Par2::Float(0.0))), 10_000.0);
    // G29 (0A86) shifts the limits with the counter; G26 (0A85) does not.
    b.ok(0x0A86, 1, Par2::Float(105.0));
    assert_eq!(b.c.axis_limits(1), Some((100.0, 10_100.0)));
    assert_eq!(b.float(0x0A94, 1, 50.0).quit, 65);
    b.ok(0x0A85, 1, Par2::Int(0));
    assert_eq!(b.c.axis_position(1), Some(0.0));
    assert_eq!(b.float(0x0A86, 1, 1e300).quit, 0x29, "the counter is a 32-bit float");
    assert_eq!(b.float(0x0A89, 1, 1e300).quit, 65);
    assert_eq!(b.c.axis_limits(1), Some((100.0, 10_100.0)));
}

#[test]
fn start_and_wait_refuses_other_commands_but_not_stops() {
    let mut b = Bench::new(3);
    b.online_at(2, 0.0);
    let a = b.float(0x0A87, 2, 3000.0);
    assert!(!a.be);
    b.at(1.0);
    for (code, par2) in [(0x190B, Par2::Int(0)), (0x0906, Par2::Int(1)), (0x0A94, Par2::Float(5.0))] {
        let a = b.cmd(code, 1, par2);
        assert_eq!((a.quit, a.be), (0x14, true), "{code:04X}");
    }
    assert_eq!(b.c.int_register(1), Some(0));
    let p = b.poll();
    assert!(!p.be && p.quit == 0);
    assert!((q_f(&p) - 750.0).abs() < 1e-6, "{p:?}");
    // 0A93 stops with the ramp and waits for standstill itself.
    let a = b.ok(0x0A93, 2, Par2::Float(0.0));
    assert!(!a.be);
    assert_eq!(b.c.busy(), Some(0x0A93));
    b.wait(0.5);
    let p = b.poll();
    assert!(p.be, "{p:?}");
    assert!((q_f(&p) - 1000.0).abs() < 1e-6, "braked from 1000 AE/s at 2000 AE/s²: {p:?}");
    assert_eq!(b.c.axis_status(2), Some(2), "stopped");
    assert_eq!(b.c.status(), 31);
    // 0A9A answers at once.
    b.ok(0x0A87, 2, Par2::Float(3000.0));
    b.wait(0.2);
    let a = b.ok(0x0A9A, 2, Par2::Float(0.0));
    assert!(a.be);
    assert_eq!(b.c.busy(), None);
    assert_eq!(b.c.axis_status(2), Some(1), "still braking");
    b.wait(1.0);
    assert_eq!(b.c.axis_status(2), Some(2));
}

#[test]
fn stop_and_resume_online() {
    let mut b = Bench::new(3);
    b.online_at(1, 0.0);
    b.ok(0x0A96, 2, Par2::Float(0.0));
    b.ok(0x0A94, 1, Par2::Float(5000.0));
    b.ok(0x0A94, 2, Par2::Float(5000.0));
    b.wait(1.0);
    let a = b.ok(0x0600, 0, Par2::Int(0));
    assert_eq!(a.status, 32, "STOP recognized while the axes brake");
    b.wait(0.5);
    assert_eq!(b.c.status(), 35);
    assert_eq!(b.c.axis_status(1), Some(2));
    // A new move resumes online mode.
    let a = b.ok(0x0A94, 1, Par2::Float(0.0));
    assert_eq!(a.status, 31);
    // The external stop input losing power stops too, and blocks moves.
    b.c.set_input_at(b.now, STOP_INPUT, false);
    assert_eq!(b.c.status(), 32);
    assert_eq!(b.float(0x0A94, 2, 0.0).quit, 0x2C);
    b.wait(2.0);
    assert_eq!(b.c.status(), 35);
    b.ok(0x0A81, 0, Par2::Int(0));
    assert_eq!(b.int(0x0603, 0, 0).quit, 0x2C, "manual 5.2.1.3: the stop input must have power");
    b.c.set_input(STOP_INPUT, true);
    b.ok(0x0700, 4, Par2::Int(0));
    assert_eq!(b.int(0x0603, 0, 0).quit, 0x2C, "no stop input defined");
}

#[test]
fn automatic_mode_runs_its_program() {
    let mut b = Bench::new(3);
    let a = b.ok(0x0602, 0, Par2::Int(0));
    assert_eq!(a.status, 11);
    assert_eq!(b.c.output(AUTO_OUTPUT), Some(false));
    b.wait(1.0);
    assert_eq!(b.c.output(AUTO_OUTPUT), Some(true));
    b.wait(1.0);
    assert_eq!(b.c.output(AUTO_OUTPUT), Some(false));
    b.wait(3.0);
    assert_eq!(b.c.output(AUTO_OUTPUT), Some(true), "five toggles in five seconds");
    assert_eq!(b.float(0x0A87, 1, 1.0).quit, 0x14, "no moves outside online mode");
    assert_eq!(b.ok(0x0600, 0, Par2::Int(0)).status, 15);
    b.wait(10.0);
    assert_eq!(b.c.output(AUTO_OUTPUT), Some(true), "the program is stopped");
    assert_eq!(b.ok(0x0602, 0, Par2::Int(0)).status, 11, "manual 5.2.1.1: a repeated start resumes");
    assert_eq!(b.ok(0x0A41, 0, Par2::Int(0)).status, 1);
    // The start input starts it too.
    b.c.set_input_at(b.now, START_INPUT, true);
    assert_eq!(b.c.status(), 11);
}

#[test]
fn limit_switch_stops_the_axis_with_an_error() {
    let mut b = Bench::new(3);
    b.ok(0x0800, 256 + 9, Par2::Float(30_000.0));
    b.online_at(1, 9000.0);
    b.ok(0x0A96, 2, Par2::Float(0.0));
    b.ok(0x0A8D, 2, Par2::Float(500.0));
    b.ok(0x0A94, 2, Par2::Float(9000.0));
    let a = b.float(0x0A87, 1, 25_000.0);
    assert!(a.quit == 0 && !a.be);
    // From 9000 at 1000 AE/s the switch (physical 10005, counter 10005 +
    // 9000 - 100) is reached after the 0.5 s ramp (250 AE) and the rest at
    // full speed.
    let hit = 0.5 + (10_005.0 + 8900.0 - 9250.0) / 1000.0;
    b.at(hit - 0.01);
    assert!(!b.poll().be);
    b.at(hit + 0.01);
    let p = b.poll();
    assert_eq!((p.quit, p.be, p.error), (0x40, true, 529), "{p:?}");
    assert!((b.c.axis_position(1).unwrap() - (10_005.0 + 8900.0)).abs() < 1e-6);
    assert_eq!(b.c.axis_status(1), Some(4));
    assert_eq!(b.c.status(), 37, "axis 2 still brakes");
    b.wait(1.0);
    assert_eq!(b.c.status(), 39);
    assert_eq!(b.c.axis_status(2), Some(2));
    let ext = q_i(&b.ok(0x1921, 1, Par2::Int(0)));
    assert_eq!(ext, 0x0100_0104, "power ready, positive switch activated, fault (as manual 5.2.4.28)");
    assert_eq!(q_i(&b.ok(0x1909, 0, Par2::Int(0))), 529);
    assert_eq!(b.float(0x0A94, 2, 0.0).quit, 0x15);
    // Leaving online mode clears the class 3 error; moving on is refused...
    b.ok(0x0A81, 0, Par2::Int(0));
    assert_eq!((b.c.status(), b.c.error()), (1, 0));
    b.online();
    assert_eq!(b.float(0x0A89, 1, 10.0).quit, 0x40);
    // ...moving back is fine, and without monitoring the switch is passed.
    b.ok(0x0A95, 1, Par2::Float(-10.0));
    b.wait(1.0);
    b.ok(0x0AA2, 0, Par2::Int(0));
    assert_eq!(b.c.limit_monitoring(3), Some(false));
    b.ok(0x0A95, 1, Par2::Float(100.0));
    b.wait(2.0);
    assert_eq!(b.c.axis_status(1), Some(0));
    assert_eq!(b.c.error(), 0);
}

#[test]
fn forced_switches_and_power_show_in_1921() {
    let mut b = Bench::new(3);
    b.online_at(1, 500.0);
    assert_eq!(q_i(&b.ok(0x1921, 1, Par2::Int(0))), 0x0101_0100);
    b.c.force_limit_switch(1, false, Some(true));
    b.c.set_power_ready(1, false);
    assert_eq!(q_i(&b.ok(0x1921, 1, Par2::Int(0))), 0x0001_0000);
    assert_eq!(b.float(0x0A94, 1, 600.0).quit, 0x2E, "power pack not ready");
    b.c.set_power_ready(1, true);
    assert_eq!(b.float(0x0A94, 1, 400.0).quit, 0x40, "towards the activated switch");
    b.ok(0x0A94, 1, Par2::Float(600.0));
}

#[test]
fn axis_on_off_and_measuring_mode() {
    let mut b = Bench::new(3);
    b.online_at(1, 0.0);
    b.ok(0x0A98, 1, Par2::Int(0));
    assert_eq!(b.c.axis_on(1), Some(false));
    assert_eq!(b.float(0x0A94, 1, 10.0).quit, 0x37);
    assert_eq!(q_i(&b.ok(0x1934, 91, Par2::Int(0))), 0, "SM91: not active");
    b.ok(0x0A97, 1, Par2::Int(0));
    b.ok(0x0AA0, 1, Par2::Int(0));
    assert_eq!(b.c.axis_status(1), Some(8));
    assert_eq!(b.float(0x0A94, 1, 10.0).quit, 0x2E);
    b.ok(0x0AA1, 1, Par2::Int(0));
    b.ok(0x0AA1, 1, Par2::Int(0));
    b.ok(0x0A94, 1, Par2::Float(1000.0));
    assert_eq!(b.int(0x0A98, 1, 0).quit, 0x2A);
    assert_eq!(b.int(0x0AA0, 1, 0).quit, 0x2A);
    assert_eq!(b.int(0x0A97, 4, 0).quit, 0x20);
}

#[test]
fn registers_flags_and_words_round_trip() {
    let mut b = Bench::new(3);
    // Manual 5.2.4.9: flag word 2 via M17 := 45F2h.
    assert_eq!(q_i(&b.ok(0x0905, 17, Par2::Int(17906))), 17906);
    for m in [18, 21, 22, 23, 24, 25, 27, 31] {
        assert_eq!(q_i(&b.ok(0x1904, m, Par2::Int(0))), 1, "M{m}");
    }
    assert_eq!(q_i(&b.ok(0x1904, 17, Par2::Int(0))), 0);
    assert_eq!(q_i(&b.ok(0x1905, 32, Par2::Int(0))), 17906);
    b.ok(0x0904, 1024, Par2::Int(1));
    assert_eq!(b.c.flag_word(64), Some(0x8000));
    // Manual 5.2.4.3 / 5.2.4.5: O13 := 1; output word 2 via O25 := 3E11h.
    assert_eq!(q_i(&b.ok(0x0902, 13, Par2::Int(1))), 1);
    assert_eq!(b.c.output(13), Some(true));
    b.ok(0x0903, 25, Par2::Int(15889));
    assert_eq!(q_i(&b.ok(0x1903, 17, Par2::Int(0))), 15889);
    assert_eq!(q_i(&b.ok(0x1902, 26, Par2::Int(0))), 1);
    assert_eq!(q_i(&b.ok(0x1903, 1, Par2::Int(0))), 1 << 12);
    // Inputs come from the bench (manual 5.2.4.2: 8D03h in word 1).
    for i in [1, 2, 9, 11, 12, 16] {
        b.c.set_input(i, true);
    }
    b.c.set_input(2, true);
    assert_eq!(q_i(&b.ok(0x1901, 10, Par2::Int(0))), 36099);
    assert_eq!(b.int(0x0902, 1, 2).quit, 0x29);
    assert_eq!(b.int(0x0903, 1, 65536).quit, 0x29);
    assert_eq!(b.int(0x1900, 0, 0).quit, 0x23);
    assert_eq!(b.int(0x0902, 1025, 1).quit, 0x24);
    assert_eq!(b.int(0x1904, 1025, 0).quit, 0x25);
    assert_eq!(b.int(0x1906, 1025, 0).quit, 0x26);
    assert_eq!(b.float(0x1907, -1, 0.0).quit, 0x27);
    // N registers are 32-bit, R registers 32-bit floats.
    b.ok(0x0906, 1024, Par2::Int(i64::from(i32::MIN)));
    assert_eq!(b.c.int_register(1024), Some(i32::MIN));
    assert_eq!(b.int(0x0906, 1, i64::from(i32::MAX) + 1).quit, 0x29);
    let a = b.ok(0x0907, 9, Par2::Float(0.1));
    assert_eq!(q_f(&a), 0.1000, "written with 4 decimals");
    assert_eq!(b.c.float_register(9), Some(f64::from(0.1f32)));
    assert_eq!(b.float(0x0907, 9, 1e39).quit, 0x29);
    // The controller converts the date: TYP 1 for an integer command is fine when integral.
    assert_eq!(q_i(&b.ok(0x0906, 2, Par2::Float(7.0))), 7);
    assert_eq!(b.float(0x0906, 2, 7.5).quit, 0x29);
}

#[test]
fn errors_read_and_reset() {
    let mut b = Bench::new(3);
    b.c.inject_error(150);
    assert_eq!(b.c.status(), 9, "home position with system error");
    assert_eq!(q_i(&b.ok(0x1909, 0, Par2::Int(0))), 150);
    assert_eq!(q_i(&b.ok(0x0909, 0, Par2::Int(0))), 0);
    assert_eq!((b.c.error(), b.c.status()), (0, 1));
    b.c.inject_error(42);
    let a = b.int(0x0909, 0, 0);
    assert_eq!((a.quit, q_i(&a), a.error), (0x15, 42, 42), "manual 5.2.4.15: class 1 cannot be reset");
    b.c.inject_error(0);
    // Readiness and malfunction outputs, once defined.
    b.ok(0x0700, 6, Par2::Int(100));
    b.ok(0x0700, 7, Par2::Int(101));
    assert_eq!((b.c.output(100), b.c.output(101)), (Some(true), Some(false)));
    b.c.inject_error(600);
    assert_eq!((b.c.output(100), b.c.output(101)), (Some(false), Some(true)));
}

#[test]
fn check_rules_on_input_and_output() {
    let mut b = Bench::new(3);
    let cmd = Command::new(0x190B, 0, Par2::Int(0));
    for rule in [CheckRule::Strict, CheckRule::WithEtx, CheckRule::Omitted] {
        let mut frame = Vec::new();
        cmd.encode_with(&EncodeOptions { check_rule: rule, ..Default::default() }, &mut frame).unwrap();
        let a = b.one(&frame);
        assert_eq!((a.quit, a.status), (0, 1), "{rule:?}");
        assert_eq!(b.c.last_check_rule(), Some(rule));
        assert_eq!(a.check_rule, CheckRule::Strict, "answers use the strict rule by default");
    }
    b.c.set_check_rule(CheckRule::WithEtx);
    assert_eq!(b.one(&cmd.encode().unwrap()).check_rule, CheckRule::WithEtx);
    // A wrong CHECK is command error 0x10.
    let a = b.one(b"\x01\x02190B;0;0;0\x0399\x04");
    assert_eq!((a.quit, a.be), (0x10, true));
}

#[test]
fn garbage_and_broken_frames_resync() {
    let mut b = Bench::new(3);
    let good = Command::new(0x0906, 1, Par2::Int(77)).encode().unwrap();
    // Noise before a frame is skipped without an answer.
    let mut bytes = b"noise\xff\x00;;".to_vec();
    bytes.extend_from_slice(&good);
    let acks = b.acks(&bytes);
    assert_eq!(acks.len(), 1);
    assert_eq!(q_i(&acks[0]), 77);
    // A frame cut off by the next SOH: 0x11, then the next frame runs.
    let mut bytes = b"\x01\x020906;1;0;5".to_vec();
    bytes.extend_from_slice(&Command::new(0x0906, 1, Par2::Int(78)).encode().unwrap());
    let acks = b.acks(&bytes);
    assert_eq!(acks.iter().map(|a| a.quit).collect::<Vec<_>>(), vec![0x11, 0]);
    assert_eq!(b.c.int_register(1), Some(78));
    // SOH without STX: 0x12; missing fields 0x11; bad CMD 0x13.
    assert_eq!(b.one(b"\x01x").quit, 0x12);
    let mut frame = |body: &[u8]| {
        let mut f = vec![1, 2];
        f.extend_from_slice(body);
        f.push(3);
        f.extend_from_slice(CheckRule::Strict.compute(body).to_string().as_bytes());
        f.push(4);
        b.one(&f).quit
    };
    assert_eq!(frame(b"0906;1;0"), 0x11);
    assert_eq!(frame(b"0906;1;0;1;2"), 0x11);
    assert_eq!(frame(b"09G6;1;0;1"), 0x13);
    assert_eq!(frame(b"0906;1;2;1"), 0x29);
    // Split anywhere: one byte at a time.
    let mut out = Vec::new();
    for byte in Command::new(0x1906, 1, Par2::Int(0)).encode().unwrap() {
        b.c.handle_bytes(b.now, &[byte], &mut out);
    }
    assert_eq!(Ack::decode(&out).unwrap().q_par, Par2::Int(78));
}

#[test]
fn bytes_with_bit_7_set_are_masked() {
    let mut b = Bench::new(3);
    let frame: Vec<u8> = Command::new(0x0906, 4, Par2::Int(-9)).encode().unwrap().iter().map(|x| x | 0x80).collect();
    let a = b.one(&frame);
    assert_eq!(a.quit, 0);
    assert_eq!(b.c.int_register(4), Some(-9));
}

#[test]
fn polls_repeat_the_last_acknowledge() {
    let mut b = Bench::new(3);
    let p = b.poll();
    assert_eq!((p.quit, p.be, p.status), (0, true, 1));
    let a = b.ok(0x0906, 1, Par2::Int(5));
    assert_eq!(b.poll(), a, "a lost acknowledge can be asked for again");
    b.online();
    let p = b.poll();
    assert_eq!(p.status, 31);
    assert_eq!(b.int(0x0A83, 9, 0).quit, 0x20);
    assert_eq!(b.poll().quit, 0x20);
}

#[test]
fn manual_moves_need_keepalive() {
    let mut b = Bench::new(3);
    b.online_at(1, 0.0);
    let a = b.ok(0x0A90, 1, Par2::Float(5000.0));
    assert!(a.be);
    // Manual speed 200 AE/s: after 0.9 s keep it going.
    b.wait(0.9);
    assert_eq!(b.c.axis_status(1), Some(1));
    let p = b.ok(0x0A92, 1, Par2::Float(0.0));
    assert!(q_f(&p) > 100.0);
    b.wait(0.9);
    assert_eq!(b.c.axis_status(1), Some(1));
    // No keepalive: brakes 1 s after the last one (at 1.9 s, for 0.1 s).
    b.wait(0.15);
    assert_eq!(b.c.axis_status(1), Some(1), "braking");
    b.wait(0.1);
    assert_eq!(b.c.axis_status(1), Some(2));
    let pos = b.c.axis_position(1).unwrap();
    assert!((pos - (0.5 * 2000.0 * 0.01 + 200.0 * (1.9 - 0.1) + 0.5 * 2000.0 * 0.01)).abs() < 1e-6, "{pos}");
}

#[test]
fn conditional_moves_stop_when_the_element_changes() {
    let mut b = Bench::new(3);
    b.online_at(1, 0.0);
    // Axis 1 may move while input 7 is 1.
    let cond = Condition { while_state: true, element: ElementType::Input, number: 7 };
    b.ok(0x0AA3, 1, Par2::Int(cond.encode()));
    b.ok(0x0A94, 1, Par2::Float(100.0));
    assert_eq!(b.c.axis_status(1), Some(2), "false at the start: no move");
    b.c.set_input(7, true);
    b.ok(0x0AA3, 1, Par2::Int(cond.encode()));
    b.ok(0x0A94, 1, Par2::Float(5000.0));
    b.wait(1.0);
    b.c.set_input_at(b.now, 7, false);
    b.wait(1.0);
    assert_eq!(b.c.axis_status(1), Some(2));
    assert!(b.c.axis_position(1).unwrap() < 2000.0);
    // Armed for one move only.
    b.ok(0x0A94, 1, Par2::Float(0.0));
    b.wait(5.0);
    assert_eq!(b.c.axis_status(1), Some(0));
    assert_eq!(b.int(0x0AA3, 1, 0x0401_0001).quit, 0x29);
    assert_eq!(b.int(0x0AA3, 0, 0x0102_0000).quit, 0x24);
}

#[test]
fn time_never_runs_backwards_and_polling_is_invariant() {
    let mut a = Bench::new(3);
    let mut b = Bench::new(3);
    b.t0 = a.t0;
    b.c = PacController::new(3, a.t0);
    for x in [&mut a, &mut b] {
        x.online_at(1, 0.0);
        x.ok(0x0A94, 1, Par2::Float(3333.0));
    }
    for i in 1..=400 {
        a.at(f64::from(i) * 0.01);
    }
    b.at(4.0);
    assert_eq!(a.c.axis_position(1), b.c.axis_position(1));
    b.c.advance(b.t0);
    assert_eq!(a.c.axis_position(1), b.c.axis_position(1));
}

fn arb_command() -> impl Strategy<Value = Command> {
    let codes: Vec<u16> = table::COMMANDS.iter().map(|c| c.code).chain([0x0000, 0xFFFF]).collect();
    (
        proptest::sample::select(codes),
        prop_oneof![-2i64..20, 0i64..5000, any::<i64>()],
        prop_oneof![
            (-3i64..3).prop_map(Par2::Int),
            any::<i32>().prop_map(|v| Par2::Int(v.into())),
            (-20_000.0f64..20_000.0).prop_map(Par2::Float),
            any::<f32>().prop_filter("finite", |v| v.is_finite()).prop_map(|v| Par2::Float(v.into())),
        ],
    )
        .prop_map(|(code, par1, par2)| Command::new(code, par1, par2))
}

proptest! {
    #[test]
    fn never_panics_on_random_bytes(chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..64), 0..16)) {
        let mut b = Bench::new(3);
        for (i, c) in chunks.iter().enumerate() {
            b.at(i as f64 * 0.3);
            let out = b.raw(c);
            let mut d = AckDecoder::new();
            d.push(&out);
            while let Some(a) = d.next() {
                prop_assert!(a.is_ok(), "{:?}", a);
            }
        }
    }

    #[test]
    fn never_panics_on_random_commands(
        cmds in proptest::collection::vec((arb_command(), 0.0f64..3.0, any::<bool>(), any::<u16>()), 0..40),
        axes in 0u8..20,
    ) {
        let t0 = Instant::now();
        let mut c = PacController::new(axes, t0);
        let mut t = 0.0;
        let mut out = Vec::new();
        for (cmd, dt, poll, input) in cmds {
            t += dt;
            let now = t0 + Duration::from_secs_f64(t);
            out.clear();
            c.handle_bytes(now, &cmd.encode().unwrap(), &mut out);
            if poll {
                c.handle_bytes(now, &[0x04], &mut out);
            }
            c.set_input_at(now, input % 1100, input % 2 == 0);
            let mut d = AckDecoder::new();
            d.push(&out);
            let mut n = 0;
            while let Some(a) = d.next() {
                prop_assert!(a.is_ok(), "{:?}", a);
                n += 1;
            }
            prop_assert_eq!(n, 1 + usize::from(poll), "one acknowledge per command and poll");
            for axis in 1..=c.axes() {
                prop_assert!(c.axis_position(axis).unwrap().is_finite());
            }
        }
    }
}
