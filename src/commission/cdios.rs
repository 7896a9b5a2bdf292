//! The checks of a Cdios 6168 module (`cdios:NODE/MODULE`), in the plan's
//! order.
//!
//! What the node offers decides what is checked. The identity is what the
//! controller's identify answer (01h) says of the module's slot: its type
//! and version (`kind` and `firmware` in a plan, written `0x44` or `68`);
//! axisctl reads no serial number of a module, so a plan may not ask one.
//! The settings are the servo configuration, events and outputs a backup
//! holds. A 6168 has no reference drive and no position limits of its own
//! (its end switches are wiring): the limits check is the speed
//! configuration (minimum below maximum, both positive, within the
//! manual's ranges) and the encoder's pulses. The motions are gotos (23h)
//! at the configured speeds, the motor enabled first (start, option 5)
//! when it is not, and disabled again afterwards (stop, option 5) when the
//! run enabled it. A goto starts under the device face's `Moving` handle:
//! every way out of it other than a standstill read fast-stops the motor.
//!
//! A move is recorded as fast as the bus allows (paced to one sample every
//! 5 ms at most), one burst per sample: status, motor speed and RPM error,
//! position and setpoint.

use std::fmt::Display;
use std::time::Duration;

use serde_json::json;

use super::plan::{Band, DevicePlan, Moves, Settings};
use super::report::{Check, Status};
use super::{attach_recording, halt_target, measure_halt, round6, step_measures, Column, DefaultPlanError, Run};
use crate::backup::{self, Device};
use crate::bench::{Address, Bench};
use crate::device::cdios::{self as dev, Node, Slot};
use crate::device::face::{Face, MotionTarget};
use crate::device::registry::Sessions;
use crate::family::Family;
use crate::proto::cdios::table::{decode_status, POSITION_UNIT, SPEED_UNIT};
use crate::proto::cdios::{GotoMode, ModuleId, NodeId, StopOption};

/// How often a move is sampled at most.
const SAMPLE_EVERY: Duration = Duration::from_millis(5);

/// The speed settings the limits check reads.
const MIN_SPEED: &str = "speeds.minimum_speed";
const MAX_SPEED: &str = "speeds.maximum_speed";
const SLOPE: &str = "speeds.slope";
const PULSES: &str = "encoder.pulses_per_revolution";
const POSITIONING_ERROR: &str = "control.positioning_error";

/// What a Cdios plan may not ask, before anything is sent.
pub fn check_plan(plan: &DevicePlan) -> Result<(), String> {
    if plan.identity.serial.is_some() {
        return Err("axisctl reads the type and version of a Cdios module (identify, 01h), no serial number: \
                    leave identity.serial out"
            .into());
    }
    for (what, v) in [("kind", &plan.identity.kind), ("firmware", &plan.identity.firmware)] {
        if let Some(text) = v {
            if number(text).is_none() {
                return Err(format!(
                    "identity.{what} {text:?}: a Cdios module's type or version is a number (0x44, 68)"
                ));
            }
        }
    }
    if plan.home.is_some() {
        return Err("a Cdios module has no reference drive: leave home out".into());
    }
    if plan.watchdog {
        return Err("the watchdog check is the PowerCube's".into());
    }
    if let Some(m) = &plan.moves {
        if m.acc.is_some() {
            return Err("move.acc: a 6168 accelerates along its configured slope (speeds.slope)".into());
        }
        if m.vel.is_some_and(|v| v.fract() != 0.0 || v > f64::from(u16::MAX)) {
            return Err("move.vel is the goto's speed in whole RPM (0 to 65535)".into());
        }
    }
    // The backup's own check knows every name a backup holds.
    let known = |n: &str| !backup::cdios::check_file(&one_setting(n)).iter().any(|p| p.message.starts_with("unknown"));
    match plan.settings.as_ref().and_then(|s| s.values.keys().find(|n| !known(n))) {
        Some(name) => Err(format!("no Cdios setting {name:?} (the names `backup` writes, e.g. {MAX_SPEED})")),
        None => Ok(()),
    }
}

