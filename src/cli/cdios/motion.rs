//! Which Cdios commands may start a motion, and of which module (see `cli::motion`).

use axisctl::device::supervisor::MotionTarget;
use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};

use super::{CdiosCommand, ModuleTarget};

fn cdios(t: &ModuleTarget) -> Option<MotionTarget> {
    Some(MotionTarget::Cdios {
        node: NodeId::new(t.node.node).expect("the parser checked the range"),
        module: CdiosModule::new(t.module).expect("the parser checked the range"),
    })
}

impl CdiosCommand {
    pub fn starts_motion(&self, _names: crate::cli::motion::Names) -> Option<MotionTarget> {
        match self {
            Self::Goto { target, .. } | Self::Traject { target, .. } | Self::Start { target, .. } => cdios(target),
            Self::Identify { .. }
            | Self::Status(_)
            | Self::Position { .. }
            | Self::SetPosition { .. }
            | Self::Stop { .. }
            | Self::Enable { .. }
            | Self::Disable(_)
            | Self::Config { .. }
            | Self::Outputs { .. }
            | Self::Analog { .. }
            | Self::Events { .. }
            | Self::Store { .. }
            | Self::Watch { .. } => None,
        }
    }
}
