//! `axisctl commission`: a written plan run over the bench, each check
//! passed or failed against the plan's thresholds with the measured value
//! beside its limit, and the handover report.
//!
//! The checks of a device run in a fixed order: identity, settings, limits,
//! homing, the test moves (recorded, with their step-response figures), the
//! halt test, the watchdog, the final backup. Every motion goes through the
//! device layer's supervised operations and is halted on every way out (a
//! signal, an error, the end of its recording); a motion check that fails
//! or is interrupted leaves the device's later motion checks unrun. The
//! library reads and computes; the binary writes the files.

pub mod cdios;
pub mod devices;
pub mod figures;
pub mod pac;
pub mod plan;
pub mod powercube;
pub mod report;

use std::sync::Arc;
use std::time::Instant;

use crate::backup;
use crate::clock::Clock;
use crate::family::Family;
use report::Check;

/// What one run shares across devices: options, the clock, the results so
/// far and the hooks that show progress.
pub struct Run<'a> {
    /// Checks that move nothing run; the others are listed as skipped.
    pub dry_run: bool,
    /// How often a halt whose acknowledge is lost is sent.
    pub halt_attempts: u32,
    /// The read retries of sessions the run opens itself (a Cdios node).
    pub retry: crate::session::RetryPolicy,
    /// The links as given, for the backup's envelope.
    pub link: String,
    /// Each family's own link, where the bench says (a device's backup
    /// names the link it is on, not every link joined).
    pub links: Vec<(Family, String)>,
    pub clock: Arc<dyn Clock>,
    pub start: Instant,
    /// A signal or a failed output: stop now, halt what moves.
    pub stop: &'a dyn Fn() -> bool,
    /// A check begins: (device, check).
    pub on_step: &'a mut dyn FnMut(&str, &str),
    /// A check ended.
    pub on_check: &'a mut dyn FnMut(&Check),
    pub checks: Vec<Check>,
    /// The final backups, one device each.
    pub backups: Vec<backup::Device>,
    /// Files for the report's directory: (name, contents).
    pub files: Vec<(String, String)>,
    /// Set once the run was stopped: nothing more is checked.
    pub interrupted: bool,
}

impl<'a> Run<'a> {
    /// Each of `names` reported as not run, with `why`: the rest of a
    /// device's plan is said, never silently dropped.
    pub fn skip(&mut self, at: &str, names: &[&'static str], why: &str) {
        for name in names {
            let t = self.begin(at, name);
            self.end(Check::new(at, name).skipped(why), t);
        }
    }

    pub fn new(
        clock: Arc<dyn Clock>,
        link: &str,
        stop: &'a dyn Fn() -> bool,
        on_step: &'a mut dyn FnMut(&str, &str),
        on_check: &'a mut dyn FnMut(&Check),
    ) -> Self {
        let start = clock.now();
        Self {
            dry_run: false,
            halt_attempts: 3,
            retry: Default::default(),
            link: link.into(),
            links: Vec::new(),
            clock,
            start,
            stop,
            on_step,
            on_check,
            checks: Vec::new(),
            backups: Vec::new(),
            files: Vec::new(),
            interrupted: false,
        }
    }

    /// The link a device of `family` is on.
    pub fn link_of(&self, family: Family) -> String {
        self.links.iter().find(|(f, _)| *f == family).map_or_else(|| self.link.clone(), |(_, l)| l.clone())
    }

    /// Seconds since the run started.
    pub fn elapsed(&self) -> f64 {
        self.clock.now().saturating_duration_since(self.start).as_secs_f64()
    }

    /// Says a check begins; its start time.
    fn begin(&mut self, device: &str, check: &str) -> f64 {
        (self.on_step)(device, check);
        self.elapsed()
    }

    /// Records a finished check that began at `t`.
    fn end(&mut self, mut c: Check, t: f64) {
        c.t = t;
        c.duration_s = self.elapsed() - t;
        (self.on_check)(&c);
        self.checks.push(c);
    }
}

/// The final backups of every device, in one `axisctl-backup/1` document.
pub const BACKUP_FILE: &str = "backup.json";

/// Why the default plan could not be made: a link that did not open (the
/// caller's own error), or a device that could not be read (its family's
/// error kept as the source, so its kind still decides the exit status).
#[derive(Debug)]
pub enum DefaultPlanError<E> {
    Open(E),
    Read(ReadFailed),
}

#[derive(Debug, thiserror::Error)]
#[error("the default plan: {family}: {source}")]
pub struct ReadFailed {
    pub family: &'static str,
    #[source]
    pub source: Box<dyn std::error::Error + Send + Sync>,
}

impl<E> DefaultPlanError<E> {
    /// A read of `family`'s device failed.
    pub fn read(family: Family, e: impl std::error::Error + Send + Sync + 'static) -> Self {
        Self::Read(ReadFailed { family: family.display_name(), source: Box::new(e) })
    }
}

/// The step-response figures of a recorded move (`t`, `y` from the sample
/// before the motion started) against the plan's bands, each measured
/// value beside its limit; no figure at all fails the check.
pub(crate) fn step_measures(c: &mut Check, plan: &plan::Moves, t: &[f64], y: &[f64], target: f64, unit: &str) {
    let band = |b: &Option<plan::Band>, name: &str, v: Option<f64>, unit: &str, c: &mut Check| {
        let limit = b.map_or_else(|| "any".to_string(), |b| b.text());
        let ok = match (b, v) {
            (Some(b), Some(v)) => b.holds(v),
            (Some(_), None) => false,
            (None, _) => true,
        };
        c.measure(name, serde_json::json!(v.map(round6)), limit, unit, ok);
    };
    match figures::step(t, y, target, plan.band_percent / 100.0) {
        Ok(f) => {
            band(&plan.rise_time_s, "rise_time", f.rise_time, "s", c);
            band(&plan.overshoot_percent, "overshoot", Some(f.overshoot_percent), "%", c);
            band(&plan.settling_time_s, "settling_time", f.settling_time, "s", c);
            band(&plan.steady_state_error, "steady_state_error", Some(f.steady_state_error), unit, c);
            band(&plan.time_to_reach_s, "time_to_reach", f.time_to_reach, "s", c);
        }
        Err(e) => {
            c.status = report::Status::Fail;
            c.detail = format!("no figures: {e}");
        }
    }
}

/// One column of a recording: its name, unit and values.
pub(crate) struct Column<'a> {
    pub name: &'a str,
    pub unit: &'a str,
    pub values: &'a [f64],
    /// Drawn in the report's plot (a status word is not).
    pub plotted: bool,
}

