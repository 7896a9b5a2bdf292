//! Cdios 6168 commands (`cdios-*`). Every command is built and range-checked
//! with the protocol table before the link is opened: bad input sends nothing.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axisctl::proto::cdios::table::{self, Field, STATUS_FLAGS};
use axisctl::proto::cdios::{
    decode_status, Address, AnalogOutput, Command, Direction, ErrorReply, GotoMode, ModuleId, NodeId, PositionSource,
    ServoConfig, ServoPart, StartOption, StatusReport, StopOption, Timers, Traject, ValidationError,
};
use axisctl::proto::parse_int;
use axisctl::session::cdios::{describe_answer, Cdios, Event};
use axisctl::session::SessionError;
use serde_json::{json, Value};

use super::{interrupted, usage, Ctx, DeviceFault, Interrupted};
use crate::cli::cdios::{
    CdiosCommand, DirectionArg, ModuleTarget, NodeArgs, PositionKind, StartOptionArg, StopOptionArg,
};
use crate::cli::WaitArgs;
use crate::output;

pub fn run(ctx: &Ctx, cmd: CdiosCommand) -> anyhow::Result<()> {
    match cmd {
        CdiosCommand::Identify { node } => identify(ctx, node),
        CdiosCommand::Status(t) => status(ctx, t),
        CdiosCommand::Position { target, source, all } => position(ctx, target, source, all),
        CdiosCommand::SetPosition { target, position } => set_position(ctx, target, position),
        CdiosCommand::Goto { target, position, relative, setpoint_relative, latched, speed, wait } => {
            let mode = match (relative, setpoint_relative, latched) {
                (false, false, false) => GotoMode::Absolute,
                (false, false, true) => GotoMode::AbsoluteSync,
                (true, _, false) => GotoMode::Relative,
                (true, _, true) => GotoMode::RelativeSync,
                (false, true, false) => GotoMode::SetpointRelative,
                (false, true, true) => GotoMode::SetpointRelativeSync,
            };
            goto(ctx, target, mode, position, speed, wait)
        }
        CdiosCommand::Traject { target, traject, latched, wait } => run_traject(ctx, target, traject, latched, wait),
        CdiosCommand::Start { target, direction, option, speed, latched } => {
            start(ctx, target, direction, option, speed, latched)
        }
        CdiosCommand::Stop { target, option, latched } => {
            let option = match option {
                StopOptionArg::ToMinSpeed => StopOption::DecelerateToMinimum,
                StopOptionArg::Decelerate => StopOption::DecelerateAndStop,
                StopOptionArg::Fast => StopOption::FastStop,
                StopOptionArg::ReleaseEmergency => StopOption::ReleaseEmergency,
                StopOptionArg::ClearHold => StopOption::ClearHold,
            };
            simple(ctx, target, "cdios-stop", &[Command::Stop { sync: latched, option }])
        }
        CdiosCommand::Enable { target, release_emergency } => {
            let enable = Command::Start {
                sync: false,
                direction: Direction::Forward,
                option: StartOption::Enable,
                motor_speed: 0,
            };
            let release = Command::Stop { sync: false, option: StopOption::ReleaseEmergency };
            let cmds: Vec<Command> = if release_emergency { vec![release, enable] } else { vec![enable] };
            simple(ctx, target, "cdios-enable", &cmds)
        }
        CdiosCommand::Disable(t) => {
            simple(ctx, t, "cdios-disable", &[Command::Stop { sync: false, option: StopOption::Disable }])
        }
        CdiosCommand::Config { target, items } => config(ctx, target, &items),
        CdiosCommand::Outputs { target, set, latched } => outputs(ctx, target, set.as_deref(), latched),
        CdiosCommand::Analog { target, output, set, latched } => analog(ctx, target, output, set, latched),
        CdiosCommand::Events {
            target,
            mask,
            raw_masks,
            position_interval,
            position_on_change,
            speed_interval,
            speed_on_change,
        } => events(
            ctx,
            target,
            EventChanges {
                mask: mask.as_deref(),
                raw_masks: raw_masks.as_deref(),
                position_interval,
                position_on_change,
                speed_interval,
                speed_on_change,
            },
        ),
        CdiosCommand::Store { target, defaults } => store(ctx, target, defaults),
        CdiosCommand::Watch { target, poll, no_poll, count, duration } => {
            watch(ctx, target, poll, no_poll, count, duration)
        }
    }
}

// ---- plumbing ----

fn node_id(n: &NodeArgs) -> NodeId {
    NodeId::new(n.node).expect("clap checks 1..=127")
}

fn module_id(t: &ModuleTarget) -> ModuleId {
    ModuleId::new(t.module).expect("clap checks 0..=15")
}

fn addr(t: &ModuleTarget) -> Address {
    Address::Module(module_id(t))
}

/// A manual range violation: exit 2, nothing sent.
fn invalid(e: ValidationError) -> anyhow::Error {
    usage(format!("{e}; nothing was sent"))
}

/// Encodes (and so range-checks) every command before anything is sent.
fn check(cmds: &[Command], address: Address) -> anyhow::Result<()> {
    for c in cmds {
        c.encode(address).map_err(invalid)?;
    }
    Ok(())
}

