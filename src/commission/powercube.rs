//! The checks of one PowerCube module, in the plan's order. Reads go
//! through `backup::powercube::capture` (the same identity and settings a
//! backup holds); homing through the supervised Home and wait; the test
//! moves and the halt test through a recording (`record::CubeSampler`) on
//! the same link, each motion started with `move_supervised` after the
//! first sample and halted on every way out.

use std::cell::Cell;
use std::time::Duration;

use serde_json::{json, Value};

use super::figures;
use super::plan::{Band, DevicePlan, Expected, Halt, Home, Identity, Moves, Settings};
use super::report::{Check, Status};
use super::DefaultPlanError;
use super::Run;
use super::{halt_target, measure_halt, round6, sig, sig7};
use crate::address::Address;
use crate::backup::{self, Device};
use crate::device::face::{MotionTarget, Moving};
use crate::device::powercube::{self as cube_dev, Cubes, Goal, Move, WaitSpec};
use crate::device::registry::Sessions;
use crate::family::Family;
use crate::plot;
use crate::proto::powercube::flags::{state, CUBE_STATE};
use crate::proto::powercube::table::{self, ids};
use crate::proto::powercube::ModuleId;
use crate::record::powercube::CubeSampler;
use crate::record::{self, Pace, Sample, Sampler, Until};

/// Motion checks of a device, in order.
const MOTION_CHECKS: [&str; 4] = ["home", "move_forward", "move_back", "halt"];

/// What a PowerCube plan may not ask: a setting the module does not have.
pub fn check_plan(plan: &DevicePlan) -> Result<(), String> {
    match plan.settings.as_ref().and_then(|s| s.values.keys().find(|n| !known_setting(n))) {
        Some(name) => Err(format!("no PowerCube parameter {name:?}")),
        None => Ok(()),
    }
}

/// The motions the plan makes on module `at`, as the confirmation lists them.
pub fn motions(at: &str, plan: &DevicePlan) -> Vec<String> {
    let unit = unit_of(plan.identity.kind.as_deref());
    let mut out = Vec::new();
    if plan.home.is_some() {
        out.push(format!("{at}: home"));
    }
    if let Some(m) = &plan.moves {
        out.push(format!(
            "{at}: ramp {} {unit} from where it stands and back, inside [{}, {}] {unit}",
            m.distance, m.window[0], m.window[1]
        ));
    }
    if let Some(h) = &plan.halt {
        out.push(format!("{at}: ramp up to {} {unit}, halted {} s into it", h.distance, h.after_s));
    }
    if plan.watchdog {
        out.push(format!("{at}: watchdog switched on, left to trip, reset (no motion)"));
    }
    out
}

/// The checks a plan asks of a module, in the order they run.
pub fn planned(plan: &DevicePlan) -> Vec<&'static str> {
    let asked = [
        ("identity", true),
        ("settings", plan.settings.is_some()),
        ("limits", plan.limits),
        ("home", plan.home.is_some()),
        ("move_forward", plan.moves.is_some()),
        ("move_back", plan.moves.is_some()),
        ("halt", plan.halt.is_some()),
        ("watchdog", plan.watchdog),
        ("backup", plan.backup),
    ];
    asked.into_iter().filter(|(_, on)| *on).map(|(name, _)| name).collect()
}

/// The PowerCube bus of the run: opened for the first module, kept for the
/// next, opened again after a module lost it.
#[derive(Default)]
pub struct Open(Option<Cubes>);

impl Open {
    /// Runs module `module`'s plan; `Err` when the bus cannot be opened.
    pub fn run<S>(
        &mut self,
        sessions: &mut S,
        module: u8,
        plan: &DevicePlan,
        expected: Option<&Device>,
        run: &mut Run,
    ) -> Result<(), String>
    where
        S: Sessions,
        S::Error: std::fmt::Display,
    {
        let m = ModuleId::new(module).ok_or_else(|| format!("module id {module} out of range"))?;
        let cubes = match self.0.take() {
            Some(c) => c,
            None => {
                Cubes::new(sessions.powercube().map_err(|e| format!("the PowerCube link could not be opened: {e:#}"))?)
            }
        };
        self.0 = run_module(cubes, m, &plan.address, plan, expected, run);
        Ok(())
    }
}

