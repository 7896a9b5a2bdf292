//! The Cdios device source: the 6168 modules of one node, four reads per
//! poll (status bytes, speed and RPM error, position, setpoint), sent as one
//! burst, and sent ahead while the device before is read
//! ([`DeviceSource::poll_ahead`]). Every action is a
//! [`crate::device::cdios`] operation; this file only words it.

use super::source::{Action, DeviceSource, HaltReport, Snapshot, SourceError};
use super::ui::cdios::CdiosSnap;
use crate::address::Address;
use crate::device::cdios::{self as device, Node, SentPoll};
use crate::device::face::Face;
use crate::family::Family;
use crate::proto::cdios::{Command, GotoMode, ModuleId, NodeId, StopOption};
use crate::session::cdios::Cdios;
use crate::session::RetryPolicy;

pub struct CdiosSource {
    node: Node,
    /// Given with `--cdios-modules`; `None` scans 0..=15 at start.
    wanted: Option<Vec<ModuleId>>,
    known: Vec<ModuleId>,
    /// Polls sent ahead, oldest first.
    ahead: Vec<SentPoll>,
}

/// Polls sent ahead at most: the next module's, and the one after it when
/// the worker sends the current one ahead too.
const AHEAD: usize = 2;

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
        Self { node: Node::new(s, node, retry), wanted: modules, known: Vec::new(), ahead: Vec::new() }
    }

    fn module(&self, dev: Address) -> Result<ModuleId, SourceError> {
        match dev {
            Address::Cdios { node, module } if node == self.node.id().get() => {
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

    fn discover(&mut self) -> Result<Vec<Address>, SourceError> {
        // A poll sent ahead for the old list is not waited for.
        for sent in std::mem::take(&mut self.ahead) {
            self.node.abandon_poll(sent);
        }
        self.known = match &self.wanted {
            Some(list) => list.clone(),
            None => self.node.scan()?,
        };
        let node = self.node.id().get();
        Ok(self.known.iter().map(|m| Address::Cdios { node, module: m.get() }).collect())
    }

    fn poll(&mut self, dev: Address) -> Result<Snapshot, SourceError> {
        let m = self.module(dev)?;
        let r = match self.ahead.iter().position(|p| p.module() == m) {
            Some(i) => {
                let sent = self.ahead.remove(i);
                self.node.collect_poll(sent)?
            }
            None => self.node.poll(m)?,
        };
        Ok(Snapshot::new(CdiosSnap {
            position: r.position,
            setpoint: r.setpoint,
            speed: r.speed,
            rpm_error: r.rpm_error,
            status: r.status,
        }))
    }

    /// Only a module that answered before: a node still to be woken is
    /// woken by its poll, where a failure is reported.
    fn poll_ahead(&mut self, dev: Address) {
        let Ok(m) = self.module(dev) else { return };
        if !self.known.contains(&m) || self.ahead.iter().any(|p| p.module() == m) || self.node.needs_wake() {
            return;
        }
        if self.ahead.len() >= AHEAD {
            let oldest = self.ahead.remove(0);
            self.node.abandon_poll(oldest);
        }
        if let Ok(sent) = self.node.send_poll(m) {
            self.ahead.push(sent);
        }
    }

    fn act(&mut self, dev: Address, action: Action) -> Result<String, SourceError> {
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

    fn face(&mut self) -> &mut dyn Face {
        &mut self.node
    }

    fn halt_all(&mut self) -> Vec<HaltReport> {
        let node = self.node.id().get();
        let known: Vec<Address> = self.known.iter().map(|m| Address::Cdios { node, module: m.get() }).collect();
        super::source::halt_all(&mut self.node, &known)
    }
}