/// A device holding only `name`, with a value every setting accepts, for
/// asking the backup's own check whether the name is one it knows.
fn one_setting(name: &str) -> Device {
    let mut d = Device::new(Family::Cdios, "");
    d.settings.insert(name.into(), backup::Setting::new(json!(1), "", true));
    d
}

/// `0x44` or `68`.
fn number(text: &str) -> Option<i64> {
    let t = text.trim();
    match t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        Some(hex) => i64::from_str_radix(hex, 16).ok(),
        None => t.parse().ok(),
    }
}

pub fn motions(at: &str, plan: &DevicePlan) -> Vec<String> {
    let mut out = Vec::new();
    if plan.moves.is_some() || plan.halt.is_some() {
        out.push(format!("{at}: motor enabled (start, option 5) if it is not, disabled again after"));
    }
    if let Some(m) = &plan.moves {
        out.push(format!(
            "{at}: goto {} counts from where it stands and back, inside [{}, {}] counts",
            m.distance, m.window[0], m.window[1]
        ));
    }
    if let Some(h) = &plan.halt {
        out.push(format!("{at}: goto up to {} counts, fast-stopped {} s into it", h.distance, h.after_s));
    }
    out
}

pub fn planned(plan: &DevicePlan) -> Vec<&'static str> {
    let asked = [
        ("identity", true),
        ("settings", plan.settings.is_some()),
        ("limits", plan.limits),
        ("move_forward", plan.moves.is_some()),
        ("move_back", plan.moves.is_some()),
        ("halt", plan.halt.is_some()),
        ("backup", plan.backup),
    ];
    asked.into_iter().filter(|(_, on)| *on).map(|(name, _)| name).collect()
}

/// The nodes of the bench: node 1 (every command's default), each node
/// the bench file expects a module on, and each node of `only` (a plan of
/// the devices named); with `only`, its nodes alone.
fn nodes(bench: &Bench, only: &[Address]) -> Vec<u8> {
    let expected = bench.links().iter().filter(|l| l.carries(Family::Cdios)).flat_map(|l| l.devices.values());
    let of = |a: &Address| match a {
        Address::Cdios { node, .. } => Some(*node),
        _ => None,
    };
    let all: Vec<u8> = if only.is_empty() {
        std::iter::once(1).chain(expected.filter_map(of)).collect()
    } else {
        only.iter().filter_map(of).collect()
    };
    let mut nodes = Vec::new();
    for n in all {
        if !nodes.contains(&n) {
            nodes.push(n);
        }
    }
    nodes
}

/// The default plan for every module of every node found: its type and
/// version and speed configuration as they are, a goto of ten encoder
/// revolutions' pulses each way inside twice that around where it stands,
/// bands wide enough for its configured speeds, the steady state within
/// its configured positioning error, and a fast stop 0.2 s into such a
/// goto.
pub fn default_plan<S: Sessions>(
    sessions: &mut S,
    link: &str,
    bench: &Bench,
    only: &[Address],
) -> Result<Vec<DevicePlan>, DefaultPlanError<S::Error>> {
    let read = |e| DefaultPlanError::read(Family::Cdios, e);
    let mut out = Vec::new();
    for n in nodes(bench, only) {
        let Some(id) = NodeId::new(n) else { continue };
        let mut node = Node::new(sessions.cdios().map_err(DefaultPlanError::Open)?, id, Default::default());
        // A node that does not answer has no module to plan.
        let Ok(slots) = node.identify() else { continue };
        let wanted = |m: ModuleId| only.is_empty() || only.contains(&Address::Cdios { node: n, module: m.get() });
        for m in node.scan().map_err(read)?.into_iter().filter(|m| wanted(*m)) {
            let slot = slot_of(&slots, m);
            let live = backup::cdios::capture(&mut node, m, slot.ty, slot.version, link).map_err(read)?;
            let here = node.position(m, crate::proto::cdios::PositionSource::Current).map_err(read)?;
            out.push(default_module(Address::Cdios { node: n, module: m.get() }, slot, &live, f64::from(here)));
        }
    }
    Ok(out)
}

fn slot_of(slots: &[Slot], m: ModuleId) -> Slot {
    slots.iter().copied().find(|s| s.module == m.get()).unwrap_or(Slot { module: m.get(), ty: 0, version: 0 })
}

