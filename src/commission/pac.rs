//! The checks of the PA-CONTROL: the controller (`pac`) and each axis
//! (`pac:N`), in the plan's order.
//!
//! What the controller offers decides what is checked. Its serial
//! interface reports no type, serial number or firmware (manual 5.2.4), so
//! the identity is what it does report: the operating status, the number
//! of configured axes, and for an axis that it is one of them. Parameters
//! are read in home position only (5.2.2, 5.2.3): an axis's identity,
//! settings and limits are read there; its motions then run in online
//! mode, entered from home position as `pac-online` enters it (the limits
//! of 0A8D / 0A8E read first), the axis released by its reference drive
//! (0A84) or by "no reference run" (0A83); after them the controller goes
//! back to home position (0A81), where the final backup is read. Every
//! motion starts under the device face's `Moving` handle: any way out of
//! it other than a standstill read stops the axis (0A93).
//!
//! A move is recorded as fast as the line allows (paced to one sample every
//! 5 ms at most): actual position (190C), actual speed (190D), axis status
//! (1910) and following error (1915, "get axis following error": the
//! controller reports it, so it is recorded and its peak measured).

use std::time::Duration;

use serde_json::json;

use super::plan::{Band, DevicePlan, Expected, Home, Moves, Settings};
use super::report::{Check, Status};
use super::{attach_recording, halt_target, measure_halt, round6, sig, step_measures, Column, DefaultPlanError, Run};
use crate::backup::{self, Device};
use crate::bench::Address;
use crate::device::face::{Face, MotionTarget};
use crate::device::pac::{Controller, Follow};
use crate::device::registry::Sessions;
use crate::family::Family;
use crate::proto::pac::table::{self, Mode};
use crate::session::pac::Progress;

/// Axis parameters 1 (traverse speed) and 6 (acceleration): the ones whose
/// range the controller gives (1802 / 1801), as `pac-online` reads them.
const RANGED: [(u8, &str); 2] = [(1, "traverse-speed"), (6, "acceleration")];
const AREA: [&str; 2] = ["traverse-area-min", "traverse-area-max"];

/// How often a move is sampled at most.
const SAMPLE_EVERY: Duration = Duration::from_millis(5);

/// What a PA-CONTROL plan may not ask, before anything is sent.
pub fn check_plan(at: Address, plan: &DevicePlan) -> Result<(), String> {
    if !plan.identity.is_empty() {
        return Err("the PA-CONTROL reports no type, serial number or firmware over its serial interface \
                    (manual 5.2.4): leave identity out; the check reads the operating status and the axes"
            .into());
    }
    if plan.watchdog {
        return Err("the watchdog check is the PowerCube's".into());
    }
    let axis = match at {
        Address::Pac { axis: Some(a) } => a,
        _ => {
            if plan.home.is_some() || plan.moves.is_some() || plan.halt.is_some() {
                return Err("the controller itself does not move: plan home, move and halt on an axis (pac:N)".into());
            }
            return known(plan, |n| table::system_param_by_name(n).is_some_and(|p| p.name == n), "system");
        }
    };
    if let Some(m) = &plan.moves {
        if m.vel.is_some() || m.acc.is_some() {
            return Err(format!(
                "move.vel and move.acc: a PA-CONTROL axis moves at its traverse speed and acceleration (axis \
                 parameters 1 and 6 of axis {axis}); expect them in settings.values instead"
            ));
        }
    }
    known(plan, |n| table::axis_param_by_name(n).is_some_and(|p| p.name == n), "axis")
}

fn known(plan: &DevicePlan, ok: impl Fn(&str) -> bool, kind: &str) -> Result<(), String> {
    match plan.settings.as_ref().and_then(|s| s.values.keys().find(|n| !ok(n))) {
        Some(name) => Err(format!("no PA-CONTROL {kind} parameter {name:?} (the names `backup` writes)")),
        None => Ok(()),
    }
}

