//! One simulated PowerCube module: state machine, motion and watchdog.
//! Parameter reads and writes are in `params.rs`.

use std::time::Instant;

use super::defaults::Defaults;
use super::traj::{self, End, Kin, Phase, Seg, Traj};
use super::{ModuleKind, ModuleSpec};
use crate::proto::powercube::can::Broadcast;
use crate::proto::powercube::flags::{self, config, state, FlagClass};
use crate::proto::powercube::table::{self, CommandId, MotionArg, MotionKind};
use crate::proto::powercube::{ModuleId, Motion, MotionValue, Request, Response};

/// The watchdog refresh period of manual section 13.
pub const WATCHDOG_PERIOD_S: f64 = 0.050;

/// Servo cycle; ActPos_ is the position one cycle earlier.
pub const SERVO_CYCLE_S: f64 = 0.001;

/// The interface a command arrived on: DISABLE_ACK and SYNC_MOTION are
/// "valid only for CAN-Bus", and the Setup word names the active interface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Iface {
    Can,
    Rs232,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct StepCmd {
    pub target: f64,
    pub time_s: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub(super) enum Activity {
    Idle,
    Homing,
    Ramp,
    /// First leg towards `to`, then periodic between `to` and `from`.
    RampLoop {
        from: f64,
        to: f64,
        vmax: f64,
        amax: f64,
    },
    CosLoop,
    Step {
        buffered: Option<StepCmd>,
    },
    Velocity,
    Current,
    /// The overshoot fault's ring after a ramp: still in motion.
    Settling,
    /// The slow-halt fault: a Halt brakes over its time instead of at once.
    Braking,
}

/// Faults of the module's own response (`sim --fault overshoot=PCT,
/// slow-halt=DUR`): what a badly tuned or worn drive does, so that the
/// commissioning checks of overshoot and halt time can be seen to fail.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ResponseFault {
    /// A ramp rings about its target after its end, the first swing this
    /// fraction of the step past it.
    pub overshoot: f64,
    /// A Halt brakes at constant deceleration to rest in this time (s).
    pub halt_time: f64,
}

