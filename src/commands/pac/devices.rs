//! `-d` on the PA-CONTROL commands: an axis command takes axes (`pac:2`,
//! or a bench-file name of one), a controller command the controller
//! (`pac`, or a bench-file name of it). Each is resolved through the bench
//! (see [`crate::commands::devices::of_family`], which also pins the link
//! the devices are on) before any link opens, and written into the command
//! as the axis number it stands for, so the rest of the command is the
//! shorthand's.

use axisctl::bench::{Address, DeviceRef};
use axisctl::family::Family;

use crate::cli::ids::{Devices, IdList};
use crate::cli::pac::{AxesArg, AxisArg, ControllerArg, PacCommand};
use crate::commands::{devices, usage, Ctx};

/// What a device named on a PA-CONTROL command must be.
#[derive(Clone, Copy)]
enum Kind {
    Axis,
    Controller,
    /// An axis, or the controller for every axis (`pac-limit-switch`'s 0).
    AxisOrAll,
}

/// The axis numbers (0 for the controller, where `kind` allows it) of
/// `refs`, in the order given and each once.
fn numbers(ctx: &Ctx, refs: &[DeviceRef], kind: Kind) -> anyhow::Result<Vec<u8>> {
    let found = devices::of_family(ctx, Family::Pac, refs)?;
    let command = ctx.command_name();
    let bench = ctx.bench()?;
    for r in refs {
        match (bench.resolve(r)?, kind) {
            (Address::Pac { axis: None }, Kind::Axis) => {
                return Err(usage(format!(
                    "{command} takes an axis (pac:AXIS); {r} is the controller itself: name one of its axes"
                )))
            }
            (at @ Address::Pac { axis: Some(_) }, Kind::Controller) => {
                return Err(usage(format!(
                    "{command} is about the controller, not an axis: name it as pac or by its bench-file name \
                     ({r} is the axis {at})"
                )))
            }
            _ => {}
        }
    }
    Ok(found
        .into_iter()
        .filter_map(|at| if let Address::Pac { axis } = at { Some(axis.unwrap_or(0)) } else { None })
        .collect())
}

/// The one axis `-d` names.
fn one(ctx: &Ctx, r: &DeviceRef, kind: Kind) -> anyhow::Result<u8> {
    Ok(numbers(ctx, std::slice::from_ref(r), kind)?[0])
}

/// `AXIS` or `-d DEVICE` as the axis number (resolving `-d`).
pub(in crate::commands) fn axis_number(ctx: &Ctx, a: &AxisArg) -> anyhow::Result<u8> {
    match (&a.device, a.axis) {
        (Some(r), _) => one(ctx, r, Kind::Axis),
        (None, Some(n)) => Ok(n),
        (None, None) => unreachable!("clap requires AXIS or -d"),
    }
}

fn axis(ctx: &Ctx, a: &mut AxisArg) -> anyhow::Result<()> {
    a.axis = Some(axis_number(ctx, a)?);
    Ok(())
}

/// A list read: `-d`'s axes, one device one object, several a list (as
/// `pac-axis 2` and `pac-axis 1,2`).
fn axes(ctx: &Ctx, a: &mut AxesArg) -> anyhow::Result<()> {
    if let Some(refs) = &a.device {
        a.axis = Some(match numbers(ctx, refs, Kind::Axis)?[..] {
            [one] if refs.len() == 1 => Devices::One(one),
            ref list => Devices::List(IdList(list.to_vec())),
        });
    }
    Ok(())
}

fn controller(ctx: &Ctx, c: &ControllerArg) -> anyhow::Result<()> {
    match &c.device {
        Some(r) => one(ctx, r, Kind::Controller).map(drop),
        None => Ok(()),
    }
}

/// Every device the command names, resolved: axis numbers written in,
/// the link pinned. Called before the link opens, so a refusal sends nothing.
pub(in crate::commands) fn resolve(ctx: &Ctx, cmd: &mut PacCommand) -> anyhow::Result<()> {
    match cmd {
        PacCommand::PacOnline(c)
        | PacCommand::PacOffline(c)
        | PacCommand::PacStop(c)
        | PacCommand::PacAutoStart(c)
        | PacCommand::PacAutoAbort(c)
        | PacCommand::PacState(c)
        | PacCommand::PacError(c)
        | PacCommand::PacResetError(c)
        | PacCommand::PacAxes(c)
        | PacCommand::PacIn { controller: c, .. }
        | PacCommand::PacOut { controller: c, .. }
        | PacCommand::PacFlag { controller: c, .. }
        | PacCommand::PacReg { controller: c, .. }
        | PacCommand::PacSysParam { controller: c, .. }
        | PacCommand::PacRaw { controller: c, .. } => controller(ctx, c),
        PacCommand::PacMove { axis: a, .. }
        | PacCommand::PacRef { axis: a, .. }
        | PacCommand::PacNoRef(a)
        | PacCommand::PacZero(a)
        | PacCommand::PacSetPos { axis: a, .. }
        | PacCommand::PacSpeed { axis: a, .. }
        | PacCommand::PacAccel { axis: a, .. }
        | PacCommand::PacStopAxis { axis: a, .. }
        | PacCommand::PacAxisPower { axis: a, .. }
        | PacCommand::PacAxisOn(a)
        | PacCommand::PacAxisOff(a)
        | PacCommand::PacMeasure { axis: a, .. }
        | PacCommand::PacAxisParam { axis: a, .. } => axis(ctx, a),
        PacCommand::PacAxis(a) => axes(ctx, a),
        PacCommand::PacLimitSwitch { axis, device, .. } => {
            if let Some(r) = device {
                *axis = Some(one(ctx, r, Kind::AxisOrAll)?);
            }
            Ok(())
        }
    }
}