/// A user value for a field of a table row, checked against the manual's range.
fn field_value<T: TryFrom<i64>>(row: &str, key: &str, v: i64) -> anyhow::Result<T> {
    let field = table::command(row).and_then(|d| d.field(key)).expect("row and field are in the table");
    field.check(v).map_err(invalid)?;
    T::try_from(v).map_err(|_| {
        invalid(ValidationError::OutOfRange { field: field.key, value: v, min: field.min, max: field.max })
    })
}

fn open(ctx: &Ctx, n: &NodeArgs) -> anyhow::Result<Cdios> {
    let mut s = Cdios::new(ctx.can_link()?).with_clock(Arc::clone(&ctx.clock));
    if let Some(t) = ctx.timeout {
        s.set_timeout(t);
    }
    s.set_retry(ctx.retry);
    s.set_nmt(!n.no_nmt);
    s.set_confirm(!n.no_confirm);
    if ctx.trace {
        s.set_tracer(Box::new(super::print_trace));
    }
    Ok(s)
}

fn status_json(r: &StatusReport) -> Value {
    json!({"status": r.status, "flags": r.flags, "errors": r.errors, "reserved": r.reserved})
}

fn status_line(ctx: &Ctx, r: &StatusReport) -> String {
    let names: Vec<String> =
        r.flags.iter().map(|n| if r.errors.contains(n) { ctx.style.error(n) } else { (*n).to_string() }).collect();
    let bytes = r.status.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ");
    format!("[{bytes}] {}", if names.is_empty() { "-".into() } else { names.join(" ") })
}

// ---- commands ----

fn identify(ctx: &Ctx, n: NodeArgs) -> anyhow::Result<()> {
    let node = node_id(&n);
    let mut s = open(ctx, &n)?;
    let mut modules = Vec::new();
    for selector in 0..=7u8 {
        let r = s.read(node, Address::Controller, &Command::Identify { selector })?;
        for (i, (ty, ver)) in [("first_type", "first_version"), ("second_type", "second_version")].iter().enumerate() {
            let t = r.get(ty).unwrap_or(0);
            let v = r.get(ver).unwrap_or(0);
            modules.push(json!({"module": 2 * selector + i as u8, "type": t, "version": v, "present": t != 0}));
        }
    }
    if ctx.json {
        output::json(&json!({"node": node, "modules": modules}));
        return Ok(());
    }
    let mut rows = vec![["MODULE", "TYPE", "VERSION"].map(String::from).to_vec()];
    for m in modules.iter().filter(|m| m["present"] == true) {
        rows.push(vec![
            m["module"].to_string(),
            format!("{:#04x}", m["type"].as_i64().unwrap_or(0)),
            format!("{:#04x}", m["version"].as_i64().unwrap_or(0)),
        ]);
    }
    if rows.len() == 1 {
        println!("node {node}: the controller reports no I/O modules");
    } else {
        println!("node {node}:");
        output::table(&rows, ctx.style);
    }
    Ok(())
}

fn status(ctx: &Ctx, t: ModuleTarget) -> anyhow::Result<()> {
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    let r = s.read_status(node, m)?;
    let (speed, rpm_error) = s.read_speed(node, m)?;
    if ctx.json {
        let mut doc = json!({"node": node, "module": m});
        merge(&mut doc, status_json(&r));
        doc["motor_speed"] = json!(speed);
        doc["rpm_error"] = json!(rpm_error);
        output::json(&doc);
        return Ok(());
    }
    println!("node {node} module {m}: {}", status_line(ctx, &r));
    let mut rows = Vec::new();
    for f in STATUS_FLAGS.iter().filter(|f| f.is_set(&r.status)) {
        let name = if f.class == table::Class::Error { ctx.style.error(f.name) } else { f.name.to_string() };
        rows.push(vec![format!("  status {} bit {}", f.byte, f.bit), name, f.meaning.to_string()]);
    }
    output::table(&rows, ctx.style);
    for (b, bit) in &r.reserved {
        println!("  {}", ctx.style.warn(&format!("status {b} bit {bit} is set (reserved)")));
    }
    println!("  motor speed {speed} RPM, RPM error {rpm_error}");
    Ok(())
}

fn merge(doc: &mut Value, more: Value) {
    if let (Some(d), Value::Object(m)) = (doc.as_object_mut(), more) {
        d.extend(m);
    }
}

fn source_of(k: PositionKind) -> PositionSource {
    match k {
        PositionKind::Current => PositionSource::Current,
        PositionKind::Latched => PositionSource::Latched,
        PositionKind::Setpoint => PositionSource::Setpoint,
    }
}

fn position(ctx: &Ctx, t: ModuleTarget, kind: PositionKind, all: bool) -> anyhow::Result<()> {
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    if all {
        let cur = s.read_position(node, m, PositionSource::Current)?;
        let latched = s.read_position(node, m, PositionSource::Latched)?;
        let setpoint = s.read_position(node, m, PositionSource::Setpoint)?;
        if ctx.json {
            output::json(
                &json!({"node": node, "module": m, "position": cur, "latched": latched, "setpoint": setpoint}),
            );
        } else {
            println!("node {node} module {m}: position {cur}, latched {latched}, setpoint {setpoint}");
        }
        return Ok(());
    }
    let p = s.read_position(node, m, source_of(kind))?;
    let name = format!("{kind:?}").to_lowercase();
    if ctx.json {
        output::json(&json!({"node": node, "module": m, "source": name, "position": p}));
    } else {
        println!("node {node} module {m}: {name} position {p}");
    }
    Ok(())
}

