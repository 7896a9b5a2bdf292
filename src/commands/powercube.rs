//! PowerCube commands: scan, info, state, home, reset, halt, move-*,
//! get-param, set-param, get-config, set-config, dio, watchdog.

mod backup;
mod dashboard;
pub mod names;
mod record;
mod tap;

use std::time::Duration;

use axisctl::device::powercube::{
    self as device, param, version_text, ConfigChange, Cubes, Deadman, Error, Goal, Move, Simple, SyncRamp, WaitEnd,
    WaitSpec,
};
use axisctl::family::Family;
use axisctl::proto::powercube::flags::{self, FlagWord};
use axisctl::proto::powercube::frame::{f32_to_f64, Value};
use axisctl::proto::powercube::table::{self, ids, ParamDef};
use axisctl::proto::powercube::{ModuleId, Request, Response};
use axisctl::session::powercube::PowerCube;
use axisctl::session::SessionError;
use serde_json::json;

use super::wait::waiting;
use super::{interrupted, usage, Ctx, Interrupted};
use crate::cli::ids::{Devices, IdList};
use crate::cli::powercube::{ModuleArg, ModulesArg};
use crate::cli::{PowerCubeCommand as Command, Target, WaitArgs, WatchdogAction};
use crate::output;
use crate::output::{say, say_part};
use axisctl::bench::{Address, DeviceRef};
use axisctl::device::face::{Face, MotionTarget, Moving};

pub fn run(ctx: &Ctx, cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Scan { device, .. } if !device.is_empty() => super::bench::scan_devices(ctx, &device),
        Command::Scan { ids, .. } => scan(ctx, &ids),
        Command::Info(m) => read_each(ctx, &modules_of(ctx, m)?, info),
        Command::State(m) => read_each(ctx, &modules_of(ctx, m)?, show_state),
        Command::Home { target, wait, deadman } => home(ctx, target_of(ctx, target)?, wait, policy(deadman)),
        Command::Reset { target } => simple(ctx, target_of(ctx, target)?, Simple::Reset),
        Command::Halt { target } => match (target.powercube(), target.device) {
            (Some(t), _) => halt(ctx, Aim { module: t.module, all: t.all }),
            (None, devices) => super::bench::halt_devices(ctx, &devices.unwrap_or_default()),
        },
        Command::MoveRamp { modules, device, pos, vel, acc, ticks, relative, force, sync, wait, deadman } => {
            let deadman = policy(deadman);
            let ids = ramp_modules(ctx, modules.map(|l| l.0), device)?;
            let ms: Vec<ModuleId> = ids.iter().map(|id| module(*id)).collect();
            if ms.len() > 1 {
                // A failure of a synchronized move is the group's, not the
                // last module's.
                output::forget_target();
            }
            match (&ms[..], &pos[..]) {
                _ if sync => move_ramp_sync(ctx, &ms, &pos, (vel, acc), ticks, force, (wait, deadman)),
                ([m], [p]) => move_ramp(ctx, *m, target(*p, relative), vel, acc, ticks, force, (wait, deadman)),
                _ => Err(usage("several modules or positions move only together: add --sync; nothing was sent")),
            }
        }
        Command::MoveStep { module: m, pos, time, ticks, relative, force } => {
            let m = module_of(ctx, &m)?;
            move_step(ctx, m, target(pos, relative), time, ticks, force)
        }
        Command::MoveVel { module: m, vel, ticks, force } => move_vel(ctx, module_of(ctx, &m)?, vel, ticks, force),
        Command::MoveCur { module: m, amps, force } => move_cur(ctx, module_of(ctx, &m)?, amps, force),
        Command::GetParam { module: m, params, all } => {
            let devices = modules_of(ctx, m)?;
            let read = ParamRead::new(&devices, &params, all)?;
            read_each(ctx, &devices, |ctx, cubes, id| read.one(ctx, cubes, id))
        }
        Command::SetParam { module: m, param, value, force } => {
            set_param(ctx, module_of(ctx, &m)?, &param, &value, force)
        }
        Command::GetConfig(m) => get_config(ctx, module_of(ctx, &m)?),
        Command::SetConfig { module: m, changes, raw, force } => {
            set_config(ctx, module_of(ctx, &m)?, &changes, raw.as_deref(), force)
        }
        Command::Dio { module: m, out } => dio(ctx, module_of(ctx, &m)?, out.as_deref()),
        Command::Watchdog { action } => watchdog(ctx, action),
    }
}

/// The module ids `-d` names (PowerCube devices of one link, in the order
/// given; see [`super::devices::of_family`]).
pub(in crate::commands) fn module_ids(ctx: &Ctx, refs: &[DeviceRef]) -> anyhow::Result<Vec<u8>> {
    let all = super::devices::of_family(ctx, Family::PowerCube, refs)?;
    Ok(all
        .into_iter()
        .filter_map(|a| if let Address::PowerCube { module } = a { Some(module) } else { None })
        .collect())
}

/// `move-ramp`'s modules, `-m` or `-d`, in the order given (positions pair
/// with them by place).
pub(in crate::commands) fn ramp_modules(
    ctx: &Ctx,
    modules: Option<Vec<u8>>,
    device: Option<Vec<DeviceRef>>,
) -> anyhow::Result<Vec<u8>> {
    match (modules, device) {
        (_, Some(refs)) => module_ids(ctx, &refs),
        (Some(list), None) => Ok(list),
        (None, None) => unreachable!("clap requires -m or -d"),
    }
}

/// The one module of `-m ID` or `-d DEVICE`.
pub(in crate::commands) fn module_of(ctx: &Ctx, m: &ModuleArg) -> anyhow::Result<ModuleId> {
    match (&m.device, m.module) {
        (Some(r), _) => Ok(module(module_ids(ctx, std::slice::from_ref(r))?[0])),
        (None, Some(id)) => Ok(module(id)),
        (None, None) => unreachable!("clap requires -m or -d"),
    }
}

