//! One 6168 module with its motor: configuration, kinematics on a fixed
//! 1/512 s control cycle, inputs, outputs, status bytes and events.

use super::config::{Params, ServoStore};
use crate::proto::cdios::table;
use crate::proto::cdios::Direction;

/// The simulated control cycle: 1/512 s, so that every 27h timer interval
/// (3.90625 ms .. 250 ms, i.e. 2^k / 256 s) is a whole number of cycles.
pub const CYCLE_NS: u64 = 1_953_125;
pub const CYCLE_S: f64 = 1.0 / 512.0;
/// Motor constant of the simulated motor: RPM per volt at the regulating
/// output (32000 RPM, the largest configurable maximum, at 10 V).
pub const RPM_PER_VOLT: f64 = 3200.0;
/// Highest encoder frequency the module counts reliably (status 3 bit 5 above it).
pub const MAX_ENCODER_HZ: f64 = 500_000.0;
/// How far the real speed trails the desired one while the speed changes:
/// the RPM error is `-rate * SPEED_LAG_S` (a bit negative while accelerating).
pub const SPEED_LAG_S: f64 = 0.01;
/// Where the end switches sit, in encoder pulses from the power-on position.
pub const END_SWITCH_PULSES: f64 = 100_000.0;
/// Where the Z (zero) input is active, in encoder pulses from the power-on
/// position: one window holding one index pulse (at 10000, a multiple of
/// every usual pulses-per-revolution setting).
pub const ZERO_WINDOW: (f64, f64) = (9_900.0, 10_400.0);
/// Type code the simulated controller reports for a 6168 in its identify table.
pub const MODULE_TYPE_6168: u8 = 68;
/// Version byte the identify table reports (V2.0).
pub const MODULE_VERSION: u8 = 0x20;

const EPS: f64 = 1e-6;

/// A speed ramp: `from` to `to` RPM over `dur` s, linear or sin².
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ramp {
    from: f64,
    to: f64,
    t: f64,
    dur: f64,
}

/// What a manual START runs until.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum RunKind {
    /// Option 0 (and STOP option 0): minimum speed.
    Minimum,
    /// Option 1: up to the maximum speed.
    Maximum,
    /// Option 3: to a given speed.
    ToSpeed(f64),
    /// Option 2: minimum speed until the end switch of the direction.
    EndSwitch,
    /// Option 4: minimum speed until the index.
    Index,
    /// Option 6: minimum speed until the index with Z active.
    IndexAndZero,
    /// STOP option 1 (and option 3 with speed 0): down to minimum, then stop;
    /// `hold`: hold at the setpoint afterwards.
    Stopping { hold: bool },
}

#[derive(Debug, Clone, PartialEq)]
pub(super) struct Goto {
    pub target: i32,
    pub cruise: f64,
    /// Absolute speed change positions still ahead, in order.
    pub changes: Vec<(i32, f64)>,
    pub traject: bool,
    pub braking: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub(super) enum Motion {
    Idle,
    Run(RunKind),
    Goto(Goto),
    /// Hold correction: back to the setpoint at minimum speed.
    Correct,
}

/// Inputs of the module (logical levels: "active", after Failsafe).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Inputs {
    pub forward_end_switch: bool,
    pub reverse_end_switch: bool,
    pub emergency: bool,
    pub ready: bool,
    pub error: bool,
}

/// Status bits that stay until cleared.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct Latches {
    pub stopped_forward: bool,
    pub stopped_reverse: bool,
    pub emergency_stop: bool,
    pub watchdog: bool,
    pub error_or_ready: bool,
    pub zeroed: bool,
    pub does_not_run: bool,
    pub wrong_direction: bool,
    pub not_initialised: bool,
}

/// Faults the simulation cannot produce by itself, for tests and demos.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// The controller's 0.5 s watchdog on the module expired (status 2 bits 6 and 5).
    Watchdog,
    /// The motor does not turn (status 3 bit 2).
    DoesNotRun,
    /// The motor turns the wrong way (status 3 bit 4).
    WrongDirection,
}

/// A motion command latched until SYNC.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Latched {
    /// 23h selector 1/3/5 (as 0/2/4) with its value.
    Goto {
        selector: u8,
        value: i32,
    },
    Traject(u8),
    Start {
        direction: u8,
        option: u8,
        speed: u16,
    },
    Stop {
        option: u8,
    },
}