fn default_module(at: Address, slot: Slot, live: &Device, here: f64) -> DevicePlan {
    let num = |n: &str| live.settings.get(n).and_then(|s| s.value.as_f64()).unwrap_or(f64::NAN);
    let distance = (10.0 * num(PULSES)).max(1.0);
    let tolerance = num(POSITIONING_ERROR).max(1.0);
    let values = [MIN_SPEED, MAX_SPEED, SLOPE, PULSES, POSITIONING_ERROR]
        .into_iter()
        .map(|n| (n.to_string(), super::plan::Expected { value: num(n), tolerance: None }))
        .collect();
    DevicePlan {
        address: at.to_string(),
        identity: super::plan::Identity {
            kind: Some(format!("0x{:02X}", slot.ty)),
            serial: None,
            firmware: Some(format!("0x{:02X}", slot.version)),
        },
        settings: Some(Settings { backup: None, tolerance: 1e-6, values }),
        limits: true,
        home: None,
        moves: Some(Moves {
            distance,
            window: [here - 2.0 * distance, here + 2.0 * distance],
            vel: None,
            acc: None,
            band_percent: 2.0,
            timeout_s: 30.0,
            rise_time_s: Some(Band::max(5.0)),
            overshoot_percent: Some(Band::max(5.0)),
            settling_time_s: Some(Band::max(10.0)),
            steady_state_error: Some(Band { min: Some(-tolerance), max: Some(tolerance) }),
            time_to_reach_s: Some(Band::max(10.0)),
        }),
        halt: Some(super::plan::Halt { distance, after_s: 0.2, standstill_s: Band::max(0.5) }),
        watchdog: false,
        backup: true,
    }
}

/// The nodes of the run, each opened for its first module and kept.
#[derive(Default)]
pub struct Open(Vec<Node>);

impl Open {
    /// Runs module `module` of node `node`; `Err` when the bus cannot be opened.
    #[allow(clippy::too_many_arguments)]
    pub fn run<S>(
        &mut self,
        sessions: &mut S,
        node: u8,
        module: u8,
        plan: &DevicePlan,
        expected: Option<&Device>,
        run: &mut Run,
    ) -> Result<(), String>
    where
        S: Sessions,
        S::Error: Display,
    {
        let id = NodeId::new(node).ok_or_else(|| format!("node id {node} out of range"))?;
        let m = ModuleId::new(module).ok_or_else(|| format!("module id {module} out of range"))?;
        let i = match self.0.iter().position(|n| n.id() == id) {
            Some(i) => i,
            None => {
                let s = sessions.cdios().map_err(|e| format!("the Cdios link could not be opened: {e:#}"))?;
                self.0.push(Node::new(s, id, run.retry));
                self.0.len() - 1
            }
        };
        run_module(&mut self.0[i], m, plan, expected, run);
        Ok(())
    }
}

fn run_module(node: &mut Node, m: ModuleId, plan: &DevicePlan, expected: Option<&Device>, run: &mut Run) {
    let at = plan.address.as_str();
    let names = planned(plan);
    let t = run.begin(at, "identity");
    let read = node.identify().map(|slots| slot_of(&slots, m)).and_then(|slot| {
        let live = backup::cdios::capture(node, m, slot.ty, slot.version, &run.link_of(Family::Cdios))?;
        Ok((slot, live))
    });
    let (slot, live) = match read {
        Ok(v) => v,
        Err(e) => {
            run.end(Check::new(at, "identity").fail(format!("module {m} could not be read: {e}")), t);
            return run.skip(at, &names[1..], "not run: the module could not be read");
        }
    };
    let id = identity(at, plan, slot);
    let blocked = id.status != Status::Pass;
    run.end(id, t);
    if let Some(s) = &plan.settings {
        let t = run.begin(at, "settings");
        run.end(super::settings_check(at, s, expected, &live), t);
    }
    if plan.limits {
        let t = run.begin(at, "limits");
        run.end(limits(at, &live), t);
    }
    let mut motion: Vec<&'static str> = Vec::new();
    if plan.moves.is_some() {
        motion.extend(["move_forward", "move_back"]);
    }
    if plan.halt.is_some() {
        motion.push("halt");
    }
    if !motion.is_empty() && !run.interrupted {
        if run.dry_run {
            run.skip(at, &motion, "dry run: not moved");
        } else if blocked {
            run.skip(at, &motion, "not run: the identity is not the planned one");
        } else {
            motions_of(node, m, plan, &motion, run);
        }
    }
    if plan.backup && !run.interrupted {
        let t = run.begin(at, "backup");
        let ck = match backup::cdios::capture(node, m, slot.ty, slot.version, &run.link_of(Family::Cdios)) {
            Ok(d) => {
                run.backups.push(d);
                let mut c = Check::new(at, "backup");
                c.file = Some(super::BACKUP_FILE.into());
                c
            }
            Err(e) => Check::new(at, "backup").fail(format!("module {m} could not be read: {e}")),
        };
        run.end(ck, t);
    }
}

