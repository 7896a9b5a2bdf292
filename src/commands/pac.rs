//! PA-CONTROL commands (`pac-*`): argument handling and printing over
//! [`device::pac`](axisctl::device::pac), which builds and validates every
//! command before anything is sent (the manual's ranges, the operating mode,
//! the controller's own limits) and runs the moves, waits and stops.
//!
//! Moves: `pac-move` starts with 0A94 / 0A95, which answer BE = 1 at once,
//! so the line stays free; `--wait` then reads 1910 (axis status) and 190C
//! (position) every poll interval for the live display, and Ctrl-C sends
//! 0A93 (stop axis) before exiting 130. The 0A87 / 0A89 way (only polls
//! until the move ends, the live position in each poll's Q_PAR, manual
//! 3.4.3) is what `pac-raw 0A87 ...` does. The reference drive 0A84 has no
//! start-and-return form: `pac-ref --wait` polls it and shows elapsed time;
//! Ctrl-C abandons it and sends 0A93 anyway.

mod backup;
mod dashboard;
mod devices;
pub mod names;
mod record;
mod tap;

use std::io::IsTerminal;
use std::time::Duration;

use anyhow::Context;
use axisctl::device::face::{Face, Halt, MotionTarget, StopHow};
use axisctl::device::pac::{self as device, Controller, Element, Register};
use axisctl::family::Family;
use axisctl::open::Takeover;
use axisctl::proto::pac::table::{self, CommandDef, POSITION_UNIT, SPEED_UNIT};
use axisctl::proto::pac::{Ack, CheckRule, Command, Par2};
use axisctl::session::pac::Progress;
use serde_json::json;

use super::pac_limits;
use super::takeover::HolderReport;
use super::{arm_interrupt, interrupted, usage, Ctx};
use crate::cli::ids::Devices;
use crate::cli::pac::{PacCommand, PacWait, ParamAccess};
use crate::cli::Switch;
use crate::output;
use crate::output::{say, tell_part};

pub(in crate::commands) use devices::axis_number;

pub fn run(ctx: &Ctx, mut cmd: PacCommand) -> anyhow::Result<()> {
    // `-d` is resolved (and its link pinned) before the link opens: a
    // device the command cannot take sends nothing.
    devices::resolve(ctx, &mut cmd)?;
    // The stops work from another terminal too: a line held by another
    // axisctl process (a `--wait`, the dashboard) is released by it first.
    let stops = matches!(cmd, PacCommand::PacStop(_) | PacCommand::PacStopAxis { .. });
    let (pac, takeover) =
        if stops { super::takeover::open(ctx, |o, spec, opts| o.pac(spec, opts))? } else { (ctx.pac()?, None) };
    let mut d = Controller::new(pac);
    let d = &mut d;
    match cmd {
        PacCommand::PacOnline(_) => online(ctx, d),
        PacCommand::PacOffline(_) => offline(ctx, d),
        PacCommand::PacStop(_) => stop(ctx, d, None, false, takeover.as_ref()),
        PacCommand::PacAutoStart(_) => simple(ctx, d, 0x0602, None, None),
        PacCommand::PacAutoAbort(_) => simple(ctx, d, 0x0A41, None, None),
        PacCommand::PacState(_) => state(ctx, d),
        PacCommand::PacError(_) => error(ctx, d),
        PacCommand::PacResetError(_) => reset_error(ctx, d),
        PacCommand::PacMove { axis, pos, relative, force, wait } => {
            move_axis(ctx, d, axis.number(), pos, relative, force, wait)
        }
        PacCommand::PacRef { axis, wait } => reference(ctx, d, axis.number(), wait),
        PacCommand::PacNoRef(a) => simple(ctx, d, 0x0A83, Some(a.number()), None),
        PacCommand::PacZero(a) => simple(ctx, d, 0x0A85, Some(a.number()), None),
        PacCommand::PacSetPos { axis, pos } => simple(ctx, d, 0x0A86, Some(axis.number()), Some(finite("POS", pos)?)),
        PacCommand::PacSpeed { axis, speed } => {
            let speed = finite("speed", speed)?;
            limited(ctx, d, 0x0A8D, axis.number(), speed)?;
            simple(ctx, d, 0x0A8D, Some(axis.number()), Some(speed))
        }
        PacCommand::PacAccel { axis, accel } => {
            let accel = finite("acceleration", accel)?;
            limited(ctx, d, 0x0A8E, axis.number(), accel)?;
            simple(ctx, d, 0x0A8E, Some(axis.number()), Some(accel))
        }
        PacCommand::PacStopAxis { axis, wait, no_wait: _ } => {
            stop(ctx, d, Some(axis.number()), wait, takeover.as_ref())
        }
        PacCommand::PacAxis(a) => axes_info(ctx, d, a.axis.as_ref().expect("-d is resolved to AXIS above")),
        PacCommand::PacAxes(_) => axes(ctx, d),
        PacCommand::PacAxisPower { axis, state } => {
            simple(ctx, d, if state.is_on() { 0x0A97 } else { 0x0A98 }, Some(axis.number()), None)
        }
        PacCommand::PacAxisOn(a) => simple(ctx, d, 0x0A97, Some(a.number()), None),
        PacCommand::PacAxisOff(a) => simple(ctx, d, 0x0A98, Some(a.number()), None),
        PacCommand::PacMeasure { axis, state, off } => {
            let on = !off && state.is_some_and(Switch::is_on);
            simple(ctx, d, if on { 0x0AA0 } else { 0x0AA1 }, Some(axis.number()), None)
        }
        PacCommand::PacLimitSwitch { axis, state, .. } => {
            let axis = axis.expect("-d is resolved to AXIS above");
            simple(ctx, d, 0x0AA2, Some(axis), Some(if state.is_on() { 1.0 } else { 0.0 }))
        }
        PacCommand::PacIn { number, word, .. } => element(ctx, d, Element::Input, number, None, word),
        PacCommand::PacOut { number, value, word, .. } => element(ctx, d, Element::Output, number, value, word),
        PacCommand::PacFlag { number, value, word, system, .. } => {
            if system {
                element(ctx, d, Element::SystemFlag, number, value, false)
            } else {
                element(ctx, d, Element::Flag, number, value, word)
            }
        }
        PacCommand::PacReg { register, value, .. } => reg(ctx, d, &register, value.as_deref()),
        PacCommand::PacSysParam { param, access, .. } => sys_param(ctx, d, &param, &access),
        PacCommand::PacAxisParam { axis, param, access } => axis_param(ctx, d, axis.number(), &param, &access),
        PacCommand::PacRaw { code, par1, par2, .. } => {
            // A raw 0A8D / 0A8E is checked as pac-speed's (silently: raw is for those who know).
            d.know_online_limits(pac_limits::load(ctx.link_for(Family::Pac)?).unwrap_or_default());
            raw(ctx, d, &code, par1, par2.as_deref())
        }
    }
}