fn report_sent(ctx: &Ctx, node: NodeId, m: ModuleId, what: &str, confirmed: bool, extra: Value) {
    if ctx.json {
        let mut doc = json!({"node": node, "module": m, "command": what, "confirmed": confirmed});
        merge(&mut doc, extra);
        output::json(&doc);
    } else {
        let how = if confirmed { "confirmed" } else { "sent (confirmations off, no error came)" };
        println!("node {node} module {m}: {what} {how}");
    }
}

/// Commands sent one after the other, each awaited.
fn simple(ctx: &Ctx, t: ModuleTarget, what: &str, cmds: &[Command]) -> anyhow::Result<()> {
    check(cmds, addr(&t))?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    let mut confirmed = true;
    for c in cmds {
        confirmed &= s.transact(node, addr(&t), c)?.is_some();
    }
    report_sent(ctx, node, m, what, confirmed, json!({}));
    Ok(())
}

fn set_position(ctx: &Ctx, t: ModuleTarget, position: i64) -> anyhow::Result<()> {
    let position = field_value::<i32>("set_position", "position", position)?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let cmd = Command::SetPosition { position };
    check(&[cmd], addr(&t))?;
    let mut s = open(ctx, &t.node)?;
    let confirmed = s.transact(node, addr(&t), &cmd)?.is_some();
    report_sent(ctx, node, m, "cdios-set-position", confirmed, json!({"position": position}));
    Ok(())
}

fn mode_name(mode: GotoMode) -> &'static str {
    table::command("goto").and_then(|d| d.selector(mode.to_u8())).map_or("?", |s| s.key)
}

fn goto(
    ctx: &Ctx,
    t: ModuleTarget,
    mode: GotoMode,
    position: i64,
    speed: Option<i64>,
    wait: WaitArgs,
) -> anyhow::Result<()> {
    let position = field_value::<i32>("goto", "position", position)?;
    let speed = speed.map(|v| field_value::<u16>("goto_next_speed", "speed", v)).transpose()?;
    let mut cmds = Vec::new();
    if let Some(speed) = speed {
        cmds.push(Command::SetNextGotoSpeed { speed });
    }
    cmds.push(Command::Goto { mode, position });
    check(&cmds, addr(&t))?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    let mut confirmed = true;
    for c in &cmds {
        confirmed &= s.transact(node, addr(&t), c)?.is_some();
    }
    let mut extra = json!({"mode": mode_name(mode), "requested": position});
    if let Some(v) = speed {
        extra["speed"] = json!(v);
    }
    if !wait.wait {
        report_sent(ctx, node, m, "cdios-goto", confirmed, extra);
        return Ok(());
    }
    if !ctx.json {
        println!(
            "node {node} module {m}: goto {} {position} {}",
            mode_name(mode),
            if confirmed { "confirmed" } else { "sent" }
        );
    }
    // The setpoint is where a relative goto ends.
    let target = s.read_position(node, m, PositionSource::Setpoint)?;
    let tolerance = positioning_error(&mut s, node, m)?;
    let mut seen = false;
    let end = wait_motion(ctx, &mut s, node, m, wait, "goto", |r, pos| {
        let active = r.flags.iter().any(|f| *f == "GOTO_ACTIVE" || *f == "TRAJECT_RUNNING");
        seen |= active;
        !active && (seen || (i64::from(pos) - i64::from(target)).abs() <= tolerance)
    })?;
    print_wait_end(ctx, "cdios-goto", &end, Some(target), extra);
    Ok(())
}

/// The configured 'Positioning Error' (20h selector 83h).
fn positioning_error(s: &mut Cdios, node: NodeId, m: ModuleId) -> anyhow::Result<i64> {
    let r = s.read(node, Address::Module(m), &Command::ReadServoConfig(ServoPart::Control))?;
    Ok(r.get("positioning_error").unwrap_or(0))
}

fn run_traject(ctx: &Ctx, t: ModuleTarget, traject: i64, latched: bool, wait: WaitArgs) -> anyhow::Result<()> {
    let n = field_value::<u8>("goto_traject", "traject", traject)?;
    let traject = Traject::from_u8(n).expect("checked 0..=1 by the table");
    let cmd = Command::GotoTraject { traject, sync: latched };
    check(&[cmd], addr(&t))?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    let confirmed = s.transact(node, addr(&t), &cmd)?.is_some();
    let extra = json!({"traject": n, "latched": latched});
    if !wait.wait {
        report_sent(ctx, node, m, "cdios-traject", confirmed, extra);
        return Ok(());
    }
    let mut seen = false;
    let end = wait_motion(ctx, &mut s, node, m, wait, "traject", |r, _| {
        let active = r.flags.iter().any(|f| *f == "GOTO_ACTIVE" || *f == "TRAJECT_RUNNING");
        seen |= active;
        seen && !active
    })?;
    print_wait_end(ctx, "cdios-traject", &end, None, extra);
    Ok(())
}