/// The default plan for every module found: its identity and limits as
/// they are, homing, a move of a tenth of its range each way at half its
/// speed and acceleration inside its limits, with bands from the ramp's
/// own duration, and a halt test half-way into such a move. With `only`
/// (`commission -d`), the modules it names, read without a scan of the
/// bus: one that does not answer ends the plan with its timeout.
pub fn default_plan<S>(
    sessions: &mut S,
    link: &str,
    only: &[Address],
) -> Result<Vec<DevicePlan>, DefaultPlanError<S::Error>>
where
    S: Sessions,
{
    let read = |e| DefaultPlanError::read(Family::PowerCube, e);
    let mut cubes = Cubes::new(sessions.powercube().map_err(DefaultPlanError::Open)?);
    let mut device = Vec::new();
    let named: Vec<ModuleId> = only
        .iter()
        .filter_map(|a| match a {
            Address::PowerCube { module } => ModuleId::new(*module),
            _ => None,
        })
        .collect();
    let modules = if only.is_empty() { cubes.present().map_err(read)? } else { named };
    for m in modules {
        let live = backup::powercube::capture(&mut cubes, m, link).map_err(read)?;
        device.push(default_device(m, &live));
    }
    Ok(device)
}

fn default_device(m: ModuleId, live: &Device) -> DevicePlan {
    let num = |n: &str| live.settings.get(n).and_then(|s| s.value.as_f64()).unwrap_or(f64::NAN);
    let text = |k: &str| live.identity.get(k).and_then(|v| v.as_str()).map(str::to_string);
    let (lo, hi) = (num("MinPos"), num("MaxPos"));
    let (vel, acc) = (sig(num("MaxVel") / 2.0), sig(num("MaxAcc") / 2.0));
    let distance = sig((hi - lo) / 10.0);
    let ramp = super::ramp_duration(distance, vel, acc);
    let values = ["MinPos", "MaxPos", "MaxVel", "MaxAcc", "MaxCur"]
        .into_iter()
        .map(|n| (n.to_string(), Expected { value: sig7(num(n)), tolerance: None }))
        .collect();
    let slack = sig(ramp + 1.0);
    DevicePlan {
        address: crate::bench::Address::PowerCube { module: m.get() }.to_string(),
        identity: Identity {
            kind: text("type"),
            serial: live.identity.get("serial").and_then(|v| v.as_u64()),
            firmware: text("version"),
        },
        settings: Some(Settings { backup: None, tolerance: 1e-6, values }),
        limits: true,
        home: Some(Home { timeout_s: 30.0 }),
        moves: Some(Moves {
            distance,
            window: [sig7(lo), sig7(hi)],
            vel: Some(vel),
            acc: Some(acc),
            band_percent: 2.0,
            timeout_s: sig(ramp * 3.0 + 5.0),
            rise_time_s: Some(Band::max(sig(ramp))),
            overshoot_percent: Some(Band::max(5.0)),
            settling_time_s: Some(Band::max(slack)),
            steady_state_error: Some(Band { min: Some(-sig(distance / 100.0)), max: Some(sig(distance / 100.0)) }),
            time_to_reach_s: Some(Band::max(slack)),
        }),
        halt: Some(Halt { distance, after_s: sig(ramp / 2.0), standstill_s: Band::max(0.5) }),
        watchdog: false,
        backup: true,
    }
}