// ---------------------------------------------------------------------------
// Plumbing

fn def(code: u16) -> &'static CommandDef {
    table::command(code).expect("codes used here are in the table")
}

fn finite(what: &str, v: f64) -> anyhow::Result<f64> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(usage(format!("{what} {v} is not a finite number")))
    }
}

/// The operating status and error number every acknowledge carries. Named
/// apart from the axis status, and `controller_error` rather than `error`,
/// so that `jq -e .error` never calls a success a failure.
fn status_json(ack: &Ack) -> serde_json::Value {
    json!({"operating_status": ack.status, "operating_status_text": table::operating_status_text(ack.status),
           "controller_error": ack.error})
}

/// The envelope of a controller-level object (docs/json.md).
fn controller(ctx: &Ctx) -> serde_json::Map<String, serde_json::Value> {
    output::envelope(Family::Pac, &ctx.link_text_for(Family::Pac), &[])
}

/// The envelope of an object about one axis.
fn on_axis(ctx: &Ctx, axis: u8) -> serde_json::Map<String, serde_json::Value> {
    output::envelope(Family::Pac, &ctx.link_text_for(Family::Pac), &[("axis", axis.into())])
}

/// `envelope` and the command's own keys.
fn doc(envelope: serde_json::Map<String, serde_json::Value>, body: serde_json::Value) -> serde_json::Value {
    output::device_doc(envelope, body)
}

/// A parameter in its wire type: TYP 0 an integer, TYP 1 a float.
fn par_json(p: &Par2) -> serde_json::Value {
    match *p {
        Par2::Int(i) => json!(i),
        Par2::Float(f) => json!(f),
    }
}

fn check_rule_name(r: CheckRule) -> &'static str {
    match r {
        CheckRule::Strict => "strict",
        CheckRule::WithEtx => "with-etx",
        CheckRule::Omitted => "omitted",
    }
}

// ---------------------------------------------------------------------------
// Commands

/// One command, its acknowledge; motion-free or finishing by itself.
fn simple(ctx: &Ctx, d: &mut Controller, code: u16, axis: Option<u8>, value: Option<f64>) -> anyhow::Result<()> {
    let done = d.send(code, axis.map_or(0, i64::from), value)?;
    report(ctx, code, axis, value, done.ack, None);
    Ok(())
}

/// `pac-online`: the device layer reads the limits of 0A8D / 0A8E on the
/// way (home position only), and they are kept for the commands after it.
fn online(ctx: &Ctx, d: &mut Controller) -> anyhow::Result<()> {
    let done = d.online()?;
    let spec = ctx.link_for(Family::Pac)?;
    if d.online_limits().is_empty() {
        // Online already, or nothing could be read: an older copy is kept.
    } else if let (Err(e), false) = (pac_limits::store(spec, d.online_limits()), ctx.json) {
        // (With --json stderr carries one error object or nothing.)
        output::err_line(format_args!(
            "axisctl: warning: the speed and acceleration limits read could not be kept ({e}): \
             pac-speed and pac-accel will leave the check to the controller"
        ));
    }
    report(ctx, 0x0603, None, None, done.ack, None);
    Ok(())
}