fn start(
    ctx: &Ctx,
    t: ModuleTarget,
    direction: DirectionArg,
    option: StartOptionArg,
    speed: Option<i64>,
    latched: bool,
) -> anyhow::Result<()> {
    let option = match option {
        StartOptionArg::MinSpeed => StartOption::MinimumSpeed,
        StartOptionArg::Accelerate => StartOption::Accelerate,
        StartOptionArg::UntilEndSwitch => StartOption::UntilEndSwitch,
        StartOptionArg::ToSpeed => StartOption::ToSpeed,
        StartOptionArg::UntilIndex => StartOption::UntilIndex,
        StartOptionArg::UntilIndexAndZero => StartOption::UntilIndexAndZero,
    };
    if option == StartOption::ToSpeed && speed.is_none() {
        return Err(usage("--option to-speed needs --speed RPM; nothing was sent"));
    }
    if option != StartOption::ToSpeed && speed.is_some() {
        return Err(usage("--speed is used only with --option to-speed; nothing was sent"));
    }
    let motor_speed = field_value::<u16>("start", "motor_speed", speed.unwrap_or(0))?;
    let direction = match direction {
        DirectionArg::Forward => Direction::Forward,
        DirectionArg::Reverse => Direction::Reverse,
    };
    simple(ctx, t, "cdios-start", &[Command::Start { sync: latched, direction, option, motor_speed }])
}

struct WaitEnd {
    position: i32,
    status: StatusReport,
    elapsed: Duration,
}

/// Polls status and position until `done`; an error flag ends the wait with
/// exit 5; Ctrl-C and the wait timeout fast-stop the motor first.
fn wait_motion(
    ctx: &Ctx,
    s: &mut Cdios,
    node: NodeId,
    m: ModuleId,
    wait: WaitArgs,
    what: &str,
    mut done: impl FnMut(&StatusReport, i32) -> bool,
) -> anyhow::Result<WaitEnd> {
    super::arm_interrupt()?;
    let clock = Arc::clone(s.clock());
    let start = clock.now();
    let limit = Duration::from_secs_f64(wait.wait_timeout.max(0.0));
    let bar = crate::output::spinner(ctx.json);
    // Sent again when no confirmation comes: stopping twice is harmless.
    let attempts = 1 + ctx.retry.read_retries;
    let stop = |s: &mut Cdios| {
        let mut last = None;
        for _ in 0..attempts {
            match s.transact(node, Address::Module(m), &Command::Stop { sync: false, option: StopOption::FastStop }) {
                Ok(a) => return Ok(a),
                Err(e @ (SessionError::Timeout { .. } | SessionError::Malformed { .. })) => last = Some(e),
                Err(e) => return Err(e),
            }
        }
        Err(last.expect("at least one attempt"))
    };
    let result = loop {
        if interrupted() {
            break Err(Interrupted(match stop(s) {
                Ok(_) => format!(": node {node} module {m} stopped (fast stop)"),
                Err(e) => format!(": STOP OF NODE {node} MODULE {m} FAILED: {e}"),
            })
            .into());
        }
        let polled = s.read_status(node, m).and_then(|r| Ok((r, s.read_position(node, m, PositionSource::Current)?)));
        let (r, pos) = match polled {
            Ok(v) => v,
            // The motor may still be running: stop it before giving up.
            Err(e) => {
                let note = match stop(s) {
                    Ok(_) => format!("node {node} module {m} stopped (fast stop)"),
                    Err(h) => format!("STOP OF NODE {node} MODULE {m} FAILED: {h}"),
                };
                break Err(anyhow::Error::new(e).context(format!("lost track of the {what} ({note})")));
            }
        };
        let elapsed = clock.now() - start;
        if let Some(bar) = &bar {
            bar.set_message(format!("module {m} {what}: pos {pos}  {}", status_line(ctx, &r)));
            bar.tick();
        }
        if !r.errors.is_empty() {
            let _ = stop(s);
            break Err(DeviceFault(format!(
                "node {node} module {m} reports an error during the {what}: {} (status {:02x?})",
                r.errors.join(", "),
                r.status
            ))
            .into());
        }
        if done(&r, pos) {
            break Ok(WaitEnd { position: pos, status: r, elapsed });
        }
        if elapsed >= limit {
            let _ = stop(s);
            break Err(anyhow::Error::new(SessionError::Timeout {
                target: format!("node {node} module {m}"),
                what: format!("the end of the {what} (motor stopped)"),
                timeout: limit,
            }));
        }
        s.listen(Duration::from_millis(wait.poll))?;
    };
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    result
}

fn print_wait_end(ctx: &Ctx, what: &str, end: &WaitEnd, target: Option<i32>, extra: Value) {
    if ctx.json {
        let mut doc = json!({"command": what, "done": true, "position": end.position,
                             "elapsed_ms": end.elapsed.as_millis() as u64});
        if let Some(t) = target {
            doc["target"] = json!(t);
        }
        merge(&mut doc, extra);
        let mut st = status_json(&end.status);
        merge(&mut st, doc);
        output::json(&st);
    } else {
        println!(
            "{what} done at {} after {:.2} s  {}",
            end.position,
            end.elapsed.as_secs_f64(),
            status_line(ctx, &end.status)
        );
    }
}

// ---- configuration ----

/// JSON group and key of a servo configuration field, e.g. `traject0` / `speed2`.
fn group_of(part: ServoPart) -> String {
    match part {
        ServoPart::TrajectEnd(t)
        | ServoPart::TrajectInitialSpeed(t)
        | ServoPart::TrajectChangePosition(t, _)
        | ServoPart::TrajectSpeed(t, _) => format!("traject{}", t.to_u8()),
        other => format!("{other:?}").to_lowercase(),
    }
}

