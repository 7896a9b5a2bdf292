//! What a run of many commands (`batch`, `shell`) set moving, and its halt
//! on the way out.
//!
//! A line without `--wait` leaves its device moving after the line ends, so
//! the run keeps each device a motion line addressed, once, in the order
//! they came ([`MovedDevices::note`]). When a signal (or a failed output)
//! ends the run, every one of them is halted with the halt the supervised
//! waits use on a signal ([`MovedDevices::halt`]), each tried whatever the
//! others did, and each outcome is kept for the run's last message.

use std::fmt;

use crate::device::cdios::Node;
use crate::device::pac::Controller;
use crate::device::powercube::Cubes;
use crate::proto::cdios::{ModuleId as CdiosModule, NodeId};
use crate::proto::powercube::ModuleId;
use crate::session::RetryPolicy;

/// A device a motion went to, as its halt addresses it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionTarget {
    /// One PowerCube module.
    Cube(ModuleId),
    /// Every module on the PowerCube bus (`home --all`, `move-ramp --sync`).
    CubeBus,
    /// One PA-CONTROL axis.
    PacAxis(u8),
    /// The whole PA-CONTROL (online mode, the program, a raw command).
    PacController,
    /// One 6168 module of a Cdios node.
    Cdios { node: NodeId, module: CdiosModule },
}

impl fmt::Display for MotionTarget {
    /// The command that stops the device by hand: how the run's message
    /// names each halt.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Cube(m) => write!(f, "halt -m {m}"),
            Self::CubeBus => f.write_str("halt --all"),
            Self::PacAxis(a) => write!(f, "pac-stop-axis {a}"),
            Self::PacController => f.write_str("pac-stop"),
            Self::Cdios { node, module } => write!(f, "cdios-stop --node {node} -m {module} --option fast"),
        }
    }
}

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
    match target {
        MotionTarget::Cube(m) => {
            opened.cubes(reach)?.halt_retrying(m, attempts).map_err(|e| e.to_string())?;
            Ok(format!("module {m} halted"))
        }
        // The broadcast stops every module on the bus, known or not.
        MotionTarget::CubeBus => {
            opened.cubes(reach)?.halt_all(&[]).broadcast.map_err(|e| e.to_string())?;
            Ok("Halt broadcast sent".into())
        }
        MotionTarget::PacAxis(axis) => match opened.controller(reach)?.halt_axis(axis).result {
            Ok(at) => Ok(format!("axis {axis} stopped at {at}")),
            Err(e) => Err(e),
        },
        MotionTarget::PacController => {
            let steps = opened.controller(reach)?.halt_all();
            let failed: Vec<String> =
                steps.iter().filter_map(|s| s.result.as_ref().err()).map(|e| e.to_string()).collect();
            if failed.is_empty() {
                Ok(steps.iter().filter_map(|s| s.result.as_ref().ok()).cloned().collect::<Vec<_>>().join("; "))
            } else {
                Err(failed.join("; "))
            }
        }
        MotionTarget::Cdios { node, module } => match opened.node(reach, node)?.halt_motor(module, attempts) {
            Ok(true) => Ok(format!("node {node} module {module}: fast stop sent")),
            Ok(false) => Ok(format!("node {node} module {module}: not running")),
            Err(e) => Err(e.to_string()),
        },
    }
}

#[cfg(test)]
mod tests;