/// `pac-offline`: the online values end, and with them the kept limits.
fn offline(ctx: &Ctx, d: &mut Controller) -> anyhow::Result<()> {
    let done = d.offline()?;
    pac_limits::forget(ctx.link_for(Family::Pac)?);
    report(ctx, 0x0A81, None, None, done.ack, None);
    Ok(())
}

/// Hands the limits `pac-online` kept to the controller, which refuses a
/// value outside them before sending. Without them the value goes out and
/// the controller checks it; a note says so.
fn limited(ctx: &Ctx, d: &mut Controller, code: u16, axis: u8, value: f64) -> anyhow::Result<()> {
    let limits = pac_limits::load(ctx.link_for(Family::Pac)?).unwrap_or_default();
    // A value that is not positive is refused anyway: no note before that.
    // With --json stderr carries one error object or nothing (docs/json.md).
    if limits.of(code, axis).is_none() && value > 0.0 && !ctx.json {
        output::err_line(format_args!(
            "axisctl: note: axis {axis}'s limits for {code:04X} are not known here (pac-online reads them in \
             home position): the controller checks the value"
        ));
    }
    d.know_online_limits(limits);
    Ok(())
}

/// A stop through the device face, then what became of the process that
/// held the line, if one did. Idempotent: in home position nothing moves,
/// which is the state asked for (exit 0, `already_stopped`). The report
/// is the controller's last acknowledge: the stop's, or the status read
/// that found it at rest.
fn stop(
    ctx: &Ctx,
    d: &mut Controller,
    axis: Option<u8>,
    wait: bool,
    takeover: Option<&Takeover>,
) -> anyhow::Result<()> {
    let at = axis.map_or(MotionTarget::PacController, MotionTarget::PacAxis);
    let how = StopHow { at_standstill: wait, ..StopHow::default() };
    let (code, _) = device::stop_command(at, how)?;
    let halt = Face::stop_with(d, at, how).map_err(|e| super::takeover::failed(e, takeover))?;
    let ack = d.session().last_ack().context("the PA-CONTROL stop left no acknowledge to report")?;
    let holder = HolderReport::after_halt(takeover);
    if halt != Halt::AtRest {
        report_with(ctx, code, axis, None, ack, holder, json!({"already_stopped": false}));
        return Ok(());
    }
    let status = ack.status;
    if ctx.json {
        let fields = json!({"acknowledged": false, "already_stopped": true, "operating_status": status,
                            "operating_status_text": table::operating_status_text(status)});
        output::json(&command_doc(ctx, code, axis, fields, holder.as_ref()));
    } else {
        if let Some(h) = &holder {
            say!("{}", h.line());
        }
        say!(
            "PA-CONTROL in {}: nothing moves, nothing to stop ({} not sent)",
            table::operating_status_text(status),
            def(code).code_hex()
        );
    }
    Ok(())
}

/// The document of one command to the controller or an axis: its envelope,
/// the command's names and PAR_1, `fields`, and the holder that let go.
fn command_doc(
    ctx: &Ctx,
    code: u16,
    axis: Option<u8>,
    fields: serde_json::Value,
    holder: Option<&HolderReport>,
) -> serde_json::Value {
    let envelope = axis.map_or_else(|| controller(ctx), |a| on_axis(ctx, a));
    let def = def(code);
    let mut d = doc(
        envelope,
        json!({"command": ctx.command_name(), "manual_command": def.name, "command_code": def.code_hex(), "par1": axis.map_or(0, i64::from)}),
    );
    merge(&mut d, fields);
    if let Some(h) = holder {
        d["holder"] = h.json();
    }
    d
}

fn report(ctx: &Ctx, code: u16, axis: Option<u8>, value: Option<f64>, ack: Ack, holder: Option<HolderReport>) {
    report_with(ctx, code, axis, value, ack, holder, json!({}));
}

/// [`report`] with `extra` keys in the JSON document.
fn report_with(
    ctx: &Ctx,
    code: u16,
    axis: Option<u8>,
    value: Option<f64>,
    ack: Ack,
    holder: Option<HolderReport>,
    extra: serde_json::Value,
) {
    let def = def(code);
    let ack_value = match def.ack {
        table::AckKind::None => None,
        _ => Some(ack.q_par),
    };
    if ctx.json {
        let mut doc = command_doc(ctx, code, axis, json!({"acknowledged": true}), holder.as_ref());
        if let Some(v) = value {
            doc["par2"] = json!(v);
        }
        if let Some(v) = ack_value {
            doc["ack_value"] = par_json(&v);
        }
        merge(&mut doc, status_json(&ack));
        merge(&mut doc, extra);
        output::json(&doc);
    } else {
        if let Some(h) = &holder {
            say!("{}", h.line());
        }
        let mut line = format!("{} ({}) done", def.name, def.code_hex());
        if let Some(v) = ack_value {
            line.push_str(&format!(", acknowledge date {v}"));
        }
        line.push_str(&format!(": status {} {}", ack.status, table::operating_status_text(ack.status)));
        if ack.error != 0 {
            line.push_str(&format!(", {}", ctx.style.error(&format!("PA-CONTROL error {}", ack.error))));
        }
        say!("{line}");
    }
}