/// One 6168 motor driver controller module and its motor.
#[derive(Debug, Clone)]
pub struct Motor6168 {
    pub(super) id: u8,
    pub(super) serial: u32,
    pub(super) store: ServoStore,
    pub(super) eeprom: ServoStore,
    pub(super) p: Params,
    /// Encoder pulses from the power-on position (never reset).
    phys: f64,
    /// `position = phys - offset`.
    offset: f64,
    /// +1 forward, -1 reverse.
    dir: f64,
    /// Desired speed magnitude, RPM.
    speed: f64,
    /// Real speed magnitude (voltage limited, lagging), RPM.
    actual: f64,
    voltage_limited: bool,
    ramp: Option<Ramp>,
    pub(super) motion: Motion,
    pub(super) setpoint: i32,
    pub(super) latched_position: i32,
    pub(super) next_speed: u16,
    pub(super) enabled: bool,
    pub(super) hold: bool,
    pub(super) inputs: Inputs,
    /// Physical end switches (reverse, forward), pulses; `None`: only `inputs` count.
    pub(super) switch_at: Option<(f64, f64)>,
    pub(super) zero_window: Option<(f64, f64)>,
    pub(super) latches: Latches,
    auto_zero_armed: bool,
    pub(super) digital: u8,
    pub(super) analog: [i16; 2],
    pub(super) latched_digital: Option<u8>,
    pub(super) latched_analog: [Option<i16>; 2],
    pub(super) latched_motion: Option<Latched>,
    pub(super) mask: [u8; 4],
    pub(super) timers: u8,
    last_status: [u8; 4],
    timer_cycles: u64,
    last_position_sent: Option<i32>,
    last_speed_sent: Option<(u16, i16)>,
    /// Something changed outside the control cycle (inputs, commands): the
    /// next cycle must run even if the motor is at rest.
    dirty: bool,
}

impl Motor6168 {
    pub(super) fn new(id: u8, serial: u32) -> Self {
        let store = ServoStore::defaults();
        let p = Params::from_store(&store);
        let mut m = Self {
            id,
            serial,
            eeprom: store.clone(),
            store,
            p,
            phys: 0.0,
            offset: 0.0,
            dir: 1.0,
            speed: 0.0,
            actual: 0.0,
            voltage_limited: false,
            ramp: None,
            motion: Motion::Idle,
            setpoint: 0,
            latched_position: 0,
            next_speed: 0,
            enabled: false,
            hold: false,
            inputs: Inputs {
                forward_end_switch: false,
                reverse_end_switch: false,
                emergency: false,
                ready: true,
                error: false,
            },
            switch_at: Some((-END_SWITCH_PULSES, END_SWITCH_PULSES)),
            zero_window: Some(ZERO_WINDOW),
            latches: Latches { not_initialised: true, ..Latches::default() },
            auto_zero_armed: true,
            digital: 0,
            analog: [0; 2],
            latched_digital: None,
            latched_analog: [None; 2],
            latched_motion: None,
            mask: [0; 4],
            timers: 0,
            last_status: [0; 4],
            timer_cycles: 0,
            last_position_sent: None,
            last_speed_sent: None,
            dirty: true,
        };
        m.last_status = m.status();
        m
    }

    /// A node reset: the stored configuration comes back, the motor is
    /// disabled and at rest, outputs off, the position uninitialised.
    pub(super) fn reset(&mut self) {
        let mut fresh = Self::new(self.id, self.serial);
        fresh.store = self.eeprom.clone();
        fresh.eeprom = self.eeprom.clone();
        fresh.p = Params::from_store(&fresh.store);
        fresh.phys = self.phys;
        fresh.offset = self.offset;
        fresh.inputs = self.inputs;
        fresh.switch_at = self.switch_at;
        fresh.zero_window = self.zero_window;
        fresh.last_status = fresh.status();
        *self = fresh;
    }

    pub fn id(&self) -> u8 {
        self.id
    }

    pub fn serial(&self) -> u32 {
        self.serial
    }

    /// The motor position (encoder pulses, saturated to 32 bits).
    pub fn position(&self) -> i32 {
        sat(self.pos_f())
    }

