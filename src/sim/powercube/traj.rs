//! Trajectories as closed-form functions of time.
//!
//! Every motion the simulated module makes is a piecewise constant-acceleration
//! profile (ramps, steps, velocity and current mode, homing), a periodic ramp
//! loop or a cosine loop. Position and velocity at any instant are computed from
//! the profile's start, never integrated step by step, so the simulation gives
//! the same answer however `advance` calls are spaced.

/// Which part of a ramp profile a segment belongs to (the RAMP_* flags).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Acc,
    Steady,
    Dec,
}

/// Constant acceleration for `dur` seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Seg {
    pub dur: f64,
    pub acc: f64,
    pub phase: Phase,
}

/// What happens after the last segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum End {
    /// The profile ends at rest; `snap` is the exact end position (the target),
    /// absorbing rounding of the segment sums.
    Stop { snap: Option<f64> },
    /// Keeps the final velocity forever (velocity and current mode).
    Cruise,
}

/// The kinematic state at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kin {
    pub pos: f64,
    pub vel: f64,
    pub acc: f64,
    /// The ramp phase, where the profile is inside a segment.
    pub phase: Option<Phase>,
}

impl Kin {
    pub fn rest(pos: f64) -> Self {
        Self { pos, vel: 0.0, acc: 0.0, phase: None }
    }
}

/// A trajectory; times are seconds on the module's clock.
#[derive(Debug, Clone, PartialEq)]
pub enum Traj {
    Hold {
        pos: f64,
    },
    Segs {
        t0: f64,
        p0: f64,
        v0: f64,
        segs: Vec<Seg>,
        end: End,
    },
    /// Ramps back and forth between `from` and `to`, starting at rest at `from`
    /// at `t0`; `leg` is the rest-to-rest profile for the distance `to - from`.
    RampLoop {
        t0: f64,
        from: f64,
        to: f64,
        leg: Vec<Seg>,
    },
    /// `from + (to - from) * (1 - cos(pi * t / half)) / 2`: rest at both ends.
    CosLoop {
        t0: f64,
        from: f64,
        to: f64,
        half: f64,
    },
    /// The overshoot fault's ring after a ramp: `target + amp * d^k *
    /// sin(pi t / half)` in the k-th half period (`d` = [`RING_DECAY`]),
    /// for `halves` half periods, then rest on `target`. The first peak is
    /// exactly `amp` past the target, so the overshoot a recording measures
    /// is the one the fault asked for.
    Ring {
        t0: f64,
        target: f64,
        amp: f64,
        half: f64,
        halves: u32,
    },
}

/// How much of its swing the ring keeps from one half period to the next.
pub const RING_DECAY: f64 = 0.25;

fn step(p: f64, v: f64, a: f64, dt: f64) -> (f64, f64) {
    (p + v * dt + 0.5 * a * dt * dt, v + a * dt)
}

/// Total duration of a segment list.
pub fn duration(segs: &[Seg]) -> f64 {
    segs.iter().map(|s| s.dur).sum()
}

/// Evaluates a segment list started at `(p0, v0)` after `dt` seconds.
fn eval_segs(p0: f64, v0: f64, segs: &[Seg], end: End, dt: f64) -> Kin {
    let (mut p, mut v) = (p0, v0);
    let mut rem = dt.max(0.0);
    for s in segs {
        if rem < s.dur {
            let (pp, vv) = step(p, v, s.acc, rem);
            return Kin { pos: pp, vel: vv, acc: s.acc, phase: Some(s.phase) };
        }
        (p, v) = step(p, v, s.acc, s.dur);
        rem -= s.dur;
    }
    match end {
        End::Stop { snap } => Kin::rest(snap.unwrap_or(p)),
        End::Cruise => Kin { pos: p + v * rem, vel: v, acc: 0.0, phase: None },
    }
}

