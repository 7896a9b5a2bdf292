//! Checks a command against the table before it is sent, so that a typo
//! becomes a typed error on the PC instead of a command error (or a move)
//! on the controller.
//!
//! [`validate`] uses what the manual states; [`validate_in`] adds what is
//! known about the controller at hand ([`Context`]: configured axes, current
//! operating status, limits read with 1701 / 1702 / 1801 / 1802).

use std::collections::BTreeMap;

use super::frame::{Command, Par2};
use super::table::{self, CommandDef, Condition, DataType, Mode, Modes, Par1Kind, Par2Kind};

/// What is known about the controller.
#[derive(Debug, Clone, PartialEq)]
pub struct Context {
    /// Configured axes (system parameter 2); at most [`table::MAX_AXES`].
    pub axes: u8,
    /// STATUS of the latest acknowledge; `None` skips the mode check.
    pub status: Option<u16>,
    /// (min, max) of axis parameters as read with 1802 / 1801, by PAR_1
    /// (axis * 256 + parameter).
    pub axis_param_limits: BTreeMap<i64, (f64, f64)>,
    /// (min, max) of system parameters as read with 1702 / 1701, by number.
    pub system_param_limits: BTreeMap<i64, (i64, i64)>,
}

impl Default for Context {
    fn default() -> Self {
        Self {
            axes: table::MAX_AXES,
            status: None,
            axis_param_limits: BTreeMap::new(),
            system_param_limits: BTreeMap::new(),
        }
    }
}

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValidationError {
    #[error("unknown command code {code:04X}")]
    UnknownCommand { code: u16 },
    #[error("command {code:04X} is sent with TYP {expected} ({expected_type:?}), not {got}")]
    WrongType { code: u16, expected: u8, expected_type: DataType, got: u8 },
    #[error("axis {axis} out of range 1 to {max}")]
    Axis { axis: i64, max: u8 },
    #[error("{what} {value} out of range {min} to {max}")]
    Par1Range { what: &'static str, value: i64, min: i64, max: i64 },
    #[error("unknown system parameter {0}")]
    UnknownSystemParameter(i64),
    #[error("system parameter {0} is not used")]
    UnusedSystemParameter(i64),
    #[error("unknown axis parameter {param} (PAR_1 {par1} = axis {axis} * 256 + {param})")]
    UnknownAxisParameter { par1: i64, axis: u8, param: u8 },
    #[error("{what} {value} out of range {min} to {max}")]
    Par2Range { what: String, value: f64, min: f64, max: f64 },
    #[error("{what} {value} is not a whole number")]
    NotIntegral { what: &'static str, value: f64 },
    #[error("{value:#x} is not a valid 0AA3 condition (condition << 24 | type << 16 | number)")]
    BadCondition { value: i64 },
    #[error("command {code:04X} is not valid in {} mode (valid in: {valid})", mode.name())]
    NotInMode { code: u16, mode: Mode, valid: Modes },
}

/// Checks `cmd` against the manual's ranges, for a controller with 16 axes.
pub fn validate(cmd: &Command) -> Result<&'static CommandDef, ValidationError> {
    validate_in(cmd, &Context::default())
}

/// Checks `cmd` against the table and what `ctx` knows.
pub fn validate_in(cmd: &Command, ctx: &Context) -> Result<&'static CommandDef, ValidationError> {
    let def = table::command(cmd.code).ok_or(ValidationError::UnknownCommand { code: cmd.code })?;
    if let Some(mode) = ctx.status.and_then(table::mode_of_status) {
        if !def.modes.contains(mode) {
            return Err(ValidationError::NotInMode { code: def.code, mode, valid: def.modes });
        }
    }
    if cmd.par2.typ() != def.data_type.typ() {
        return Err(ValidationError::WrongType {
            code: def.code,
            expected: def.data_type.typ(),
            expected_type: def.data_type,
            got: cmd.par2.typ(),
        });
    }
    check_par1(def, cmd.par1, ctx)?;
    check_par2(def, cmd.par1, &cmd.par2, ctx)?;
    Ok(def)
}

