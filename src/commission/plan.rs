//! The commissioning plan (TOML): per device, what it must be (identity),
//! what its settings must be (a backup file or inline values, each with a
//! tolerance), and which tests run with which windows and thresholds.
//! Every table refuses unknown keys, so a misspelt threshold is an error,
//! never a check silently left out.

use std::collections::BTreeMap;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// Why a plan cannot be used. Nothing was sent.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error("plan {file}, line {line}: {message}")]
    Toml { file: String, line: usize, message: String },
    #[error("plan {file}: {message}")]
    Invalid { file: String, message: String },
}

/// A whole plan: one `[[device]]` table per device, run in this order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plan {
    #[serde(default)]
    pub device: Vec<DevicePlan>,
}

/// One device's plan. A test left out is not run (and not listed as
/// passed); `limits` and `backup` run unless switched off.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DevicePlan {
    /// A bench address (`powercube:3`, `pac:1`, `cdios:1/0`) or a name from
    /// the bench file.
    pub address: String,
    #[serde(default, skip_serializing_if = "Identity::is_empty")]
    pub identity: Identity,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settings: Option<Settings>,
    /// Limits sane: min < max, speeds and accelerations positive and within
    /// the module's ROM range.
    #[serde(default = "yes")]
    pub limits: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub home: Option<Home>,
    #[serde(default, rename = "move", skip_serializing_if = "Option::is_none")]
    pub moves: Option<Moves>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub halt: Option<Halt>,
    /// The PowerCube watchdog: trips when refreshes stop, recovers after a
    /// reset (CAN only).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub watchdog: bool,
    /// A final backup of the device into the report's directory.
    #[serde(default = "yes")]
    pub backup: bool,
}

fn yes() -> bool {
    true
}

/// The device that was ordered; a key left out is not compared.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Identity {
    /// The kind (`rotary`, `linear`; a Cdios module type, a controller type).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub firmware: Option<String>,
}

impl Identity {
    pub fn is_empty(&self) -> bool {
        self.kind.is_none() && self.serial.is_none() && self.firmware.is_none()
    }
}

/// The settings the device must hold: those of a backup file (its device
/// of the same address), and inline values, which win over the file's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backup: Option<PathBuf>,
    /// The tolerance of a value that gives none: relative to the expected
    /// value's magnitude (1e-6 by default: a float's precision).
    #[serde(default = "default_relative")]
    pub tolerance: f64,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub values: BTreeMap<String, Expected>,
}

fn default_relative() -> f64 {
    1e-6
}

/// One expected value; `tolerance` is absolute, in the setting's unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expected {
    pub value: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tolerance: Option<f64>,
}

/// Homing (PowerCube home, PA-CONTROL reference drive).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Home {
    /// Fails past this, the device halted.
    pub timeout_s: f64,
}

/// A band a measured figure must lie in; either end may be open.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Band {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
}

impl Band {
    pub fn max(max: f64) -> Self {
        Self { min: None, max: Some(max) }
    }

    pub fn holds(&self, v: f64) -> bool {
        v.is_finite() && self.min.is_none_or(|m| v >= m) && self.max.is_none_or(|m| v <= m)
    }

    /// `<= 0.5`, `0.1 .. 0.5`, `>= 2`: the limit beside the measured value.
    pub fn text(&self) -> String {
        match (self.min, self.max) {
            (Some(a), Some(b)) => format!("{a} .. {b}"),
            (None, Some(b)) => format!("<= {b}"),
            (Some(a), None) => format!(">= {a}"),
            (None, None) => "any".into(),
        }
    }
}

/// The test moves: from where the device stands after homing, `distance`
/// forward and back again, each a ramp that must stay inside `window`.
/// Each recorded move's figures are held to the bands given.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Moves {
    /// In the device's unit (rad, m, encoder counts); positive.
    pub distance: f64,
    /// [min, max] position every target must lie in.
    pub window: [f64; 2],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vel: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acc: Option<f64>,
    /// The settling band, in % of the step.
    #[serde(default = "default_band")]
    pub band_percent: f64,
    /// A move not ended by then is halted and fails.
    #[serde(default = "default_move_timeout")]
    pub timeout_s: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rise_time_s: Option<Band>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub overshoot_percent: Option<Band>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settling_time_s: Option<Band>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub steady_state_error: Option<Band>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_to_reach_s: Option<Band>,
}