/// Points per line of a report's plot.
const PLOT_POINTS: usize = 1500;

/// A recording as CSV beside the report (every sample) and its plot for
/// the HTML (at most [`PLOT_POINTS`] per line).
pub(crate) fn attach_recording(c: &mut Check, at: &str, t: &[f64], columns: &[Column], run: &mut Run) {
    let file = format!("{}-{}.csv", at.replace([':', '/'], "-"), c.check);
    let mut csv = String::from("t [s]");
    for col in columns {
        csv += &if col.unit.is_empty() { format!(",{}", col.name) } else { format!(",{} [{}]", col.name, col.unit) };
    }
    csv.push('\n');
    for (i, ti) in t.iter().enumerate() {
        csv += &ti.to_string();
        for col in columns {
            csv += &format!(",{}", col.values.get(i).copied().unwrap_or(f64::NAN));
        }
        csv.push('\n');
    }
    run.files.push((file.clone(), csv));
    c.recording = Some(file);
    let every = t.len().div_ceil(PLOT_POINTS).max(1);
    let series = columns
        .iter()
        .filter(|col| col.plotted)
        .map(|col| crate::plot::Series {
            name: format!("{at} {}", col.name),
            unit: Some(col.unit.to_string()),
            points: t
                .iter()
                .copied()
                .zip(col.values.iter().copied())
                .enumerate()
                .filter(|(i, _)| i % every == 0 || i + 1 == t.len())
                .map(|(_, p)| p)
                .collect(),
        })
        .collect();
    let chart = crate::plot::Chart { title: format!("{at} {}", c.check), x_label: "t (s)".into(), series };
    c.svg = crate::plot::svg(&chart, 900, 520).ok();
}

/// Where the halt test moves: `distance` from `here`, forward when that
/// stays inside the plan's move window (if it has one), else back; an
/// error (in `unit`) when neither fits, so nothing moves.
pub(crate) fn halt_target(here: f64, distance: f64, window: Option<[f64; 2]>, unit: &str) -> Result<f64, String> {
    let fits = |p: f64| window.is_none_or(|[lo, hi]| (lo..=hi).contains(&p));
    let target = if fits(here + distance) { here + distance } else { here - distance };
    match fits(target) {
        true => Ok(target),
        false => Err(format!("no room for {distance} {unit} inside the move window: not moved")),
    }
}