/// Builds the command for `def` with the right TYP (a missing value is 0)
/// and validates it with `ctx`.
pub fn build(def: &CommandDef, par1: i64, value: Option<f64>, ctx: &Context) -> Result<Command, ValidationError> {
    let v = value.unwrap_or(0.0);
    let par2 = match def.data_type {
        DataType::Float => Par2::Float(v),
        DataType::Int => {
            if v.fract() != 0.0 || !v.is_finite() {
                return Err(ValidationError::NotIntegral { what: "PAR_2", value: v });
            }
            // Saturating: out-of-range values are caught by the range checks.
            Par2::Int(v as i64)
        }
    };
    let cmd = Command::new(def.code, par1, par2);
    validate_in(&cmd, ctx)?;
    Ok(cmd)
}

fn range(what: &'static str, value: i64, min: i64, max: i64) -> Result<(), ValidationError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(ValidationError::Par1Range { what, value, min, max })
    }
}

fn check_axis(axis: i64, ctx: &Context, allow_all: bool) -> Result<(), ValidationError> {
    let max = ctx.axes.min(table::MAX_AXES);
    let min = if allow_all { 0 } else { 1 };
    if (min..=i64::from(max)).contains(&axis) {
        Ok(())
    } else {
        Err(ValidationError::Axis { axis, max })
    }
}

fn check_par1(def: &CommandDef, par1: i64, ctx: &Context) -> Result<(), ValidationError> {
    match def.par1 {
        Par1Kind::Unused => range("PAR_1 (unused)", par1, 0, 0),
        Par1Kind::Axis => check_axis(par1, ctx, false),
        Par1Kind::AxisOrAll => check_axis(par1, ctx, true),
        Par1Kind::Input => range("input", par1, 1, 1024),
        Par1Kind::Output => range("output", par1, 1, 1024),
        Par1Kind::Flag => range("flag", par1, 1, 1024),
        Par1Kind::IntRegister => range("N register", par1, 1, 1024),
        Par1Kind::FloatRegister => range("R register", par1, 1, 1024),
        Par1Kind::SystemElement => range("system element", par1, 0, 65535),
        Par1Kind::SystemParam => match table::system_param(par1) {
            None => Err(ValidationError::UnknownSystemParameter(par1)),
            Some(p) if p.unused => Err(ValidationError::UnusedSystemParameter(par1)),
            Some(_) => Ok(()),
        },
        Par1Kind::AxisParam => {
            range("axis parameter PAR_1", par1, 0x0101, 0x10FF)?;
            let (axis, param) = table::split_axis_param_par1(par1).expect("range checked");
            check_axis(i64::from(axis), ctx, false)?;
            table::axis_param(param).map(|_| ()).ok_or(ValidationError::UnknownAxisParameter { par1, axis, param })
        }
    }
}

fn par2_range(what: impl Into<String>, value: f64, min: f64, max: f64) -> Result<(), ValidationError> {
    if value >= min && value <= max {
        Ok(())
    } else {
        Err(ValidationError::Par2Range { what: what.into(), value, min, max })
    }
}

