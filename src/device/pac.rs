//! PA-CONTROL operations over one [`Pac`] session: every read, command,
//! move, stop and halt a person or a script performs, with the checks that
//! decide whether it may be sent. `pac-*` and the dashboard call these and
//! only print.
//!
//! - Commands are built from their table row and validated before anything
//!   is sent: the manual's ranges, and the operating mode (read with 190B,
//!   then followed through every acknowledge) unless the command is valid in
//!   every mode or is itself a mode change (5.2.1, 0A41, 0A81): those go out
//!   as exactly one frame and the controller's QUIT says if the mode was
//!   wrong. [`Controller::online`] reads first: from home position, the
//!   limits of 0A8D / 0A8E ([`OnlineLimits`]), which only that mode reads.
//! - Moves start with 0A94 / 0A95, which answer BE = 1 at once, so the line
//!   stays free for polls and stops (manual 5.2.6.6). Their target is
//!   checked against the axis' traverse area (1913 / 1914) first.
//! - While a start-and-wait command runs (0A84, or 0A87 / 0A89 sent raw) the
//!   controller takes only polls; the one way past that is giving it up and
//!   stopping its axis (0A93), which stops and halt-all do.

mod elements;
mod error;
mod face;
mod halt;
mod limits;
mod motion;
#[cfg(test)]
mod tests;

use std::collections::BTreeMap;
use std::fmt;

pub use elements::{Element, Register, RegisterKind};
pub use error::Error;
pub use face::{stop_command, Follow};
pub use halt::{HaltStep, HaltTarget};
pub use limits::OnlineLimits;
pub use motion::{Halted, MoveProgress, MoveStart};

/// How a stop asked for by hand went ([`Controller::stop_by_hand`]).
#[derive(Debug)]
pub(crate) enum StopOutcome {
    /// Sent and acknowledged (the acknowledge is the session's last).
    Sent,
    /// Nothing to stop: the controller is in home position (the status
    /// read is the session's last acknowledge).
    AtRest,
}

use crate::proto::pac::session::Step;
use crate::proto::pac::table::{self, CommandDef, Mode};
use crate::proto::pac::validate::{self, Context};
use crate::proto::pac::{Ack, Command, Par2};
use crate::proto::DecodeError;
use crate::session::pac::{Done, Pac, PacError};
use crate::session::SessionError;

pub type Result<T, E = Error> = std::result::Result<T, E>;

/// QUIT "axis number unknown": the probe for configured axes ends there.
const AXIS_UNKNOWN: u16 = 0x20;

/// Codes that change the operating mode: exempt from the local mode check.
const MODE_CHANGES: [u16; 5] = [0x0600, 0x0602, 0x0603, 0x0A41, 0x0A81];

/// An axis' traverse area as the controller reports it (1913 / 1914).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraverseArea {
    pub min: f64,
    pub max: f64,
}

/// What 190C / 190D / 1910 / 1921 say about an axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisState {
    pub position: f64,
    pub speed: f64,
    /// 1910 (manual 6.3 axis status).
    pub status: i64,
    /// 1921 (extended axis status bits).
    pub ext_status: u32,
}

/// The command the controller is still processing (BE = 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Busy(pub Command);

impl fmt::Display for Busy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{:04X} ({}) is running: the controller answers only polls until it ends",
            self.0.code,
            table::command(self.0.code).map_or("?", |d| d.name)
        )
    }
}

/// The acknowledge of 0909 and the error number still standing (0: reset).
#[derive(Debug, Clone, Copy)]
pub struct Reset {
    pub ack: Ack,
    pub left: i64,
}

impl Reset {
    /// An error that could not be reset is a fault of the controller.
    pub fn check(&self) -> Result<()> {
        if self.left == 0 {
            Ok(())
        } else {
            Err(Error::ErrorNotReset(self.left))
        }
    }
}

/// A target as `pac-move` checks it: finite, and inside the axis' traverse
/// area when one is known.
pub fn check_target(axis: u8, target: f64, area: Option<TraverseArea>) -> Result<()> {
    if !target.is_finite() {
        return Err(Error::NotFinite { target });
    }
    match area {
        Some(a) if target < a.min || target > a.max => Err(Error::OutsideTraverseArea { axis, target, area: a }),
        _ => Ok(()),
    }
}