/// The modules of a read: `-m` as typed, or `-d`'s devices (one device is
/// one object, several a list, as `-m 17` and `-m 3,5`).
fn modules_of(ctx: &Ctx, m: ModulesArg) -> anyhow::Result<Devices> {
    match (m.device, m.module) {
        (Some(refs), _) => match module_ids(ctx, &refs)?[..] {
            [one] if refs.len() == 1 => Ok(Devices::One(one)),
            ref ids => Ok(Devices::List(IdList(ids.to_vec()))),
        },
        (None, Some(d)) => Ok(d),
        (None, None) => unreachable!("clap requires -m or -d"),
    }
}

/// What a command goes to once `-d` is resolved: one module, or `all`
/// (the broadcast).
#[derive(Debug, Clone, Copy)]
struct Aim {
    module: Option<u8>,
    all: bool,
}

/// `-m`, `--all` or `-d` as the module or broadcast it names.
fn target_of(ctx: &Ctx, t: Target) -> anyhow::Result<Aim> {
    match t.device {
        Some(r) => Ok(Aim { module: Some(module_ids(ctx, std::slice::from_ref(&r))?[0]), all: false }),
        None => Ok(Aim { module: t.module, all: t.all }),
    }
}

/// `--deadman` arms the watchdog for the motion; without it the motion's
/// wait refreshes a watchdog that is on already.
fn policy(deadman: bool) -> Deadman {
    if deadman {
        Deadman::Arm
    } else {
        Deadman::Auto
    }
}

/// The result of a supervised motion once its dead-man backstop is
/// released (watchdogs switched on for it switched off, the refresh
/// stopped). The motion's own error comes first: a failure to release is
/// then only said.
fn released<T>(cubes: &mut Cubes, r: anyhow::Result<T>) -> anyhow::Result<T> {
    match (r, cubes.release_deadman()) {
        (Ok(t), Ok(())) => Ok(t),
        (Ok(_), Err(e)) => Err(e.into()),
        (Err(e), Err(left)) => {
            output::err_line(format_args!("{left}"));
            Err(e)
        }
        (Err(e), Ok(())) => Err(e),
    }
}

/// A position as typed, or with `--relative` a distance from where the
/// module is when the command runs.
fn target(value: f64, relative: bool) -> device::Target {
    if relative {
        device::Target::By(value)
    } else {
        device::Target::To(value)
    }
}

fn module(id: u8) -> ModuleId {
    output::target(Family::PowerCube, &[("module", id.into())]);
    ModuleId::new(id).expect("clap checks 1..=31")
}

/// The envelope of a per-module object (docs/json.md).
fn envelope(ctx: &Ctx, m: ModuleId) -> serde_json::Map<String, serde_json::Value> {
    output::envelope(Family::PowerCube, &ctx.link_text_for(Family::PowerCube), &[("module", m.get().into())])
}

/// `envelope` and the command's own keys.
fn doc(ctx: &Ctx, m: ModuleId, body: serde_json::Value) -> serde_json::Value {
    output::device_doc(envelope(ctx, m), body)
}

fn cubes(ctx: &Ctx) -> anyhow::Result<Cubes> {
    let mut cubes = Cubes::new(ctx.powercube()?);
    // With --json stderr carries one error object or nothing (docs/json.md).
    if !ctx.json {
        cubes.warn_with(|w| output::err_line(format_args!("axisctl: warning: {w}")));
    }
    Ok(cubes)
}

/// A read of each module asked for: one JSON object for `-m ID`, else
/// `{"devices": [...]}` in id order (`-m all`: the modules that answer).
/// `read` prints the human form itself and returns the JSON object.
fn read_each(
    ctx: &Ctx,
    devices: &Devices,
    read: impl FnMut(&Ctx, &mut Cubes, ModuleId) -> anyhow::Result<serde_json::Value>,
) -> anyhow::Result<()> {
    let mut cubes = cubes(ctx)?;
    let ids: Vec<ModuleId> = match devices {
        Devices::One(id) => vec![module(*id)],
        Devices::List(list) => list.0.iter().map(|id| module(*id)).collect(),
        Devices::All => {
            let present = cubes.present()?;
            if present.is_empty() {
                return Err(Error::NoneAnswered { ids: "1-31".into() }.into());
            }
            present
        }
    };
    read_ids(ctx, &mut cubes, devices, ids, read)
}

/// [`read_each`] once the modules are known: each one's read in turn, then
/// the JSON document in the shape `devices` asks for.
fn read_ids(
    ctx: &Ctx,
    cubes: &mut Cubes,
    devices: &Devices,
    ids: Vec<ModuleId>,
    mut read: impl FnMut(&Ctx, &mut Cubes, ModuleId) -> anyhow::Result<serde_json::Value>,
) -> anyhow::Result<()> {
    let mut docs = Vec::new();
    for m in ids {
        // The error object names the module being read.
        module(m.get());
        docs.push(read(ctx, cubes, m)?);
    }
    if ctx.json {
        match devices {
            Devices::One(_) => output::json(&docs[0]),
            _ => output::json(&json!({ "devices": docs })),
        }
    }
    Ok(())
}

fn f64_of(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

fn word_json(word: &FlagWord, raw: u32) -> serde_json::Value {
    output::flag_word(word, raw)
}

/// Flags of a word, one per line, coloured by class.
fn print_word(ctx: &Ctx, word: &FlagWord, raw: u32) {
    say!("{} {:#010x}", word.name, raw);
    let mut rows = Vec::new();
    for d in word.set_flags(raw) {
        rows.push(vec![format!("  {}", ctx.style.flag(d.name, d.class)), d.class.name().into()]);
    }
    if rows.is_empty() {
        say!("  (no flags set)");
    }
    output::table(&[vec![String::new(), String::new()]].into_iter().chain(rows).collect::<Vec<_>>()[1..], ctx.style);
    let unknown = raw & !word.known_mask();
    if unknown != 0 {
        say!("  {}", ctx.style.warn(&format!("unknown bits {unknown:#010x}")));
    }
}

fn kind_of(config_word: u32) -> &'static str {
    if device::is_linear(config_word) {
        "linear"
    } else {
        "rotary"
    }
}

