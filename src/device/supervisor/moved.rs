//! What a run of many commands (`batch`, `shell`) set moving, and its halt
//! on the way out.
//!
//! A line without `--wait` leaves its device moving after the line ends, so
//! the run keeps each device a motion line addressed, once, in the order
//! they came ([`MovedDevices::note`]). When a signal (or a failed output)
//! ends the run, every one of them is halted with the halt the supervised
//! waits use on a signal ([`MovedDevices::halt`]), each tried whatever the
//! others did, and each outcome is kept for the run's last message.

use crate::device::face::{Face, Halt, MotionTarget};
use crate::family::Family;
use crate::session::RetryPolicy;

/// Where the halts get their devices: the caller opens the face of a
/// family (for the Cdios, of one node) on the link it holds (a run of many
/// commands keeps one open link). Each family is asked once per stop and
/// each Cdios node once; an error says why the device could not be reached
/// (asked again for its next halt).
pub trait Reach {
    fn face(&mut self, family: Family, node: Option<u8>) -> Result<Box<dyn Face>, String>;
}

/// Which face halts a device: its family, and for the Cdios its node.
type FaceKey = (Family, Option<u8>);

/// The faces opened for one stop, by family and node.
#[derive(Default)]
struct Opened {
    faces: Vec<(FaceKey, Box<dyn Face>)>,
}

impl Opened {
    fn face(&mut self, reach: &mut dyn Reach, target: MotionTarget) -> Result<&mut dyn Face, String> {
        let key = (target.family(), target.node());
        let at = match self.faces.iter().position(|(k, _)| *k == key) {
            Some(at) => at,
            None => {
                self.faces.push((key, reach.face(key.0, key.1)?));
                self.faces.len() - 1
            }
        };
        Ok(self.faces[at].1.as_mut())
    }
}

/// One halt and how it went: what the device layer said, or why it failed.
#[derive(Debug, Clone, PartialEq)]
pub struct HaltOutcome {
    pub target: MotionTarget,
    pub result: Result<String, String>,
}

/// The devices the motion lines addressed, each once, in order.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct MovedDevices {
    targets: Vec<MotionTarget>,
}

impl MovedDevices {
    pub fn new() -> Self {
        Self::default()
    }

    /// Keeps `target` unless it is kept already: a device is halted once
    /// however many lines moved it.
    pub fn note(&mut self, target: MotionTarget) {
        if !self.targets.contains(&target) {
            self.targets.push(target);
        }
    }

    pub fn targets(&self) -> &[MotionTarget] {
        &self.targets
    }

    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Halts every device kept, in order, each whatever became of the
    /// others, and forgets them (a later stop halts only what moved since).
    /// A halt whose acknowledge is lost is sent as often as a read is
    /// (once, then `retry.read_retries` more times): stopping twice is
    /// harmless; a motion is never resent.
    pub fn halt(&mut self, reach: &mut dyn Reach, retry: RetryPolicy) -> Vec<HaltOutcome> {
        let attempts = 1 + retry.read_retries;
        let mut opened = Opened::default();
        std::mem::take(&mut self.targets)
            .into_iter()
            .map(|target| HaltOutcome { target, result: halt_one(&mut opened, reach, target, attempts) })
            .collect()
    }
}

fn halt_one(opened: &mut Opened, reach: &mut dyn Reach, target: MotionTarget, attempts: u32) -> Result<String, String> {
    // Each family's halt is its face's; only the words are this run's.
    let halted = opened.face(reach, target)?.halt(target, attempts);
    let done = halted.map_err(|e| e.to_string())?;
    Ok(match (target, done) {
        (MotionTarget::Cube(m), _) => format!("module {m} halted"),
        (MotionTarget::CubeBus, _) => "Halt broadcast sent".into(),
        (MotionTarget::PacAxis(axis), Halt::StoppedAt(at)) => format!("axis {axis} stopped at {at}"),
        (MotionTarget::Cdios { node, module }, Halt::AtRest) => format!("node {node} module {module}: not running"),
        (MotionTarget::Cdios { node, module }, _) => format!("node {node} module {module}: fast stop sent"),
        (_, Halt::Steps(said)) => said,
        (_, other) => format!("{other:?}"),
    })
}

#[cfg(test)]
mod tests;
