//! The simulated controller's configuration: the values and limits its
//! parameters have at power-up, and where the hardware of each axis sits.
//!
//! The protocol tables (which parameters exist, their names and units) are
//! in [`crate::proto::pac::table`]; a real controller's limits depend on its
//! configuration and are only known by asking it (1701 / 1702 / 1801 /
//! 1802), so these are the simulated controller's own.

use crate::proto::pac::table;

/// Value, minimum and maximum of an axis parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisParamConfig {
    pub default: f64,
    pub min: f64,
    pub max: f64,
}

/// The configuration of axis parameter `number`, `None` outside the 0800 list.
/// Switches take the table's 0 / 1 range; the traverse speed maximum is the
/// 1801 example's 50000.
pub fn axis_param(number: u8) -> Option<AxisParamConfig> {
    let def = table::axis_param(number)?;
    let (default, min, max) = match number {
        1 => (1000.0, 0.1, 50_000.0),
        2 => (50.0, 0.1, 50_000.0),
        3 => (200.0, 0.1, 50_000.0),
        4 => (5.0, 0.1, 1_000.0),
        5 => (10.0, 0.1, 1_000.0),
        6 => (2000.0, 1.0, 100_000.0),
        7 => (1.0, 0.001, 1_000.0),
        8 => (0.0, -1.0e6, 1.0e6),
        9 => (TRAVERSE_MAX, -1.0e6, 1.0e6),
        10 => (2.0, 0.0, 10.0),
        11 => (1.0, 0.0, 10.0),
        15 => (2000.0, 1.0, 100_000.0),
        17 => (10.0, 0.0, 10_000.0),
        26 => (400.0, 1.0, 100_000.0),
        27 => (200.0, 1.0, 100_000.0),
        29 | 30 | 50 => (0.0, 0.0, 3.0),
        _ => (0.0, -1.0e6, 1.0e6),
    };
    Some(match (def.min, def.max) {
        (Some(lo), Some(hi)) => AxisParamConfig { default: default.clamp(lo, hi), min: lo, max: hi },
        _ => AxisParamConfig { default, min, max },
    })
}

/// Value, minimum and maximum of a system parameter, `None` for numbers
/// outside the 0700 list and for those it marks "currently not used".
/// `axes` is the number of axes the hardware has (the maximum of parameter 2).
pub fn system_param(number: i64, axes: u8) -> Option<(i64, i64, i64)> {
    let def = table::system_param(number)?;
    if def.unused {
        return None;
    }
    let element = (0, 0, 1024);
    Some(match number {
        1 => (1, 0, 4),
        2 => (i64::from(axes), 0, i64::from(axes)),
        3 => (START_INPUT.into(), 0, 1024),
        4 => (STOP_INPUT.into(), 0, 1024),
        8 | 19 => (0, 0, 1),
        17 => (3, 0, 126),
        20 => (0, 0, 3),
        _ => element,
    })
}

/// The default start input (system parameter 3): a rising edge starts
/// automatic mode from home position.
pub const START_INPUT: u16 = 1;
/// The default external stop input (system parameter 4). It must be powered
/// for online mode (manual 5.2.1.3); the bench powers it at power-up.
pub const STOP_INPUT: u16 = 2;
/// The output the built-in automatic program toggles.
pub const AUTO_OUTPUT: u16 = 16;
/// The automatic program's toggle period, seconds.
pub const AUTO_PERIOD: f64 = 1.0;
/// A manual move (0A90 / 0A91) stops unless 0A92 follows within this many
/// seconds (manual 5.2.6.12).
pub const MANUAL_KEEPALIVE: f64 = 1.0;

/// Default maximum traverse area (axis parameter 9), AE.
pub const TRAVERSE_MAX: f64 = 10_000.0;

/// Where each axis' hardware sits on its own "physical" scale, AE: the
/// reference switch at 0, the limit switches just outside the default
/// traverse area 0..10000.
pub const REFERENCE_SWITCH: f64 = 0.0;
pub const NEGATIVE_SWITCH: f64 = -5.0;
pub const POSITIVE_SWITCH: f64 = TRAVERSE_MAX + 5.0;
/// The reference drive leaves the switch by this distance at creep speed;
/// the position counter becomes 0 there.
pub const REFERENCE_CREEP: f64 = 1.0;

/// The physical position of an axis at power-up (not referenced; the
/// position counter starts equal to it).
pub fn power_up_position(axis: u8) -> f64 {
    100.0 * f64::from(axis)
}

/// PA-CONTROL error numbers the simulator raises (manual 5.2.4.16: 529 is
/// the positive limit switch; the negative one's number is not printed,
/// 530 is this simulator's choice).
pub const E_LIMIT_POSITIVE: u16 = 529;
pub const E_LIMIT_NEGATIVE: u16 = 530;

/// Cooler temperature answered by 1920, °C.
pub const TEMPERATURE: f64 = 35.0;
