//! The PA-CONTROL device source: the controller (operating status, error
//! number) and its axes (position, speed, 1910 status, 1921 extended
//! status), over one half-duplex RS232 line.
//!
//! Moves start with 0A94 / 0A95 (start and return), so the line stays free
//! for polls and stops. The reference drive 0A84 has no such form: while it
//! runs the controller takes only polls (manual 5.2.6.6), so the controller
//! line polls it and the axes show as stale with that reason; halt-all then
//! gives it up and stops the axis anyway (0A93, as Ctrl-C does in the CLI).

use std::collections::BTreeMap;

use super::source::{
    Action, DeviceKey, DeviceSource, Family, HaltReport, PacAxisSnap, PacCtrlSnap, Snapshot, SourceError,
};
use crate::proto::pac::session::Step;
use crate::proto::pac::table::{self, Mode};
use crate::proto::pac::validate::{self, Context};
use crate::proto::pac::{Command, Par2};
use crate::session::pac::{Pac, PacError};
use crate::session::SessionError;

/// QUIT "axis number unknown": the probe for configured axes ends there.
const AXIS_UNKNOWN: u16 = 0x20;

pub struct PacSource {
    pac: Pac,
    /// Given with `--axes`; `None` asks the controller.
    wanted: Option<Vec<u8>>,
    axes: Vec<u8>,
    /// Traverse area (1913 / 1914) per axis, read once.
    areas: BTreeMap<u8, (f64, f64)>,
}

fn err(e: PacError) -> SourceError {
    match e {
        PacError::Session(s) => SourceError::Session(s),
        other => SourceError::Refused(other.to_string()),
    }
}

/// A target as `pac-move` checks it: finite, and inside the axis' traverse
/// area when the controller reported one.
pub fn check_target(axis: u8, target: f64, s: &PacAxisSnap) -> Result<(), String> {
    if !target.is_finite() {
        return Err(format!("target position {target} is not a finite number; nothing was sent"));
    }
    if let (Some(min), Some(max)) = (s.min_pos, s.max_pos) {
        if target < min || target > max {
            return Err(format!(
                "target position {target} is outside axis {axis}'s traverse area {min}..={max} (1913 / 1914); nothing was sent"
            ));
        }
    }
    Ok(())
}

impl PacSource {
    pub fn new(pac: Pac, axes: Option<Vec<u8>>) -> Self {
        Self { pac, wanted: axes, axes: Vec::new(), areas: BTreeMap::new() }
    }

    fn busy_reason(&self) -> Option<String> {
        self.pac.busy_command().map(|c| {
            format!(
                "{:04X} ({}) is running: the controller answers only polls until it ends",
                c.code,
                table::command(c.code).map_or("?", |d| d.name)
            )
        })
    }

    fn read(&mut self, code: u16, par1: i64) -> Result<Par2, SourceError> {
        Ok(self.pac.transact(&Command::new(code, par1, Par2::Int(0))).map_err(err)?.ack.q_par)
    }

    fn read_f64(&mut self, code: u16, par1: i64) -> Result<f64, SourceError> {
        Ok(self.read(code, par1)?.as_f64())
    }

    fn read_i64(&mut self, code: u16, par1: i64) -> Result<i64, SourceError> {
        let v = self.read(code, par1)?;
        v.as_i64().ok_or_else(|| {
            SourceError::Session(SessionError::Malformed {
                target: "PA-CONTROL".into(),
                source: crate::proto::DecodeError::Malformed(format!("{code:04X} answered {v} for an integer")),
            })
        })
    }

    fn status(&mut self) -> Result<u16, SourceError> {
        match self.pac.last_status() {
            Some(s) => Ok(s),
            None => Ok(self.pac.transact(&Command::new(0x190B, 0, Par2::Int(0))).map_err(err)?.ack.status),
        }
    }

