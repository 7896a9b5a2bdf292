//! One simulated axis: parameters, position counter, motion and switches.
//!
//! Motion is kept on the axis' physical scale (the reference switch at 0,
//! see [`config`]) as a closed-form trajectory; the position counter the
//! protocol shows is `physical - offset`, so setting or referencing the
//! counter never moves the trajectory.

use super::config;
use crate::proto::pac::table::Condition;
use crate::sim::powercube::traj::{self, End, Kin, Traj};
use crate::sim::powercube::ResponseFault;

/// What an axis does while its trajectory runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotionKind {
    /// A positioning (0A87 / 0A89 / 0A94 / 0A95).
    Move,
    /// A manual move (0A90 / 0A91) that stops unless kept alive by `deadline`.
    Manual { deadline: f64 },
    /// A reference drive (0A84).
    Reference,
    /// Braking to standstill after a stop.
    Stop,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Distinguishes motions, so that a poll knows whether the move it waits
    /// for is still the one running.
    pub id: u64,
    pub kind: MotionKind,
    pub end: f64,
}

/// How an axis came to rest (the 1910 status when standing).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rest {
    InPosition,
    Stopped,
    Fault,
}

/// A timed event of an axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Event {
    /// The trajectory ended.
    End,
    /// A manual move was not kept alive.
    ManualTimeout,
    /// A limit switch was reached with monitoring on (`true` = positive).
    LimitSwitch { positive: bool },
}

#[derive(Debug, Clone)]
pub struct Axis {
    /// Axis parameters 1..=50 at index 0..50.
    pub params: [f64; 50],
    pub traj: Traj,
    pub motion: Option<Motion>,
    /// physical = counter + offset.
    pub offset: f64,
    /// 0A86 (G29) shifts the software limits with the counter.
    pub limit_shift: f64,
    /// Released for traversing (reference drive, 0A83, 0A96).
    pub released: bool,
    pub referenced: bool,
    pub on: bool,
    pub measuring: bool,
    pub power_ready: bool,
    pub monitoring: bool,
    /// Bench overrides of the [negative, positive] switch states.
    pub forced: [Option<bool>; 2],
    /// 0A8D / 0A8E values, valid until online mode ends.
    pub online_speed: Option<f64>,
    pub online_acc: Option<f64>,
    pub rest: Rest,
    /// 0AA3: armed for the next move / guarding the running one.
    pub armed_condition: Option<Condition>,
    pub active_condition: Option<Condition>,
    /// SR71..: counter target of the last traverse command.
    pub last_target: f64,
    /// SR51..: counter position when the axis was last switched off.
    pub off_position: f64,
    /// `sim --fault overshoot=PCT,slow-halt=DUR`: a positioning rings past
    /// its target (moving until the ring ends), a stop brakes over DUR.
    pub response: ResponseFault,
    /// Where the running positioning started (physical): the ring's step.
    move_from: f64,
    /// The ring after a positioning runs: its end is the motion's end.
    ringing: bool,
}

/// The half period and number of half periods of the overshoot ring (as a
/// PowerCube module's).
const RING_HALF_S: f64 = 0.15;
const RING_HALVES: u32 = 6;

impl Axis {
    pub fn new(number: u8) -> Self {
        let mut params = [0.0; 50];
        for (i, p) in params.iter_mut().enumerate() {
            *p = config::axis_param(i as u8 + 1).map_or(0.0, |c| c.default);
        }
        let pos = config::power_up_position(number);
        Self {
            params,
            traj: Traj::Hold { pos },
            motion: None,
            offset: 0.0,
            limit_shift: 0.0,
            released: false,
            referenced: false,
            on: true,
            measuring: false,
            power_ready: true,
            monitoring: true,
            forced: [None, None],
            online_speed: None,
            online_acc: None,
            rest: Rest::InPosition,
            armed_condition: None,
            active_condition: None,
            last_target: pos,
            off_position: pos,
            response: ResponseFault::default(),
            move_from: pos,
            ringing: false,
        }
    }

    pub fn param(&self, number: u8) -> f64 {
        self.params[usize::from(number.clamp(1, 50)) - 1]
    }

    pub fn kin(&self, t: f64) -> Kin {
        self.traj.eval(t)
    }

    pub fn physical(&self, t: f64) -> f64 {
        self.kin(t).pos
    }

    /// The position counter.
    pub fn position(&self, t: f64) -> f64 {
        self.physical(t) - self.offset
    }

    pub fn speed(&self, t: f64) -> f64 {
        if self.motion.is_some() {
            self.kin(t).vel.abs()
        } else {
            0.0
        }
    }

    pub fn moving(&self) -> bool {
        self.motion.is_some()
    }

    /// The 1910 status.
    pub fn status(&self) -> u8 {
        if self.measuring {
            8
        } else if self.moving() {
            1
        } else {
            match self.rest {
                Rest::InPosition => 0,
                Rest::Stopped => 2,
                Rest::Fault => 4,
            }
        }
    }