/// The halt test's figures from its recording: the time from the halt (or
/// stop) going out to the first sample at rest, against the plan's band,
/// and how far the device went on after it (in `unit`). `what`: "halt" or
/// "stop", for the message when there are none.
pub(crate) fn measure_halt(
    c: &mut Check,
    h: &plan::Halt,
    (t, pos): (&[f64], &[f64]),
    (sent, rest): (Option<f64>, Option<f64>),
    (what, unit): (&str, &str),
) -> Result<(), String> {
    let (Some(sent), Some(rest)) = (sent, rest) else {
        return Err(if sent.is_none() {
            format!("the move ended before the {what} was due")
        } else {
            "never at rest".into()
        });
    };
    let secs = rest - sent;
    c.measure(
        "time_to_standstill",
        serde_json::json!(round6(secs)),
        h.standstill_s.text(),
        "s",
        h.standstill_s.holds(secs),
    );
    let at_sent = t.iter().position(|ti| *ti >= sent).map_or(f64::NAN, |i| pos[i]);
    let end = pos.last().copied().unwrap_or(f64::NAN);
    c.measure("distance_after_halt", serde_json::json!(round6((end - at_sent).abs())), "any".into(), unit, true);
    Ok(())
}

/// An error and its causes, as a report's detail: "lost track of module
/// 17 while homing (module 17 halted): no answer ... within 400 ms".
pub(crate) fn with_causes(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        text = format!("{text}: {c}");
        cause = c.source();
    }
    text
}

/// Six decimals, and no -0: what a report shows.
pub(crate) fn round6(v: f64) -> f64 {
    if v.is_finite() {
        (v * 1e6).round() / 1e6 + 0.0
    } else {
        v
    }
}

/// A trapezoid's duration over `distance` at `vel` and `acc` (a triangle
/// when the speed is never reached): the default plans' bands.
pub fn ramp_duration(distance: f64, vel: f64, acc: f64) -> f64 {
    if distance >= vel * vel / acc {
        distance / vel + vel / acc
    } else {
        2.0 * (distance / acc).sqrt()
    }
}

/// Three significant digits: a plan a person reads and edits.
pub fn sig(v: f64) -> f64 {
    format!("{v:.2e}").parse().unwrap_or(v)
}

/// Seven: a float setting as a device holds it (f32).
pub fn sig7(v: f64) -> f64 {
    format!("{v:.6e}").parse().unwrap_or(v)
}

