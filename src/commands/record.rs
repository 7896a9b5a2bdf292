//! `record`: sample chosen values of one family's devices and stream them
//! (JSON Lines, CSV or text), optionally while a motion given after `--`
//! runs on the same open link. That motion is supervised from before its
//! first byte: a signal, a failed output write, an error or the end of the
//! recording while it still moves halts it.

use std::time::Duration;

use axisctl::bench::DeviceRef;
use axisctl::device::cdios::{self as cdios_dev, Node};
use axisctl::device::face::Moving;
use axisctl::device::face::{FaceError, MotionTarget};
use axisctl::device::pac::Controller;
use axisctl::device::powercube::{self as cube_dev, Cubes, Move};
use axisctl::device::supervisor;
use axisctl::family::{Family, CDIOS_MODULE, PAC_AXIS, POWERCUBE_MODULE};
use axisctl::proto::cdios::{GotoMode, ModuleId as CdiosModule, NodeId};
use axisctl::proto::powercube::table::ids;
use axisctl::proto::powercube::ModuleId;
use axisctl::record::cdios::{CdiosSampler, CdiosValue};
use axisctl::record::pac::{PacSampler, PacValue};
use axisctl::record::powercube::CubeSampler;
use axisctl::record::{self, Channel, End, HaltMotion, HaltWhen, Pace, RecordError, Recording, Sample, Until};
use axisctl::Address;
use serde_json::{json, Map, Value};

use super::powercube::{module_of as cube_of, ramp_modules};
use super::{usage, Ctx, Interrupted, OutputFailed};
use crate::cli::ids::parse_list;
use crate::cli::record::{Format, RecordArgs};
use crate::cli::{cdios::CdiosCommand, pac::PacCommand, Command, PowerCubeCommand};
use crate::output::{self, say};

pub(in crate::commands) mod several;

/// What is recorded: one family's devices and values, checked before the
/// link opens.
enum Selection {
    PowerCube { modules: Vec<ModuleId>, params: Vec<&'static axisctl::proto::powercube::table::ParamDef> },
    Pac { axes: Vec<u8>, values: Vec<PacValue> },
    Cdios { node: NodeId, modules: Vec<CdiosModule>, values: Vec<CdiosValue> },
}

/// A motion of `record ... -- MOTION`, checked as far as can be without
/// the link. A Cdios `node` is the node the motion named (`-d`, or a typed
/// `--node`), which must be the recording's; `None` takes the recording's.
#[derive(Debug, Clone, Copy)]
enum Motion {
    Cube { module: ModuleId, mv: Move, ticks: bool, relative: bool, force: bool },
    Pac { axis: u8, pos: f64, relative: bool, force: bool },
    Cdios { node: Option<u8>, module: CdiosModule, mode: GotoMode, position: i64 },
}

impl Motion {
    fn family(&self) -> Family {
        match self {
            Self::Cube { .. } => Family::PowerCube,
            Self::Pac { .. } => Family::Pac,
            Self::Cdios { .. } => Family::Cdios,
        }
    }

    /// The device it moves, as the recording addresses it (the Cdios node
    /// is the recording's own).
    fn address(&self, node: u8) -> Address {
        match *self {
            Self::Cube { module, .. } => Address::PowerCube { module: module.get() },
            Self::Pac { axis, .. } => Address::Pac { axis: Some(axis) },
            Self::Cdios { module, .. } => Address::Cdios { node, module: module.get() },
        }
    }

