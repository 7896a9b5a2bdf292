//! A simulated PA-CONTROL positioning controller behind its RS232 online
//! command port (specs/pa-control-interfaces.txt chapters 3, 5 and 6, with
//! the corrections of specs/README.md).
//!
//! # Driving it
//!
//! Sans-IO and clock-injected: every entry point takes `now`; nothing reads a
//! clock. [`PacController::handle_bytes`] takes the host's bytes split
//! anywhere (the [`CommandDecoder`] masks them to 7 bits, so 8-bit garbage
//! from a pty is harmless) and appends the acknowledges. Motion is a
//! closed-form function of time (the PowerCube simulator's `traj`), and
//! timed events (end of a move, a limit switch reached, a manual move not
//! kept alive) are applied at the exact instant they fall on, lazily,
//! whenever the controller is next touched: one `advance` after 10 s gives
//! the same state as a thousand calls. Time never runs backwards.
//!
//! Every command, status and error number comes from
//! [`crate::proto::pac::table`]; the simulated configuration (parameter
//! values and limits, switch positions) is in `config.rs`.
//!
//! # Behaviour
//!
//! - **Power-up**: home position (status 1), error 0, `axes` axes (system
//!   parameter 2, at most 16) standing at 100 AE * axis number, switched on,
//!   power packs ready, not referenced. Input 2, the external stop input
//!   (system parameter 4), is powered; input 1 is the start input.
//! - **Operating modes** (6.4): 0602 starts automatic mode (status 11) from
//!   home, or resumes it from 15 (manual 5.2.1.1 says the program continues
//!   after a repeated start); a rising edge on the start input does the
//!   same. 0603 starts online mode (31) and needs the stop input defined and
//!   powered, else command error 0x2C. Both check the axis parameters first
//!   (creep speed above reference speed: 0x66, start-stop speed above
//!   traverse speed: 0x68). 0600 (or the stop input losing power) stops:
//!   moving axes brake at their acceleration, status 12 / 32 until they
//!   stand, then 15 / 35. A move command in 35 resumes online mode (31); the
//!   manual has no other way out of 35 but 0A81. 0A41 / 0A81 return to home
//!   position at once: the axes stop where they are ("the current position
//!   taken over"), online speeds and accelerations are reset, errors of
//!   class 3 (500-999) are cleared. Home position with an error of class 1
//!   or 2 is status 9.
//! - **The automatic program** toggles output 16 every second while
//!   automatic mode runs; it moves no axis.
//! - **Commands outside their modes** (the table's modes, manual 3.1):
//!   command error 0x14 "inadmissible command", the answer manual 5.2.4.15
//!   gives for 0909 outside home position. Unknown codes: 0x13.
//! - **Parameters and elements**: a PAR_1 outside the configured range
//!   answers 0x20 (axis, also beyond system parameter 2), 0x21 (axis
//!   parameter), 0x22 (system parameter, including those "currently not
//!   used"), 0x23..0x27 (input, output, flag, N, R); a command date out of
//!   range 0x29 (limits as 1701/1702/1801/1802 answer them; also a TYP 1
//!   date that is not integral where an integer is expected: the controller
//!   converts the date to the command's type, so either TYP is accepted).
//!   R registers keep 32-bit floats.
//! - **Axes**: moves need the axis released (reference drive, 0A83 or 0A96;
//!   else 0x2B), switched on (0x37), its power pack ready and not in
//!   measuring mode (0x2E), standing (0x2A), the stop input powered (0x2C),
//!   no malfunction (0x15), the target inside the software limits (axis
//!   parameters 8 / 9, shifted by 0A86 as G29 does; else 0x41 = 65) and, with
//!   monitoring on, no activated limit switch in the direction of travel
//!   (0x40). Profiles are trapezoidal (triangular when short) at the online
//!   speed / acceleration (0A8D / 0A8E, limited by parameters 1 / 6) or
//!   parameters 1 / 6. The reference drive runs at the reference speed to
//!   the reference switch, then 1 AE off it at creep speed, and sets the
//!   counter to 0 and the referenced flag. Manual moves (0A90 / 0A91) run at
//!   the manual speed and brake unless 0A92 follows within 1 s.
//! - **Limit switches** sit 5 AE outside the default traverse area (physical
//!   -5 and 10005); the bench can force them ([`PacController::force_limit_switch`]).
//!   Reaching one with monitoring on (0AA2; always on after 0603) stops that
//!   axis dead (status 4), raises error 529 (positive, manual 5.2.4.16) or
//!   530 (negative), brakes the other axes and sets status 37, then 39;
//!   moves answer 0x15 until 0A81.
//! - **0AA3** arms a condition for the axis' next move: it runs only while
//!   the element has the state, and brakes (status 2) when it changes; a
//!   move whose condition is false at the start does not start.
//! - **Start and wait** (0A87, 0A89, and 0A84 and 0A93, which the table
//!   also marks as waiting): the first acknowledge has BE = 0 (unless the
//!   move is already over) and the start position; each poll (lone EOT)
//!   answers the current position, BE = 1 once the axis stands. A move
//!   ended by a limit switch answers QUIT 0x40 then. While such a command is
//!   unfinished the manual allows only polls (5.2.6.6); any other command
//!   is refused with 0x14 and the move goes on, except the stop commands
//!   0600, 0A93, 0A9A and 0A81, which a user must always be able to send
//!   (the simulator's choice: the manual does not say). They end the wait.
//! - **Polls** with nothing pending repeat the last acknowledge with the
//!   current STATUS and ERROR (recovering a lost acknowledge without
//!   running a command twice); before any command they answer QUIT 0.
//! - **Frame errors** are answered (BE = 1, Q_PAR 0): wrong CHECK 0x10 (any
//!   CHECK matching either rule of the specs README is right, and `0` means
//!   "not computed", manual 3.1), SOH without STX 0x12, a frame cut short or
//!   with missing / extra fields 0x11, a CMD that is not 4 hex digits 0x13,
//!   other unreadable fields 0x29. Bytes outside frames are skipped silently.
//!   A frame error does not end a pending wait.
//! - **Acknowledges** use CHECK without ETX ([`CheckRule::Strict`]) unless
//!   [`PacController::set_check_rule`] says otherwise, and write floats as
//!   the manual's examples do: positions and parameters with 3 decimals,
//!   R registers with 4.
//! - **Other reads**: 190D is the speed's magnitude, 190E the counter (the
//!   encoder follows exactly), 190F / 1915 answer 0.0, 1920 35.0 °C. System
//!   elements (6.2): SM51.. referenced, SM91.. active (on, not measuring),
//!   SM231.. fault, SN10 error number, SN71.. axis status, SR51.. position
//!   when switched off, SR71.. last target; others read 0. If system
//!   parameters 6 / 7 name outputs, they show readiness (no error) and
//!   malfunction (an error).
//! - 0A98 (axis off) and 0AA0 (measuring mode) refuse a moving axis (0x2A);
//!   0AA1 on an axis not in measuring mode only acknowledges (5.2.6.21).
//!   0909 resets errors of classes 2 and 3 and answers 0x15 with the error
//!   number for class 1 (5.2.4.15). [`PacController::inject_error`] raises
//!   any error from the bench side.