fn default_band() -> f64 {
    2.0
}

fn default_move_timeout() -> f64 {
    30.0
}

/// The halt test: a move of `distance` halted `after_s` into it; the time
/// from the halt to standstill must lie within `standstill_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Halt {
    pub distance: f64,
    pub after_s: f64,
    pub standstill_s: Band,
}

impl Plan {
    /// Parses and checks a plan; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<Self, PlanError> {
        let plan: Plan = toml::from_str(text).map_err(|e| PlanError::Toml {
            file: file.into(),
            // Bytes, not chars: a span never splits a character here.
            line: 1 + text.as_bytes()[..e.span().map_or(0, |s| s.start).min(text.len())]
                .iter()
                .filter(|b| **b == b'\n')
                .count(),
            message: e.message().trim().to_string(),
        })?;
        plan.check().map_err(|message| PlanError::Invalid { file: file.into(), message })?;
        Ok(plan)
    }

    /// The plan as TOML, as `--print-plan` writes it.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_else(|e| format!("# plan not printable: {e}\n"))
    }

    /// What TOML cannot say: positive distances, a window that is one,
    /// finite thresholds, each device once.
    fn check(&self) -> Result<(), String> {
        let mut seen = std::collections::BTreeSet::new();
        for d in &self.device {
            let at = &d.address;
            if !seen.insert(at.as_str()) {
                return Err(format!("device {at} is planned twice"));
            }
            let positive = |what: &str, v: f64| {
                if v.is_finite() && v > 0.0 {
                    Ok(())
                } else {
                    Err(format!("device {at}: {what} must be a positive number, not {v}"))
                }
            };
            if let Some(s) = &d.settings {
                positive("settings.tolerance", s.tolerance)?;
                for (name, e) in &s.values {
                    if !e.value.is_finite() || e.tolerance.is_some_and(|t| !(t.is_finite() && t >= 0.0)) {
                        return Err(format!("device {at}: settings.values.{name}: a finite value and tolerance >= 0"));
                    }
                }
            }
            if let Some(h) = &d.home {
                positive("home.timeout_s", h.timeout_s)?;
            }
            if let Some(m) = &d.moves {
                positive("move.distance", m.distance)?;
                positive("move.timeout_s", m.timeout_s)?;
                if !(m.window[0].is_finite() && m.window[1].is_finite() && m.window[0] < m.window[1]) {
                    return Err(format!("device {at}: move.window must be [min, max] with min < max"));
                }
                if m.distance > m.window[1] - m.window[0] {
                    return Err(format!("device {at}: move.distance {} is wider than move.window", m.distance));
                }
                if !(m.band_percent > 0.0 && m.band_percent < 100.0) {
                    return Err(format!("device {at}: move.band_percent must lie in 0 < b < 100"));
                }
                for v in [m.vel, m.acc].into_iter().flatten() {
                    positive("move.vel and move.acc", v)?;
                }
                let bands =
                    [m.rise_time_s, m.overshoot_percent, m.settling_time_s, m.steady_state_error, m.time_to_reach_s];
                bands.iter().flatten().try_for_each(|b| band_ok(at, b))?;
            }
            if let Some(h) = &d.halt {
                positive("halt.distance", h.distance)?;
                positive("halt.after_s", h.after_s)?;
                band_ok(at, &h.standstill_s)?;
            }
        }
        Ok(())
    }
}

fn band_ok(at: &str, b: &Band) -> Result<(), String> {
    let finite = [b.min, b.max].iter().flatten().all(|v| v.is_finite());
    let ordered = matches!((b.min, b.max), (Some(a), Some(c)) if a <= c) || b.min.is_none() || b.max.is_none();
    if finite && ordered && (b.min.is_some() || b.max.is_some()) {
        Ok(())
    } else {
        Err(format!("device {at}: a band needs min and/or max, finite, min <= max (got {})", b.text()))
    }
}

#[cfg(test)]
mod tests;
