//! Device sources: one per family on a link. A source owns its session,
//! turns polls into typed [`Snapshot`]s and carries out [`Action`]s. The
//! worker of a link ([`super::worker`]) drives its sources one call at a
//! time, so a source never waits on anything but its own transactions.

use std::fmt;
use std::ops::Deref;
use std::sync::Arc;

use super::ui::pane::Pane;
use crate::address::Address;
use crate::device::face::{Face, FaceError, Halt, MotionTarget};
use crate::family::Family;
use crate::session::SessionError;

/// What one poll of one device returns: the family's own reading (its
/// pane module's type, e.g. `ui::powercube::CubeSnap`) behind the
/// questions every part of the screen asks of it ([`Pane`]).
#[derive(Clone)]
pub struct Snapshot(Arc<dyn Pane>);

impl Snapshot {
    pub fn new(reading: impl Pane) -> Self {
        Self(Arc::new(reading))
    }

    /// The reading as its family's type, for that family's code.
    pub fn get<T: Pane>(&self) -> Option<&T> {
        self.0.as_any().downcast_ref()
    }
}

impl Deref for Snapshot {
    type Target = dyn Pane;
    fn deref(&self) -> &dyn Pane {
        &*self.0
    }
}

impl PartialEq for Snapshot {
    fn eq(&self, other: &Self) -> bool {
        self.0.same(&*other.0)
    }
}

impl fmt::Debug for Snapshot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// What the user asks of the selected device.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Homing (PowerCube), reference drive (PA-CONTROL).
    Home,
    /// Clear the error state.
    Reset,
    /// Halt / stop this device.
    Halt,
    Enable,
    Disable,
    /// Move by this much from the current position.
    Jog(f64),
    /// Move to this absolute position.
    MoveTo(f64),
    /// PA-CONTROL: switch to online mode.
    Online,
    /// PA-CONTROL: leave online mode.
    Offline,
}

impl Action {
    pub fn name(self) -> String {
        match self {
            Self::Home => "home".into(),
            Self::Reset => "reset".into(),
            Self::Halt => "halt".into(),
            Self::Enable => "enable".into(),
            Self::Disable => "disable".into(),
            Self::Jog(d) => format!("jog {d:+}"),
            Self::MoveTo(p) => format!("move to {p}"),
            Self::Online => "online".into(),
            Self::Offline => "offline".into(),
        }
    }

    /// Whether the action makes something move (never retried).
    pub fn is_motion(self) -> bool {
        matches!(self, Self::Home | Self::Jog(_) | Self::MoveTo(_))
    }
}

/// Why a poll or an action failed.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The exchange failed: link, timeout, malformed answer or device refusal.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// Refused before anything was sent (a limit, a bad value, a fault).
    #[error("{0}")]
    Refused(String),
    /// The family has no such action.
    #[error("{0}")]
    Unsupported(String),
}

impl SourceError {
    /// Health counters: an answer that says no is still an answer.
    pub fn health(&self) -> Health {
        match self {
            Self::Session(SessionError::Timeout { .. }) => Health::Timeout,
            Self::Session(SessionError::Device { .. }) | Self::Refused(_) | Self::Unsupported(_) => Health::Answer,
            Self::Session(_) => Health::Error,
        }
    }
}

/// How one exchange with the link went, for the link health counters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Health {
    Answer,
    Timeout,
    Error,
}

/// One line of a halt-all report.
pub type HaltReport = (Option<Address>, Result<String, SourceError>);

impl From<FaceError> for SourceError {
    fn from(e: FaceError) -> Self {
        match e {
            FaceError::PowerCube(e) => e.into(),
            FaceError::Pac(e) => e.into(),
            FaceError::Cdios(e) => e.into(),
            FaceError::Session(s) => Self::Session(s),
            other => Self::Refused(other.to_string()),
        }
    }
}

/// The face's halt-all of the devices a source shows (the face's own
/// sequence, the one `halt --all` sends), in the dashboard's words.
pub fn halt_all(face: &mut dyn Face, known: &[Address]) -> Vec<HaltReport> {
    let known: Vec<MotionTarget> = known.iter().filter_map(|k| MotionTarget::try_from(*k).ok()).collect();
    face.halt_all(Some(&known))
        .into_iter()
        .map(|s| {
            let said = s.result.map(|h| match h {
                Halt::Broadcast => "Halt broadcast".to_string(),
                Halt::Halted => "halted".into(),
                Halt::StoppedAt(at) => format!("stopped at {at}"),
                Halt::FastStop { confirmed: true } => "fast stop confirmed".into(),
                Halt::FastStop { confirmed: false } => "fast stop sent (confirmations off)".into(),
                Halt::AtRest => "not running".into(),
                Halt::Steps(said) => said,
            });
            (s.target.and_then(|t| Address::try_from(t).ok()), said.map_err(Into::into))
        })
        .collect()
}

/// A family on a link.
pub trait DeviceSource: Send {
    fn family(&self) -> Family;
    /// The devices to show: the ones given on the command line, or a scan.
    fn discover(&mut self) -> Result<Vec<Address>, SourceError>;
    /// Reads one device.
    fn poll(&mut self, dev: Address) -> Result<Snapshot, SourceError>;
    /// Sends the reads of `dev`'s next poll ahead of it, so that the link
    /// carries them while the poll before is read (on a CAN link shared by
    /// several families, whichever family that poll is of); the next
    /// [`Self::poll`] of `dev` takes their answers. Errors are left for that
    /// poll to meet and report. A source that cannot does nothing (the
    /// default): its poll sends the reads itself.
    fn poll_ahead(&mut self, _dev: Address) {}
    /// Carries out an action; the text says what was done.
    fn act(&mut self, dev: Address, action: Action) -> Result<String, SourceError>;
    /// Stops every device of the family, as fast as the link allows.
    fn halt_all(&mut self) -> Vec<HaltReport>;
    /// The device face the source drives: what halts a device it moved.
    fn face(&mut self) -> &mut dyn Face;
}
