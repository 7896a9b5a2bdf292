//! Sessions: send a request, wait for the matching answer with a timeout,
//! ignore foreign traffic, and turn what went wrong into a typed error.
//!
//! The matching rules live in `proto`, sans-IO (`proto::powercube::session`,
//! `proto::cdios::session`, `proto::pac::session`); a session only moves
//! bytes or frames, and its core (deadlines, the retry policy, tracing, the
//! pipelined CAN burst) is shared by the three families. Reads may be
//! retried; motion commands never are. Families sharing one CAN link do so
//! through [`bus`], which routes each answer to its family's session.

pub mod bus;
pub mod cdios;
mod core;
pub mod pac;
pub mod powercube;

use std::time::Duration;

use crate::link::LinkError;
use crate::proto::{DecodeError, Refusal};

/// What kind of failure, in the contract's exit-code terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorKind {
    Usage,
    Link,
    Timeout,
    /// A wait for the end of a motion ran out while the device answered:
    /// it was still busy, and was stopped.
    WaitTimeout,
    Device,
    Malformed,
    Interrupted,
    Other,
}

impl ErrorKind {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Usage => "usage",
            Self::Link => "link",
            Self::Timeout => "timeout",
            Self::WaitTimeout => "wait_timeout",
            Self::Device => "device",
            Self::Malformed => "malformed",
            Self::Interrupted => "interrupted",
            Self::Other => "other",
        }
    }
}

/// A session-level failure.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error(transparent)]
    Link(#[from] LinkError),
    #[error("no answer from {target} to {what} within {} ms", timeout.as_millis())]
    Timeout { target: String, what: String, timeout: Duration },
    /// A wait for the end of a motion ran out, every poll answered: the
    /// device is busy, not gone, unlike [`Self::Timeout`]. Boxed: rare, and
    /// larger than a `Result` should carry.
    #[error("{0}")]
    WaitExpired(Box<WaitExpired>),
    #[error("malformed answer from {target}: {source}")]
    Malformed { target: String, source: DecodeError },
    #[error("{target} refused {what}: {refusal}")]
    /// Boxed: a refusal is rare and large, a `Result` is common.
    Device { target: String, what: String, refusal: Box<Refusal> },
}

/// What a wait that ran out was waiting for, and how the stop that ends it
/// went (`stopped`; `None`: nothing was stopped).
#[derive(Debug, thiserror::Error)]
#[error(
    "wait timed out after {} s: {target} was still {what} (it answered every poll){}",
    timeout.as_secs_f64(),
    stopped.as_ref().map(|s| format!("; {s}")).unwrap_or_default()
)]
pub struct WaitExpired {
    pub target: String,
    pub what: String,
    pub timeout: Duration,
    pub stopped: Option<String>,
}

impl SessionError {
    /// A wait for `target` that ran out while it was still `what`.
    pub fn wait_expired(
        target: impl Into<String>,
        what: impl Into<String>,
        timeout: Duration,
        stopped: Option<String>,
    ) -> Self {
        Self::WaitExpired(Box::new(WaitExpired { target: target.into(), what: what.into(), timeout, stopped }))
    }

    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::Link(_) => ErrorKind::Link,
            Self::Timeout { .. } => ErrorKind::Timeout,
            Self::WaitExpired(_) => ErrorKind::WaitTimeout,
            Self::Malformed { .. } => ErrorKind::Malformed,
            Self::Device { .. } => ErrorKind::Device,
        }
    }

    /// `target` refused `what`.
    pub fn refused(target: impl Into<String>, what: impl Into<String>, refusal: Refusal) -> Self {
        Self::Device { target: target.into(), what: what.into(), refusal: Box::new(refusal) }
    }

    /// What the device answered, for a refusal.
    pub fn refusal(&self) -> Option<&Refusal> {
        match self {
            Self::Device { refusal, .. } => Some(refusal),
            _ => None,
        }
    }
}

/// One line of `--trace`.
#[derive(Debug, Clone)]
pub enum TraceEvent {
    Sent(String),
    Received(String),
    Note(String),
}

/// Receives trace events; `None` disables tracing at no cost.
pub type Tracer = Box<dyn FnMut(TraceEvent) + Send>;

/// How often a read is retried after a timeout or a malformed answer.
#[derive(Debug, Clone, Copy)]
pub struct RetryPolicy {
    pub read_retries: u32,
}

impl Default for RetryPolicy {
    fn default() -> Self {
        Self { read_retries: 2 }
    }
}