mod axis;
mod config;

#[cfg(test)]
mod tests;

use std::time::Instant;

use crate::link::mem::ByteDevice;
use crate::proto::pac::frame::{FloatFormat, FrameError};
use crate::proto::pac::table::{self, CommandDef, Condition, DataType, ElementType, Mode};
use crate::proto::pac::{Ack, CheckRule, Command, CommandDecoder, Par2, Request};
use axis::{Axis, Event, MotionKind, Rest};

pub use config::{AUTO_OUTPUT, START_INPUT, STOP_INPUT};

const ELEMENTS: usize = 1024;
const WORDS: usize = ELEMENTS / 16;

/// Command error numbers (manual 6.5) the simulator answers.
mod quit {
    pub const CHECK: u16 = 0x10;
    pub const SEQUENCE_SETUP: u16 = 0x11;
    pub const SEQUENCE_BEGINNING: u16 = 0x12;
    pub const UNKNOWN_COMMAND: u16 = 0x13;
    pub const INADMISSIBLE: u16 = 0x14;
    pub const NOT_EXECUTABLE: u16 = 0x15;
    pub const AXIS: u16 = 0x20;
    pub const AXIS_PARAM: u16 = 0x21;
    pub const SYSTEM_PARAM: u16 = 0x22;
    pub const INPUT: u16 = 0x23;
    pub const OUTPUT: u16 = 0x24;
    pub const FLAG: u16 = 0x25;
    pub const N_REG: u16 = 0x26;
    pub const R_REG: u16 = 0x27;
    pub const RANGE: u16 = 0x29;
    pub const MOVING: u16 = 0x2A;
    pub const NO_REFERENCE: u16 = 0x2B;
    pub const NO_EXT_STOP: u16 = 0x2C;
    pub const NOT_READY: u16 = 0x2E;
    pub const NOT_ON: u16 = 0x37;
    pub const LIMIT_SWITCH: u16 = 0x40;
    pub const OUTSIDE: u16 = 0x41;
    pub const CREEP_TOO_HIGH: u16 = 0x66;
    pub const INITIAL_TOO_HIGH: u16 = 0x68;
}

/// Commands executed even while a start-and-wait command is unfinished.
const STOP_CODES: [u16; 4] = [0x0600, 0x0A93, 0x0A9A, 0x0A81];

#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Home,
    Auto { running: bool, since: f64 },
    Online(Online),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Online {
    Running,
    Stopping,
    Malfunction,
}

/// An unfinished start-and-wait command.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Pending {
    code: u16,
    axis: usize,
    motion: u64,
}

/// What a command answers when it is accepted.
struct Done {
    q: f64,
    wait: Option<(usize, u64)>,
}

impl Done {
    fn q(q: f64) -> Result<Self, u16> {
        Ok(Self { q, wait: None })
    }
}

/// One PA-CONTROL with its axes, inputs, outputs, flags and registers.
#[derive(Debug, Clone)]
pub struct PacController {
    origin: Instant,
    /// Seconds since `origin` the controller has run to.
    t: f64,
    axes: Vec<Axis>,
    op: Op,
    error: u16,
    inputs: [u16; WORDS],
    outputs: [u16; WORDS],
    flags: [u16; WORDS],
    n_regs: Vec<i32>,
    r_regs: Vec<f32>,
    /// System parameters 1..=20 at index 0..20.
    sys_params: [i64; 20],
    decoder: CommandDecoder,
    check_rule: CheckRule,
    pending: Option<Pending>,
    last: Option<(Ack, FloatFormat)>,
    last_rule: Option<CheckRule>,
    next_motion: u64,
}

impl PacController {
    /// A controller with `axes` axes (at most 16), powered up at `now` in
    /// home position (status 1).
    pub fn new(axes: u8, now: Instant) -> Self {
        let hw = axes.min(table::MAX_AXES);
        let mut sys_params = [0; 20];
        for (i, p) in sys_params.iter_mut().enumerate() {
            *p = config::system_param(i as i64 + 1, hw).map_or(0, |c| c.0);
        }
        let mut c = Self {
            origin: now,
            t: 0.0,
            axes: (1..=hw).map(Axis::new).collect(),
            op: Op::Home,
            error: 0,
            inputs: [0; WORDS],
            outputs: [0; WORDS],
            flags: [0; WORDS],
            n_regs: vec![0; ELEMENTS],
            r_regs: vec![0.0; ELEMENTS],
            sys_params,
            decoder: CommandDecoder::new(),
            check_rule: CheckRule::Strict,
            pending: None,
            last: None,
            last_rule: None,
            next_motion: 0,
        };
        set_bit(&mut c.inputs, STOP_INPUT, true);
        c
    }

    fn secs(&self, now: Instant) -> f64 {
        now.saturating_duration_since(self.origin).as_secs_f64()
    }

