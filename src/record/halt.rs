//! When the motion a recording started is halted, and by which sequence.
//!
//! A recording that reached its `--count` or `--for` leaves a motion that
//! already ended alone, but halts one that still moves: nobody watches it
//! from then on. A recording that ended any other way halts the motion
//! whatever it does: a signal, an output that cannot be written, a panic
//! on another thread (all of which end it as [`End::Stopped`]) or a failed
//! read (the device's state is then unknown). The halt sequences are the
//! device layer's, the ones the supervised waits use.

use super::{End, RecordError, Sampler};
use crate::address::Address;
use crate::device::face::{Face, FaceError, Found, Halt, HaltStep, MotionTarget, State};
use crate::family::Family;

/// When the recorded motion is halted at the end of the recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HaltWhen {
    /// Only if the device still moves (or cannot be read).
    IfMoving,
    /// Whatever the device does.
    Always,
}

impl HaltWhen {
    /// How the recording ended decides: only the end it was asked for
    /// (`--count`, `--for`) may leave the device alone.
    pub fn after(ended: &Result<End, RecordError>) -> Self {
        match ended {
            Ok(End::Done) => Self::IfMoving,
            Ok(End::Stopped) | Err(_) => Self::Always,
        }
    }
}

/// A sampler whose device a recorded motion moves: the look at the device
/// and its halt, on the sampler's own link, both the device face's.
pub trait HaltMotion: Sampler {
    /// The face of the sampler's device.
    fn face(&mut self) -> &mut dyn Face;

    /// Whether the device at `at` still moves; `None` when that cannot be
    /// read (it is then halted).
    fn still_moving(&mut self, at: Address) -> Option<bool> {
        let t = MotionTarget::try_from(at).ok()?;
        self.face().state(t).ok().map(|s| s.moving)
    }

    /// The family's halt of `at`: what was done (`halted`), or the failure
    /// in capitals (`HALT FAILED: ...`). `attempts`: how often a halt whose
    /// acknowledge is lost is sent.
    fn halt(&mut self, at: Address, attempts: u32) -> Result<String, String> {
        let face = self.face();
        let Some(t) = MotionTarget::try_from(at).ok().filter(|t| t.family() == face.family()) else {
            return Err(foreign(at));
        };
        let failed = if t.family() == Family::PowerCube { "HALT FAILED" } else { "STOP FAILED" };
        match face.halt(t, attempts) {
            Ok(Halt::AtRest) => Ok("not running (it had come to rest)".into()),
            Ok(Halt::StoppedAt(position)) => Ok(format!("stopped at {position}")),
            Ok(Halt::FastStop { .. }) => Ok("fast stop sent".into()),
            Ok(_) => Ok("halted".into()),
            Err(e) => Err(format!("{failed}: {e}")),
        }
    }

    /// After the halt: what the family set up to supervise the motion is
    /// undone (a PowerCube's dead-man backstop); the failure, said.
    fn release(&mut self) -> Result<(), String> {
        Ok(())
    }
}

/// A recording as a device face: the sampler's own face, so that a
/// [`Moving`](crate::device::face::Moving) handle halts a recorded motion
/// while the sampling loop holds the sampler.
pub struct Recording<'a, S: HaltMotion> {
    sampler: &'a mut S,
    family: Family,
}

impl<'a, S: HaltMotion> Recording<'a, S> {
    pub fn new(sampler: &'a mut S) -> Self {
        let family = sampler.face().family();
        Self { sampler, family }
    }

    pub fn sampler(&mut self) -> &mut S {
        self.sampler
    }
}

impl<S: HaltMotion> Face for Recording<'_, S> {
    fn family(&self) -> Family {
        self.family
    }
    fn discover(&mut self, candidates: &[u8]) -> Result<Vec<Found>, FaceError> {
        self.sampler.face().discover(candidates)
    }
    fn identify(&mut self, at: MotionTarget) -> Result<String, FaceError> {
        self.sampler.face().identify(at)
    }
    fn state(&mut self, at: MotionTarget) -> Result<State, FaceError> {
        self.sampler.face().state(at)
    }
    fn halt(&mut self, at: MotionTarget, attempts: u32) -> Result<Halt, FaceError> {
        self.sampler.face().halt(at, attempts)
    }
    fn stop(&mut self, at: MotionTarget) -> Result<Halt, FaceError> {
        self.sampler.face().stop(at)
    }
    fn halt_all(&mut self, known: Option<&[MotionTarget]>) -> Vec<HaltStep> {
        self.sampler.face().halt_all(known)
    }
}

/// Halts the motion at `at` when `when` says so; what was done, `None` when
/// the device stood and was left alone.
pub fn halt_motion<S: HaltMotion + ?Sized>(
    s: &mut S,
    at: Address,
    when: HaltWhen,
    attempts: u32,
) -> Option<Result<String, String>> {
    if when == HaltWhen::IfMoving && s.still_moving(at) == Some(false) {
        return None;
    }
    Some(s.halt(at, attempts))
}

/// A motion address of another family than the sampler's: the binary
/// pairs them before the link opens, so this never holds a device.
fn foreign(at: Address) -> String {
    format!("HALT FAILED: {} is not a device of this recording", at.column())
}

#[cfg(test)]
mod tests;
