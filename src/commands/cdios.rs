//! Cdios 6168 commands (`cdios-*`). Every command is built and range-checked
//! with the protocol table before the link is opened: bad input sends nothing.

mod backup;
mod dashboard;
pub mod names;
mod record;

use clap::ValueEnum;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axisctl::device::cdios::config::{self as servo, Request as ConfigRequest};
use axisctl::device::cdios::{self as device, EventChange, Goal, Node, WaitEnd, WaitSpec};
use axisctl::device::face::{Face, Halt, Manner, MotionTarget, StopHow};
use axisctl::family::Family;
use axisctl::proto::cdios::table::{self, STATUS_FLAGS};
use axisctl::proto::cdios::{
    decode_status, Command, Direction, GotoMode, ModuleId, NodeId, PositionSource, StartOption, StatusReport,
    StopOption, Timers,
};
use axisctl::session::cdios::{Cdios, Event};
use serde_json::{json, Value};

use super::takeover::HolderReport;
use super::wait::waiting;
use super::{interrupted, usage, Ctx};
use crate::cli::cdios::{
    CdiosCommand, DirectionArg, ModuleTarget, ModulesTarget, NodeArgs, PositionKind, StartOptionArg, StopOptionArg,
};
use crate::cli::ids::Devices;
use crate::cli::WaitArgs;
use crate::output;
use crate::output::say;
use axisctl::bench::{Address, DeviceRef};

pub fn run(ctx: &Ctx, cmd: CdiosCommand) -> anyhow::Result<()> {
    match cmd {
        CdiosCommand::Identify { node, device } => identify(ctx, node_of(ctx, node, device)?),
        CdiosCommand::Status(t) => status(ctx, reads_of(ctx, t)?),
        CdiosCommand::Position { target, source, all } => position(ctx, reads_of(ctx, target)?, source, all),
        CdiosCommand::SetPosition { target, position } => set_position(ctx, target_of(ctx, target)?, position),
        CdiosCommand::Goto { target, position, relative, setpoint_relative, latched, speed, force, wait } => {
            let target = target_of(ctx, target)?;
            let mode = match (relative, setpoint_relative, latched) {
                (false, false, false) => GotoMode::Absolute,
                (false, false, true) => GotoMode::AbsoluteSync,
                (true, _, false) => GotoMode::Relative,
                (true, _, true) => GotoMode::RelativeSync,
                (false, true, false) => GotoMode::SetpointRelative,
                (false, true, true) => GotoMode::SetpointRelativeSync,
            };
            goto(ctx, target, mode, position, (speed, force), wait)
        }
        CdiosCommand::Traject { target, traject, latched, wait } => {
            run_traject(ctx, target_of(ctx, target)?, traject, latched, wait)
        }
        CdiosCommand::Start { target, direction, option, speed, latched } => {
            start(ctx, target_of(ctx, target)?, direction, option, speed, latched)
        }
        CdiosCommand::Stop { target, option, latched } => {
            let option = match option {
                StopOptionArg::ToMinSpeed => StopOption::DecelerateToMinimum,
                StopOptionArg::Decelerate => StopOption::DecelerateAndStop,
                StopOptionArg::Fast => StopOption::FastStop,
                StopOptionArg::ReleaseEmergency => StopOption::ReleaseEmergency,
                StopOptionArg::ClearHold => StopOption::ClearHold,
            };
            stop(ctx, target_of(ctx, target)?, option, latched)
        }
        CdiosCommand::Enable { target, release_emergency } => {
            simple(ctx, target_of(ctx, target)?, "cdios-enable", &device::enable_commands(release_emergency))
        }
        CdiosCommand::Disable(t) => {
            simple(ctx, target_of(ctx, t)?, "cdios-disable", &[device::stop_command(StopOption::Disable, false)])
        }
        CdiosCommand::Config { target, items } => config(ctx, target_of(ctx, target)?, &items),
        CdiosCommand::Outputs { target, set, latched } => {
            outputs(ctx, target_of(ctx, target)?, set.as_deref(), latched)
        }
        CdiosCommand::Analog { target, output, set, latched } => {
            analog(ctx, target_of(ctx, target)?, output, set, latched)
        }
        CdiosCommand::Events {
            target,
            mask,
            raw_masks,
            position_interval,
            position_on_change,
            speed_interval,
            speed_on_change,
        } => {
            let change = EventChange::parse(
                mask.as_deref(),
                raw_masks.as_deref(),
                position_interval,
                position_on_change,
                speed_interval,
                speed_on_change,
            )?;
            events(ctx, target_of(ctx, target)?, &change)
        }
        CdiosCommand::Store { target, defaults } => store(ctx, target_of(ctx, target)?, defaults),
        CdiosCommand::Watch { target, poll, no_poll, count, duration } => {
            watch(ctx, target_of(ctx, target)?, poll, no_poll, count, duration)
        }
    }
}