    /// The setpoint (latest GOTO position / traject end point).
    pub fn setpoint(&self) -> i32 {
        self.setpoint
    }

    pub fn enabled(&self) -> bool {
        self.enabled
    }

    pub fn hold(&self) -> bool {
        self.hold
    }

    /// Whether a motion (goto, start, correction) is under way.
    pub fn running(&self) -> bool {
        self.motion != Motion::Idle
    }

    /// The real motor speed in RPM (a magnitude; see [`Self::status`] for the direction).
    pub fn speed_rpm(&self) -> f64 {
        self.actual
    }

    /// The speed the controller wants, RPM.
    pub fn desired_rpm(&self) -> f64 {
        self.speed
    }

    pub fn digital_outputs(&self) -> u8 {
        self.digital
    }

    /// Analog outputs #1 and #2, mV. While the motor is enabled #1 is the
    /// motor regulating voltage.
    pub fn analog_outputs(&self) -> [i16; 2] {
        [if self.enabled { self.regulating_mv() } else { self.analog[0] }, self.analog[1]]
    }

    pub fn inputs(&self) -> Inputs {
        self.inputs
    }

    /// The servo configuration currently in use, as 20h field values by set selector.
    pub fn config(&self) -> &ServoStore {
        &self.store
    }

    /// Forces an end switch input on or off (the physical switches at
    /// ±[`END_SWITCH_PULSES`] are active beyond their position either way).
    pub fn set_end_switch(&mut self, direction: Direction, active: bool) {
        match direction {
            Direction::Forward => self.inputs.forward_end_switch = active,
            Direction::Reverse => self.inputs.reverse_end_switch = active,
        }
        self.dirty = true;
    }

    /// Moves the physical end switches (pulses from the power-on position), or removes them.
    pub fn set_end_switch_positions(&mut self, at: Option<(f64, f64)>) {
        self.switch_at = at;
        self.dirty = true;
    }

    /// The emergency stop input.
    pub fn set_emergency(&mut self, active: bool) {
        self.inputs.emergency = active;
        self.dirty = true;
    }

    pub fn set_ready(&mut self, active: bool) {
        self.inputs.ready = active;
        self.dirty = true;
    }

    pub fn set_error_input(&mut self, active: bool) {
        self.inputs.error = active;
        self.dirty = true;
    }

    /// Moves the Z input window (pulses from the power-on position), or removes it.
    pub fn set_zero_window(&mut self, window: Option<(f64, f64)>) {
        self.zero_window = window;
        self.dirty = true;
    }

    /// An external force moves the shaft by `pulses` (a held motor is brought back).
    pub fn push(&mut self, pulses: f64) {
        if pulses.is_finite() {
            self.phys += pulses;
            self.dirty = true;
        }
    }

    /// Injects a fault: the motor stops at once and is disabled.
    pub fn inject(&mut self, fault: Fault) {
        match fault {
            Fault::Watchdog => {
                self.latches.watchdog = true;
                self.latches.emergency_stop = true;
            }
            Fault::DoesNotRun => self.latches.does_not_run = true,
            Fault::WrongDirection => self.latches.wrong_direction = true,
        }
        self.halt_disable();
    }

    /// +1 forward, -1 reverse (of the running or last motion).
    pub(super) fn dir(&self) -> f64 {
        self.dir
    }

    pub(super) fn pos_f(&self) -> f64 {
        self.phys - self.offset
    }

    pub(super) fn set_position(&mut self, pos: i32) {
        self.offset = self.phys - f64::from(pos);
        self.setpoint = pos;
        self.latches.not_initialised = false;
        self.dirty = true;
    }

    pub(super) fn forward_switch(&self) -> bool {
        self.inputs.forward_end_switch || self.switch_at.is_some_and(|(_, f)| self.phys >= f)
    }

    pub(super) fn reverse_switch(&self) -> bool {
        self.inputs.reverse_end_switch || self.switch_at.is_some_and(|(r, _)| self.phys <= r)
    }

    /// The end switch in the direction of `dir` (+1 / -1).
    pub(super) fn switch_towards(&self, dir: f64) -> bool {
        if dir > 0.0 {
            self.forward_switch()
        } else {
            self.reverse_switch()
        }
    }