fn key_of(part: ServoPart, field: &Field) -> String {
    match part {
        ServoPart::TrajectChangePosition(_, s) | ServoPart::TrajectSpeed(_, s) => {
            format!("{}{}", field.key, s.to_u8())
        }
        _ => field.key.to_string(),
    }
}

fn set_row(part: ServoPart) -> &'static table::CommandDef {
    table::command_for(table::SERVO_CONFIGURATION, part.selector()).expect("every part has a set row")
}

/// Every configurable field: (part, field, `group.key` name).
fn config_fields() -> Vec<(ServoPart, &'static Field, String)> {
    let mut out = Vec::new();
    for part in ServoPart::all() {
        for f in set_row(part).value_fields() {
            out.push((part, f, format!("{}.{}", group_of(part), key_of(part, f))));
        }
    }
    out
}

const GROUPS: &[&str] = &["speeds", "voltage", "encoder", "control", "inputs", "traject0", "traject1"];

fn norm(s: &str) -> String {
    s.trim().to_ascii_lowercase().replace('-', "_")
}

/// `maximum_speed` or `speeds.maximum_speed`; trajects need their group.
fn find_field(name: &str) -> Option<(ServoPart, &'static Field)> {
    let n = norm(name);
    config_fields()
        .into_iter()
        .find(|(part, _, full)| {
            *full == n || (!group_of(*part).starts_with("traject") && full.ends_with(&format!(".{n}")))
        })
        .map(|(p, f, _)| (p, f))
}

/// Field keys and new values of one selector.
type Assignments = Vec<(&'static str, i64)>;

fn config(ctx: &Ctx, t: ModuleTarget, items: &[String]) -> anyhow::Result<()> {
    let sets: Vec<&String> = items.iter().filter(|i| i.contains('=')).collect();
    if !sets.is_empty() && sets.len() != items.len() {
        return Err(usage("give either parts to show or FIELD=VALUE assignments, not both"));
    }
    if sets.is_empty() {
        let groups: Vec<String> = if items.is_empty() {
            GROUPS.iter().map(|g| g.to_string()).collect()
        } else {
            items
                .iter()
                .map(|i| {
                    let g = norm(i);
                    if GROUPS.contains(&g.as_str()) {
                        Ok(g)
                    } else {
                        Err(usage(format!("unknown part {i:?}; parts: {}", GROUPS.join(", "))))
                    }
                })
                .collect::<anyhow::Result<_>>()?
        };
        return show_config(ctx, t, &groups);
    }
    // Resolve and range-check every assignment before anything is sent.
    let mut changes: BTreeMap<u8, (ServoPart, Assignments)> = BTreeMap::new();
    for a in sets {
        let (name, value) = a.split_once('=').expect("filtered on '='");
        let (part, field) = find_field(name).ok_or_else(|| {
            let names: Vec<String> = config_fields().into_iter().map(|(.., n)| n).collect();
            usage(format!("unknown configuration field {name:?}; fields: {}", names.join(", ")))
        })?;
        let v = parse_int(value).ok_or_else(|| usage(format!("{name}: {value:?} is not an integer")))?;
        field.check(v).map_err(invalid)?;
        changes.entry(part.selector()).or_insert((part, Vec::new())).1.push((field.key, v));
    }
    let node = node_id(&t.node);
    let mut s = open(ctx, &t.node)?;
    // Each selector is written whole: read it, change the named fields, write it.
    let mut writes = Vec::new();
    for (part, new) in changes.values() {
        let r = s.read(node, addr(&t), &Command::ReadServoConfig(*part))?;
        let cfg = ServoConfig::from_values(*part, |k| {
            new.iter().rev().find(|(nk, _)| *nk == k).map(|(_, v)| *v).or_else(|| r.get(k))
        })
        .map_err(|e| DeviceFault(format!("cannot write {}: {e}", group_of(*part))))?;
        writes.push(Command::SetServoConfig(cfg));
    }
    check(&writes, addr(&t))?;
    for w in &writes {
        s.transact(node, addr(&t), w)?;
    }
    let groups: Vec<String> = {
        let mut g: Vec<String> = changes.values().map(|(p, _)| group_of(*p)).collect();
        g.dedup();
        g
    };
    show_config_with(ctx, &mut s, t, &groups)
}

fn show_config(ctx: &Ctx, t: ModuleTarget, groups: &[String]) -> anyhow::Result<()> {
    let mut s = open(ctx, &t.node)?;
    show_config_with(ctx, &mut s, t, groups)
}

fn show_config_with(ctx: &Ctx, s: &mut Cdios, t: ModuleTarget, groups: &[String]) -> anyhow::Result<()> {
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut doc = serde_json::Map::new();
    let mut rows = vec![["FIELD", "VALUE", "UNIT", "RANGE"].map(String::from).to_vec()];
    for part in ServoPart::all().into_iter().filter(|p| groups.contains(&group_of(*p))) {
        let r = s.read(node, addr(&t), &Command::ReadServoConfig(part))?;
        let g = doc.entry(group_of(part)).or_insert_with(|| json!({}));
        for f in set_row(part).value_fields() {
            let v = r.get(f.key).unwrap_or(0);
            g[key_of(part, f)] = json!(v);
            let shown = match f.scale {
                Some(sc) => format!("{v} ({} {})", v as f64 * sc.factor, sc.unit),
                None => v.to_string(),
            };
            rows.push(vec![
                format!("{}.{}", group_of(part), key_of(part, f)),
                shown,
                f.unit.to_string(),
                format!("{}..{}", f.min, f.max),
            ]);
        }
    }
    if ctx.json {
        output::json(&json!({"node": node, "module": m, "config": doc}));
    } else {
        println!("node {node} module {m}:");
        output::table(&rows, ctx.style);
    }
    Ok(())
}

// ---- outputs ----

fn outputs(ctx: &Ctx, t: ModuleTarget, set: Option<&str>, latched: bool) -> anyhow::Result<()> {
    let set = set
        .map(|text| {
            let v = parse_int(text).ok_or_else(|| usage(format!("--set {text:?} is not a number")))?;
            field_value::<u8>("set_digital_outputs", "outputs", v)
        })
        .transpose()?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    if let Some(o) = set {
        check(&[Command::SetDigitalOutputs { latched, outputs: o }], addr(&t))?;
    }
    let mut s = open(ctx, &t.node)?;
    if let Some(o) = set {
        s.transact(node, addr(&t), &Command::SetDigitalOutputs { latched, outputs: o })?;
    }
    let r = s.read(node, addr(&t), &Command::GetDigitalOutputs)?;
    let state = r.get("state").unwrap_or(0) as u8;
    let bits: Vec<bool> = (0..4).map(|i| state & (1 << i) != 0).collect();
    if ctx.json {
        output::json(&json!({"node": node, "module": m, "outputs": state, "bits": bits}));
    } else {
        let on: Vec<String> = (0..4).filter(|i| bits[*i]).map(|i| (i + 1).to_string()).collect();
        println!(
            "node {node} module {m}: outputs {state:#06b} (on: {})",
            if on.is_empty() { "none".into() } else { on.join(", ") }
        );
    }
    Ok(())
}

fn analog(ctx: &Ctx, t: ModuleTarget, output: Option<i64>, set: Option<i64>, latched: bool) -> anyhow::Result<()> {
    let which = |n: i64| match n {
        1 => Ok(AnalogOutput::One),
        2 => Ok(AnalogOutput::Two),
        _ => Err(usage(format!("--output {n}: the 6168 has analog outputs 1 and 2; nothing was sent"))),
    };
    let outs: Vec<AnalogOutput> = match output {
        Some(n) => vec![which(n)?],
        None => vec![AnalogOutput::One, AnalogOutput::Two],
    };
    let set_cmd = match set {
        Some(v) => Some(Command::SetAnalogOutput {
            output: outs[0],
            latched,
            millivolts: field_value::<i16>("set_analog_output", "value", v)?,
        }),
        None => None,
    };
    if let Some(c) = set_cmd {
        check(&[c], addr(&t))?;
    }
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    if let Some(c) = set_cmd {
        s.transact(node, addr(&t), &c)?;
    }
    let mut list = Vec::new();
    for o in outs {
        let r = s.read(node, addr(&t), &Command::ReadAnalogOutput { output: o })?;
        let mv = r.get("value").unwrap_or(0);
        list.push(json!({"output": o.to_u8(), "millivolts": mv, "volts": mv as f64 / 1000.0}));
    }
    if ctx.json {
        output::json(&json!({"node": node, "module": m, "analog": list}));
    } else {
        for a in &list {
            println!("node {node} module {m}: analog output {} = {} V", a["output"], a["volts"]);
        }
    }
    Ok(())
}

// ---- events ----

struct EventChanges<'a> {
    mask: Option<&'a str>,
    raw_masks: Option<&'a str>,
    position_interval: Option<i64>,
    position_on_change: Option<bool>,
    speed_interval: Option<i64>,
    speed_on_change: Option<bool>,
}