/// Runs the plan's checks on module `m` (`at` is its address as the report
/// says it); `expected`: the plan's backup file's device, if any. Returns
/// the handle for the next module, `None` when the link was lost with it.
fn run_module(
    mut cubes: Cubes,
    m: ModuleId,
    at: &str,
    plan: &DevicePlan,
    expected: Option<&Device>,
    run: &mut Run,
) -> Option<Cubes> {
    // Identity, settings and limits come from one read of the module.
    let t = run.begin(at, "identity");
    let live = match backup::powercube::capture(&mut cubes, m, &run.link_of(Family::PowerCube)) {
        Ok(d) => d,
        Err(e) => {
            run.end(Check::new(at, "identity").fail(format!("module {m} could not be read: {e}")), t);
            // The rest of its plan is said, not silently dropped.
            run.skip(at, &planned(plan)[1..], "not run: the module could not be read");
            return Some(cubes);
        }
    };
    let id = identity(at, plan, &live);
    // Not the module ordered: its plan's motions may not suit it.
    let mut blocked = (id.status != Status::Pass).then(|| "the identity is not the planned one".to_string());
    run.end(id, t);
    if let Some(s) = &plan.settings {
        let t = run.begin(at, "settings");
        run.end(super::settings_check(at, s, expected, &live), t);
    }
    if plan.limits {
        let t = run.begin(at, "limits");
        run.end(limits(at, &live), t);
    }
    let unit = live.settings.get("MaxPos").map(|s| s.unit.clone()).unwrap_or_default();
    let mut cubes = Some(cubes);
    for name in MOTION_CHECKS {
        let planned = match name {
            "home" => plan.home.is_some(),
            "move_forward" | "move_back" => plan.moves.is_some(),
            _ => plan.halt.is_some(),
        };
        if !planned || run.interrupted {
            continue;
        }
        let t = run.begin(at, name);
        let c = Check::new(at, name);
        let why_not = if run.dry_run {
            Some("dry run: not moved".to_string())
        } else if let Some(b) = &blocked {
            Some(format!("not run: {b}"))
        } else if cubes.is_none() {
            Some("not run: the link was lost".to_string())
        } else {
            None
        };
        if let Some(why) = why_not {
            run.end(c.skipped(why), t);
            continue;
        }
        let mut cs = cubes.take().expect("checked above");
        let c = match name {
            "home" => {
                let c = home(&mut cs, m, at, plan, run);
                cubes = Some(cs);
                c
            }
            "halt" => {
                let (back, c) = halt_test(cs, m, at, plan, &unit, run);
                cubes = back;
                c
            }
            _ => {
                let forward = name == "move_forward";
                let (back, c) = test_move(cs, m, at, plan.moves.as_ref().expect("planned"), forward, &unit, run);
                cubes = back;
                c
            }
        };
        // A motion that went wrong (an error, said in `detail`) leaves the
        // module in a state nobody planned: no further motion. Figures out
        // of their bands are measured, not errors: the next move runs.
        if c.status == Status::Fail && !c.detail.is_empty() {
            blocked = Some(format!("{name} failed"));
        }
        run.end(c, t);
    }
    let mut cubes = cubes?;
    if plan.watchdog && !run.interrupted {
        let t = run.begin(at, "watchdog");
        // Tripping it faults the module: not on a module not to be moved.
        let c = match (&blocked, run.dry_run) {
            (_, true) => Check::new(at, "watchdog").skipped("dry run"),
            (Some(b), false) => Check::new(at, "watchdog").skipped(format!("not run: {b}")),
            (None, false) => watchdog(&mut cubes, m, at),
        };
        run.end(c, t);
    }
    if plan.backup && !run.interrupted {
        let t = run.begin(at, "backup");
        let c = match backup::powercube::capture(&mut cubes, m, &run.link_of(Family::PowerCube)) {
            Ok(d) => {
                run.backups.push(d);
                let mut c = Check::new(at, "backup");
                c.file = Some(super::BACKUP_FILE.into());
                c
            }
            Err(e) => Check::new(at, "backup").fail(format!("module {m} could not be read: {e}")),
        };
        run.end(c, t);
    }
    Some(cubes)
}

fn identity(at: &str, plan: &DevicePlan, live: &Device) -> Check {
    let mut c = Check::new(at, "identity");
    let got = |k: &str| live.identity.get(k).cloned().unwrap_or(Value::Null);
    let want = &plan.identity;
    let kind = got("type");
    c.measure(
        "kind",
        kind.clone(),
        text_or_any(want.kind.as_ref()),
        "",
        want.kind.as_ref().is_none_or(|k| kind == json!(k)),
    );
    let serial = got("serial");
    let ok = want.serial.is_none_or(|s| serial.as_u64() == Some(s));
    c.measure("serial", serial, text_or_any(want.serial.as_ref()), "", ok);
    let fw = got("version");
    let ok = want.firmware.as_ref().is_none_or(|f| fw == json!(f));
    c.measure("firmware", fw, text_or_any(want.firmware.as_ref()), "", ok);
    c
}