fn check_par2(def: &CommandDef, par1: i64, par2: &Par2, ctx: &Context) -> Result<(), ValidationError> {
    let v = par2.as_f64();
    let int = |what: &'static str| par2.as_i64().ok_or(ValidationError::NotIntegral { what, value: v });
    match def.par2 {
        Par2Kind::Unused => par2_range("PAR_2 (unused)", v, 0.0, 0.0),
        Par2Kind::Bit => par2_range("PAR_2 (0 / 1)", v, 0.0, 1.0),
        Par2Kind::Word16 => par2_range("PAR_2 (16-bit word)", v, 0.0, 65535.0),
        Par2Kind::Int32 => par2_range("PAR_2 (32-bit integer)", v, f64::from(i32::MIN), f64::from(i32::MAX)),
        // The controller keeps 32-bit floats; the frame carries only finite
        // values, so there is nothing more the manual lets us check.
        Par2Kind::Float => par2_range("PAR_2 (32-bit float)", v, -f64::from(f32::MAX), f64::from(f32::MAX)),
        Par2Kind::Condition => {
            let raw = int("0AA3 condition")?;
            Condition::decode(raw).map(|_| ()).ok_or(ValidationError::BadCondition { value: raw })
        }
        Par2Kind::SystemParamValue => {
            par2_range("PAR_2 (32-bit integer)", v, f64::from(i32::MIN), f64::from(i32::MAX))?;
            let p = table::system_param(par1).expect("PAR_1 checked");
            let (min, max) = ctx
                .system_param_limits
                .get(&par1)
                .copied()
                .unwrap_or((p.min.unwrap_or(i64::from(i32::MIN)), p.max.unwrap_or(i64::from(i32::MAX))));
            par2_range(format!("system parameter {} ({})", p.number, p.name), v, min as f64, max as f64)
        }
        Par2Kind::AxisParamValue => {
            par2_range("PAR_2 (32-bit float)", v, -f64::from(f32::MAX), f64::from(f32::MAX))?;
            let (axis, param) = table::split_axis_param_par1(par1).expect("PAR_1 checked");
            let p = table::axis_param(param).expect("PAR_1 checked");
            let (min, max) = ctx
                .axis_param_limits
                .get(&par1)
                .copied()
                .unwrap_or((p.min.unwrap_or(f64::MIN), p.max.unwrap_or(f64::MAX)));
            par2_range(format!("axis {axis} parameter {} ({})", p.number, p.name), v, min, max)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(code: u16, par1: i64, par2: Par2) -> Command {
        Command::new(code, par1, par2)
    }

    // Every command of the manual's examples (chapters 3 and 5) validates.
    #[test]
    fn manual_examples_validate() {
        use Par2::{Float as F, Int as I};
        let ok = [
            cmd(0x0906, 5, I(12345)),
            cmd(0x1900, 5, I(0)),
            cmd(0x1906, 2, I(0)),
            cmd(0x0906, 3, I(333)),
            cmd(0x1907, 1, F(0.0)),
            cmd(0x0603, 0, I(0)),
            cmd(0x0A87, 2, F(5552.0)),
            cmd(0x0600, 0, I(0)),
            cmd(0x0602, 0, I(0)),
            cmd(0x0700, 3, I(1)),
            cmd(0x1700, 1, I(0)),
            cmd(0x1701, 2, I(0)),
            cmd(0x1702, 2, I(0)),
            cmd(0x0800, 774, F(200.0)),
            cmd(0x1800, 543, F(0.0)),
            cmd(0x1801, 769, F(0.0)),
            cmd(0x1802, 1030, F(0.0)),
            cmd(0x1900, 13, I(0)),
            cmd(0x1901, 10, I(0)),
            cmd(0x0902, 13, I(1)),
            cmd(0x1902, 243, I(0)),
            cmd(0x0903, 25, I(15889)),
            cmd(0x1903, 33, I(0)),
            cmd(0x0904, 11, I(1)),
            cmd(0x1904, 243, I(0)),
            cmd(0x0905, 17, I(17906)),
            cmd(0x1905, 33, I(0)),
            cmd(0x0906, 97, I(12589)),
            cmd(0x1906, 129, I(0)),
            cmd(0x0907, 27, F(10.0)),
            cmd(0x1907, 37, F(0.0)),
            cmd(0x0909, 0, I(0)),
            cmd(0x1909, 0, I(0)),
            cmd(0x190B, 0, I(0)),
            cmd(0x190C, 2, F(0.0)),
            cmd(0x190D, 1, F(0.0)),
            cmd(0x190E, 2, F(0.0)),
            cmd(0x1910, 4, I(0)),
            cmd(0x1911, 0, I(0)),
            cmd(0x1913, 2, F(0.0)),
            cmd(0x1914, 4, F(0.0)),
            cmd(0x1915, 3, F(0.0)),
            cmd(0x1920, 3, F(0.0)),
            cmd(0x1921, 8, I(0)),
            cmd(0x0A41, 0, I(0)),
            cmd(0x0A81, 0, I(0)),
            cmd(0x0A83, 2, I(0)),
            cmd(0x0A84, 4, I(0)),
            cmd(0x0A85, 2, I(0)),
            cmd(0x0A86, 2, F(200.0)),
            cmd(0x0A87, 2, F(200.0)),
            cmd(0x0A89, 3, F(10.0)),
            cmd(0x0A8D, 3, F(20480.0)),
            cmd(0x0A8E, 3, F(10.0)),
            cmd(0x0A90, 3, F(200.0)),
            cmd(0x0A91, 2, F(200.0)),
            cmd(0x0A92, 4, F(0.0)),
            cmd(0x0A93, 4, F(0.0)),
            cmd(0x0A94, 3, F(200.0)),
            cmd(0x0A95, 4, F(10.0)),
            cmd(0x0A96, 4, F(0.0)),
            cmd(0x0A9A, 4, F(0.0)),
            cmd(0x0AA0, 1, I(0)),
            cmd(0x0AA1, 1, I(0)),
            cmd(0x0AA2, 0, I(1)),
            cmd(0x0AA3, 1, I(0x0101_0005)),
        ];
        for c in ok {
            assert_eq!(validate(&c).map(|d| d.code), Ok(c.code), "{c:?}");
        }
    }

    #[test]
    fn rejections() {
        use Par2::{Float as F, Int as I};
        let cases: Vec<(Command, ValidationError)> = vec![
            (cmd(0x0A88, 1, F(0.0)), ValidationError::UnknownCommand { code: 0x0A88 }),
            (
                cmd(0x0A87, 2, I(5552)),
                ValidationError::WrongType { code: 0x0A87, expected: 1, expected_type: DataType::Float, got: 0 },
            ),
            (cmd(0x0A87, 0, F(1.0)), ValidationError::Axis { axis: 0, max: 16 }),
            (cmd(0x0A87, 17, F(1.0)), ValidationError::Axis { axis: 17, max: 16 }),
            (cmd(0x0AA2, 17, I(1)), ValidationError::Axis { axis: 17, max: 16 }),
            (cmd(0x1900, 1025, I(0)), ValidationError::Par1Range { what: "input", value: 1025, min: 1, max: 1024 }),
            (cmd(0x190B, 1, I(0)), ValidationError::Par1Range { what: "PAR_1 (unused)", value: 1, min: 0, max: 0 }),
            (cmd(0x0700, 21, I(0)), ValidationError::UnknownSystemParameter(21)),
            (cmd(0x1700, 9, I(0)), ValidationError::UnusedSystemParameter(9)),
            (
                cmd(0x1800, 3 * 256 + 51, F(0.0)),
                ValidationError::UnknownAxisParameter { par1: 3 * 256 + 51, axis: 3, param: 51 },
            ),
            (
                cmd(0x1800, 6, F(0.0)),
                ValidationError::Par1Range { what: "axis parameter PAR_1", value: 6, min: 0x101, max: 0x10FF },
            ),
            (
                cmd(0x0902, 13, I(2)),
                ValidationError::Par2Range { what: "PAR_2 (0 / 1)".into(), value: 2.0, min: 0.0, max: 1.0 },
            ),
            (
                cmd(0x0903, 25, I(65536)),
                ValidationError::Par2Range {
                    what: "PAR_2 (16-bit word)".into(),
                    value: 65536.0,
                    min: 0.0,
                    max: 65535.0,
                },
            ),
            (
                cmd(0x0906, 1, I(1 << 31)),
                ValidationError::Par2Range {
                    what: "PAR_2 (32-bit integer)".into(),
                    value: 2147483648.0,
                    min: -2147483648.0,
                    max: 2147483647.0,
                },
            ),
            (
                cmd(0x190C, 1, F(3.0)),
                ValidationError::Par2Range { what: "PAR_2 (unused)".into(), value: 3.0, min: 0.0, max: 0.0 },
            ),
            (cmd(0x0AA3, 1, I(0x0205_0001)), ValidationError::BadCondition { value: 0x0205_0001 }),
            // Axis parameter 31 (invert shaft encoder direction) is a 0 / 1 switch.
            (
                cmd(0x0800, 543, F(2.0)),
                ValidationError::Par2Range {
                    what: "axis 2 parameter 31 (invert-encoder-direction)".into(),
                    value: 2.0,
                    min: 0.0,
                    max: 1.0,
                },
            ),
        ];
        for (c, e) in cases {
            assert_eq!(validate(&c), Err(e), "{c:?}");
        }
    }

    #[test]
    fn context_limits_axes_and_mode() {
        let mut ctx = Context { axes: 3, status: Some(31), ..Default::default() };
        assert!(validate_in(&cmd(0x0A87, 3, Par2::Float(1.0)), &ctx).is_ok());
        assert_eq!(
            validate_in(&cmd(0x0A87, 4, Par2::Float(1.0)), &ctx),
            Err(ValidationError::Axis { axis: 4, max: 3 })
        );
        // Parameters can only be set in home position.
        assert_eq!(
            validate_in(&cmd(0x0800, 774, Par2::Float(200.0)), &ctx),
            Err(ValidationError::NotInMode { code: 0x0800, mode: Mode::Online, valid: Modes::HOME })
        );
        ctx.status = Some(1);
        assert_eq!(
            validate_in(&cmd(0x0A87, 1, Par2::Float(1.0)), &ctx).unwrap_err().to_string(),
            "command 0A87 is not valid in home position mode (valid in: online)"
        );
        // 1802 said min acceleration of axis 3 is 7000 (example of 5.2.3.3, for axis 4).
        ctx.axis_param_limits.insert(774, (7000.0, 50000.0));
        assert!(validate_in(&cmd(0x0800, 774, Par2::Float(7000.0)), &ctx).is_ok());
        assert!(matches!(
            validate_in(&cmd(0x0800, 774, Par2::Float(200.0)), &ctx),
            Err(ValidationError::Par2Range { min, .. }) if min == 7000.0
        ));
        ctx.system_param_limits.insert(2, (0, 3));
        assert!(validate_in(&cmd(0x0700, 2, Par2::Int(3)), &ctx).is_ok());
        assert!(validate_in(&cmd(0x0700, 2, Par2::Int(4)), &ctx).is_err());
        // Status unknown: no mode check.
        ctx.status = None;
        assert!(validate_in(&cmd(0x0A87, 1, Par2::Float(1.0)), &ctx).is_ok());
    }

    #[test]
    fn build_picks_the_type() {
        let ctx = Context::default();
        let def = table::command_by_name("pos-axis-absolut").unwrap();
        assert_eq!(build(def, 2, Some(5552.0), &ctx), Ok(cmd(0x0A87, 2, Par2::Float(5552.0))));
        let def = table::command_by_name("put-int-reg").unwrap();
        assert_eq!(build(def, 5, Some(12345.0), &ctx), Ok(cmd(0x0906, 5, Par2::Int(12345))));
        assert_eq!(build(def, 5, Some(1.5), &ctx), Err(ValidationError::NotIntegral { what: "PAR_2", value: 1.5 }));
        let def = table::command_by_name("get-float-reg").unwrap();
        assert_eq!(build(def, 1, None, &ctx), Ok(cmd(0x1907, 1, Par2::Float(0.0))));
        let def = table::command_by_name("start-online").unwrap();
        assert_eq!(build(def, 0, None, &ctx).unwrap().encode().unwrap(), b"\x01\x020603;0;0;0\x0314\x04");
    }

    proptest::proptest! {
        #[test]
        fn validate_never_panics(code in proptest::prelude::any::<u16>(), par1 in proptest::prelude::any::<i64>(),
                                 i in proptest::prelude::any::<i64>(), f in proptest::prelude::any::<f64>(),
                                 float in proptest::prelude::any::<bool>(), axes in 0u8..20, status in 0u16..50) {
            let par2 = if float { Par2::Float(f) } else { Par2::Int(i) };
            let c = Command::new(code, par1, par2);
            let ctx = Context { axes, status: Some(status), ..Default::default() };
            let _ = validate_in(&c, &ctx);
            let _ = validate(&c);
        }
    }
}