// ---- the devices a command names ----

/// One module once `-d` is resolved: its node, with the node's options,
/// and its id. `--node N -m ID` is shorthand for the same.
#[derive(Debug, Clone, Copy)]
pub(in crate::commands) struct Target {
    pub node: NodeArgs,
    pub module: u8,
}

/// The (node, module) pairs `-d` names: Cdios modules of one link, each
/// once, in the order given (see [`super::devices::of_family`]).
fn pairs(ctx: &Ctx, refs: &[DeviceRef]) -> anyhow::Result<Vec<(u8, u8)>> {
    let all = super::devices::of_family(ctx, Family::Cdios, refs)?;
    Ok(all
        .into_iter()
        .filter_map(|a| if let Address::Cdios { node, module } = a { Some((node, module)) } else { None })
        .collect())
}

/// The one module of `--node N -m ID` or `-d DEVICE`.
pub(in crate::commands) fn target_of(ctx: &Ctx, t: ModuleTarget) -> anyhow::Result<Target> {
    match (t.device, t.module) {
        (Some(r), _) => {
            let (node, module) = pairs(ctx, std::slice::from_ref(&r))?[0];
            Ok(Target { node: NodeArgs { node, ..t.node }, module })
        }
        (None, Some(module)) => Ok(Target { node: t.node, module }),
        (None, None) => unreachable!("clap requires -m or -d"),
    }
}

/// A node-level command's node: `--node N`, or the node of the module `-d`
/// names.
fn node_of(ctx: &Ctx, n: NodeArgs, device: Option<DeviceRef>) -> anyhow::Result<NodeArgs> {
    match device {
        Some(r) => Ok(NodeArgs { node: pairs(ctx, std::slice::from_ref(&r))?[0].0, ..n }),
        None => Ok(n),
    }
}

/// The modules of a node a read goes to.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Ids {
    These(Vec<u8>),
    /// Every module the node reports (`-m all`).
    Present,
}

/// What a read goes over: each node with its modules, in the order read,
/// and whether the document is one object (`--node N -m ID`, `-d` of one
/// device) or a `{"devices": [...]}` list.
#[derive(Debug, Clone)]
struct Reads {
    groups: Vec<(NodeArgs, Ids)>,
    one: bool,
}

impl Reads {
    /// `--node` × `-m`: every module named on every node named, in id order.
    fn shorthand(nodes: &crate::cli::cdios::NodesArgs, modules: &Devices) -> Self {
        let ids = match modules {
            Devices::One(m) => Ids::These(vec![*m]),
            Devices::List(l) => Ids::These(l.0.clone()),
            Devices::All => Ids::Present,
        };
        let one = matches!((&nodes.node, modules), (Devices::One(_), Devices::One(_)));
        Self { groups: nodes.each().into_iter().map(|n| (n, ids.clone())).collect(), one }
    }

    /// `-d`: exactly the pairs named, in the order named; neighbours on one
    /// node are read in one go. One device is one object, several a list
    /// (as `-m 0` and `-m 0,1`).
    fn named(options: NodeArgs, pairs: &[(u8, u8)], devices: usize) -> Self {
        let mut groups: Vec<(NodeArgs, Ids)> = Vec::new();
        for &(node, module) in pairs {
            match groups.last_mut() {
                Some((n, Ids::These(ids))) if n.node == node => ids.push(module),
                _ => groups.push((NodeArgs { node, ..options }, Ids::These(vec![module]))),
            }
        }
        Self { groups, one: devices == 1 }
    }
}

/// The reads of `--node`/`-m` or `-d`, resolved before any link opens.
fn reads_of(ctx: &Ctx, t: ModulesTarget) -> anyhow::Result<Reads> {
    match (t.device, t.module) {
        (Some(refs), _) => {
            let options = NodeArgs { node: 0, no_nmt: t.node.no_nmt, no_confirm: t.node.no_confirm };
            Ok(Reads::named(options, &pairs(ctx, &refs)?, refs.len()))
        }
        (None, Some(m)) => Ok(Reads::shorthand(&t.node, &m)),
        (None, None) => unreachable!("clap requires -m or -d"),
    }
}

