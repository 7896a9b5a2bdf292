//! Which PA-CONTROL commands may start a motion, and of which axis (see `cli::motion`).

use axisctl::bench::{Address, DeviceRef};
use axisctl::device::supervisor::MotionTarget;

use super::{AxisArg, ControllerArg, PacCommand};
use crate::cli::motion::Names;

/// The axis `AXIS` or `-d` names; `None` when `-d` names no axis (the
/// command then fails before sending).
fn axis_target(a: &AxisArg, names: Names) -> Option<MotionTarget> {
    match &a.device {
        Some(r) => match names(r)? {
            Address::Pac { axis: Some(axis) } => Some(MotionTarget::PacAxis(axis)),
            _ => None,
        },
        None => a.axis.map(MotionTarget::PacAxis),
    }
}

/// The controller, unless `-d` names something else (the command then
/// fails before sending).
fn controller_target(c: &ControllerArg, names: Names) -> Option<MotionTarget> {
    let named = |r: &DeviceRef| names(r) == Some(Address::Pac { axis: None });
    c.device.as_ref().is_none_or(named).then_some(MotionTarget::PacController)
}

impl PacCommand {
    pub fn starts_motion(&self, names: Names) -> Option<MotionTarget> {
        match self {
            Self::PacMove { axis, .. } | Self::PacRef { axis, .. } => axis_target(axis, names),
            // Online mode takes motion commands from the program and the
            // front panel too; the program moves whatever it names; a raw
            // code can be any motion.
            Self::PacOnline(c) | Self::PacAutoStart(c) | Self::PacRaw { controller: c, .. } => {
                controller_target(c, names)
            }
            Self::PacOffline(_)
            | Self::PacStop(_)
            | Self::PacAutoAbort(_)
            | Self::PacState(_)
            | Self::PacError(_)
            | Self::PacResetError(_)
            | Self::PacNoRef(_)
            | Self::PacZero(_)
            | Self::PacSetPos { .. }
            | Self::PacSpeed { .. }
            | Self::PacAccel { .. }
            | Self::PacStopAxis { .. }
            | Self::PacAxis(_)
            | Self::PacAxes(_)
            | Self::PacAxisPower { .. }
            | Self::PacAxisOn(_)
            | Self::PacAxisOff(_)
            | Self::PacMeasure { .. }
            | Self::PacLimitSwitch { .. }
            | Self::PacIn { .. }
            | Self::PacOut { .. }
            | Self::PacFlag { .. }
            | Self::PacReg { .. }
            | Self::PacSysParam { .. }
            | Self::PacAxisParam { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use axisctl::bench::{Address, DeviceRef};
    use axisctl::device::supervisor::MotionTarget;

    use crate::cli::motion::addresses_only;

    fn parse(line: &str) -> crate::cli::Command {
        let words: Vec<String> = line.split_whitespace().map(String::from).collect();
        crate::cli::parse_words(&words).unwrap_or_else(|e| panic!("{line}: {e}")).command
    }

    /// `-d` names the axis that moves, through the bench's names; one that
    /// names no axis (the controller, another family, an unknown name) moves
    /// nothing, as the line fails before sending. A controller command
    /// moves the controller unless `-d` names something else.
    #[test]
    fn a_device_named_with_d_is_the_axis_that_moves() {
        let names = |r: &DeviceRef| match r {
            DeviceRef::Name(n) if n == "slide" => Address::pac(Some(2)),
            DeviceRef::Name(n) if n == "panel" => Address::pac(None),
            DeviceRef::Name(n) if n == "wrist" => Address::powercube(9),
            r => addresses_only(r),
        };
        for (line, target) in [
            ("pac-move -d slide 900", Some(MotionTarget::PacAxis(2))),
            ("pac-move -d pac:5 900 --wait", Some(MotionTarget::PacAxis(5))),
            ("pac-move 3 900", Some(MotionTarget::PacAxis(3))),
            ("pac-ref --device slide --wait", Some(MotionTarget::PacAxis(2))),
            ("pac-move -d pac 900", None),
            ("pac-move -d panel 900", None),
            ("pac-move -d wrist 900", None),
            ("pac-ref -d nobody", None),
            ("pac-online -d panel", Some(MotionTarget::PacController)),
            ("pac-online -d pac", Some(MotionTarget::PacController)),
            ("pac-online", Some(MotionTarget::PacController)),
            ("pac-auto-start -d slide", None),
            ("pac-raw -d nobody 0A94 2 100.0", None),
            ("pac-stop-axis -d slide", None),
            ("pac-axis -d slide", None),
            ("record --axis 2 position -- pac-move -d slide 250", Some(MotionTarget::PacAxis(2))),
        ] {
            assert_eq!(parse(line).starts_motion(&names), target, "{line}");
        }
    }
}
