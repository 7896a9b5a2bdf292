//! The device face: what every family answers to, in the spirit of
//! probe-rs's probe drivers (one trait, one registry of families). Find
//! the devices, say what one is, read the state all families share, halt
//! and stop one, stop everything, and start a motion that returns a
//! [`Moving`] handle: the device is halted when the handle goes away
//! unless the motion completed or was handed over on purpose. The
//! per-family operations (moves with their limit checks, homing, modes,
//! configuration) stay beside it in the family's own module; the face is
//! what bench-wide code, waits, `batch`, `record` and the dashboard halt
//! through, so "halt what moved" is written once per family.

use std::ops::{Deref, DerefMut};
use std::panic::{self, AssertUnwindSafe};

use crate::family::Family;

pub use super::registry::error::FaceError;
pub use super::registry::target::MotionTarget;

/// A device a face found, and what it says of itself in a few words.
#[derive(Debug, Clone, PartialEq)]
pub struct Found {
    pub target: MotionTarget,
    pub detail: String,
}

/// The state every family can report of one device.
#[derive(Debug, Clone, PartialEq)]
pub struct State {
    /// Whether it may be moving (a command still running counts).
    pub moving: bool,
    /// The family's own words for it (a state word, an axis status).
    pub detail: String,
}

/// What a halt or a stop did.
#[derive(Debug, Clone, PartialEq)]
pub enum Halt {
    /// A broadcast went out: every device of the bus stops, none answers.
    Broadcast,
    /// The device acknowledged the halt.
    Halted,
    /// Stopped and polled to standstill at this position.
    StoppedAt(f64),
    /// A fast stop was sent; `confirmed` when the node confirmed it.
    FastStop { confirmed: bool },
    /// Nothing moved: the device was at rest, the state asked for.
    AtRest,
    /// The family's own sequence ran; what it said, step by step.
    Steps(String),
}

/// How hard a person's stop is made. `Default` is the family's own stop
/// (its face's [`Face::stop`]); the others are manners some families offer
/// and the rest refuse, before sending.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Manner {
    #[default]
    Default,
    /// Stop as fast as the device can.
    Fast,
    /// Decelerate on the set ramp, then stop.
    Decelerate,
    /// Decelerate to the minimum speed, then stop.
    DecelerateToMinimum,
}

/// A person's stop as the command line asked for it, in words every family
/// reads the same way ([`Face::stop_with`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StopHow {
    pub manner: Manner,
    /// Stop on the next SYNC instead of now.
    pub on_sync: bool,
    /// Answer only once the device stands still.
    pub at_standstill: bool,
}

impl std::fmt::Display for StopHow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self.manner {
            Manner::Default => "stop",
            Manner::Fast => "fast stop",
            Manner::Decelerate => "decelerating stop",
            Manner::DecelerateToMinimum => "stop through the minimum speed",
        })?;
        if self.on_sync {
            f.write_str(" on the next SYNC")?;
        }
        if self.at_standstill {
            f.write_str(" answered at standstill")?;
        }
        Ok(())
    }
}

/// One step of a halt of everything, and how it went. `target: None`:
/// the whole family on the link (a broadcast, or a probe that failed).
#[derive(Debug)]
pub struct HaltStep {
    pub target: Option<MotionTarget>,
    pub result: Result<Halt, FaceError>,
}

/// The face of one family on one link (for the Cdios: of one node).
pub trait Face {
    fn family(&self) -> Family;

    /// The devices that answer. `candidates`: the ids to probe where the
    /// family probes a range of ids (empty: its whole range).
    fn discover(&mut self, candidates: &[u8]) -> Result<Vec<Found>, FaceError>;

    /// What the device says it is (version, type, operating status).
    fn identify(&mut self, at: MotionTarget) -> Result<String, FaceError>;

    /// Whether it moves, read now.
    fn state(&mut self, at: MotionTarget) -> Result<State, FaceError>;

    /// The halt of a way out of a motion: the family's fastest stop, sent
    /// again up to `attempts` times when its acknowledge is lost (stopping
    /// twice is harmless; a motion is never resent).
    fn halt(&mut self, at: MotionTarget, attempts: u32) -> Result<Halt, FaceError>;

    /// A person's stop: idempotent, a device at rest is [`Halt::AtRest`].
    fn stop(&mut self, at: MotionTarget) -> Result<Halt, FaceError>;

    /// [`Face::stop`] made the way `how` says. A family that has no such
    /// manner refuses it before sending anything: a stop that silently
    /// became another could surprise the person who chose it.
    fn stop_with(&mut self, at: MotionTarget, how: StopHow) -> Result<Halt, FaceError> {
        if how == StopHow::default() {
            return self.stop(at);
        }
        Err(FaceError::Unsupported(format!("the {} has no {how}", self.family().display_name())))
    }

    /// Stops every device of the family on the link, each step tried
    /// whatever the others did. `known`: the devices the caller knows
    /// already (the dashboard's); `None`: the face finds them first.
    fn halt_all(&mut self, known: Option<&[MotionTarget]>) -> Vec<HaltStep>;