/// The half period of the overshoot fault's ring (s), and how many.
const RING_HALF_S: f64 = 0.15;
const RING_HALVES: u32 = 6;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Limits {
    pub min_pos: f64,
    pub max_pos: f64,
    pub max_vel: f64,
    pub max_acc: f64,
    pub max_cur: f64,
    pub max_delta_pos: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Targets {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
}

/// Supervision limits (ActMin*/ActMax*); stored and reported, the simulated
/// supplies and temperature never leave them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Supervision {
    pub logic_min: f64,
    pub logic_max: f64,
    pub motor_min: f64,
    pub motor_max: f64,
    pub logic_under_ms: u32,
    pub logic_over_ms: u32,
    pub motor_under_ms: u32,
    pub motor_over_ms: u32,
    pub temp_max: f64,
    pub temp_min: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Event {
    Watchdog,
    SoftLimit,
    ProfileEnd,
}

/// A simulated PowerCube drive module. See the [module docs](super) for the
/// behaviour it models.
#[derive(Debug, Clone)]
pub struct Module {
    pub(super) spec: ModuleSpec,
    pub(super) def: Defaults,
    epoch: Instant,
    /// Seconds since `epoch` up to which the state is computed.
    pub(super) t: f64,
    pub(super) traj: Traj,
    pub(super) activity: Activity,
    pub(super) home_ok: bool,
    pub(super) halted: bool,
    /// Latched error and warning flags of CubeState (ERROR included).
    pub(super) faults: u32,
    pub(super) ramp_end: bool,
    pub(super) brake_engaged: bool,
    /// Where the home switch edge is, in the module's coordinates.
    pub(super) switch_pos: f64,
    /// PosCount = (pos + count_offset) * IncRatio: the raw counter does not
    /// jump when homing redefines the coordinates.
    pub(super) count_offset: f64,
    pub(super) ref_pos_count: i64,
    pub(super) wd_online: bool,
    pub(super) wd_refresh: f64,
    pub(super) inputs: u8,
    pub(super) outputs: u8,
    pub(super) iface: Iface,
    /// SYNC_MOTION: the last motion command, released by StartMotion.
    pub(super) pending: Option<Request>,
    pub(super) config: u32,
    pub(super) lim: Limits,
    pub(super) target: Targets,
    pub(super) home_offset: f64,
    /// Commanded current in A (current mode, RawCur, Cur).
    pub(super) cmd_cur: f64,
    pub(super) step_target: f64,
    pub(super) move_mode: u8,
    pub(super) c0: i16,
    pub(super) damp: i16,
    pub(super) a0: i16,
    pub(super) sync_time: u16,
    pub(super) sup: Supervision,
    pub(super) saved_pos: f64,
    /// ResetTime: the origin of ActFPosTime's millisecond stamp.
    pub(super) time_zero: f64,
    pub(super) response: ResponseFault,
    /// Where the running ramp started: the overshoot fault's step.
    ramp_from: f64,
}

/// CubeState flags the manual classes as errors.
pub(super) fn error_mask() -> u32 {
    flags::CUBE_STATE.flags.iter().filter(|f| f.class == FlagClass::Error).fold(0, |m, f| m | f.mask)
}

/// The amplifier sub-flags that come with STATE_POWERFAULT.
const POW_FLAGS: u32 = state::POW_VOLT_ERR
    | state::POW_FET_TEMP
    | state::POW_WDG_TEMP
    | state::POW_SHORTCUR
    | state::POW_HALLERR
    | state::POW_INTEGRAL_ERR;

/// `x` limited to `[lo, hi]` without ever panicking (`hi < lo` gives `lo`).
pub(super) fn limit(x: f64, lo: f64, hi: f64) -> f64 {
    x.min(hi).max(lo)
}

impl Module {
    pub fn new(spec: ModuleSpec, now: Instant) -> Self {
        let def = Defaults::new(spec.kind, spec.serial, spec.version, spec.id.get());
        let start = def.home_offset;
        let dir = if def.home_vel < 0.0 { -1.0 } else { 1.0 };
        let brake_engaged = def.config & config::BRAKE_AT_POWERON != 0;
        Self {
            spec,
            epoch: now,
            t: 0.0,
            traj: Traj::Hold { pos: start },
            activity: Activity::Idle,
            home_ok: false,
            halted: false,
            faults: 0,
            ramp_end: false,
            brake_engaged,
            switch_pos: start + dir * def.home_distance,
            count_offset: -start,
            ref_pos_count: 0,
            wd_online: false,
            wd_refresh: 0.0,
            inputs: 0,
            outputs: 0,
            iface: Iface::Can,
            pending: None,
            config: def.config,
            lim: Limits {
                min_pos: def.min_pos,
                max_pos: def.max_pos,
                max_vel: def.max_vel,
                max_acc: def.max_acc,
                max_cur: def.max_cur,
                max_delta_pos: def.max_delta_pos,
            },
            target: Targets { pos: start, vel: def.max_vel / 2.0, acc: def.max_acc / 2.0 },
            home_offset: def.home_offset,
            cmd_cur: 0.0,
            step_target: start,
            move_mode: 0,
            c0: def.c0,
            damp: def.damp,
            a0: def.a0,
            sync_time: 0,
            sup: Supervision {
                logic_min: 18.0,
                logic_max: 30.0,
                motor_min: 20.0,
                motor_max: 60.0,
                logic_under_ms: 10,
                logic_over_ms: 10,
                motor_under_ms: 10,
                motor_over_ms: 10,
                temp_max: 70.0,
                temp_min: -10.0,
            },
            saved_pos: start,
            time_zero: 0.0,
            response: ResponseFault::default(),
            ramp_from: start,
            def,
        }
    }

    pub fn id(&self) -> ModuleId {
        self.spec.id
    }

    pub fn kind(&self) -> ModuleKind {
        self.spec.kind
    }

    pub fn spec(&self) -> ModuleSpec {
        self.spec
    }

    /// The module's ROM values.
    pub fn defaults(&self) -> &Defaults {
        &self.def
    }

    /// Whether the watchdog is online (manual 13).
    pub fn watchdog_online(&self) -> bool {
        self.wd_online
    }

    /// Handles one addressed command as if it came over CAN; `None` if no
    /// acknowledge is sent.
    pub fn handle(&mut self, now: Instant, req: &Request) -> Option<Response> {
        self.handle_on(now, req, Iface::Can)
    }

    pub(crate) fn handle_on(&mut self, now: Instant, req: &Request, iface: Iface) -> Option<Response> {
        self.advance(now);
        self.iface = iface;
        let resp = match *req {
            Request::Reset => {
                self.reset();
                Some(Response::Simple(CommandId::Reset))
            }
            Request::Home => {
                self.home();
                Some(Response::Simple(CommandId::Home))
            }
            Request::Halt => {
                self.halt_commanded();
                Some(Response::Simple(CommandId::Halt))
            }
            Request::RecalcPidParam => Some(Response::Simple(CommandId::RecalcPidParam)),
            Request::ResetTime => {
                self.time_zero = self.t;
                Some(Response::Simple(CommandId::ResetTime))
            }
            Request::Watchdog => {
                if self.config & config::WATCHDOG_ENABLE != 0 {
                    self.wd_online = !self.wd_online;
                    // Going online counts as the first life sign.
                    self.wd_refresh = self.t;
                }
                Some(Response::Simple(CommandId::Watchdog))
            }
            Request::GetExtended { param } => {
                return self.get(param).map(|v| Response::Get { param, data: v.to_payload() });
            }
            Request::SetExtended { param, data } => {
                self.set_extended(param, data.as_slice()).then_some(Response::SetAck { param })
            }
            Request::SetMotion(m) => self.set_motion(m),
            Request::SetIStep { target, time_ms } => {
                self.submit(Request::SetIStep { target, time_ms });
                Some(Response::Simple(CommandId::SetIStep))
            }
        };
        let quiet = iface == Iface::Can && self.config & config::DISABLE_ACK != 0;
        resp.filter(|_| !quiet)
    }

    /// Applies a broadcast (never acknowledged) as if it came over CAN.
    pub fn broadcast(&mut self, now: Instant, b: Broadcast) {
        self.broadcast_on(now, b, Iface::Can)
    }

    pub(crate) fn broadcast_on(&mut self, now: Instant, b: Broadcast, iface: Iface) {
        self.advance(now);
        self.iface = iface;
        match b {
            Broadcast::Reset => self.reset(),
            Broadcast::Home => self.home(),
            Broadcast::Halt => self.halt_commanded(),
            Broadcast::WatchdogRefresh => self.wd_refresh = self.t,
            // The simulated bus has no bit rate.
            Broadcast::ChangeBaudrate(_) => {}
            Broadcast::SavePos => self.saved_pos = self.kin().pos,
            Broadcast::StartMotion => {
                if let Some(req) = self.pending.take() {
                    self.execute(req);
                }
            }
        }
    }

    /// The module's state at the last `advance`.
    pub(super) fn kin(&self) -> Kin {
        self.traj.eval(self.t)
    }

    pub fn position(&self) -> f32 {
        self.kin().pos as f32
    }

    pub fn velocity(&self) -> f32 {
        self.kin().vel as f32
    }

    pub fn cube_state(&self) -> u32 {
        let k = self.kin();
        let mut s = self.faults;
        let mut set = |cond: bool, bit: u32| {
            if cond {
                s |= bit;
            }
        };
        set(self.home_ok, state::HOME_OK);
        set(self.halted, state::HALTED);
        set(self.activity != Activity::Idle, state::MOTION);
        if matches!(self.activity, Activity::Ramp | Activity::RampLoop { .. }) {
            set(k.phase == Some(Phase::Acc), state::RAMP_ACC);
            set(k.phase == Some(Phase::Steady), state::RAMP_STEADY);
            set(k.phase == Some(Phase::Dec), state::RAMP_DEC);
        }
        set(self.ramp_end, state::RAMP_END);
        if let Activity::Step { buffered } = &self.activity {
            set(true, state::INPROGRESS);
            set(buffered.is_some(), state::FULLBUFFER);
        }
        set(self.brake_engaged && self.config & config::BRAKE_PRESENT != 0, state::BRAKEACTIVE);
        set(self.home_switch_active(k.pos), state::SWR);
        s
    }

    pub fn short_state(&self) -> u8 {
        flags::short_state_from_cube_state(self.cube_state())
    }

    /// The DIO byte of extended acknowledges: inputs | outputs << 4.
    pub fn dio(&self) -> u8 {
        (self.inputs & 0x0f) | (self.outputs & 0x0f) << 4
    }

    /// The home switch: active over `switch_width` past its edge, seen from
    /// the side homing approaches from.
    pub(super) fn home_switch_active(&self, pos: f64) -> bool {
        let dir = if self.def.home_vel < 0.0 { -1.0 } else { 1.0 };
        let past = (pos - self.switch_pos) * dir;
        past > 1e-9 && past < self.def.switch_width
    }

    /// Bench side: raises error flags as a fault would. Error flags stop the
    /// module (STATE_ERROR and STATE_HALTED); amplifier flags also raise
    /// STATE_POWERFAULT; STATE_CURLIMIT is a warning and only latches;
    /// other bits are ignored. Takes effect at the last `advance`.
    pub fn inject_error(&mut self, flags: u32) {
        let errs = flags & error_mask();
        self.faults |= flags & state::CURLIMIT;
        if errs != 0 {
            let pow = if errs & POW_FLAGS != 0 { state::POWERFAULT } else { 0 };
            self.trip(errs | pow);
        }
    }

    /// Bench side: the response faults from now on (the next ramp, the
    /// next Halt).
    pub fn set_response_fault(&mut self, fault: ResponseFault) {
        self.response = fault;
    }

    /// Bench side: the four digital inputs (bits 0..3).
    pub fn set_inputs(&mut self, bits: u8) {
        self.inputs = bits & 0x0f;
    }

    /// Brings motion, homing and the watchdog up to `now`. Time never runs
    /// backwards: an earlier `now` changes nothing.
    pub fn advance(&mut self, now: Instant) {
        let target = now.checked_duration_since(self.epoch).map_or(0.0, |d| d.as_secs_f64()).max(self.t);
        self.run_until(target);
    }

    /// Applies the events due up to `target` (seconds) and moves there.
    fn run_until(&mut self, target: f64) {
        // Every event either ends a profile or latches a flag that disables
        // its source, so this terminates; the bound is a guard only.
        for _ in 0..10_000 {
            match self.next_event() {
                Some((te, ev)) if te <= target => {
                    self.t = te.max(self.t);
                    self.apply(ev);
                }
                _ => break,
            }
        }
        self.t = target;
    }

    fn next_event(&self) -> Option<(f64, Event)> {
        let mut best: Option<(f64, Event)> = None;
        let mut offer = |t: Option<f64>, ev: Event| {
            if let Some(t) = t {
                if best.is_none_or(|(b, _)| t < b) {
                    best = Some((t, ev));
                }
            }
        };
        let wd_armed =
            self.wd_online && self.config & config::WATCHDOG_ENABLE != 0 && self.faults & state::COMM_ERROR == 0;
        offer(wd_armed.then_some(self.wd_refresh + WATCHDOG_PERIOD_S), Event::Watchdog);
        if self.soft_limits_active() && !matches!(self.activity, Activity::Idle | Activity::Homing) {
            let (min, max) = self.soft_bounds();
            offer(self.traj.first_exit(min, max, self.t), Event::SoftLimit);
        }
        offer(self.traj.end_time(), Event::ProfileEnd);
        best
    }

    fn apply(&mut self, ev: Event) {
        match ev {
            Event::Watchdog => self.trip(state::COMM_ERROR),
            Event::SoftLimit => {
                self.trip(state::BEYOND_SOFT);
                self.hold_on_crossed_bound();
            }
            Event::ProfileEnd => self.profile_end(),
        }
    }

    /// Where the soft limits trip: MinPos and MaxPos widened by a rounding
    /// margin, so a module stopped exactly on one does not trip.
    fn soft_bounds(&self) -> (f64, f64) {
        let eps = 1e-7 * (1.0 + self.lim.max_pos.abs().max(self.lim.min_pos.abs()));
        (self.lim.min_pos - eps, self.lim.max_pos + eps)
    }

    /// A module stopped by crossing a soft limit holds on the bound itself.
    /// The crossing instant is found from the instant the search started, so
    /// the position there carries a rounding error that depends on how often
    /// the module was polled; one side or the other of the bound decides
    /// whether the next outward move trips at once or an instant later.
    fn hold_on_crossed_bound(&mut self) {
        let (min, max) = self.soft_bounds();
        if let Traj::Hold { pos } = &mut self.traj {
            for bound in [min, max] {
                if (*pos - bound).abs() <= 1e-12 * (1.0 + bound.abs()) {
                    *pos = bound;
                }
            }
        }
    }

    /// Soft limits hold once the coordinate system is fixed (manual 12).
    fn soft_limits_active(&self) -> bool {
        self.home_ok
    }

    fn profile_end(&mut self) {
        // The target exactly, not the sum of the segments.
        let pos = self.traj.end_pos().unwrap_or_else(|| self.kin().pos);
        self.traj = Traj::Hold { pos };
        match std::mem::replace(&mut self.activity, Activity::Idle) {
            Activity::Homing => {
                // The switch edge becomes HomeOffset; the raw counter keeps
                // counting through the change of coordinates.
                let delta = self.home_offset - pos;
                self.count_offset -= delta;
                self.switch_pos = self.home_offset;
                self.traj = Traj::Hold { pos: self.home_offset };
                self.home_ok = true;
                self.ramp_end = true;
                self.ref_pos_count = self.pos_count();
                if self.config & config::ZERO_MOVE_AFTER_HOK != 0 {
                    let (v, a) = self.homing_vel_acc();
                    self.start_ramp(0.0, v, a);
                }
            }
            Activity::Ramp if self.response.overshoot > 0.0 && pos != self.ramp_from => {
                let amp = self.response.overshoot * (pos - self.ramp_from);
                self.traj = Traj::Ring { t0: self.t, target: pos, amp, half: RING_HALF_S, halves: RING_HALVES };
                self.activity = Activity::Settling;
            }
            Activity::Ramp | Activity::Settling => self.ramp_end = true,
            Activity::RampLoop { from, to, vmax, amax } => {
                self.traj = Traj::RampLoop {
                    t0: self.t,
                    from: to,
                    to: from,
                    leg: traj::plan_ramp(0.0, 0.0, from - to, vmax, amax),
                };
                self.activity = Activity::RampLoop { from, to, vmax, amax };
            }
            Activity::Step { buffered: Some(next) } => self.start_step(next),
            Activity::Step { buffered: None }
            | Activity::Velocity
            | Activity::Current
            | Activity::CosLoop
            | Activity::Braking
            | Activity::Idle => {}
        }
    }

    /// Emergency stop with error flags (STATE_ERROR | STATE_HALTED).
    fn trip(&mut self, errs: u32) {
        self.faults |= errs | state::ERROR;
        self.halt();
    }

    fn stop_here(&mut self) {
        let pos = self.kin().pos;
        self.traj = Traj::Hold { pos };
        self.activity = Activity::Idle;
    }

    fn halt(&mut self) {
        self.stop_here();
        self.pending = None;
        self.halted = true;
        self.brake_engaged = true;
    }

    /// A Halt the host sent. With the slow-halt fault a moving module
    /// brakes to rest over the fault's time (MOTION set until then); a
    /// trip stays an instant stop, so a soft limit crossed while braking
    /// still holds the module on it.
    fn halt_commanded(&mut self) {
        let k = self.kin();
        let dur = self.response.halt_time;
        if dur <= 0.0 || k.vel == 0.0 || matches!(self.activity, Activity::Idle | Activity::Braking) {
            return self.halt();
        }
        self.halt();
        let segs = vec![Seg { dur, acc: -k.vel / dur, phase: Phase::Dec }];
        self.traj = Traj::Segs { t0: self.t, p0: k.pos, v0: k.vel, segs, end: End::Stop { snap: None } };
        self.activity = Activity::Braking;
        self.brake_engaged = false;
    }

    fn reset(&mut self) {
        let old = self.faults;
        // Bit 27 is STATE_POW_SETUP_ERR (power off to clear) on firmware
        // 3.5.14..3.5.1D, otherwise the resettable STATE_LOGIC_VOLT.
        let bit27 = if (0x3514..=0x351d).contains(&self.spec.version) { 0 } else { state::LOGIC_VOLT };
        let wd_fresh = !self.wd_online || self.t - self.wd_refresh < WATCHDOG_PERIOD_S;
        let comm = if wd_fresh { state::COMM_ERROR } else { 0 };
        let resettable = state::TOW_ERROR | state::BEYOND_SOFT | state::POW_VOLT_ERR | state::CURLIMIT | bit27 | comm;
        let mut f = old & !resettable;
        let pow_left = f & POW_FLAGS != 0;
        // A power fault that only came from a voltage dip clears with it.
        if old & state::POWERFAULT != 0 && !pow_left && old & state::POW_VOLT_ERR != 0 {
            f &= !state::POWERFAULT;
        }
        if f & error_mask() & !state::ERROR == 0 {
            f &= !state::ERROR;
            self.halted = false;
        }
        self.faults = f;
    }

    /// Whether a motion command may start now (manual 5: a halted or failed
    /// module does not accept motion commands; 7.2: M3_COMPATIBLE modules
    /// only after homing). Commands during homing are ignored as well.
    fn motion_allowed(&self) -> bool {
        !self.halted
            && self.faults & state::ERROR == 0
            && self.activity != Activity::Homing
            && (self.home_ok || self.config & config::M3_COMPATIBLE == 0)
    }

    fn home(&mut self) {
        if self.halted || self.faults & state::ERROR != 0 || self.activity == Activity::Homing {
            return;
        }
        let k = self.kin();
        let (v, a) = self.homing_vel_acc();
        let mut segs = traj::plan_ramp(k.pos, k.vel, self.switch_pos, v, a);
        segs.push(Seg { dur: self.def.home_settle, acc: 0.0, phase: Phase::Steady });
        self.begin_motion();
        self.home_ok = false;
        self.traj =
            Traj::Segs { t0: self.t, p0: k.pos, v0: k.vel, segs, end: End::Stop { snap: Some(self.switch_pos) } };
        self.activity = Activity::Homing;
    }

    fn homing_vel_acc(&self) -> (f64, f64) {
        (
            limit(self.def.home_vel.abs(), self.def.min_vel, self.lim.max_vel),
            limit(self.def.home_acc, self.def.min_acc, self.lim.max_acc),
        )
    }

    fn begin_motion(&mut self) {
        self.ramp_end = false;
        self.brake_engaged = false;
    }

    /// A target position limited to the operating range once homed.
    pub(super) fn clamp_pos(&self, p: f64) -> f64 {
        if self.soft_limits_active() {
            limit(p, self.lim.min_pos, self.lim.max_pos)
        } else {
            p
        }
    }

    pub(super) fn ramp_vel(&self) -> f64 {
        limit(self.target.vel.abs(), self.def.min_vel, self.lim.max_vel)
    }

    pub(super) fn ramp_acc(&self) -> f64 {
        limit(self.target.acc.abs(), self.def.min_acc, self.lim.max_acc)
    }

    fn start_ramp(&mut self, target: f64, vmax: f64, amax: f64) {
        let k = self.kin();
        let target = self.clamp_pos(target);
        self.target.pos = target;
        let segs = traj::plan_ramp(k.pos, k.vel, target, vmax, amax);
        self.ramp_from = k.pos;
        self.begin_motion();
        self.traj = Traj::Segs { t0: self.t, p0: k.pos, v0: k.vel, segs, end: End::Stop { snap: Some(target) } };
        self.activity = Activity::Ramp;
    }

    fn start_ramp_loop(&mut self, target: f64) {
        let k = self.kin();
        let to = self.clamp_pos(target);
        let (vmax, amax) = (self.ramp_vel(), self.ramp_acc());
        if (to - k.pos).abs() < 1e-9 {
            return self.start_ramp(to, vmax, amax);
        }
        self.start_ramp(to, vmax, amax);
        self.activity = Activity::RampLoop { from: k.pos, to, vmax, amax };
    }

    fn start_cos_loop(&mut self, target: f64, time_s: f64) {
        let k = self.kin();
        let to = self.clamp_pos(target);
        let d = to - k.pos;
        // Peak velocity of the cosine is pi d / (2 half): keep it in MaxVel.
        let half = time_s.max(std::f64::consts::PI * d.abs() / (2.0 * self.lim.max_vel.max(self.def.min_vel)));
        if d.abs() < 1e-9 || half <= 0.0 {
            return self.start_ramp(to, self.ramp_vel(), self.ramp_acc());
        }
        self.begin_motion();
        self.traj = Traj::CosLoop { t0: self.t, from: k.pos, to, half };
        self.activity = Activity::CosLoop;
    }

    fn start_step(&mut self, cmd: StepCmd) {
        let k = self.kin();
        let target = self.clamp_pos(cmd.target);
        let d = target - k.pos;
        // A step faster than MaxVel takes longer than asked (manual 12).
        let dur = cmd.time_s.max(d.abs() / self.lim.max_vel.max(self.def.min_vel));
        let (v0, segs) =
            if dur > 0.0 { (d / dur, vec![Seg { dur, acc: 0.0, phase: Phase::Steady }]) } else { (0.0, vec![]) };
        self.step_target = target;
        self.begin_motion();
        self.traj = Traj::Segs { t0: self.t, p0: k.pos, v0, segs, end: End::Stop { snap: Some(target) } };
        self.activity = Activity::Step { buffered: None };
    }

    fn step(&mut self, cmd: StepCmd) {
        match &mut self.activity {
            // Manual 5, STATE_FULLBUFFER: one command waits; a newer one
            // replaces it.
            Activity::Step { buffered } => *buffered = Some(cmd),
            _ => self.start_step(cmd),
        }
    }

    fn start_velocity(&mut self, v: f64, activity: Activity) {
        let k = self.kin();
        let v = limit(v, -self.lim.max_vel, self.lim.max_vel);
        let segs = traj::plan_velocity(k.vel, v, self.lim.max_acc.max(self.def.min_acc));
        let end = if v == 0.0 { End::Stop { snap: None } } else { End::Cruise };
        self.begin_motion();
        self.traj = Traj::Segs { t0: self.t, p0: k.pos, v0: k.vel, segs, end };
        self.activity = activity;
    }

    /// Current mode on an unloaded bench: the motor runs up to a speed
    /// proportional to the current (MaxVel at DefMaxCur).
    fn start_current(&mut self, amps: f64) {
        let cap = if self.config & config::ALLOW_FULL_CUR != 0 {
            self.lim.max_cur
        } else {
            self.lim.max_cur.min(self.def.nominal_cur())
        };
        let i = limit(amps, -cap, cap);
        if i != amps {
            self.faults |= state::CURLIMIT;
        }
        self.cmd_cur = i;
        self.start_velocity(self.def.max_vel * i / self.def.max_cur, Activity::Current);
    }

    fn set_motion(&mut self, m: Motion) -> Option<Response> {
        let def = table::motion(m.id)?;
        // The position when the command arrived, in the command's unit.
        let pos = match def.arg {
            MotionArg::Float => (self.kin().pos as f32).to_le_bytes(),
            MotionArg::Int32 | MotionArg::Int16 => self.act_ipos().to_le_bytes(),
        };
        self.submit(Request::SetMotion(m));
        Some(if def.extended_ack {
            Response::MotionAckExt { motion: m.id, pos, short_state: self.short_state(), dio: self.dio() }
        } else {
            Response::MotionAck { motion: m.id }
        })
    }

    /// Runs a motion command now, or keeps it for StartMotion (SYNC_MOTION,
    /// CAN only).
    fn submit(&mut self, req: Request) {
        if self.iface == Iface::Can && self.config & config::SYNC_MOTION != 0 {
            self.pending = Some(req);
        } else {
            self.execute(req);
        }
    }

    fn execute(&mut self, req: Request) {
        self.start_motion(req);
        // A motion that is over as soon as it starts (a ramp to where the
        // module stands) ends at once, as the state in an acknowledge shows.
        self.run_until(self.t);
    }

    fn start_motion(&mut self, req: Request) {
        let motion = match req {
            Request::SetMotion(m) => m,
            Request::SetIStep { target, time_ms } => {
                Motion { id: 11, value: MotionValue::Int32(target), time_ms: Some(time_ms) }
            }
            _ => return,
        };
        let Some(def) = table::motion(motion.id) else { return };
        if !self.motion_allowed() {
            return;
        }
        let inc = self.inc_ratio();
        let value = match (motion.value, def.kind) {
            (MotionValue::Float(x), _) => f64::from(x),
            (MotionValue::Int32(i), MotionKind::Current) => f64::from(i) * self.def.cur_ratio,
            (MotionValue::Int16(i), MotionKind::Current) => f64::from(i) * self.def.cur_ratio,
            (MotionValue::Int32(i), _) => f64::from(i) / inc,
            (MotionValue::Int16(i), _) => f64::from(i) / inc,
        };
        if !value.is_finite() {
            return;
        }
        self.move_mode = motion.id;
        let time_s = f64::from(motion.time_ms.unwrap_or(0)) / 1000.0;
        match def.kind {
            MotionKind::Ramp => self.start_ramp(value, self.ramp_vel(), self.ramp_acc()),
            MotionKind::RampLoop => self.start_ramp_loop(value),
            MotionKind::CosLoop => self.start_cos_loop(value, time_s),
            MotionKind::Step => self.step(StepCmd { target: value, time_s }),
            MotionKind::Velocity => self.start_velocity(value, Activity::Velocity),
            MotionKind::Current => self.start_current(value),
        }
    }

    pub(super) fn inc_ratio(&self) -> f64 {
        self.def.inc_ratio()
    }

    pub(super) fn to_ticks(&self, x: f64) -> i64 {
        (x * self.inc_ratio()).round() as i64
    }

    pub(super) fn act_ipos(&self) -> i32 {
        self.to_ticks(self.kin().pos).clamp(i32::MIN.into(), i32::MAX.into()) as i32
    }

    pub(super) fn pos_count(&self) -> i64 {
        self.to_ticks(self.kin().pos + self.count_offset)
    }

    /// Motor current in A: the command in current mode, otherwise what
    /// accelerating and friction would draw.
    pub(super) fn motor_current(&self) -> f64 {
        if self.activity == Activity::Current {
            return self.cmd_cur;
        }
        let k = self.kin();
        let i = 0.4 * self.def.max_cur * k.acc / self.def.max_acc + 0.1 * self.def.max_cur * k.vel / self.def.max_vel;
        limit(i, -self.lim.max_cur, self.lim.max_cur)
    }

    /// Seconds since the module was created, at the last `advance`.
    pub fn elapsed(&self) -> f64 {
        self.t
    }
}
