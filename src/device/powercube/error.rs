//! What can go wrong with a PowerCube operation, in the contract's terms:
//! refused before sending (exit 2), the session's failure (its own kind),
//! a module fault (exit 5), interrupted (130).

use crate::proto::powercube::limits::LimitError;
use crate::proto::powercube::ModuleId;
use crate::proto::Refusal;
use crate::session::{ErrorKind, SessionError};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A value outside the module's limits or the wire type: nothing was sent.
    #[error("{0}")]
    Limit(#[from] LimitError),
    /// Bad input (a name, a value, an unsupported request): nothing was sent.
    #[error("{0}")]
    Refused(String),
    /// The exchange failed; its kind is the session's.
    #[error("{0}")]
    Session(#[from] SessionError),
    /// A motion command went out and was not acknowledged.
    #[error("{what} to module {module}")]
    Motion {
        what: String,
        module: ModuleId,
        #[source]
        source: SessionError,
    },
    /// A motion under supervision went out and was not acknowledged: the
    /// module may have taken it, so it was halted.
    #[error(
        "{what} to module {module} was not acknowledged; the module may have been moving: {}",
        halt_note(*module, halt_failed.as_deref())
    )]
    MotionUnconfirmed {
        what: String,
        module: ModuleId,
        halt_failed: Option<String>,
        #[source]
        source: SessionError,
    },
    /// A motion to several modules under supervision (one acknowledged Home
    /// each) went out to `module` without its acknowledge: it may have taken
    /// it, so it and every module sent the motion before it were halted.
    #[error(
        "{what} to module {module} was not acknowledged; the module may have been moving: {}",
        halted_modules(halted).unwrap_or_else(|| "nothing to halt".into())
    )]
    MotionsUnconfirmed {
        what: String,
        module: ModuleId,
        halted: Vec<(ModuleId, bool)>,
        #[source]
        source: SessionError,
    },
    /// The wait for one module of a motion of several failed (`source`); the
    /// other modules of the motion were halted too (`halted`).
    #[error("{source}; {}", halted_modules(halted).map_or_else(|| "no other module to halt".into(), |h| h + " too"))]
    OthersHalted {
        #[source]
        source: Box<Error>,
        halted: Vec<(ModuleId, bool)>,
    },
    /// A signal (or a failed output) came while a motion of several modules
    /// was being sent: nothing more was sent (not `what`), and the modules
    /// sent their part so far were halted.
    #[error("interrupted before {what}: {}", halted_modules(halted).unwrap_or_else(|| "nothing was sent".into()))]
    InterruptedBefore { what: String, halted: Vec<(ModuleId, bool)> },
    /// The module reports an error or is halted: a motion would not move it.
    /// Nothing was sent.
    #[error("module {module} is not ready ({})", why.join(", "))]
    NotReady { module: ModuleId, why: Vec<&'static str> },
    /// The module holds motion commands until the start broadcast
    /// (CONFIGID_MOD_SYNC_MOTION): a wait for one sent alone would never end.
    /// Nothing was sent.
    #[error("module {module} is in sync mode (CONFIGID_MOD_SYNC_MOTION): it holds a motion until the start broadcast")]
    SyncMode { module: ModuleId },
    /// A synchronized move names a module not in sync mode: it would start
    /// on its own target. Nothing was sent.
    #[error("module {module} is not in sync mode (CONFIGID_MOD_SYNC_MOTION): it would start before the others")]
    NotSyncMode { module: ModuleId },
    /// A module of a synchronized move did not take its target: the modules
    /// given one so far, and that one, were halted (`halted`: whether each
    /// halt was acknowledged), and no start broadcast was sent.
    #[error(
        "the synchronized move was not started: module {module} did not take its target ({})",
        halted_list(halted)
    )]
    SyncAborted {
        module: ModuleId,
        halted: Vec<(ModuleId, bool)>,
        #[source]
        source: Box<Error>,
    },
    /// An error flag came up while waiting for the end of a motion.
    #[error("module {module} reports an error while {what}: {} (state {cube:#010x})", errors.join(", "))]
    Faulted { module: ModuleId, what: String, errors: Vec<&'static str>, cube: u32 },
    /// Config was written, and the module kept another word.
    #[error("module {module} kept Config {kept:#010x} instead of {wanted:#010x}")]
    ConfigNotKept { module: ModuleId, wanted: u32, kept: u32 },
    /// A wait lost the module: the read failed (the module was halted first,
    /// or the halt failed too: `halt_failed`).
    #[error("lost track of module {module} while {what} ({})", halt_note(*module, halt_failed.as_deref()))]
    LostTrack {
        module: ModuleId,
        what: String,
        halt_failed: Option<String>,
        #[source]
        source: SessionError,
    },
    /// Ctrl-C during a wait; the module was halted (or the halt failed).
    #[error("interrupted: {}", halt_note(*module, halt_failed.as_deref()))]
    Interrupted { module: ModuleId, halt_failed: Option<String> },
    /// A scan in which no id answered: nothing to talk to on this link, which
    /// a script must not take for success.
    #[error("no PowerCube module answered on ids {ids}")]
    NoneAnswered { ids: String },
    /// The watchdog that `--deadman` switched on for a motion could not be
    /// switched off again (`source`): it halts the module 50 ms after the
    /// last refresh.
    #[error(
        "the watchdog of module {module}, switched on for this motion, could not be switched off again ({source}); \
         it halts the module 50 ms after the last refresh: run `axisctl watchdog off -m {module}`, then reset"
    )]
    WatchdogLeftOn {
        module: ModuleId,
        #[source]
        source: Box<Error>,
    },
    /// A parameter answered with another type than the table's.
    #[error("{param} answered {got}, expected UInt32")]
    UnexpectedType { param: &'static str, got: String },
}