    /// Starts a motion of `targets` with `send`: the [`Moving`] handle is
    /// armed before the first motion byte leaves, so a panic inside `send`
    /// halts them. When `send` fails, the family's start has handled it
    /// (a motion that may have gone out is halted there, a refused one
    /// sent nothing) and the handle is released without sending.
    fn start<R, E>(
        &mut self,
        targets: Vec<MotionTarget>,
        attempts: u32,
        send: impl FnOnce(&mut Self) -> Result<R, E>,
    ) -> Result<(Moving<'_, Self>, R), E>
    where
        Self: Sized,
    {
        let mut moving = Moving::new(self, targets, attempts);
        match send(&mut moving) {
            Ok(r) => Ok((moving, r)),
            Err(e) => {
                moving.release();
                Err(e)
            }
        }
    }
}

/// A motion in progress on a face: the device is halted when this handle
/// is dropped, whatever the way out (an error, `?`, a panic's unwind),
/// unless it was marked [`Moving::completed`] (a known standstill) or
/// [`Moving::release`]d (the motion is left running on purpose, or the
/// family's wait halted it already and said so).
pub struct Moving<'a, F: Face + ?Sized> {
    dev: Dev<'a, F>,
    targets: Vec<MotionTarget>,
    attempts: u32,
    armed: bool,
}

impl<'a, F: Face + ?Sized> Moving<'a, F> {
    /// Armed from now on: create it before the first motion byte leaves.
    pub fn new(dev: &'a mut F, targets: Vec<MotionTarget>, attempts: u32) -> Self {
        Self { dev: Dev::Borrowed(dev), targets, attempts: attempts.max(1), armed: true }
    }

    /// A handle that owns its face: for a motion that outlives the code
    /// that started it (a `batch` line without `--wait`), kept by whoever
    /// answers for it until the end.
    pub fn owning(dev: Box<F>, targets: Vec<MotionTarget>, attempts: u32) -> Self {
        Self { dev: Dev::Owned(dev), targets, attempts: attempts.max(1), armed: true }
    }

    /// Another device of this face set moving: halted with the others,
    /// once however often it is added.
    pub fn add(&mut self, target: MotionTarget) {
        if !self.targets.contains(&target) {
            self.targets.push(target);
        }
    }

    /// The devices this handle halts, in the order they were added.
    pub fn targets(&self) -> &[MotionTarget] {
        &self.targets
    }

    /// Halts one of its devices now and forgets it (`None`: not one of
    /// its devices), so that several handles can halt in one given order.
    pub fn halt_one(&mut self, target: MotionTarget) -> Option<Result<Halt, FaceError>> {
        let at = self.targets.iter().position(|t| *t == target)?;
        self.targets.remove(at);
        Some(self.dev.halt(target, self.attempts))
    }

    /// The motion ended at a known standstill: nothing to halt.
    pub fn completed(mut self) {
        self.armed = false;
    }

    /// The caller takes the motion over: it stays as it is.
    pub fn release(mut self) {
        self.armed = false;
    }

    /// Halts every target now, each whatever the others did.
    pub fn halt(mut self) -> Vec<(MotionTarget, Result<Halt, FaceError>)> {
        self.armed = false;
        halt_each(&mut *self.dev, &self.targets, self.attempts)
    }

    /// Runs the family's wait: its arrival completes the motion; its error
    /// comes after the family's wait halted the device itself (every
    /// family's wait does, and says so in the error), so nothing is sent
    /// twice; a panic inside it unwinds through this handle, which halts.
    pub fn follow<R, E>(mut self, wait: impl FnOnce(&mut F) -> Result<R, E>) -> Result<R, E> {
        let r = wait(&mut *self.dev);
        self.armed = false;
        r
    }
}

/// The face a handle halts through: borrowed from the code that waits on
/// the motion, or owned by the handle when the motion outlives that code.
enum Dev<'a, F: ?Sized> {
    Borrowed(&'a mut F),
    Owned(Box<F>),
}

impl<F: ?Sized> Deref for Dev<'_, F> {
    type Target = F;
    fn deref(&self) -> &F {
        match self {
            Dev::Borrowed(d) => d,
            Dev::Owned(d) => d,
        }
    }
}

impl<F: ?Sized> DerefMut for Dev<'_, F> {
    fn deref_mut(&mut self) -> &mut F {
        match self {
            Dev::Borrowed(d) => d,
            Dev::Owned(d) => d,
        }
    }
}

fn halt_each<F: Face + ?Sized>(
    dev: &mut F,
    targets: &[MotionTarget],
    attempts: u32,
) -> Vec<(MotionTarget, Result<Halt, FaceError>)> {
    targets.iter().map(|t| (*t, dev.halt(*t, attempts))).collect()
}

impl<F: Face + ?Sized> Deref for Moving<'_, F> {
    type Target = F;
    fn deref(&self) -> &F {
        &self.dev
    }
}

impl<F: Face + ?Sized> DerefMut for Moving<'_, F> {
    fn deref_mut(&mut self) -> &mut F {
        &mut self.dev
    }
}

impl<F: Face + ?Sized> Drop for Moving<'_, F> {
    fn drop(&mut self) {
        if !self.armed {
            return;
        }
        // A halt that panics in turn must not abort the process mid-unwind
        // before the other targets are tried.
        for t in self.targets.clone() {
            let dev = &mut *self.dev;
            let _ = panic::catch_unwind(AssertUnwindSafe(|| dev.halt(t, self.attempts)));
        }
    }
}

#[cfg(test)]
mod tests;
