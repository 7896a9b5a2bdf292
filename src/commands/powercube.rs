//! PowerCube commands: scan, info, state, home, reset, halt, move-*,
//! get-param, set-param, get-config, set-config, dio, watchdog.

use std::time::Duration;

use anyhow::{bail, Context as _};
use axisctl::proto::powercube::can::Broadcast;
use axisctl::proto::powercube::flags::{self, config, state, FlagWord};
use axisctl::proto::powercube::frame::{f32_to_f64, parse_int, Value};
use axisctl::proto::powercube::limits::{self, LimitError, Limits};
use axisctl::proto::powercube::table::{self, ids, ParamDef};
use axisctl::proto::powercube::{ModuleId, Motion, MotionValue, Request, Response};
use axisctl::session::powercube::{decode_get, describe, PowerCube};
use axisctl::session::SessionError;
use serde_json::json;

use super::{interrupted, usage, Ctx, DeviceFault, Interrupted};
use crate::cli::{PowerCubeCommand as Command, Target, WaitArgs, WatchdogAction};
use crate::output;

pub fn run(ctx: &Ctx, cmd: Command) -> anyhow::Result<()> {
    match cmd {
        Command::Scan { ids } => scan(ctx, &ids),
        Command::Info(m) => info(ctx, module(m.module)),
        Command::State(m) => show_state(ctx, module(m.module)),
        Command::Home { target, wait } => home(ctx, target, wait),
        Command::Reset { target } => simple(ctx, target, Request::Reset, Broadcast::Reset),
        Command::Halt { target } => simple(ctx, target, Request::Halt, Broadcast::Halt),
        Command::MoveRamp { module: m, pos, vel, acc, ticks, force, wait } => {
            move_ramp(ctx, module(m.module), pos, vel, acc, ticks, force, wait)
        }
        Command::MoveStep { module: m, pos, time, ticks, force } => {
            move_step(ctx, module(m.module), pos, time, ticks, force)
        }
        Command::MoveVel { module: m, vel, ticks, force } => move_vel(ctx, module(m.module), vel, ticks, force),
        Command::MoveCur { module: m, amps, force } => move_cur(ctx, module(m.module), amps, force),
        Command::GetParam { module: m, params, all } => get_param(ctx, module(m.module), &params, all),
        Command::SetParam { module: m, param, value } => set_param(ctx, module(m.module), &param, &value),
        Command::GetConfig(m) => get_config(ctx, module(m.module)),
        Command::SetConfig { module: m, changes, raw } => set_config(ctx, module(m.module), &changes, raw.as_deref()),
        Command::Dio { module: m, out } => dio(ctx, module(m.module), out.as_deref()),
        Command::Watchdog { action } => watchdog(ctx, action),
    }
}

fn module(id: u8) -> ModuleId {
    ModuleId::new(id).expect("clap checks 1..=31")
}

fn param(id: u8) -> &'static ParamDef {
    table::param(id).expect("ids constants are in the table")
}

fn get_u32(pc: &mut PowerCube, m: ModuleId, id: u8) -> anyhow::Result<u32> {
    match pc.get(m, param(id))? {
        Value::UInt32(v) => Ok(v),
        other => bail!("{} answered {other:?}, expected UInt32", param(id).name),
    }
}