fn merge(doc: &mut serde_json::Value, more: serde_json::Value) {
    if let (Some(a), serde_json::Value::Object(b)) = (doc.as_object_mut(), more) {
        a.extend(b);
    }
}

fn state(ctx: &Ctx, d: &mut Controller) -> anyhow::Result<()> {
    let ack = d.send(0x190B, 0, None)?.ack;
    let mode = table::mode_of_status(ack.status).map(|m| m.name());
    if ctx.json {
        let mut doc = doc(controller(ctx), status_json(&ack));
        doc["mode"] = json!(mode);
        output::json(&doc);
    } else {
        say!("status {} {} ({} mode)", ack.status, table::operating_status_text(ack.status), mode.unwrap_or("?"));
        if ack.error != 0 {
            say!("{}", ctx.style.error(&format!("PA-CONTROL error {} (see pac-error)", ack.error)));
        }
    }
    Ok(())
}

fn error(ctx: &Ctx, d: &mut Controller) -> anyhow::Result<()> {
    let ack = d.send(0x1909, 0, None)?.ack;
    let number = ack.q_par.as_i64().unwrap_or(i64::from(ack.error));
    if ctx.json {
        let mut doc = doc(controller(ctx), status_json(&ack));
        doc["controller_error"] = json!(number);
        output::json(&doc);
    } else if number == 0 {
        say!("no PA-CONTROL error");
    } else {
        say!("{}", ctx.style.error(&format!("PA-CONTROL error E{number}")));
    }
    Ok(())
}

fn reset_error(ctx: &Ctx, d: &mut Controller) -> anyhow::Result<()> {
    let reset = d.reset_error()?;
    let (ack, left) = (reset.ack, reset.left);
    if ctx.json {
        let mut doc = doc(controller(ctx), status_json(&ack));
        doc["reset"] = json!(left == 0);
        doc["remaining_error"] = json!(left);
        output::json(&doc);
    } else if left == 0 {
        say!("error reset");
    } else {
        say!("{}", ctx.style.error(&format!("error E{left} could not be reset")));
    }
    Ok(reset.check()?)
}

/// Live progress of a wait: a spinner on a terminal, JSON lines on request.
struct Reporter {
    bar: Option<indicatif::ProgressBar>,
    json: bool,
    link: String,
}

impl Reporter {
    fn new(ctx: &Ctx, wait: &PacWait) -> Self {
        let bar = crate::output::spinner(ctx.json);
        Self { bar, json: wait.progress_json, link: ctx.link_text_for(Family::Pac) }
    }

    /// One poll: the spinner's text, and with `--progress-json` a line on
    /// stderr about the axis in the contract's envelope.
    fn report(&self, axis: u8, body: serde_json::Value, text: String) {
        if let Some(bar) = &self.bar {
            bar.set_message(text);
            bar.tick();
        }
        if self.json {
            let envelope = crate::output::envelope(Family::Pac, &self.link, &[("axis", axis.into())]);
            let doc = crate::output::device_doc(envelope, body);
            crate::output::err_line(format_args!("{}", json!({ "progress": doc })));
        }
    }

    fn finish(self) {
        if let Some(bar) = self.bar {
            bar.finish_and_clear();
        }
    }
}