impl EventChanges<'_> {
    fn any(&self) -> bool {
        self.mask.is_some()
            || self.raw_masks.is_some()
            || self.position_interval.is_some()
            || self.position_on_change.is_some()
            || self.speed_interval.is_some()
            || self.speed_on_change.is_some()
    }
}

/// Status flag names to the four mask bytes.
fn masks_from_names(text: &str) -> anyhow::Result<[u8; 4]> {
    let mut masks = [0u8; 4];
    if text.trim().eq_ignore_ascii_case("none") {
        return Ok(masks);
    }
    for name in text.split([',', '|']).map(str::trim).filter(|s| !s.is_empty()) {
        let f =
            STATUS_FLAGS.iter().find(|f| f.name.eq_ignore_ascii_case(&name.replace('-', "_"))).ok_or_else(|| {
                let all: Vec<&str> = STATUS_FLAGS.iter().map(|f| f.name).collect();
                usage(format!("unknown status flag {name:?}; flags: {}", all.join(", ")))
            })?;
        masks[f.byte as usize - 1] |= 1 << f.bit;
    }
    Ok(masks)
}

fn masks_from_raw(text: &str) -> anyhow::Result<[u8; 4]> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        return Err(usage(format!("--raw-masks {text:?}: give four bytes M1,M2,M3,M4")));
    }
    let mut out = [0u8; 4];
    for (i, p) in parts.iter().enumerate() {
        let v = parse_int(p).ok_or_else(|| usage(format!("--raw-masks: {p:?} is not a number")))?;
        out[i] = field_value::<u8>("set_event_mask", ["mask1", "mask2", "mask3", "mask4"][i], v)?;
    }
    Ok(out)
}

