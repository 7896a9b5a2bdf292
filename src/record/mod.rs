//! Sampling chosen values of the devices of one link, as fast as the link
//! allows or at a set rate, with a monotonic time stamp per sample: the
//! library side of `axisctl record`.
//!
//! One [`Sampler`] per family reads all of its channels in one exchange per
//! sample, pipelined where the link allows it (a PowerCube burst over every
//! module and parameter on CAN, the Cdios node's burst per module), the way
//! the dashboard's worker polls. PA-CONTROL's half-duplex line takes one
//! request at a time. The sampler owns the device handle, so a motion
//! started through [`crate::device`] goes out on the same open link.

pub mod cdios;
mod halt;
pub mod pac;
pub mod powercube;
mod several;

use std::time::{Duration, Instant};

use crate::address::Address;
use crate::clock::Clock;
use crate::device::face::FaceError;

pub use halt::{halt_motion, HaltMotion, HaltWhen, Recording};
pub use several::Several;

/// The value among `all` that `text` names, case aside: the one parse of
/// each family's value names.
fn by_name<T: Copy>(all: &[T], name: fn(T) -> &'static str, text: &str) -> Option<T> {
    all.iter().copied().find(|v| name(*v).eq_ignore_ascii_case(text))
}

/// One recorded value: a device, the value's name and its unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Channel {
    pub address: Address,
    /// The name as the command line takes it (`ActPos`, `position`).
    pub name: String,
    /// The manual's unit, `""` when it gives none.
    pub unit: String,
}

/// The device layer's error as the device face carries it (the family's
/// own typed error kept whole), boxed: a sample's result stays small. Each
/// sampler's module converts its family's error.
#[derive(Debug, thiserror::Error)]
#[error(transparent)]
pub struct RecordError(Box<FaceError>);

impl RecordError {
    /// The face's error, with the family's own inside (its exit-code
    /// class, its refusal).
    pub fn into_face(self) -> FaceError {
        *self.0
    }
}

impl From<FaceError> for RecordError {
    fn from(e: FaceError) -> Self {
        Self(Box::new(e))
    }
}

/// The devices of one family on one link, read together once per sample.
pub trait Sampler {
    /// What each sample holds, in order.
    fn channels(&self) -> &[Channel];
    /// One value per channel; NaN for a value the device does not have.
    fn sample(&mut self) -> Result<Vec<f64>, RecordError>;
    /// Samples follow each other back to back from now on (no rate): the
    /// sampler may send the next sample's requests before the answers of
    /// the current one are in, so that the link never waits for the host.
    fn back_to_back(&mut self) {}
    /// When the devices read the values of the sample [`Self::sample`]
    /// just returned, if the sampler knows better than "when it was called"
    /// (requests sent ahead of the call).
    fn read_at(&self) -> Option<Instant> {
        None
    }
    /// Waits `d` between two samples (woken early by a caught signal); a
    /// sampler whose link must stay busy meanwhile (a PowerCube watchdog
    /// kept alive for a recorded motion) does that here.
    fn pause(&mut self, clock: &dyn Clock, d: Duration) {
        clock.sleep_or_wake(d);
    }
    /// The recording is over: requests sent ahead will not be collected.
    /// Nothing is waited for (a halt may have to go out next).
    fn finish(&mut self) {}
}

/// When a recording ends by itself (it also ends when `stop` says so).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Until {
    Count(u64),
    Elapsed(Duration),
    Stopped,
}

/// One sample: seconds since the recording started (monotonic), the index
/// and the values in channel order.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    pub t: f64,
    pub seq: u64,
    pub values: Vec<f64>,
}

/// Why a recording ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    /// `--count` or `--for` reached.
    Done,
    /// `stop` asked for it (a signal, a failed output).
    Stopped,
}

/// How samples follow each other.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pace {
    /// Sample n is taken at n x the period from the start (a late one is
    /// taken at once, never twice) and stamped when its requests leave.
    Every(Duration),
    /// Back to back: the sampler may keep the next sample's requests in
    /// flight while the current one is read ([`Sampler::back_to_back`]); a
    /// sample is then stamped when the devices answered it
    /// ([`Sampler::read_at`]), since its requests left while the bus still
    /// carried the sample before. A sample is never taken sooner than
    /// `min_gap` after the one before (zero: as fast as the link answers).
    BackToBack { min_gap: Duration },
}

impl Pace {
    /// `--rate`'s period, or back to back as fast as the link answers.
    pub fn from_period(period: Option<Duration>) -> Self {
        period.map_or(Pace::BackToBack { min_gap: Duration::ZERO }, Pace::Every)
    }
}

/// Samples until `until` or `stop`, and hands each sample to `sink` as
/// soon as it is read, with the sampler (a motion is started from there, on
/// the same link, between two samples), at the given [`Pace`]. Stamps never
/// go back.
pub fn record<S: Sampler + ?Sized>(
    sampler: &mut S,
    clock: &dyn Clock,
    pace: Pace,
    until: Until,
    stop: &dyn Fn() -> bool,
    sink: &mut dyn FnMut(&Sample, &mut S) -> Result<(), RecordError>,
) -> Result<End, RecordError> {
    if let Pace::BackToBack { .. } = pace {
        sampler.back_to_back();
    }
    let ended = samples(sampler, clock, pace, until, stop, sink);
    sampler.finish();
    ended
}

fn samples<S: Sampler + ?Sized>(
    sampler: &mut S,
    clock: &dyn Clock,
    pace: Pace,
    until: Until,
    stop: &dyn Fn() -> bool,
    sink: &mut dyn FnMut(&Sample, &mut S) -> Result<(), RecordError>,
) -> Result<End, RecordError> {
    let start = clock.now();
    let mut last_called: Option<Instant> = None;
    let mut seq = 0u64;
    let mut last_t = 0.0f64;
    loop {
        if stop() {
            return Ok(End::Stopped);
        }
        match until {
            Until::Count(n) if seq >= n => return Ok(End::Done),
            Until::Elapsed(d) if clock.now().duration_since(start) >= d => return Ok(End::Done),
            _ => {}
        }
        let due = match pace {
            Pace::Every(p) => Some(start + p.mul_f64(seq as f64)),
            Pace::BackToBack { min_gap } => last_called.map(|t| t + min_gap),
        };
        if let Some(wait) = due.and_then(|due| due.checked_duration_since(clock.now())).filter(|w| !w.is_zero()) {
            // Woken early by a signal: the loop checks `stop` again.
            sampler.pause(clock, wait);
            continue;
        }
        let called = clock.now();
        last_called = Some(called);
        let values = sampler.sample()?;
        let at = sampler.read_at().unwrap_or(called);
        let t = at.saturating_duration_since(start).as_secs_f64().max(last_t);
        last_t = t;
        sink(&Sample { t, seq, values }, sampler)?;
        seq += 1;
    }
}

#[cfg(test)]
mod tests;