fn move_axis(
    ctx: &Ctx,
    d: &mut Controller,
    axis: u8,
    pos: f64,
    relative: bool,
    force: bool,
    wait: PacWait,
) -> anyhow::Result<()> {
    let pos = finite("POS", pos)?;
    on_axis(ctx, axis);
    if !wait.wait {
        // One-shot: unsupervised once acknowledged.
        let started = d.start_move(axis, pos, relative, !force)?;
        let (code, target, start_position) = (started.code, started.target, started.start_position);
        if ctx.json {
            let mut doc = doc(
                on_axis(ctx, axis),
                json!({"command": ctx.command_name(), "manual_command": def(code).name, "command_code": def(code).code_hex(),
                "target": output::with_unit(json!(target), POSITION_UNIT), "start_position": output::with_unit(json!(start_position), POSITION_UNIT), "done": false, "acknowledged": true}),
            );
            merge(&mut doc, status_json(&started.ack));
            output::json(&doc);
        } else {
            say!(
                "axis {axis}: moving from {start_position} to {target} {POSITION_UNIT} ({} started)",
                def(code).code_hex()
            );
        }
        return Ok(());
    }
    // Supervised from before the first byte; the device layer's waited
    // move halts the axis on every way out, an unwinding panic included.
    arm_interrupt()?;
    let follow = device::Follow { poll: Duration::from_millis(wait.poll), limit: wait.wait_timeout };
    let reporter = Reporter::new(ctx, &wait);
    // The target is known once the start is acknowledged, before the first look.
    let target = std::cell::Cell::new(f64::NAN);
    let result = d.move_waited((axis, pos, relative, !force), follow, &mut |s| target.set(s.target), &mut |p| {
        let (position, status, target) = (p.position, p.status, target.get());
        reporter.report(
            axis,
            json!({"position": crate::output::with_unit(json!(position), POSITION_UNIT), "axis_status": status,
                   "elapsed_ms": p.elapsed.as_millis() as u64}),
            format!("axis {axis} -> {target}: position {position:.3}  {}", table::axis_status_text(status)),
        );
        !interrupted()
    });
    reporter.finish();
    let (started, end) = result.map_err(|e| super::stopped_by_output(e.into()))?;
    let (code, target, start_position) = (started.code, started.target, started.start_position);
    let device::MoveProgress { position, status, elapsed } = end;
    if ctx.json {
        output::json(&doc(
            on_axis(ctx, axis),
            json!({"command": ctx.command_name(), "manual_command": def(code).name, "command_code": def(code).code_hex(),
            "target": output::with_unit(json!(target), POSITION_UNIT), "start_position": output::with_unit(json!(start_position), POSITION_UNIT),
            "position": output::with_unit(json!(position), POSITION_UNIT), "axis_status": status,
            "axis_status_text": table::axis_status_text(status), "done": true,
            "elapsed_ms": elapsed.as_millis() as u64}),
        ));
    } else {
        crate::output::say!(
            "axis {axis}: at {position} {POSITION_UNIT} after {:.2} s ({})",
            elapsed.as_secs_f64(),
            table::axis_status_text(status)
        );
    }
    Ok(())
}

fn reference(ctx: &Ctx, d: &mut Controller, axis: u8, wait: PacWait) -> anyhow::Result<()> {
    on_axis(ctx, axis);
    if !wait.wait {
        // No start-and-return form exists: the drive runs on and the
        // controller answers only polls until it ends.
        let (ack, done) = d.start_reference(axis)?;
        if ctx.json {
            let mut doc = doc(
                on_axis(ctx, axis),
                json!({"command": ctx.command_name(), "manual_command": def(0x0A84).name, "command_code": "0A84",
                                                         "done": done, "acknowledged": true}),
            );
            merge(&mut doc, status_json(&ack));
            output::json(&doc);
        } else if done {
            say!("axis {axis}: reference drive done");
        } else {
            say!(
                "axis {axis}: reference drive started; until it ends the controller accepts only polls \
                 (use --wait to follow it)"
            );
        }
        return Ok(());
    }
    arm_interrupt()?;
    let poll = Duration::from_millis(wait.poll);
    let limit = wait.wait_timeout;
    let reporter = Reporter::new(ctx, &wait);
    let result = d.reference_waited(axis, device::Follow { poll, limit }, &mut |p: &Progress| {
        // 0A84's acknowledge date has no meaning (5.2.6.3): only time shows.
        reporter.report(
            axis,
            json!({"polls": p.polls, "done": p.ack.be, "operating_status": p.ack.status,
                   "elapsed_ms": p.elapsed.as_millis() as u64}),
            format!("axis {axis}: reference drive, {} poll(s)", p.polls),
        );
        !interrupted()
    });
    reporter.finish();
    let done = result.map_err(|e| super::stopped_by_output(e.into()))?;
    let position = d.read_f64(0x190C, axis.into())?;
    if ctx.json {
        let mut doc = doc(
            on_axis(ctx, axis),
            json!({"command": ctx.command_name(), "manual_command": def(0x0A84).name, "command_code": "0A84",
            "done": true, "position": output::with_unit(json!(position), POSITION_UNIT), "polls": done.polls,
            "elapsed_ms": done.elapsed.as_millis() as u64}),
        );
        merge(&mut doc, status_json(&done.ack));
        output::json(&doc);
    } else {
        crate::output::say!(
            "axis {axis}: referenced, at {position} {POSITION_UNIT} after {:.2} s",
            done.elapsed.as_secs_f64()
        );
    }
    Ok(())
}

/// Everything 1910 / 1921 / 190C / 190D / 1913 / 1914 say about an axis.
fn axis_json(ctx: &Ctx, d: &mut Controller, axis: u8) -> anyhow::Result<serde_json::Value> {
    let envelope = on_axis(ctx, axis);
    let state = d.axis_state(axis)?;
    let area = d.traverse_area(axis)?;
    let (position, speed, status, ext_raw) = (state.position, state.speed, state.status as u64, state.ext_status);
    let (min, max) = (area.min, area.max);
    Ok(doc(
        envelope,
        json!({"position": output::with_unit(json!(position), POSITION_UNIT),
              "speed": output::with_unit(json!(speed), SPEED_UNIT), "axis_status": status,
              "axis_status_text": table::axis_status_text(status), "state": super::decode::ext_axis_state(ext_raw),
              "traverse_min": output::with_unit(json!(min), POSITION_UNIT),
              "traverse_max": output::with_unit(json!(max), POSITION_UNIT)}),
    ))
}