    /// Builds and checks a command the way `pac-*` does: the manual's
    /// ranges, and the operating mode unless the command is a mode change
    /// or valid in every mode.
    fn build(&mut self, code: u16, par1: i64, value: Option<f64>) -> Result<Command, SourceError> {
        let def = table::command(code).expect("codes used here are in the table");
        let mode_change = matches!(code, 0x0600 | 0x0602 | 0x0603 | 0x0A41 | 0x0A81);
        let every_mode = Mode::ALL.iter().all(|m| def.modes.contains(*m));
        let ctx = Context {
            axes: self.axes.iter().copied().max().unwrap_or(table::MAX_AXES),
            status: if mode_change || every_mode { None } else { Some(self.status()?) },
            ..Context::default()
        };
        validate::build(def, par1, value, &ctx).map_err(|e| SourceError::Refused(format!("{e}; nothing was sent")))
    }

    fn send(&mut self, code: u16, par1: i64, value: Option<f64>) -> Result<String, SourceError> {
        let cmd = self.build(code, par1, value)?;
        let done = self.pac.transact(&cmd).map_err(err)?;
        Ok(format!("{code:04X} done (status {})", done.ack.status))
    }

    fn area(&mut self, axis: u8) -> Result<(f64, f64), SourceError> {
        if let Some(a) = self.areas.get(&axis) {
            return Ok(*a);
        }
        let a = (self.read_f64(0x1913, axis.into())?, self.read_f64(0x1914, axis.into())?);
        self.areas.insert(axis, a);
        Ok(a)
    }

    fn move_axis(&mut self, axis: u8, value: f64, relative: bool) -> Result<String, SourceError> {
        let code = if relative { 0x0A95 } else { 0x0A94 };
        self.build(code, axis.into(), Some(value))?;
        let target = if relative { self.read_f64(0x190C, axis.into())? + value } else { value };
        let (min, max) = self.area(axis)?;
        let snap =
            PacAxisSnap { position: 0.0, speed: 0.0, status: 0, ext_status: 0, min_pos: Some(min), max_pos: Some(max) };
        check_target(axis, target, &snap).map_err(SourceError::Refused)?;
        let cmd = self.build(code, axis.into(), Some(value))?;
        self.pac.transact(&cmd).map_err(err)?;
        Ok(format!("moving to {target}"))
    }

    /// The configured axes: system parameter 2 in home position (the only
    /// mode that reads parameters), else 1910 on 1, 2, ... until "axis
    /// number unknown", as `pac-axes` finds them.
    fn configured_axes(&mut self) -> Result<Vec<u8>, SourceError> {
        if self.status()? == 1 {
            if let Ok(n) = self.read_i64(0x1700, 2) {
                return Ok((1..=n.clamp(0, i64::from(table::MAX_AXES)) as u8).collect());
            }
        }
        let mut n = 0;
        for axis in 1..=table::MAX_AXES {
            match self.pac.transact(&Command::new(0x1910, axis.into(), Par2::Int(0))) {
                Ok(_) => n = axis,
                Err(PacError::Session(SessionError::Device { .. })) if self.pac.last_quit() == Some(AXIS_UNKNOWN) => {
                    break
                }
                Err(e) => return Err(err(e)),
            }
        }
        Ok((1..=n).collect())
    }
}

impl DeviceSource for PacSource {
    fn family(&self) -> Family {
        Family::Pac
    }

    fn discover(&mut self) -> Result<Vec<DeviceKey>, SourceError> {
        self.axes = match self.wanted.clone() {
            Some(list) => list,
            None => self.configured_axes()?,
        };
        let mut out = vec![DeviceKey::PacController];
        out.extend(self.axes.iter().map(|a| DeviceKey::PacAxis(*a)));
        Ok(out)
    }

    fn poll(&mut self, dev: DeviceKey) -> Result<Snapshot, SourceError> {
        match dev {
            DeviceKey::PacController => {
                let ack = if self.pac.busy_command().is_some() {
                    match self.pac.poll().map_err(err)? {
                        Step::Done(a) | Step::NeedPoll { last: a, .. } => a,
                    }
                } else {
                    self.pac.transact(&Command::new(0x190B, 0, Par2::Int(0))).map_err(err)?.ack
                };
                Ok(Snapshot::PacController(PacCtrlSnap {
                    status: ack.status,
                    error: ack.error,
                    axes: self.axes.len() as u8,
                }))
            }
            DeviceKey::PacAxis(axis) => {
                if let Some(why) = self.busy_reason() {
                    return Err(SourceError::Refused(why));
                }
                let a = i64::from(axis);
                let position = self.read_f64(0x190C, a)?;
                let speed = self.read_f64(0x190D, a)?;
                let status = self.read_i64(0x1910, a)?;
                let ext_status = self.read_i64(0x1921, a)? as u32;
                let area = self.area(axis).ok();
                Ok(Snapshot::PacAxis(PacAxisSnap {
                    position,
                    speed,
                    status,
                    ext_status,
                    min_pos: area.map(|a| a.0),
                    max_pos: area.map(|a| a.1),
                }))
            }
            other => Err(SourceError::Unsupported(format!("{} is not a PA-CONTROL device", other.label()))),
        }
    }