impl Traj {
    pub fn eval(&self, t: f64) -> Kin {
        match self {
            Self::Hold { pos } => Kin::rest(*pos),
            Self::Segs { t0, p0, v0, segs, end } => eval_segs(*p0, *v0, segs, *end, t - t0),
            Self::RampLoop { t0, from, to, leg } => {
                let d = duration(leg);
                if d <= 0.0 {
                    return Kin::rest(*from);
                }
                let period = 2.0 * d;
                let ph = (t - t0).max(0.0).rem_euclid(period);
                // The outbound leg runs from `from`; the return leg is the same
                // profile mirrored, starting at `to`.
                let (start, sign, dt) = if ph < d { (*from, 1.0, ph) } else { (*to, -1.0, ph - d) };
                let k = eval_segs(0.0, 0.0, leg, End::Cruise, dt);
                Kin { pos: start + sign * k.pos, vel: sign * k.vel, acc: sign * k.acc, phase: k.phase }
            }
            Self::CosLoop { t0, from, to, half } => {
                let w = std::f64::consts::PI / half;
                let dt = (t - t0).max(0.0);
                let amp = (to - from) / 2.0;
                Kin {
                    pos: from + amp * (1.0 - (w * dt).cos()),
                    vel: amp * w * (w * dt).sin(),
                    acc: amp * w * w * (w * dt).cos(),
                    phase: None,
                }
            }
            Self::Ring { t0, target, amp, half, halves } => {
                let dt = (t - t0).max(0.0);
                let k = (dt / half).floor();
                if k >= f64::from(*halves) {
                    return Kin::rest(*target);
                }
                let w = std::f64::consts::PI / half;
                let a = amp * RING_DECAY.powf(k);
                Kin {
                    pos: target + a * (w * dt).sin(),
                    vel: a * w * (w * dt).cos(),
                    acc: -a * w * w * (w * dt).sin(),
                    phase: None,
                }
            }
        }
    }

    /// Where a profile that ends at its target stops.
    pub fn end_pos(&self) -> Option<f64> {
        match self {
            Self::Segs { end: End::Stop { snap }, .. } => *snap,
            Self::Ring { target, .. } => Some(*target),
            _ => None,
        }
    }

    /// When a profile that ends at rest is over.
    pub fn end_time(&self) -> Option<f64> {
        match self {
            Self::Segs { t0, segs, end: End::Stop { .. }, .. } => Some(t0 + duration(segs)),
            Self::Ring { t0, half, halves, .. } => Some(t0 + half * f64::from(*halves)),
            _ => None,
        }
    }

    /// The first time, not before `from_t`, at which the trajectory moves out
    /// of `[min, max]` (moving outward beyond a bound; a module already beyond
    /// a bound may move back in). Only segment profiles can leave the range:
    /// loops run between targets already clamped into it, and the overshoot
    /// fault's ring is a fault of the simulation, not a motion the limits
    /// supervise.
    pub fn first_exit(&self, min: f64, max: f64, from_t: f64) -> Option<f64> {
        let Self::Segs { t0, p0, v0, segs, end } = self else { return None };
        let (mut p, mut v) = (*p0, *v0);
        let mut t = *t0;
        let tail = match end {
            End::Cruise => Some(Seg { dur: f64::INFINITY, acc: 0.0, phase: Phase::Steady }),
            End::Stop { .. } => None,
        };
        for s in segs.iter().chain(tail.iter()) {
            let seg_end = t + s.dur;
            if seg_end >= from_t {
                let skip = (from_t - t).max(0.0);
                let (ps, vs) = step(p, v, s.acc, skip);
                let rem = s.dur - skip;
                let up = first_cross_up(ps, vs, s.acc, rem, max);
                let down = first_cross_up(-ps, -vs, -s.acc, rem, -min);
                let hit = match (up, down) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
                if let Some(h) = hit {
                    return Some(t + skip + h);
                }
            }
            if s.dur.is_infinite() {
                break;
            }
            (p, v) = step(p, v, s.acc, s.dur);
            t = seg_end;
        }
        None
    }
}

/// Earliest `tau` in `[0, dur]` at which `p + v tau + a tau^2 / 2` exceeds
/// `m` while increasing.
fn first_cross_up(p: f64, v: f64, a: f64, dur: f64, m: f64) -> Option<f64> {
    if p >= m && (v > 0.0 || (v == 0.0 && a > 0.0)) {
        return Some(0.0);
    }
    // Beyond the bound and moving back in, then turning outward again before
    // it is back in range: the module leaves when its velocity turns, at
    // `-v / a`. Without this the move on beyond the limit would never be
    // caught (no crossing of `m` happens), while a poll taken just after the
    // turn sees "beyond and moving outward" and trips there.
    if p >= m && v < 0.0 && a > 0.0 {
        let turn = -v / a;
        if turn <= dur && p + v * turn + a * turn * turn / 2.0 >= m {
            return Some(turn);
        }
    }
    let c = p - m;
    let mut best: Option<f64> = None;
    let mut consider = |tau: f64| {
        if tau.is_finite() && tau >= 0.0 && tau <= dur && v + a * tau > 0.0 {
            best = Some(best.map_or(tau, |b: f64| b.min(tau)));
        }
    };
    if a.abs() < 1e-15 {
        if v.abs() > 0.0 {
            consider(-c / v);
        }
    } else {
        let disc = v * v - 2.0 * a * c;
        if disc >= 0.0 {
            let sq = disc.sqrt();
            consider((-v - sq) / a);
            consider((-v + sq) / a);
        }
    }
    best
}

