//! Which PA-CONTROL commands may start a motion, and of which axis (see `cli::motion`).

use axisctl::device::supervisor::MotionTarget;

use super::PacCommand;

impl PacCommand {
    pub fn starts_motion(&self, _names: crate::cli::motion::Names) -> Option<MotionTarget> {
        match self {
            Self::PacMove { axis, .. } | Self::PacRef { axis, .. } => Some(MotionTarget::PacAxis(axis.axis)),
            // Online mode takes motion commands from the program and the
            // front panel too; the program moves whatever it names; a raw
            // code can be any motion.
            Self::PacOnline | Self::PacAutoStart | Self::PacRaw { .. } => Some(MotionTarget::PacController),
            Self::PacOffline
            | Self::PacStop
            | Self::PacAutoAbort
            | Self::PacState
            | Self::PacError
            | Self::PacResetError
            | Self::PacNoRef(_)
            | Self::PacZero(_)
            | Self::PacSetPos { .. }
            | Self::PacSpeed { .. }
            | Self::PacAccel { .. }
            | Self::PacStopAxis { .. }
            | Self::PacAxis(_)
            | Self::PacAxes
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