/// The motions the plan makes, as the confirmation lists them.
pub fn motions(at: &str, plan: &DevicePlan) -> Vec<String> {
    let mut out = Vec::new();
    if plan.home.is_some() || plan.moves.is_some() || plan.halt.is_some() {
        out.push(format!("{at}: the controller goes online (0603) and back to home position (0A81) after"));
    }
    if plan.home.is_some() {
        out.push(format!("{at}: reference drive (0A84)"));
    }
    if let Some(m) = &plan.moves {
        out.push(format!(
            "{at}: move {} AE from where it stands and back, inside [{}, {}] AE",
            m.distance, m.window[0], m.window[1]
        ));
    }
    if let Some(h) = &plan.halt {
        out.push(format!("{at}: move up to {} AE, stopped (0A9A) {} s into it", h.distance, h.after_s));
    }
    out
}

/// The checks a plan asks of the controller or an axis, in run order.
pub fn planned(at: Address, plan: &DevicePlan) -> Vec<&'static str> {
    let axis = matches!(at, Address::Pac { axis: Some(_) });
    let asked = [
        ("identity", true),
        ("settings", plan.settings.is_some()),
        ("limits", plan.limits && axis),
        ("home", plan.home.is_some()),
        ("move_forward", plan.moves.is_some()),
        ("move_back", plan.moves.is_some()),
        ("halt", plan.halt.is_some()),
        ("backup", plan.backup),
    ];
    asked.into_iter().filter(|(_, on)| *on).map(|(name, _)| name).collect()
}

/// The default plan: the controller (its system parameters as they are)
/// and each configured axis: its traverse area, speed and acceleration as
/// they are, the reference drive, a move of a tenth of its traverse area
/// each way with bands from the ramp's own duration, and a stop half-way
/// into such a move, allowed twice its braking time at its acceleration.
/// With `only` (`commission -d`), the controller and the configured axes it
/// names.
pub fn default_plan<S: Sessions>(
    sessions: &mut S,
    link: &str,
    only: &[Address],
) -> Result<Vec<DevicePlan>, DefaultPlanError<S::Error>> {
    let read = |e| DefaultPlanError::read(Family::Pac, e);
    let wanted = |a: Address| only.is_empty() || only.contains(&a);
    let mut c = Controller::new(sessions.pac().map_err(DefaultPlanError::Open)?);
    let axes = c.configured_axes().map_err(read)?;
    let mut out = vec![DevicePlan {
        address: Address::Pac { axis: None }.to_string(),
        identity: Default::default(),
        settings: None,
        limits: true,
        home: None,
        moves: None,
        halt: None,
        watchdog: false,
        backup: true,
    }];
    out.retain(|_| wanted(Address::Pac { axis: None }));
    for axis in (1..=axes).filter(|a| wanted(Address::Pac { axis: Some(*a) })) {
        let live = backup::pac::capture_axis(&mut c, axis, link).map_err(read)?;
        out.push(default_axis(axis, &live));
    }
    Ok(out)
}

fn default_axis(axis: u8, live: &Device) -> DevicePlan {
    let num = |n: &str| live.settings.get(n).and_then(|s| s.value.as_f64()).unwrap_or(f64::NAN);
    let (lo, hi) = (num(AREA[0]), num(AREA[1]));
    let (vel, acc) = (num("traverse-speed"), num("acceleration"));
    let distance = sig((hi - lo) / 10.0);
    let ramp = super::ramp_duration(distance, vel, acc);
    let slack = sig(ramp + 1.0);
    let values = AREA
        .into_iter()
        .chain(["traverse-speed", "acceleration"])
        .map(|n| (n.to_string(), Expected { value: num(n), tolerance: None }))
        .collect();
    DevicePlan {
        address: Address::Pac { axis: Some(axis) }.to_string(),
        identity: Default::default(),
        settings: Some(Settings { backup: None, tolerance: 1e-6, values }),
        limits: true,
        home: Some(Home { timeout_s: 60.0 }),
        moves: Some(Moves {
            distance,
            window: [lo, hi],
            vel: None,
            acc: None,
            band_percent: 2.0,
            timeout_s: sig(ramp * 3.0 + 5.0),
            rise_time_s: Some(Band::max(sig(ramp))),
            overshoot_percent: Some(Band::max(5.0)),
            settling_time_s: Some(Band::max(slack)),
            steady_state_error: Some(Band { min: Some(-sig(distance / 100.0)), max: Some(sig(distance / 100.0)) }),
            time_to_reach_s: Some(Band::max(slack)),
        }),
        halt: Some(super::plan::Halt {
            distance,
            after_s: sig(ramp / 2.0),
            standstill_s: Band::max(sig(2.0 * vel / acc + 0.2)),
        }),
        watchdog: false,
        backup: true,
    }
}

