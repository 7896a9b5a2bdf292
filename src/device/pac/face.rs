//! The PA-CONTROL's device face: one face for the controller of a line,
//! and the waited moves that hold its `Moving` handle.

use std::time::Duration;

use crate::device::face::{Face, FaceError, Found, Halt, HaltStep, Manner, MotionTarget, Moving, State, StopHow};
use crate::family::Family;
use crate::proto::pac::table;
use crate::session::pac::{Done, Progress};

use super::{Controller, HaltTarget, MoveProgress, MoveStart, Result, StopOutcome};

fn step_target(t: HaltTarget) -> MotionTarget {
    match t {
        HaltTarget::Controller => MotionTarget::PacController,
        HaltTarget::Axis(a) => MotionTarget::PacAxis(a),
    }
}

fn not_here(at: MotionTarget) -> FaceError {
    FaceError::NotHere(at, "PA-CONTROL")
}

impl Face for Controller {
    fn family(&self) -> Family {
        Family::Pac
    }

    /// A controller that does not answer is absent (no device, no error):
    /// a serial line says nothing of who is on it. Then the controller
    /// and each configured axis.
    fn discover(&mut self, _candidates: &[u8]) -> Result<Vec<Found>, FaceError> {
        let Ok(status) = self.status() else { return Ok(Vec::new()) };
        let axes = self.configured_axes()?;
        let detail = format!("status {status} {}, {axes} axes", table::operating_status_text(status));
        let mut found = vec![Found { target: MotionTarget::PacController, detail }];
        found.extend((1..=axes).map(|a| Found { target: MotionTarget::PacAxis(a), detail: String::new() }));
        Ok(found)
    }

    fn identify(&mut self, at: MotionTarget) -> Result<String, FaceError> {
        match at {
            MotionTarget::PacController | MotionTarget::PacAxis(_) => {
                let status = self.status()?;
                Ok(format!("status {status} {}", table::operating_status_text(status)))
            }
            other => Err(not_here(other)),
        }
    }

    /// A command of ours still running moves, whatever the axis says;
    /// otherwise the axis status (1910) says: 1 is moving.
    fn state(&mut self, at: MotionTarget) -> Result<State, FaceError> {
        if let Some(busy) = self.busy() {
            return Ok(State { moving: true, detail: busy.to_string() });
        }
        match at {
            MotionTarget::PacAxis(axis) => {
                let status = self.read_i64(0x1910, i64::from(axis))?;
                let detail = table::axis_status_text(status as u64).to_string();
                Ok(State { moving: status == 1, detail })
            }
            MotionTarget::PacController => {
                let status = self.read_status()?;
                let mode = table::mode_of_status(status);
                let moving = !matches!(mode, Some(table::Mode::Home));
                Ok(State { moving, detail: table::operating_status_text(status).to_string() })
            }
            other => Err(not_here(other)),
        }
    }

    /// An axis: 0A93, polled to standstill (the stop of last resort the
    /// waits use). The controller: halt-all by the mode read now.
    fn halt(&mut self, at: MotionTarget, _attempts: u32) -> Result<Halt, FaceError> {
        match at {
            MotionTarget::PacAxis(axis) => match self.halt_axis(axis).result {
                Ok(at) => Ok(Halt::StoppedAt(at)),
                Err(e) => Err(FaceError::HaltFailed(e)),
            },
            MotionTarget::PacController => {
                let steps = Controller::halt_all(self);
                let failed: Vec<String> =
                    steps.iter().filter_map(|s| s.result.as_ref().err()).map(|e| e.to_string()).collect();
                if failed.is_empty() {
                    let said: Vec<&str> = steps.iter().filter_map(|s| s.result.as_deref().ok()).collect();
                    Ok(Halt::Steps(said.join("; ")))
                } else {
                    Err(FaceError::HaltFailed(failed.join("; ")))
                }
            }
            other => Err(not_here(other)),
        }
    }

    fn stop(&mut self, at: MotionTarget) -> Result<Halt, FaceError> {
        self.stop_with(at, StopHow::default())
    }