fn mask_flags(masks: [u8; 4]) -> Vec<&'static str> {
    STATUS_FLAGS.iter().filter(|f| f.is_set(&masks)).map(|f| f.name).collect()
}

fn events(ctx: &Ctx, t: ModuleTarget, ch: EventChanges) -> anyhow::Result<()> {
    let new_masks = match (ch.mask, ch.raw_masks) {
        (Some(n), _) => Some(masks_from_names(n)?),
        (_, Some(r)) => Some(masks_from_raw(r)?),
        _ => None,
    };
    let pi = ch.position_interval.map(|v| field_value::<u8>("set_event_mask", "position_interval", v)).transpose()?;
    let si = ch.speed_interval.map(|v| field_value::<u8>("set_event_mask", "speed_interval", v)).transpose()?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    let read = |s: &mut Cdios| -> anyhow::Result<([u8; 4], Timers)> {
        let r = s.read(node, Address::Module(m), &Command::ReadEventMask)?;
        let g = |k: &str| r.get(k).unwrap_or(0);
        Ok((
            [g("mask1") as u8, g("mask2") as u8, g("mask3") as u8, g("mask4") as u8],
            Timers {
                position_interval: g("position_interval") as u8,
                position_on_change: g("position_on_change") != 0,
                speed_interval: g("speed_interval") as u8,
                speed_on_change: g("speed_on_change") != 0,
            },
        ))
    };
    let (mut masks, mut timers) = read(&mut s)?;
    if ch.any() {
        masks = new_masks.unwrap_or(masks);
        timers.position_interval = pi.unwrap_or(timers.position_interval);
        timers.speed_interval = si.unwrap_or(timers.speed_interval);
        timers.position_on_change = ch.position_on_change.unwrap_or(timers.position_on_change);
        timers.speed_on_change = ch.speed_on_change.unwrap_or(timers.speed_on_change);
        let cmd = Command::SetEventMask { masks, timers };
        check(&[cmd], addr(&t))?;
        s.transact(node, addr(&t), &cmd)?;
        (masks, timers) = read(&mut s)?;
    }
    let ms = |c: u8| Timers::interval_ms(c).unwrap_or(0.0);
    if ctx.json {
        output::json(&json!({
            "node": node, "module": m, "masks": masks, "mask_flags": mask_flags(masks),
            "timers": {
                "position_interval": timers.position_interval, "position_interval_ms": ms(timers.position_interval),
                "position_on_change": timers.position_on_change,
                "speed_interval": timers.speed_interval, "speed_interval_ms": ms(timers.speed_interval),
                "speed_on_change": timers.speed_on_change,
            },
        }));
    } else {
        let names = mask_flags(masks);
        println!("node {node} module {m}: event masks {:02x?}", masks);
        println!("  events on: {}", if names.is_empty() { "-".into() } else { names.join(" ") });
        let every = |c: u8, change: bool| match c {
            0 => "never".to_string(),
            _ => format!("every {} ms{}", ms(c), if change { " when changed" } else { "" }),
        };
        println!("  position: {}", every(timers.position_interval, timers.position_on_change));
        println!("  speed:    {}", every(timers.speed_interval, timers.speed_on_change));
    }
    Ok(())
}

// ---- store ----

fn store(ctx: &Ctx, t: ModuleTarget, defaults: bool) -> anyhow::Result<()> {
    let cmd = Command::StoreConfiguration { defaults };
    check(&[cmd], addr(&t))?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    let t0 = s.clock().now();
    s.transact(node, addr(&t), &cmd)?;
    let elapsed = s.clock().now() - t0;
    if ctx.json {
        output::json(&json!({"node": node, "module": m, "command": "cdios-store", "defaults": defaults,
                             "confirmed": true, "elapsed_ms": elapsed.as_millis() as u64}));
    } else {
        let what = if defaults { "default configuration" } else { "configuration" };
        println!("node {node} module {m}: {what} stored in EEPROM ({} ms)", elapsed.as_millis());
    }
    Ok(())
}

// ---- watch ----

fn event_json(ev: &Event, start: Instant) -> Value {
    let a = &ev.answer;
    let mut doc = json!({"type": "event", "node": a.node, "module": a.module,
                         "t_ms": ev.at.saturating_duration_since(start).as_millis() as u64,
                         "code": a.data[0], "data": a.data});
    if let Some(r) = ev.decoded() {
        doc["command"] = json!(r.def.map(|d| d.key));
        let values: serde_json::Map<String, Value> =
            r.fields.iter().map(|f| (f.key.to_string(), json!(f.raw))).collect();
        if r.def.is_some_and(|d| d.key == "read_status") {
            let g = |k: &str| r.get(k).unwrap_or(0) as u8;
            merge(&mut doc, status_json(&decode_status([g("status1"), g("status2"), g("status3"), g("status4")])));
        }
        doc["values"] = Value::Object(values);
    }
    doc
}