/// The controller's line for the run: opened for its first device, kept.
#[derive(Default)]
pub struct Open(Option<Controller>);

impl Open {
    /// Runs the plan of the controller (`axis: None`) or of one axis; `Err`
    /// when the line cannot be opened.
    pub fn run<S>(
        &mut self,
        sessions: &mut S,
        axis: Option<u8>,
        plan: &DevicePlan,
        expected: Option<&Device>,
        run: &mut Run,
    ) -> Result<(), String>
    where
        S: Sessions,
        S::Error: std::fmt::Display,
    {
        if self.0.is_none() {
            let pac = sessions.pac().map_err(|e| format!("the PA-CONTROL line could not be opened: {e:#}"))?;
            self.0 = Some(Controller::new(pac));
        }
        let c = self.0.as_mut().expect("opened above");
        match axis {
            None => run_controller(c, plan, expected, run),
            Some(axis) => run_axis(c, axis, plan, expected, run),
        }
        Ok(())
    }
}

/// The rest of a device's plan said, not silently dropped.
fn run_controller(c: &mut Controller, plan: &DevicePlan, expected: Option<&Device>, run: &mut Run) {
    let at = plan.address.as_str();
    let names = planned(Address::Pac { axis: None }, plan);
    let t = run.begin(at, "identity");
    let live = match backup::pac::capture_controller(c, &run.link_of(Family::Pac)) {
        Ok(d) => d,
        Err(e) => {
            run.end(Check::new(at, "identity").fail(format!("the controller could not be read: {e}")), t);
            run.skip(at, &names[1..], "not run: the controller could not be read");
            return;
        }
    };
    let mut id = Check::new(at, "identity");
    id.measure("operating status", json!(1), "1 (home position)".into(), "", true);
    id.measure("axes", live.identity.get("axes").cloned().unwrap_or_default(), "any".into(), "", true);
    run.end(id, t);
    if let Some(s) = &plan.settings {
        let t = run.begin(at, "settings");
        run.end(super::settings_check(at, s, expected, &live), t);
    }
    if plan.backup && !run.interrupted {
        let t = run.begin(at, "backup");
        run.backups.push(live);
        let mut c = Check::new(at, "backup");
        c.file = Some(super::BACKUP_FILE.into());
        run.end(c, t);
    }
}

/// The identity of an axis: the controller in home position (the only
/// mode its parameters are read in) and the axis one of its axes.
fn axis_identity(c: &mut Controller, at: &str, axis: u8) -> Result<Check, String> {
    let mut id = Check::new(at, "identity");
    let status = c.read_status().map_err(|e| format!("the operating status could not be read: {e}"))?;
    let home = table::mode_of_status(status) == Some(Mode::Home);
    let text = format!("{status} ({})", table::operating_status_text(status));
    id.measure("operating status", json!(text), "1 (home position)".into(), "", home);
    let axes = c.configured_axes().map_err(|e| format!("the number of axes could not be read: {e}"))?;
    id.measure("axes", json!(axes), format!(">= {axis}"), "", axis <= axes);
    if !home {
        id.detail = "parameters are read in home position only: `axisctl pac-offline` first".into();
    }
    Ok(id)
}

