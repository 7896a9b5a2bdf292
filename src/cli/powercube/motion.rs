//! Which PowerCube commands may start a motion, and of which module (see `cli::motion`).

use axisctl::device::supervisor::MotionTarget;
use axisctl::proto::powercube::ModuleId;

use super::{PowerCubeCommand, Target};

fn cube(m: u8) -> MotionTarget {
    MotionTarget::Cube(ModuleId::new(m).expect("the parser checked the range"))
}

/// One module, or the whole bus for `--all`.
fn cube_target(t: &Target) -> MotionTarget {
    t.module.map_or(MotionTarget::CubeBus, cube)
}

impl PowerCubeCommand {
    pub fn starts_motion(&self) -> Option<MotionTarget> {
        match self {
            Self::Home { target, .. } => Some(cube_target(target)),
            // --sync (several modules, one broadcast start): the whole bus.
            Self::MoveRamp { modules, sync, .. } => match (&modules.0[..], sync) {
                ([m], false) => Some(cube(*m)),
                _ => Some(MotionTarget::CubeBus),
            },
            Self::MoveStep { module, .. } | Self::MoveVel { module, .. } | Self::MoveCur { module, .. } => {
                Some(cube(module.module))
            }
            Self::Scan { .. }
            | Self::Info(_)
            | Self::State(_)
            | Self::Reset { .. }
            | Self::Halt { .. }
            | Self::GetParam { .. }
            | Self::SetParam { .. }
            | Self::GetConfig(_)
            | Self::SetConfig { .. }
            | Self::Dio { .. }
            | Self::Watchdog { .. } => None,
        }
    }
}