pub(super) fn text_or_any<T: ToString>(v: Option<&T>) -> String {
    v.map_or_else(|| "any".to_string(), |v| v.to_string())
}

fn num(live: &Device, name: &str) -> Option<f64> {
    live.settings.get(name).and_then(|s| s.value.as_f64())
}

/// Min below max; speed, acceleration and current positive and within the
/// ROM's range (the module clips a written limit to it, so a value outside
/// says the module is not what it claims or the read is wrong).
fn limits(at: &str, live: &Device) -> Check {
    let mut c = Check::new(at, "limits");
    let unit = |n: &str| live.settings.get(n).map(|s| s.unit.clone()).unwrap_or_default();
    let (min, max) = (num(live, "MinPos"), num(live, "MaxPos"));
    let ok = matches!((min, max), (Some(a), Some(b)) if a < b);
    c.measure("MaxPos - MinPos", json!(max.zip(min).map(|(b, a)| b - a)), "> 0".into(), &unit("MaxPos"), ok);
    let ranged: [(&str, Option<&str>, &str); 5] = [
        ("MinPos", Some("DefMinPos"), "DefMaxPos"),
        ("MaxPos", Some("DefMinPos"), "DefMaxPos"),
        ("MaxVel", Some("DefMinVel"), "DefMaxVel"),
        ("MaxAcc", Some("DefMinAcc"), "DefMaxAcc"),
        ("MaxCur", None, "DefMaxCur"),
    ];
    for (name, lo, hi) in ranged {
        let v = num(live, name);
        let lo_v = lo.and_then(|l| num(live, l));
        let hi_v = num(live, hi);
        // Positions may be negative; speeds, accelerations and currents not.
        let positive = !name.ends_with("Pos");
        let floor = match (lo_v, positive) {
            (Some(l), true) => Some(l.max(0.0)),
            (l, _) => l,
        };
        let ok = v.is_some_and(|v| {
            (!positive || v > 0.0) && floor.is_none_or(|l| v >= l) && hi_v.is_none_or(|h| v <= h) && v.is_finite()
        });
        let limit = match (floor, hi_v) {
            (Some(l), Some(h)) if positive => format!("> 0, {l} .. {h}"),
            (Some(l), Some(h)) => format!("{l} .. {h}"),
            (None, Some(h)) => format!("> 0, <= {h}"),
            _ => "a value".into(),
        };
        c.measure(name, json!(v), limit, &unit(name), ok);
    }
    c
}

fn home(cubes: &mut Cubes, m: ModuleId, at: &str, plan: &DevicePlan, run: &mut Run) -> Check {
    let timeout = plan.home.as_ref().map_or(30.0, |h| h.timeout_s);
    let mut c = Check::new(at, "home");
    if let Err(e) = cubes.home_supervised(m, run.halt_attempts) {
        return c.fail(format!("Home: {e}"));
    }
    let spec = WaitSpec {
        poll: Duration::from_millis(20),
        timeout: Duration::from_secs_f64(timeout),
        halt_attempts: run.halt_attempts,
    };
    let stop = run.stop;
    // A panic in the wait halts the module; the wait halts on its own errors.
    let waited = Moving::new(cubes, vec![MotionTarget::Cube(m)], spec.halt_attempts)
        .follow(|cs| cs.wait(m, Goal::Homed, spec, stop, &mut |_, _| {}));
    let released = cubes.release_deadman();
    match waited {
        Ok(end) => {
            let secs = end.elapsed.as_secs_f64();
            c.measure("time to home", json!(round6(secs)), format!("<= {timeout}"), "s", secs <= timeout);
            c.measure("position", json!(round6(f64::from(end.position))), "any".into(), "", true);
            if let Err(e) = released {
                c = c.fail(format!("homed, but the dead-man backstop was not released: {e}"));
            }
            c
        }
        Err(e) => {
            if stop() {
                run.interrupted = true;
            }
            c.fail(super::with_causes(&e))
        }
    }
}