fn run_axis(c: &mut Controller, axis: u8, plan: &DevicePlan, expected: Option<&Device>, run: &mut Run) {
    let at = plan.address.as_str();
    let names = planned(Address::Pac { axis: Some(axis) }, plan);
    let t = run.begin(at, "identity");
    let id = match axis_identity(c, at, axis) {
        Ok(id) => id,
        Err(e) => Check::new(at, "identity").fail(e),
    };
    if id.status != Status::Pass {
        run.end(id, t);
        run.skip(at, &names[1..], "not run: the identity is not the planned one");
        return;
    }
    let live = match backup::pac::capture_axis(c, axis, &run.link_of(Family::Pac)) {
        Ok(d) => d,
        Err(e) => {
            run.end(id.fail(format!("axis {axis} could not be read: {e}")), t);
            run.skip(at, &names[1..], "not run: the axis could not be read");
            return;
        }
    };
    run.end(id, t);
    if let Some(s) = &plan.settings {
        let t = run.begin(at, "settings");
        run.end(super::settings_check(at, s, expected, &live), t);
    }
    if plan.limits {
        let t = run.begin(at, "limits");
        run.end(limits(c, at, axis, &live), t);
    }
    let motion = plan.home.is_some() || plan.moves.is_some() || plan.halt.is_some();
    if motion && !run.interrupted {
        motions_of(c, axis, plan, run);
    }
    if plan.backup && !run.interrupted {
        let t = run.begin(at, "backup");
        let c = match backup::pac::capture_axis(c, axis, &run.link_of(Family::Pac)) {
            Ok(d) => {
                run.backups.push(d);
                let mut c = Check::new(at, "backup");
                c.file = Some(super::BACKUP_FILE.into());
                c
            }
            Err(e) => Check::new(at, "backup").fail(format!("axis {axis} could not be read: {e}")),
        };
        run.end(c, t);
    }
}

/// The traverse area one (min < max); speed and acceleration positive and
/// within the range the controller gives for them (1802 / 1801).
fn limits(c: &mut Controller, at: &str, axis: u8, live: &Device) -> Check {
    let mut ck = Check::new(at, "limits");
    let num = |n: &str| live.settings.get(n).and_then(|s| s.value.as_f64());
    let (min, max) = (num(AREA[0]), num(AREA[1]));
    let ok = matches!((min, max), (Some(a), Some(b)) if a < b);
    ck.measure(
        "traverse-area-max - traverse-area-min",
        json!(max.zip(min).map(|(b, a)| b - a)),
        "> 0".into(),
        "AE",
        ok,
    );
    for (param, name) in RANGED {
        let v = num(name);
        let par1 = table::axis_param_par1(axis, param);
        // A controller that refuses the range leaves the value to its own check.
        let range = c.read_f64(0x1802, par1).and_then(|lo| Ok((lo, c.read_f64(0x1801, par1)?))).ok();
        let ok = v.is_some_and(|v| v.is_finite() && v > 0.0 && range.is_none_or(|(lo, hi)| v >= lo && v <= hi));
        let limit = match range {
            Some((lo, hi)) => format!("> 0, {lo} .. {hi}"),
            None => "> 0 (the controller gives no range)".into(),
        };
        let unit = live.settings.get(name).map(|s| s.unit.clone()).unwrap_or_default();
        ck.measure(name, json!(v), limit, &unit, ok);
    }
    ck
}