    fn zero_input_at(&self, phys: f64) -> bool {
        self.zero_window.is_some_and(|(lo, hi)| (lo..=hi).contains(&phys))
    }

    pub(super) fn zero_input(&self) -> bool {
        self.zero_input_at(self.phys)
    }

    /// "Emergency stop, watchdog status active, error input active, ready not
    /// active": what makes GOTO / START / STOP answer error bit 1.
    pub(super) fn emergency_blocked(&self) -> bool {
        self.latches.emergency_stop
            || self.inputs.emergency
            || (self.p.error_check && self.inputs.error)
            || (self.p.ready_check && !self.inputs.ready)
    }

    pub(super) fn regulating_mv(&self) -> i16 {
        let mv = self.dir * self.actual / RPM_PER_VOLT * 1000.0;
        mv.round().clamp(-10000.0, 10000.0) as i16
    }

    /// RPM error: real minus desired speed.
    pub fn rpm_error(&self) -> f64 {
        self.actual - self.speed
    }

    pub(super) fn config_changed(&mut self) {
        self.p = Params::from_store(&self.store);
        self.dirty = true;
    }

    pub(super) fn mark_dirty(&mut self) {
        self.dirty = true;
    }

    /// Nothing can change by letting time pass (no motion, no timers, no pending input change).
    pub(super) fn is_static(&self) -> bool {
        !self.dirty && self.motion == Motion::Idle && self.ramp.is_none() && self.timers == 0 && self.speed == 0.0
    }

    // ---- Status ----

    /// The four status bytes of 26h selector 0.
    pub fn status(&self) -> [u8; 4] {
        let running = self.running();
        let mut s1 = 0u8;
        if running && self.speed > 0.0 {
            s1 |= if self.dir > 0.0 { 0x01 } else { 0x02 };
        }
        if self.motion == Motion::Run(RunKind::EndSwitch) {
            s1 |= 0x04;
        }
        match self.ramp {
            Some(r) if r.to > r.from => s1 |= 0x20,
            Some(_) => s1 |= 0x40,
            None if running && self.speed > 0.0 => {
                if (self.speed - self.p.min_rpm).abs() < EPS {
                    s1 |= 0x08;
                }
                if self.cruise_speed().is_some_and(|c| c > self.p.min_rpm + EPS && (self.speed - c).abs() < EPS) {
                    s1 |= 0x10;
                }
            }
            None => {}
        }
        if matches!(self.motion, Motion::Goto(_)) {
            s1 |= 0x80;
        }
        let l = &self.latches;
        let s2 = bits(&[
            self.forward_switch(),
            self.reverse_switch(),
            self.inputs.emergency,
            l.stopped_forward,
            l.stopped_reverse,
            l.emergency_stop,
            l.watchdog,
            l.error_or_ready,
        ]);
        let encoder_hz = self.actual * self.p.ppr / 60.0;
        let s3 = bits(&[
            l.zeroed,
            false,
            l.does_not_run,
            false,
            l.wrong_direction,
            encoder_hz > MAX_ENCODER_HZ,
            self.voltage_limited,
            self.enabled,
        ]);
        let traject = matches!(&self.motion, Motion::Goto(g) if g.traject);
        let s4 = bits(&[
            self.zero_input(),
            false,
            self.hold,
            traject,
            self.inputs.ready,
            self.inputs.error,
            false,
            l.not_initialised,
        ]);
        [s1, s2, s3, s4]
    }

    /// The speed the current motion aims for once accelerated ("maximum speed" of status 1 bit 4).
    fn cruise_speed(&self) -> Option<f64> {
        match &self.motion {
            Motion::Goto(g) if !g.braking => Some(g.cruise),
            Motion::Run(RunKind::Maximum) => Some(self.p.max_rpm),
            Motion::Run(RunKind::ToSpeed(s)) => Some(*s),
            _ => None,
        }
    }

    // ---- Motion control ----

    /// Starts moving from rest at the minimum speed in `dir`.
    pub(super) fn start_moving(&mut self, dir: f64, motion: Motion) {
        if self.motion == Motion::Idle || self.speed == 0.0 {
            self.dir = dir;
            self.speed = self.p.min_rpm;
            self.ramp = None;
        }
        self.motion = motion;
        self.hold = false;
        self.dirty = true;
    }