    /// RS232 bytes from the host, split anywhere; acknowledges are appended to `out`.
    pub fn handle_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.advance(now);
        self.decoder.push(bytes);
        while let Some(req) = self.decoder.next() {
            match req {
                Ok(Request::Poll) => self.answer_poll(out),
                Ok(Request::Command { command, check_rule }) => {
                    self.last_rule = Some(check_rule);
                    self.execute(&command, out);
                }
                Err(e) => {
                    if let Some(q) = frame_error_quit(&e) {
                        let ack = self.ack(q, true, Par2::Int(0));
                        self.send(ack, FloatFormat::Fixed(3), out);
                    }
                }
            }
        }
    }

    /// Runs the controller up to `now` (moves, reference drives, the automatic program).
    pub fn advance(&mut self, now: Instant) {
        let t = self.secs(now);
        self.run_to(t);
    }

    /// The operating status of manual 6.4 (1 home, 11 automatic, 31 online, ...).
    pub fn status(&self) -> u16 {
        let moving = self.axes.iter().any(Axis::moving);
        match self.op {
            Op::Home if (1..500).contains(&self.error) => 9,
            Op::Home => 1,
            Op::Auto { running: true, .. } => 11,
            Op::Auto { running: false, .. } if moving => 12,
            Op::Auto { running: false, .. } => 15,
            Op::Online(Online::Running) => 31,
            Op::Online(Online::Stopping) if moving => 32,
            Op::Online(Online::Stopping) => 35,
            Op::Online(Online::Malfunction) if moving => 37,
            Op::Online(Online::Malfunction) => 39,
        }
    }

    /// The PA-CONTROL error number (Exxx); 0 = none.
    pub fn error(&self) -> u16 {
        self.error
    }

    /// Axes the controller has (the maximum of system parameter 2).
    pub fn axes(&self) -> u8 {
        self.axes.len() as u8
    }

    fn axis(&self, axis: u8) -> Option<&Axis> {
        self.axes.get(usize::from(axis).checked_sub(1)?)
    }

    fn axis_mut(&mut self, axis: u8) -> Option<&mut Axis> {
        self.axes.get_mut(usize::from(axis).checked_sub(1)?)
    }

    /// The position counter of an axis, in axis units (AE).
    pub fn axis_position(&self, axis: u8) -> Option<f64> {
        Some(self.axis(axis)?.position(self.t))
    }

    /// The current traverse speed of an axis (AE/s, magnitude).
    pub fn axis_speed(&self, axis: u8) -> Option<f64> {
        Some(self.axis(axis)?.speed(self.t))
    }

    /// The 1910 axis status (0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring mode).
    pub fn axis_status(&self, axis: u8) -> Option<u8> {
        Some(self.axis(axis)?.status())
    }

    /// The 1921 extended axis status word.
    pub fn axis_ext_status(&self, axis: u8) -> Option<u32> {
        Some(self.axis(axis)?.ext_status(self.t))
    }

    /// Whether the axis has been referenced (reference drive or 0A96).
    pub fn axis_referenced(&self, axis: u8) -> Option<bool> {
        Some(self.axis(axis)?.referenced)
    }

    /// Whether the axis is released for traversing (referenced or 0A83).
    pub fn axis_released(&self, axis: u8) -> Option<bool> {
        Some(self.axis(axis)?.released)
    }

    /// Whether the axis is switched on (0A97 / 0A98).
    pub fn axis_on(&self, axis: u8) -> Option<bool> {
        Some(self.axis(axis)?.on)
    }

    /// Whether the axis is in measuring mode (0AA0 / 0AA1).
    pub fn axis_measuring(&self, axis: u8) -> Option<bool> {
        Some(self.axis(axis)?.measuring)
    }

    /// Where the axis' current motion ends, on the counter's scale.
    pub fn axis_target(&self, axis: u8) -> Option<f64> {
        let a = self.axis(axis)?;
        a.motion.and_then(|_| a.traj.end_pos()).map(|p| p - a.offset)
    }

    /// The software limits of an axis (1913 / 1914).
    pub fn axis_limits(&self, axis: u8) -> Option<(f64, f64)> {
        Some(self.axis(axis)?.limits())
    }

    /// An axis parameter (0800 list) of an axis.
    pub fn axis_param(&self, axis: u8, param: u8) -> Option<f64> {
        let a = self.axis(axis)?;
        (1..=50).contains(&param).then(|| a.param(param))
    }

    /// Whether limit switch monitoring is on for an axis (0AA2).
    pub fn limit_monitoring(&self, axis: u8) -> Option<bool> {
        Some(self.axis(axis)?.monitoring)
    }

    /// The bench side changes an input (1..=1024), at the latest instant the
    /// controller has seen (call [`advance`](Self::advance) first, or use
    /// [`set_input_at`](Self::set_input_at)). Numbers out of range are ignored.
    pub fn set_input(&mut self, n: u16, on: bool) {
        if !(1..=ELEMENTS as u16).contains(&n) || get_bit(&self.inputs, n) == on {
            return;
        }
        set_bit(&mut self.inputs, n, on);
        let t = self.t;
        if n == self.sys_param_element(4) && !on {
            self.stop_all_modes(t);
        }
        if n == self.sys_param_element(3) && on {
            // A start input edge acts as 0602 would; refusals stay silent.
            let _ = self.start_auto(t);
        }
        self.check_conditions(t);
    }

    /// [`set_input`](Self::set_input) at `now`.
    pub fn set_input_at(&mut self, now: Instant, n: u16, on: bool) {
        self.advance(now);
        self.set_input(n, on);
    }

    pub fn input(&self, n: u16) -> Option<bool> {
        element_ok(n).then(|| get_bit(&self.inputs, n))
    }

    pub fn output(&self, n: u16) -> Option<bool> {
        element_ok(n).then(|| get_bit(&self.outputs, n))
    }

    pub fn flag(&self, n: u16) -> Option<bool> {
        element_ok(n).then(|| get_bit(&self.flags, n))
    }

    /// The 16 outputs of output word `word` (1 = outputs 1..16).
    pub fn output_word(&self, word: u16) -> Option<u16> {
        self.outputs.get(usize::from(word).checked_sub(1)?).copied()
    }

    /// The 16 inputs of input word `word`.
    pub fn input_word(&self, word: u16) -> Option<u16> {
        self.inputs.get(usize::from(word).checked_sub(1)?).copied()
    }

    /// The 16 flags of flag word `word`.
    pub fn flag_word(&self, word: u16) -> Option<u16> {
        self.flags.get(usize::from(word).checked_sub(1)?).copied()
    }

    /// Integer register N (1..=1024).
    pub fn int_register(&self, n: u16) -> Option<i32> {
        self.n_regs.get(usize::from(n).checked_sub(1)?).copied()
    }

    /// Real number register R (1..=1024), a 32-bit float in the controller.
    pub fn float_register(&self, n: u16) -> Option<f64> {
        self.r_regs.get(usize::from(n).checked_sub(1)?).map(|v| f64::from(*v))
    }

    /// A system parameter (0700 list).
    pub fn system_param(&self, n: u16) -> Option<i64> {
        config::system_param(n.into(), self.axes())?;
        Some(self.sys_params[usize::from(n) - 1])
    }

    /// The bench side: an axis' power pack ready or not.
    pub fn set_power_ready(&mut self, axis: u8, ready: bool) {
        if let Some(a) = self.axis_mut(axis) {
            a.power_ready = ready;
        }
    }

    /// The bench side: force a limit switch activated (`Some(true)`, e.g. a
    /// broken cable), not activated (`Some(false)`), or back to following
    /// the axis position (`None`). Takes effect for the next move.
    pub fn force_limit_switch(&mut self, axis: u8, positive: bool, state: Option<bool>) {
        if let Some(a) = self.axis_mut(axis) {
            a.forced[usize::from(positive)] = state;
        }
    }

    /// The bench side: a moving axis runs onto the limit switch ahead of it
    /// now (as with a jammed or misplaced switch): it halts with status 4 and
    /// E_LIMIT_*, exactly as when the switch is reached. A standing axis is
    /// left alone.
    pub fn trip_axis(&mut self, now: Instant, axis: u8) {
        self.advance(now);
        let t = self.t;
        let Some(a) = self.axis(axis).filter(|a| a.moving()) else { return };
        let positive = a.kin(t).vel >= 0.0;
        self.apply_event(usize::from(axis) - 1, Event::LimitSwitch { positive });
    }

    /// The bench side: raise a PA-CONTROL error (0 clears it).
    pub fn inject_error(&mut self, error: u16) {
        self.error = error;
        self.sync_signal_outputs();
    }

    /// Which CHECK rule the acknowledges use (default [`CheckRule::Strict`]).
    pub fn set_check_rule(&mut self, rule: CheckRule) {
        self.check_rule = rule;
    }

    /// The CHECK rule the last command frame matched.
    pub fn last_check_rule(&self) -> Option<CheckRule> {
        self.last_rule
    }

    /// Whether a start-and-wait command (0A87 / 0A89 / 0A84 / 0A93) is
    /// unfinished, and which.
    pub fn busy(&self) -> Option<u16> {
        self.pending.map(|p| p.code)
    }

    /// The instant the controller was powered up.
    pub fn powered_up(&self) -> Instant {
        self.origin
    }

    // -----------------------------------------------------------------------
    // Time

    fn run_to(&mut self, t: f64) {
        if t < self.t {
            return;
        }
        loop {
            let from = self.t;
            let next = self
                .axes
                .iter()
                .enumerate()
                .filter_map(|(i, a)| a.next_event(from).map(|(te, ev)| (te, i, ev)))
                .filter(|(te, ..)| *te <= t)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let Some((te, i, ev)) = next else { break };
            self.auto_ticks(te);
            self.t = te.max(self.t);
            self.apply_event(i, ev);
        }
        self.auto_ticks(t);
        self.t = t;
    }

    fn apply_event(&mut self, i: usize, ev: Event) {
        let t = self.t;
        match ev {
            Event::End => self.axes[i].finish(t),
            Event::ManualTimeout => {
                let id = self.motion_id();
                self.axes[i].stop(t, id);
            }
            Event::LimitSwitch { positive } => {
                self.axes[i].halt(t, Rest::Fault);
                self.error = if positive { config::E_LIMIT_POSITIVE } else { config::E_LIMIT_NEGATIVE };
                if let Op::Online(_) = self.op {
                    self.op = Op::Online(Online::Malfunction);
                }
                for j in 0..self.axes.len() {
                    let id = self.motion_id();
                    self.axes[j].stop(t, id);
                }
                self.sync_signal_outputs();
            }
        }
    }

    /// The automatic program: toggles [`AUTO_OUTPUT`] every [`config::AUTO_PERIOD`].
    fn auto_ticks(&mut self, t: f64) {
        if let Op::Auto { running: true, since } = self.op {
            let ticks = |x: f64| ((x - since) / config::AUTO_PERIOD).floor().max(0.0) as u64;
            if (ticks(t) - ticks(self.t.max(since))) % 2 == 1 {
                let on = get_bit(&self.outputs, AUTO_OUTPUT);
                set_bit(&mut self.outputs, AUTO_OUTPUT, !on);
                self.check_conditions(self.t);
            }
        }
    }

    fn motion_id(&mut self) -> u64 {
        self.next_motion += 1;
        self.next_motion
    }

    // -----------------------------------------------------------------------
    // Acknowledges

    fn ack(&self, quit: u16, be: bool, q_par: Par2) -> Ack {
        Ack { quit, be, status: self.status(), error: self.error, q_par, check_rule: self.check_rule }
    }

    fn send(&mut self, ack: Ack, fmt: FloatFormat, out: &mut Vec<u8>) {
        // Only finite floats reach here (register and parameter values are
        // checked on the way in); a failure would mean no answer at all.
        if ack.encode_with(fmt, out).is_err() {
            let fallback = Ack { q_par: Par2::Int(0), ..ack };
            let _ = fallback.encode_with(fmt, out);
        }
    }

    fn answer_poll(&mut self, out: &mut Vec<u8>) {
        if let Some(p) = self.pending {
            let def = table::command(p.code).expect("pending codes come from the table");
            let a = &self.axes[p.axis];
            let running = a.motion.is_some_and(|m| m.id == p.motion);
            let quit = if !running && a.rest == Rest::Fault { quit::LIMIT_SWITCH } else { 0 };
            let q = if def.ack == table::AckKind::None { 0.0 } else { a.position(self.t) };
            let ack = self.ack(quit, !running, par2(def, q));
            if !running {
                self.pending = None;
                self.last = Some((ack, float_format(def)));
            }
            self.send(ack, float_format(def), out);
        } else if let Some((last, fmt)) = self.last {
            let ack = Ack { status: self.status(), error: self.error, check_rule: self.check_rule, ..last };
            self.send(ack, fmt, out);
        } else {
            let ack = self.ack(0, true, Par2::Int(0));
            self.send(ack, FloatFormat::Fixed(3), out);
        }
    }

    fn execute(&mut self, cmd: &Command, out: &mut Vec<u8>) {
        let Some(def) = table::command(cmd.code) else {
            let ack = self.ack(quit::UNKNOWN_COMMAND, true, Par2::Int(0));
            return self.send(ack, FloatFormat::Fixed(3), out);
        };
        let fmt = float_format(def);
        if self.pending.is_some() && !STOP_CODES.contains(&def.code) {
            let ack = self.ack(quit::INADMISSIBLE, true, par2(def, 0.0));
            return self.send(ack, fmt, out);
        }
        let t = self.t;
        match self.run(def, cmd, t) {
            Ok(done) => {
                self.sync_signal_outputs();
                let mut be = true;
                self.pending = None;
                if let Some((axis, motion)) = done.wait {
                    if self.axes[axis].motion.is_some_and(|m| m.id == motion) {
                        be = false;
                        self.pending = Some(Pending { code: def.code, axis, motion });
                    }
                }
                let ack = self.ack(0, be, par2(def, done.q));
                if be {
                    self.last = Some((ack, fmt));
                }
                self.send(ack, fmt, out);
            }
            Err(q) => {
                // Manual 5.2.4.15: an error 0909 cannot reset comes back in
                // the acknowledge date.
                let date = if def.code == 0x0909 { f64::from(self.error) } else { 0.0 };
                let ack = self.ack(q, true, par2(def, date));
                if self.pending.is_none() {
                    self.last = Some((ack, fmt));
                }
                self.send(ack, fmt, out);
            }
        }
    }

    // -----------------------------------------------------------------------
    // Commands

    fn mode(&self) -> Mode {
        table::mode_of_status(self.status()).unwrap_or(Mode::Home)
    }

    /// Number of configured axes (system parameter 2, at most the hardware's).
    fn configured_axes(&self) -> usize {
        usize::try_from(self.sys_params[1]).unwrap_or(0).min(self.axes.len())
    }

    fn sys_param_element(&self, n: usize) -> u16 {
        u16::try_from(self.sys_params[n - 1]).unwrap_or(0)
    }

    fn axis_index(&self, par1: i64) -> Result<usize, u16> {
        match usize::try_from(par1) {
            Ok(a) if (1..=self.configured_axes()).contains(&a) => Ok(a - 1),
            _ => Err(quit::AXIS),
        }
    }

    /// The axes PAR_1 names where 0 means all.
    fn axes_or_all(&self, par1: i64) -> Result<Vec<usize>, u16> {
        if par1 == 0 {
            Ok((0..self.configured_axes()).collect())
        } else {
            self.axis_index(par1).map(|i| vec![i])
        }
    }

    fn run(&mut self, def: &'static CommandDef, cmd: &Command, t: f64) -> Result<Done, u16> {
        let resume_auto = def.code == 0x0602 && self.status() == 15;
        if !def.modes.contains(self.mode()) && !resume_auto {
            return Err(quit::INADMISSIBLE);
        }
        let par1 = cmd.par1;
        // The controller converts the date to the command's type (manual 3.3).
        let value = cmd.par2.as_f64();
        let int = || cmd.par2.as_i64().ok_or(quit::RANGE);
        let element = |what: u16| match u16::try_from(par1) {
            Ok(n) if element_ok(n) => Ok(n),
            _ => Err(what),
        };
        match def.code {
            0x0600 => {
                self.stop_all_modes(t);
                Done::q(0.0)
            }
            0x0602 => self.start_auto(t).map(|_| Done { q: 0.0, wait: None }),
            0x0603 => {
                self.check_ext_stop()?;
                self.check_axis_params()?;
                for a in &mut self.axes {
                    a.monitoring = true;
                    a.online_speed = None;
                    a.online_acc = None;
                }
                self.op = Op::Online(Online::Running);
                Done::q(0.0)
            }
            0x0700 => {
                let (_, min, max) = config::system_param(par1, self.axes()).ok_or(quit::SYSTEM_PARAM)?;
                let v = int()?;
                if !(min..=max).contains(&v) {
                    return Err(quit::RANGE);
                }
                self.sys_params[par1 as usize - 1] = v;
                Done::q(v as f64)
            }
            0x1700..=0x1702 => {
                let (_, min, max) = config::system_param(par1, self.axes()).ok_or(quit::SYSTEM_PARAM)?;
                let v = match def.code {
                    0x1700 => self.sys_params[par1 as usize - 1],
                    0x1701 => max,
                    _ => min,
                };
                Done::q(v as f64)
            }
            0x0800 | 0x1800..=0x1802 => {
                let (axis, param) = table::split_axis_param_par1(par1).ok_or(quit::AXIS_PARAM)?;
                let i = self.axis_index(axis.into())?;
                let cfg = config::axis_param(param).ok_or(quit::AXIS_PARAM)?;
                let v = match def.code {
                    0x0800 => {
                        if !(cfg.min..=cfg.max).contains(&value) {
                            return Err(quit::RANGE);
                        }
                        self.axes[i].params[usize::from(param) - 1] = f64::from(value as f32);
                        self.axes[i].param(param)
                    }
                    0x1800 => self.axes[i].param(param),
                    0x1801 => cfg.max,
                    _ => cfg.min,
                };
                Done::q(v)
            }
            0x1900 => Done::q(b(get_bit(&self.inputs, element(quit::INPUT)?))),
            0x1901 => Done::q(word_of(&self.inputs, element(quit::INPUT)?).into()),
            0x0902 | 0x0904 => {
                let n = element(if def.code == 0x0902 { quit::OUTPUT } else { quit::FLAG })?;
                let on = match int()? {
                    0 => false,
                    1 => true,
                    _ => return Err(quit::RANGE),
                };
                let bits = if def.code == 0x0902 { &mut self.outputs } else { &mut self.flags };
                set_bit(bits, n, on);
                self.check_conditions(t);
                Done::q(b(on))
            }
            0x1902 => Done::q(b(get_bit(&self.outputs, element(quit::OUTPUT)?))),
            0x1904 => Done::q(b(get_bit(&self.flags, element(quit::FLAG)?))),
            0x0903 | 0x0905 => {
                let n = element(if def.code == 0x0903 { quit::OUTPUT } else { quit::FLAG })?;
                let w = u16::try_from(int()?).map_err(|_| quit::RANGE)?;
                let bits = if def.code == 0x0903 { &mut self.outputs } else { &mut self.flags };
                bits[usize::from(n - 1) / 16] = w;
                self.check_conditions(t);
                Done::q(w.into())
            }
            0x1903 => Done::q(word_of(&self.outputs, element(quit::OUTPUT)?).into()),
            0x1905 => Done::q(word_of(&self.flags, element(quit::FLAG)?).into()),
            0x0906 => {
                let n = element(quit::N_REG)?;
                let v = i32::try_from(int()?).map_err(|_| quit::RANGE)?;
                self.n_regs[usize::from(n) - 1] = v;
                Done::q(v.into())
            }
            0x1906 => Done::q(self.n_regs[usize::from(element(quit::N_REG)?) - 1].into()),
            0x0907 => {
                let n = element(quit::R_REG)?;
                if value.abs() > f64::from(f32::MAX) {
                    return Err(quit::RANGE);
                }
                self.r_regs[usize::from(n) - 1] = value as f32;
                Done::q(f64::from(value as f32))
            }
            0x1907 => Done::q(self.r_regs[usize::from(element(quit::R_REG)?) - 1].into()),
            0x0909 => match self.error {
                0 => Done::q(0.0),
                1..=99 => Err(quit::NOT_EXECUTABLE),
                _ => {
                    self.error = 0;
                    Done::q(0.0)
                }
            },
            0x1909 => Done::q(self.error.into()),
            0x190B => Done::q(0.0),
            0x190C | 0x190E => Done::q(self.axes[self.axis_index(par1)?].position(t)),
            0x190D => Done::q(self.axes[self.axis_index(par1)?].speed(t)),
            0x190F | 0x1915 => self.axis_index(par1).and_then(|_| Done::q(0.0)),
            0x1910 => Done::q(self.axes[self.axis_index(par1)?].status().into()),
            0x1911 => {
                let bits = self.axes.iter().take(self.configured_axes()).enumerate();
                Done::q(bits.filter(|(_, a)| a.moving()).fold(0u32, |acc, (i, _)| acc | 1 << i).into())
            }
            0x1913 => Done::q(self.axes[self.axis_index(par1)?].limits().0),
            0x1914 => Done::q(self.axes[self.axis_index(par1)?].limits().1),
            0x1920 => self.axis_index(par1).and_then(|_| Done::q(config::TEMPERATURE)),
            0x1921 => Done::q(self.axes[self.axis_index(par1)?].ext_status(t).into()),
            0x1934 | 0x1935 | 0x1937 => Done::q(self.system_element(def.code, par1)),
            0x0A41 | 0x0A81 => {
                self.go_home(t);
                Done::q(0.0)
            }
            _ => self.run_axis(def, cmd, t),
        }
    }

    /// The online axis commands (5.2.6).
    fn run_axis(&mut self, def: &'static CommandDef, cmd: &Command, t: f64) -> Result<Done, u16> {
        let value = cmd.par2.as_f64();
        if matches!(def.code, 0x0AA2 | 0x0AA3) {
            let axes = self.axes_or_all(cmd.par1)?;
            if def.code == 0x0AA2 {
                let on = match cmd.par2.as_i64() {
                    Some(0) => false,
                    Some(1) => true,
                    _ => return Err(quit::RANGE),
                };
                for i in axes {
                    self.axes[i].monitoring = on;
                }
            } else {
                let c = cmd.par2.as_i64().and_then(Condition::decode).ok_or(quit::RANGE)?;
                if !element_ok(c.number) {
                    return Err(match c.element {
                        ElementType::Input => quit::INPUT,
                        ElementType::Output => quit::OUTPUT,
                        ElementType::Flag => quit::FLAG,
                    });
                }
                for i in axes {
                    self.axes[i].armed_condition = Some(c);
                }
            }
            return Done::q(0.0);
        }
        let i = self.axis_index(cmd.par1)?;
        match def.code {
            0x0A83 => {
                self.axes[i].released = true;
                Done::q(0.0)
            }
            0x0A84 => {
                self.check_can_move(i)?;
                let a = &self.axes[i];
                let legs = [
                    (config::REFERENCE_SWITCH, a.param(2)),
                    (config::REFERENCE_SWITCH + config::REFERENCE_CREEP, a.param(4)),
                ];
                self.check_direction(i, legs[0].0 - a.physical(t), t)?;
                self.resume_online();
                let id = self.motion_id();
                self.axes[i].referenced = false;
                self.axes[i].start(t, &legs, MotionKind::Reference, id);
                Ok(Done { q: 0.0, wait: Some((i, id)) })
            }
            0x0A85 | 0x0A86 | 0x0A96 => {
                let a = &mut self.axes[i];
                if a.moving() {
                    return Err(quit::MOVING);
                }
                if value.abs() > f64::from(f32::MAX) {
                    return Err(quit::RANGE);
                }
                let new = if def.code == 0x0A85 { 0.0 } else { f64::from(value as f32) };
                let old = a.position(t);
                match def.code {
                    // G29 shifts the software limits with the counter (5.2.6.5);
                    // G26 keeps them (5.2.6.4).
                    0x0A86 => a.limit_shift += new - old,
                    0x0A96 => {
                        a.limit_shift = 0.0;
                        a.referenced = true;
                        a.released = true;
                    }
                    _ => {}
                }
                a.offset = a.physical(t) - new;
                Done::q(a.position(t))
            }
            0x0A87 | 0x0A89 | 0x0A94 | 0x0A95 | 0x0A90 | 0x0A91 => {
                let relative = matches!(def.code, 0x0A89 | 0x0A95 | 0x0A91);
                let manual = matches!(def.code, 0x0A90 | 0x0A91);
                self.check_can_move(i)?;
                if !self.axes[i].released {
                    return Err(quit::NO_REFERENCE);
                }
                let a = &self.axes[i];
                let start = a.position(t);
                let target = f64::from((if relative { start + value } else { value }) as f32);
                let (lo, hi) = a.limits();
                if !(lo..=hi).contains(&target) {
                    return Err(quit::OUTSIDE);
                }
                self.check_direction(i, target - start, t)?;
                self.resume_online();
                let a = &mut self.axes[i];
                a.last_target = target;
                a.active_condition = a.armed_condition.take();
                let speed = if manual { a.param(3) } else { a.speed_for_moves() };
                let kind = if manual {
                    MotionKind::Manual { deadline: t + config::MANUAL_KEEPALIVE }
                } else {
                    MotionKind::Move
                };
                let id = self.motion_id();
                if self.condition_holds(self.axes[i].active_condition) {
                    let a = &mut self.axes[i];
                    a.start(t, &[(target + a.offset, speed)], kind, id);
                    if a.motion.is_some_and(|m| m.end <= t) {
                        a.finish(t);
                    }
                } else {
                    self.axes[i].active_condition = None;
                    self.axes[i].rest = Rest::Stopped;
                }
                let wait = def.is_start_and_wait().then_some((i, id));
                Ok(Done { q: start, wait })
            }
            0x0A8D | 0x0A8E => {
                let param = if def.code == 0x0A8D { 1 } else { 6 };
                let cfg = config::axis_param(param).expect("parameters 1 and 6 exist");
                if !(cfg.min..=cfg.max).contains(&value) {
                    return Err(quit::RANGE);
                }
                let v = f64::from(value as f32);
                let a = &mut self.axes[i];
                if param == 1 {
                    a.online_speed = Some(v);
                } else {
                    a.online_acc = Some(v);
                }
                Done::q(v)
            }
            0x0A92 => {
                let a = &mut self.axes[i];
                if let Some(m) = a.motion.as_mut() {
                    if let MotionKind::Manual { deadline } = &mut m.kind {
                        *deadline = t + config::MANUAL_KEEPALIVE;
                    }
                }
                Done::q(a.position(t))
            }
            0x0A93 | 0x0A9A => {
                let id = self.motion_id();
                let a = &mut self.axes[i];
                a.stop(t, id);
                if a.motion.is_some_and(|m| m.end <= t) {
                    a.finish(t);
                }
                let wait = (def.code == 0x0A93).then_some((i, id));
                Done::q(a.position(t)).map(|d| Done { wait, ..d })
            }
            0x0A97 => {
                self.axes[i].on = true;
                Done::q(0.0)
            }
            0x0A98 | 0x0AA0 => {
                let a = &mut self.axes[i];
                if a.moving() {
                    return Err(quit::MOVING);
                }
                if def.code == 0x0A98 {
                    a.on = false;
                    a.off_position = a.position(t);
                } else {
                    a.measuring = true;
                }
                Done::q(0.0)
            }
            0x0AA1 => {
                self.axes[i].measuring = false;
                Done::q(0.0)
            }
            // Every code of the table is handled above.
            _ => Err(quit::UNKNOWN_COMMAND),
        }
    }

    fn check_can_move(&self, i: usize) -> Result<(), u16> {
        let a = &self.axes[i];
        if self.op == Op::Online(Online::Malfunction) {
            return Err(quit::NOT_EXECUTABLE);
        }
        self.check_ext_stop()?;
        if !a.on {
            return Err(quit::NOT_ON);
        }
        if a.measuring || !a.power_ready {
            return Err(quit::NOT_READY);
        }
        if a.moving() {
            return Err(quit::MOVING);
        }
        Ok(())
    }

    /// With monitoring on, no move towards an activated limit switch.
    fn check_direction(&self, i: usize, delta: f64, t: f64) -> Result<(), u16> {
        let a = &self.axes[i];
        if a.monitoring && delta != 0.0 && a.switch_active(delta > 0.0, t) {
            return Err(quit::LIMIT_SWITCH);
        }
        Ok(())
    }

    fn check_ext_stop(&self) -> Result<(), u16> {
        let n = self.sys_param_element(4);
        if element_ok(n) && get_bit(&self.inputs, n) {
            Ok(())
        } else {
            Err(quit::NO_EXT_STOP)
        }
    }

    /// The parameter conversion check of 0602 / 0603 (6.5, errors 60-6B).
    fn check_axis_params(&self) -> Result<(), u16> {
        for a in self.axes.iter().take(self.configured_axes()) {
            if a.param(4) > a.param(2) {
                return Err(quit::CREEP_TOO_HIGH);
            }
            if a.param(5) > a.param(1) {
                return Err(quit::INITIAL_TOO_HIGH);
            }
        }
        Ok(())
    }

    fn resume_online(&mut self) {
        if self.op == Op::Online(Online::Stopping) {
            self.op = Op::Online(Online::Running);
        }
    }

    fn start_auto(&mut self, t: f64) -> Result<(), u16> {
        match self.op {
            Op::Home => {
                self.check_axis_params()?;
                self.op = Op::Auto { running: true, since: t };
                Ok(())
            }
            Op::Auto { running: false, .. } if !self.axes.iter().any(Axis::moving) => {
                self.op = Op::Auto { running: true, since: t };
                Ok(())
            }
            _ => Err(quit::INADMISSIBLE),
        }
    }

    /// 0600, or the external stop input losing power.
    fn stop_all_modes(&mut self, t: f64) {
        match self.op {
            Op::Home => return,
            Op::Auto { since, .. } => self.op = Op::Auto { running: false, since },
            Op::Online(Online::Malfunction) => {}
            Op::Online(_) => self.op = Op::Online(Online::Stopping),
        }
        for i in 0..self.axes.len() {
            let id = self.motion_id();
            self.axes[i].stop(t, id);
        }
    }

    /// 0A41 / 0A81.
    fn go_home(&mut self, t: f64) {
        for a in &mut self.axes {
            a.halt(t, Rest::Stopped);
            a.online_speed = None;
            a.online_acc = None;
            a.active_condition = None;
            if a.rest == Rest::Fault {
                a.rest = Rest::Stopped;
            }
        }
        if (500..1000).contains(&self.error) {
            self.error = 0;
        }
        self.op = Op::Home;
        self.pending = None;
    }

    fn condition_holds(&self, c: Option<Condition>) -> bool {
        let Some(c) = c else { return true };
        let bits = match c.element {
            ElementType::Input => &self.inputs,
            ElementType::Output => &self.outputs,
            ElementType::Flag => &self.flags,
        };
        get_bit(bits, c.number) == c.while_state
    }

    /// Brakes moves whose 0AA3 condition no longer holds.
    fn check_conditions(&mut self, t: f64) {
        for i in 0..self.axes.len() {
            let c = self.axes[i].active_condition;
            if c.is_some() && !self.condition_holds(c) {
                let id = self.motion_id();
                self.axes[i].stop(t, id);
            }
        }
    }

    fn sync_signal_outputs(&mut self) {
        let ready = self.sys_param_element(6);
        let fault = self.sys_param_element(7);
        if element_ok(ready) {
            set_bit(&mut self.outputs, ready, self.error == 0);
        }
        if element_ok(fault) {
            set_bit(&mut self.outputs, fault, self.error != 0);
        }
    }

    /// 1934 / 1935 / 1937 (manual 6.2's extract of the system elements).
    fn system_element(&self, code: u16, n: i64) -> f64 {
        let axis = |first: i64| {
            let i = usize::try_from(n - first).ok()?;
            self.axes.get(i).filter(|_| i < self.configured_axes())
        };
        let v = match (code, n) {
            (0x1934, 51..=66) => axis(51).map(|a| b(a.referenced)),
            (0x1934, 91..=106) => axis(91).map(|a| b(a.on && !a.measuring)),
            (0x1934, 231..=246) => axis(231).map(|a| b(a.rest == Rest::Fault && !a.moving())),
            (0x1935, 10) => Some(self.error.into()),
            (0x1935, 71..=86) => axis(71).map(|a| a.status().into()),
            (0x1937, 51..=66) => axis(51).map(|a| a.off_position),
            (0x1937, 71..=86) => axis(71).map(|a| a.last_target),
            _ => None,
        };
        v.unwrap_or(0.0)
    }
}