/// One recorded ramp: its samples and what happened around it.
#[derive(Default)]
struct Trace {
    t: Vec<f64>,
    pos: Vec<f64>,
    vel: Vec<f64>,
    cur: Vec<f64>,
    state: Vec<u32>,
    /// When the ramp was acknowledged (s, recording time).
    started: Option<f64>,
    /// When the Halt went out (the halt test).
    halted: Option<f64>,
    /// The first sample at rest after the end of the motion.
    rest: Option<f64>,
    /// A sample showed the motion (MOTION set): a sample at rest before
    /// that one was read before the module took the ramp.
    seen_motion: bool,
    unit: String,
}

/// Points per line of a report's plot.
const PLOT_POINTS: usize = 1500;

/// The recorded ramps take at most 2000 samples a second. Back to back a
/// real bus gives fewer (about 1400 at 1 Mbit/s: four reads and their
/// answers per sample), so this binds only on a link faster than any real
/// one: the in-process simulator answers at once, and without it gave
/// 60 000 a second, megabytes of CSV per move and a core kept busy.
const MIN_SAMPLE_GAP: Duration = Duration::from_micros(500);

const REC_PARAMS: [u8; 4] = [ids::ACT_POS, ids::ACT_VEL, ids::CUR, ids::CUBE_STATE];

/// Records a ramp of `m` to `target` from its first sample on; with
/// `halt_after`, a Halt goes out that long after the start. Ends once the
/// module rests (and a tail for the steady state has been sampled), at the
/// timeout (halted), or on a stop (halted, `run.interrupted`).
fn record_ramp(
    cubes: Cubes,
    m: ModuleId,
    mv: Move,
    halt_after: Option<f64>,
    timeout: f64,
    run: &mut Run,
) -> (Option<Cubes>, Result<Trace, String>) {
    let params: Vec<_> = REC_PARAMS.iter().map(|id| cube_dev::param(*id)).collect();
    let mut s = match CubeSampler::new(cubes, &[m], &params) {
        Ok(s) => s,
        Err(e) => return (None, Err(format!("the recording could not start: {e}"))),
    };
    let mut trace = Trace { unit: s.channels()[0].unit.clone(), ..Trace::default() };
    let attempts = run.halt_attempts;
    let done = Cell::new(false);
    let mut failed: Cell<Option<String>> = Cell::new(None);
    let stop = run.stop;
    let clock = run.clock.clone();
    // Armed before the ramp starts (after the first sample): a panic's
    // unwind halts it; every other end is weighed below.
    let mut faced = record::Recording::new(&mut s);
    let ended = Moving::new(&mut faced, vec![MotionTarget::Cube(m)], attempts).follow(|r| {
        let s = r.sampler();
        let mut sink = |sample: &Sample, s: &mut CubeSampler| -> Result<(), record::RecordError> {
            let v = &sample.values;
            let st = if v[3].is_finite() { v[3] as u32 } else { 0 };
            trace.t.push(sample.t);
            trace.pos.push(v[0]);
            trace.vel.push(v[1]);
            trace.cur.push(v[2]);
            trace.state.push(st);
            if trace.started.is_none() {
                s.cubes().move_supervised(m, mv, false, false, attempts)?;
                trace.started = Some(sample.t);
                return Ok(());
            }
            let since = sample.t - trace.started.unwrap_or(0.0);
            if let (Some(after), None) = (halt_after, trace.halted) {
                if since >= after {
                    if let Err(e) = s.cubes().halt_retrying(m, attempts) {
                        failed.set(Some(format!("HALT FAILED: {e}")));
                        done.set(true);
                    }
                    trace.halted = Some(sample.t);
                    return Ok(());
                }
            }
            // The error flags as the waits read them (a following error
            // too large is STATE_TOW_ERROR).
            let decoded = CUBE_STATE.decode(st);
            if decoded.has_error() {
                let names = decoded.errors.join(", ");
                failed.set(Some(format!("the module faulted: {names} (CubeState 0x{st:08x})")));
                done.set(true);
            }
            trace.seen_motion |= st & state::MOTION != 0;
            let resting = st & state::MOTION == 0 && v[1].abs() <= 1e-9;
            let ended = trace.halted.is_some() || st & state::RAMP_END != 0;
            if resting && trace.seen_motion && ended && trace.rest.is_none() {
                trace.rest = Some(sample.t);
            }
            // A tail after the rest for the steady state: a tenth of
            // the motion's time, at least 0.2 s.
            if let Some(r) = trace.rest {
                let tail = (0.1 * (r - trace.started.unwrap_or(0.0))).max(0.2);
                if sample.t >= r + tail {
                    done.set(true);
                }
            }
            Ok(())
        };
        let until = Until::Elapsed(Duration::from_secs_f64(timeout));
        let pace = Pace::BackToBack { min_gap: MIN_SAMPLE_GAP };
        record::record(s, clock.as_ref(), pace, until, &|| stop() || done.get(), &mut sink)
    });
    let interrupted = stop();
    // The motion is halted unless it came to rest by itself and nothing
    // else went wrong: the same rule as `record -- move-ramp`.
    let rested = trace.rest.is_some() && ended.is_ok() && !interrupted && failed.get_mut().is_none();
    let halt = if trace.started.is_some() && !rested { Some(s.cubes().halt_retrying(m, attempts)) } else { None };
    let released = s.cubes().release_deadman();
    if interrupted {
        run.interrupted = true;
    }
    let halt_note = match &halt {
        Some(Ok(())) => ", halted".to_string(),
        Some(Err(e)) => format!(", HALT FAILED: {e}"),
        None => String::new(),
    };
    let cubes = s.into_cubes();
    let result = match (ended, failed.into_inner()) {
        (Err(e), _) => Err(format!("{e}{halt_note}")),
        (Ok(_), _) if interrupted => Err(format!("interrupted{halt_note}")),
        (Ok(_), Some(f)) => Err(format!("{f}{halt_note}")),
        (Ok(_), None) if trace.rest.is_none() => Err(format!("not at rest after {timeout} s{halt_note}")),
        (Ok(_), None) => match released {
            Err(e) => Err(format!("the dead-man backstop was not released: {e}")),
            Ok(()) => Ok(trace),
        },
    };
    (Some(cubes), result)
}