/// How long after a scan request's last byte an RS232 answer must start
/// (at least; a longer --timeout makes the scan proportionally patient).
const SCAN_ANSWER_START: Duration = Duration::from_millis(8);

/// A scan over RS232 that reads garbage: a PowerCube module never answers
/// in anything but its frames, so the line is likely someone else's.
#[derive(Debug, thiserror::Error)]
#[error(
    "{source}; another protocol on this line? A PA-CONTROL answers on RS232 too: try `axisctl --link {link} pac-state`"
)]
struct OtherProtocol {
    source: Error,
    link: String,
}

fn other_protocol(ctx: &Ctx, e: Error) -> anyhow::Error {
    match ctx.link_for(Family::PowerCube) {
        Ok(spec @ axisctl::link::LinkSpec::Serial { .. }) if e.kind() == axisctl::session::ErrorKind::Malformed => {
            OtherProtocol { source: e, link: spec.to_string() }.into()
        }
        _ => e.into(),
    }
}

fn scan(ctx: &Ctx, list: &IdList) -> anyhow::Result<()> {
    if super::bench::whole(ctx)? {
        return super::bench::scan(ctx, &list.to(Some));
    }
    let ids = list.to(ModuleId::new);
    let mut cubes = cubes(ctx)?;
    let pc = cubes.session();
    // An absent module never answers; a present one starts answering right
    // after the request, so a scan need not wait the whole timeout per id.
    pc.set_answer_start_timeout(Some(SCAN_ANSWER_START.max(pc.timeout() / 8)));
    let found = cubes.scan(&ids).map_err(|e| other_protocol(ctx, e))?;
    if found.is_empty() {
        return Err(Error::NoneAnswered { ids: list.to_string() }.into());
    }
    let mut modules = Vec::new();
    for f in found {
        let m = f.module;
        let vals = cubes.get_many(m, &[param(ids::DEF_CUBE_SERIAL), param(ids::CONFIG), param(ids::CUBE_STATE)])?;
        let [serial, config_word, cube] = [&vals[0], &vals[1], &vals[2]].map(|v| f64_of(v) as u32);
        let version = f64_of(&f.version) as u16;
        modules.push((m, version, serial, config_word, cube));
    }
    if ctx.json {
        let list: Vec<_> = modules
            .iter()
            .map(|(m, version, serial, cfg, cube)| {
                doc(
                    ctx,
                    *m,
                    json!({"version": version, "version_text": version_text(*version), "serial": serial,
                       "kind": kind_of(*cfg), "state": word_json(&flags::CUBE_STATE, *cube)}),
                )
            })
            .collect();
        output::json(&json!({"devices": list}));
        return Ok(());
    }
    let mut rows = vec![["MODULE", "SERIAL", "VERSION", "KIND", "STATE"].map(String::from).to_vec()];
    for (m, version, serial, cfg, cube) in &modules {
        rows.push(vec![
            m.to_string(),
            serial.to_string(),
            version_text(*version),
            kind_of(*cfg).into(),
            state_summary(ctx, *cube),
        ]);
    }
    output::table(&rows, ctx.style);
    Ok(())
}

/// The set flags of a CubeState, errors coloured.
fn state_summary(ctx: &Ctx, cube: u32) -> String {
    let names: Vec<String> = flags::CUBE_STATE
        .set_flags(cube)
        .map(|d| ctx.style.flag(d.name.trim_start_matches("STATE_"), d.class))
        .collect();
    if names.is_empty() {
        "-".into()
    } else {
        names.join(" ")
    }
}

fn info(ctx: &Ctx, cubes: &mut Cubes, m: ModuleId) -> anyhow::Result<serde_json::Value> {
    let identity = [
        ids::DEF_CUBE_SERIAL,
        ids::DEF_CUBE_VERSION,
        ids::CONFIG,
        ids::DEF_PULSES_PER_TURN,
        ids::DEF_GEAR_RATIO,
        ids::MIN_POS,
        ids::MAX_POS,
        ids::MAX_VEL,
        ids::MAX_ACC,
        ids::MAX_CUR,
    ];
    let defs: Vec<_> = identity.iter().chain(&device::LIVE).map(|id| param(*id)).collect();
    // Firmware before 4.6.01 has no temperature and supply voltages: those
    // rows stay empty (null in JSON).
    let vals = cubes.get_present(m, &defs)?;
    let num = |i: usize| vals[i].as_ref().map_or(f64::NAN, f64_of);
    let config_word = num(2) as u32;
    let cube = num(16) as u32;
    let version = num(1) as u16;
    let linear = device::is_linear(config_word);
    let kind = kind_of(config_word);
    if ctx.json {
        let mut params = serde_json::Map::new();
        for (d, v) in defs.iter().zip(&vals) {
            params.insert(d.name.into(), param_json(d, linear, serde_json::to_value(v)?));
        }
        return Ok(doc(
            ctx,
            m,
            json!({
                "kind": kind, "serial": num(0) as u32, "version": version,
                "version_text": version_text(version), "params": params,
                "config": word_json(&flags::CONFIG, config_word), "state": word_json(&flags::CUBE_STATE, cube),
            }),
        ));
    }
    say!("module {m}: {kind}, serial {}, version {}", num(0) as u32, version_text(version));
    let mut t = vec![["PARAMETER", "VALUE", "UNIT"].map(String::from).to_vec()];
    for (d, v) in defs.iter().zip(&vals).skip(3).take(13) {
        match v {
            Some(v) => t.push(vec![d.name.into(), v.to_string(), d.unit_for(linear).into()]),
            None => t.push(vec![d.name.into(), format!("- (firmware {})", version_text(version)), String::new()]),
        }
    }
    output::table(&t, ctx.style);
    say!("state: {}", state_summary(ctx, cube));
    Ok(serde_json::Value::Null)
}

/// A parameter in the one value shape, as `info` and `get-param` give it.
fn param_json(d: &ParamDef, linear: bool, value: serde_json::Value) -> serde_json::Value {
    json!({"id": d.id, "type": d.ty.name(), "unit": d.unit_for(linear), "value": value})
}