fn watch(
    ctx: &Ctx,
    t: ModuleTarget,
    poll: u64,
    no_poll: bool,
    count: Option<u64>,
    duration: Option<f64>,
) -> anyhow::Result<()> {
    if poll == 0 {
        return Err(usage("--poll must be at least 1 ms"));
    }
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut s = open(ctx, &t.node)?;
    super::arm_interrupt()?;
    let clock = Arc::clone(s.clock());
    let start = clock.now();
    let stop_after = duration.map(|d| Duration::from_secs_f64(d.max(0.0)));
    let mut lines = 0u64;
    let mut last: Option<([u8; 4], i32)> = None;
    let enough = |lines: u64| count.is_some_and(|c| lines >= c);
    while !interrupted() && !enough(lines) && stop_after.is_none_or(|d| clock.now() - start < d) {
        if !no_poll {
            let r = s.read_status(node, m)?;
            let pos = s.read_position(node, m, PositionSource::Current)?;
            if last != Some((r.status, pos)) {
                last = Some((r.status, pos));
                let t_ms = (clock.now() - start).as_millis() as u64;
                if ctx.json {
                    let mut doc = json!({"type": "status", "node": node, "module": m, "t_ms": t_ms, "position": pos});
                    merge(&mut doc, status_json(&r));
                    output::json(&doc);
                } else {
                    println!("{:>9.3} status   pos {pos:<11} {}", t_ms as f64 / 1e3, status_line(ctx, &r));
                }
                lines += 1;
            }
        }
        let wait = match stop_after {
            Some(d) => Duration::from_millis(poll).min(d.saturating_sub(clock.now() - start)),
            None => Duration::from_millis(poll),
        };
        s.listen(wait)?;
        for ev in s.take_events() {
            if enough(lines) {
                break;
            }
            if ev.answer.node != node || ev.answer.module != m.get() {
                continue;
            }
            if ctx.json {
                output::json(&event_json(&ev, start));
            } else {
                let t_ms = ev.at.saturating_duration_since(start).as_millis() as f64 / 1e3;
                println!("{t_ms:>9.3} event    {}", describe_answer(&ev.answer));
            }
            lines += 1;
        }
    }
    Ok(())
}

// ---- decode ----

/// `axisctl decode cdios-status|cdios-error VALUE`; `None` for other kinds.
pub fn decode_kind(ctx: &Ctx, kind: &str, value: &str) -> Option<anyhow::Result<()>> {
    match kind.to_ascii_lowercase().as_str() {
        "cdios-status" => Some(decode_status_bytes(ctx, value)),
        "cdios-error" => Some(decode_error(ctx, value)),
        _ => None,
    }
}

fn hex_bytes(text: &str) -> anyhow::Result<Vec<u8>> {
    crate::output::parse_hex_bytes(text).ok_or_else(|| usage(format!("{text:?} is not a sequence of hex bytes")))
}

fn decode_status_bytes(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let b = hex_bytes(value)?;
    let status: [u8; 4] = b.as_slice().try_into().map_err(|_| {
        usage(format!(
            "cdios-status takes the 4 status bytes in wire order (status 1 first), e.g. 81008010; got {} bytes",
            b.len()
        ))
    })?;
    let r = decode_status(status);
    if ctx.json {
        let details: Vec<Value> = STATUS_FLAGS
            .iter()
            .filter(|f| f.is_set(&status))
            .map(|f| json!({"name": f.name, "byte": f.byte, "bit": f.bit, "class": f.class, "meaning": f.meaning}))
            .collect();
        let mut doc = json!({"kind": "cdios-status", "details": details});
        merge(&mut doc, status_json(&r));
        output::json(&doc);
        return Ok(());
    }
    println!("Cdios 6168 status {}", status_line(ctx, &r));
    let mut rows = vec![["BIT", "FLAG", "CLASS", "MEANING"].map(String::from).to_vec()];
    for f in STATUS_FLAGS.iter().filter(|f| f.is_set(&status)) {
        let name = if f.class == table::Class::Error { ctx.style.error(f.name) } else { f.name.to_string() };
        rows.push(vec![
            format!("status {}.{}", f.byte, f.bit),
            name,
            format!("{:?}", f.class).to_lowercase(),
            f.meaning.into(),
        ]);
    }
    if rows.len() > 1 {
        output::table(&rows, ctx.style);
    }
    for (b, bit) in &r.reserved {
        println!("{}", ctx.style.warn(&format!("status {b} bit {bit} is set (reserved)")));
    }
    Ok(())
}

fn decode_error(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let b = hex_bytes(value)?;
    let e = ErrorReply::decode(&b).map_err(|err| {
        usage(format!(
            "cdios-error takes the data bytes of an error reply (code | 0x80 first, e.g. a3 01 00 00 80): {err}"
        ))
    })?;
    let general = e.general_error();
    if ctx.json {
        let flags: Vec<Value> = e
            .flags()
            .iter()
            .map(|f| json!({"name": f.name, "status": f.byte, "bit": f.bit, "meaning": f.meaning}))
            .collect();
        output::json(&json!({
            "kind": "cdios-error", "code": e.code, "command": e.command,
            "command_name": table::COMMANDS.iter().find(|c| c.code == e.command).map(|c| c.name),
            "module": e.module, "general": e.general,
            "general_name": general.map(|g| g.0), "general_text": general.map(|g| g.1),
            "status1": e.status1, "status2": e.status2, "flags": flags, "unknown_bits": e.unknown_bits(),
        }));
        return Ok(());
    }
    println!("{}", e.describe());
    if let Some((name, text)) = general {
        println!("general error {} {name}: {text}", e.general);
    }
    for f in e.flags() {
        println!("  error status {} bit {}: {} ({})", f.byte, f.bit, ctx.style.error(f.name), f.meaning);
    }
    Ok(())
}