/// Online, released, the motion checks, back to home position.
fn motions_of(c: &mut Controller, axis: u8, plan: &DevicePlan, run: &mut Run) {
    let at = plan.address.as_str();
    let mut names = Vec::new();
    if plan.home.is_some() {
        names.push("home");
    }
    if plan.moves.is_some() {
        names.extend(["move_forward", "move_back"]);
    }
    if plan.halt.is_some() {
        names.push("halt");
    }
    if run.dry_run {
        return run.skip(at, &names, "dry run: not moved");
    }
    // Online mode as `pac-online` enters it; the axis is released by its
    // reference drive, or by 0A83 when the plan has none.
    if let Err(e) = c.online() {
        return run.skip(at, &names, &format!("not run: the controller did not go online (0603): {e}"));
    }
    let mut blocked: Option<String> = None;
    if plan.home.is_none() {
        if let Err(e) = c.send(0x0A83, axis.into(), None) {
            blocked = Some(format!("axis {axis} was not released (0A83): {e}"));
        }
    }
    for name in names {
        if run.interrupted {
            break;
        }
        let t = run.begin(at, name);
        if let Some(b) = &blocked {
            run.end(Check::new(at, name).skipped(format!("not run: {b}")), t);
            continue;
        }
        let ck = match name {
            "home" => reference(c, axis, at, plan, run),
            "halt" => halt_test(c, axis, at, plan, run),
            _ => test_move(c, axis, at, plan.moves.as_ref().expect("planned"), name == "move_forward", run),
        };
        if ck.status == Status::Fail && !ck.detail.is_empty() {
            blocked = Some(format!("{name} failed"));
        }
        run.end(ck, t);
    }
    // Back to home position (every axis stops where it is): where the
    // parameters are read, and where the controller was found.
    if let Err(e) = c.offline() {
        let t = run.begin(at, "offline");
        run.end(
            Check::new(at, "offline").fail(format!("the controller did not go back to home position (0A81): {e}")),
            t,
        );
    }
}

fn reference(c: &mut Controller, axis: u8, at: &str, plan: &DevicePlan, run: &mut Run) -> Check {
    let timeout = plan.home.as_ref().map_or(60.0, |h| h.timeout_s);
    let ck = Check::new(at, "home");
    let follow = Follow { poll: Duration::from_millis(20), limit: Duration::from_secs_f64(timeout) };
    let stop = run.stop;
    let t0 = run.clock.now();
    match c.reference_waited(axis, follow, &mut |_: &Progress| !stop()) {
        Ok(_) => {
            let secs = run.clock.now().saturating_duration_since(t0).as_secs_f64();
            let mut ck = ck;
            ck.measure("time to reference", json!(round6(secs)), format!("<= {timeout}"), "s", secs <= timeout);
            match c.read_f64(0x190C, axis.into()) {
                Ok(p) => ck.measure("position", json!(p), "any".into(), "AE", true),
                Err(e) => ck = ck.fail(format!("referenced; the position could not be read: {e}")),
            }
            ck
        }
        Err(e) => {
            if stop() {
                run.interrupted = true;
            }
            ck.fail(format!("reference drive 0A84: {e}"))
        }
    }
}

/// One recorded move and what happened around it.
#[derive(Default)]
struct Trace {
    t: Vec<f64>,
    pos: Vec<f64>,
    speed: Vec<f64>,
    status: Vec<f64>,
    following: Vec<f64>,
    /// When the stop went out (the halt test), recording time.
    stopped: Option<f64>,
    /// The first sample at rest after the motion.
    rest: Option<f64>,
}

impl Trace {
    fn sample(&mut self, c: &mut Controller, axis: u8, t: f64) -> Result<u64, String> {
        let read = |c: &mut Controller, code: u16| {
            c.read_f64(code, axis.into()).map_err(|e| format!("{code:04X} could not be read: {e}"))
        };
        let pos = read(c, 0x190C)?;
        let speed = read(c, 0x190D)?;
        let status = read(c, 0x1910)?;
        let following = read(c, 0x1915)?;
        self.t.push(t);
        self.pos.push(pos);
        self.speed.push(speed);
        self.status.push(status);
        self.following.push(following);
        Ok(status as u64)
    }
}

