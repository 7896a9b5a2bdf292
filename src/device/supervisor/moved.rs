//! What a run of many commands (`batch`, `shell`) set moving, and its halt
//! on the way out.
//!
//! A line without `--wait` leaves its device moving after the line ends, so
//! the run holds a [`Moving`] handle for each device a motion line
//! addresses, armed before the line runs ([`MovedDevices::arm`]), one
//! handle per face (a family on the link, for the Cdios one node), each
//! device once, in the order the lines first moved them. When a signal, a
//! failure or the end of a shell ends the run, every one of them is halted
//! through its handle with the face's halt, the one the supervised waits
//! use ([`MovedDevices::halt`]), each tried whatever the others did, and
//! each outcome is kept for the run's last message. Where the run may leave
//! them moving (a batch that ran to its end, `--keep-going`, `exit
//! --keep-moving`) the handles are released ([`MovedDevices::release`]);
//! otherwise a way out that skips both (a panic's unwind) drops them,
//! which halts.

use crate::device::face::{Face, Halt, MotionTarget, Moving};
use crate::family::Family;
use crate::session::RetryPolicy;

/// A face a run may keep across its lines (the shell's prompt watcher
/// halts from another thread).
pub type RunFace = dyn Face + Send;

/// Where the handles get their devices: the caller opens the face of a
/// family (for the Cdios, of one node) on the link it holds (a run of many
/// commands keeps one open link). An error says why the device could not be
/// reached; the halt asks again.
pub trait Reach {
    fn face(&mut self, family: Family, node: Option<u8>) -> Result<Box<RunFace>, String>;
}

/// Which face halts a device: its family, and for the Cdios its node.
type FaceKey = (Family, Option<u8>);

fn key(target: MotionTarget) -> FaceKey {
    (target.family(), target.node())
}

/// One halt and how it went: what the device layer said, or why it failed.
#[derive(Debug, Clone, PartialEq)]
pub struct HaltOutcome {
    pub target: MotionTarget,
    pub result: Result<String, String>,
}

/// The devices the motion lines addressed, each once, in order, and the
/// handles that halt them.
pub struct MovedDevices {
    order: Vec<MotionTarget>,
    held: Vec<(FaceKey, Moving<'static, RunFace>)>,
    /// A halt whose acknowledge is lost is sent as often as a read is
    /// (once, then `read_retries` more times): stopping twice is harmless;
    /// a motion is never resent.
    attempts: u32,
}

impl MovedDevices {
    pub fn new(retry: RetryPolicy) -> Self {
        Self { order: Vec::new(), held: Vec::new(), attempts: 1 + retry.read_retries }
    }

    /// Before a line that may set `target` moving: keeps it (once however
    /// many lines move it) under its face's handle, opened now if this is
    /// the face's first device. A face that cannot be opened leaves the
    /// device kept without a handle: its halt reaches for it again, and
    /// says why when it still cannot.
    pub fn arm(&mut self, reach: &mut dyn Reach, target: MotionTarget) {
        if self.order.contains(&target) {
            return;
        }
        self.order.push(target);
        if let Some((_, moving)) = self.held.iter_mut().find(|(k, _)| *k == key(target)) {
            moving.add(target);
        } else if let Ok(face) = reach.face(target.family(), target.node()) {
            self.held.push((key(target), Moving::owning(face, vec![target], self.attempts)));
        }
    }

    pub fn targets(&self) -> &[MotionTarget] {
        &self.order
    }

    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// Halts every device kept, in order, each whatever became of the
    /// others, and forgets them (a later stop halts only what moved since).
    pub fn halt(&mut self, reach: &mut dyn Reach) -> Vec<HaltOutcome> {
        let mut held = std::mem::take(&mut self.held);
        let outcomes = std::mem::take(&mut self.order)
            .into_iter()
            .map(|target| HaltOutcome { target, result: self.halt_one(&mut held, reach, target) })
            .collect();
        // Every device is halted or failed and said: the emptied handles
        // have nothing left to halt when they go.
        for (_, moving) in held {
            moving.release();
        }
        outcomes
    }

    fn halt_one(
        &self,
        held: &mut Vec<(FaceKey, Moving<'static, RunFace>)>,
        reach: &mut dyn Reach,
        target: MotionTarget,
    ) -> Result<String, String> {
        if !held.iter().any(|(k, _)| *k == key(target)) {
            // Not reached when it was armed: asked again, once per face.
            let face = reach.face(target.family(), target.node())?;
            held.push((key(target), Moving::owning(face, Vec::new(), self.attempts)));
        }
        let (_, moving) = held.iter_mut().find(|(k, _)| *k == key(target)).expect("held above");
        moving.add(target);
        let halted = moving.halt_one(target).expect("added above");
        said(target, halted.map_err(|e| e.to_string())?)
    }

    /// The run leaves what its lines moved as it is, on purpose, and
    /// forgets it.
    pub fn release(&mut self) {
        self.order.clear();
        for (_, moving) in self.held.drain(..) {
            moving.release();
        }
    }
}

/// Each family's halt is its face's; only the words are this run's.
fn said(target: MotionTarget, done: Halt) -> Result<String, String> {
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
