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

pub mod figures;
pub mod plan;
pub mod powercube;
pub mod report;

use std::sync::Arc;
use std::time::Instant;

use crate::backup;
use crate::clock::Clock;
use report::Check;

/// What one run shares across devices: options, the clock, the results so
/// far and the hooks that show progress.
pub struct Run<'a> {
    /// Checks that move nothing run; the others are listed as skipped.
    pub dry_run: bool,
    /// How often a halt whose acknowledge is lost is sent.
    pub halt_attempts: u32,
    /// The link the devices are on, for the backup's envelope.
    pub link: String,
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
            link: link.into(),
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