    /// Speed 0 at once; the position becomes the setpoint.
    pub(super) fn stop_now(&mut self, hold: bool) {
        self.speed = 0.0;
        self.actual = 0.0;
        self.ramp = None;
        self.motion = Motion::Idle;
        self.setpoint = self.position();
        self.hold = hold && self.enabled;
        self.voltage_limited = false;
        self.dirty = true;
    }

    /// Fast stop and disable (end switch, emergency, STOP option 5).
    pub(super) fn halt_disable(&mut self) {
        self.stop_now(false);
        self.enabled = false;
        self.hold = false;
        self.latched_motion = None;
    }

    fn ramp_to(&mut self, target: f64) {
        let goal = self.ramp.map_or(self.speed, |r| r.to);
        if (goal - target).abs() < EPS {
            return;
        }
        let dur = (target - self.speed).abs() / self.p.accel.max(EPS);
        if dur < CYCLE_S / 2.0 {
            self.speed = target;
            self.ramp = None;
        } else {
            self.ramp = Some(Ramp { from: self.speed, to: target, t: 0.0, dur });
        }
    }

    fn ramp_step(&mut self) {
        let Some(mut r) = self.ramp else { return };
        r.t += CYCLE_S;
        let f = (r.t / r.dur).min(1.0);
        let shape = if self.p.sin2 { (std::f64::consts::FRAC_PI_2 * f).sin().powi(2) } else { f };
        self.speed = r.from + (r.to - r.from) * shape;
        if f >= 1.0 {
            self.speed = r.to;
            self.ramp = None;
        } else {
            self.ramp = Some(r);
        }
    }

    /// Pulses per cycle at `rpm`.
    fn pulses_per_cycle(&self, rpm: f64) -> f64 {
        rpm * self.p.ppr / 60.0 * CYCLE_S
    }

    /// Pulses needed to slow from `rpm` to the minimum speed.
    fn braking_distance(&self, rpm: f64) -> f64 {
        let min = self.p.min_rpm;
        if rpm <= min {
            return 0.0;
        }
        let t = (rpm - min) / self.p.accel.max(EPS);
        // The real speed runs ahead of the desired one while slowing down.
        let lag = (rpm - min) * SPEED_LAG_S;
        ((rpm + min) / 2.0 * t + lag) * self.p.ppr / 60.0
    }

    /// The desired speed for this cycle; may end the motion.
    fn motion_target(&mut self) -> f64 {
        let (min, max, pos, dir, speed) = (self.p.min_rpm, self.p.max_rpm, self.pos_f(), self.dir, self.speed);
        // Decide to brake one cycle early rather than one late.
        let brake = self.braking_distance(speed) + self.pulses_per_cycle(speed);
        let mut stop_with = None;
        let target = match &mut self.motion {
            Motion::Idle => 0.0,
            Motion::Run(kind) => match *kind {
                RunKind::Maximum => max,
                RunKind::ToSpeed(s) => s,
                RunKind::Stopping { hold } => {
                    if speed <= min + EPS {
                        stop_with = Some(hold);
                    }
                    min
                }
                RunKind::Minimum | RunKind::EndSwitch | RunKind::Index | RunKind::IndexAndZero => min,
            },
            Motion::Correct => min,
            Motion::Goto(g) => {
                while let Some(&(at, s)) = g.changes.first() {
                    if (f64::from(at) - pos) * dir <= 0.0 {
                        g.cruise = s;
                        g.braking = false;
                        g.changes.remove(0);
                    } else {
                        break;
                    }
                }
                let remaining = (f64::from(g.target) - pos) * dir;
                if remaining < 0.0 || remaining <= brake {
                    // Arriving, or interrupted by a goto behind us: slow down first.
                    g.braking = true;
                }
                if g.braking {
                    min
                } else {
                    g.cruise
                }
            }
        };
        if let Some(hold) = stop_with {
            self.stop_now(hold);
            return 0.0;
        }
        target
    }