fn show_state(ctx: &Ctx, cubes: &mut Cubes, m: ModuleId) -> anyhow::Result<serde_json::Value> {
    let cube = cubes.state(m)?;
    state_shown(ctx, m, cube)
}

/// Prints `state`'s human form and returns its JSON object.
fn state_shown(ctx: &Ctx, m: ModuleId, cube: u32) -> anyhow::Result<serde_json::Value> {
    if ctx.json {
        // The short state in the one state shape, as `decode profibus-image` gives it.
        let short = word_json(&flags::SHORT_STATE, flags::short_state_from_cube_state(cube).into());
        return Ok(doc(ctx, m, json!({"state": word_json(&flags::CUBE_STATE, cube), "short_state": short})));
    }
    say_part!("module {m}: ");
    print_word(ctx, &flags::CUBE_STATE, cube);
    Ok(serde_json::Value::Null)
}

/// One command to one module, or its broadcast to all.
fn simple(ctx: &Ctx, target: Aim, cmd: Simple) -> anyhow::Result<()> {
    cubes(ctx)?.simple(target.module.map(module), cmd)?;
    report_sent(ctx, target, &cmd.name().to_lowercase(), None);
    Ok(())
}

/// Halt, also from another terminal: a module held by another axisctl
/// process (a `--wait`, the dashboard) is released by it first.
fn halt(ctx: &Ctx, target: Aim) -> anyhow::Result<()> {
    if target.all && super::bench::whole(ctx)? {
        return super::bench::halt_all(ctx);
    }
    let (pc, takeover) = super::takeover::open(ctx, |o, spec, opts| o.powercube(spec, opts))?;
    // The face's stop: one module's acknowledged Halt, or the broadcast.
    let at = target.module.map(module).map_or(MotionTarget::CubeBus, MotionTarget::Cube);
    let sent = Cubes::new(pc).stop(at);
    sent.map_err(|e| super::takeover::failed(e, takeover.as_ref()))?;
    let holder = super::takeover::HolderReport::after_halt(takeover.as_ref());
    report_sent(ctx, target, "halt", holder.as_ref());
    Ok(())
}

fn report_sent(ctx: &Ctx, target: Aim, what: &str, holder: Option<&super::takeover::HolderReport>) {
    if ctx.json {
        let mut out = match target.module {
            Some(m) => doc(ctx, module(m), json!({"command": what, "acknowledged": true})),
            None => {
                let mut all = output::envelope(Family::PowerCube, &ctx.link_text_for(Family::PowerCube), &[]);
                all.insert("module".into(), serde_json::Value::Null);
                output::device_doc(all, json!({"command": what, "broadcast": true, "acknowledged": false}))
            }
        };
        if let Some(h) = holder {
            out["holder"] = h.json();
        }
        output::json(&out);
    } else {
        if let Some(h) = holder {
            say!("{}", h.line());
        }
        match target.module {
            Some(m) => say!("module {m}: {what} acknowledged"),
            None => say!("{what} broadcast to all modules"),
        }
    }
}

fn home(ctx: &Ctx, target: Aim, wait: WaitArgs, deadman: Deadman) -> anyhow::Result<()> {
    let mut cubes = cubes(ctx)?;
    if !wait.wait {
        cubes.simple(target.module.map(module), Simple::Home)?;
        report_sent(ctx, target, "home", None);
        return Ok(());
    }
    cubes.set_deadman(deadman)?;
    // Supervised from before the first byte: a signal now halts.
    super::arm_interrupt()?;
    // Held from before the first Home: every way out halts (one module, or the bus).
    let at = target.module.map(module).map_or(MotionTarget::CubeBus, MotionTarget::Cube);
    let r = Moving::new(&mut cubes, vec![at], 1 + ctx.retry.read_retries).follow(|c| home_waited(ctx, c, target, wait));
    released(&mut cubes, r)
}

fn home_waited(ctx: &Ctx, cubes: &mut Cubes, target: Aim, wait: WaitArgs) -> anyhow::Result<()> {
    let attempts = 1 + ctx.retry.read_retries;
    let modules = match target.module.map(module) {
        Some(m) => {
            cubes.home_supervised(m, attempts)?;
            vec![m]
        }
        None => {
            let present = cubes.present()?;
            if present.is_empty() {
                return Err(Error::NoneAnswered { ids: "1-31".into() }.into());
            }
            cubes
                .home_each_supervised(&present, attempts, &interrupted)
                .map_err(|e| super::stopped_by_output(e.into()))?;
            present
        }
    };
    refresh_ahead(cubes);
    let goals: Vec<(ModuleId, Goal)> = modules.iter().map(|m| (*m, Goal::Homed)).collect();
    let results = waiting(ctx, &wait, |t, show| {
        let spec = WaitSpec { poll: t.poll, timeout: t.timeout, halt_attempts: t.stop_attempts };
        let progress =
            &mut |m, pos: f32, cube| show(format!("module {m} homing: pos {pos:.4}  {}", state_summary(ctx, cube)));
        // The caller's Moving handle halts on a panic; the wait on its own errors.
        let waited = cubes.wait_each(&goals, spec, &interrupted, progress);
        waited.map_err(|e| super::stopped_by_output(e.into()))
    })?;
    print_wait_results(ctx, cubes, "home", &results)
}

/// The device's wait, with the spinner and Ctrl-C (which halts the module).
fn wait_for(ctx: &Ctx, cubes: &mut Cubes, m: ModuleId, wait: WaitArgs, goal: Goal) -> anyhow::Result<WaitEnd> {
    waiting(ctx, &wait, |t, show| {
        let spec = WaitSpec { poll: t.poll, timeout: t.timeout, halt_attempts: t.stop_attempts };
        let what = goal.doing();
        let progress =
            &mut |pos: f32, cube| show(format!("module {m} {what}: pos {pos:.4}  {}", state_summary(ctx, cube)));
        // The caller's Moving handle halts on a panic; the wait on its own errors.
        let waited = cubes.wait(m, goal, spec, &interrupted, progress);
        waited.map_err(|e| super::stopped_by_output(e.into()))
    })
}