    fn device(&self) -> String {
        match self {
            Self::Cube { module, .. } => format!("module {module}"),
            Self::Pac { axis, .. } => format!("axis {axis}"),
            Self::Cdios { module, .. } => format!("module {module}"),
        }
    }
}

const MOTIONS: &str = "move-ramp, move-step, move-vel, move-cur (PowerCube), pac-move (PA-CONTROL), cdios-goto (Cdios)";

pub fn run(ctx: &Ctx, mut args: RecordArgs) -> anyhow::Result<()> {
    if let Some(refs) = args.device.take() {
        args = with_devices(ctx, args, &refs)?;
    }
    if several::addressed(&args.values) {
        return several::run(ctx, &args);
    }
    let sel = selection(&args)?;
    let motion = (!args.motion.is_empty()).then(|| motion(ctx, &args.motion)).transpose()?;
    if let Some(m) = &motion {
        let fam = match &sel {
            Selection::PowerCube { .. } => Family::PowerCube,
            Selection::Pac { .. } => Family::Pac,
            Selection::Cdios { .. } => Family::Cdios,
        };
        if m.family() != fam {
            return Err(usage(format!(
                "the motion after -- is a {} command but the recording is of {} devices: record the device \
                 that moves; nothing was sent",
                m.family().display_name(),
                fam.display_name()
            )));
        }
        // The recording's node is the one its session talks to: a motion
        // of another node would go to the recording's module of that id.
        if let (Motion::Cdios { node: Some(moved), .. }, Selection::Cdios { node, .. }) = (m, &sel) {
            if *moved != node.get() {
                return Err(usage(format!(
                    "the motion after -- is on Cdios node {moved} but the recording is of node {node}: record \
                     the node that moves; nothing was sent"
                )));
            }
        }
    }
    let (pace, until, format) = pace(ctx, &args)?;
    // From here on a signal ends the recording between two samples (and
    // halts a motion it started) instead of killing the process mid-line.
    super::arm_interrupt()?;
    let attempts = 1 + ctx.retry.read_retries;
    let mut writer = Writer::new(format);
    match sel {
        Selection::PowerCube { modules, params } => {
            let mut s = CubeSampler::new(Cubes::new(ctx.powercube()?), &modules, &params).map_err(device_error)?;
            let start = |s: &mut CubeSampler, m: &Motion| start_cube(s, m, attempts);
            go(&mut s, ctx, (pace, until), (motion, 0, attempts), &mut writer, start)
        }
        Selection::Pac { axes, values } => {
            let mut ctl = Controller::new(ctx.pac()?);
            ctl.set_axes(axes.clone());
            let mut s = PacSampler::new(ctl, &axes, &values);
            go(&mut s, ctx, (pace, until), (motion, 0, attempts), &mut writer, start_pac)
        }
        Selection::Cdios { node, modules, values } => {
            let mut session = ctx.cdios()?;
            session.set_nmt(true);
            let mut s =
                CdiosSampler::new(Node::new(session, node, ctx.retry), &modules, &values).map_err(device_error)?;
            let start = move |s: &mut CdiosSampler, m: &Motion| start_cdios(s, m, attempts);
            go(&mut s, ctx, (pace, until), (motion, node.get(), attempts), &mut writer, start)
        }
    }
}

/// The rate, the end and the format of a recording, checked before the link opens.
fn pace(ctx: &Ctx, args: &RecordArgs) -> anyhow::Result<(Pace, Until, Format)> {
    let period = match args.rate {
        Some(hz) if !(hz.is_finite() && hz > 0.0 && hz <= 100_000.0) => {
            return Err(usage(format!("--rate {hz} is out of range: more than 0 and at most 100000 Hz")))
        }
        Some(hz) => Some(Duration::from_secs_f64(1.0 / hz)),
        None => None,
    };
    let until = match (args.count, args.duration) {
        (Some(_), Some(_)) => return Err(usage("--count and --for both end the recording: give one")),
        (Some(0), None) => return Err(usage("--count 0 records nothing: give at least 1")),
        (Some(n), None) => Until::Count(n),
        (None, Some(d)) => Until::Elapsed(d),
        (None, None) => Until::Stopped,
    };
    let format = args.format.unwrap_or(if ctx.json { Format::Jsonl } else { Format::Text });
    if ctx.json && format != Format::Jsonl {
        return Err(usage("--json writes JSON Lines: leave out --format, or give --format csv without --json"));
    }
    Ok((Pace::from_period(period), until, format))
}

/// The devices and values, every name checked before anything is sent.
/// `record -d DEVICES VALUE...`: each value of each device. Devices of one
/// family on one link (the Cdios: modules of one node, the PA-CONTROL: its
/// axes) are the plain form (`-m`, `--axis`, `--node -m`), which also takes
/// a motion after `--`, on the link they are on; any other set is
/// `DEVICE.VALUE` for each, read on each device's link.
fn with_devices(ctx: &Ctx, mut args: RecordArgs, refs: &[DeviceRef]) -> anyhow::Result<RecordArgs> {
    if several::addressed(&args.values) {
        return Err(usage("with -d the values are given without a device (ActPos, not shoulder.ActPos)"));
    }
    let named = super::devices::any_family(ctx, refs)?;
    let ids = |f: fn(Address) -> Option<String>| named.iter().map(|(a, _)| f(*a)).collect::<Option<Vec<_>>>();
    let one_link = named.iter().all(|(_, l)| l.text == named[0].1.text);
    let plain = match named.first().map(|(a, _)| *a) {
        Some(Address::PowerCube { .. }) => ids(|a| match a {
            Address::PowerCube { module } => Some(module.to_string()),
            _ => None,
        })
        .map(|m| (m, None, None)),
        Some(Address::Pac { .. }) => ids(|a| match a {
            Address::Pac { axis: Some(axis) } => Some(axis.to_string()),
            _ => None,
        })
        .map(|axes| (Vec::new(), Some(axes.join(",")), None)),
        Some(Address::Cdios { node, .. }) => ids(move |a| match a {
            Address::Cdios { module, .. } => Some(module.to_string()),
            _ => None,
        })
        .filter(|_| named.iter().all(|(a, _)| matches!(a, Address::Cdios { node: n, .. } if *n == node)))
        .map(|m| (m, None, Some(node))),
        None => None,
    };
    match plain {
        Some((modules, axis, node)) if one_link => {
            ctx.pin_link(named[0].0.family(), named[0].1);
            args.module = (!modules.is_empty()).then(|| modules.join(","));
            args.axis = axis;
            args.node = node;
        }
        _ => {
            let values = std::mem::take(&mut args.values);
            args.values = named.iter().flat_map(|(a, _)| values.iter().map(move |v| format!("{a}.{v}"))).collect();
        }
    }
    Ok(args)
}

fn selection(args: &RecordArgs) -> anyhow::Result<Selection> {
    let list = |text: &str, range| parse_list(text, range, false).map_err(usage);
    match (&args.module, &args.axis, args.node) {
        (_, Some(_), Some(_)) => {
            Err(usage("--axis (PA-CONTROL) and --node (Cdios) record different families: give one"))
        }
        (Some(_), Some(_), None) => Err(usage(
            "-m (PowerCube modules) and --axis (PA-CONTROL axes) are different families: record them in two commands",
        )),
        (None, Some(axes), None) => {
            let axes = list(axes, PAC_AXIS)?.0;
            let values = names(&args.values, PacValue::parse, PacValue::ALL.map(PacValue::name).as_slice())?;
            Ok(Selection::Pac { axes, values })
        }
        (modules, None, Some(node)) => {
            let node = NodeId::new(node).ok_or_else(|| usage(format!("node id {node} is out of range 1..127")))?;
            let modules = modules.as_deref().ok_or_else(|| usage("--node needs the 6168 modules: -m 0 or -m 0,1"))?;
            let modules = list(modules, CDIOS_MODULE)?.to(CdiosModule::new);
            let values = names(&args.values, CdiosValue::parse, CdiosValue::ALL.map(CdiosValue::name).as_slice())?;
            Ok(Selection::Cdios { node, modules, values })
        }
        (Some(modules), None, None) => {
            let modules = list(modules, POWERCUBE_MODULE)?.to(ModuleId::new);
            args.values.iter().try_for_each(|n| super::powercube::names::check_param(n))?;
            let params = cube_dev::readable_params(&args.values, false)?;
            Ok(Selection::PowerCube { modules, params })
        }
        (None, None, None) => Err(usage(
            "nothing to record: give PowerCube modules (-m 17 ActPos), PA-CONTROL axes (--axis 2 position) or a \
             Cdios node and modules (--node 1 -m 0 position speed)",
        )),
    }
}

pub(in crate::commands) fn names<T>(
    given: &[String],
    parse: fn(&str) -> Option<T>,
    known: &[&str],
) -> anyhow::Result<Vec<T>> {
    given
        .iter()
        .map(|n| parse(n).ok_or_else(|| usage(format!("no value {n:?} to record here; known: {}", known.join(", ")))))
        .collect()
}

/// The command after `--`, parsed by the real parser and limited to the
/// motions the recording can supervise.
fn motion(ctx: &Ctx, words: &[String]) -> anyhow::Result<Motion> {
    let cli =
        crate::cli::parse_words(words).map_err(|e| usage(format!("the motion after --: {}", e.kind_text(words))))?;
    let one = |m: u8| ModuleId::new(m).expect("the parser checked the range");
    let m = match cli.command {
        Command::PowerCube(PowerCubeCommand::MoveRamp {
            modules,
            device,
            pos,
            vel,
            acc,
            ticks,
            relative,
            force,
            sync,
            ..
        }) => match (&ramp_modules(ctx, modules.map(|l| l.0), device)?[..], &pos[..], sync) {
            ([m], [p], false) => {
                Motion::Cube { module: one(*m), mv: Move::Ramp { pos: *p, vel, acc }, ticks, relative, force }
            }
            _ => return Err(usage("record -- move-ramp moves one module to one position (no --sync)")),
        },
        Command::PowerCube(PowerCubeCommand::MoveStep { module, pos, time, ticks, relative, force }) => Motion::Cube {
            module: cube_of(ctx, &module)?,
            mv: Move::Step { pos, time_ms: time },
            ticks,
            relative,
            force,
        },
        Command::PowerCube(PowerCubeCommand::MoveVel { module, vel, ticks, force }) => {
            Motion::Cube { module: cube_of(ctx, &module)?, mv: Move::Vel(vel), ticks, relative: false, force }
        }
        Command::PowerCube(PowerCubeCommand::MoveCur { module, amps, force }) => {
            Motion::Cube { module: cube_of(ctx, &module)?, mv: Move::Cur(amps), ticks: false, relative: false, force }
        }
        Command::Pac(PacCommand::PacMove { axis, pos, relative, force, .. }) => {
            Motion::Pac { axis: super::pac::axis_number(ctx, &axis)?, pos, relative, force }
        }
        Command::Cdios(CdiosCommand::Goto {
            target, position, relative, setpoint_relative, latched, speed, ..
        }) => {
            if latched || speed.is_some() {
                return Err(usage("record -- cdios-goto takes no --latched or --speed (set the speed first)"));
            }
            let mode = match (relative, setpoint_relative) {
                (true, _) => GotoMode::Relative,
                (false, true) => GotoMode::SetpointRelative,
                _ => GotoMode::Absolute,
            };
            // `--node` left out is the recording's node, as it always was.
            let typed = target.device.is_some() || words.iter().any(|w| w == "--node" || w.starts_with("--node="));
            let target = super::cdios::target_of(ctx, target)?;
            let module = CdiosModule::new(target.module).expect("the parser checked the range");
            cdios_dev::check(&cdios_dev::goto_commands(mode, position, None)?, module)?;
            Motion::Cdios { node: typed.then_some(target.node.node), module, mode, position }
        }
        _ => return Err(usage(format!("record -- takes one motion command: {MOTIONS}"))),
    };
    if let Motion::Cube { mv, ticks, .. } = m {
        mv.check(ticks)?;
    }
    Ok(m)
}

trait KindText {
    fn kind_text(&self, words: &[String]) -> String;
}

impl KindText for clap::Error {
    /// clap's message without its usage block, which names `axisctl` alone.
    fn kind_text(&self, words: &[String]) -> String {
        let text = self.to_string();
        let first = text.lines().next().unwrap_or_default().trim_start_matches("error: ").to_string();
        format!("`{}`: {first}", words.join(" "))
    }
}

/// Samples, starts the motion after the first sample, and halts it on
/// every way out (when is [`HaltWhen`]'s to say). `node`: the Cdios node
/// of the recording; `attempts`: how often a lost halt is sent.
fn go<S: HaltMotion>(
    s: &mut S,
    ctx: &Ctx,
    (pace, until): (Pace, Until),
    (motion, node, attempts): (Option<Motion>, u8, u32),
    writer: &mut Writer,
    start: impl Fn(&mut S, &Motion) -> Result<String, RecordError>,
) -> anyhow::Result<()> {
    let links: Vec<String> = s.channels().iter().map(|c| ctx.link_text_for(c.address.family())).collect();
    writer.header(s.channels(), &links);
    let (mut tried, mut started) = (false, false);
    let clock = ctx.clock.clone();
    // Armed before the motion starts (after the first sample): the face
    // halts it on a panic's unwind; every other end is weighed below.
    let targets = motion.as_ref().and_then(|m| MotionTarget::try_from(m.address(node)).ok()).into_iter().collect();
    let mut faced = Recording::new(s);
    let ended = Moving::new(&mut faced, targets, attempts).follow(|r| {
        let s = r.sampler();
        let mut sink = |sample: &Sample, s: &mut S| -> Result<(), RecordError> {
            writer.sample(sample);
            if let (Some(m), false) = (&motion, tried) {
                // Started once the first sample shows where it started
                // from. A start that fails was handled by the device
                // layer (a motion that may have gone out is halted there).
                tried = true;
                let text = start(s, m)?;
                started = true;
                output::err_line(format_args!("{} at t = {:.4} s: {text}", m.device(), sample.t));
            }
            Ok(())
        };
        record::record(s, clock.as_ref(), pace, until, &|| supervisor::stop_requested(), &mut sink)
    });
    output::flush();
    let Some(m) = motion.filter(|_| started) else {
        // Without a motion Ctrl-C is how an open-ended recording ends.
        return ended.map(|_| ()).map_err(device_error);
    };
    let why = supervisor::stop_reason();
    let halted =
        record::halt_motion(s, m.address(node), HaltWhen::after(&ended), attempts).map(|r| r.unwrap_or_else(|e| e));
    let said = halted.as_deref().map(|h| format!(": {} {h}", m.device())).unwrap_or_default();
    if let Some(h) = &halted {
        output::err_line(format_args!("{} {h}", m.device()));
    }
    if let Err(left) = s.release() {
        output::err_line(format_args!("{left}"));
        if matches!(ended, Ok(End::Done)) {
            return Err(anyhow::anyhow!(left));
        }
    }
    match (ended, why) {
        (Err(e), _) => Err(device_error(e).context(format!("recording failed{said}"))),
        (Ok(End::Stopped), Some(why @ (supervisor::StopReason::Output(_) | supervisor::StopReason::Panic(_)))) => {
            Err(OutputFailed(format!("{why}, so the motion was stopped{said}")).into())
        }
        (Ok(End::Stopped), _) => Err(Interrupted(said).into()),
        (Ok(End::Done), _) => Ok(()),
    }
}

/// The device layer's own error, so that its exit-code class and refusal
/// are found in the chain (a transparent wrapper would hide its type).
pub(in crate::commands) fn device_error(e: RecordError) -> anyhow::Error {
    match e.into_face() {
        FaceError::PowerCube(e) => e.into(),
        FaceError::Pac(e) => e.into(),
        FaceError::Cdios(e) => e.into(),
        other => other.into(),
    }
}

fn start_cube(s: &mut CubeSampler, m: &Motion, attempts: u32) -> Result<String, RecordError> {
    let Motion::Cube { module, mut mv, ticks, relative, force } = *m else { unreachable!("a PowerCube motion") };
    let cubes = s.cubes();
    if relative {
        let id = if ticks { ids::ACT_I_POS } else { ids::ACT_POS };
        let here = cubes.read_now(module, &[id])?[0];
        mv = match mv {
            Move::Ramp { pos, vel, acc } => Move::Ramp { pos: here + pos, vel, acc },
            Move::Step { pos, time_ms } => Move::Step { pos: here + pos, time_ms },
            other => other,
        };
    }
    let moved = cubes.move_supervised(module, mv, ticks, force, attempts)?;
    super::powercube::refresh_ahead(cubes);
    Ok(format!("{} acknowledged", moved.described))
}

fn start_pac(s: &mut PacSampler, m: &Motion) -> Result<String, RecordError> {
    let Motion::Pac { axis, pos, relative, force } = *m else { unreachable!("a PA-CONTROL motion") };
    let started = s.controller().start_move_supervised(axis, pos, relative, !force)?;
    Ok(format!("moving to {}", started.target))
}

fn start_cdios(s: &mut CdiosSampler, m: &Motion, attempts: u32) -> Result<String, RecordError> {
    let Motion::Cdios { module, mode, position, .. } = *m else { unreachable!("a Cdios motion") };
    let cmds = cdios_dev::goto_commands(mode, position, None)?;
    let confirmed = s.node().send_supervised(module, &cmds, attempts)?;
    Ok(format!("goto {} {position} {}", cdios_dev::mode_name(mode), if confirmed { "confirmed" } else { "sent" }))
}

/// A device's envelope and the channels (index, name) it holds.
type DeviceColumns = (Map<String, Value>, Vec<(usize, String)>);

/// Writes the samples in the chosen format.
pub(super) struct Writer {
    format: Format,
    devices: Vec<DeviceColumns>,
    units: Vec<String>,
    /// Text columns: each as wide as its header.
    widths: Vec<usize>,
}

impl Writer {
    pub fn new(format: Format) -> Self {
        Self { format, devices: Vec::new(), units: Vec::new(), widths: Vec::new() }
    }