/// `pac-axis` of each axis asked for: one object for one axis, else
/// `{"devices": [...]}` (`all`: every configured axis).
fn axes_info(ctx: &Ctx, d: &mut Controller, axes: &Devices) -> anyhow::Result<()> {
    let list: Vec<u8> = match axes {
        Devices::One(a) => vec![*a],
        Devices::List(l) => l.0.clone(),
        Devices::All => (1..=d.configured_axes()?).collect(),
    };
    let mut docs = Vec::new();
    for axis in list {
        docs.push(axis_info(ctx, d, axis)?);
    }
    if ctx.json {
        match axes {
            Devices::One(_) => output::json(&docs[0]),
            _ => output::json(&json!({ "devices": docs })),
        }
    }
    Ok(())
}

fn axis_info(ctx: &Ctx, d: &mut Controller, axis: u8) -> anyhow::Result<serde_json::Value> {
    let doc = axis_json(ctx, d, axis)?;
    if ctx.json {
        return Ok(doc);
    }
    let flags = &doc["state"]["flags"];
    let yes = |name: &str| if flags.as_array().is_some_and(|f| f.iter().any(|f| f == name)) { "yes" } else { "no" };
    let with_unit = |v: &serde_json::Value| format!("{} {}", v["value"], v["unit"].as_str().unwrap_or(""));
    let rows = vec![
        vec!["axis".into(), axis.to_string()],
        vec!["position".into(), with_unit(&doc["position"])],
        vec!["speed".into(), with_unit(&doc["speed"])],
        vec!["status".into(), format!("{} {}", doc["axis_status"], doc["axis_status_text"].as_str().unwrap_or(""))],
        vec![
            "traverse area".into(),
            format!("{} to {}", doc["traverse_min"]["value"], with_unit(&doc["traverse_max"])),
        ],
        vec!["power pack ready".into(), yes("POWER_PACK_READY").into()],
        vec!["+ limit switch activated".into(), yes("POSITIVE_LIMIT_ACTIVATED").into()],
        vec!["- limit switch activated".into(), yes("NEGATIVE_LIMIT_ACTIVATED").into()],
        vec!["extended status".into(), format!("{:#010x}", doc["state"]["raw"].as_u64().unwrap_or(0))],
    ];
    output::table(&rows, crate::output::Style { color: false });
    Ok(serde_json::Value::Null)
}

fn axes(ctx: &Ctx, d: &mut Controller) -> anyhow::Result<()> {
    let n = d.configured_axes()?;
    let moving = d.read_i64(0x1911, 0)? as u64;
    let mut list = Vec::new();
    for axis in 1..=n {
        let a = i64::from(axis);
        let envelope = on_axis(ctx, axis);
        let position = d.read_f64(0x190C, a)?;
        let status = d.read_i64(0x1910, a)? as u64;
        list.push(doc(
            envelope,
            json!({"position": output::with_unit(json!(position), POSITION_UNIT), "axis_status": status,
                         "axis_status_text": table::axis_status_text(status)}),
        ));
    }
    if ctx.json {
        output::json(&doc(controller(ctx), json!({"devices": list, "moving": table::moving_axes(moving)})));
        return Ok(());
    }
    let mut rows = vec![["AXIS", "POSITION", "STATUS"].map(String::from).to_vec()];
    for a in &list {
        rows.push(vec![
            a["axis"].to_string(),
            format!("{} {POSITION_UNIT}", a["position"]["value"]),
            format!("{} {}", a["axis_status"], a["axis_status_text"].as_str().unwrap_or("")),
        ]);
    }
    output::table(&rows, ctx.style);
    Ok(())
}

/// Decimal, 0x hex or 0b binary.
fn parse_uint(text: &str) -> anyhow::Result<u64> {
    axisctl::proto::parse_uint(text)
        .ok_or_else(|| usage(format!("{text:?} is not a number (decimal, 0x hex or 0b binary)")))
}

fn element(
    ctx: &Ctx,
    d: &mut Controller,
    el: Element,
    number: u16,
    value: Option<String>,
    word: bool,
) -> anyhow::Result<()> {
    let key = el.key();
    if let Some(text) = value {
        el.write_code(word)?;
        let v = parse_uint(&text)?;
        d.write_element(el, number, v, word)?;
    }
    if word {
        let w = d.read_element_word(el, number)?;
        let members = table::word_members(number, w);
        if ctx.json {
            output::json(&doc(controller(ctx), json!({key: number, "word": w, "set": members})));
        } else {
            let first = (number.max(1) - 1) / 16 * 16 + 1;
            say!("{key}s {first} to {}: {w:#06x} {w:016b}  set: {members:?}", first + 15);
        }
    } else {
        let v = d.read_element(el, number)?;
        if ctx.json {
            output::json(&doc(controller(ctx), json!({key: number, "value": v})));
        } else {
            say!("{key} {number}: {v}");
        }
    }
    Ok(())
}