impl ByteDevice for PacController {
    fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.handle_bytes(now, bytes, out);
    }
    fn poll(&mut self, now: Instant, _out: &mut Vec<u8>) {
        self.advance(now);
    }
}

fn b(v: bool) -> f64 {
    if v {
        1.0
    } else {
        0.0
    }
}

fn element_ok(n: u16) -> bool {
    (1..=ELEMENTS as u16).contains(&n)
}

fn get_bit(bits: &[u16; WORDS], n: u16) -> bool {
    let i = usize::from(n.clamp(1, ELEMENTS as u16) - 1);
    bits[i / 16] >> (i % 16) & 1 == 1
}

fn set_bit(bits: &mut [u16; WORDS], n: u16, on: bool) {
    let i = usize::from(n.clamp(1, ELEMENTS as u16) - 1);
    if on {
        bits[i / 16] |= 1 << (i % 16);
    } else {
        bits[i / 16] &= !(1 << (i % 16));
    }
}

fn word_of(bits: &[u16; WORDS], n: u16) -> u16 {
    bits[usize::from(n - 1) / 16]
}

/// The acknowledge date in the command's type.
fn par2(def: &CommandDef, q: f64) -> Par2 {
    match def.data_type {
        DataType::Float => Par2::Float(q),
        DataType::Int => Par2::Int(q as i64),
    }
}