    /// The columns, each channel with the link its device is on.
    pub fn header(&mut self, channels: &[Channel], links: &[String]) {
        self.units = channels.iter().map(|c| c.unit.clone()).collect();
        for ((i, c), link) in channels.iter().enumerate().zip(links) {
            let key = json!([c.address.column(), link]);
            let pos = self.devices.iter().position(|(env, _)| env.get("_addr") == Some(&key));
            let at = match pos {
                Some(p) => p,
                None => {
                    let mut env = Map::new();
                    env.insert("family".into(), json!(c.address.family().name()));
                    env.insert("link".into(), json!(link));
                    match c.address {
                        Address::PowerCube { module: m } => env.insert("module".into(), json!(m)),
                        // A channel is an axis's, never the controller's.
                        Address::Pac { axis } => axis.and_then(|a| env.insert("axis".into(), json!(a))),
                        Address::Cdios { node, module } => {
                            env.insert("node".into(), json!(node));
                            env.insert("module".into(), json!(module))
                        }
                    };
                    env.insert("_addr".into(), key);
                    self.devices.push((env, Vec::new()));
                    self.devices.len() - 1
                }
            };
            self.devices[at].1.push((i, c.name.clone()));
        }
        for (env, _) in &mut self.devices {
            env.remove("_addr");
        }
        let columns: Vec<String> = channels.iter().map(column).collect();
        match self.format {
            Format::Jsonl => {}
            Format::Csv => say!("t [s],{}", columns.join(",")),
            Format::Text => {
                self.widths = columns.iter().map(|c| c.len().max(12) + 2).collect();
                let head: String = columns.iter().zip(&self.widths).map(|(c, w)| format!("{c:>w$}")).collect();
                say!("{:>10}{head}", "t [s]")
            }
        }
    }

