//! The registry of device faces: the one list of families the bench-wide
//! code iterates ([`FACES`]), the address every face halts by
//! ([`MotionTarget`]), and the one error a face returns ([`FaceError`]).
//! Code that visits every family goes through this folder instead of
//! naming a family's types (tests/library/architecture.rs counts the files that
//! still do); a fourth family adds its variant here and a `face.rs` in its
//! folder.

pub mod error;
pub mod target;

pub use error::FaceError;
pub use target::MotionTarget;

use super::face::Face;
use super::{cdios, pac, powercube};
use crate::family::Family;
use crate::proto::cdios::NodeId;
use crate::session::cdios::Cdios;
use crate::session::pac::Pac;
use crate::session::powercube::PowerCube;
use crate::session::RetryPolicy;

/// The families with a device face, in the order a bench is visited.
pub const FACES: [Family; 3] = [Family::PowerCube, Family::Pac, Family::Cdios];

/// Where the faces get their sessions: the caller opens them on the link it
/// holds (the opener of a command, the takeover of an emergency halt).
pub trait Sessions {
    type Error;
    fn powercube(&mut self) -> Result<PowerCube, Self::Error>;
    fn pac(&mut self) -> Result<Pac, Self::Error>;
    fn cdios(&mut self) -> Result<Cdios, Self::Error>;
}

/// The units a family is reached as on one link: one face for the
/// PowerCube bus and for the PA-CONTROL, one per node for the Cdios
/// (`cdios_nodes`, the nodes to visit).
pub fn units(family: Family, cdios_nodes: &[u8]) -> Vec<Option<u8>> {
    match family {
        Family::Cdios => cdios_nodes.iter().filter(|n| NodeId::new(**n).is_some()).map(|n| Some(*n)).collect(),
        Family::PowerCube | Family::Pac => vec![None],
    }
}

/// Opens the face of one unit of `family` (see [`units`]). A Cdios unit
/// without a valid node id gets node 1, the one every command defaults to.
pub fn open<S: Sessions + ?Sized>(
    family: Family,
    node: Option<u8>,
    sessions: &mut S,
    retry: RetryPolicy,
) -> Result<Box<dyn Face + Send>, S::Error> {
    Ok(match family {
        Family::PowerCube => Box::new(powercube::Cubes::new(sessions.powercube()?)),
        Family::Pac => Box::new(pac::Controller::new(sessions.pac()?)),
        Family::Cdios => {
            let node = node.and_then(NodeId::new).unwrap_or(NodeId::FACTORY);
            Box::new(cdios::Node::new(sessions.cdios()?, node, retry))
        }
    })
}
