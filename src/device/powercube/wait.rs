//! Waiting for the end of a homing or a ramp: CubeState and ActPos are
//! polled until the goal is reached. An error flag ends the wait as a fault;
//! an interruption, a lost module and the wait timeout halt the module first.

use std::sync::Arc;
use std::time::Duration;

use super::error::halt_note;
use super::{param, Cubes, Error};
use crate::proto::powercube::flags::{state, CUBE_STATE};
use crate::proto::powercube::table::ids;
use crate::proto::powercube::ModuleId;
use crate::session::SessionError;

/// How a wait polls and when it gives up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WaitSpec {
    pub poll: Duration,
    pub timeout: Duration,
    /// How often the Halt that ends a failed wait is sent at most.
    pub halt_attempts: u32,
}

/// What a wait is for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Goal {
    /// Homing done: STATE_HOME_OK and no motion, with or without
    /// RAMP_END (see [`homed`]).
    Homed,
    /// A ramp to `target` (units, or ticks with `ticks`) ended.
    RampEnd { target: f64, ticks: bool },
}

/// Where a wait ended.
#[derive(Debug, Clone, PartialEq)]
pub struct WaitEnd {
    pub module: ModuleId,
    pub position: f32,
    pub cube: u32,
    pub elapsed: Duration,
}

impl Goal {
    /// "homing" / "moving", as the messages say.
    pub fn doing(self) -> &'static str {
        match self {
            Self::Homed => "homing",
            Self::RampEnd { .. } => "moving",
        }
    }
}

impl Cubes {
    /// Polls until `goal`; `interrupted` is asked before each poll and
    /// `progress` sees every poll (position, CubeState).
    pub fn wait(
        &mut self,
        m: ModuleId,
        goal: Goal,
        spec: WaitSpec,
        interrupted: &dyn Fn() -> bool,
        progress: &mut dyn FnMut(f32, u32),
    ) -> Result<WaitEnd, Error> {
        let what = goal.doing();
        let mut done = self.done_test(m, goal)?;
        let clock = Arc::clone(self.session().clock());
        let start = clock.now();
        loop {
            if interrupted() {
                let halt_failed = self.halt_retrying(m, spec.halt_attempts).err().map(|e| self.backstop(e.to_string()));
                return Err(Error::Interrupted { module: m, halt_failed });
            }
            let vals = match self.get_many(m, &[param(ids::CUBE_STATE), param(ids::ACT_POS)]) {
                Ok(v) => v,
                // The module may still be moving: stop it before giving up.
                Err(e) => {
                    let halt_failed =
                        self.halt_retrying(m, spec.halt_attempts).err().map(|e| self.backstop(e.to_string()));
                    return Err(match e {
                        Error::Session(source) => {
                            Error::LostTrack { module: m, what: what.into(), halt_failed, source }
                        }
                        other => other,
                    });
                }
            };
            let f = |i: usize| vals[i].as_f64().unwrap_or(f64::NAN);
            let (cube, pos) = (f(0) as u32, f(1) as f32);
            let elapsed = clock.now() - start;
            progress(pos, cube);
            let d = CUBE_STATE.decode(cube);
            if d.has_error() {
                return Err(Error::Faulted { module: m, what: what.into(), errors: d.errors, cube });
            }
            if done(cube, pos) {
                return Ok(WaitEnd { module: m, position: pos, cube, elapsed });
            }
            if elapsed >= spec.timeout {
                let halt_failed = self.halt_retrying(m, spec.halt_attempts).err().map(|e| self.backstop(e.to_string()));
                return Err(Error::Session(SessionError::wait_expired(
                    format!("module {m}"),
                    what,
                    spec.timeout,
                    Some(halt_note(m, halt_failed.as_deref())),
                )));
            }
            // Refreshes the watchdog meanwhile when a supervised motion
            // keeps it. A link that fails here fails the next poll, which
            // halts first.
            let _ = self.session().pause(spec.poll);
        }
    }

    /// The test of a goal on (CubeState, ActPos). A ramp has ended once no
    /// motion is flagged, RAMP_END is, and the module either was seen moving
    /// or stands at the target (a ramp to where it stands never moves).
    fn done_test(&mut self, m: ModuleId, goal: Goal) -> Result<Box<dyn FnMut(u32, f32) -> bool>, Error> {
        Ok(match goal {
            Goal::Homed => Box::new(|cube, _| homed(cube)),
            Goal::RampEnd { target, ticks } => {
                // ActPos is in units: a tick target is converted with IncRatio.
                let scale = if ticks {
                    self.session().get(m, param(ids::INC_RATIO))?.as_f64().unwrap_or(f64::NAN)
                } else {
                    1.0
                };
                let goal = if ticks && scale != 0.0 { target / scale } else { target };
                let mut seen_motion = false;
                Box::new(move |cube, p| {
                    seen_motion |= cube & state::MOTION != 0;
                    let near = (f64::from(p) - goal).abs() <= 1e-3 * goal.abs().max(1.0);
                    cube & state::MOTION == 0 && cube & state::RAMP_END != 0 && (seen_motion || near)
                })
            }
        })
    }
}

/// The end of homing. HOME_OK is the evidence that homing is done; RAMP_END
/// is not asked for: the vendor's library waits for both, but IPA's driver
/// checks HOME_OK only, so some firmware evidently ends homing without it.
/// RAMP_END alone proves nothing about homing (a ramp sets it too).
pub fn homed(cube: u32) -> bool {
    cube & state::HOME_OK != 0 && cube & state::MOTION == 0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homing_ends_on_home_ok_with_or_without_ramp_end() {
        assert!(homed(state::HOME_OK));
        assert!(homed(state::HOME_OK | state::RAMP_END));
        assert!(!homed(state::RAMP_END), "a ramp's end is not the end of homing");
        assert!(!homed(state::HOME_OK | state::MOTION), "still moving");
    }
}
