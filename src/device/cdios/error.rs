//! What can go wrong with a Cdios operation, in the contract's terms:
//! refused before sending (exit 2), the session's failure (its own kind),
//! a module fault (exit 5), interrupted (130).

use crate::proto::cdios::{ModuleId, NodeId, ValidationError};
use crate::proto::Refusal;
use crate::session::{ErrorKind, SessionError};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Outside the manual's range for the field: nothing was sent.
    #[error("{0}; nothing was sent")]
    Invalid(#[from] ValidationError),
    /// Bad input (a name, a combination of options): nothing was sent.
    #[error("{0}")]
    Refused(String),
    /// The exchange failed; its kind is the session's.
    #[error("{0}")]
    Session(#[from] SessionError),
    /// A status error bit came up while waiting for the end of a motion (the
    /// motor was fast-stopped first).
    #[error("node {node} module {module} reports an error during the {what}: {} (status {status:02x?})", errors.join(", "))]
    Faulted { node: NodeId, module: ModuleId, what: String, errors: Vec<&'static str>, status: [u8; 4] },
    /// The module's configuration cannot be written back whole.
    #[error("cannot write {group}: {reason}")]
    ConfigRejected { group: String, reason: ValidationError },
    /// A wait lost the module: the read failed (the motor was stopped first,
    /// or the stop failed too: `stop_failed`).
    #[error("lost track of the {what} ({})", stop_note(*node, *module, stop_failed.as_deref()))]
    LostTrack {
        node: NodeId,
        module: ModuleId,
        what: String,
        stop_failed: Option<String>,
        #[source]
        source: SessionError,
    },
    /// Ctrl-C during a wait; the motor was stopped (or the stop failed).
    #[error("interrupted: {}", stop_note(*node, *module, stop_failed.as_deref()))]
    Interrupted { node: NodeId, module: ModuleId, stop_failed: Option<String> },
    /// A signal (or a failed output) came after the motion was supervised
    /// but before its first frame left: nothing was sent, nothing moves.
    #[error("interrupted before the motion of node {node} module {module} was sent: nothing moved")]
    InterruptedBefore { node: NodeId, module: ModuleId },
}

/// `node 1 module 0 stopped (fast stop)`, or the failure in capitals.
pub(super) fn stop_note(node: NodeId, m: ModuleId, failed: Option<&str>) -> String {
    match failed {
        None => format!("node {node} module {m} stopped (fast stop)"),
        Some(e) => format!("STOP OF NODE {node} MODULE {m} FAILED: {e}"),
    }
}

impl Error {
    /// The error reply the node sent, when the operation failed on one.
    pub fn refusal(&self) -> Option<Refusal> {
        match self {
            Self::Session(e) | Self::LostTrack { source: e, .. } => e.refusal().cloned(),
            _ => None,
        }
    }

    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::Invalid(_) | Self::Refused(_) => ErrorKind::Usage,
            Self::Session(e) | Self::LostTrack { source: e, .. } => e.kind(),
            Self::Faulted { .. } | Self::ConfigRejected { .. } => ErrorKind::Device,
            Self::Interrupted { .. } | Self::InterruptedBefore { .. } => ErrorKind::Interrupted,
        }
    }

    /// Whether the error was raised before anything was sent.
    pub fn nothing_sent(&self) -> bool {
        matches!(self, Self::Invalid(_) | Self::Refused(_) | Self::InterruptedBefore { .. })
    }
}