/// A rest-or-moving to rest move from `(p0, v0)` to `target`, limited by
/// `vmax` and `amax` (both > 0): trapezoidal where the distance allows,
/// triangular otherwise. A module moving away from the target, or too fast to
/// stop in time, first brakes at `amax` and comes back.
pub fn plan_ramp(p0: f64, v0: f64, target: f64, vmax: f64, amax: f64) -> Vec<Seg> {
    let mut segs = Vec::new();
    let (mut p, mut v) = (p0, v0);
    // Each pass removes one obstacle (moving away, overspeed, overshoot);
    // a handful always suffices.
    for _ in 0..8 {
        let d = target - p;
        if d == 0.0 && v == 0.0 {
            break;
        }
        let s = if d != 0.0 { d.signum() } else { -v.signum() };
        let u = s * v;
        let dist = d.abs();
        if u < 0.0 {
            push(&mut segs, &mut p, &mut v, -u / amax, s * amax, Phase::Dec);
            v = 0.0;
            continue;
        }
        if u > vmax * (1.0 + 1e-12) {
            push(&mut segs, &mut p, &mut v, (u - vmax) / amax, -s * amax, Phase::Dec);
            v = s * vmax;
            continue;
        }
        let u = u.min(vmax);
        let stop = u * u / (2.0 * amax);
        if stop > dist * (1.0 + 1e-9) + 1e-15 {
            push(&mut segs, &mut p, &mut v, u / amax, -s * amax, Phase::Dec);
            v = 0.0;
            continue;
        }
        let vp = (amax * dist + u * u / 2.0).sqrt();
        if vp <= vmax {
            push(&mut segs, &mut p, &mut v, (vp - u) / amax, s * amax, Phase::Acc);
            push(&mut segs, &mut p, &mut v, vp / amax, -s * amax, Phase::Dec);
        } else {
            let acc_dist = (vmax * vmax - u * u) / (2.0 * amax);
            let dec_dist = vmax * vmax / (2.0 * amax);
            push(&mut segs, &mut p, &mut v, (vmax - u) / amax, s * amax, Phase::Acc);
            push(&mut segs, &mut p, &mut v, (dist - acc_dist - dec_dist) / vmax, 0.0, Phase::Steady);
            push(&mut segs, &mut p, &mut v, vmax / amax, -s * amax, Phase::Dec);
        }
        break;
    }
    segs
}

fn push(segs: &mut Vec<Seg>, p: &mut f64, v: &mut f64, dur: f64, acc: f64, phase: Phase) {
    let dur = dur.max(0.0);
    if dur > 0.0 {
        segs.push(Seg { dur, acc, phase });
        (*p, *v) = step(*p, *v, acc, dur);
    }
}