/// The device's settings against the plan's: those the backup file's
/// device restores (compared as `diff` compares them, within the plan's
/// relative tolerance), then the inline values (within their own
/// tolerance, else the relative one). Any family: `live` is the device
/// read into a backup's shape.
pub fn settings_check(at: &str, plan: &plan::Settings, file: Option<&backup::Device>, live: &backup::Device) -> Check {
    let mut c = Check::new(at, "settings");
    let mut expected: std::collections::BTreeMap<String, (serde_json::Value, Option<f64>, String)> = Default::default();
    if let Some(f) = file {
        for (name, s) in f.restorable() {
            expected.insert(name.clone(), (s.value.clone(), None, s.unit.clone()));
        }
    }
    for (name, e) in &plan.values {
        let unit = live.settings.get(name).map(|s| s.unit.clone()).unwrap_or_default();
        expected.insert(name.clone(), (serde_json::json!(e.value), e.tolerance, unit));
    }
    if plan.backup.is_some() && file.is_none() {
        return c.fail(format!("the plan's backup file holds no device {at}"));
    }
    for (name, (want, tol, unit)) in expected {
        let got = live.settings.get(&name).map(|s| s.value.clone());
        let (ok, limit) = match (want.as_f64(), got.as_ref().and_then(|g| g.as_f64())) {
            (Some(w), Some(g)) => {
                let tol = tol.unwrap_or(plan.tolerance * w.abs());
                (
                    (g - w).abs() <= tol || backup::same_value(&want, got.as_ref().unwrap_or(&want)),
                    format!("{w} ± {}", format!("{tol:.3e}").parse().unwrap_or(tol)),
                )
            }
            _ => (got.as_ref().is_some_and(|g| backup::same_value(&want, g)), want.to_string()),
        };
        c.measure(&name, got.unwrap_or(serde_json::Value::Null), limit, &unit, ok);
    }
    if c.measured.is_empty() {
        c.detail = "the plan expects no setting".into();
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;
    use plan::{Expected, Settings};
    use report::Status;

    #[test]
    fn a_failed_check_says_the_causes_of_its_error() {
        use crate::device::powercube::Error;
        use crate::session::SessionError;
        let source = SessionError::Timeout {
            target: "module 17".into(),
            what: "GetExtended".into(),
            timeout: std::time::Duration::from_millis(400),
        };
        let e = Error::LostTrack {
            module: crate::proto::powercube::ModuleId::new(17).unwrap(),
            what: "homing".into(),
            halt_failed: None,
            source,
        };
        let text = with_causes(&e);
        assert!(text.starts_with(&format!("{e}: ")) && text.contains("400"), "{text}");
    }

    #[test]
    fn the_halt_test_moves_forward_inside_the_window_else_back() {
        assert_eq!(halt_target(1.0, 0.5, None, "rad"), Ok(1.5));
        assert_eq!(halt_target(1.0, 0.5, Some([0.0, 2.0]), "rad"), Ok(1.5));
        assert_eq!(halt_target(1.8, 0.5, Some([0.0, 2.0]), "rad"), Ok(1.3));
        assert_eq!(
            halt_target(1.0, 5.0, Some([0.0, 2.0]), "AE"),
            Err("no room for 5 AE inside the move window: not moved".into())
        );
    }

    fn device(values: &[(&str, serde_json::Value, bool)]) -> backup::Device {
        let mut d = backup::Device::new(Family::PowerCube, "sim");
        d.module = Some(5);
        for (name, v, restore) in values {
            d.settings.insert(name.to_string(), backup::Setting::new(v.clone(), "rad/s", *restore));
        }
        d
    }

    fn settings(values: &[(&str, f64, Option<f64>)]) -> Settings {
        Settings {
            backup: None,
            tolerance: 1e-6,
            values: values.iter().map(|(n, v, t)| (n.to_string(), Expected { value: *v, tolerance: *t })).collect(),
        }
    }

    #[test]
    fn inline_values_pass_within_their_tolerance_and_fail_outside() {
        let live = device(&[("MaxVel", 1.5.into(), true), ("MaxAcc", 3.0.into(), true)]);
        let c = settings_check("powercube:5", &settings(&[("MaxVel", 1.45, Some(0.1))]), None, &live);
        assert_eq!(c.status, Status::Pass);
        assert_eq!(c.measured[0].limit, "1.45 ± 0.1");
        let c = settings_check("powercube:5", &settings(&[("MaxVel", 1.45, Some(0.01))]), None, &live);
        assert_eq!(c.status, Status::Fail);
        assert_eq!((c.measured[0].value.as_f64(), c.measured[0].pass), (Some(1.5), false));
        // Without its own tolerance: relative to the value (1e-6 here).
        let c = settings_check("powercube:5", &settings(&[("MaxAcc", 3.0000001, None)]), None, &live);
        assert_eq!(c.status, Status::Pass);
        let c = settings_check("powercube:5", &settings(&[("MaxAcc", 3.001, None)]), None, &live);
        assert_eq!(c.status, Status::Fail);
        // A setting the device does not have fails, with no value.
        let c = settings_check("powercube:5", &settings(&[("MaxCur", 5.0, Some(1.0))]), None, &live);
        assert_eq!((c.status, &c.measured[0].value), (Status::Fail, &serde_json::Value::Null));
    }

    #[test]
    fn a_backup_files_restorable_settings_are_expected_and_inline_values_win() {
        let live = device(&[("MaxVel", 1.5.into(), true), ("MaxAcc", 3.0.into(), true)]);
        // The file's MaxAcc differs; its read-only value is not compared.
        let file =
            device(&[("MaxVel", 1.0.into(), true), ("MaxAcc", 2.0.into(), true), ("DefMaxVel", 9.0.into(), false)]);
        let mut plan = settings(&[("MaxVel", 1.5, None)]);
        plan.backup = Some("arm.json".into());
        let c = settings_check("powercube:5", &plan, Some(&file), &live);
        let out: Vec<&str> = c.measured.iter().filter(|m| !m.pass).map(|m| m.name.as_str()).collect();
        assert_eq!(out, ["MaxAcc"], "the inline MaxVel wins over the file's");
        assert_eq!(c.measured.len(), 2, "DefMaxVel is kept for information only");
        let c = settings_check("powercube:5", &plan, None, &live);
        assert_eq!(c.status, Status::Fail, "the file holds no such device: {}", c.detail);
    }
}
