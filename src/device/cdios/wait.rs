//! Waiting for the end of a goto or a traject: status and position are
//! polled until the goal is reached. An error bit ends the wait as a fault;
//! a fault, an interruption, a lost module and the wait timeout fast-stop
//! the motor first.

use std::sync::Arc;
use std::time::Duration;

use super::error::stop_note;
use super::{Error, Node};
use crate::proto::cdios::{Address, Command, ModuleId, PositionSource, ServoPart, StatusReport};
use crate::session::SessionError;

/// How a wait polls and when it gives up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaitSpec {
    pub poll: Duration,
    pub timeout: Duration,
    /// How often the fast stop that ends a failed wait is sent at most.
    pub stop_attempts: u32,
}

/// What a wait is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Goal {
    Goto,
    Traject,
}

/// The longest stretch a wait listens without asking whether to stop.
const LISTEN_SLICE: std::time::Duration = std::time::Duration::from_millis(20);

impl Goal {
    /// "goto" / "traject", as the messages say.
    pub fn name(self) -> &'static str {
        match self {
            Self::Goto => "goto",
            Self::Traject => "traject",
        }
    }
}

/// Where a wait ended.
#[derive(Debug, Clone, PartialEq)]
pub struct WaitEnd {
    pub position: i32,
    pub status: StatusReport,
    pub elapsed: Duration,
    /// Where a goto ends: its setpoint (a relative goto's target included).
    pub target: Option<i32>,
}

fn active(r: &StatusReport) -> bool {
    r.flags.iter().any(|f| *f == "GOTO_ACTIVE" || *f == "TRAJECT_RUNNING")
}

impl Node {
    /// The configured 'Positioning Error' (20h selector 83h): how near a
    /// goto's target counts as there.
    pub fn positioning_error(&mut self, m: ModuleId) -> Result<i64, Error> {
        self.ready(m)?;
        let r = self.s.read(self.node, Address::Module(m), &Command::ReadServoConfig(ServoPart::Control))?;
        Ok(r.get("positioning_error").unwrap_or(0))
    }

    /// Polls until `goal`; `interrupted` is asked before each poll, and
    /// `progress` sees every poll (position, status). A goto has ended when
    /// neither goto nor traject is active and the motion was seen or the
    /// module stands within the positioning error of the setpoint.
    pub fn wait(
        &mut self,
        m: ModuleId,
        goal: Goal,
        spec: WaitSpec,
        interrupted: &dyn Fn() -> bool,
        progress: &mut dyn FnMut(i32, &StatusReport),
    ) -> Result<WaitEnd, Error> {
        let node = self.node;
        let what = goal.name();
        let near = match goal {
            Goal::Goto => {
                let target = self.position(m, PositionSource::Setpoint)?;
                Some((target, self.positioning_error(m)?))
            }
            Goal::Traject => None,
        };
        let clock = Arc::clone(self.s.clock());
        let start = clock.now();
        let mut seen = false;
        loop {
            if interrupted() {
                let stop_failed = self.stop_retrying(m, spec.stop_attempts).err().map(|e| e.to_string());
                return Err(Error::Interrupted { node, module: m, stop_failed });
            }
            let polled = self
                .s
                .read_status(node, m)
                .and_then(|r| Ok((r, self.s.read_position(node, m, PositionSource::Current)?)));
            let (r, pos) = match polled {
                Ok(v) => v,
                // The motor may still be running: stop it before giving up.
                Err(source) => {
                    let stop_failed = self.stop_retrying(m, spec.stop_attempts).err().map(|e| e.to_string());
                    return Err(Error::LostTrack { node, module: m, what: what.into(), stop_failed, source });
                }
            };
            let elapsed = clock.now() - start;
            progress(pos, &r);
            if !r.errors.is_empty() {
                let _ = self.stop_retrying(m, spec.stop_attempts);
                return Err(Error::Faulted { node, module: m, what: what.into(), errors: r.errors, status: r.status });
            }
            let moving = active(&r);
            seen |= moving;
            let done = match near {
                Some((target, tolerance)) => {
                    !moving && (seen || (i64::from(pos) - i64::from(target)).abs() <= tolerance)
                }
                None => seen && !moving,
            };
            if done {
                return Ok(WaitEnd { position: pos, status: r, elapsed, target: near.map(|n| n.0) });
            }
            if elapsed >= spec.timeout {
                // A motor that came to rest short of the goal refuses the
                // stop as not running: the standstill wanted, no failure.
                let stopped = match self.halt_motor(m, spec.stop_attempts) {
                    Ok(true) => stop_note(node, m, None),
                    Ok(false) => format!("node {node} module {m} at rest, nothing to stop"),
                    Err(e) => stop_note(node, m, Some(&e.to_string())),
                };
                return Err(Error::Session(SessionError::wait_expired(
                    format!("node {node} module {m}"),
                    format!("running the {what}"),
                    spec.timeout,
                    Some(stopped),
                )));
            }
            // Events are read while waiting, in slices short enough that a
            // stop request acts well within a wire round trip.
            let until = clock.now() + spec.poll;
            while !interrupted() {
                let left = until.saturating_duration_since(clock.now());
                if left.is_zero() {
                    break;
                }
                self.s.listen(left.min(LISTEN_SLICE))?;
            }
        }
    }
}
