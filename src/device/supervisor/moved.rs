//! What a run of many commands (`batch`, `shell`) set moving, and its halt
//! on the way out.
//!
//! A line without `--wait` leaves its device moving after the line ends, so
//! the run keeps each device a motion line addressed, once, in the order
//! they came ([`MovedDevices::note`]). When a signal (or a failed output)
//! ends the run, every one of them is halted with the halt the supervised
//! waits use on a signal ([`MovedDevices::halt`]), each tried whatever the
//! others did, and each outcome is kept for the run's last message.

use crate::device::cdios::Node;
use crate::device::face::{Face, Halt, MotionTarget};
use crate::device::pac::Controller;
use crate::device::powercube::Cubes;
use crate::proto::cdios::NodeId;
use crate::session::RetryPolicy;

/// Where the halts get their devices: the caller opens them on the link it
/// holds (a run of many commands keeps one open link). Each family is
/// asked once per stop and each Cdios node once; an error says why the
/// device could not be reached (asked again for its next halt).
pub trait Reach {
    fn cubes(&mut self) -> Result<Cubes, String>;
    fn controller(&mut self) -> Result<Controller, String>;
    fn node(&mut self, node: NodeId) -> Result<Node, String>;
}

/// The devices opened for one stop.
#[derive(Default)]
struct Opened {
    cubes: Option<Cubes>,
    controller: Option<Controller>,
    nodes: Vec<Node>,
}

impl Opened {
    fn cubes(&mut self, reach: &mut dyn Reach) -> Result<&mut Cubes, String> {
        if self.cubes.is_none() {
            self.cubes = Some(reach.cubes()?);
        }
        Ok(self.cubes.as_mut().expect("opened above"))
    }

    fn controller(&mut self, reach: &mut dyn Reach) -> Result<&mut Controller, String> {
        if self.controller.is_none() {
            self.controller = Some(reach.controller()?);
        }
        Ok(self.controller.as_mut().expect("opened above"))
    }

    fn node(&mut self, reach: &mut dyn Reach, node: NodeId) -> Result<&mut Node, String> {
        let at = match self.nodes.iter().position(|n| n.id() == node) {
            Some(at) => at,
            None => {
                self.nodes.push(reach.node(node)?);
                self.nodes.len() - 1
            }
        };
        Ok(&mut self.nodes[at])
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
    let halted = match target {
        MotionTarget::Cube(_) | MotionTarget::CubeBus => opened.cubes(reach)?.halt(target, attempts),
        MotionTarget::PacAxis(_) | MotionTarget::PacController => opened.controller(reach)?.halt(target, attempts),
        MotionTarget::Cdios { node, .. } => opened.node(reach, node)?.halt(target, attempts),
    };
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