// ---- plumbing ----

fn node_id(n: &NodeArgs) -> NodeId {
    NodeId::new(n.node).expect("clap checks 1..=127")
}

fn module_id(t: &Target) -> ModuleId {
    output::target(Family::Cdios, &[("node", t.node.node.into()), ("module", t.module.into())]);
    ModuleId::new(t.module).expect("clap checks 0..=15")
}

/// A per-module object: the envelope (docs/json.md) and the command's keys.
fn doc(ctx: &Ctx, node: NodeId, m: ModuleId, body: Value) -> Value {
    let envelope = output::envelope(
        Family::Cdios,
        &ctx.link_text_for(Family::Cdios),
        &[("node", node.get().into()), ("module", m.get().into())],
    );
    output::device_doc(envelope, body)
}

fn open(ctx: &Ctx, n: &NodeArgs) -> anyhow::Result<Node> {
    Ok(node(ctx.cdios()?, n, ctx))
}

fn node(mut s: Cdios, n: &NodeArgs, ctx: &Ctx) -> Node {
    s.set_nmt(!n.no_nmt);
    s.set_confirm(!n.no_confirm);
    Node::new(s, node_id(n), ctx.retry)
}

/// The 4 status bytes in the one `state` shape: status 1 is the low byte
/// of `raw`, so a flag's mask is `1 << (8 * (byte - 1) + bit)`.
pub(super) fn status_json(r: &StatusReport) -> Value {
    let mask = |byte: u8, bit: u8| 1u64 << (8 * u32::from(byte.saturating_sub(1)) + u32::from(bit));
    let set: Vec<output::Detail> = STATUS_FLAGS
        .iter()
        .filter(|f| f.is_set(&r.status))
        .map(|f| output::Detail {
            name: f.name,
            mask: mask(f.byte, f.bit),
            class: f.class.name(),
            description: f.meaning,
        })
        .collect();
    let unknown = r.reserved.iter().fold(0, |m, (byte, bit)| m | mask(*byte, *bit));
    output::state(u32::from_le_bytes(r.status).into(), &set, unknown)
}

pub(super) fn status_line(ctx: &Ctx, r: &StatusReport) -> String {
    let names: Vec<String> =
        r.flags.iter().map(|n| if r.errors.contains(n) { ctx.style.error(n) } else { (*n).to_string() }).collect();
    let bytes = r.status.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ");
    format!("[{bytes}] {}", if names.is_empty() { "-".into() } else { names.join(" ") })
}

// ---- commands ----

fn identify(ctx: &Ctx, n: NodeArgs) -> anyhow::Result<()> {
    let node = node_id(&n);
    let slots = open(ctx, &n)?.identify()?;
    let modules: Vec<Value> = slots
        .iter()
        .map(|s| json!({"module": s.module, "type": s.ty, "version": s.version, "present": s.ty != 0}))
        .collect();
    if ctx.json {
        let envelope =
            output::envelope(Family::Cdios, &ctx.link_text_for(Family::Cdios), &[("node", node.get().into())]);
        output::json(&output::device_doc(envelope, json!({"modules": modules})));
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
        say!("node {node}: the controller reports no I/O modules");
    } else {
        say!("node {node}:");
        output::table(&rows, ctx.style);
    }
    Ok(())
}

fn status(ctx: &Ctx, t: Reads) -> anyhow::Result<()> {
    read_each(ctx, &t, |ctx, s, node, m| {
        let r = s.status(m)?;
        let (speed, rpm_error) = s.speed(m)?;
        if ctx.json {
            let (speed, rpm_error) = (
                output::with_unit(json!(speed), table::SPEED_UNIT),
                output::with_unit(json!(rpm_error), table::SPEED_UNIT),
            );
            return Ok(doc(
                ctx,
                node,
                m,
                json!({"state": status_json(&r), "motor_speed": speed, "rpm_error": rpm_error}),
            ));
        }
        say!("node {node} module {m}: {}", status_line(ctx, &r));
        let mut rows = Vec::new();
        for f in STATUS_FLAGS.iter().filter(|f| f.is_set(&r.status)) {
            let name = if f.class == table::Class::Error { ctx.style.error(f.name) } else { f.name.to_string() };
            rows.push(vec![format!("  status {} bit {}", f.byte, f.bit), name, f.meaning.to_string()]);
        }
        output::table(&rows, ctx.style);
        for (b, bit) in &r.reserved {
            say!("  {}", ctx.style.warn(&format!("status {b} bit {bit} is set (reserved)")));
        }
        say!("  motor speed {speed} {u}, RPM error {rpm_error} {u}", u = table::SPEED_UNIT);
        Ok(Value::Null)
    })
}

