//! Moves, reference drives and stops.
//!
//! A wait that is given up or loses track of a moving axis stops the axis
//! before it reports: nothing is left moving on our behalf.

use std::fmt;
use std::time::Duration;

use crate::device::supervisor;
use crate::proto::pac::session::Step;
use crate::proto::pac::{Ack, Command, Par2};
use crate::session::pac::{Done, PacError, Progress};
use crate::session::SessionError;

use super::{check_target, stoppable_axis, Controller, Error, Result};

/// How stopping an axis went: where it stands, or why the stop failed.
#[derive(Debug, Clone, PartialEq)]
pub struct Halted {
    pub axis: u8,
    pub result: std::result::Result<f64, String>,
}

impl fmt::Display for Halted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.result {
            Ok(p) => write!(f, "axis {} stopped at {p}", self.axis),
            Err(e) => write!(f, "STOP OF AXIS {} FAILED: {e}", self.axis),
        }
    }
}

/// A move the controller accepted (0A94 / 0A95 answered).
#[derive(Debug, Clone, Copy)]
pub struct MoveStart {
    pub code: u16,
    pub target: f64,
    /// The acknowledge date: where the axis stood.
    pub start_position: f64,
    pub ack: Ack,
}

/// One look at a moving axis (1910 and 190C), or where it ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveProgress {
    pub position: f64,
    pub status: u64,
    pub elapsed: Duration,
}

impl Controller {
    /// Starts a move to `pos` (or by `pos`, relative) with 0A94 / 0A95. In
    /// this order, so that nothing is read from a controller that could not
    /// move anyway: mode and ranges, the target (190C for a relative move),
    /// the traverse area unless `check_area` is false (the controller then
    /// checks, QUIT 0x41), then the command.
    pub fn start_move(&mut self, axis: u8, pos: f64, relative: bool, check_area: bool) -> Result<MoveStart> {
        self.start_move_gated(axis, pos, relative, check_area, &|| false)
    }

    /// [`Self::start_move`], sent only if `stop` is still false once the
    /// checks (which read the controller) are done.
    fn start_move_gated(
        &mut self,
        axis: u8,
        pos: f64,
        relative: bool,
        check_area: bool,
        stop: &dyn Fn() -> bool,
    ) -> Result<MoveStart> {
        let code = if relative { 0x0A95 } else { 0x0A94 };
        self.build(code, axis.into(), Some(pos))?;
        let target = if relative { self.read_f64(0x190C, axis.into())? + pos } else { pos };
        let area = if check_area { Some(self.traverse_area(axis)?) } else { None };
        check_target(axis, target, area)?;
        if stop() {
            return Err(Error::InterruptedBefore(format!("the move {code:04X} of axis {axis}")));
        }
        let ack = self.send(code, axis.into(), Some(pos))?.ack;
        Ok(MoveStart { code, target, start_position: ack.q_par.as_f64(), ack })
    }

    /// [`Self::start_move`] under supervision: a move command that went out
    /// without an acknowledge (lost, late or garbled) may still have been
    /// taken, so the axis is stopped before the error is returned. A refusal
    /// (QUIT) and every check before sending need no stop.
    pub fn start_move_supervised(&mut self, axis: u8, pos: f64, relative: bool, check_area: bool) -> Result<MoveStart> {
        let code = if relative { 0x0A95 } else { 0x0A94 };
        let target = if relative { None } else { Some(pos) };
        match self.start_move_gated(axis, pos, relative, check_area, &supervisor::stop_requested) {
            Err(e @ Error::Session(SessionError::Timeout { .. } | SessionError::Malformed { .. })) => {
                // A read before the move may be what timed out: stopping an
                // axis that never moved is harmless.
                let halted = self.halt_axis(axis);
                let what = target.map_or_else(|| format!("{code:04X}"), |t| format!("{code:04X} to {t}"));
                let context =
                    format!("the move {what} was not acknowledged; axis {axis} may have been moving ({halted})");
                Err(Error::Stopped { context, source: Box::new(e) })
            }
            other => other,
        }
    }

    /// Follows a started move every `poll` (1910, 190C) until the axis stands
    /// (status 0), faults, or `limit` passes. `observe` sees each look and
    /// returns `false` to give up. Every way out but arrival stops the axis.
    pub fn wait_move(
        &mut self,
        axis: u8,
        target: f64,
        poll: Duration,
        limit: Duration,
        observe: &mut dyn FnMut(&MoveProgress) -> bool,
    ) -> Result<MoveProgress> {
        let clock = std::sync::Arc::clone(self.pac.clock());
        let t0 = clock.now();
        let mut seen_moving = false;
        loop {
            let polled =
                self.read_i64(0x1910, axis.into()).and_then(|s| Ok((s as u64, self.read_f64(0x190C, axis.into())?)));
            let (status, position) = match polled {
                Ok(v) => v,
                Err(e) => {
                    let halted = self.halt_axis(axis);
                    let context = format!("lost track of axis {axis} during the move ({halted})");
                    return Err(Error::Stopped { context, source: Box::new(e) });
                }
            };
            let now = MoveProgress { position, status, elapsed: clock.now() - t0 };
            if !observe(&now) {
                return Err(Error::Interrupted(self.halt_axis(axis)));
            }
            match status {
                1 => seen_moving = true,
                // A controller may report "in position" for a moment before
                // the move shows as started; a short grace covers that.
                0 if seen_moving
                    || (position - target).abs() <= 1e-6 * target.abs().max(1.0)
                    || now.elapsed >= poll * 4 =>
                {
                    return Ok(now)
                }
                0 => {}
                other => {
                    // Reading the error number makes it show in a trace; the
                    // status already says the move failed.
                    let _ = self.pac.transact(&Command::new(0x1909, 0, Par2::Int(0)));
                    return Err(Error::MoveFailed { axis, position, status: other, target });
                }
            }
            if now.elapsed >= limit {
                let stopped = Some(self.halt_axis(axis).to_string());
                return Err(Error::Session(SessionError::wait_expired(
                    format!("PA-CONTROL axis {axis}"),
                    "moving",
                    limit,
                    stopped,
                )));
            }
            clock.sleep_or_wake(poll);
        }
    }