/// Where the module stands now.
fn position(cubes: &mut Cubes, m: ModuleId) -> Result<f64, String> {
    cubes.read_now(m, &[ids::ACT_POS]).map(|v| v[0]).map_err(|e| format!("ActPos could not be read: {e}"))
}

/// Forward: `distance` from where it stands, towards the side with room
/// (up first if it fits); back: to where the forward move started.
fn test_move(
    mut cubes: Cubes,
    m: ModuleId,
    at: &str,
    plan: &Moves,
    forward: bool,
    unit: &str,
    run: &mut Run,
) -> (Option<Cubes>, Check) {
    let name = if forward { "move_forward" } else { "move_back" };
    let c = Check::new(at, name);
    let here = match position(&mut cubes, m) {
        Ok(p) => p,
        Err(e) => return (Some(cubes), c.fail(e)),
    };
    let [lo, hi] = plan.window;
    let target = if forward {
        if here + plan.distance <= hi {
            here + plan.distance
        } else {
            here - plan.distance
        }
    } else {
        match run.checks.iter().rev().find(|c| c.device == at && c.check == "move_forward") {
            Some(f) => f.measured.iter().find(|x| x.name == "start").and_then(|x| x.value.as_f64()).unwrap_or(here),
            None => here,
        }
    };
    if !(lo..=hi).contains(&target) || !(lo..=hi).contains(&here) {
        let text = format!("the move from {here:.6} to {target:.6} {unit} leaves the window [{lo}, {hi}]: not moved");
        return (Some(cubes), c.fail(text));
    }
    let mv = Move::Ramp { pos: target, vel: plan.vel, acc: plan.acc };
    let (back, trace) = record_ramp(cubes, m, mv, None, plan.timeout_s, run);
    let trace = match trace {
        Ok(t) => t,
        Err(e) => return (back, c.fail(e)),
    };
    (back, move_check(c, at, plan, here, target, &trace, run))
}