fn identity(at: &str, plan: &DevicePlan, slot: Slot) -> Check {
    let mut c = Check::new(at, "identity");
    let want = &plan.identity;
    for (name, got, want) in [("kind", slot.ty, &want.kind), ("firmware", slot.version, &want.firmware)] {
        let ok = want.as_deref().is_none_or(|w| number(w) == Some(got));
        c.measure(name, json!(format!("0x{got:02X}")), want.clone().unwrap_or_else(|| "any".into()), "", ok);
    }
    if slot.ty == 0 {
        c = c.fail("the controller's identify answer has no module in this slot");
    }
    c
}

/// Minimum speed below the maximum, both positive, the slope and the
/// encoder's pulses positive, each within the manual's range.
fn limits(at: &str, live: &Device) -> Check {
    let mut c = Check::new(at, "limits");
    let num = |n: &str| live.settings.get(n).and_then(|s| s.value.as_f64());
    let (lo, hi) = (num(MIN_SPEED), num(MAX_SPEED));
    let ok = matches!((lo, hi), (Some(a), Some(b)) if a < b);
    c.measure("maximum_speed - minimum_speed", json!(hi.zip(lo).map(|(b, a)| b - a)), "> 0".into(), SPEED_UNIT, ok);
    // The backup's own range check: the manual's range of each field.
    let problems = backup::cdios::check_file(live);
    for name in [MIN_SPEED, MAX_SPEED, SLOPE, PULSES] {
        let v = num(name);
        let out_of_range = problems.iter().any(|p| p.name == name);
        let ok = v.is_some_and(|v| v > 0.0) && !out_of_range;
        let unit = live.settings.get(name).map(|s| s.unit.clone()).unwrap_or_default();
        c.measure(name, json!(v), "> 0, within the manual's range".into(), &unit, ok);
    }
    c
}