/// Changes velocity from `v0` to `v1` at `amax`.
pub fn plan_velocity(v0: f64, v1: f64, amax: f64) -> Vec<Seg> {
    let dv = v1 - v0;
    if dv == 0.0 {
        return Vec::new();
    }
    let phase = if v1.abs() > v0.abs() { Phase::Acc } else { Phase::Dec };
    vec![Seg { dur: dv.abs() / amax, acc: dv.signum() * amax, phase }]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn end_of(p0: f64, v0: f64, segs: &[Seg]) -> (f64, f64) {
        let k = eval_segs(p0, v0, segs, End::Cruise, duration(segs));
        (k.pos, k.vel)
    }

    #[test]
    fn trapezoid_has_the_textbook_duration() {
        // 0 -> 0.75 at 0.08 / 0.5 (the manual's section 8/9 values):
        // t = d / v + v / a.
        let segs = plan_ramp(0.0, 0.0, 0.75, 0.08, 0.5);
        assert_eq!(segs.iter().map(|s| s.phase).collect::<Vec<_>>(), [Phase::Acc, Phase::Steady, Phase::Dec]);
        assert!((duration(&segs) - (0.75 / 0.08 + 0.08 / 0.5)).abs() < 1e-9);
        let (p, v) = end_of(0.0, 0.0, &segs);
        assert!((p - 0.75).abs() < 1e-9 && v.abs() < 1e-9);
    }

    #[test]
    fn short_moves_are_triangular() {
        let segs = plan_ramp(1.0, 0.0, 0.9, 1.0, 2.0);
        assert_eq!(segs.len(), 2);
        // d = a t^2 / 4 over the whole move: t = 2 sqrt(d / a).
        assert!((duration(&segs) - 2.0 * (0.1f64 / 2.0).sqrt()).abs() < 1e-9);
        let (p, v) = end_of(1.0, 0.0, &segs);
        assert!((p - 0.9).abs() < 1e-9 && v.abs() < 1e-9);
    }

    #[test]
    fn replanning_handles_any_start_velocity() {
        for (p0, v0, target) in [(0.0, -1.0, 1.0), (0.0, 3.0, 1.0), (0.0, 1.0, 0.01), (0.5, 0.5, 0.5), (0.0, 0.0, 0.0)]
        {
            let segs = plan_ramp(p0, v0, target, 1.5, 3.0);
            let (p, v) = end_of(p0, v0, &segs);
            assert!((p - target).abs() < 1e-9, "{p0} {v0} {target}: ends at {p}");
            assert!(v.abs() < 1e-9);
            for s in &segs {
                assert!(s.acc.abs() <= 3.0 + 1e-12);
            }
        }
    }

    #[test]
    fn exits_are_found_on_the_way_out_only() {
        let t = Traj::Segs { t0: 1.0, p0: 0.0, v0: 0.0, segs: plan_velocity(0.0, 1.0, 2.0), end: End::Cruise };
        // 0.25 m during 0.5 s of acceleration, then 1 m/s: reaches 1.0 at 1.0 + 0.5 + 0.75.
        let hit = t.first_exit(-1.0, 1.0, 1.0).unwrap();
        assert!((hit - 2.25).abs() < 1e-9, "{hit}");
        // Already beyond the bound but moving back in: no exit.
        let back = Traj::Segs { t0: 0.0, p0: 2.0, v0: -1.0, segs: vec![], end: End::Cruise };
        assert_eq!(back.first_exit(-10.0, 1.0, 0.0), Some(12.0), "leaves at the other end only");
        let out = Traj::Segs { t0: 0.0, p0: -2.0, v0: -1.0, segs: vec![], end: End::Cruise };
        assert_eq!(out.first_exit(-1.0, 1.0, 0.5), Some(0.5));
    }

    // The proptest regression of extra_advance_calls_change_nothing (MaxPos
    // -0.0 = MinPos, the module 2e-7 beyond it): a velocity command from a
    // slow inward step turns outward without ever coming back in range. The
    // exit is the turn; before, lazy evaluation missed it while a poll just
    // after the turn tripped, so the two disagreed.
    #[test]
    fn beyond_a_bound_turning_outward_leaves_at_the_turn() {
        let segs = plan_velocity(-1e-6, 1.0, 2.0);
        let t = Traj::Segs { t0: 0.0, p0: 2e-7, v0: -1e-6, segs, end: End::Cruise };
        let hit = t.first_exit(-1e-7, 1e-7, 0.0).unwrap();
        assert!((hit - 0.5e-6).abs() < 1e-15, "{hit}");
        assert_eq!(t.first_exit(-1e-7, 1e-7, 0.0), t.first_exit(-1e-7, 1e-7, 0.25e-6), "polling changes nothing");
        // Turning while back in range is no exit.
        let t = Traj::Segs { t0: 0.0, p0: 2e-7, v0: -1.0, segs: plan_velocity(-1.0, 1.0, 2.0), end: End::Cruise };
        let hit = t.first_exit(-1.0, 1e-7, 0.0).unwrap();
        assert!(hit > 0.5, "crosses back out after the turn: {hit}");
    }

    #[test]
    fn loops_are_periodic() {
        let leg = plan_ramp(0.0, 0.0, 1.0, 1.0, 1.0);
        let d = duration(&leg);
        let l = Traj::RampLoop { t0: 0.0, from: 0.0, to: 1.0, leg };
        assert!((l.eval(d).pos - 1.0).abs() < 1e-9);
        assert!(l.eval(2.0 * d).pos.abs() < 1e-9);
        assert!((l.eval(1000.0 * d + 0.3).pos - l.eval(0.3).pos).abs() < 1e-6);
        let c = Traj::CosLoop { t0: 0.0, from: 0.0, to: 1.0, half: 2.0 };
        assert!((c.eval(2.0).pos - 1.0).abs() < 1e-12);
        assert!(c.eval(4.0).pos.abs() < 1e-12);
    }
}