/// The figures of a recorded move against the plan's bands.
fn move_check(mut c: Check, at: &str, plan: &Moves, here: f64, target: f64, tr: &Trace, run: &mut Run) -> Check {
    let unit = tr.unit.as_str();
    c.measure("start", json!(here), "any".into(), unit, true);
    c.measure("target", json!(target), format!("[{}, {}]", plan.window[0], plan.window[1]), unit, true);
    // Figures from the acknowledge on: the sample before it is the start.
    let from = tr.t.iter().position(|t| Some(*t) >= tr.started).unwrap_or(0).saturating_sub(1);
    let (t, y) = (&tr.t[from..], &tr.pos[from..]);
    let band = |b: &Option<Band>, name: &str, v: Option<f64>, unit: &str, c: &mut Check| {
        let limit = b.map_or_else(|| "any".to_string(), |b| b.text());
        let ok = match (b, v) {
            (Some(b), Some(v)) => b.holds(v),
            (Some(_), None) => false,
            (None, _) => true,
        };
        c.measure(name, json!(v.map(round6)), limit, unit, ok);
    };
    match figures::step(t, y, target, plan.band_percent / 100.0) {
        Ok(f) => {
            band(&plan.rise_time_s, "rise_time", f.rise_time, "s", &mut c);
            band(&plan.overshoot_percent, "overshoot", Some(f.overshoot_percent), "%", &mut c);
            band(&plan.settling_time_s, "settling_time", f.settling_time, "s", &mut c);
            band(&plan.steady_state_error, "steady_state_error", Some(f.steady_state_error), unit, &mut c);
            band(&plan.time_to_reach_s, "time_to_reach", f.time_to_reach, "s", &mut c);
        }
        Err(e) => c = c.fail(format!("no figures: {e}")),
    }
    if let Ok((v, _)) = figures::peak_abs(&tr.t, &tr.vel) {
        c.measure("peak_speed", json!(round6(v)), "any".into(), &format!("{unit}/s"), true);
    }
    if let Ok((a, _)) = figures::peak_abs(&tr.t, &tr.cur) {
        c.measure("peak_current", json!(round6(a)), "any".into(), "A", true);
    }
    attach(&mut c, at, tr, run);
    c
}

/// The recording as CSV beside the report, and its plot for the HTML.
fn attach(c: &mut Check, at: &str, tr: &Trace, run: &mut Run) {
    let file = format!("{}-{}.csv", at.replace([':', '/'], "-"), c.check);
    let mut csv = format!("t [s],ActPos [{u}],ActVel [{u}/s],Cur [A],CubeState\n", u = tr.unit);
    for i in 0..tr.t.len() {
        csv += &format!("{},{},{},{},{}\n", tr.t[i], tr.pos[i], tr.vel[i], tr.cur[i], tr.state[i]);
    }
    run.files.push((file.clone(), csv));
    c.recording = Some(file);
    // A bus read back to back gives thousands of samples a second: the
    // plot keeps every k-th (and the last), the CSV all of them.
    let every = tr.t.len().div_ceil(PLOT_POINTS).max(1);
    let series = |name: &str, unit: &str, v: &[f64]| plot::Series {
        name: format!("{at} {name}"),
        unit: Some(unit.to_string()),
        points: tr
            .t
            .iter()
            .copied()
            .zip(v.iter().copied())
            .enumerate()
            .filter(|(i, _)| i % every == 0 || i + 1 == tr.t.len())
            .map(|(_, p)| p)
            .collect(),
    };
    let chart = plot::Chart {
        title: format!("{at} {}", c.check),
        x_label: "t (s)".into(),
        series: vec![
            series("ActPos", &tr.unit, &tr.pos),
            series("ActVel", &format!("{}/s", tr.unit), &tr.vel),
            series("Cur", "A", &tr.cur),
        ],
    };
    c.svg = plot::svg(&chart, 900, 520).ok();
}