/// Reads several parameters of one module, pipelined on CAN.
fn get_many(pc: &mut PowerCube, m: ModuleId, defs: &[&'static ParamDef]) -> anyhow::Result<Vec<Value>> {
    let reqs: Vec<_> = defs.iter().map(|d| (m, Request::GetExtended { param: d.id })).collect();
    let answers = pc.transact_many(&reqs)?;
    defs.iter()
        .zip(answers)
        .map(|(d, a)| {
            // A pipelined read that failed is retried one by one; the
            // pipelined attempt counts as its first.
            let resp = match a {
                Ok(r) => r,
                Err(e) => pc.retry_read(m, &Request::GetExtended { param: d.id }, e)?,
            };
            Ok(decode_get(m, d, &resp)?)
        })
        .collect()
}

fn f64_of(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

fn word_json(word: &FlagWord, raw: u32) -> serde_json::Value {
    let d = word.decode(raw);
    json!({"raw": raw, "flags": d.flags, "errors": d.errors, "warnings": d.warnings})
}

/// Flags of a word, one per line, coloured by class.
fn print_word(ctx: &Ctx, word: &FlagWord, raw: u32) {
    println!("{} {:#010x}", word.name, raw);
    let mut rows = Vec::new();
    for d in word.set_flags(raw) {
        rows.push(vec![format!("  {}", ctx.style.flag(d.name, d.class)), format!("{:?}", d.class).to_lowercase()]);
    }
    if rows.is_empty() {
        println!("  (no flags set)");
    }
    output::table(&[vec![String::new(), String::new()]].into_iter().chain(rows).collect::<Vec<_>>()[1..], ctx.style);
    let unknown = raw & !word.known_mask();
    if unknown != 0 {
        println!("  {}", ctx.style.warn(&format!("unknown bits {unknown:#010x}")));
    }
}

fn kind_of(config_word: u32) -> &'static str {
    if config_word & config::LINEAR != 0 {
        "linear"
    } else {
        "rotary"
    }
}

/// `3.5.18` from 0x3518.
fn version_text(v: u16) -> String {
    format!("{:x}.{:x}.{:02x}", v >> 12, (v >> 8) & 0xf, v & 0xff)
}

pub(crate) fn parse_ids(text: &str) -> anyhow::Result<Vec<ModuleId>> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (a, b) = part.split_once('-').unwrap_or((part, part));
        let parse = |s: &str| {
            s.trim()
                .parse::<u8>()
                .ok()
                .and_then(ModuleId::new)
                .ok_or_else(|| usage(format!("{s:?} in --ids is not a module id 1..31")))
        };
        let (a, b) = (parse(a)?, parse(b)?);
        if a > b {
            return Err(usage(format!("range {part:?} in --ids runs backwards")));
        }
        out.extend((a.get()..=b.get()).filter_map(ModuleId::new));
    }
    out.sort();
    out.dedup();
    if out.is_empty() {
        return Err(usage("--ids lists no module"));
    }
    Ok(out)
}

/// How long after a scan request's last byte an RS232 answer must start
/// (at least; a longer --timeout makes the scan proportionally patient).
const SCAN_ANSWER_START: Duration = Duration::from_millis(8);

