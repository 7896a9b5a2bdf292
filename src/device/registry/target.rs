//! The address every face halts by: a device a motion went to.

use std::fmt;

use crate::family::Family;
use crate::proto::cdios::{ModuleId as CdiosModule, NodeId};
use crate::proto::powercube::ModuleId;

/// A device a motion went to, as its halt addresses it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionTarget {
    /// One PowerCube module.
    Cube(ModuleId),
    /// Every module on the PowerCube bus (`home --all`, `move-ramp --sync`).
    CubeBus,
    /// One PA-CONTROL axis.
    PacAxis(u8),
    /// The whole PA-CONTROL (online mode, the program, a raw command).
    PacController,
    /// One 6168 module of a Cdios node.
    Cdios { node: NodeId, module: CdiosModule },
}

impl MotionTarget {
    pub fn family(self) -> Family {
        match self {
            Self::Cube(_) | Self::CubeBus => Family::PowerCube,
            Self::PacAxis(_) | Self::PacController => Family::Pac,
            Self::Cdios { .. } => Family::Cdios,
        }
    }

    /// The Cdios node whose face halts it (`None`: the family has one face per link).
    pub fn node(self) -> Option<u8> {
        match self {
            Self::Cdios { node, .. } => Some(node.get()),
            _ => None,
        }
    }

    /// The raw numbers of the address: module, axis, or node and module.
    pub fn ids(self) -> (Option<u8>, Option<u8>) {
        match self {
            Self::Cube(m) => (Some(m.get()), None),
            Self::PacAxis(a) => (Some(a), None),
            Self::Cdios { node, module } => (Some(node.get()), Some(module.get())),
            Self::CubeBus | Self::PacController => (None, None),
        }
    }
}

impl fmt::Display for MotionTarget {
    /// The command that stops the device by hand: how a run's message
    /// names each halt.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cube(m) => write!(f, "halt -m {m}"),
            Self::CubeBus => f.write_str("halt --all"),
            Self::PacAxis(a) => write!(f, "pac-stop-axis {a}"),
            Self::PacController => f.write_str("pac-stop"),
            Self::Cdios { node, module } => write!(f, "cdios-stop --node {node} -m {module} --option fast"),
        }
    }
}