    fn act(&mut self, dev: DeviceKey, action: Action) -> Result<String, SourceError> {
        if self.pac.busy_command().is_some() && action != Action::Halt {
            return Err(SourceError::Refused(format!(
                "{}; nothing was sent (s or space stops it)",
                self.busy_reason().unwrap_or_default()
            )));
        }
        match (dev, action) {
            (_, Action::Online) => self.send(0x0603, 0, None),
            (_, Action::Offline) => self.send(0x0A81, 0, None),
            (_, Action::Reset) => {
                let cmd = self.build(0x0909, 0, None)?;
                let left = self.pac.transact(&cmd).map_err(err)?.ack.q_par.as_i64().unwrap_or(0);
                if left == 0 {
                    Ok("error reset".into())
                } else {
                    Err(SourceError::Refused(format!("error E{left} could not be reset")))
                }
            }
            (DeviceKey::PacController, Action::Halt) => self.send(0x0600, 0, None),
            (DeviceKey::PacAxis(axis), Action::Halt) => {
                if self.pac.busy_command().is_some() {
                    let cmd = Command::new(0x0A93, axis.into(), Par2::Int(0));
                    self.pac.abandon_and_stop(&cmd).map_err(err)?;
                    Ok("running command given up, axis stopped (0A93)".into())
                } else {
                    self.send(0x0A9A, axis.into(), None)
                }
            }
            (DeviceKey::PacAxis(axis), Action::Home) => {
                let cmd = self.build(0x0A84, axis.into(), None)?;
                match self.pac.start(&cmd).map_err(err)? {
                    Step::Done(_) => Ok("reference drive done".into()),
                    Step::NeedPoll { .. } => Ok("reference drive started (only polls until it ends)".into()),
                }
            }
            (DeviceKey::PacAxis(axis), Action::Enable) => self.send(0x0A97, axis.into(), None),
            (DeviceKey::PacAxis(axis), Action::Disable) => self.send(0x0A98, axis.into(), None),
            (DeviceKey::PacAxis(axis), Action::Jog(d)) => self.move_axis(axis, d, true),
            (DeviceKey::PacAxis(axis), Action::MoveTo(p)) => self.move_axis(axis, p, false),
            (d, a) => Err(SourceError::Unsupported(format!("{} has no {}", d.label(), a.name()))),
        }
    }

    /// Gives up a running reference drive first (stopping its axis), then
    /// stops every axis. Outside online mode no axis moves: nothing to stop.
    fn halt_all(&mut self) -> Vec<HaltReport> {
        let mut out = Vec::new();
        if let Some(c) = self.pac.busy_command().cloned() {
            let stop = Command::new(0x0A93, c.par1, Par2::Int(0));
            let r = self.pac.abandon_and_stop(&stop).map(|_| format!("{:04X} given up, axis stopped", c.code));
            let axis = u8::try_from(c.par1).ok().filter(|a| *a >= 1).map(DeviceKey::PacAxis);
            out.push((axis, r.map_err(err)));
        }
        let online = self.pac.last_status().and_then(table::mode_of_status) == Some(Mode::Online);
        for axis in self.axes.clone() {
            let r = if online {
                self.pac
                    .transact(&Command::new(0x0A9A, axis.into(), Par2::Int(0)))
                    .map(|_| "stopped (0A9A)".to_string())
                    .map_err(err)
            } else {
                Ok("not in online mode: does not move".to_string())
            };
            out.push((Some(DeviceKey::PacAxis(axis)), r));
        }
        out
    }
}