/// A read of each module asked for: one JSON object for `--node N -m ID`
/// or one `-d` device, else `{"devices": [...]}` in the order of `t`
/// (`-m all`: the modules each node reports). `read` prints the human form
/// itself and returns the JSON object. One session serves every node.
fn read_each(
    ctx: &Ctx,
    t: &Reads,
    mut read: impl FnMut(&Ctx, &mut Node, NodeId, ModuleId) -> anyhow::Result<Value>,
) -> anyhow::Result<()> {
    let mut session = None;
    let mut docs = Vec::new();
    for (n, ids) in &t.groups {
        let node = node_id(n);
        output::target(Family::Cdios, &[("node", node.get().into())]);
        let s = match session.take() {
            Some(s) => s,
            None => ctx.cdios()?,
        };
        let mut s = self::node(s, n, ctx);
        let ids: Vec<u8> = match ids {
            Ids::These(ids) => ids.clone(),
            Ids::Present => s.identify()?.iter().filter(|slot| slot.ty != 0).map(|slot| slot.module).collect(),
        };
        for id in ids {
            let m = module_id(&Target { node: *n, module: id });
            docs.push(read(ctx, &mut s, node, m)?);
        }
        session = Some(s.into_session());
    }
    if ctx.json {
        match t.one {
            true => output::json(&docs[0]),
            false => output::json(&json!({ "devices": docs })),
        }
    }
    Ok(())
}