fn valid_in_every_mode(def: &CommandDef) -> bool {
    Mode::ALL.iter().all(|m| def.modes.contains(*m))
}

/// Speeds and accelerations (0A8D / 0A8E) must be positive. Their min / max
/// (axis parameters 1 / 6) can only be read in home position, where these
/// commands are not valid: [`Controller::online`] reads them on the way
/// ([`limits`]); where they are not known the controller checks (0x29).
fn check_positive(code: u16, value: Option<f64>) -> Result<()> {
    let what = match code {
        0x0A8D => "speed",
        0x0A8E => "acceleration",
        _ => return Ok(()),
    };
    match value {
        Some(v) if v.is_nan() || v <= 0.0 => Err(Error::Refused(format!("{what} {v} must be greater than 0"))),
        _ => Ok(()),
    }
}

/// The axis a command moves and waits on: the one to stop when its wait is
/// given up or loses track.
pub fn stoppable_axis(cmd: &Command) -> Option<u8> {
    table::command(cmd.code)
        .filter(|d| d.motion && d.is_start_and_wait() && d.par1 == table::Par1Kind::Axis)
        .and_then(|_| u8::try_from(cmd.par1).ok())
}

/// A PA-CONTROL and what is known about it.
pub struct Controller {
    pac: Pac,
    limits: Context,
    /// The axes halt-all stops: set by [`Controller::set_axes`].
    axes: Vec<u8>,
    /// Read once per axis: the controller's traverse area changes only with
    /// its parameters, which are written in home position.
    areas: BTreeMap<u8, TraverseArea>,
    /// The limits of 0A8D / 0A8E, read on the way online or handed over.
    online_limits: OnlineLimits,
}

impl Controller {
    pub fn new(pac: Pac) -> Self {
        Self {
            pac,
            limits: Context::default(),
            axes: Vec::new(),
            areas: BTreeMap::new(),
            online_limits: OnlineLimits::default(),
        }
    }

    /// Limits read by another process on its way online (a stored copy):
    /// 0A8D / 0A8E outside them are refused before sending.
    pub fn know_online_limits(&mut self, limits: OnlineLimits) {
        self.online_limits = limits;
    }

    /// The limits 0A8D / 0A8E are checked against (empty: none known).
    pub fn online_limits(&self) -> &OnlineLimits {
        &self.online_limits
    }

    /// The session underneath, for its settings and state.
    pub fn session(&self) -> &Pac {
        &self.pac
    }

    pub fn session_mut(&mut self) -> &mut Pac {
        &mut self.pac
    }

    /// The axes to work with (given, or [`configured_axes`](Self::configured_axes));
    /// axis numbers above the highest are refused before sending.
    pub fn set_axes(&mut self, axes: Vec<u8>) {
        self.limits.axes = axes.iter().copied().max().unwrap_or(table::MAX_AXES);
        self.axes = axes;
    }

    pub fn axes(&self) -> &[u8] {
        &self.axes
    }

    /// The unfinished command, if one runs.
    pub fn busy(&self) -> Option<Busy> {
        self.pac.busy_command().copied().map(Busy)
    }

    /// Refuses while a command runs, before anything else is tried.
    pub fn ensure_idle(&self) -> Result<()> {
        self.busy().map_or(Ok(()), |b| Err(Error::Busy(b)))
    }

    /// The operating status, read once (190B, valid in every mode) and then
    /// followed through every acknowledge. For checks before sending; halt-all
    /// reads it fresh.
    pub fn status(&mut self) -> Result<u16> {
        if let Some(s) = self.pac.last_status() {
            return Ok(s);
        }
        self.read_status()
    }

    /// 190B, sent now.
    pub fn read_status(&mut self) -> Result<u16> {
        Ok(self.pac.transact(&Command::new(0x190B, 0, Par2::Int(0)))?.ack.status)
    }

