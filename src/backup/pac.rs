//! PA-CONTROL: the controller's system parameters and each configured
//! axis' parameters (manual 5.2.2 and 5.2.3). The controller reads and
//! writes parameters in home position only (operating status 1), so a
//! backup and a restore need it there; neither moves anything.
//!
//! One device object for the controller (no axis: its system parameters,
//! identity `axes`, the number of axes, which is its configuration and is
//! never written) and one per axis (its axis parameters by CLI name, in
//! the axis' units). The parameters the manual marks unused are left out.
//!
//! Order: system parameters first, then per axis the units and the
//! hardware (gear factor, encoder and motor steps, directions, switches,
//! currents), then the traverse area (min and max in the order that keeps
//! min <= max at every step), then the values in those units (speeds,
//! acceleration, tow fault, reference offset). Each write goes through the
//! device layer, which checks it against the controller's own limits
//! (1701 / 1702, 1801 / 1802) and reads it back.

use std::collections::BTreeSet;

use crate::device::pac::{Controller, Error};
use crate::family::Family;
use crate::proto::pac::table::{self, AxisParamDef, SystemParamDef};

use super::{not_reached, same_value, step, Device, Problem, Setting, Step, Stop, ValueResult};

/// The identity a restore compares: the number of axes.
pub const IDENTITY: [&str; 1] = ["axes"];

const NUMBER_OF_AXES: u16 = 2;
const AREA: [&str; 2] = ["traverse-area-min", "traverse-area-max"];
/// Values in the axis' units: written after the units and the area.
const IN_UNITS: [&str; 8] = [
    "max-towfault",
    "reference-switch-offset",
    "start-stop-speed",
    "creep-speed",
    "manual-speed",
    "reference-speed",
    "traverse-speed",
    "acceleration",
];

fn system_params() -> impl Iterator<Item = &'static SystemParamDef> {
    table::SYSTEM_PARAMS.iter().filter(|p| !p.unused && p.number != NUMBER_OF_AXES)
}

fn axis_params() -> impl Iterator<Item = &'static AxisParamDef> {
    table::AXIS_PARAMS.iter().filter(|p| !p.unused)
}

/// The controller's home position: the one mode that reads and writes parameters.
pub fn ensure_home(c: &mut Controller) -> Result<(), Error> {
    c.ensure_idle()?;
    let status = c.read_status()?;
    if status != 1 {
        return Err(Error::Refused(format!(
            "the PA-CONTROL is in operating status {status}; it reads and writes parameters in home position only \
             (manual 5.2.2, 5.2.3): `axisctl pac-offline` or `pac-stop` first; nothing was written"
        )));
    }
    Ok(())
}

/// The controller: its system parameters and the number of axes.
pub fn capture_controller(c: &mut Controller, link: &str) -> Result<Device, Error> {
    ensure_home(c)?;
    let mut dev = Device::new(Family::Pac, link);
    dev.identity.insert("axes".into(), c.read_i64(0x1700, NUMBER_OF_AXES.into())?.into());
    for p in system_params() {
        let v = c.read_i64(0x1700, p.number.into())?;
        dev.settings.insert(
            p.name.into(),
            Setting {
                id: Some(p.number.into()),
                ty: Some("int".into()),
                unit: String::new(),
                value: v.into(),
                restore: true,
            },
        );
    }
    Ok(dev)
}

/// One axis: its parameters.
pub fn capture_axis(c: &mut Controller, axis: u8, link: &str) -> Result<Device, Error> {
    let mut dev = Device::new(Family::Pac, link);
    dev.axis = Some(axis);
    for p in axis_params() {
        let v = c.read_f64(0x1800, table::axis_param_par1(axis, p.number))?;
        dev.settings.insert(
            p.name.into(),
            Setting {
                id: Some(p.number.into()),
                ty: Some("float".into()),
                unit: p.unit.into(),
                value: v.into(),
                restore: true,
            },
        );
    }
    Ok(dev)
}

/// The checks that need only the file: a known, used parameter of the
/// right kind (system or axis), an integer for a system parameter, and the
/// manual's range where it gives one.
pub fn check_file(dev: &Device) -> Vec<Problem> {
    let mut out = Vec::new();
    for (name, s) in dev.restorable() {
        let problem = if dev.axis.is_none() {
            match system_params().find(|p| p.name == name) {
                None if name == "number-of-axes" => {
                    Some("the number of axes is the controller's configuration (restore must be false)".to_string())
                }
                None => Some(format!("unknown system parameter {name:?}")),
                Some(_) => match s.value.as_f64() {
                    Some(v) if v.fract() == 0.0 => None,
                    _ => Some(format!("{} is not an integer", s.value)),
                },
            }
        } else {
            match axis_params().find(|p| p.name == name) {
                None => Some(format!("unknown axis parameter {name:?}")),
                Some(p) => match s.value.as_f64() {
                    None => Some(format!("{} is not a number", s.value)),
                    Some(v) if p.min.is_some_and(|lo| v < lo) || p.max.is_some_and(|hi| v > hi) => {
                        Some(format!("{v} is outside the manual's range {:?} to {:?}", p.min, p.max))
                    }
                    Some(_) => None,
                },
            }
        };
        out.extend(problem.map(|message| Problem { device: dev.address(), name: name.clone(), message }));
    }
    out
}