    /// Applies input changes: emergency, ready / error inputs, end switches.
    fn supervise(&mut self) {
        if self.enabled {
            if self.inputs.emergency {
                self.latches.emergency_stop = true;
                self.halt_disable();
            } else if (self.p.error_check && self.inputs.error) || (self.p.ready_check && !self.inputs.ready) {
                self.latches.error_or_ready = true;
                self.latches.emergency_stop = true;
                self.halt_disable();
            }
        }
        if self.running() && self.speed > 0.0 && self.motion != Motion::Run(RunKind::EndSwitch) {
            if self.dir > 0.0 && self.p.forward_check && self.forward_switch() {
                self.latches.stopped_forward = true;
                self.halt_disable();
            } else if self.dir < 0.0 && self.p.reverse_check && self.reverse_switch() {
                self.latches.stopped_reverse = true;
                self.halt_disable();
            }
        }
        if !self.zero_input() {
            self.auto_zero_armed = true;
        }
        if self.motion == Motion::Idle && self.hold && self.enabled {
            let err = f64::from(self.setpoint) - self.pos_f();
            if err.abs() > self.p.positioning_error {
                self.start_moving(err.signum(), Motion::Correct);
                self.hold = true;
            }
        }
    }

    /// One control cycle; events (as reply data) are appended to `events`.
    pub(super) fn cycle(&mut self, events: &mut Vec<[u8; 8]>) {
        self.dirty = false;
        self.supervise();
        let target = self.motion_target();
        if let Motion::Goto(g) = &self.motion {
            // Turn round once slowed down after an interrupting goto behind us.
            if (f64::from(g.target) - self.pos_f()) * self.dir < 0.0 && self.speed <= self.p.min_rpm + EPS {
                self.dir = -self.dir;
                if let Motion::Goto(g) = &mut self.motion {
                    g.braking = false;
                }
            }
        }
        let before = self.speed;
        if self.running() {
            self.ramp_to(target);
            self.ramp_step();
        }
        self.update_actual(before);
        if self.running() {
            self.travel();
        }
        self.emit(events);
    }

    fn update_actual(&mut self, before: f64) {
        if !self.running() {
            self.actual = 0.0;
            self.voltage_limited = false;
            return;
        }
        let limit = self.p.max_mv / 1000.0 * RPM_PER_VOLT;
        self.voltage_limited = self.speed > limit + EPS;
        let rate = (self.speed - before) / CYCLE_S;
        self.actual = (self.speed.min(limit) - rate * SPEED_LAG_S).max(0.0);
    }

    /// Moves the shaft by one cycle at the real speed; ends gotos, searches and corrections.
    fn travel(&mut self) {
        let step = self.pulses_per_cycle(self.actual);
        let pos = self.pos_f();
        match self.motion.clone() {
            Motion::Goto(g) => {
                let remaining = (f64::from(g.target) - pos) * self.dir;
                if remaining >= 0.0 && remaining <= step {
                    self.phys = f64::from(g.target) + self.offset;
                    self.stop_now(true);
                    self.setpoint = g.target;
                    return;
                }
            }
            Motion::Correct => {
                let remaining = (f64::from(self.setpoint) - pos) * self.dir;
                if remaining <= step {
                    self.phys = f64::from(self.setpoint) + self.offset;
                    let sp = self.setpoint;
                    self.stop_now(true);
                    self.setpoint = sp;
                    return;
                }
            }
            _ => {}
        }
        let from = self.phys;
        let to = from + self.dir * step;
        self.phys = to;
        // Index pulses at every multiple of the pulses per revolution.
        let ppr = self.p.ppr;
        let (a, b) = ((from / ppr).floor(), (to / ppr).floor());
        if a != b {
            let index = if self.dir > 0.0 { b * ppr } else { a * ppr };
            self.on_index(index);
        }
        if self.motion == Motion::Run(RunKind::EndSwitch) && self.switch_towards(self.dir) {
            self.offset = self.phys;
            self.latches.not_initialised = false;
            self.stop_now(self.p.hold_on_enable);
        }
    }

    fn on_index(&mut self, index_phys: f64) {
        let z = self.zero_input_at(index_phys);
        match self.motion {
            Motion::Run(RunKind::Index) => {
                self.zero_at(index_phys);
                self.stop_now(self.p.hold_on_enable);
                return;
            }
            Motion::Run(RunKind::IndexAndZero) if z => {
                self.zero_at(index_phys);
                self.stop_now(self.p.hold_on_enable);
                return;
            }
            _ => {}
        }
        if self.p.auto_zero && z && self.auto_zero_armed {
            self.auto_zero_armed = false;
            self.zero_at(index_phys);
        }
    }