pub(super) fn merge(doc: &mut Value, more: Value) {
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

fn position(ctx: &Ctx, t: Reads, kind: PositionKind, all: bool) -> anyhow::Result<()> {
    read_each(ctx, &t, |ctx, s, node, m| {
        if all {
            let cur = s.position(m, PositionSource::Current)?;
            let latched = s.position(m, PositionSource::Latched)?;
            let setpoint = s.position(m, PositionSource::Setpoint)?;
            if ctx.json {
                return Ok(doc(
                    ctx,
                    node,
                    m,
                    json!({"position": counts(cur), "latched": counts(latched), "setpoint": counts(setpoint)}),
                ));
            }
            say!("node {node} module {m}: position {cur}, latched {latched}, setpoint {setpoint}");
            return Ok(Value::Null);
        }
        let p = s.position(m, source_of(kind))?;
        let name = kind.to_possible_value().map(|v| v.get_name().to_string()).unwrap_or_default();
        if ctx.json {
            return Ok(doc(ctx, node, m, json!({"source": name, "position": counts(p)})));
        }
        say!("node {node} module {m}: {name} position {p}");
        Ok(Value::Null)
    })
}

/// A position as every family gives it: `{value, unit}`.
fn counts(position: i32) -> Value {
    output::with_unit(json!(position), table::POSITION_UNIT)
}

fn report_sent(ctx: &Ctx, node: NodeId, m: ModuleId, what: &str, confirmed: bool, extra: Value) {
    if ctx.json {
        // `acknowledged` is false when confirmations are off (--no-confirm):
        // the command went out and no error came back, nothing more.
        let mut doc = doc(ctx, node, m, json!({"command": what, "acknowledged": confirmed}));
        merge(&mut doc, extra);
        output::json(&doc);
    } else {
        let how = if confirmed { "confirmed" } else { "sent (confirmations off, no error came)" };
        say!("node {node} module {m}: {what} {how}");
    }
}

/// Commands sent one after the other, each awaited.
fn simple(ctx: &Ctx, t: Target, what: &str, cmds: &[Command]) -> anyhow::Result<()> {
    let m = module_id(&t);
    device::check(cmds, m)?;
    let mut s = open(ctx, &t.node)?;
    let confirmed = s.send(m, cmds)?;
    report_sent(ctx, s.id(), m, what, confirmed, json!({}));
    Ok(())
}

/// cdios-stop, also from another terminal: a link held by another axisctl
/// process (a `--wait`, the dashboard) is released by it first.
/// A motor already at rest is the state asked for (exit 0, `already_stopped`).
fn stop(ctx: &Ctx, t: Target, option: StopOption, latched: bool) -> anyhow::Result<()> {
    let m = module_id(&t);
    device::check(&[device::stop_command(option, latched)], m)?;
    let (session, takeover) = super::takeover::open(ctx, |o, spec, opts| o.cdios(spec, opts))?;
    let mut s = node(session, &t.node, ctx);
    let manner = match option {
        StopOption::FastStop => Some(Manner::Fast),
        StopOption::DecelerateAndStop => Some(Manner::Decelerate),
        StopOption::DecelerateToMinimum => Some(Manner::DecelerateToMinimum),
        _ => None,
    };
    let sent = match manner {
        Some(manner) => {
            let at = MotionTarget::Cdios { node: s.id(), module: m };
            match Face::stop_with(&mut s, at, StopHow { manner, on_sync: latched, at_standstill: false }) {
                Ok(Halt::AtRest) => Ok((true, true)),
                Ok(h) => Ok((h != Halt::FastStop { confirmed: false }, false)),
                Err(e) => Err(anyhow::Error::from(e)),
            }
        }
        // Not a stop (release the emergency stop, clear a hold): sent as
        // it is, its refusal is an answer to keep.
        None => s.send(m, &[device::stop_command(option, latched)]).map(|c| (c, false)).map_err(Into::into),
    };
    let (confirmed, already) = sent.map_err(|e| super::takeover::failed(e, takeover.as_ref()))?;
    let mut extra = json!({});
    if let Some(h) = HolderReport::after_halt(takeover.as_ref()) {
        if !ctx.json {
            say!("{}", h.line());
        }
        extra["holder"] = h.json();
    }
    extra["already_stopped"] = json!(already);
    if already && !ctx.json {
        let who = if takeover.is_some() {
            "its holder had already stopped the motor"
        } else {
            "the motor was at rest already"
        };
        say!("node {} module {m}: {who} (nothing to stop)", s.id());
        return Ok(());
    }
    report_sent(ctx, s.id(), m, "cdios-stop", confirmed, extra);
    Ok(())
}

/// A refusal that says nothing but "the motor is not running".
fn set_position(ctx: &Ctx, t: Target, position: i64) -> anyhow::Result<()> {
    let position = device::field_value::<i32>("set_position", "position", position)?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let cmd = Command::SetPosition { position };
    device::check(&[cmd], m)?;
    let confirmed = open(ctx, &t.node)?.send(m, &[cmd])?;
    report_sent(ctx, node, m, "cdios-set-position", confirmed, json!({"position": counts(position)}));
    Ok(())
}

/// `--speed` against the speeds the module is configured with: the
/// controller would clamp a speed outside them without a word, so the move
/// would not be the one asked for. `--force` skips this (never the manual's
/// range, which [`device::goto_commands`] checks).
fn check_goto_speed(s: &mut Node, m: ModuleId, speed: i64) -> anyhow::Result<()> {
    if speed == 0 {
        return Ok(()); // 0 means the configured maximum
    }
    let speeds = s.read_config(m, &["speeds".to_string()])?;
    let get = |key| speeds.iter().find_map(|(_, r)| r.get(key));
    let bound = match (get("minimum_speed"), get("maximum_speed")) {
        (_, Some(max)) if speed > max => Some(("above", "maximum", max)),
        (Some(min), _) if speed < min => Some(("below", "minimum", min)),
        _ => None,
    };
    match bound {
        Some((side, which, v)) => Err(usage(format!(
            "--speed {speed} {u} is {side} module {m}'s configured {which} speed {v} {u} (the controller would \
             clamp it); nothing was sent (use --force to send it anyway)",
            u = table::SPEED_UNIT
        ))),
        None => Ok(()),
    }
}

fn goto(
    ctx: &Ctx,
    t: Target,
    mode: GotoMode,
    position: i64,
    (speed, force): (Option<i64>, bool),
    wait: WaitArgs,
) -> anyhow::Result<()> {
    let cmds = device::goto_commands(mode, position, speed)?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    device::check(&cmds, m)?;
    let mut s = open(ctx, &t.node)?;
    if let (Some(v), false) = (speed, force) {
        check_goto_speed(&mut s, m, v)?;
    }
    let mut extra = json!({"mode": device::mode_name(mode), "requested": position});
    if let Some(v) = speed {
        extra["speed"] = output::with_unit(json!(v), table::SPEED_UNIT);
    }
    if !wait.wait {
        // One-shot: unsupervised once sent.
        let confirmed = s.send(m, &cmds)?;
        report_sent(ctx, node, m, "cdios-goto", confirmed, extra);
        return Ok(());
    }
    // Supervised from before the first byte, and held by the face's Moving
    // handle until the wait ends: every way out stops the motor.
    super::arm_interrupt()?;
    let attempts = 1 + ctx.retry.read_retries;
    let at = MotionTarget::Cdios { node: s.id(), module: m };
    let (moving, confirmed) = s.start(vec![at], attempts, |s| s.send_supervised(m, &cmds, attempts))?;
    if !ctx.json {
        crate::output::say!(
            "node {node} module {m}: goto {} {position} {}",
            device::mode_name(mode),
            if confirmed { "confirmed" } else { "sent" }
        );
    }
    let end = moving.follow(|s| wait_motion(ctx, s, m, wait, Goal::Goto))?;
    print_wait_end(ctx, (node, m), "cdios-goto", &end, extra);
    Ok(())
}

fn run_traject(ctx: &Ctx, t: Target, traject: i64, latched: bool, wait: WaitArgs) -> anyhow::Result<()> {
    let cmd = device::traject_command(traject, latched)?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    device::check(&[cmd], m)?;
    let mut s = open(ctx, &t.node)?;
    let extra = json!({"traject": traject, "on_sync": latched});
    if !wait.wait {
        let confirmed = s.send(m, &[cmd])?;
        report_sent(ctx, node, m, "cdios-traject", confirmed, extra);
        return Ok(());
    }
    super::arm_interrupt()?;
    let attempts = 1 + ctx.retry.read_retries;
    let at = MotionTarget::Cdios { node: s.id(), module: m };
    let (moving, _) = s.start(vec![at], attempts, |s| s.send_supervised(m, &[cmd], attempts))?;
    let end = moving.follow(|s| wait_motion(ctx, s, m, wait, Goal::Traject))?;
    print_wait_end(ctx, (node, m), "cdios-traject", &end, extra);
    Ok(())
}

fn start(
    ctx: &Ctx,
    t: Target,
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
    let direction = match direction {
        DirectionArg::Forward => Direction::Forward,
        DirectionArg::Reverse => Direction::Reverse,
    };
    let cmd = device::start_command(direction, option, speed, latched)?;
    simple(ctx, t, "cdios-start", &[cmd])
}

/// The device's wait, with the spinner and Ctrl-C (which fast-stops the motor).
fn wait_motion(ctx: &Ctx, s: &mut Node, m: ModuleId, wait: WaitArgs, goal: Goal) -> anyhow::Result<WaitEnd> {
    waiting(ctx, &wait, |t, show| {
        let spec = WaitSpec { poll: t.poll, timeout: t.timeout, stop_attempts: t.stop_attempts };
        let progress =
            &mut |pos, r: &_| show(format!("module {m} {}: pos {pos}  {}", goal.name(), status_line(ctx, r)));
        // The caller's Moving handle, armed before the motion frame, halts
        // the motor on a panic; the wait halts it on its own errors.
        let waited = s.wait(m, goal, spec, &interrupted, progress);
        waited.map_err(|e| super::stopped_by_output(e.into()))
    })
}

fn print_wait_end(ctx: &Ctx, (node, m): (NodeId, ModuleId), what: &str, end: &WaitEnd, extra: Value) {
    if ctx.json {
        let mut doc = doc(
            ctx,
            node,
            m,
            json!({"command": what, "done": true, "position": counts(end.position),
                             "elapsed_ms": end.elapsed.as_millis() as u64, "state": status_json(&end.status)}),
        );
        if let Some(t) = end.target {
            doc["target"] = counts(t);
        }
        merge(&mut doc, extra);
        output::json(&doc);
    } else {
        crate::output::say!(
            "{what} done at {} after {:.2} s  {}",
            end.position,
            end.elapsed.as_secs_f64(),
            status_line(ctx, &end.status)
        );
    }
}

// ---- configuration ----

fn config(ctx: &Ctx, t: Target, items: &[String]) -> anyhow::Result<()> {
    // Every name and value is resolved and checked before anything is sent.
    items.iter().try_for_each(|i| names::check_config_item(i))?;
    match ConfigRequest::parse(items)? {
        ConfigRequest::Show(groups) => show_config(ctx, &mut open(ctx, &t.node)?, t, &groups),
        ConfigRequest::Set(changes) => {
            let mut s = open(ctx, &t.node)?;
            let groups = s.write_config(module_id(&t), &changes)?;
            show_config(ctx, &mut s, t, &groups)
        }
    }
}

fn show_config(ctx: &Ctx, s: &mut Node, t: Target, groups: &[String]) -> anyhow::Result<()> {
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut doc = serde_json::Map::new();
    let mut rows = vec![["FIELD", "VALUE", "UNIT", "RANGE"].map(String::from).to_vec()];
    for (part, r) in s.read_config(m, groups)? {
        let g = doc.entry(servo::group_of(part)).or_insert_with(|| json!({}));
        for f in servo::set_row(part).value_fields() {
            let v = r.get(f.key).unwrap_or(0);
            g[servo::key_of(part, f)] = json!(v);
            let shown = match f.scale {
                Some(sc) => format!("{v} ({} {})", v as f64 * sc.factor, sc.unit),
                None => v.to_string(),
            };
            rows.push(vec![
                format!("{}.{}", servo::group_of(part), servo::key_of(part, f)),
                shown,
                f.unit.to_string(),
                format!("{} to {}", f.min, f.max),
            ]);
        }
    }
    if ctx.json {
        output::json(&self::doc(ctx, node, m, json!({"config": doc})));
    } else {
        say!("node {node} module {m}:");
        output::table(&rows, ctx.style);
    }
    Ok(())
}

// ---- outputs ----

fn outputs(ctx: &Ctx, t: Target, set: Option<&str>, latched: bool) -> anyhow::Result<()> {
    let set = set.map(device::outputs_value).transpose()?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    let state = open(ctx, &t.node)?.outputs(m, set, latched)?;
    let bits: Vec<bool> = (0..4).map(|i| state & (1 << i) != 0).collect();
    if ctx.json {
        output::json(&doc(ctx, node, m, json!({"outputs": state, "bits": bits})));
    } else {
        let on: Vec<String> = (0..4).filter(|i| bits[*i]).map(|i| (i + 1).to_string()).collect();
        say!(
            "node {node} module {m}: outputs {state:#06b} (on: {})",
            if on.is_empty() { "none".into() } else { on.join(", ") }
        );
    }
    Ok(())
}

fn analog(ctx: &Ctx, t: Target, output: Option<i64>, set: Option<i64>, latched: bool) -> anyhow::Result<()> {
    let (outs, set) = device::analog_request(output, set, latched)?;
    let (node, m) = (node_id(&t.node), module_id(&t));
    if let Some(c) = set {
        device::check(&[c], m)?;
    }
    let read = open(ctx, &t.node)?.analog(m, &outs, set)?;
    let list: Vec<Value> = read
        .iter()
        .map(|a| json!({"output": a.output, "millivolts": a.millivolts, "volts": a.millivolts as f64 / 1000.0}))
        .collect();
    if ctx.json {
        output::json(&doc(ctx, node, m, json!({"analog": list})));
    } else {
        for a in &list {
            say!("node {node} module {m}: analog output {} = {} V", a["output"], a["volts"]);
        }
    }
    Ok(())
}

// ---- events ----

fn events(ctx: &Ctx, t: Target, change: &EventChange) -> anyhow::Result<()> {
    let (node, m) = (node_id(&t.node), module_id(&t));
    let setup = open(ctx, &t.node)?.events(m, change)?;
    let (masks, timers) = (setup.masks, setup.timers);
    let ms = |c: u8| Timers::interval_ms(c).unwrap_or(0.0);
    if ctx.json {
        output::json(&doc(
            ctx,
            node,
            m,
            json!({
                "masks": masks, "mask_flags": device::mask_flags(masks),
                "timers": {
                    "position_interval": timers.position_interval, "position_interval_ms": ms(timers.position_interval),
                    "position_on_change": timers.position_on_change,
                    "speed_interval": timers.speed_interval, "speed_interval_ms": ms(timers.speed_interval),
                    "speed_on_change": timers.speed_on_change,
                },
            }),
        ));
    } else {
        let names = device::mask_flags(masks);
        say!("node {node} module {m}: event masks {:02x?}", masks);
        say!("  events on: {}", if names.is_empty() { "-".into() } else { names.join(" ") });
        let every = |c: u8, change: bool| match c {
            0 => "never".to_string(),
            _ => format!("every {} ms{}", ms(c), if change { " when changed" } else { "" }),
        };
        say!("  position: {}", every(timers.position_interval, timers.position_on_change));
        say!("  speed:    {}", every(timers.speed_interval, timers.speed_on_change));
    }
    Ok(())
}

// ---- store ----

fn store(ctx: &Ctx, t: Target, defaults: bool) -> anyhow::Result<()> {
    let (node, m) = (node_id(&t.node), module_id(&t));
    device::check(&[Command::StoreConfiguration { defaults }], m)?;
    let elapsed = open(ctx, &t.node)?.store(m, defaults)?;
    if ctx.json {
        output::json(&doc(
            ctx,
            node,
            m,
            json!({"command": "cdios-store", "defaults": defaults,
                             "acknowledged": true, "elapsed_ms": elapsed.as_millis() as u64}),
        ));
    } else {
        let what = if defaults { "default configuration" } else { "configuration" };
        say!("node {node} module {m}: {what} stored in EEPROM ({} ms)", elapsed.as_millis());
    }
    Ok(())
}

// ---- watch ----

fn event_json(ctx: &Ctx, ev: &Event, start: Instant) -> Value {
    let a = &ev.answer;
    let address = [("node", u64::from(a.node.get())), ("module", u64::from(a.module))];
    let mut doc = output::device_doc(
        output::envelope(Family::Cdios, &ctx.link_text_for(Family::Cdios), &address),
        json!({"kind": "event", "t_ms": ev.at.saturating_duration_since(start).as_millis() as u64,
               "code": a.data[0], "data": a.data}),
    );
    if let Some(r) = ev.decoded() {
        if let Some(def) = r.def {
            doc["message"] = json!(def.key);
        }
        let values: serde_json::Map<String, Value> =
            r.fields.iter().map(|f| (f.key.to_string(), json!(f.raw))).collect();
        if r.def.is_some_and(|d| d.key == "read_status") {
            let g = |k: &str| r.get(k).unwrap_or(0) as u8;
            doc["state"] = status_json(&decode_status([g("status1"), g("status2"), g("status3"), g("status4")]));
        }
        doc["values"] = Value::Object(values);
    }
    doc
}

fn watch(
    ctx: &Ctx,
    t: Target,
    poll: u64,
    no_poll: bool,
    count: Option<u64>,
    duration: Option<f64>,
) -> anyhow::Result<()> {
    if poll == 0 {
        return Err(usage("--poll must be at least 1 ms"));
    }
    let (node, m) = (node_id(&t.node), module_id(&t));
    let mut node_ops = open(ctx, &t.node)?;
    node_ops.ready(m)?;
    let s = node_ops.session();
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
                    let body =
                        json!({"kind": "status", "t_ms": t_ms, "position": counts(pos), "state": status_json(&r)});
                    output::json(&doc(ctx, node, m, body));
                } else {
                    say!("{:>9.3} status   pos {pos:<11} {}", t_ms as f64 / 1e3, status_line(ctx, &r));
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
                output::json(&event_json(ctx, &ev, start));
            } else {
                let t_ms = ev.at.saturating_duration_since(start).as_millis() as f64 / 1e3;
                say!("{t_ms:>9.3} event    {}", ev.answer);
            }
            lines += 1;
        }
    }
    Ok(())
}