    /// A fresh acknowledge: a poll while a command runs (nothing else may be
    /// sent), else 190B.
    pub fn poll_state(&mut self) -> Result<Ack> {
        if self.pac.busy_command().is_some() {
            return match self.pac.poll()? {
                Step::Done(a) | Step::NeedPoll { last: a, .. } => Ok(a),
            };
        }
        Ok(self.pac.transact(&Command::new(0x190B, 0, Par2::Int(0)))?.ack)
    }

    /// Builds and validates a command: the table's ranges, the known
    /// limits, and the mode unless the command is a mode change or valid in
    /// every mode. Nothing is sent but, when needed, 190B.
    pub fn build(&mut self, code: u16, par1: i64, value: Option<f64>) -> Result<Command> {
        let def = table::command(code).ok_or(validate::ValidationError::UnknownCommand { code })?;
        check_positive(code, value)?;
        if let Some(why) = limits::check(&self.online_limits, code, par1, value) {
            return Err(Error::Refused(why));
        }
        let exempt = valid_in_every_mode(def) || MODE_CHANGES.contains(&code);
        self.limits.status = if exempt { None } else { Some(self.status()?) };
        Ok(validate::build(def, par1, value, &self.limits)?)
    }

    /// Builds, validates and sends a command; polls it to its end.
    pub fn send(&mut self, code: u16, par1: i64, value: Option<f64>) -> Result<Done> {
        let cmd = self.build(code, par1, value)?;
        Ok(self.pac.transact(&cmd)?)
    }

    pub fn read_f64(&mut self, code: u16, par1: i64) -> Result<f64> {
        Ok(self.send(code, par1, None)?.ack.q_par.as_f64())
    }

    pub fn read_i64(&mut self, code: u16, par1: i64) -> Result<i64> {
        let q_par = self.send(code, par1, None)?.ack.q_par;
        q_par.as_i64().ok_or_else(|| {
            Error::Session(SessionError::Malformed {
                target: "PA-CONTROL".into(),
                source: DecodeError::Malformed(format!("{code:04X} answered {q_par} where an integer was expected")),
            })
        })
    }

    /// Position, speed, status and extended status of an axis.
    pub fn axis_state(&mut self, axis: u8) -> Result<AxisState> {
        let a = i64::from(axis);
        Ok(AxisState {
            position: self.read_f64(0x190C, a)?,
            speed: self.read_f64(0x190D, a)?,
            status: self.read_i64(0x1910, a)?,
            ext_status: self.read_i64(0x1921, a)? as u32,
        })
    }

    /// The axis' traverse area, read once.
    pub fn traverse_area(&mut self, axis: u8) -> Result<TraverseArea> {
        if let Some(a) = self.areas.get(&axis) {
            return Ok(*a);
        }
        let a = TraverseArea { min: self.read_f64(0x1913, axis.into())?, max: self.read_f64(0x1914, axis.into())? };
        self.areas.insert(axis, a);
        Ok(a)
    }

    /// The number of configured axes: system parameter 2 in home position
    /// (the only mode that reads parameters), else 1910 on 1, 2, ... until
    /// "axis number unknown" (0x20).
    pub fn configured_axes(&mut self) -> Result<u8> {
        if self.status()? == 1 {
            if let Ok(n) = self.read_i64(0x1700, 2) {
                return Ok(n.clamp(0, i64::from(table::MAX_AXES)) as u8);
            }
        }
        let mut n = 0;
        for axis in 1..=table::MAX_AXES {
            match self.pac.transact(&Command::new(0x1910, axis.into(), Par2::Int(0))) {
                Ok(_) => n = axis,
                Err(PacError::Session(SessionError::Device { .. })) if self.pac.last_quit() == Some(AXIS_UNKNOWN) => {
                    break
                }
                Err(e) => return Err(e.into()),
            }
        }
        Ok(n)
    }

    /// Writes system parameter `number` within the controller's own limits
    /// (1702 / 1701) and the table's, then reads it back.
    pub fn write_system_param(&mut self, number: i64, value: f64) -> Result<i64> {
        let (min, max) = (self.read_i64(0x1702, number)?, self.read_i64(0x1701, number)?);
        self.limits.system_param_limits.insert(number, (min, max));
        self.send(0x0700, number, Some(value))?;
        self.read_i64(0x1700, number)
    }