/// The ends of waits, with the position's unit (the module's Config, read
/// once the motion is over, says rad or m).
fn print_wait_results(ctx: &Ctx, cubes: &mut Cubes, what: &str, results: &[WaitEnd]) -> anyhow::Result<()> {
    let mut list = Vec::new();
    for r in results {
        let unit = table::position_unit(device::is_linear(cubes.get_u32(r.module, ids::CONFIG)?));
        list.push((r, unit));
    }
    if ctx.json {
        let list: Vec<_> = list
            .iter()
            .map(|(r, unit)| {
                doc(
                    ctx,
                    r.module,
                    json!({"command": what, "done": true,
                    "position": output::with_unit(json!(f32_to_f64(r.position)), unit),
                    "elapsed_ms": r.elapsed.as_millis() as u64, "state": word_json(&flags::CUBE_STATE, r.cube)}),
                )
            })
            .collect();
        if let [one] = &list[..] {
            output::json(one);
        } else {
            output::json(&json!({"devices": list}));
        }
    } else {
        for (r, unit) in list {
            say!(
                "module {}: {what} done at {:.4} {unit} after {:.2} s  [{}]",
                r.module,
                r.position,
                r.elapsed.as_secs_f64(),
                state_summary(ctx, r.cube)
            );
        }
    }
    Ok(())
}

/// A move's target with its unit under --json: ticks with --ticks, else rad
/// or m by the module's Config, read before the motion frame (a failed read
/// leaves nothing moving, and nothing is read after the motion).
fn target_unit(ctx: &Ctx, cubes: &mut Cubes, m: ModuleId, ticks: bool) -> anyhow::Result<&'static str> {
    Ok(match (ctx.json, ticks) {
        (false, _) => "",
        (true, true) => "ticks",
        (true, false) => table::position_unit(device::is_linear(cubes.get_u32(m, ids::CONFIG)?)),
    })
}

/// Checks and sends a move; the checks that need no module come before the
/// link is opened. A move to be waited for must start on its own.
/// Checks the motion, opens the link and sends it.
fn send_move(ctx: &Ctx, m: ModuleId, mv: Move, ticks: bool, force: bool) -> anyhow::Result<Cubes> {
    mv.check(ticks)?;
    let mut cubes = cubes(ctx)?;
    send_on(ctx, &mut cubes, m, mv, ticks, force, false)?;
    Ok(cubes)
}

/// A ramp or step to `target`: a relative one is resolved on the open link
/// (a read, before anything moves), then `to` builds the motion for the
/// absolute position. Returns that position.
fn send_move_to(
    ctx: &Ctx,
    cubes: &mut Cubes,
    (m, target): (ModuleId, device::Target),
    to: impl Fn(f64) -> Move,
    ticks: bool,
    force: bool,
    wait: bool,
) -> anyhow::Result<f64> {
    let pos = cubes.resolve(m, target, ticks)?;
    let mv = to(pos);
    mv.check(ticks)?;
    send_on(ctx, cubes, m, mv, ticks, force, wait)?;
    Ok(pos)
}

/// The checks of a motion to `target` that need no module, before the link opens.
fn check_target(target: device::Target, to: impl Fn(f64) -> Move, ticks: bool) -> anyhow::Result<()> {
    if let device::Target::To(p) = target {
        to(p).check(ticks)?;
    }
    Ok(())
}