fn reg(ctx: &Ctx, d: &mut Controller, register: &str, value: Option<&str>) -> anyhow::Result<()> {
    let reg: Register = register.parse()?;
    if let Some(text) = value {
        reg.write_code()?;
        let v: f64 = text.trim().parse().map_err(|_| usage(format!("{text:?} is not a number")))?;
        d.write_register(reg, finite("value", v)?)?;
    }
    let q_par = d.read_register(reg)?;
    if ctx.json {
        // Integer registers stay integers: 12345, not 12345.0.
        let value = match q_par.as_i64() {
            Some(i) if !reg.is_float() => json!(i),
            _ => json!(q_par.as_f64()),
        };
        output::json(&doc(
            controller(ctx),
            json!({"register": reg.to_string(), "type": if reg.is_float() { "float" } else { "int" }, "value": value}),
        ));
    } else {
        say!("{reg} = {q_par}");
    }
    Ok(())
}

/// A parameter in the one shape of every family (`.params.NAME.value`);
/// `limit` says whether the value is the parameter's `min` or `max` rather
/// than its value.
fn param_json(
    name: &str,
    id: impl Into<u64>,
    ty: &str,
    unit: &str,
    value: serde_json::Value,
    what: &str,
) -> serde_json::Value {
    let limit = if what == "value" { serde_json::Value::Null } else { json!(what) };
    json!({"params": {name: {"id": id.into(), "type": ty, "unit": unit, "value": value}}, "limit": limit})
}

fn parse_value(text: &str) -> anyhow::Result<f64> {
    let v: f64 = text.trim().parse().map_err(|_| usage(format!("{text:?} is not a number")))?;
    finite("value", v)
}

fn sys_param(ctx: &Ctx, d: &mut Controller, name: &str, access: &ParamAccess) -> anyhow::Result<()> {
    let p = table::system_param_by_name(name).ok_or_else(|| {
        let names: Vec<_> = table::SYSTEM_PARAMS.iter().filter(|p| !p.unused).map(|p| p.name).collect();
        let hint = super::names::did_you_mean(name, names.iter().copied());
        usage(format!("unknown system parameter {name:?}{hint}; known: {}", names.join(", ")))
    })?;
    let n = i64::from(p.number);
    let (what, value) = if access.min {
        ("min", d.read_i64(0x1702, n)?)
    } else if access.max {
        ("max", d.read_i64(0x1701, n)?)
    } else {
        if let Some(text) = &access.value {
            let v = parse_value(text)?;
            ("value", d.write_system_param(n, v)?)
        } else {
            ("value", d.read_i64(0x1700, n)?)
        }
    };
    if ctx.json {
        output::json(&doc(controller(ctx), param_json(p.name, p.number, "int", "", json!(value), what)));
    } else {
        say!("system parameter {} ({}) {what}: {value}", p.number, p.manual_name);
    }
    Ok(())
}

fn axis_param(ctx: &Ctx, d: &mut Controller, axis: u8, name: &str, access: &ParamAccess) -> anyhow::Result<()> {
    let p = table::axis_param_by_name(name).ok_or_else(|| {
        let hint = super::names::did_you_mean(name, table::AXIS_PARAMS.iter().filter(|p| !p.unused).map(|p| p.name));
        usage(format!("unknown axis parameter {name:?}{hint}; `axisctl params pac` lists them (manual 5.2.3)"))
    })?;
    let par1 = table::axis_param_par1(axis, p.number);
    let (what, value) = if access.min {
        ("min", d.read_f64(0x1802, par1)?)
    } else if access.max {
        ("max", d.read_f64(0x1801, par1)?)
    } else {
        if let Some(text) = &access.value {
            let v = parse_value(text)?;
            ("value", d.write_axis_param(par1, v)?)
        } else {
            ("value", d.read_f64(0x1800, par1)?)
        }
    };
    if ctx.json {
        output::json(&doc(on_axis(ctx, axis), param_json(p.name, p.number, "float", p.unit, json!(value), what)));
    } else {
        say!("axis {axis} parameter {} ({}) {what}: {value} {}", p.number, p.manual_name, p.unit);
    }
    Ok(())
}

