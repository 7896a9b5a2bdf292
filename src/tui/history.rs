//! The motion of each device over the last [`WINDOW`]: what the chart draws
//! and the SVG snapshot plots. Fed from the polls the workers already make
//! (no extra bus traffic), kept in a ring that never holds more than
//! [`CAPACITY`] samples, however long the dashboard runs.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::source::Snapshot;
use super::worker::MAX_RATE;

/// How far back the chart looks.
pub const WINDOW: Duration = Duration::from_secs(30);

/// The most samples a device keeps: the window at the fastest poll rate,
/// and one more for the line into the window's left edge.
pub const CAPACITY: usize = (WINDOW.as_secs() as usize) * (MAX_RATE as usize) + 1;

/// One poll's motion values, in the device's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub at: Instant,
    pub pos: f64,
    pub vel: f64,
    /// Motor current, for the families that report it (PowerCube ActCur).
    pub cur: Option<f64>,
}

pub use super::ui::pane::Units;

/// The motion values of a snapshot and their units; `None` for a device
/// that does not move (the PA-CONTROL controller line).
pub fn motion(snap: &Snapshot) -> Option<(Units, [f64; 2], Option<f64>)> {
    snap.motion()
}

/// A bounded ring of samples, oldest first.
#[derive(Debug, Clone, Default)]
pub struct History {
    samples: VecDeque<Sample>,
}

/// One quantity over the window, as the chart and the snapshot draw it:
/// x in seconds before now (−30 … 0), y in `unit`.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    pub name: &'static str,
    pub unit: &'static str,
    pub points: Vec<(f64, f64)>,
}

impl History {
    /// Adds a poll's values; drops what left the window and, whatever the
    /// poll rate, anything beyond [`CAPACITY`].
    pub fn push(&mut self, snap: &Snapshot, at: Instant) {
        let Some((_, [pos, vel], cur)) = motion(snap) else { return };
        // Polls arrive in order per device; a report from before the newest
        // sample (a clock step) would fold the chart back on itself.
        if self.samples.back().is_some_and(|s| s.at > at) {
            return;
        }
        self.samples.push_back(Sample { at, pos, vel, cur });
        self.forget_before(at);
        while self.samples.len() > CAPACITY {
            self.samples.pop_front();
        }
    }

    /// Drops the samples older than the window before `now`, keeping the
    /// last one before it so that the line starts at the left edge.
    fn forget_before(&mut self, now: Instant) {
        while self.samples.len() > 1 && now.saturating_duration_since(self.samples[1].at) > WINDOW {
            self.samples.pop_front();
        }
    }

    pub fn len(&self) -> usize {
        self.samples.len()
    }

    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    pub fn samples(&self) -> impl Iterator<Item = &Sample> {
        self.samples.iter()
    }

    /// Position, velocity and (where the device has it) current over the
    /// window before `now`, with `units`.
    pub fn traces(&self, units: Units, now: Instant) -> Vec<Trace> {
        let x = |s: &Sample| -(now.saturating_duration_since(s.at).as_secs_f64());
        let shown: Vec<&Sample> = self
            .samples
            .iter()
            .filter(|s| now.saturating_duration_since(s.at) <= WINDOW + Duration::from_secs(1))
            .collect();
        let mut out = vec![
            Trace { name: "position", unit: units.pos, points: shown.iter().map(|s| (x(s), s.pos)).collect() },
            Trace { name: "velocity", unit: units.vel, points: shown.iter().map(|s| (x(s), s.vel)).collect() },
        ];
        if let Some(unit) = units.cur {
            let points = shown.iter().filter_map(|s| s.cur.map(|c| (x(s), c))).collect();
            out.push(Trace { name: "current", unit, points });
        }
        out
    }
}

/// At most two points per column of `columns` across the window (the
/// lowest and the highest of the samples that fall into it, in time order):
/// the chart's cost depends on its width, not on the poll rate, and a short
/// peak still shows.
pub fn thin(points: &[(f64, f64)], columns: usize) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    if points.len() <= 2 * columns {
        return points.to_vec();
    }
    let span = WINDOW.as_secs_f64();
    let column = |x: f64| (((x + span) / span * columns as f64).floor().max(0.0) as usize).min(columns - 1);
    let mut out = Vec::with_capacity(2 * columns);
    let mut i = 0;
    while i < points.len() {
        let c = column(points[i].0);
        let mut j = i;
        let (mut lo, mut hi) = (i, i);
        while j < points.len() && column(points[j].0) == c {
            if points[j].1 < points[lo].1 {
                lo = j;
            }
            if points[j].1 > points[hi].1 {
                hi = j;
            }
            j += 1;
        }
        out.push(points[lo.min(hi)]);
        if lo != hi {
            out.push(points[lo.max(hi)]);
        }
        i = j;
    }
    out
}
