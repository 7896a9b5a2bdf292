//! What a PA-CONTROL operation can fail with. The variant says what the
//! caller may assume: a refusal means nothing went out, a session error
//! means the exchange failed (link, timeout, garbled answer or the
//! controller's QUIT), a fault means the controller did what it was told
//! and reports trouble, an interruption means a wait was given up.

use crate::proto::pac::table;
use crate::proto::pac::validate::ValidationError;
use crate::proto::Refusal;
use crate::session::pac::PacError;
use crate::session::{ErrorKind, SessionError};

use super::{Busy, Halted, TraverseArea};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The manual's ranges or the operating mode rule the command out.
    #[error("{0}; nothing was sent")]
    Invalid(#[from] ValidationError),
    /// A rule of this layer rules the request out (a read-only element, a
    /// speed that is not positive, an unreadable register name).
    #[error("{0}")]
    Refused(String),
    #[error("target position {target} is not a finite number; nothing was sent")]
    NotFinite { target: f64 },
    #[error(
        "target position {target} is outside axis {axis}'s traverse area {} to {} (1913 / 1914); nothing was sent",
        area.min, area.max
    )]
    OutsideTraverseArea { axis: u8, target: f64, area: TraverseArea },
    /// A start-and-wait command runs: until it ends the controller takes
    /// only polls (manual 5.2.6.6).
    #[error("{0}; nothing was sent")]
    Busy(Busy),
    /// Refused by the session before sending (an unfinished command, a date
    /// that cannot be written), or a wait the observer gave up.
    #[error(transparent)]
    Pac(PacError),
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The axis stopped short of its target with a fault status.
    #[error("axis {axis} ended the move at {position} with status {status} ({}), target {target}",
            table::axis_status_text(*status))]
    MoveFailed { axis: u8, position: f64, status: u64, target: f64 },
    /// 0909 answered with the error still standing (5.2.4.15).
    #[error("PA-CONTROL error E{0} could not be reset")]
    ErrorNotReset(i64),
    /// Manual operation runs on the front panel: 0600 is not valid there
    /// and the online interface has no other stop.
    #[error("status {status} ({}): the online interface cannot stop manual operation, use the front panel",
            table::operating_status_text(*status))]
    ManualMode { status: u16 },
    /// A wait was given up (Ctrl-C); the axis was stopped first.
    #[error("interrupted: {0}")]
    Interrupted(Halted),
    /// A signal (or a failed output) came after the motion was supervised
    /// but before its frame left: nothing was sent, nothing moves.
    #[error("interrupted before {0} was sent: nothing moved")]
    InterruptedBefore(String),
    /// The exchange failed while the axis may have been moving, so it was
    /// stopped; `context` says how that went.
    #[error("{context}")]
    Stopped {
        context: String,
        #[source]
        source: Box<Error>,
    },
}

impl From<PacError> for Error {
    fn from(e: PacError) -> Self {
        match e {
            PacError::Session(s) => Self::Session(s),
            other => Self::Pac(other),
        }
    }
}

impl Error {
    /// The controller's refusal (QUIT), when the operation failed on one.
    pub fn refusal(&self) -> Option<Refusal> {
        match self {
            Self::Session(e) | Self::Pac(PacError::Session(e)) => e.refusal().cloned(),
            Self::Stopped { source, .. } => source.refusal(),
            _ => None,
        }
    }

    /// The exit-code class (`cli-contract.md`).
    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::Invalid(_)
            | Self::Refused(_)
            | Self::NotFinite { .. }
            | Self::OutsideTraverseArea { .. }
            | Self::Busy(_) => ErrorKind::Usage,
            Self::Pac(e) => e.kind(),
            Self::Session(e) => e.kind(),
            Self::MoveFailed { .. } | Self::ErrorNotReset(_) | Self::ManualMode { .. } => ErrorKind::Device,
            Self::Interrupted(_) | Self::InterruptedBefore(_) => ErrorKind::Interrupted,
            Self::Stopped { source, .. } => source.kind(),
        }
    }

    /// True when nothing was sent for the refused operation.
    pub fn nothing_sent(&self) -> bool {
        self.kind() == ErrorKind::Usage || matches!(self, Self::InterruptedBefore(_))
    }
}