fn scan(ctx: &Ctx, ids_text: &str) -> anyhow::Result<()> {
    let ids = parse_ids(ids_text)?;
    let mut pc = ctx.powercube()?;
    // An absent module never answers; a present one starts answering right
    // after the request, so a scan need not wait the whole timeout per id.
    pc.set_answer_start_timeout(Some(SCAN_ANSWER_START.max(pc.timeout() / 8)));
    let probes: Vec<_> = ids.iter().map(|m| (*m, Request::GetExtended { param: ids::DEF_CUBE_VERSION })).collect();
    let answers = pc.transact_many(&probes)?;
    let mut found = Vec::new();
    for ((m, _), a) in probes.iter().zip(answers) {
        match a {
            Ok(resp) => found.push((*m, decode_get(*m, param(ids::DEF_CUBE_VERSION), &resp)?)),
            Err(SessionError::Timeout { .. }) => {}
            Err(e) => return Err(e.into()),
        }
    }
    let mut modules = Vec::new();
    for (m, version) in found {
        let vals = get_many(&mut pc, m, &[param(ids::DEF_CUBE_SERIAL), param(ids::CONFIG), param(ids::CUBE_STATE)])?;
        let [serial, config_word, cube] = [&vals[0], &vals[1], &vals[2]].map(|v| f64_of(v) as u32);
        let version = f64_of(&version) as u16;
        modules.push((m, version, serial, config_word, cube));
    }
    if ctx.json {
        let list: Vec<_> = modules
            .iter()
            .map(|(m, version, serial, cfg, cube)| {
                json!({"module": m, "version": version, "version_text": version_text(*version), "serial": serial,
                       "kind": kind_of(*cfg), "state": word_json(&flags::CUBE_STATE, *cube)})
            })
            .collect();
        output::json(&json!({"modules": list}));
        return Ok(());
    }
    if modules.is_empty() {
        println!("no PowerCube modules answered on ids {ids_text}");
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

fn info(ctx: &Ctx, m: ModuleId) -> anyhow::Result<()> {
    let mut pc = ctx.powercube()?;
    let rows: &[u8] = &[
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
        ids::ACT_POS,
        ids::ACT_VEL,
        ids::CUR,
        ids::ACT_F_TEMP,
        ids::ACT_F_MOTOR_SUPPLY,
        ids::ACT_F_LOGIC_SUPPLY,
        ids::CUBE_STATE,
    ];
    let defs: Vec<_> = rows.iter().map(|id| param(*id)).collect();
    let vals = get_many(&mut pc, m, &defs)?;
    let config_word = f64_of(&vals[2]) as u32;
    let cube = f64_of(&vals[16]) as u32;
    let kind = kind_of(config_word);
    if ctx.json {
        let mut params = serde_json::Map::new();
        for (d, v) in defs.iter().zip(&vals) {
            params.insert(d.name.into(), serde_json::to_value(v)?);
        }
        output::json(&json!({
            "module": m, "kind": kind, "serial": f64_of(&vals[0]) as u32, "version": f64_of(&vals[1]) as u16,
            "version_text": version_text(f64_of(&vals[1]) as u16), "params": params,
            "config": word_json(&flags::CONFIG, config_word), "state": word_json(&flags::CUBE_STATE, cube),
        }));
        return Ok(());
    }
    println!("module {m}: {kind}, serial {}, version {}", vals[0], version_text(f64_of(&vals[1]) as u16));
    let mut t = vec![["PARAMETER", "VALUE", "UNIT"].map(String::from).to_vec()];
    for (d, v) in defs.iter().zip(&vals).skip(3).take(13) {
        t.push(vec![d.name.into(), v.to_string(), unit_for(d, kind)]);
    }
    output::table(&t, ctx.style);
    println!("state: {}", state_summary(ctx, cube));
    Ok(())
}

/// The table's "rad|m" units, resolved for the module's kind.
fn unit_for(d: &ParamDef, kind: &str) -> String {
    match d.unit.split_once('|') {
        Some((rot, lin)) => (if kind == "linear" { lin } else { rot }).into(),
        None => d.unit.into(),
    }
}

fn read_state(pc: &mut PowerCube, m: ModuleId) -> anyhow::Result<u32> {
    get_u32(pc, m, ids::CUBE_STATE)
}

fn show_state(ctx: &Ctx, m: ModuleId) -> anyhow::Result<()> {
    let mut pc = ctx.powercube()?;
    let cube = read_state(&mut pc, m)?;
    if ctx.json {
        let mut doc = word_json(&flags::CUBE_STATE, cube);
        doc["module"] = json!(m);
        doc["short_state"] = json!(flags::short_state_from_cube_state(cube));
        output::json(&doc);
    } else {
        print!("module {m}: ");
        print_word(ctx, &flags::CUBE_STATE, cube);
    }
    Ok(())
}

/// One command to one module, or its broadcast to all.
fn simple(ctx: &Ctx, target: Target, req: Request, b: Broadcast) -> anyhow::Result<()> {
    let mut pc = ctx.powercube()?;
    match target.module {
        Some(id) => {
            pc.transact(module(id), &req)?;
        }
        None => pc.broadcast(b)?,
    }
    report_sent(ctx, target, req.command().name());
    Ok(())
}

fn report_sent(ctx: &Ctx, target: Target, what: &str) {
    if ctx.json {
        match target.module {
            Some(m) => output::json(&json!({"module": m, "command": what, "acknowledged": true})),
            None => output::json(&json!({"module": null, "broadcast": true, "command": what})),
        }
    } else {
        match target.module {
            Some(m) => println!("module {m}: {what} acknowledged"),
            None => println!("{what} broadcast to all modules"),
        }
    }
}

fn home(ctx: &Ctx, target: Target, wait: WaitArgs) -> anyhow::Result<()> {
    let mut pc = ctx.powercube()?;
    let modules = match target.module {
        Some(id) => {
            // No state read first: Home must be exactly one frame, and a
            // faulted module shows up in --wait anyway.
            let m = module(id);
            pc.transact(m, &Request::Home)?;
            vec![m]
        }
        None => {
            pc.broadcast(Broadcast::Home)?;
            if wait.wait {
                present_modules(&mut pc)?
            } else {
                vec![]
            }
        }
    };
    if !wait.wait {
        report_sent(ctx, target, "Home");
        return Ok(());
    }
    let mut results = Vec::new();
    for m in modules {
        let end = wait_until(ctx, &mut pc, m, wait, "homing", |cube, _| {
            cube & state::HOME_OK != 0 && cube & state::MOTION == 0
        })?;
        results.push(end);
    }
    print_wait_results(ctx, "Home", &results);
    Ok(())
}

/// Ids that answer DefCubeVersion (a quick pipelined scan).
fn present_modules(pc: &mut PowerCube) -> anyhow::Result<Vec<ModuleId>> {
    let probes: Vec<_> = ModuleId::all().map(|m| (m, Request::GetExtended { param: ids::DEF_CUBE_VERSION })).collect();
    let answers = pc.transact_many(&probes)?;
    Ok(probes.iter().zip(answers).filter(|(_, a)| a.is_ok()).map(|((m, _), _)| *m).collect())
}

/// Motion is refused while the module reports an error or is halted: it
/// would not move, and the user should reset first.
fn refuse_if_faulted(pc: &mut PowerCube, m: ModuleId) -> anyhow::Result<()> {
    if let Some(why) = limits::not_ready(read_state(pc, m)?) {
        return Err(DeviceFault(format!(
            "module {m} is not ready ({}): clear it with `axisctl reset -m {m}`",
            why.join(", ")
        ))
        .into());
    }
    Ok(())
}

struct WaitEnd {
    module: ModuleId,
    position: f32,
    cube: u32,
    elapsed: Duration,
}

/// Polls CubeState and ActPos until `done`; an error flag ends the wait
/// with exit 5, Ctrl-C and the wait timeout halt the module first.
fn wait_until(
    ctx: &Ctx,
    pc: &mut PowerCube,
    m: ModuleId,
    wait: WaitArgs,
    what: &str,
    mut done: impl FnMut(u32, f32) -> bool,
) -> anyhow::Result<WaitEnd> {
    super::arm_interrupt()?;
    let clock = std::sync::Arc::clone(pc.clock());
    let start = clock.now();
    let limit = Duration::from_secs_f64(wait.wait_timeout.max(0.0));
    let bar = crate::output::spinner(ctx.json);
    let attempts = 1 + ctx.retry.read_retries;
    let halt = |pc: &mut PowerCube| halt_module(pc, m, attempts);
    let result = loop {
        if interrupted() {
            let halted = halt(pc);
            break Err(Interrupted(match halted {
                Ok(_) => format!(": module {m} halted"),
                Err(e) => format!(": HALT OF MODULE {m} FAILED: {e}"),
            })
            .into());
        }
        let vals = match get_many(pc, m, &[param(ids::CUBE_STATE), param(ids::ACT_POS)]) {
            Ok(v) => v,
            // The module may still be moving: stop it before giving up.
            Err(e) => {
                let note = match halt(pc) {
                    Ok(_) => format!("module {m} halted"),
                    Err(h) => format!("HALT OF MODULE {m} FAILED: {h}"),
                };
                break Err(e.context(format!("lost track of module {m} while {what} ({note})")));
            }
        };
        let (cube, pos) = (f64_of(&vals[0]) as u32, f64_of(&vals[1]) as f32);
        let elapsed = clock.now() - start;
        if let Some(bar) = &bar {
            bar.set_message(format!("module {m} {what}: pos {pos:.4}  {}", state_summary(ctx, cube)));
            bar.tick();
        }
        let d = flags::CUBE_STATE.decode(cube);
        if d.has_error() {
            break Err(DeviceFault(format!(
                "module {m} reports an error while {what}: {} (state {cube:#010x})",
                d.errors.join(", ")
            ))
            .into());
        }
        if done(cube, pos) {
            break Ok(WaitEnd { module: m, position: pos, cube, elapsed });
        }
        if elapsed >= limit {
            let halted = halt(pc).is_ok();
            break Err(anyhow::Error::new(SessionError::Timeout {
                target: format!("module {m}"),
                what: format!("the end of {what} ({})", if halted { "module halted" } else { "HALT FAILED" }),
                timeout: limit,
            }));
        }
        clock.sleep(Duration::from_millis(wait.poll));
    };
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    result
}

/// Halt, sent again when its acknowledge does not come: stopping twice is
/// harmless, not stopping is not. (Motion commands are never sent twice.)
fn halt_module(pc: &mut PowerCube, m: ModuleId, attempts: u32) -> Result<Response, SessionError> {
    let mut last = None;
    for _ in 0..attempts.max(1) {
        match pc.transact(m, &Request::Halt) {
            Ok(r) => return Ok(r),
            Err(e @ (SessionError::Timeout { .. } | SessionError::Malformed { .. })) => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.expect("at least one attempt"))
}

fn print_wait_results(ctx: &Ctx, what: &str, results: &[WaitEnd]) {
    if ctx.json {
        let list: Vec<_> = results
            .iter()
            .map(|r| {
                json!({"module": r.module, "command": what, "done": true, "position": f32_to_f64(r.position),
                       "elapsed_ms": r.elapsed.as_millis() as u64, "state": word_json(&flags::CUBE_STATE, r.cube)})
            })
            .collect();
        if let [one] = &list[..] {
            output::json(one);
        } else {
            output::json(&json!({"modules": list}));
        }
    } else {
        for r in results {
            println!(
                "module {}: {what} done at {:.4} after {:.2} s  [{}]",
                r.module,
                r.position,
                r.elapsed.as_secs_f64(),
                state_summary(ctx, r.cube)
            );
        }
    }
}

/// The module's own limits, read before any motion command.
fn read_limits(pc: &mut PowerCube, m: ModuleId, ticks: bool) -> anyhow::Result<Limits> {
    let defs: Vec<_> = Limits::param_ids(ticks).iter().map(|id| param(*id)).collect();
    let v = get_many(pc, m, &defs)?;
    Ok(Limits::from_values([0, 1, 2, 3, 4].map(|i| f64_of(&v[i])), ticks))
}

/// A refused value: exit 2 naming the limit, nothing sent.
fn refused(e: LimitError) -> anyhow::Error {
    match e {
        LimitError::Exceeds { .. } => usage(format!("{e} (use --force to skip this check)")),
        other => usage(other.to_string()),
    }
}

fn motion_value(v: f64, ticks: bool, what: &'static str) -> anyhow::Result<MotionValue> {
    limits::motion_value(v, ticks, what).map_err(refused)
}

fn send_motion(ctx: &Ctx, pc: &mut PowerCube, m: ModuleId, motion: Motion) -> anyhow::Result<Response> {
    let req = Request::SetMotion(motion);
    let resp = pc.transact(m, &req).with_context(|| format!("{} to module {m}", describe(&req)))?;
    if !ctx.json {
        println!("module {m}: {} acknowledged", describe(&req));
    }
    Ok(resp)
}

#[allow(clippy::too_many_arguments)]
fn move_ramp(
    ctx: &Ctx,
    m: ModuleId,
    pos: f64,
    vel: Option<f64>,
    acc: Option<f64>,
    ticks: bool,
    force: bool,
    wait: WaitArgs,
) -> anyhow::Result<()> {
    let target = motion_value(pos, ticks, "target position")?;
    let vel_v = vel.map(|v| motion_value(v, ticks, "velocity")).transpose()?;
    let acc_v = acc.map(|a| motion_value(a, ticks, "acceleration")).transpose()?;
    for (name, v) in [("velocity", vel), ("acceleration", acc)] {
        if let Some(v) = v {
            limits::check_positive(name, v).map_err(refused)?;
        }
    }
    let mut pc = ctx.powercube()?;
    refuse_if_faulted(&mut pc, m)?;
    if !force {
        let l = read_limits(&mut pc, m, ticks)?;
        l.check_pos(pos, m).map_err(refused)?;
        if let Some(v) = vel {
            l.check_vel(v, m).map_err(refused)?;
        }
        if let Some(a) = acc {
            l.check_acc(a, m).map_err(refused)?;
        }
    }
    let (vel_id, acc_id) =
        if ticks { (ids::TARGET_VEL_INC, ids::TARGET_ACC_INC) } else { (ids::TARGET_VEL, ids::TARGET_ACC) };
    for (id, v) in [(vel_id, vel_v), (acc_id, acc_v)] {
        if let Some(v) = v {
            let value = match v {
                MotionValue::Float(f) => Value::Float(f),
                MotionValue::Int32(i) => Value::Int32(i),
                MotionValue::Int16(i) => Value::Int16(i),
            };
            pc.set(m, param(id), value)?;
        }
    }
    let motion_id = if ticks { 9 } else { 4 };
    send_motion(ctx, &mut pc, m, Motion { id: motion_id, value: target, time_ms: None })?;
    if !wait.wait {
        if ctx.json {
            output::json(&json!({"module": m, "command": "move-ramp", "target": pos, "acknowledged": true}));
        }
        return Ok(());
    }
    let mut seen_motion = false;
    // Ticks are converted with IncRatio for the position check.
    let scale = if ticks { f64_of(&pc.get(m, param(ids::INC_RATIO))?) } else { 1.0 };
    let goal = if ticks && scale != 0.0 { pos / scale } else { pos };
    let end = wait_until(ctx, &mut pc, m, wait, "moving", |cube, p| {
        seen_motion |= cube & state::MOTION != 0;
        let near = (f64::from(p) - goal).abs() <= 1e-3 * goal.abs().max(1.0);
        cube & state::MOTION == 0 && cube & state::RAMP_END != 0 && (seen_motion || near)
    })?;
    print_wait_results(ctx, "move-ramp", &[end]);
    Ok(())
}

fn move_step(ctx: &Ctx, m: ModuleId, pos: f64, time: u16, ticks: bool, force: bool) -> anyhow::Result<()> {
    let target = motion_value(pos, ticks, "target position")?;
    let mut pc = ctx.powercube()?;
    refuse_if_faulted(&mut pc, m)?;
    if !force {
        read_limits(&mut pc, m, ticks)?.check_pos(pos, m).map_err(refused)?;
    }
    let id = if ticks { 11 } else { 6 };
    send_motion(ctx, &mut pc, m, Motion { id, value: target, time_ms: Some(time) })?;
    if ctx.json {
        output::json(
            &json!({"module": m, "command": "move-step", "target": pos, "time_ms": time, "acknowledged": true}),
        );
    }
    Ok(())
}

fn move_vel(ctx: &Ctx, m: ModuleId, vel: f64, ticks: bool, force: bool) -> anyhow::Result<()> {
    let value = motion_value(vel, ticks, "velocity")?;
    let mut pc = ctx.powercube()?;
    refuse_if_faulted(&mut pc, m)?;
    if !force {
        read_limits(&mut pc, m, ticks)?.check_vel(vel, m).map_err(refused)?;
    }
    send_motion(ctx, &mut pc, m, Motion { id: if ticks { 12 } else { 7 }, value, time_ms: None })?;
    if ctx.json {
        output::json(&json!({"module": m, "command": "move-vel", "velocity": vel, "acknowledged": true}));
    }
    Ok(())
}

fn move_cur(ctx: &Ctx, m: ModuleId, amps: f64, force: bool) -> anyhow::Result<()> {
    limits::check_finite("current", amps).map_err(refused)?;
    let mut pc = ctx.powercube()?;
    refuse_if_faulted(&mut pc, m)?;
    if !force {
        read_limits(&mut pc, m, false)?.check_cur(amps, m).map_err(refused)?;
    }
    send_motion(ctx, &mut pc, m, Motion { id: 8, value: MotionValue::Float(amps as f32), time_ms: None })?;
    if ctx.json {
        output::json(&json!({"module": m, "command": "move-cur", "current": amps, "acknowledged": true}));
    }
    Ok(())
}

fn resolve(text: &str) -> anyhow::Result<&'static ParamDef> {
    table::resolve_param(text).ok_or_else(|| {
        usage(format!("unknown parameter {text:?}: use a manual name such as ActPos or an id such as 60 or 0x3c"))
    })
}

fn get_param(ctx: &Ctx, m: ModuleId, names: &[String], all: bool) -> anyhow::Result<()> {
    let defs: Vec<&'static ParamDef> = if all {
        table::PARAMS.iter().filter(|d| d.access.readable()).collect()
    } else {
        let defs = names.iter().map(|n| resolve(n)).collect::<anyhow::Result<Vec<_>>>()?;
        if let Some(d) = defs.iter().find(|d| !d.access.readable()) {
            return Err(usage(format!("{} ({:#04x}) is not readable (the manual marks it write-only)", d.name, d.id)));
        }
        defs
    };
    let mut pc = ctx.powercube()?;
    // Config rides along so that "rad|m" units resolve for the module's kind.
    let mut with_config = defs.clone();
    with_config.push(param(ids::CONFIG));
    let mut vals = get_many(&mut pc, m, &with_config)?;
    let kind = vals.pop().map_or("rotary", |c| kind_of(f64_of(&c) as u32));
    if ctx.json {
        let mut params = serde_json::Map::new();
        for (d, v) in defs.iter().zip(&vals) {
            params.insert(
                d.name.into(),
                json!({"id": d.id, "type": d.ty.name(), "unit": unit_for(d, kind), "value": serde_json::to_value(v)?}),
            );
        }
        output::json(&json!({"module": m, "params": params}));
        return Ok(());
    }
    let mut rows = vec![["PARAMETER", "ID", "TYPE", "VALUE", "UNIT"].map(String::from).to_vec()];
    for (d, v) in defs.iter().zip(&vals) {
        rows.push(vec![d.name.into(), format!("{:#04x}", d.id), d.ty.name().into(), v.to_string(), unit_for(d, kind)]);
    }
    output::table(&rows, ctx.style);
    Ok(())
}

fn set_param(ctx: &Ctx, m: ModuleId, name: &str, text: &str) -> anyhow::Result<()> {
    let d = resolve(name)?;
    if !d.access.writable() {
        return Err(usage(format!("{} ({:#04x}) is read-only; nothing was sent", d.name, d.id)));
    }
    let value = Value::parse(d.ty, text).map_err(|e| usage(format!("{}: {e}; nothing was sent", d.name)))?;
    let mut pc = ctx.powercube()?;
    pc.set(m, d, value)?;
    if ctx.json {
        output::json(&json!({"module": m, "param": d.name, "id": d.id, "type": d.ty.name(), "value": value}));
    } else {
        println!("module {m}: {} = {value} acknowledged", d.name);
    }
    Ok(())
}

fn print_config(ctx: &Ctx, m: ModuleId, raw: u32) {
    if ctx.json {
        let mut doc = word_json(&flags::CONFIG, raw);
        doc["module"] = json!(m);
        output::json(&doc);
    } else {
        print!("module {m}: ");
        print_word(ctx, &flags::CONFIG, raw);
    }
}

fn get_config(ctx: &Ctx, m: ModuleId) -> anyhow::Result<()> {
    let mut pc = ctx.powercube()?;
    let raw = get_u32(&mut pc, m, ids::CONFIG)?;
    print_config(ctx, m, raw);
    Ok(())
}

fn set_config(ctx: &Ctx, m: ModuleId, changes: &[String], raw: Option<&str>) -> anyhow::Result<()> {
    // Resolve every flag before opening the link: a typo sends nothing.
    let mut set = 0u32;
    let mut clear = 0u32;
    for c in changes {
        let (on, name) = match c.as_bytes().first() {
            Some(b'+') => (true, &c[1..]),
            Some(b'-') => (false, &c[1..]),
            _ => return Err(usage(format!("{c:?}: write +FLAG to set or -FLAG to clear"))),
        };
        let def = flags::CONFIG.flag(name).ok_or_else(|| {
            usage(format!("unknown Config flag {name:?} (e.g. CONFIGID_MOD_BRAKE_PRESENT or brake-present)"))
        })?;
        if on {
            set |= def.mask
        } else {
            clear |= def.mask
        }
    }
    let raw = raw
        .map(|r| {
            parse_int(r)
                .and_then(|v| u32::try_from(v).ok())
                .ok_or_else(|| usage(format!("--raw {r:?} is not a 32-bit value")))
        })
        .transpose()?;
    let mut pc = ctx.powercube()?;
    let new = match raw {
        Some(v) => v,
        None => (get_u32(&mut pc, m, ids::CONFIG)? | set) & !clear,
    };
    pc.set(m, param(ids::CONFIG), Value::UInt32(new))?;
    let readback = get_u32(&mut pc, m, ids::CONFIG)?;
    print_config(ctx, m, readback);
    if readback != new {
        return Err(DeviceFault(format!("module {m} kept Config {readback:#010x} instead of {new:#010x}")).into());
    }
    Ok(())
}

fn dio(ctx: &Ctx, m: ModuleId, out: Option<&str>) -> anyhow::Result<()> {
    let outputs = out
        .map(|o| {
            parse_int(o)
                .filter(|v| (0..=0xf).contains(v))
                .ok_or_else(|| usage(format!("--out {o:?} must be a 4-bit mask 0..15 (e.g. 0b0101)")))
        })
        .transpose()?;
    let mut pc = ctx.powercube()?;
    let mut raw = get_u32(&mut pc, m, ids::DIO_SETUP)?;
    if let Some(o) = outputs {
        raw = (raw & !0xf0) | ((o as u32) << 4);
        pc.set(m, param(ids::DIO_SETUP), Value::UInt32(raw))?;
        raw = get_u32(&mut pc, m, ids::DIO_SETUP)?;
    }
    if ctx.json {
        let mut doc = word_json(&flags::DIO_SETUP, raw);
        doc["module"] = json!(m);
        doc["inputs"] = json!(raw & 0xf);
        doc["outputs"] = json!((raw >> 4) & 0xf);
        output::json(&doc);
    } else {
        print!("module {m}: ");
        print_word(ctx, &flags::DIO_SETUP, raw);
    }
    Ok(())
}

fn watchdog(ctx: &Ctx, action: WatchdogAction) -> anyhow::Result<()> {
    let mut pc = ctx.powercube()?;
    match action {
        WatchdogAction::On(a) | WatchdogAction::Off(a) if !pc.is_can() => {
            let _ = a;
            Err(usage("the watchdog is a CAN feature (its refresh is a CAN broadcast)"))
        }
        WatchdogAction::On(a) => {
            let m = module(a.module);
            let cfg = get_u32(&mut pc, m, ids::CONFIG)?;
            if cfg & config::WATCHDOG_ENABLE == 0 {
                pc.set(m, param(ids::CONFIG), Value::UInt32(cfg | config::WATCHDOG_ENABLE))?;
            }
            pc.transact(m, &Request::Watchdog)?;
            if ctx.json {
                output::json(&json!({"module": m, "watchdog": "toggled", "config_enabled": true}));
            } else {
                println!("module {m}: watchdog switched (0x07 toggles online/offline); keep it alive with `axisctl watchdog keepalive`, or it halts within 50 ms");
            }
            Ok(())
        }
        WatchdogAction::Off(a) => {
            let m = module(a.module);
            pc.transact(m, &Request::Watchdog)?;
            if ctx.json {
                output::json(&json!({"module": m, "watchdog": "toggled"}));
            } else {
                println!("module {m}: watchdog switched (0x07 toggles online/offline)");
            }
            Ok(())
        }
        WatchdogAction::Keepalive { interval, duration } => keepalive(ctx, &mut pc, interval, duration),
    }
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
        output::json(&json!({"refreshes": st.refreshes, "interval_ms": interval_ms,
            "min_gap_ms": ms(st.min_gap_us), "mean_gap_ms": ms(st.mean_gap_us), "p99_gap_ms": ms(st.p99_gap_us),
            "max_gap_ms": ms(st.max_gap_us), "scheduling": scheduling}));
    } else {
        println!(
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