/// A ramp of the plan's distance halted `after_s` into it: the time from
/// the Halt to the first sample at rest.
fn halt_test(
    mut cubes: Cubes,
    m: ModuleId,
    at: &str,
    plan: &DevicePlan,
    unit: &str,
    run: &mut Run,
) -> (Option<Cubes>, Check) {
    let h = plan.halt.as_ref().expect("planned");
    let mut c = Check::new(at, "halt");
    let here = match position(&mut cubes, m) {
        Ok(p) => p,
        Err(e) => return (Some(cubes), c.fail(e)),
    };
    // Inside the move window when there is one, else the module's limits
    // (the device layer refuses a ramp beyond them anyway).
    let target = match halt_target(here, h.distance, plan.moves.as_ref().map(|mv| mv.window), unit) {
        Ok(t) => t,
        Err(why) => return (Some(cubes), c.fail(why)),
    };
    let (vel, acc) = plan.moves.as_ref().map_or((None, None), |mv| (mv.vel, mv.acc));
    let mv = Move::Ramp { pos: target, vel, acc };
    let timeout = h.after_s + 30.0;
    let (back, trace) = record_ramp(cubes, m, mv, Some(h.after_s), timeout, run);
    let tr = match trace {
        Ok(t) => t,
        Err(e) => return (back, c.fail(e)),
    };
    if let Err(why) = measure_halt(&mut c, h, (&tr.t, &tr.pos), (tr.halted, tr.rest), ("halt", unit)) {
        return (back, c.fail(why));
    }
    attach(&mut c, at, &tr, run);
    // The test halted it, and it stands: the Halt state is the test's, not
    // a finding, so a Reset leaves the module ready as it was found (a run
    // after this one moves it again).
    let Some(mut cubes) = back else { return (None, c) };
    if let Err(e) = reset(&mut cubes, m, run.halt_attempts) {
        c = c.fail(format!("standstill measured; the Reset after it failed: {e}"));
    }
    (Some(cubes), c)
}

/// A Reset, sent again while its acknowledge is lost: it moves nothing,
/// and resetting twice is harmless (a loaded bus loses one now and then).
fn reset(cubes: &mut Cubes, m: ModuleId, attempts: u32) -> Result<(), cube_dev::Error> {
    let mut left = attempts.max(1);
    loop {
        left -= 1;
        match cubes.simple(Some(m), cube_dev::Simple::Reset) {
            Err(e) if left > 0 && e.kind() == crate::session::ErrorKind::Timeout => continue,
            other => return other,
        }
    }
}

/// The watchdog trips (CubeState COMM_ERROR) once refreshes stop, and the
/// module recovers with the watchdog off again and a Reset. Nothing moves:
/// the module stands. A watchdog that is on already is someone's (a
/// keep-alive refreshes it): it is left alone and the check skipped.
fn watchdog(cubes: &mut Cubes, m: ModuleId, at: &str) -> Check {
    let c = Check::new(at, "watchdog");
    let step = |r: Result<bool, cube_dev::Error>, what: &str| r.map_err(|e| format!("{what}: {e}"));
    let run = |cubes: &mut Cubes| -> Result<Check, String> {
        let mut c = c.clone();
        if !step(cubes.watchdog_on(m), "switching the watchdog on")? {
            return Ok(c.skipped("the watchdog is on already (refreshed by someone else): not tested"));
        }
        // It trips 50 ms after the last refresh; three times that is waited.
        let clock = cubes.session().clock().clone();
        clock.sleep(Duration::from_millis(150));
        let tripped = cubes.state(m).map_err(|e| format!("CubeState: {e}"))?;
        let trip = tripped & state::COMM_ERROR != 0;
        c.measure("tripped", json!(trip), "true".into(), "", trip);
        step(cubes.watchdog_off(m), "switching the watchdog off")?;
        reset(cubes, m, 1).map_err(|e| format!("Reset: {e}"))?;
        let after = cubes.state(m).map_err(|e| format!("CubeState: {e}"))?;
        let clear = after & (state::ERROR | state::COMM_ERROR) == 0;
        c.measure("recovered after reset", json!(clear), "true".into(), "", clear);
        Ok(c)
    };
    run(cubes).unwrap_or_else(|e| Check::new(at, "watchdog").fail(e))
}

/// The unit of a module's positions, for the motions' list before anything
/// is read: the plan does not say whether a module is linear.
fn unit_of(kind: Option<&str>) -> &'static str {
    match kind {
        Some("linear") => "m",
        Some("rotary") => "rad",
        _ => "units",
    }
}

/// Whether `name` is a PowerCube parameter a plan may expect.
fn known_setting(name: &str) -> bool {
    table::param_by_name(name).is_some()
}

/// The recorded module as the recording addresses it.
pub fn address(m: ModuleId) -> Address {
    Address::PowerCube { module: m.get() }
}