/// `module 3 halted`, or the failure in capitals: nobody may miss it.
pub(super) fn halt_note(m: ModuleId, failed: Option<&str>) -> String {
    match failed {
        None => format!("module {m} halted"),
        Some(e) => format!("HALT OF MODULE {m} FAILED: {e}"),
    }
}

/// `modules 3, 5 halted, no start broadcast sent`, a failed halt in capitals.
fn halted_list(halted: &[(ModuleId, bool)]) -> String {
    let mut out: Vec<String> = halted_modules(halted).into_iter().collect();
    out.push("no start broadcast sent".into());
    out.join(", ")
}

/// `modules 3, 5 halted`, each failed halt in capitals; `None` for none.
fn halted_modules(halted: &[(ModuleId, bool)]) -> Option<String> {
    let ok: Vec<String> = halted.iter().filter(|(_, ok)| *ok).map(|(m, _)| m.to_string()).collect();
    let mut out = Vec::new();
    if !ok.is_empty() {
        out.push(format!("module{} {} halted", if ok.len() == 1 { "" } else { "s" }, ok.join(", ")));
    }
    out.extend(halted.iter().filter(|(_, ok)| !*ok).map(|(m, _)| format!("HALT OF MODULE {m} FAILED")));
    (!out.is_empty()).then(|| out.join(", "))
}

impl Error {
    /// What the module itself reported: its CubeState errors, or the
    /// refusal the session received.
    pub fn refusal(&self) -> Option<Refusal> {
        match self {
            Self::Faulted { cube, .. } => Some(Refusal::powercube(*cube)),
            Self::SyncAborted { source, .. } | Self::OthersHalted { source, .. } => source.refusal(),
            Self::Session(e)
            | Self::Motion { source: e, .. }
            | Self::MotionUnconfirmed { source: e, .. }
            | Self::MotionsUnconfirmed { source: e, .. }
            | Self::LostTrack { source: e, .. } => e.refusal().cloned(),
            _ => None,
        }
    }

    pub fn kind(&self) -> ErrorKind {
        match self {
            Self::SyncAborted { source, .. }
            | Self::OthersHalted { source, .. }
            | Self::WatchdogLeftOn { source, .. } => source.kind(),
            Self::Limit(_) | Self::Refused(_) | Self::SyncMode { .. } | Self::NotSyncMode { .. } => ErrorKind::Usage,
            Self::Session(e)
            | Self::Motion { source: e, .. }
            | Self::MotionUnconfirmed { source: e, .. }
            | Self::MotionsUnconfirmed { source: e, .. }
            | Self::LostTrack { source: e, .. } => e.kind(),
            Self::NotReady { .. } | Self::Faulted { .. } | Self::ConfigNotKept { .. } => ErrorKind::Device,
            Self::Interrupted { .. } | Self::InterruptedBefore { .. } => ErrorKind::Interrupted,
            Self::NoneAnswered { .. } => ErrorKind::Timeout,
            Self::UnexpectedType { .. } => ErrorKind::Other,
        }
    }

    /// Whether the error was raised before anything was sent.
    pub fn nothing_sent(&self) -> bool {
        matches!(
            self,
            Self::Limit(_)
                | Self::Refused(_)
                | Self::NotReady { .. }
                | Self::SyncMode { .. }
                | Self::NotSyncMode { .. }
        ) || matches!(self, Self::InterruptedBefore { halted, .. } if halted.is_empty())
    }
}