    /// `pac-stop` (0600) / `pac-stop-axis` (0A9A; answered at standstill:
    /// 0A93): in home position nothing moves and nothing is sent but the
    /// status read. The acknowledge, or the status read, stays the
    /// session's last (`Pac::last_ack`) for the command that reports it.
    fn stop_with(&mut self, at: MotionTarget, how: StopHow) -> Result<Halt, FaceError> {
        let (code, par1) = stop_command(at, how)?;
        Ok(match self.stop_by_hand(code, par1)? {
            StopOutcome::Sent => Halt::Steps(format!("{code:04X} sent")),
            StopOutcome::AtRest => Halt::AtRest,
        })
    }

    /// Halt-all by the mode read now (see `halt.rs`). Without `known`, the
    /// configured axes are read first (online mode stops each of them;
    /// unknown, the program stop 0600 goes out); with it, the axes the
    /// caller set on the controller are kept.
    fn halt_all(&mut self, known: Option<&[MotionTarget]>) -> Vec<HaltStep> {
        if known.is_none() {
            let axes = self.configured_axes().map(|n| (1..=n).collect()).unwrap_or_default();
            self.set_axes(axes);
        }
        Controller::halt_all(self)
            .into_iter()
            .map(|s| HaltStep {
                target: Some(step_target(s.target)),
                result: s.result.map(Halt::Steps).map_err(Into::into),
            })
            .collect()
    }
}

/// The command (and its PAR1) a person's stop of `at` sends: 0A93 (answered
/// at standstill) or 0A9A for an axis, the program stop 0600 for the
/// controller. What `pac-stop` reports it sent comes from here too.
pub fn stop_command(at: MotionTarget, how: StopHow) -> Result<(u16, i64), FaceError> {
    if how.manner != Manner::Default || how.on_sync {
        return Err(FaceError::Unsupported(format!("the PA-CONTROL has no {how}")));
    }
    Ok(match at {
        MotionTarget::PacAxis(axis) if how.at_standstill => (0x0A93, i64::from(axis)),
        MotionTarget::PacAxis(axis) => (0x0A9A, i64::from(axis)),
        MotionTarget::PacController if !how.at_standstill => (0x0600, 0),
        MotionTarget::PacController => {
            return Err(FaceError::Unsupported("the PA-CONTROL's program stop is answered at once".into()))
        }
        other => return Err(not_here(other)),
    })
}

/// How a waited move is followed: the poll interval and the longest wait.
#[derive(Debug, Clone, Copy)]
pub struct Follow {
    pub poll: Duration,
    pub limit: Duration,
}

impl Controller {
    /// `pac-move --wait`: the move started under the face's [`Moving`]
    /// handle (armed before its frame leaves) and followed to its end.
    /// `started` sees the acknowledged start before the first look,
    /// `observe` each look (and returns `false` to give up). Every way out
    /// but arrival stops the axis: the wait's own errors after its 0A93,
    /// a panic (in `observe` too) through the handle's drop.
    pub fn move_waited(
        &mut self,
        (axis, pos, relative, check_area): (u8, f64, bool, bool),
        follow: Follow,
        started: &mut dyn FnMut(&MoveStart),
        observe: &mut dyn FnMut(&MoveProgress) -> bool,
    ) -> Result<(MoveStart, MoveProgress)> {
        let targets = vec![MotionTarget::PacAxis(axis)];
        let (moving, start) = self.start(targets, 1, |d| d.start_move_supervised(axis, pos, relative, check_area))?;
        started(&start);
        let end = moving.follow(|d| d.wait_move(axis, start.target, follow.poll, follow.limit, observe))?;
        Ok((start, end))
    }

    /// `pac-ref --wait`: the reference drive (0A84) run to its end under
    /// the face's [`Moving`] handle, armed before its frame leaves.
    pub fn reference_waited(
        &mut self,
        axis: u8,
        follow: Follow,
        observe: &mut dyn FnMut(&Progress) -> bool,
    ) -> Result<Done> {
        let moving = Moving::new(self, vec![MotionTarget::PacAxis(axis)], 1);
        moving.follow(|d| d.reference(axis, follow.poll, follow.limit, observe))
    }
}
