//! The checks a motion target passes before anything is sent: finite,
//! representable in the motion's wire type, and within the module's own
//! limits (MinPos / MaxPos / MaxVel / MaxAcc / MaxCur, or the ActI* tick
//! limits). The CLI (`move-*`) and the dashboard (jog, move to a typed
//! target) both call these, so both refuse exactly the same input with the
//! same words.

use super::{ModuleId, MotionValue};

/// A module's limits as read from it (units, or encoder ticks when `ticks`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    pub min_pos: f64,
    pub max_pos: f64,
    pub max_vel: f64,
    pub max_acc: f64,
    pub max_cur: f64,
    /// The position / velocity / acceleration limits are ActIMinPos.. (ticks).
    pub ticks: bool,
}

/// Why a value was refused; nothing was sent.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LimitError {
    #[error("{what} {value} exceeds module {module}'s {limit_name} = {limit}; nothing was sent")]
    Exceeds { what: &'static str, value: f64, module: ModuleId, limit_name: &'static str, limit: f64 },
    #[error("{what} {value} is not a finite number")]
    NotFinite { what: &'static str, value: f64 },
    #[error("{what} {value} is not a whole number of encoder ticks in the Int32 range")]
    NotTicks { what: &'static str, value: f64 },
    #[error("{what} must be positive, got {value}")]
    NotPositive { what: &'static str, value: f64 },
    #[error("{what} {value} is outside the manual's range {lo} to {hi}; nothing was sent")]
    OutsideManual { what: &'static str, value: f64, lo: f64, hi: f64 },
    /// The wire carries a 32-bit float: a larger value would go out as infinity.
    #[error("{what} {value} does not fit the wire's 32-bit float (|value| <= {})", f32::MAX)]
    NotFloat32 { what: &'static str, value: f64 },
}

/// `value` as the 32-bit float the wire carries, refused where it would
/// become infinite. `--force` skips the module's limits, never this.
pub fn float32(what: &'static str, value: f64) -> Result<f32, LimitError> {
    check_finite(what, value)?;
    let f = value as f32;
    if f.is_finite() {
        Ok(f)
    } else {
        Err(LimitError::NotFloat32 { what, value })
    }
}

fn check(
    ok: bool,
    what: &'static str,
    value: f64,
    limit_name: &'static str,
    limit: f64,
    module: ModuleId,
) -> Result<(), LimitError> {
    if ok {
        Ok(())
    } else {
        Err(LimitError::Exceeds { what, value, module, limit_name, limit })
    }
}

impl Limits {
    /// The parameter ids to read, in the order of the fields.
    pub fn param_ids(ticks: bool) -> [u8; 5] {
        use super::table::ids;
        if ticks {
            [ids::ACT_I_MIN_POS, ids::ACT_I_MAX_POS, ids::ACT_I_MAX_VEL, ids::ACT_I_MAX_ACC, ids::MAX_CUR]
        } else {
            [ids::MIN_POS, ids::MAX_POS, ids::MAX_VEL, ids::MAX_ACC, ids::MAX_CUR]
        }
    }

    /// From the values of [`Limits::param_ids`], in order.
    pub fn from_values(v: [f64; 5], ticks: bool) -> Self {
        Self { min_pos: v[0], max_pos: v[1], max_vel: v[2], max_acc: v[3], max_cur: v[4], ticks }
    }

    pub fn check_pos(&self, pos: f64, m: ModuleId) -> Result<(), LimitError> {
        check_finite("target position", pos)?;
        let (lo, hi) = if self.ticks { ("ActIMinPos", "ActIMaxPos") } else { ("MinPos", "MaxPos") };
        check(pos >= self.min_pos, "target position", pos, lo, self.min_pos, m)?;
        check(pos <= self.max_pos, "target position", pos, hi, self.max_pos, m)
    }

    /// A velocity's magnitude against MaxVel.
    pub fn check_vel(&self, vel: f64, m: ModuleId) -> Result<(), LimitError> {
        check_finite("velocity", vel)?;
        let name = if self.ticks { "ActIMaxVel" } else { "MaxVel" };
        check(vel.abs() <= self.max_vel, "velocity", vel, name, self.max_vel, m)
    }

    pub fn check_acc(&self, acc: f64, m: ModuleId) -> Result<(), LimitError> {
        check_finite("acceleration", acc)?;
        let name = if self.ticks { "ActIMaxAcc" } else { "MaxAcc" };
        check(acc <= self.max_acc, "acceleration", acc, name, self.max_acc, m)
    }

    /// A current's magnitude against MaxCur.
    pub fn check_cur(&self, amps: f64, m: ModuleId) -> Result<(), LimitError> {
        check_finite("current", amps)?;
        check(amps.abs() <= self.max_cur, "current", amps, "MaxCur", self.max_cur, m)
    }
}

/// The parameter writes that act like motion: a target or a commanded
/// current. What each is checked against, and whether that limit is read
/// in encoder ticks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SettingLimit {
    /// MinPos / MaxPos (ActIMinPos / ActIMaxPos).
    Pos { ticks: bool },
    /// MaxVel (ActIMaxVel), positive like a ramp's velocity.
    Vel { ticks: bool },
    /// MaxAcc (ActIMaxAcc), positive like a ramp's acceleration.
    Acc { ticks: bool },
    /// MaxCur, either sign.
    Cur,
    /// Current in digits: the manual's range only, no module limit.
    RawCur,
}

/// The manual gives RawCur as "Commanded Current in Digits [-500...+500]".
pub const RAW_CUR_RANGE: (f64, f64) = (-500.0, 500.0);

impl SettingLimit {
    /// The limit a write of parameter `id` is checked against, if any.
    pub fn of(id: u8) -> Option<Self> {
        use super::table::ids;
        Some(match id {
            ids::TARGET_POS => Self::Pos { ticks: false },
            ids::TARGET_POS_INC => Self::Pos { ticks: true },
            ids::TARGET_VEL => Self::Vel { ticks: false },
            ids::TARGET_VEL_INC => Self::Vel { ticks: true },
            ids::TARGET_ACC => Self::Acc { ticks: false },
            ids::TARGET_ACC_INC => Self::Acc { ticks: true },
            ids::CUR => Self::Cur,
            ids::RAW_CUR => Self::RawCur,
            _ => return None,
        })
    }

    /// Whether the module's limits are needed (read in ticks when `Some(true)`).
    pub fn module_limits(self) -> Option<bool> {
        match self {
            Self::Pos { ticks } | Self::Vel { ticks } | Self::Acc { ticks } => Some(ticks),
            Self::Cur => Some(false),
            Self::RawCur => None,
        }
    }

    /// The checks that need no module, which `--force` never skips: the
    /// manual's range, and a positive velocity or acceleration.
    pub fn check_manual(self, what: &'static str, value: f64) -> Result<(), LimitError> {
        check_finite(what, value)?;
        match self {
            Self::RawCur => {
                let (lo, hi) = RAW_CUR_RANGE;
                if value < lo || value > hi {
                    return Err(LimitError::OutsideManual { what, value, lo, hi });
                }
                Ok(())
            }
            Self::Vel { .. } | Self::Acc { .. } => check_positive(what, value),
            Self::Pos { .. } | Self::Cur => Ok(()),
        }
    }

    /// The module's own limit, as a move with this value is checked.
    pub fn check_module(self, value: f64, l: &Limits, m: ModuleId) -> Result<(), LimitError> {
        match self {
            Self::Pos { .. } => l.check_pos(value, m),
            Self::Vel { .. } => l.check_vel(value, m),
            Self::Acc { .. } => l.check_acc(value, m),
            Self::Cur => l.check_cur(value, m),
            Self::RawCur => Ok(()),
        }
    }
}

pub fn check_finite(what: &'static str, value: f64) -> Result<(), LimitError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(LimitError::NotFinite { what, value })
    }
}

/// Ramp velocities and accelerations must be positive.
pub fn check_positive(what: &'static str, value: f64) -> Result<(), LimitError> {
    if value > 0.0 {
        Ok(())
    } else {
        Err(LimitError::NotPositive { what, value })
    }
}

/// Why a module in this CubeState takes no motion command (error flags, or
/// halted), or `None` when it does: it would not move, and the user should
/// reset it first.
pub fn not_ready(cube_state: u32) -> Option<Vec<&'static str>> {
    use super::flags::{state, CUBE_STATE};
    let mut why = CUBE_STATE.decode(cube_state).errors;
    if cube_state & state::HALTED != 0 {
        why.push("STATE_HALTED");
    }
    (!why.is_empty()).then_some(why)
}

/// A value as the motion's wire type, range-checked for that type.
pub fn motion_value(v: f64, ticks: bool, what: &'static str) -> Result<MotionValue, LimitError> {
    check_finite(what, v)?;
    if ticks {
        if v.fract() != 0.0 || v < f64::from(i32::MIN) || v > f64::from(i32::MAX) {
            return Err(LimitError::NotTicks { what, value: v });
        }
        Ok(MotionValue::Int32(v as i32))
    } else {
        Ok(MotionValue::Float(float32(what, v)?))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m17() -> ModuleId {
        ModuleId::new(17).unwrap()
    }

    const LIN: Limits = Limits { min_pos: 0.0, max_pos: 1.0, max_vel: 0.1, max_acc: 0.5, max_cur: 5.0, ticks: false };

    #[test]
    fn motion_values_must_fit_the_wire_float() {
        for v in [1e39, -1e39, f64::MAX, f64::INFINITY, f64::NAN] {
            assert!(motion_value(v, false, "target position").is_err(), "{v}");
            assert!(float32("current", v).is_err(), "{v}");
        }
        let max = f64::from(f32::MAX);
        assert_eq!(motion_value(max, false, "velocity"), Ok(MotionValue::Float(f32::MAX)));
        assert_eq!(float32("current", -max), Ok(f32::MIN));
    }

    #[test]
    fn refusals_name_the_limit_and_say_nothing_was_sent() {
        assert_eq!(
            LIN.check_pos(5.0, m17()).unwrap_err().to_string(),
            "target position 5 exceeds module 17's MaxPos = 1; nothing was sent"
        );
        assert_eq!(
            LIN.check_pos(-0.5, m17()).unwrap_err().to_string(),
            "target position -0.5 exceeds module 17's MinPos = 0; nothing was sent"
        );
        assert!(LIN.check_pos(0.75, m17()).is_ok());
        assert!(LIN.check_pos(1.0, m17()).is_ok(), "the limit itself is allowed");
        assert!(matches!(LIN.check_vel(-0.2, m17()), Err(LimitError::Exceeds { limit_name: "MaxVel", .. })));
        assert!(LIN.check_vel(-0.1, m17()).is_ok());
        assert!(matches!(LIN.check_cur(6.0, m17()), Err(LimitError::Exceeds { limit_name: "MaxCur", .. })));
        assert!(matches!(LIN.check_pos(f64::NAN, m17()), Err(LimitError::NotFinite { .. })));
        let ticks = Limits { ticks: true, ..LIN };
        assert!(matches!(ticks.check_pos(2.0, m17()), Err(LimitError::Exceeds { limit_name: "ActIMaxPos", .. })));
    }

    #[test]
    fn settings_that_act_like_motion_are_checked_like_motion() {
        use crate::proto::powercube::table::ids;
        let raw = SettingLimit::of(ids::RAW_CUR).unwrap();
        assert!(raw.check_manual("RawCur", 500.0).is_ok());
        assert!(raw.check_manual("RawCur", -500.0).is_ok());
        assert_eq!(
            raw.check_manual("RawCur", 501.0).unwrap_err().to_string(),
            "RawCur 501 is outside the manual's range -500 to 500; nothing was sent"
        );
        assert!(raw.check_manual("RawCur", -501.0).is_err());
        assert_eq!(raw.module_limits(), None);
        let vel = SettingLimit::of(ids::TARGET_VEL).unwrap();
        assert!(matches!(vel.check_manual("TargetVel", 0.0), Err(LimitError::NotPositive { .. })));
        assert!(matches!(vel.check_module(0.2, &LIN, m17()), Err(LimitError::Exceeds { limit_name: "MaxVel", .. })));
        let acc = SettingLimit::of(ids::TARGET_ACC).unwrap();
        assert!(matches!(acc.check_module(0.6, &LIN, m17()), Err(LimitError::Exceeds { limit_name: "MaxAcc", .. })));
        assert!(acc.check_module(0.5, &LIN, m17()).is_ok());
        let pos = SettingLimit::of(ids::TARGET_POS).unwrap();
        assert!(pos.check_manual("TargetPos", -3.0).is_ok(), "positions may be negative");
        assert!(matches!(pos.check_module(-0.1, &LIN, m17()), Err(LimitError::Exceeds { limit_name: "MinPos", .. })));
        let cur = SettingLimit::of(ids::CUR).unwrap();
        assert!(matches!(cur.check_module(-6.0, &LIN, m17()), Err(LimitError::Exceeds { limit_name: "MaxCur", .. })));
        for (id, want) in [
            (ids::TARGET_POS_INC, SettingLimit::Pos { ticks: true }),
            (ids::TARGET_VEL_INC, SettingLimit::Vel { ticks: true }),
            (ids::TARGET_ACC_INC, SettingLimit::Acc { ticks: true }),
        ] {
            assert_eq!(SettingLimit::of(id), Some(want), "{id:#04x}");
            assert_eq!(want.module_limits(), Some(true), "checked against the ActI* limits");
        }
        assert_eq!(SettingLimit::of(ids::MAX_VEL), None, "a limit itself is not a motion");
    }

    #[test]
    fn halted_or_faulted_modules_are_not_ready() {
        use crate::proto::powercube::flags::state;
        assert_eq!(not_ready(state::HOME_OK | state::RAMP_END), None);
        assert_eq!(not_ready(state::HALTED | state::HOME_OK), Some(vec!["STATE_HALTED"]));
        assert_eq!(
            not_ready(state::ERROR | state::TOW_ERROR | state::HALTED),
            Some(vec!["STATE_ERROR", "STATE_TOW_ERROR", "STATE_HALTED"])
        );
    }

    #[test]
    fn tick_values_must_be_whole_int32() {
        assert_eq!(motion_value(12.0, true, "target position"), Ok(MotionValue::Int32(12)));
        assert!(matches!(motion_value(1.5, true, "x"), Err(LimitError::NotTicks { .. })));
        assert!(matches!(motion_value(3e9, true, "x"), Err(LimitError::NotTicks { .. })));
        // Below Int32 too: `as i32` would saturate to i32::MIN and send it.
        assert!(matches!(motion_value(-3e9, true, "x"), Err(LimitError::NotTicks { .. })));
        for edge in [i32::MIN, i32::MAX] {
            assert_eq!(motion_value(f64::from(edge), true, "x"), Ok(MotionValue::Int32(edge)), "{edge}");
        }
        assert_eq!(motion_value(0.25, false, "x"), Ok(MotionValue::Float(0.25)));
        assert!(matches!(check_positive("velocity", 0.0), Err(LimitError::NotPositive { .. })));
    }
}