/// PAR_1 and the limit / read codes of a setting of `dev`.
fn codes(dev: &Device, name: &str) -> Option<(i64, u16, u16)> {
    match dev.axis {
        None => system_params().find(|p| p.name == name).map(|p| (i64::from(p.number), 0x1702, 0x1701)),
        Some(a) => {
            axis_params().find(|p| p.name == name).map(|p| (table::axis_param_par1(a, p.number), 0x1802, 0x1801))
        }
    }
}

fn changed<'a>(file: &'a Device, live: &'a Device) -> impl Iterator<Item = (&'a String, &'a Setting)> {
    file.restorable().filter(move |(n, s)| live.settings.get(*n).is_none_or(|l| !same_value(&s.value, &l.value)))
}

/// The checks against the controller: each value that will be written
/// within the controller's own limits (read for the changed values only),
/// and the traverse area's min <= max.
pub fn check_live(c: &mut Controller, file: &Device, live: &Device) -> Result<Vec<Problem>, Error> {
    let mut out = Vec::new();
    for (name, s) in changed(file, live) {
        let (Some((par1, min_code, max_code)), Some(v)) = (codes(file, name), s.value.as_f64()) else { continue };
        let (lo, hi) = (c.read_f64(min_code, par1)?, c.read_f64(max_code, par1)?);
        if v < lo || v > hi {
            let unit = if s.unit.is_empty() { String::new() } else { format!(" {}", s.unit) };
            out.push(Problem {
                device: file.address(),
                name: name.clone(),
                message: format!("{v}{unit} is outside the controller's limits {lo} to {hi}"),
            });
        }
    }
    let after =
        |n: &str| file.settings.get(n).filter(|s| s.restore).or(live.settings.get(n)).and_then(|s| s.value.as_f64());
    if let (Some(lo), Some(hi)) = (after(AREA[0]), after(AREA[1])) {
        if file.axis.is_some() && lo > hi {
            out.push(Problem {
                device: file.address(),
                name: AREA[0].into(),
                message: format!("traverse area min {lo} would lie above its max {hi}"),
            });
        }
    }
    Ok(out)
}

/// The order of the writes for this device.
pub fn order(file: &Device, live: &Device) -> Vec<&'static str> {
    if file.axis.is_none() {
        return system_params().map(|p| p.name).collect();
    }
    let late: BTreeSet<&str> = AREA.into_iter().chain(IN_UNITS).collect();
    let mut out: Vec<&'static str> = axis_params().map(|p| p.name).filter(|n| !late.contains(n)).collect();
    // Max first when the new area lies above the old one.
    let new_min = file.settings.get(AREA[0]).and_then(|s| s.value.as_f64());
    let old_max = live.settings.get(AREA[1]).and_then(|s| s.value.as_f64());
    if new_min.zip(old_max).is_some_and(|(lo, hi)| lo > hi) {
        out.extend(AREA.iter().rev());
    } else {
        out.extend(AREA);
    }
    out.extend(IN_UNITS);
    out
}

/// Writes the file's settings that differ from the controller's, in
/// [`order`], each read back; `skip` names the invalid ones. `stop` is
/// asked before each value: once it says why, the rest are not written.
pub fn restore(
    c: &mut Controller,
    file: &Device,
    live: &Device,
    skip: &BTreeSet<String>,
    stop: Stop<'_>,
) -> Result<Vec<ValueResult>, Error> {
    ensure_home(c)?;
    let mut out = Vec::new();
    let mut stopped: Option<String> = None;
    for name in order(file, live) {
        if let Some(why) = stopped.clone().or_else(stop) {
            out.extend(not_reached(file, live, name, skip, &why));
            stopped = Some(why);
            continue;
        }
        let (s, r) = match step(file, live, name, skip) {
            None => continue,
            Some(Step::Done(r)) => {
                out.push(r);
                continue;
            }
            Some(Step::Write(s, r)) => (s, r),
        };
        let (Some((par1, _, _)), Some(v)) = (codes(file, name), s.value.as_f64()) else {
            out.push(r.skipped("not a parameter of this device"));
            continue;
        };
        let written = if file.axis.is_none() {
            c.write_system_param(par1, v).map(serde_json::Value::from)
        } else {
            c.write_axis_param(par1, v).map(serde_json::Value::from)
        };
        out.push(match written {
            Ok(held) => r.read_back(held),
            Err(e) => {
                let kind = e.kind();
                r.failed(&e, kind)
            }
        });
    }
    Ok(out)
}