    fn zero_at(&mut self, index_phys: f64) {
        // Targets in flight keep their meaning in the new coordinates.
        self.offset = index_phys;
        self.latches.zeroed = true;
        self.latches.not_initialised = false;
    }

    // ---- Events ----

    /// Sends status events for masked changes and the timer events that are due.
    pub(super) fn emit(&mut self, events: &mut Vec<[u8; 8]>) {
        self.status_events(events);
        if self.timers == 0 {
            return;
        }
        self.timer_cycles += 1;
        let due = |code: u8, cycles: u64| code != 0 && cycles.is_multiple_of(1u64 << code);
        let (pos_code, pos_change) = (self.timers & 0x07, self.timers & 0x08 != 0);
        let (spd_code, spd_change) = ((self.timers >> 4) & 0x07, self.timers & 0x80 != 0);
        if due(pos_code, self.timer_cycles) {
            let pos = self.position();
            if !pos_change || self.last_position_sent != Some(pos) {
                self.last_position_sent = Some(pos);
                if let Some(d) = reply("read_position", self.id, 0, &[("position", pos.into())]) {
                    events.push(event(d));
                }
            }
        }
        if due(spd_code, self.timer_cycles) {
            let v = (self.speed_word(), self.rpm_error_word());
            if !spd_change || self.last_speed_sent != Some(v) {
                self.last_speed_sent = Some(v);
                let values = [("motor_speed", i64::from(v.0)), ("rpm_error", i64::from(v.1))];
                if let Some(d) = reply("read_speed_error", self.id, 2, &values) {
                    events.push(event(d));
                }
            }
        }
    }

    /// A status event if a masked status bit changed since the last look.
    pub(super) fn status_events(&mut self, events: &mut Vec<[u8; 8]>) {
        let now = self.status();
        let changed = (0..4).any(|i| (now[i] ^ self.last_status[i]) & self.mask[i] != 0);
        self.last_status = now;
        if changed {
            events.push(event(self.status_reply(now)));
        }
    }

    /// 27h: new masks restart the comparison from the present status and the timers from now.
    pub(super) fn set_events(&mut self, mask: [u8; 4], timers: u8) {
        self.mask = mask;
        self.timers = timers;
        self.last_status = self.status();
        self.timer_cycles = 0;
        self.last_position_sent = None;
        self.last_speed_sent = None;
    }

    pub(super) fn status_reply(&self, s: [u8; 4]) -> [u8; 8] {
        let values = [
            ("status1", i64::from(s[0])),
            ("status2", i64::from(s[1])),
            ("status3", i64::from(s[2])),
            ("status4", i64::from(s[3])),
        ];
        reply("read_status", self.id, 0, &values).unwrap_or([
            table::MOTOR_STATUS,
            self.id,
            0,
            s[0],
            s[1],
            s[2],
            s[3],
            0,
        ])
    }

    pub(super) fn speed_word(&self) -> u16 {
        self.actual.round().clamp(0.0, 30000.0) as u16
    }

    pub(super) fn rpm_error_word(&self) -> i16 {
        self.rpm_error().round().clamp(-30000.0, 30000.0) as i16
    }

    /// Reading status clears status 3 bit 0.
    pub(super) fn take_status(&mut self) -> [u8; 4] {
        let s = self.status();
        self.latches.zeroed = false;
        s
    }

    pub(super) fn read_position(&self, selector: u8) -> i32 {
        match selector {
            1 => self.latched_position,
            2 => self.setpoint,
            _ => self.position(),
        }
    }
}

/// A reply (or event) to the table row `key`, from the table's encoder.
pub(super) fn reply(key: &str, module: u8, selector: u8, values: &[(&str, i64)]) -> Option<[u8; 8]> {
    table::encode_reply(table::command(key)?, module, selector, values).ok()
}

/// The event form of reply data: code | 0x40.
fn event(mut d: [u8; 8]) -> [u8; 8] {
    d[0] |= 0x40;
    d
}

fn bits(b: &[bool; 8]) -> u8 {
    b.iter().enumerate().fold(0, |acc, (i, &on)| acc | (u8::from(on) << i))
}

pub(super) fn sat(v: f64) -> i32 {
    v.round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}
