//! The Cdios device source: the 6168 modules of one node, four reads per
//! poll (status bytes, speed and RPM error, position, setpoint).

use super::source::{Action, CdiosSnap, DeviceKey, DeviceSource, HaltReport, Snapshot, SourceError};
use crate::family::Family;
use crate::proto::cdios::table;
use crate::proto::cdios::{
    Address, Command, Direction, GotoMode, ModuleId, NodeId, PositionSource, StartOption, StatusSelector, StopOption,
};
use crate::session::cdios::Cdios;
use crate::session::RetryPolicy;

/// Status 1 bits 0 and 1: running forward / reverse.
const RUNNING: u8 = 0x03;

pub struct CdiosSource {
    s: Cdios,
    node: NodeId,
    /// Given with `--cdios-modules`; `None` scans 0..=15 at start.
    wanted: Option<Vec<ModuleId>>,
    known: Vec<ModuleId>,
    retry: RetryPolicy,
}

/// A goto position as the CLI checks it: the table's range for the field.
pub fn check_position(row: &str, v: f64) -> Result<i32, String> {
    if v.fract() != 0.0 || !v.is_finite() {
        return Err(format!("position {v} is not a whole number of counts; nothing was sent"));
    }
    let field = table::command(row).and_then(|d| d.field("position")).expect("goto rows have a position");
    field.check(v as i64).map_err(|e| format!("{e}; nothing was sent"))?;
    Ok(v as i32)
}

impl CdiosSource {
    pub fn new(s: Cdios, node: NodeId, modules: Option<Vec<ModuleId>>, retry: RetryPolicy) -> Self {
        Self { s, node, wanted: modules, known: Vec::new(), retry }
    }

    fn module(&self, dev: DeviceKey) -> Result<ModuleId, SourceError> {
        match dev {
            DeviceKey::Cdios { node, module } if node == self.node.get() => {
                ModuleId::new(module).ok_or_else(|| SourceError::Refused(format!("no module id {module}")))
            }
            other => Err(SourceError::Unsupported(format!("{} is not on Cdios node {}", other.label(), self.node))),
        }
    }

    fn send(&mut self, m: ModuleId, cmd: Command, what: &str) -> Result<String, SourceError> {
        cmd.encode(Address::Module(m)).map_err(|e| SourceError::Refused(format!("{e}; nothing was sent")))?;
        let confirmed = self.s.transact(self.node, Address::Module(m), &cmd)?.is_some();
        Ok(if confirmed { format!("{what} confirmed") } else { format!("{what} sent (confirmations off)") })
    }
}

impl DeviceSource for CdiosSource {
    fn family(&self) -> Family {
        Family::Cdios
    }

    /// A module answers its status read; an absent one times out (or is
    /// refused by the controller), so the scan reads once, without retries.
    fn discover(&mut self) -> Result<Vec<DeviceKey>, SourceError> {
        self.known = match &self.wanted {
            Some(list) => list.clone(),
            None => {
                self.s.set_retry(RetryPolicy { read_retries: 0 });
                let mut found = Vec::new();
                for m in ModuleId::all() {
                    match self.s.read_status(self.node, m) {
                        Ok(_) => found.push(m),
                        Err(crate::session::SessionError::Link(e)) => {
                            self.s.set_retry(self.retry);
                            return Err(crate::session::SessionError::Link(e).into());
                        }
                        Err(_) => {}
                    }
                }
                self.s.set_retry(self.retry);
                found
            }
        };
        Ok(self.known.iter().map(|m| DeviceKey::Cdios { node: self.node.get(), module: m.get() }).collect())
    }

    fn poll(&mut self, dev: DeviceKey) -> Result<Snapshot, SourceError> {
        let m = self.module(dev)?;
        // One burst per poll: status, speed, position, setpoint.
        let replies = self.s.read_many(
            self.node,
            Address::Module(m),
            &[
                Command::ReadStatus(StatusSelector::Status),
                Command::ReadStatus(StatusSelector::SpeedError),
                Command::ReadPosition(PositionSource::Current),
                Command::ReadPosition(PositionSource::Setpoint),
            ],
        )?;
        let get = |i: usize, k: &str| replies[i].get(k).unwrap_or(0);
        let byte = |k| get(0, k) as u8;
        Ok(Snapshot::Cdios(CdiosSnap {
            position: get(2, "position"),
            setpoint: get(3, "position"),
            speed: get(1, "motor_speed"),
            rpm_error: get(1, "rpm_error"),
            status: [byte("status1"), byte("status2"), byte("status3"), byte("status4")],
        }))
    }

    fn act(&mut self, dev: DeviceKey, action: Action) -> Result<String, SourceError> {
        let m = self.module(dev)?;
        match action {
            Action::Halt => self.send(m, Command::Stop { sync: false, option: StopOption::FastStop }, "fast stop"),
            Action::Reset => self.send(
                m,
                Command::Stop { sync: false, option: StopOption::ReleaseEmergency },
                "emergency stop release",
            ),
            Action::Enable => self.send(
                m,
                Command::Start {
                    sync: false,
                    direction: Direction::Forward,
                    option: StartOption::Enable,
                    motor_speed: 0,
                },
                "enable",
            ),
            Action::Disable => self.send(m, Command::Stop { sync: false, option: StopOption::Disable }, "disable"),
            Action::Jog(d) => {
                let position = check_position("goto", d).map_err(SourceError::Refused)?;
                self.send(
                    m,
                    Command::Goto { mode: GotoMode::Relative, position },
                    &format!("goto relative {position:+}"),
                )
            }
            Action::MoveTo(p) => {
                let position = check_position("goto", p).map_err(SourceError::Refused)?;
                self.send(m, Command::Goto { mode: GotoMode::Absolute, position }, &format!("goto {position}"))
            }
            Action::Home => Err(SourceError::Unsupported("the Cdios 6168 has no homing command".into())),
            Action::Online | Action::Offline => {
                Err(SourceError::Unsupported("online / offline is a PA-CONTROL mode".into()))
            }
        }
    }

    fn halt_all(&mut self) -> Vec<HaltReport> {
        let node = self.node.get();
        self.known
            .clone()
            .into_iter()
            .map(|m| {
                let mut r = self.send(m, Command::Stop { sync: false, option: StopOption::FastStop }, "fast stop");
                // A motor that is not running refuses a stop: that is no failure.
                if let Err(SourceError::Session(crate::session::SessionError::Device { .. })) = &r {
                    if let Ok(st) = self.s.read_status(self.node, m) {
                        if st.status[0] & RUNNING == 0 {
                            r = Ok("not running".into());
                        }
                    }
                }
                (Some(DeviceKey::Cdios { node, module: m.get() }), r)
            })
            .collect()
    }
}
