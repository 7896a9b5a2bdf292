//! Step-response figures of one recorded motion: rise time (10-90 %),
//! overshoot, settling time to a band, steady-state error, peak, time to
//! reach the band. Pure: samples in, figures out.
//!
//! The step is taken from the first sample to `target`, so a move that
//! starts anywhere is measured in fractions of its own step. Crossings are
//! interpolated linearly between the two samples around them: at the rates
//! a bus allows (a few ms a sample) the figures would otherwise be
//! quantised to the sampling period.

use serde::Serialize;

/// Why no figures can be given for a recording.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FigureError {
    #[error("no samples to measure")]
    Empty,
    #[error("{times} time stamps for {values} values")]
    Lengths { times: usize, values: usize },
    #[error("sample {index} is not a finite number")]
    NotFinite { index: usize },
    #[error("time goes back at sample {index}")]
    TimeBack { index: usize },
    #[error("the step is zero: the target is where the motion started")]
    NoStep,
    #[error("the settling band {0} is not a fraction between 0 and 1")]
    Band(f64),
}

/// The figures of one step; times in seconds from the first sample,
/// values in the recording's unit. `None`: the response never got there.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Figures {
    /// From 10 % to 90 % of the step.
    pub rise_time: Option<f64>,
    /// How far past the target the response went, in % of the step (0 when
    /// it never passed it).
    pub overshoot_percent: f64,
    /// From the start to the last entry into the band (`None`: it ends
    /// outside the band).
    pub settling_time: Option<f64>,
    /// The end value minus the target (the mean of the last tenth of the
    /// recording's time, so noise averages out).
    pub steady_state_error: f64,
    /// The value farthest in the step's direction, and when.
    pub peak: f64,
    pub time_to_peak: f64,
    /// The first entry into the band.
    pub time_to_reach: Option<f64>,
}

/// The figures of the response `(t, y)` to a step from `y[0]` to
/// `target`; `band` is the settling band as a fraction of the step
/// (0.02 for 2 %). Time must not go back (equal stamps are allowed: two
/// samples answered by one burst).
pub fn step(t: &[f64], y: &[f64], target: f64, band: f64) -> Result<Figures, FigureError> {
    check(t, y)?;
    if !(band.is_finite() && band > 0.0 && band < 1.0) {
        return Err(FigureError::Band(band));
    }
    if !target.is_finite() {
        return Err(FigureError::NotFinite { index: 0 });
    }
    let (t0, y0) = (t[0], y[0]);
    let size = target - y0;
    if size == 0.0 || !size.is_finite() || size.abs() <= f64::EPSILON * target.abs().max(y0.abs()) {
        return Err(FigureError::NoStep);
    }
    // The response as a fraction of the step: 0 at the start, 1 at the target.
    let x: Vec<f64> = y.iter().map(|v| (v - y0) / size).collect();
    let at = |level: f64| first_crossing(t, &x, level).map(|c| c - t0);
    let rise_time = match (at(0.1), at(0.9)) {
        (Some(a), Some(b)) => Some(b - a),
        _ => None,
    };
    let (peak_i, peak_x) =
        x.iter().copied().enumerate().fold(
            (0, f64::NEG_INFINITY),
            |best, (i, v)| {
                if v > best.1 {
                    (i, v)
                } else {
                    best
                }
            },
        );
    let inside = |v: f64| (v - 1.0).abs() <= band;
    let time_to_reach = x.iter().position(|v| inside(*v)).map(|i| entry(t, &x, i, band) - t0);
    let settling_time = match x.iter().rposition(|v| !inside(*v)) {
        None => Some(0.0),
        Some(last) if last + 1 == x.len() => None,
        Some(last) => Some(entry(t, &x, last + 1, band) - t0),
    };
    Ok(Figures {
        rise_time,
        overshoot_percent: ((peak_x - 1.0) * 100.0).max(0.0),
        settling_time,
        steady_state_error: tail_mean(t, y) - target,
        peak: y[peak_i],
        time_to_peak: t[peak_i] - t0,
        time_to_reach,
    })
}

/// The largest magnitude of a signal (a current, a speed) and when.
pub fn peak_abs(t: &[f64], y: &[f64]) -> Result<(f64, f64), FigureError> {
    check(t, y)?;
    let i = (0..y.len()).fold(0, |best, i| if y[i].abs() > y[best].abs() { i } else { best });
    Ok((y[i].abs(), t[i] - t[0]))
}

fn check(t: &[f64], y: &[f64]) -> Result<(), FigureError> {
    if t.len() != y.len() {
        return Err(FigureError::Lengths { times: t.len(), values: y.len() });
    }
    if t.is_empty() {
        return Err(FigureError::Empty);
    }
    if let Some(index) = t.iter().zip(y).position(|(a, b)| !a.is_finite() || !b.is_finite()) {
        return Err(FigureError::NotFinite { index });
    }
    if let Some(i) = t.windows(2).position(|w| w[1] < w[0]) {
        return Err(FigureError::TimeBack { index: i + 1 });
    }
    Ok(())
}

/// When `x` first reaches `level` (from below), interpolated.
fn first_crossing(t: &[f64], x: &[f64], level: f64) -> Option<f64> {
    let i = x.iter().position(|v| *v >= level)?;
    Some(if i == 0 { t[0] } else { between(t[i - 1], x[i - 1], t[i], x[i], level) })
}

/// When the response entered the band at sample `i` (inside, the one
/// before outside): interpolated to the band's edge it crossed.
fn entry(t: &[f64], x: &[f64], i: usize, band: f64) -> f64 {
    if i == 0 {
        return t[0];
    }
    let edge = if x[i - 1] < 1.0 { 1.0 - band } else { 1.0 + band };
    between(t[i - 1], x[i - 1], t[i], x[i], edge)
}

/// The time at which the line from (ta, xa) to (tb, xb) meets `level`,
/// kept within [ta, tb].
fn between(ta: f64, xa: f64, tb: f64, xb: f64, level: f64) -> f64 {
    if xb == xa {
        return tb;
    }
    let f = ((level - xa) / (xb - xa)).clamp(0.0, 1.0);
    ta + f * (tb - ta)
}

/// The mean of the samples in the last tenth of the time span (at least
/// the last sample).
fn tail_mean(t: &[f64], y: &[f64]) -> f64 {
    let (first, last) = (t[0], t[t.len() - 1]);
    let from = last - 0.1 * (last - first);
    let tail: Vec<f64> = t.iter().zip(y).filter(|(ti, _)| **ti >= from).map(|(_, v)| *v).collect();
    tail.iter().sum::<f64>() / tail.len() as f64
}

#[cfg(test)]
mod tests;
