//! The address every face halts by: a device a motion went to.

use std::fmt;

use crate::address::Address;
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
}

/// A motion target is a device address in the face's validated form: the
/// one conversion each way, so a halt and the address it came from never
/// disagree. Ids out of the protocol's range have no target.
impl TryFrom<Address> for MotionTarget {
    type Error = NoTarget;

    fn try_from(a: Address) -> Result<Self, NoTarget> {
        Ok(match a {
            Address::PowerCube { module } => Self::Cube(ModuleId::new(module).ok_or(NoTarget(a))?),
            Address::Pac { axis: Some(axis) } => Self::PacAxis(axis),
            Address::Pac { axis: None } => Self::PacController,
            Address::Cdios { node, module } => Self::Cdios {
                node: NodeId::new(node).ok_or(NoTarget(a))?,
                module: CdiosModule::new(module).ok_or(NoTarget(a))?,
            },
        })
    }
}

/// The device a target halts; `Err` for the whole PowerCube bus, which is
/// no one device.
impl TryFrom<MotionTarget> for Address {
    type Error = MotionTarget;

    fn try_from(t: MotionTarget) -> Result<Self, MotionTarget> {
        Ok(match t {
            MotionTarget::Cube(m) => Self::PowerCube { module: m.get() },
            MotionTarget::PacAxis(axis) => Self::Pac { axis: Some(axis) },
            MotionTarget::PacController => Self::Pac { axis: None },
            MotionTarget::Cdios { node, module } => Self::Cdios { node: node.get(), module: module.get() },
            MotionTarget::CubeBus => return Err(t),
        })
    }
}

/// An address whose ids the protocol does not take (built by hand past
/// the registry's ranges).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{0}: no such device in its protocol")]
pub struct NoTarget(pub Address);

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::family;

    fn every_address() -> Vec<Address> {
        let r = |r: family::IdRange| r.min..=r.max;
        let mut out: Vec<Address> = r(family::POWERCUBE_MODULE).map(|module| Address::PowerCube { module }).collect();
        out.push(Address::Pac { axis: None });
        out.extend(r(family::PAC_AXIS).map(|a| Address::Pac { axis: Some(a) }));
        for node in r(family::CDIOS_NODE) {
            out.extend(r(family::CDIOS_MODULE).map(|module| Address::Cdios { node, module }));
        }
        out
    }

    #[test]
    fn every_address_has_its_target_and_back() {
        for a in every_address() {
            let t = MotionTarget::try_from(a).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(t.family(), a.family(), "{a}");
            assert_eq!(Address::try_from(t), Ok(a), "{a} -> {t}");
        }
    }

    #[test]
    fn the_bus_is_no_address_and_ids_past_the_protocol_no_target() {
        assert_eq!(Address::try_from(MotionTarget::CubeBus), Err(MotionTarget::CubeBus));
        for a in [
            Address::PowerCube { module: 0 },
            Address::Cdios { node: 0, module: 0 },
            Address::Cdios { node: 1, module: 16 },
        ] {
            assert_eq!(MotionTarget::try_from(a), Err(NoTarget(a)));
        }
    }
}
