//! The one error a face returns: the family's own, kept whole.

use super::target::MotionTarget;
use crate::device::{cdios, pac, powercube};
use crate::proto::Refusal;
use crate::session::{ErrorKind, SessionError};

/// What a face operation failed with: the family's own typed error, kept
/// whole (its exit-code class, its refusal), or a halt the family reported
/// as failed in words.
#[derive(Debug, thiserror::Error)]
pub enum FaceError {
    #[error(transparent)]
    PowerCube(#[from] powercube::Error),
    #[error(transparent)]
    Pac(#[from] pac::Error),
    #[error(transparent)]
    Cdios(#[from] cdios::Error),
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The family's halt said it failed (a PA-CONTROL 0A93 that never stood).
    #[error("{0}")]
    HaltFailed(String),
    /// An address of another family, or of another node: this face holds no such device.
    #[error("{0} is not a device of this {1} face")]
    NotHere(MotionTarget, &'static str),
    /// An operation this family does not offer (a stop manner it has not).
    #[error("{0}")]
    Unsupported(String),
}

impl FaceError {
    /// The exit-code class, the family error's own.
    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::PowerCube(e) => e.kind(),
            Self::Pac(e) => e.kind(),
            Self::Cdios(e) => e.kind(),
            Self::Session(e) => e.kind(),
            Self::HaltFailed(_) => ErrorKind::Device,
            Self::NotHere(..) | Self::Unsupported(_) => ErrorKind::Usage,
        }
    }

    /// What the device itself answered, when the failure is its refusal.
    pub fn refusal(&self) -> Option<Refusal> {
        match self {
            Self::PowerCube(e) => e.refusal(),
            Self::Pac(e) => e.refusal(),
            Self::Cdios(e) => e.refusal(),
            Self::Session(e) => e.refusal().cloned(),
            Self::HaltFailed(_) | Self::NotHere(..) | Self::Unsupported(_) => None,
        }
    }

    /// Whether the failure is known to have sent nothing.
    pub fn nothing_sent(&self) -> bool {
        match self {
            Self::PowerCube(e) => e.nothing_sent(),
            Self::Pac(e) => e.nothing_sent(),
            Self::Cdios(e) => e.nothing_sent(),
            Self::NotHere(..) | Self::Unsupported(_) => true,
            Self::Session(_) | Self::HaltFailed(_) => false,
        }
    }
}
