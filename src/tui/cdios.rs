//! The Cdios device source: the 6168 modules of one node, four reads per
//! poll (status bytes, speed and RPM error, position, setpoint). Every
//! action is a [`crate::device::cdios`] operation; this file only words it.

use super::source::{Action, CdiosSnap, DeviceKey, DeviceSource, HaltReport, Snapshot, SourceError};
use crate::device::cdios::{self as device, Node, Stopped};
use crate::family::Family;
use crate::proto::cdios::{Command, GotoMode, ModuleId, NodeId, StopOption};
use crate::session::cdios::Cdios;
use crate::session::RetryPolicy;

pub struct CdiosSource {
    node: Node,
    /// Given with `--cdios-modules`; `None` scans 0..=15 at start.
    wanted: Option<Vec<ModuleId>>,
    known: Vec<ModuleId>,
}

/// A goto position as the CLI checks it: the table's range for the field.
pub fn check_position(row: &str, v: f64) -> Result<i32, String> {
    device::check_position(row, v).map_err(|e| e.to_string())
}

impl From<device::Error> for SourceError {
    fn from(e: device::Error) -> Self {
        match e {
            device::Error::Session(s) | device::Error::LostTrack { source: s, .. } => Self::Session(s),
            other => Self::Refused(other.to_string()),
        }
    }
}

/// How a sent command is reported.
fn sent(what: &str, confirmed: bool) -> String {
    if confirmed {
        format!("{what} confirmed")
    } else {
        format!("{what} sent (confirmations off)")
    }
}

impl CdiosSource {
    pub fn new(s: Cdios, node: NodeId, modules: Option<Vec<ModuleId>>, retry: RetryPolicy) -> Self {
        Self { node: Node::new(s, node, retry), wanted: modules, known: Vec::new() }
    }

    fn module(&self, dev: DeviceKey) -> Result<ModuleId, SourceError> {
        match dev {
            DeviceKey::Cdios { node, module } if node == self.node.id().get() => {
                ModuleId::new(module).ok_or_else(|| SourceError::Refused(format!("no module id {module}")))
            }
            other => {
                Err(SourceError::Unsupported(format!("{} is not on Cdios node {}", other.label(), self.node.id())))
            }
        }
    }

    fn send(&mut self, m: ModuleId, cmd: Command, what: &str) -> Result<String, SourceError> {
        Ok(sent(what, self.node.send(m, &[cmd])?))
    }

    fn goto(&mut self, m: ModuleId, mode: GotoMode, v: f64) -> Result<String, SourceError> {
        let position = device::check_position("goto", v)?;
        let what = match mode {
            GotoMode::Relative => format!("goto relative {position:+}"),
            _ => format!("goto {position}"),
        };
        self.send(m, Command::Goto { mode, position }, &what)
    }
}

impl DeviceSource for CdiosSource {
    fn family(&self) -> Family {
        Family::Cdios
    }

    fn discover(&mut self) -> Result<Vec<DeviceKey>, SourceError> {
        self.known = match &self.wanted {
            Some(list) => list.clone(),
            None => self.node.scan()?,
        };
        let node = self.node.id().get();
        Ok(self.known.iter().map(|m| DeviceKey::Cdios { node, module: m.get() }).collect())
    }

    fn poll(&mut self, dev: DeviceKey) -> Result<Snapshot, SourceError> {
        let m = self.module(dev)?;
        let r = self.node.poll(m)?;
        Ok(Snapshot::Cdios(CdiosSnap {
            position: r.position,
            setpoint: r.setpoint,
            speed: r.speed,
            rpm_error: r.rpm_error,
            status: r.status,
        }))
    }

    fn act(&mut self, dev: DeviceKey, action: Action) -> Result<String, SourceError> {
        let m = self.module(dev)?;
        match action {
            Action::Halt => self.send(m, device::FAST_STOP, "fast stop"),
            Action::Reset => {
                self.send(m, device::stop_command(StopOption::ReleaseEmergency, false), "emergency stop release")
            }
            Action::Enable => Ok(sent("enable", self.node.send(m, &device::enable_commands(false))?)),
            Action::Disable => self.send(m, device::stop_command(StopOption::Disable, false), "disable"),
            Action::Jog(d) => self.goto(m, GotoMode::Relative, d),
            Action::MoveTo(p) => self.goto(m, GotoMode::Absolute, p),
            Action::Home => Err(SourceError::Unsupported("the Cdios 6168 has no homing command".into())),
            Action::Online | Action::Offline => {
                Err(SourceError::Unsupported("online / offline is a PA-CONTROL mode".into()))
            }
        }
    }

    fn halt_all(&mut self) -> Vec<HaltReport> {
        let node = self.node.id().get();
        self.node
            .halt_all(&self.known)
            .into_iter()
            .map(|(m, r)| {
                let text = r.map(|s| match s {
                    Stopped::FastStop { confirmed } => sent("fast stop", confirmed),
                    Stopped::NotRunning => "not running".into(),
                });
                (Some(DeviceKey::Cdios { node, module: m.get() }), text.map_err(Into::into))
            })
            .collect()
    }
}