/// R registers are written with 4 decimals (manual 3.4.2: `640.0000`),
/// everything else with 3 (3.4.3: `1255.000`).
fn float_format(def: &CommandDef) -> FloatFormat {
    match def.code {
        0x0907 | 0x1907 => FloatFormat::Fixed(4),
        _ => FloatFormat::Fixed(3),
    }
}

/// The command error a broken frame is answered with; `None`: no answer.
fn frame_error_quit(e: &FrameError) -> Option<u16> {
    Some(match e {
        FrameError::Garbage { .. } => return None,
        FrameError::MissingStx => quit::SEQUENCE_BEGINNING,
        FrameError::Truncated { .. } | FrameError::TooLong => quit::SEQUENCE_SETUP,
        FrameError::BadCheck { .. } => quit::CHECK,
        FrameError::MissingField { .. } | FrameError::ExtraField { .. } => quit::SEQUENCE_SETUP,
        FrameError::BadField { field: "CMD", .. } => quit::UNKNOWN_COMMAND,
        FrameError::BadField { .. } | FrameError::NotOneFrame(_) => quit::RANGE,
    })
}

/// `trip=`: an axis that moves too long runs onto its limit switch.
impl crate::sim::fault::Jams for PacController {
    fn moving(&mut self, now: Instant) -> Vec<(u8, bool)> {
        self.advance(now);
        (1..=self.axes()).map(|a| (a, self.axis_status(a) == Some(1))).collect()
    }

    fn jam(&mut self, now: Instant, id: u8) {
        self.trip_axis(now, id);
    }
}

impl PacController {
    /// Puts the controller in `start`'s mode through its own input, as a
    /// client would: start online (0603) and "no reference run" (0A83) for
    /// each axis, or start automatic (0602); in home position nothing.
    pub fn start(&mut self, now: Instant, start: crate::link::PacStart) {
        use crate::link::PacStart;
        let axes = self.axes();
        let cmds: Vec<Command> = match start {
            PacStart::Home => Vec::new(),
            PacStart::Online => std::iter::once(Command::new(0x0603, 0, Par2::Int(0)))
                .chain((1..=axes).map(|a| Command::new(0x0A83, a.into(), Par2::Int(0))))
                .collect(),
            PacStart::Automatic => vec![Command::new(0x0602, 0, Par2::Int(0))],
        };
        for cmd in cmds {
            if let Ok(bytes) = cmd.encode() {
                self.handle_bytes(now, &bytes, &mut Vec::new());
            }
        }
    }
}