    /// Writes an axis parameter (PAR_1 axis * 256 + number) within the
    /// controller's own limits (1802 / 1801) and the table's, then reads it back.
    pub fn write_axis_param(&mut self, par1: i64, value: f64) -> Result<f64> {
        let (min, max) = (self.read_f64(0x1802, par1)?, self.read_f64(0x1801, par1)?);
        self.limits.axis_param_limits.insert(par1, (min, max));
        self.send(0x0800, par1, Some(value))?;
        self.read_f64(0x1800, par1)
    }

    /// 0603: home position to online mode. From home position the limits of
    /// 0A8D / 0A8E are read first (the only mode they can be read in), and
    /// kept ([`online_limits`](Self::online_limits)).
    pub fn online(&mut self) -> Result<Done> {
        if self.busy().is_none() && table::mode_of_status(self.read_status()?) == Some(Mode::Home) {
            self.online_limits = self.read_online_limits()?;
        }
        self.send(0x0603, 0, None)
    }

    /// Axis parameters 1 and 6's min / max (1802 / 1801) of the axes to work
    /// with, or of the configured ones. An axis whose limits the controller
    /// refuses to give is left out: its values are then checked by the
    /// controller alone.
    fn read_online_limits(&mut self) -> Result<OnlineLimits> {
        let axes = if self.axes.is_empty() { (1..=self.configured_axes()?).collect() } else { self.axes.clone() };
        let mut found = OnlineLimits::default();
        for axis in axes {
            for param in limits::PARAMS {
                let par1 = table::axis_param_par1(axis, param);
                match (self.read_f64(0x1802, par1), self.read_f64(0x1801, par1)) {
                    (Ok(min), Ok(max)) => found.insert(axis, param, min, max),
                    (Err(Error::Session(e)), _) | (_, Err(Error::Session(e))) if e.refusal().is_none() => {
                        return Err(e.into())
                    }
                    _ => {}
                }
            }
        }
        Ok(found)
    }

    /// 0A81: online mode back to home position (every axis stops where it
    /// is). The online values, and so their limits, end there.
    pub fn offline(&mut self) -> Result<Done> {
        let done = self.send(0x0A81, 0, None)?;
        self.online_limits = OnlineLimits::default();
        Ok(done)
    }

    /// 0600: stop the automatic program or the online axes (a mode change:
    /// sent without the local mode check, the QUIT says if it was pointless).
    pub fn stop(&mut self) -> Result<Done> {
        self.send(0x0600, 0, None)
    }

    /// A stop that a person or a script asked for (0600, 0A9A, 0A93): in home
    /// position no axis moves (halt-all's table), so that is the state asked
    /// for and nothing is sent but the status read; the stop would only be
    /// refused there. In every other mode, or while a command of ours runs,
    /// the stop goes out as before.
    pub(crate) fn stop_by_hand(&mut self, code: u16, par1: i64) -> Result<StopOutcome> {
        if self.busy().is_none() {
            let status = self.read_status()?;
            if table::mode_of_status(status) == Some(Mode::Home) {
                return Ok(StopOutcome::AtRest);
            }
        }
        self.send(code, par1, None)?;
        Ok(StopOutcome::Sent)
    }

    /// 0A97: switch an axis on.
    pub fn enable(&mut self, axis: u8) -> Result<Done> {
        self.send(0x0A97, axis.into(), None)
    }

    /// 0A98: switch an axis off.
    pub fn disable(&mut self, axis: u8) -> Result<Done> {
        self.send(0x0A98, axis.into(), None)
    }

    /// 0909 (home position only); the acknowledge date is the error number
    /// if it could not be reset (5.2.4.15).
    pub fn reset_error(&mut self) -> Result<Reset> {
        let ack = self.send(0x0909, 0, None)?.ack;
        Ok(Reset { ack, left: ack.q_par.as_i64().unwrap_or(0) })
    }
}
