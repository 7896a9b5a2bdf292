//! The PowerCube device source: modules by id, read in one pipelined burst
//! per poll on CAN (one request after the other on RS232). On CAN the
//! worker has a module's burst sent ahead ([`DeviceSource::poll_ahead`])
//! while the device before it is read, so the bus is not idle while the
//! answers cross the link and the host turns around. Every action is a
//! [`crate::device::powercube`] operation; this file only words it.

use crate::address::Address;
use std::collections::BTreeMap;

use super::source::{Action, DeviceSource, HaltReport, Snapshot, SourceError};
use super::ui::powercube::CubeSnap;
use crate::device::face::Face;
use crate::device::powercube::{self as device, Cubes, SentRead, Simple, Target};
use crate::family::Family;
use crate::proto::powercube::limits::Limits;
use crate::proto::powercube::ModuleId;
use crate::session::powercube::PowerCube;

/// Read once per module, and again after an action may have changed it.
#[derive(Debug, Clone, Copy)]
struct Static {
    linear: bool,
    limits: Limits,
}

pub struct CubeSource {
    cubes: Cubes,
    /// Given with `--modules`; `None` scans 1..=31 at start.
    wanted: Option<Vec<ModuleId>>,
    known: Vec<ModuleId>,
    statics: BTreeMap<u8, Static>,
    /// Reads sent ahead of their polls, oldest first.
    ahead: Vec<SentRead>,
}

/// Reads sent ahead at most: the next module's, and the one after it when
/// the worker sends the current one ahead too.
const AHEAD: usize = 2;

/// A device error as the dashboard shows it: refusals say that nothing was
/// sent and which key helps.
impl From<device::Error> for SourceError {
    fn from(e: device::Error) -> Self {
        match e {
            device::Error::Session(s)
            | device::Error::Motion { source: s, .. }
            | device::Error::LostTrack { source: s, .. } => Self::Session(s),
            device::Error::NotReady { .. } => Self::Refused(format!("{e}: reset it first (r); nothing was sent")),
            other => Self::Refused(other.to_string()),
        }
    }
}

impl CubeSource {
    pub fn new(pc: PowerCube, modules: Option<Vec<ModuleId>>) -> Self {
        Self { cubes: Cubes::new(pc), wanted: modules, known: Vec::new(), statics: BTreeMap::new(), ahead: Vec::new() }
    }

    fn module(dev: Address) -> Result<ModuleId, SourceError> {
        match dev {
            Address::PowerCube { module: m } => {
                ModuleId::new(m).ok_or_else(|| SourceError::Refused(format!("no module id {m}")))
            }
            other => Err(SourceError::Unsupported(format!("{} is not a PowerCube module", other.label()))),
        }
    }

    fn statics(&mut self, m: ModuleId) -> Result<Static, SourceError> {
        if let Some(s) = self.statics.get(&m.get()) {
            return Ok(*s);
        }
        let (linear, limits) = self.cubes.kind_and_limits(m)?;
        let s = Static { linear, limits };
        self.statics.insert(m.get(), s);
        Ok(s)
    }

    /// A checked ramp (the device reads state and limits fresh); the
    /// limits shown are read again on the next poll.
    fn ramp(&mut self, m: ModuleId, target: Target) -> Result<String, SourceError> {
        let linear = self.statics(m)?.linear;
        self.statics.remove(&m.get());
        let pos = self.cubes.ramp(m, target)?;
        Ok(format!("ramp to {pos:.4} {}", crate::proto::powercube::table::position_unit(linear)))
    }

    fn simple(&mut self, m: ModuleId, cmd: Simple) -> Result<String, SourceError> {
        self.cubes.simple(Some(m), cmd)?;
        Ok(format!("{} acknowledged", cmd.name()))
    }
}

impl DeviceSource for CubeSource {
    fn family(&self) -> Family {
        Family::PowerCube
    }

    fn discover(&mut self) -> Result<Vec<Address>, SourceError> {
        // A read sent ahead for the old list is not waited for.
        for read in std::mem::take(&mut self.ahead) {
            self.cubes.abandon_read(read);
        }
        self.known = match &self.wanted {
            Some(list) => list.clone(),
            None => self.cubes.present()?,
        };
        Ok(self.known.iter().map(|m| Address::PowerCube { module: m.get() }).collect())
    }

    fn poll(&mut self, dev: Address) -> Result<Snapshot, SourceError> {
        let m = Self::module(dev)?;
        let s = self.statics(m)?;
        let v = match self.ahead.iter().position(|r| r.module() == m) {
            Some(i) => {
                let read = self.ahead.remove(i);
                self.cubes.collect_read(read)?
            }
            None => self.cubes.read_now(m, &device::LIVE)?,
        };
        Ok(Snapshot::new(CubeSnap {
            linear: s.linear,
            pos: v[0],
            vel: v[1],
            cur: v[2],
            temp: v[3],
            motor_v: v[4],
            logic_v: v[5],
            cube_state: v[6] as u32,
            limits: s.limits,
        }))
    }

    /// Only on CAN, and only once the module's kind and limits are known:
    /// nothing but the burst itself goes out ahead.
    fn poll_ahead(&mut self, dev: Address) {
        let Ok(m) = Self::module(dev) else { return };
        if !self.cubes.session().is_can()
            || !self.statics.contains_key(&m.get())
            || self.ahead.iter().any(|r| r.module() == m)
        {
            return;
        }
        if self.ahead.len() >= AHEAD {
            let oldest = self.ahead.remove(0);
            self.cubes.abandon_read(oldest);
        }
        if let Ok(read) = self.cubes.send_read(m, &device::LIVE) {
            self.ahead.push(read);
        }
    }

    fn act(&mut self, dev: Address, action: Action) -> Result<String, SourceError> {
        let m = Self::module(dev)?;
        match action {
            Action::Home => self.simple(m, Simple::Home),
            Action::Reset => {
                self.statics.remove(&m.get());
                self.simple(m, Simple::Reset)
            }
            Action::Halt => self.simple(m, Simple::Halt),
            Action::Jog(step) => self.ramp(m, Target::By(step)),
            Action::MoveTo(pos) => self.ramp(m, Target::To(pos)),
            Action::Enable | Action::Disable => Err(SourceError::Unsupported(
                "PowerCube modules have no enable / disable: r (reset) switches the servo on, s (halt) stops it".into(),
            )),
            Action::Online | Action::Offline => {
                Err(SourceError::Unsupported("online / offline is a PA-CONTROL mode".into()))
            }
        }
    }

    fn face(&mut self) -> &mut dyn Face {
        &mut self.cubes
    }

    fn halt_all(&mut self) -> Vec<HaltReport> {
        let known: Vec<Address> = self.known.iter().map(|m| Address::PowerCube { module: m.get() }).collect();
        super::source::halt_all(&mut self.cubes, &known)
    }
}
