//! The PowerCube device source: modules by id, read in one pipelined burst
//! per poll on CAN (one request after the other on RS232).

use std::collections::BTreeMap;

use super::source::{Action, CubeSnap, DeviceKey, DeviceSource, HaltReport, Snapshot, SourceError};
use crate::family::Family;
use crate::proto::powercube::can::Broadcast;
use crate::proto::powercube::flags::config;
use crate::proto::powercube::limits::{self, Limits};
use crate::proto::powercube::table::{self, ids};
use crate::proto::powercube::{ModuleId, Motion, Request};
use crate::session::powercube::{decode_get, PowerCube};
use crate::session::SessionError;

/// What one poll reads, in [`CubeSnap`] field order.
const POLLED: [u8; 7] = [
    ids::ACT_POS,
    ids::ACT_VEL,
    ids::CUR,
    ids::ACT_F_TEMP,
    ids::ACT_F_MOTOR_SUPPLY,
    ids::ACT_F_LOGIC_SUPPLY,
    ids::CUBE_STATE,
];

/// FRAMP_MODE: a ramp to a position in units (the CLI's `move-ramp`).
const FRAMP: u8 = 4;

/// Read once per module, and again after an action may have changed it.
#[derive(Debug, Clone, Copy)]
struct Static {
    linear: bool,
    limits: Limits,
}

pub struct CubeSource {
    pc: PowerCube,
    /// Given with `--modules`; `None` scans 1..=31 at start.
    wanted: Option<Vec<ModuleId>>,
    known: Vec<ModuleId>,
    statics: BTreeMap<u8, Static>,
}

impl CubeSource {
    pub fn new(pc: PowerCube, modules: Option<Vec<ModuleId>>) -> Self {
        Self { pc, wanted: modules, known: Vec::new(), statics: BTreeMap::new() }
    }

    fn module(dev: DeviceKey) -> Result<ModuleId, SourceError> {
        match dev {
            DeviceKey::Cube(m) => ModuleId::new(m).ok_or_else(|| SourceError::Refused(format!("no module id {m}"))),
            other => Err(SourceError::Unsupported(format!("{} is not a PowerCube module", other.label()))),
        }
    }

    /// Reads parameters pipelined; the first failure fails the lot.
    fn read(&mut self, m: ModuleId, params: &[u8]) -> Result<Vec<f64>, SessionError> {
        let reqs: Vec<_> = params.iter().map(|p| (m, Request::GetExtended { param: *p })).collect();
        let answers = self.pc.transact_many(&reqs)?;
        params
            .iter()
            .zip(answers)
            .map(|(p, a)| {
                let def = table::param(*p).expect("ids constants are in the table");
                Ok(decode_get(m, def, &a?)?.as_f64().unwrap_or(f64::NAN))
            })
            .collect()
    }

    fn statics(&mut self, m: ModuleId) -> Result<Static, SessionError> {
        if let Some(s) = self.statics.get(&m.get()) {
            return Ok(*s);
        }
        let mut params = vec![ids::CONFIG];
        params.extend(Limits::param_ids(false));
        let v = self.read(m, &params)?;
        let s = Static {
            linear: (v[0] as u32) & config::LINEAR != 0,
            limits: Limits::from_values([v[1], v[2], v[3], v[4], v[5]], false),
        };
        self.statics.insert(m.get(), s);
        Ok(s)
    }

    /// A ramp to `target`, checked the way `move-ramp` checks it: the module
    /// must be ready, the target within its MinPos..MaxPos. Never retried.
    fn ramp_to(&mut self, m: ModuleId, target: impl FnOnce(f64) -> f64) -> Result<String, SourceError> {
        let v = self.read(m, &[ids::CUBE_STATE, ids::ACT_POS])?;
        if let Some(why) = limits::not_ready(v[0] as u32) {
            return Err(SourceError::Refused(format!(
                "module {m} is not ready ({}): reset it first (r); nothing was sent",
                why.join(", ")
            )));
        }
        self.statics.remove(&m.get());
        let s = self.statics(m)?;
        let pos = target(v[1]);
        s.limits.check_pos(pos, m).map_err(|e| SourceError::Refused(e.to_string()))?;
        let value =
            limits::motion_value(pos, false, "target position").map_err(|e| SourceError::Refused(e.to_string()))?;
        self.pc.transact(m, &Request::SetMotion(Motion { id: FRAMP, value, time_ms: None }))?;
        Ok(format!("ramp to {pos:.4} {}", if s.linear { "m" } else { "rad" }))
    }
}

impl DeviceSource for CubeSource {
    fn family(&self) -> Family {
        Family::PowerCube
    }

    fn discover(&mut self) -> Result<Vec<DeviceKey>, SourceError> {
        self.known = match &self.wanted {
            Some(list) => list.clone(),
            None => {
                let probes: Vec<_> =
                    ModuleId::all().map(|m| (m, Request::GetExtended { param: ids::DEF_CUBE_VERSION })).collect();
                let answers = self.pc.transact_many(&probes)?;
                probes.iter().zip(answers).filter(|(_, a)| a.is_ok()).map(|((m, _), _)| *m).collect()
            }
        };
        Ok(self.known.iter().map(|m| DeviceKey::Cube(m.get())).collect())
    }

    fn poll(&mut self, dev: DeviceKey) -> Result<Snapshot, SourceError> {
        let m = Self::module(dev)?;
        let s = self.statics(m)?;
        let v = self.read(m, &POLLED)?;
        Ok(Snapshot::Cube(CubeSnap {
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

    fn act(&mut self, dev: DeviceKey, action: Action) -> Result<String, SourceError> {
        let m = Self::module(dev)?;
        let simple = |pc: &mut PowerCube, req: Request, what: &str| -> Result<String, SourceError> {
            pc.transact(m, &req)?;
            Ok(format!("{what} acknowledged"))
        };
        match action {
            Action::Home => simple(&mut self.pc, Request::Home, "Home"),
            Action::Reset => {
                self.statics.remove(&m.get());
                simple(&mut self.pc, Request::Reset, "Reset")
            }
            Action::Halt => simple(&mut self.pc, Request::Halt, "Halt"),
            Action::Jog(step) => {
                limits::check_finite("jog step", step).map_err(|e| SourceError::Refused(e.to_string()))?;
                self.ramp_to(m, |pos| pos + step)
            }
            Action::MoveTo(pos) => self.ramp_to(m, |_| pos),
            Action::Enable | Action::Disable => Err(SourceError::Unsupported(
                "PowerCube modules have no enable / disable: r (reset) switches the servo on, s (halt) stops it".into(),
            )),
            Action::Online | Action::Offline => {
                Err(SourceError::Unsupported("online / offline is a PA-CONTROL mode".into()))
            }
        }
    }

    /// The broadcast first (one frame stops every module on the bus, known
    /// or not), then each known module's acknowledged Halt for the report.
    fn halt_all(&mut self) -> Vec<HaltReport> {
        let mut out =
            vec![(None, self.pc.broadcast(Broadcast::Halt).map(|_| "Halt broadcast".into()).map_err(Into::into))];
        for m in self.known.clone() {
            let r = self.pc.transact(m, &Request::Halt).map(|_| "halted".to_string()).map_err(Into::into);
            out.push((Some(DeviceKey::Cube(m.get())), r));
        }
        out
    }
}