/// `send CODE;PAR1;TYP;PAR2`: the command shown, refused without
/// `--force` when it may start a motion, then sent as `pac-raw` sends it
/// (checked, followed to its end, printed decoded).
fn send_line(ctx: &Ctx, text: &str, force: bool) -> anyhow::Result<()> {
    let cmd = &crate::cli::pac::send::parse(text).map_err(usage)?;
    let def = table::command(cmd.code);
    let name = def.map_or("unknown code", |d| d.name);
    if !ctx.json {
        output::err_line(format_args!("-> {:04X};{};{};{}  {name}", cmd.code, cmd.par1, cmd.par2.typ(), cmd.par2));
    }
    // An unknown code may be anything: it is treated as motion.
    if def.is_none_or(|d| d.motion) && !force {
        return Err(usage(format!(
            "{:04X} ({name}) may start a motion: not sent (--force sends it; nothing then stops it but you)",
            cmd.code
        )));
    }
    let mut d = Controller::new(ctx.pac()?);
    d.know_online_limits(pac_limits::load(ctx.link_for(Family::Pac)?).unwrap_or_default());
    let par2 = match cmd.par2 {
        Par2::Int(i) => i.to_string(),
        Par2::Float(f) => format!("{f:?}"),
    };
    raw(ctx, &mut d, &format!("{:04X}", cmd.code), cmd.par1, Some(&par2))
}

fn raw(ctx: &Ctx, d: &mut Controller, code_text: &str, par1: i64, par2: Option<&str>) -> anyhow::Result<()> {
    let known = table::command_by_name(code_text);
    let cmd = match known {
        Some(def) => {
            let v = par2.map(parse_value).transpose()?;
            d.build(def.code, par1, v)?
        }
        None => {
            let hex = code_text.trim_start_matches("0x").trim_start_matches("0X");
            let code = u16::from_str_radix(hex, 16)
                .ok()
                .filter(|_| hex.len() == 4)
                .ok_or_else(|| usage(format!("{code_text:?} is neither a command name nor a 4-digit hex code")))?;
            let par2 = match par2 {
                None => Par2::Int(0),
                Some(t) if t.contains('.') => Par2::Float(parse_value(t)?),
                Some(t) => Par2::Int(t.trim().parse().map_err(|_| usage(format!("{t:?} is not an integer")))?),
            };
            Command::new(code, par1, par2)
        }
    };
    let def = known;
    let stoppable = device::stoppable_axis(&cmd).is_some();
    if stoppable {
        arm_interrupt()?;
    }
    let show = !ctx.json && std::io::stderr().is_terminal();
    let result = d.follow(&cmd, &mut |p: &Progress| {
        if show && !p.ack.be {
            tell_part!("\r  BE 0, poll {}: Q_PAR {}   ", p.polls, p.ack.q_par);
        }
        !stoppable || !interrupted()
    });
    if show {
        tell_part!("\r\x1b[K");
    }
    let done = result?;
    let ack = done.ack;
    if ctx.json {
        let mut doc = doc(
            controller(ctx),
            json!({"command": ctx.command_name(), "command_code": format!("{:04X}", cmd.code),
            "manual_command": def.map(|d| d.name), "par1": cmd.par1,
            "par2": par_json(&cmd.par2), "quit": ack.quit, "be": ack.be, "typ": ack.q_par.typ(),
            "q_par": par_json(&ack.q_par), "polls": done.polls, "check_rule": check_rule_name(ack.check_rule)}),
        );
        merge(&mut doc, status_json(&ack));
        output::json(&doc);
    } else {
        say!(
            "{:04X} {}: QUIT {} BE {} STATUS {} ({}) ERROR {} Q_PAR {}{}",
            cmd.code,
            def.map_or("(unknown code)", |d| d.name),
            ack.quit,
            u8::from(ack.be),
            ack.status,
            table::operating_status_text(ack.status),
            ack.error,
            ack.q_par,
            if done.polls > 0 { format!(" after {} poll(s)", done.polls) } else { String::new() }
        );
    }
    Ok(())
}

/// A PA-CONTROL refusal in the error document: the QUIT and its text.
impl super::error_json::DeviceDoc for axisctl::proto::pac::refusal::PacRefusal {
    fn device_doc(&self) -> serde_json::Value {
        json!({"family": "pac", "command_code": format!("{:04X}", self.command),
               "code": self.quit, "name": null, "text": self.text, "details": [], "unknown_bits": 0})
    }
}

/// What this folder answers for the family (`super::family_cli`).
pub const CLI: super::FamilyCli = super::FamilyCli {
    names: &names::PacNames,
    dashboard_source: dashboard::source,
    backup_live: backup::live,
    record_plan: record::plan,
    line: Some(crate::cli::send::LineCommand {
        check: |text| crate::cli::pac::send::parse(text).map(drop),
        moves: crate::cli::pac::send::moves,
        send: send_line,
    }),
    serial_trace: Some(tap::trace),
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uint_forms() {
        assert_eq!(parse_uint("0x3E11").unwrap(), 15889);
        assert_eq!(parse_uint("0b101").unwrap(), 5);
        assert_eq!(parse_uint("17906").unwrap(), 17906);
        assert!(parse_uint("x").is_err());
    }
}