/// Moves axis `axis` to `target` under the face's `Moving` handle, sampled
/// from the acknowledge on; with `stop_after`, 0A9A goes out that long into
/// the move. Ends at rest (with a tail for the steady state), at the
/// timeout, on a fault or on a stop (`run.interrupted`): every end but rest
/// stops the axis (0A93) through the handle.
fn record_move(
    c: &mut Controller,
    axis: u8,
    target: f64,
    stop_after: Option<f64>,
    timeout: f64,
    run: &mut Run,
) -> Result<(f64, Trace), String> {
    let clock = run.clock.clone();
    let t0 = clock.now();
    let secs = |clock: &dyn crate::clock::Clock| clock.now().saturating_duration_since(t0).as_secs_f64();
    let targets = vec![MotionTarget::PacAxis(axis)];
    let (mut moving, start) = c
        .start(targets, 1, |d| d.start_move_supervised(axis, target, false, true))
        .map_err(|e| format!("the move 0A94 to {target} AE: {e}"))?;
    let mut tr = Trace::default();
    // The acknowledge's date is where the axis stood: the step's start.
    tr.t.push(0.0);
    tr.pos.push(start.start_position);
    tr.speed.push(0.0);
    tr.status.push(1.0);
    tr.following.push(0.0);
    let mut seen_moving = false;
    let failure = loop {
        if (run.stop)() {
            run.interrupted = true;
            break Some("interrupted".to_string());
        }
        let now = secs(clock.as_ref());
        let status = match tr.sample(&mut moving, axis, now) {
            Ok(s) => s,
            Err(e) => break Some(format!("lost track of axis {axis}: {e}")),
        };
        match status {
            1 => seen_moving = true,
            // In position (0), or stopped (2) after our stop.
            0 | 2 if (seen_moving || now >= 0.2) && tr.rest.is_none() && tr.speed.last() == Some(&0.0) => {
                tr.rest = Some(now)
            }
            0 | 2 => {}
            other => {
                break Some(format!("axis {axis} faulted: status {other} ({})", table::axis_status_text(other)));
            }
        }
        if let (Some(after), None) = (stop_after, tr.stopped) {
            if now >= after && tr.rest.is_none() {
                if let Err(e) = moving.send(0x0A9A, axis.into(), None) {
                    break Some(format!("STOP 0A9A FAILED: {e}"));
                }
                tr.stopped = Some(now);
            }
        }
        if let Some(r) = tr.rest {
            if now >= r + (0.1 * r).max(0.2) {
                break None;
            }
        }
        if now >= timeout {
            break Some(format!("not at rest after {timeout} s"));
        }
        clock.sleep(SAMPLE_EVERY);
    };
    match failure {
        None => {
            moving.completed();
            Ok((start.start_position, tr))
        }
        Some(why) => {
            let halted: Vec<String> = moving
                .halt()
                .into_iter()
                .map(|(_, r)| match r {
                    Ok(_) => "stopped (0A93)".to_string(),
                    Err(e) => format!("STOP FAILED: {e}"),
                })
                .collect();
            Err(format!("{why}, {}", halted.join(", ")))
        }
    }
}

fn test_move(c: &mut Controller, axis: u8, at: &str, plan: &Moves, forward: bool, run: &mut Run) -> Check {
    let name = if forward { "move_forward" } else { "move_back" };
    let mut ck = Check::new(at, name);
    let here = match c.read_f64(0x190C, axis.into()) {
        Ok(p) => p,
        Err(e) => return ck.fail(format!("190C could not be read: {e}")),
    };
    let [lo, hi] = plan.window;
    let target = if forward {
        if here + plan.distance <= hi {
            here + plan.distance
        } else {
            here - plan.distance
        }
    } else {
        run.checks
            .iter()
            .rev()
            .find(|c| c.device == at && c.check == "move_forward")
            .and_then(|f| f.measured.iter().find(|x| x.name == "start").and_then(|x| x.value.as_f64()))
            .unwrap_or(here)
    };
    if !(lo..=hi).contains(&target) || !(lo..=hi).contains(&here) {
        return ck.fail(format!("the move from {here} to {target} AE leaves the window [{lo}, {hi}]: not moved"));
    }
    let (start, tr) = match record_move(c, axis, target, None, plan.timeout_s, run) {
        Ok(v) => v,
        Err(e) => return ck.fail(e),
    };
    ck.measure("start", json!(start), "any".into(), "AE", true);
    ck.measure("target", json!(target), format!("[{lo}, {hi}]"), "AE", true);
    step_measures(&mut ck, plan, &tr.t, &tr.pos, target, "AE");
    if let Ok((v, _)) = super::figures::peak_abs(&tr.t, &tr.speed) {
        ck.measure("peak_speed", json!(round6(v)), "any".into(), "AE/s", true);
    }
    if let Ok((f, _)) = super::figures::peak_abs(&tr.t, &tr.following) {
        ck.measure("peak_following_error", json!(round6(f)), "any".into(), "AE", true);
    }
    attach(&mut ck, at, &tr, run);
    ck
}