    /// Starts the reference drive (0A84) and returns its first acknowledge
    /// and whether it is done. It has no start-and-return form: until it
    /// ends the controller takes only polls.
    pub fn start_reference(&mut self, axis: u8) -> Result<(Ack, bool)> {
        let cmd = self.build(0x0A84, axis.into(), None)?;
        Ok(match self.pac.start(&cmd)? {
            Step::Done(a) => (a, true),
            Step::NeedPoll { last, .. } => (last, false),
        })
    }

    /// Runs the reference drive to its end, polled every `poll` for at most
    /// `limit`; `observe` sees each acknowledge and returns `false` to give
    /// up (the axis is then stopped).
    pub fn reference(
        &mut self,
        axis: u8,
        poll: Duration,
        limit: Duration,
        observe: &mut dyn FnMut(&Progress) -> bool,
    ) -> Result<Done> {
        let cmd = self.build(0x0A84, axis.into(), None)?;
        self.pac.set_poll_interval(poll);
        self.pac.set_busy_timeout(limit);
        if supervisor::stop_requested() {
            return Err(Error::InterruptedBefore(format!("the reference drive 0A84 of axis {axis}")));
        }
        self.follow(&cmd, observe)
    }

    /// Sends an already built command (or one the table does not know) and
    /// polls it to its end. A start-and-wait motion command whose wait is
    /// given up, whose acknowledge is lost, or whose polls fail while it
    /// runs, has its axis stopped.
    pub fn follow(&mut self, cmd: &Command, observe: &mut dyn FnMut(&Progress) -> bool) -> Result<Done> {
        let axis = stoppable_axis(cmd);
        match (self.pac.transact_with(cmd, observe), axis) {
            (Ok(done), _) => Ok(done),
            (Err(PacError::Abandoned { .. }), Some(axis)) => Err(Error::Interrupted(self.halt_axis(axis))),
            // Still running when the wait ran out: stopped, and said so in
            // the timeout's own words.
            (Err(PacError::Session(SessionError::WaitExpired(mut expired))), Some(axis)) => {
                expired.stopped = Some(self.halt_axis(axis).to_string());
                Err(Error::Session(SessionError::WaitExpired(expired)))
            }
            // Running (BE = 0 seen), or its acknowledge lost or garbled: the
            // axis may be moving. A refusal (QUIT) moved nothing.
            (Err(e @ PacError::Session(_)), Some(axis))
                if self.pac.busy_command().is_some()
                    || matches!(
                        e,
                        PacError::Session(SessionError::Timeout { .. } | SessionError::Malformed { .. })
                    ) =>
            {
                let context = self.halt_axis(axis).to_string();
                Err(Error::Stopped { context, source: Box::new(e.into()) })
            }
            (Err(e), _) => Err(e.into()),
        }
    }

    /// Stops an axis now (0A93, polled to standstill), giving up an
    /// unfinished command first; sent again when no acknowledge comes
    /// (stopping twice is harmless). Its answers are awaited patiently
    /// ([`Pac::patiently`](crate::session::pac::Pac::patiently)): on a slow
    /// line a late one is taken, not given up on. Not validated: 0A93 is
    /// the stop of last resort and the controller's QUIT says if it was
    /// pointless.
    pub fn halt_axis(&mut self, axis: u8) -> Halted {
        let stop = Command::new(0x0A93, axis.into(), Par2::Float(0.0));
        let mut last = String::new();
        for _ in 0..3 {
            match self.pac.patiently(|pac| pac.abandon_and_stop(&stop)) {
                Ok(done) => return Halted { axis, result: Ok(done.ack.q_par.as_f64()) },
                Err(e @ PacError::Session(SessionError::Timeout { .. } | SessionError::Malformed { .. })) => {
                    last = e.to_string()
                }
                Err(e) => return Halted { axis, result: Err(e.to_string()) },
            }
        }
        Halted { axis, result: Err(last) }
    }

    /// Gives up the unfinished command, if any, and stops the axis it
    /// names (0A93). Returns what was given up and how the stop went.
    pub fn give_up_busy(&mut self) -> Option<(Command, Result<Done>)> {
        let running = *self.pac.busy_command()?;
        let stop = Command::new(0x0A93, running.par1, Par2::Float(0.0));
        Some((running, self.pac.abandon_and_stop(&stop).map_err(Error::from)))
    }

    /// A person's stop of one axis: an unfinished command is given up and
    /// its axis stopped (0A93); the axis itself, if another, gets 0A9A
    /// (stop without waiting, online mode). Says what was done.
    pub fn stop_axis(&mut self, axis: u8) -> Result<String> {
        let mut note = None;
        if let Some((running, r)) = self.give_up_busy() {
            r?;
            if running.par1 == i64::from(axis) {
                return Ok("running command given up, axis stopped (0A93)".into());
            }
            note = Some(format!("{:04X} given up, axis {} stopped (0A93); ", running.code, running.par1));
        }
        let done = self.send(0x0A9A, axis.into(), None)?;
        Ok(format!("{}0A9A done (status {})", note.unwrap_or_default(), done.ack.status))
    }
}