fn send_on(
    ctx: &Ctx,
    cubes: &mut Cubes,
    m: ModuleId,
    mv: Move,
    ticks: bool,
    force: bool,
    wait: bool,
) -> anyhow::Result<()> {
    let moved = if wait {
        // Supervised from before the motion byte leaves; without a wait the
        // motion is one-shot and unsupervised once acknowledged.
        super::arm_interrupt()?;
        let moved = cubes.move_supervised(m, mv, ticks, force, 1 + ctx.retry.read_retries);
        refresh_ahead(cubes);
        moved
    } else {
        cubes.move_module(m, mv, ticks, force)
    }?;
    if !ctx.json {
        say!("module {m}: {} acknowledged", moved.described);
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn move_ramp(
    ctx: &Ctx,
    m: ModuleId,
    target: device::Target,
    vel: Option<f64>,
    acc: Option<f64>,
    ticks: bool,
    force: bool,
    (wait, deadman): (WaitArgs, Deadman),
) -> anyhow::Result<()> {
    let ramp = |pos| Move::Ramp { pos, vel, acc };
    check_target(target, ramp, ticks)?;
    let mut cubes = cubes(ctx)?;
    if !wait.wait {
        let unit = target_unit(ctx, &mut cubes, m, ticks)?;
        let pos = send_move_to(ctx, &mut cubes, (m, target), ramp, ticks, force, false)?;
        if ctx.json {
            let target = output::with_unit(json!(pos), unit);
            output::json(&doc(ctx, m, json!({"command": "move-ramp", "target": target, "acknowledged": true})));
        }
        return Ok(());
    }
    cubes.set_deadman(deadman)?;
    // Held from before the motion frame until the wait ends: every way out halts.
    let r = Moving::new(&mut cubes, vec![MotionTarget::Cube(m)], 1 + ctx.retry.read_retries).follow(|c| {
        send_move_to(ctx, c, (m, target), ramp, ticks, force, true)
            .and_then(|pos| wait_for(ctx, c, m, wait, Goal::RampEnd { target: pos, ticks }))
    });
    let end = released(&mut cubes, r)?;
    print_wait_results(ctx, &mut cubes, "move-ramp", &[end])
}

/// Several modules, each to its position, started by one broadcast; every
/// check comes before the first frame.
fn move_ramp_sync(
    ctx: &Ctx,
    ms: &[ModuleId],
    pos: &[f64],
    (vel, acc): (Option<f64>, Option<f64>),
    ticks: bool,
    force: bool,
    (wait, deadman): (WaitArgs, Deadman),
) -> anyhow::Result<()> {
    let plan = SyncRamp::new(ms, pos, vel, acc, ticks)?;
    let mut cubes = cubes(ctx)?;
    if wait.wait {
        cubes.set_deadman(deadman)?;
        super::arm_interrupt()?;
        // Held from before the first frame until the wait ends: every way out halts the bus.
        let r = Moving::new(&mut cubes, vec![MotionTarget::CubeBus], 1 + ctx.retry.read_retries)
            .follow(|c| move_ramp_sync_waited(ctx, c, &plan, ticks, force, wait));
        return released(&mut cubes, r);
    }
    let units = ms.iter().map(|m| target_unit(ctx, &mut cubes, *m, ticks)).collect::<anyhow::Result<Vec<_>>>()?;
    let started = cubes.move_sync(&plan, force, 1 + ctx.retry.read_retries)?;
    say_started(ctx, &started);
    if ctx.json {
        let list: Vec<_> = started
            .iter()
            .zip(units)
            .map(|((m, moved), unit)| {
                doc(ctx, *m, json!({"target": output::with_unit(json!(moved.target), unit), "acknowledged": true}))
            })
            .collect();
        output::json(&json!({"command": "move-ramp", "sync": true, "devices": list, "broadcast": "StartMotion"}));
    }
    Ok(())
}

fn say_started(ctx: &Ctx, started: &[(ModuleId, device::Moved)]) {
    if !ctx.json {
        for (m, moved) in started {
            say!("module {m}: {} acknowledged", moved.described);
        }
        say!("StartMotion broadcast to all modules");
    }
}

fn move_ramp_sync_waited(
    ctx: &Ctx,
    cubes: &mut Cubes,
    plan: &SyncRamp,
    ticks: bool,
    force: bool,
    wait: WaitArgs,
) -> anyhow::Result<()> {
    let started = cubes
        .move_sync_supervised(plan, force, 1 + ctx.retry.read_retries, &interrupted)
        .map_err(|e| super::stopped_by_output(e.into()))?;
    say_started(ctx, &started);
    refresh_ahead(cubes);
    let ends = waiting(ctx, &wait, |t, show| {
        let spec = WaitSpec { poll: t.poll, timeout: t.timeout, halt_attempts: t.stop_attempts };
        let progress =
            &mut |m, pos: f32, cube| show(format!("module {m} moving: pos {pos:.4}  {}", state_summary(ctx, cube)));
        // The caller's Moving handle halts on a panic; the wait on its own errors.
        let waited = cubes.wait_sync(&started, ticks, spec, &interrupted, progress);
        waited.map_err(|e| super::stopped_by_output(e.into()))
    })?;
    print_wait_results(ctx, cubes, "move-ramp", &ends)
}

fn move_step(
    ctx: &Ctx,
    m: ModuleId,
    target: device::Target,
    time: u16,
    ticks: bool,
    force: bool,
) -> anyhow::Result<()> {
    let step = |pos| Move::Step { pos, time_ms: time };
    check_target(target, step, ticks)?;
    let mut cubes = cubes(ctx)?;
    let unit = target_unit(ctx, &mut cubes, m, ticks)?;
    let pos = send_move_to(ctx, &mut cubes, (m, target), step, ticks, force, false)?;
    if ctx.json {
        let target = output::with_unit(json!(pos), unit);
        output::json(&doc(
            ctx,
            m,
            json!({"command": "move-step", "target": target, "time_ms": time, "acknowledged": true}),
        ));
    }
    Ok(())
}

fn move_vel(ctx: &Ctx, m: ModuleId, vel: f64, ticks: bool, force: bool) -> anyhow::Result<()> {
    send_move(ctx, m, Move::Vel(vel), ticks, force)?;
    if ctx.json {
        output::json(&doc(ctx, m, json!({"command": "move-vel", "velocity": vel, "acknowledged": true})));
    }
    Ok(())
}

fn move_cur(ctx: &Ctx, m: ModuleId, amps: f64, force: bool) -> anyhow::Result<()> {
    send_move(ctx, m, Move::Cur(amps), false, force)?;
    if ctx.json {
        output::json(&doc(ctx, m, json!({"command": "move-cur", "current": amps, "acknowledged": true})));
    }
    Ok(())
}

/// What a `get-param` line reads of each module, and how it shows it.
struct ParamRead {
    /// The parameters asked for, then Config: it rides along so that
    /// "rad|m" units resolve for the module's kind.
    defs: Vec<&'static ParamDef>,
    all: bool,
    /// A list or `all`: each module's table under its name.
    several: bool,
}

impl ParamRead {
    /// Every name is resolved before the link opens: a typo sends nothing.
    fn new(devices: &Devices, params: &[String], all: bool) -> anyhow::Result<Self> {
        params.iter().try_for_each(|n| names::check_param(n))?;
        let mut defs = device::readable_params(params, all)?;
        defs.push(param(ids::CONFIG));
        Ok(Self { defs, all, several: !matches!(devices, Devices::One(_)) })
    }

    /// Reads one module and shows it.
    fn one(&self, ctx: &Ctx, cubes: &mut Cubes, m: ModuleId) -> anyhow::Result<serde_json::Value> {
        let vals = cubes.get_params(m, &self.defs, self.all)?;
        self.show(ctx, m, vals)
    }

    /// Prints the human table and returns the JSON object, from the values
    /// of `defs` (Config last).
    fn show(
        &self,
        ctx: &Ctx,
        m: ModuleId,
        mut vals: Vec<(&'static ParamDef, Value)>,
    ) -> anyhow::Result<serde_json::Value> {
        let linear = vals.pop().is_some_and(|(_, c)| device::is_linear(f64_of(&c) as u32));
        if ctx.json {
            let mut params = serde_json::Map::new();
            for (d, v) in &vals {
                params.insert(d.name.into(), param_json(d, linear, serde_json::to_value(v)?));
            }
            return Ok(doc(ctx, m, json!({ "params": params })));
        }
        if self.several {
            say!("module {m}:");
        }
        let mut rows = vec![["PARAMETER", "ID", "TYPE", "VALUE", "UNIT"].map(String::from).to_vec()];
        for (d, v) in &vals {
            rows.push(vec![
                d.name.into(),
                format!("{:#04x}", d.id),
                d.ty.name().into(),
                v.to_string(),
                d.unit_for(linear).into(),
            ]);
        }
        output::table(&rows, ctx.style);
        Ok(serde_json::Value::Null)
    }
}

/// A read line whose requests are known before anything is sent, of named
/// modules (not `all`, which asks who is present first): `state`, and
/// `get-param` of named parameters every firmware has (not `--all` nor a
/// measurement of newer firmware, which read the module's version first).
/// `batch` sends the requests of consecutive such lines in one burst and
/// hands each line its answers; the line then shows them as its one-shot
/// run would.
pub struct PipelinedRead {
    devices: Devices,
    modules: Vec<ModuleId>,
    /// What each module is asked, in order.
    defs: Vec<&'static ParamDef>,
    /// `None`: `state`.
    params: Option<ParamRead>,
}

impl PipelinedRead {
    /// `None` for a command that is not such a read, or that a one-shot run
    /// refuses (it runs on its own and says why).
    pub fn plan(cmd: &Command) -> Option<Self> {
        let (devices, params) = match cmd {
            // `-d` is resolved through the bench by the line's own run.
            Command::GetParam { module: m, params, all: false } => {
                let devices = m.module.as_ref()?;
                (devices, Some(ParamRead::new(devices, params, false).ok()?))
            }
            Command::State(m) => (m.module.as_ref()?, None),
            _ => return None,
        };
        let modules: Vec<ModuleId> = match devices {
            Devices::One(id) => vec![ModuleId::new(*id)?],
            Devices::List(list) => list.0.iter().map(|id| ModuleId::new(*id)).collect::<Option<_>>()?,
            Devices::All => return None,
        };
        let defs = params.as_ref().map_or_else(|| vec![param(ids::CUBE_STATE)], |p| p.defs.clone());
        Cubes::param_requests(*modules.first()?, &defs)?;
        Some(Self { devices: devices.clone(), modules, defs, params })
    }

    /// The requests, module by module, in the order the one-shot run sends them.
    pub fn requests(&self) -> Vec<(ModuleId, Request)> {
        let reqs = self.modules.iter().map(|m| Cubes::param_requests(*m, &self.defs));
        reqs.flatten().flatten().collect()
    }

    /// The line's output from the answers to [`Self::requests`], in order;
    /// a read the burst did not answer gets the session's retries on its
    /// own, and the line fails as its one-shot run would.
    pub fn finish(
        &self,
        ctx: &Ctx,
        cubes: &mut Cubes,
        answers: Vec<Result<Response, SessionError>>,
    ) -> anyhow::Result<()> {
        let mut answers = answers.into_iter();
        read_ids(ctx, cubes, &self.devices, self.modules.clone(), |ctx, cubes, m| {
            let mut mine = answers.by_ref().take(self.defs.len());
            match &self.params {
                Some(read) => {
                    let vals = cubes.params_answered(m, &self.defs, mine)?;
                    read.show(ctx, m, vals)
                }
                None => {
                    let answer = mine.next().expect("one request, one answer");
                    let cube = cubes.state_answered(m, answer)?;
                    state_shown(ctx, m, cube)
                }
            }
        })
    }
}

fn set_param(ctx: &Ctx, m: ModuleId, name: &str, text: &str, force: bool) -> anyhow::Result<()> {
    names::check_param(name)?;
    let (d, value) = device::param_write(name, text)?;
    let held = cubes(ctx)?.write_param(m, d, value, force)?;
    if ctx.json {
        output::json(&doc(
            ctx,
            m,
            json!({"command": "set-param", "param": d.name, "id": d.id, "type": d.ty.name(),
                                         "value": value, "held": held, "acknowledged": true}),
        ));
        return Ok(());
    }
    match held {
        Some(h) if h != value => say!("module {m}: {} = {value} acknowledged; the module reads back {h}", d.name),
        Some(_) => say!("module {m}: {} = {value} acknowledged and read back", d.name),
        None => say!("module {m}: {} = {value} acknowledged (write-only: the module does not report it)", d.name),
    }
    Ok(())
}

fn print_config(ctx: &Ctx, m: ModuleId, raw: u32) {
    if ctx.json {
        output::json(&doc(ctx, m, json!({"config": word_json(&flags::CONFIG, raw)})));
    } else {
        say_part!("module {m}: ");
        print_word(ctx, &flags::CONFIG, raw);
    }
}

fn get_config(ctx: &Ctx, m: ModuleId) -> anyhow::Result<()> {
    let raw = cubes(ctx)?.get_u32(m, ids::CONFIG)?;
    print_config(ctx, m, raw);
    Ok(())
}

fn set_config(ctx: &Ctx, m: ModuleId, changes: &[String], raw: Option<&str>, force: bool) -> anyhow::Result<()> {
    // Every flag is resolved and weighed before the link opens: a typo, or a
    // safety removed without --force, sends nothing.
    // The flags take hyphen values, so a `--force` written after them
    // arrives as one of them.
    let force = force || changes.iter().any(|c| c == "--force");
    let changes: Vec<String> = changes.iter().filter(|c| *c != "--force").cloned().collect();
    changes.iter().try_for_each(|c| names::check_config_flag(c))?;
    let change = ConfigChange::parse(&changes, raw)?;
    change.check_safeties(force)?;
    match cubes(ctx)?.write_config(m, change) {
        Ok(kept) => {
            print_config(ctx, m, kept);
            Ok(())
        }
        Err(e) => {
            if let Error::ConfigNotKept { kept, .. } = e {
                print_config(ctx, m, kept);
            }
            Err(e.into())
        }
    }
}

fn dio(ctx: &Ctx, m: ModuleId, out: Option<&str>) -> anyhow::Result<()> {
    let outputs = out.map(device::dio_outputs).transpose()?;
    let raw = cubes(ctx)?.dio(m, outputs)?;
    if ctx.json {
        output::json(&doc(
            ctx,
            m,
            json!({"dio": word_json(&flags::DIO_SETUP, raw),
            "inputs": raw & 0xf, "outputs": (raw >> 4) & 0xf}),
        ));
    } else {
        say_part!("module {m}: ");
        print_word(ctx, &flags::DIO_SETUP, raw);
    }
    Ok(())
}

fn watchdog(ctx: &Ctx, action: WatchdogAction) -> anyhow::Result<()> {
    match action {
        WatchdogAction::On(a) => watchdog_switch(ctx, &a, true),
        WatchdogAction::Off(a) => watchdog_switch(ctx, &a, false),
        WatchdogAction::Keepalive { interval, duration } => keepalive(ctx, cubes(ctx)?.session(), interval, duration),
    }
}

/// `watchdog on` / `off`: the module is resolved before the link opens, so
/// a bad `-d` sends nothing.
fn watchdog_switch(ctx: &Ctx, a: &ModuleArg, on: bool) -> anyhow::Result<()> {
    let m = module_of(ctx, a)?;
    let mut cubes = cubes(ctx)?;
    let changed = if on { cubes.watchdog_on(m)? } else { cubes.watchdog_off(m)? };
    let state = if on { "on" } else { "off" };
    if ctx.json {
        output::json(&doc(ctx, m, json!({"watchdog": state, "changed": changed})));
    } else if !changed {
        say!(
            "module {m}: watchdog already {state}{}; nothing sent",
            if on { " (CONFIGID_MOD_WATCHDOG_ENABLE set)" } else { "" }
        );
    } else if on {
        say!("module {m}: watchdog online; keep it alive with `axisctl watchdog keepalive`, or it halts within 50 ms");
    } else {
        say!("module {m}: watchdog off (CONFIGID_MOD_WATCHDOG_ENABLE cleared)");
    }
    Ok(())
}

/// Broadcasts the refresh on a fixed schedule (not "sleep after send", which
/// drifts) and reports the gaps between refreshes.
fn keepalive(ctx: &Ctx, pc: &mut PowerCube, interval_ms: u64, duration: Option<f64>) -> anyhow::Result<()> {
    super::arm_interrupt()?;
    let scheduling = raise_priority();
    let clock = std::sync::Arc::clone(pc.clock());
    let start = clock.now();
    let stop_after = duration.map(|s| Duration::from_secs_f64(s.max(0.0)));
    let mut keep_going = || !interrupted() && stop_after.is_none_or(|d| clock.now() - start < d);
    let st = pc.keepalive(Duration::from_millis(interval_ms), &mut keep_going)?;
    let ms = |us: u64| us as f64 / 1e3;
    if ctx.json {
        // The refresh is a broadcast: addressed to every module.
        let mut all = output::envelope(Family::PowerCube, &ctx.link_text_for(Family::PowerCube), &[]);
        all.insert("module".into(), serde_json::Value::Null);
        output::json(&output::device_doc(
            all,
            json!({"refreshes": st.refreshes, "interval_ms": interval_ms,
            "min_gap_ms": ms(st.min_gap_us), "mean_gap_ms": ms(st.mean_gap_us), "p99_gap_ms": ms(st.p99_gap_us),
            "max_gap_ms": ms(st.max_gap_us), "scheduling": scheduling}),
        ));
    } else {
        say!(
            "{} watchdog refreshes, interval {interval_ms} ms, gaps min {:.2} / mean {:.2} / p99 {:.2} / max {:.2} ms \
             ({scheduling} scheduling)",
            st.refreshes,
            ms(st.min_gap_us),
            ms(st.mean_gap_us),
            ms(st.p99_gap_us),
            ms(st.max_gap_us)
        );
    }
    if interrupted() {
        return Err(
            Interrupted(": keep-alive stopped; modules with an online watchdog halt within 50 ms".into()).into()
        );
    }
    Ok(())
}

/// A wait that keeps the module watchdog refreshed runs ahead of ordinary
/// work, as the keep-alive does: on a loaded host a refresh late by more
/// than the watchdog's 50 ms halts the module (docs/safety.md § 13).
pub(super) fn refresh_ahead(cubes: &Cubes) {
    if cubes.deadman_refreshing() {
        raise_priority();
    }
}

/// Puts the keep-alive thread ahead of ordinary work where the system allows
/// it: a busy machine must not delay a refresh by tens of milliseconds
/// (docs/safety.md has the figures). SCHED_FIFO first (root or
/// CAP_SYS_NICE), then nice -10; otherwise ordinary scheduling.
fn raise_priority() -> &'static str {
    // SAFETY: plain system calls on the calling thread with valid arguments.
    unsafe {
        let param = libc::sched_param { sched_priority: 20 };
        if libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0 {
            return "fifo";
        }
        if libc::setpriority(libc::PRIO_PROCESS, 0, -10) == 0 {
            return "nice";
        }
    }
    "normal"
}

/// A PowerCube refusal in the error document: the CubeState word read, its
/// error flags.
impl super::error_json::DeviceDoc for axisctl::proto::powercube::refusal::PowerCubeRefusal {
    fn device_doc(&self) -> serde_json::Value {
        let state = output::flag_word(&axisctl::proto::powercube::flags::CUBE_STATE, self.cube_state);
        let details: Vec<serde_json::Value> = state["details"]
            .as_array()
            .map(|d| d.iter().filter(|d| d["class"] == "error").cloned().collect())
            .unwrap_or_default();
        json!({"family": "powercube", "command_code": null, "code": self.cube_state, "name": null,
               "text": self.errors.join(", "), "details": details, "unknown_bits": state["unknown_bits"]})
    }
}

/// What this folder answers for the family (`super::family_cli`).
pub const CLI: super::FamilyCli = super::FamilyCli {
    names: &names::PowerCubeNames,
    dashboard_source: dashboard::source,
    backup_live: backup::live,
    record_plan: record::plan,
    line: None,
    serial_trace: Some(tap::trace),
};