/// A move of the plan's distance stopped (0A9A) `after_s` into it: the time
/// from the stop to the first sample at rest.
fn halt_test(c: &mut Controller, axis: u8, at: &str, plan: &DevicePlan, run: &mut Run) -> Check {
    let h = plan.halt.as_ref().expect("planned");
    let mut ck = Check::new(at, "halt");
    let here = match c.read_f64(0x190C, axis.into()) {
        Ok(p) => p,
        Err(e) => return ck.fail(format!("190C could not be read: {e}")),
    };
    let target = match halt_target(here, h.distance, plan.moves.as_ref().map(|m| m.window), "AE") {
        Ok(t) => t,
        Err(why) => return ck.fail(why),
    };
    let (_, tr) = match record_move(c, axis, target, Some(h.after_s), h.after_s + 30.0, run) {
        Ok(v) => v,
        Err(e) => return ck.fail(e),
    };
    if let Err(why) = measure_halt(&mut ck, h, (&tr.t, &tr.pos), (tr.stopped, tr.rest), ("stop", "AE")) {
        return ck.fail(why);
    }
    attach(&mut ck, at, &tr, run);
    ck
}

fn attach(ck: &mut Check, at: &str, tr: &Trace, run: &mut Run) {
    let columns = [
        Column { name: "position", unit: "AE", values: &tr.pos, plotted: true },
        Column { name: "speed", unit: "AE/s", values: &tr.speed, plotted: true },
        Column { name: "status", unit: "", values: &tr.status, plotted: false },
        Column { name: "following_error", unit: "AE", values: &tr.following, plotted: true },
    ];
    attach_recording(ck, at, &tr.t, &columns, run);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(text: &str) -> DevicePlan {
        super::super::plan::Plan::parse(text, "p").unwrap().device.remove(0)
    }

    #[test]
    fn what_the_controller_cannot_report_or_do_is_refused_before_anything_is_sent() {
        let axis = Address::Pac { axis: Some(1) };
        let cases = [
            ("identity = { serial = 3 }", "no type, serial number or firmware"),
            ("watchdog = true", "PowerCube's"),
            ("settings = { values = { traverse-sped = { value = 1.0 } } }", "traverse-sped"),
            ("move = { distance = 1.0, window = [0.0, 10.0], vel = 3.0 }", "traverse speed"),
        ];
        for (line, want) in cases {
            let p = plan(&format!("[[device]]\naddress = \"pac:1\"\n{line}\n"));
            let err = check_plan(axis, &p).unwrap_err();
            assert!(err.contains(want), "{line}: {err}");
        }
        let p = plan("[[device]]\naddress = \"pac\"\nhome = { timeout_s = 5 }\n");
        assert!(check_plan(Address::Pac { axis: None }, &p).unwrap_err().contains("does not move"));
        let p = plan("[[device]]\naddress = \"pac:1\"\nsettings = { values = { acceleration = { value = 1.0 } } }\n");
        assert_eq!(check_plan(axis, &p), Ok(()));
    }
}