fn motions_of(node: &mut Node, m: ModuleId, plan: &DevicePlan, names: &[&'static str], run: &mut Run) {
    let at = plan.address.as_str();
    let was_enabled = match node.status(m) {
        Ok(s) => s.flags.contains(&"ENABLED"),
        Err(e) => return run.skip(at, names, &format!("not run: the status could not be read: {e}")),
    };
    if !was_enabled {
        if let Err(e) = node.send(m, &dev::enable_commands(false)) {
            return run.skip(at, names, &format!("not run: the motor was not enabled: {e}"));
        }
    }
    let mut blocked: Option<String> = None;
    for name in names {
        if run.interrupted {
            break;
        }
        let t = run.begin(at, name);
        if let Some(b) = &blocked {
            run.end(Check::new(at, name).skipped(format!("not run: {b}")), t);
            continue;
        }
        let ck = match *name {
            "halt" => halt_test(node, m, at, plan, run),
            _ => test_move(node, m, at, plan.moves.as_ref().expect("planned"), *name == "move_forward", run),
        };
        if ck.status == Status::Fail && !ck.detail.is_empty() {
            blocked = Some(format!("{name} failed"));
        }
        run.end(ck, t);
    }
    // As it was found: a motor the run enabled is disabled again.
    if !was_enabled {
        if let Err(e) = node.send(m, &[dev::stop_command(StopOption::Disable, false)]) {
            let t = run.begin(at, "disable");
            run.end(Check::new(at, "disable").fail(format!("the motor was not disabled again: {e}")), t);
        }
    }
}

#[derive(Default)]
struct Trace {
    t: Vec<f64>,
    pos: Vec<f64>,
    setpoint: Vec<f64>,
    speed: Vec<f64>,
    rpm_error: Vec<f64>,
    stopped: Option<f64>,
    rest: Option<f64>,
}

/// A goto of `m` to `target` under the face's `Moving` handle, sampled from
/// its confirmation on; with `stop_after`, a fast stop goes out that long
/// into it. Ends at rest (with a tail for the steady state), at the
/// timeout, on an error flag or on a stop: every end but rest fast-stops
/// the motor through the handle.
fn record_goto(
    node: &mut Node,
    m: ModuleId,
    (target, speed): (f64, Option<f64>),
    stop_after: Option<f64>,
    timeout: f64,
    run: &mut Run,
) -> Result<Trace, String> {
    let attempts = run.halt_attempts;
    let tolerance = node.positioning_error(m).map_err(|e| format!("the positioning error could not be read: {e}"))?;
    let cmds = dev::goto_commands(GotoMode::Absolute, target.round() as i64, speed.map(|v| v as i64))
        .map_err(|e| e.to_string())?;
    let clock = run.clock.clone();
    let t0 = clock.now();
    let first = node.poll(m).map_err(|e| format!("module {m} could not be read: {e}"))?;
    let at = MotionTarget::Cdios { node: node.id(), module: m };
    let (mut moving, _) = node
        .start(vec![at], attempts, |n| n.send_supervised(m, &cmds, attempts))
        .map_err(|e| format!("the goto to {target} counts: {e}"))?;
    let mut tr = Trace::default();
    let push = |tr: &mut Trace, t: f64, r: &dev::Reading| {
        tr.t.push(t);
        tr.pos.push(r.position as f64);
        tr.setpoint.push(r.setpoint as f64);
        tr.speed.push(r.speed as f64);
        tr.rpm_error.push(r.rpm_error as f64);
    };
    push(&mut tr, 0.0, &first);
    let mut seen = false;
    let failure = loop {
        if (run.stop)() {
            run.interrupted = true;
            break Some("interrupted".to_string());
        }
        let now = clock.now().saturating_duration_since(t0).as_secs_f64();
        let r = match moving.poll(m) {
            Ok(r) => r,
            Err(e) => break Some(format!("lost track of module {m}: {e}")),
        };
        push(&mut tr, now, &r);
        let st = decode_status(r.status);
        if !st.errors.is_empty() {
            break Some(format!("module {m} faulted: {}", st.errors.join(", ")));
        }
        let active = st.flags.iter().any(|f| *f == "GOTO_ACTIVE" || f.starts_with("RUNNING_"));
        seen |= active;
        let near = (r.position as f64 - target).abs() <= tolerance as f64;
        if !active && r.speed == 0 && (seen || near) && tr.rest.is_none() {
            tr.rest = Some(now);
        }
        if let (Some(after), None, None) = (stop_after, tr.stopped, tr.rest) {
            if now >= after {
                if let Err(e) = moving.halt_motor(m, attempts) {
                    break Some(format!("FAST STOP FAILED: {e}"));
                }
                tr.stopped = Some(now);
            }
        }
        if let Some(rest) = tr.rest {
            if now >= rest + (0.1 * rest).max(0.2) {
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
            Ok(tr)
        }
        Some(why) => {
            let halted: Vec<String> = moving
                .halt()
                .into_iter()
                .map(|(_, r)| match r {
                    Ok(_) => "fast-stopped".to_string(),
                    Err(e) => format!("FAST STOP FAILED: {e}"),
                })
                .collect();
            Err(format!("{why}, {}", halted.join(", ")))
        }
    }
}

fn here(node: &mut Node, m: ModuleId) -> Result<f64, String> {
    node.position(m, crate::proto::cdios::PositionSource::Current)
        .map(f64::from)
        .map_err(|e| format!("the position could not be read: {e}"))
}

fn test_move(node: &mut Node, m: ModuleId, at: &str, plan: &Moves, forward: bool, run: &mut Run) -> Check {
    let name = if forward { "move_forward" } else { "move_back" };
    let mut ck = Check::new(at, name);
    let here = match here(node, m) {
        Ok(p) => p,
        Err(e) => return ck.fail(e),
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
        return ck.fail(format!("the goto from {here} to {target} counts leaves the window [{lo}, {hi}]: not moved"));
    }
    let tr = match record_goto(node, m, (target, plan.vel), None, plan.timeout_s, run) {
        Ok(t) => t,
        Err(e) => return ck.fail(e),
    };
    ck.measure("start", json!(here), "any".into(), POSITION_UNIT, true);
    ck.measure("target", json!(target), format!("[{lo}, {hi}]"), POSITION_UNIT, true);
    step_measures(&mut ck, plan, &tr.t, &tr.pos, target, POSITION_UNIT);
    if let Ok((v, _)) = super::figures::peak_abs(&tr.t, &tr.speed) {
        ck.measure("peak_speed", json!(round6(v)), "any".into(), SPEED_UNIT, true);
    }
    if let Ok((v, _)) = super::figures::peak_abs(&tr.t, &tr.rpm_error) {
        ck.measure("peak_rpm_error", json!(round6(v)), "any".into(), SPEED_UNIT, true);
    }
    attach(&mut ck, at, &tr, run);
    ck
}

fn halt_test(node: &mut Node, m: ModuleId, at: &str, plan: &DevicePlan, run: &mut Run) -> Check {
    let h = plan.halt.as_ref().expect("planned");
    let mut ck = Check::new(at, "halt");
    let here = match here(node, m) {
        Ok(p) => p,
        Err(e) => return ck.fail(e),
    };
    let target = match halt_target(here, h.distance, plan.moves.as_ref().map(|mv| mv.window), POSITION_UNIT) {
        Ok(t) => t,
        Err(why) => return ck.fail(why),
    };
    let vel = plan.moves.as_ref().and_then(|mv| mv.vel);
    let tr = match record_goto(node, m, (target, vel), Some(h.after_s), h.after_s + 30.0, run) {
        Ok(t) => t,
        Err(e) => return ck.fail(e),
    };
    if let Err(why) = measure_halt(&mut ck, h, (&tr.t, &tr.pos), (tr.stopped, tr.rest), ("stop", POSITION_UNIT)) {
        return ck.fail(why);
    }
    attach(&mut ck, at, &tr, run);
    ck
}

fn attach(ck: &mut Check, at: &str, tr: &Trace, run: &mut Run) {
    let columns = [
        Column { name: "position", unit: POSITION_UNIT, values: &tr.pos, plotted: true },
        Column { name: "setpoint", unit: POSITION_UNIT, values: &tr.setpoint, plotted: true },
        Column { name: "speed", unit: SPEED_UNIT, values: &tr.speed, plotted: true },
        Column { name: "rpm_error", unit: SPEED_UNIT, values: &tr.rpm_error, plotted: true },
    ];
    attach_recording(ck, at, &tr.t, &columns, run);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(line: &str) -> DevicePlan {
        let text = format!("[[device]]\naddress = \"cdios:1/0\"\n{line}\n");
        super::super::plan::Plan::parse(&text, "p").unwrap().device.remove(0)
    }

    #[test]
    fn what_a_6168_cannot_report_or_do_is_refused_before_anything_is_sent() {
        let cases = [
            ("identity = { serial = 3 }", "no serial number"),
            ("identity = { kind = \"stepper\" }", "is a number"),
            ("home = { timeout_s = 5 }", "no reference drive"),
            ("move = { distance = 1.0, window = [0.0, 10.0], acc = 3.0 }", "slope"),
            ("settings = { values = { \"speeds.maximum_sped\" = { value = 1.0 } } }", "maximum_sped"),
        ];
        for (line, want) in cases {
            let err = check_plan(&plan(line)).unwrap_err();
            assert!(err.contains(want), "{line}: {err}");
        }
        let ok = plan("identity = { kind = \"0x44\", firmware = \"32\" }\nsettings = { values = { \"speeds.maximum_speed\" = { value = 8000 } } }");
        assert_eq!(check_plan(&ok), Ok(()));
        assert_eq!((number("0x44"), number("68"), number("x")), (Some(68), Some(68), None));
    }
}