    /// Whether a limit switch is activated now (`positive` picks which).
    pub fn switch_active(&self, positive: bool, t: f64) -> bool {
        let p = self.physical(t);
        match self.forced[usize::from(positive)] {
            Some(state) => state,
            None if positive => p >= config::POSITIVE_SWITCH,
            None => p <= config::NEGATIVE_SWITCH,
        }
    }

    /// The 1921 word (specs README): power pack ready, switches (1 = not
    /// activated), axis status.
    pub fn ext_status(&self, t: f64) -> u32 {
        (u32::from(self.power_ready) << 24)
            | (u32::from(!self.switch_active(true, t)) << 16)
            | (u32::from(!self.switch_active(false, t)) << 8)
            | u32::from(self.status())
    }

    /// The software limits on the counter's scale.
    pub fn limits(&self) -> (f64, f64) {
        (self.param(8) + self.limit_shift, self.param(9) + self.limit_shift)
    }

    pub fn speed_for_moves(&self) -> f64 {
        self.online_speed.unwrap_or(self.param(1))
    }

    pub fn acceleration(&self) -> f64 {
        self.online_acc.unwrap_or(self.param(6))
    }

    /// Starts a rest-to-rest profile made of `legs` (physical targets, each
    /// with its speed), ending at the last target.
    pub fn start(&mut self, t: f64, legs: &[(f64, f64)], kind: MotionKind, id: u64) {
        let p0 = self.physical(t);
        let acc = self.acceleration().max(f64::MIN_POSITIVE);
        let mut segs = Vec::new();
        let mut from = p0;
        for &(target, speed) in legs {
            segs.extend(traj::plan_ramp(from, 0.0, target, speed.max(f64::MIN_POSITIVE), acc));
            from = target;
        }
        let end = t + traj::duration(&segs);
        self.traj = Traj::Segs { t0: t, p0, v0: 0.0, segs, end: End::Stop { snap: Some(from) } };
        self.motion = Some(Motion { id, kind, end });
        self.move_from = p0;
        self.ringing = false;
    }

    /// Brakes to standstill at the axis' acceleration.
    pub fn stop(&mut self, t: f64, id: u64) {
        if self.motion.is_none() {
            return;
        }
        let k = self.kin(t);
        self.ringing = false;
        let segs = match self.response.halt_time {
            d if d > 0.0 && k.vel != 0.0 => vec![traj::Seg { dur: d, acc: -k.vel / d, phase: traj::Phase::Dec }],
            _ => traj::plan_velocity(k.vel, 0.0, self.acceleration().max(f64::MIN_POSITIVE)),
        };
        let end = t + traj::duration(&segs);
        self.traj = Traj::Segs { t0: t, p0: k.pos, v0: k.vel, segs, end: End::Stop { snap: None } };
        self.motion = Some(Motion { id, kind: MotionKind::Stop, end });
        self.active_condition = None;
    }

    /// Stands still where it is at once.
    pub fn halt(&mut self, t: f64, rest: Rest) {
        let pos = self.physical(t);
        self.traj = Traj::Hold { pos };
        if self.motion.take().is_some() || rest == Rest::Fault {
            self.rest = rest;
        }
        self.active_condition = None;
    }

    /// The next timed event not before `from`, with its time.
    pub fn next_event(&self, from: f64) -> Option<(f64, Event)> {
        let m = self.motion?;
        let mut best = (m.end, Event::End);
        if let MotionKind::Manual { deadline } = m.kind {
            if deadline < best.0 {
                best = (deadline, Event::ManualTimeout);
            }
        }
        if self.monitoring {
            if let Some(tc) = self.traj.first_exit(config::NEGATIVE_SWITCH, config::POSITIVE_SWITCH, from) {
                if tc < best.0 {
                    let positive = self.traj.eval(tc).vel > 0.0;
                    best = (tc, Event::LimitSwitch { positive });
                }
            }
        }
        Some((best.0.max(from), best.1))
    }

    /// The trajectory ended at `t`.
    pub fn finish(&mut self, t: f64) {
        let Some(m) = self.motion else { return };
        let here = self.physical(t);
        if m.kind == MotionKind::Move && !self.ringing && self.response.overshoot > 0.0 && here != self.move_from {
            let amp = self.response.overshoot * (here - self.move_from);
            self.traj = Traj::Ring { t0: t, target: here, amp, half: RING_HALF_S, halves: RING_HALVES };
            self.motion = Some(Motion { end: t + RING_HALF_S * f64::from(RING_HALVES), ..m });
            self.ringing = true;
            return;
        }
        self.ringing = false;
        self.halt(t, if m.kind == MotionKind::Stop { Rest::Stopped } else { Rest::InPosition });
        if m.kind == MotionKind::Reference {
            // Manual 5.2.6.3: the counter is set to zero when the flag is set.
            self.offset = self.physical(t);
            self.limit_shift = 0.0;
            self.referenced = true;
            self.released = true;
        }
    }
}
