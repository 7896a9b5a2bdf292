//! Halt-all: stop whatever the controller is moving, by the operating mode
//! read fresh at that moment (a cached one may be minutes old: a start
//! input or the front panel changes the mode without us).
//!
//! | mode read             | sent                                               |
//! |-----------------------|----------------------------------------------------|
//! | automatic             | 0600 STOP (the program and every axis brake)       |
//! | online                | 0A9A to every known axis (online mode stays);      |
//! |                       | 0600 STOP when no axes are known                   |
//! | home position         | nothing: no axis moves there                       |
//! | manual (front panel)  | nothing: 0600 is not valid there; reported as fault|
//! | unreadable or unknown | 0600 STOP anyway: the one stop of both moving modes|
//!
//! 0A93 / 0A9A go out with TYP F as the table has them, unvalidated like
//! 0600: in an emergency the controller's QUIT is the check.
//!
//! A running start-and-wait command (a reference drive) is given up first
//! and its axis stopped with 0A93, since until it ends the controller takes
//! nothing but polls.

use crate::proto::pac::table::{self, Mode};
use crate::proto::pac::{Command, Par2};

use super::{Controller, Error, Result};

/// Whom one step of halt-all concerns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HaltTarget {
    Controller,
    Axis(u8),
}

/// One step of halt-all and how it went.
#[derive(Debug)]
pub struct HaltStep {
    pub target: HaltTarget,
    pub result: Result<String>,
}

impl HaltStep {
    fn new(target: HaltTarget, result: Result<String>) -> Self {
        Self { target, result }
    }
}

impl Controller {
    /// Stops everything that may move (see the module docs for what each
    /// mode gets). Never stops early: each step is tried and reported.
    pub fn halt_all(&mut self) -> Vec<HaltStep> {
        let mut out = Vec::new();
        if let Some((running, r)) = self.give_up_busy() {
            let target =
                u8::try_from(running.par1).ok().filter(|a| *a >= 1).map_or(HaltTarget::Controller, HaltTarget::Axis);
            out.push(HaltStep::new(target, r.map(|_| format!("{:04X} given up, axis stopped", running.code))));
        }
        let status = self.read_status();
        match status.as_ref().ok().copied().and_then(table::mode_of_status) {
            Some(Mode::Online) if self.axes.is_empty() => out.push(self.stop_program("online, no axes known")),
            Some(Mode::Online) => {
                for axis in self.axes.clone() {
                    let r = self.pac.transact(&Command::new(0x0A9A, axis.into(), Par2::Float(0.0)));
                    out.push(HaltStep::new(
                        HaltTarget::Axis(axis),
                        r.map(|_| "stopped (0A9A)".into()).map_err(Error::from),
                    ));
                }
            }
            Some(Mode::Automatic) => out.push(self.stop_program("automatic mode")),
            Some(Mode::Home) => {
                out.push(HaltStep::new(HaltTarget::Controller, Ok("home position: no axis moves, nothing sent".into())))
            }
            Some(Mode::Manual) => {
                let status = *status.as_ref().expect("a mode comes from a status");
                out.push(HaltStep::new(HaltTarget::Controller, Err(Error::ManualMode { status })))
            }
            None => {
                let why = match status {
                    Ok(s) => format!("unknown operating status {s}"),
                    Err(e) => {
                        out.push(HaltStep::new(HaltTarget::Controller, Err(e)));
                        "operating mode unreadable".into()
                    }
                };
                out.push(self.stop_program(&why));
            }
        }
        out
    }

    /// 0600, unvalidated: in an emergency the controller's QUIT is the check.
    fn stop_program(&mut self, why: &str) -> HaltStep {
        let r = self.pac.transact(&Command::new(0x0600, 0, Par2::Int(0)));
        HaltStep::new(HaltTarget::Controller, r.map(|_| format!("{why}: STOP (0600) sent")).map_err(Error::from))
    }
}