    pub fn sample(&mut self, s: &Sample) {
        match self.format {
            Format::Jsonl => {
                let devices: Vec<Value> = self
                    .devices
                    .iter()
                    .map(|(env, chans)| {
                        let mut d = env.clone();
                        let values: Map<String, Value> = chans
                            .iter()
                            .map(|(i, name)| (name.clone(), output::with_unit(number(s.values[*i]), &self.units[*i])))
                            .collect();
                        d.insert("values".into(), Value::Object(values));
                        Value::Object(d)
                    })
                    .collect();
                output::json(&json!({"command": "record", "t": round_t(s.t), "seq": s.seq, "devices": devices}));
            }
            Format::Csv => {
                let vals: Vec<String> =
                    s.values.iter().map(|v| if v.is_finite() { v.to_string() } else { String::new() }).collect();
                say!("{},{}", round_t(s.t), vals.join(","));
            }
            Format::Text => {
                let vals: String = s.values.iter().zip(&self.widths).map(|(v, w)| format!("{v:>w$}")).collect();
                say!("{:>10.4}{vals}", s.t);
            }
        }
    }
}

/// Microseconds are as fine as a monotonic stamp of a frame exchange gets.
fn round_t(t: f64) -> f64 {
    (t * 1e6).round() / 1e6
}

/// An integer stays an integer (Cdios counts, status words).
fn number(v: f64) -> Value {
    if !v.is_finite() {
        Value::Null
    } else if v.fract() == 0.0 && v.abs() < 9.0e15 {
        json!(v as i64)
    } else {
        json!(v)
    }
}

/// `module 17 ActPos [m]`: a CSV column and a chart's legend entry.
pub fn column(c: &Channel) -> String {
    if c.unit.is_empty() {
        format!("{} {}", c.address.column(), c.name)
    } else {
        format!("{} {} [{}]", c.address.column(), c.name, c.unit)
    }
}
