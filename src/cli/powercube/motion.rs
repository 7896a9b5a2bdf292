//! Which PowerCube commands may start a motion, and of which module (see `cli::motion`).

use axisctl::bench::{Address, DeviceRef};
use axisctl::device::supervisor::MotionTarget;
use axisctl::proto::powercube::ModuleId;

use super::{PowerCubeCommand, Target};
use crate::cli::motion::Names;

fn cube(m: u8) -> MotionTarget {
    MotionTarget::Cube(ModuleId::new(m).expect("the parser checked the range"))
}

/// The module `-m` or `-d` names; `None` when `-d` names no PowerCube
/// module (the command then fails before sending).
fn cube_of(module: Option<u8>, device: Option<&DeviceRef>, names: Names) -> Option<MotionTarget> {
    match device {
        Some(r) => match names(r)? {
            Address::PowerCube { module } => Some(cube(module)),
            _ => None,
        },
        None => module.map(cube),
    }
}

/// One module, or the whole bus for `--all`.
fn cube_target(t: &Target, names: Names) -> Option<MotionTarget> {
    match t.all {
        true => Some(MotionTarget::CubeBus),
        false => cube_of(t.module, t.device.as_ref(), names),
    }
}

impl PowerCubeCommand {
    pub fn starts_motion(&self, names: Names) -> Option<MotionTarget> {
        match self {
            Self::Home { target, .. } => cube_target(target, names),
            // --sync (several modules, one broadcast start): the whole bus.
            Self::MoveRamp { sync: true, .. } => Some(MotionTarget::CubeBus),
            Self::MoveRamp { modules: Some(list), .. } => match &list.0[..] {
                [m] => Some(cube(*m)),
                _ => Some(MotionTarget::CubeBus),
            },
            Self::MoveRamp { device: Some(refs), .. } => match &refs[..] {
                [r] => cube_of(None, Some(r), names),
                _ => Some(MotionTarget::CubeBus),
            },
            Self::MoveRamp { .. } => None,
            Self::MoveStep { module, .. } | Self::MoveVel { module, .. } | Self::MoveCur { module, .. } => {
                cube_of(module.module, module.device.as_ref(), names)
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