/// A Cdios refusal in the error document: the general code and the error
/// status bits the node set.
impl super::error_json::DeviceDoc for axisctl::proto::cdios::refusal::CdiosRefusal {
    fn device_doc(&self) -> Value {
        // Error status byte 1 is the low byte of the mask, byte 2 the next.
        let mask = |status: u8, bit: u8| 1u64 << (8 * u32::from(status.saturating_sub(1)) + u32::from(bit));
        let details: Vec<_> = self
            .errors
            .iter()
            .map(|b| json!({"name": b.name, "mask": mask(b.status, b.bit), "class": "error", "description": b.meaning}))
            .collect();
        let unknown = self.unknown_bits.iter().fold(0, |m, b| m | mask(b.status, b.bit));
        json!({"family": "cdios", "command_code": format!("{:02X}", self.command), "code": self.general,
               "name": self.general_name, "text": self.general_text.unwrap_or("not in the manual's table"),
               "details": details, "unknown_bits": unknown})
    }
}

/// What this folder answers for the family (`super::family_cli`).
pub const CLI: super::FamilyCli = super::FamilyCli {
    names: &names::CdiosNames,
    dashboard_source: dashboard::source,
    backup_live: backup::live,
    record_plan: record::plan,
    line: None,
    serial_trace: None,
};
