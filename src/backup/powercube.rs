//! PowerCube: which parameters a backup holds, their checks before a
//! restore, and the order it writes them in.
//!
//! Restored (read-write rows of the table that configure the module):
//! Config; the limits MinPos, MaxPos, MaxDeltaPos, MaxVel, MaxAcc, MaxCur
//! and the supply / temperature supervision; the ramp's TargetVelInc and
//! TargetAccInc; the servo loop ActC0, ActDamp, ActA0; HomeOffset and
//! ActSyncTime. Not restored: the ActI* tick limits (mirrors of the unit
//! limits), TargetPosInc, Cur and RawCur (a target position or a commanded
//! current is a motion, not a setting), DioSetup (live I/O). The ROM ranges
//! (Def*) and IncRatio are kept for information and for the checks.
//!
//! Order: Config first (its flags decide how the module treats the rest);
//! then MinPos and MaxPos, in the order that keeps MinPos <= MaxPos at
//! every step (the module limits each against the other); then the other
//! limits; then TargetVelInc / TargetAccInc, which must lie within MaxVel
//! and MaxAcc just written; then the servo loop, HomeOffset and
//! ActSyncTime. No command in it is a motion.

use std::collections::BTreeSet;

use crate::device::powercube::{self as device, Cubes, Error};
use crate::family::Family;
use crate::proto::powercube::flags::{config, state};
use crate::proto::powercube::frame::Value;
use crate::proto::powercube::table::{self, ParamDef};
use crate::proto::powercube::ModuleId;

use super::{not_reached, step, Device, Outcome, Problem, Setting, Step, Stop, ValueResult};

/// The identity a restore compares: a file of another module is refused.
pub const IDENTITY: [&str; 2] = ["serial", "type"];

const CONFIG: &str = "Config";
const POSITION: [&str; 2] = ["MinPos", "MaxPos"];
const LIMITS: [&str; 14] = [
    "MaxDeltaPos",
    "MaxVel",
    "MaxAcc",
    "MaxCur",
    "ActMinLogicSupply",
    "ActMaxLogicSupply",
    "ActMinMotorSupply",
    "ActMaxMotorSupply",
    "ActLogicUndershootTime",
    "ActLogicOvershootTime",
    "ActMotorUndershootTime",
    "ActMotorOvershootTime",
    "ActMinTemp",
    "ActMaxTemp",
];
/// Values that must lie within the limits: written after them.
const BOUND: [&str; 2] = ["TargetVelInc", "TargetAccInc"];
const SERVO: [&str; 5] = ["ActC0", "ActDamp", "ActA0", "HomeOffset", "ActSyncTime"];

/// Every parameter a restore writes, in the order of the module doc
/// (MinPos / MaxPos as a pair whose order the values decide).
pub fn restored() -> impl Iterator<Item = &'static str> {
    std::iter::once(CONFIG).chain(POSITION).chain(LIMITS).chain(BOUND).chain(SERVO)
}

/// A limit and the ROM values it must lie within (the module limits it to them).
const ROM_RANGE: [(&str, Option<&str>, &str); 6] = [
    ("MinPos", Some("DefMinPos"), "DefMaxPos"),
    ("MaxPos", Some("DefMinPos"), "DefMaxPos"),
    ("MaxVel", Some("DefMinVel"), "DefMaxVel"),
    ("MaxAcc", Some("DefMinAcc"), "DefMaxAcc"),
    ("MaxCur", None, "DefMaxCur"),
    ("MaxDeltaPos", None, "DefMaxDeltaPos"),
];

fn def(name: &str) -> &'static ParamDef {
    table::param_by_name(name).expect("the backup's names are rows of the table")
}

/// Information kept beside the settings, and read for the checks: the
/// identity, the ROM ranges the limits must lie within, and IncRatio
/// (units to encoder ticks).
const INFO: [&str; 11] = [
    "DefCubeSerial",
    "DefCubeVersion",
    "DefMinPos",
    "DefMaxPos",
    "DefMaxDeltaPos",
    "DefMinVel",
    "DefMaxVel",
    "DefMinAcc",
    "DefMaxAcc",
    "DefMaxCur",
    "IncRatio",
];

fn info_defs() -> impl Iterator<Item = &'static ParamDef> {
    INFO.into_iter().map(def)
}

/// Reads one module into a backup device: identity, the restored
/// parameters and the ROM values, in pipelined reads.
pub fn capture(cubes: &mut Cubes, m: ModuleId, link: &str) -> Result<Device, Error> {
    let defs: Vec<&'static ParamDef> = restored().map(def).chain(info_defs()).collect();
    let values = cubes.get_present(m, &defs)?;
    let get = |name: &str| defs.iter().zip(&values).find(|(d, _)| d.name == name).and_then(|(_, v)| *v);
    let linear = get(CONFIG).and_then(|v| v.as_f64()).is_some_and(|c| device::is_linear(c as u32));
    let mut dev = Device::new(Family::PowerCube, link);
    dev.module = Some(m.get());
    let serial = get("DefCubeSerial").and_then(|v| v.as_f64()).unwrap_or(0.0) as u64;
    let version = get("DefCubeVersion").and_then(|v| v.as_f64()).unwrap_or(0.0) as u16;
    dev.identity.insert("serial".into(), serial.into());
    dev.identity.insert("version".into(), table::version_text(version).into());
    dev.identity.insert("type".into(), (if linear { "linear" } else { "rotary" }).into());
    let restore: BTreeSet<&str> = restored().collect();
    for (d, v) in defs.iter().zip(values) {
        // Serial and version are the identity's.
        let Some(v) = v.filter(|_| !matches!(d.name, "DefCubeSerial" | "DefCubeVersion")) else { continue };
        let value = serde_json::to_value(v).unwrap_or(serde_json::Value::Null);
        dev.settings.insert(
            d.name.into(),
            Setting {
                id: Some(d.id.into()),
                ty: Some(d.ty.name().into()),
                unit: d.unit_for(linear).into(),
                value,
                restore: restore.contains(d.name),
            },
        );
    }
    Ok(dev)
}

/// The file's value as the parameter's wire type, through the same parser
/// and access check as `set-param`.
fn wire_value(name: &str, value: &serde_json::Value) -> Result<(&'static ParamDef, Value), String> {
    let text = match value {
        serde_json::Value::Number(n) => n.to_string(),
        other => return Err(format!("{other} is not a number")),
    };
    device::param_write(name, &text).map_err(|e| e.to_string().trim_end_matches("; nothing was sent").to_string())
}

/// The checks that need only the file: a known, restorable name and a
/// value of the parameter's type.
pub fn check_file(dev: &Device) -> Vec<Problem> {
    let restore: BTreeSet<&str> = restored().collect();
    let mut out = Vec::new();
    for (name, s) in dev.restorable() {
        let problem = match table::param_by_name(name) {
            None => Some(format!("unknown parameter {name:?}")),
            Some(d) if !d.access.writable() => Some(format!("{} is read-only (restore must be false)", d.name)),
            Some(d) if !restore.contains(d.name) => {
                Some(format!("{} is no setting a restore writes (restore must be false)", d.name))
            }
            Some(d) if d.name != name => Some(format!("write the manual's name {} (not {name:?})", d.name)),
            Some(_) => wire_value(name, &s.value).err(),
        };
        out.extend(problem.map(|message| Problem { device: dev.address(), name: name.clone(), message }));
    }
    out
}

fn number(dev: &Device, name: &str) -> Option<f64> {
    dev.settings.get(name).and_then(|s| s.value.as_f64())
}

/// The file's value where it restores it, else the live one: what the
/// module will hold after the restore.
fn after(file: &Device, live: &Device, name: &str) -> Option<f64> {
    file.settings.get(name).filter(|s| s.restore).and_then(|s| s.value.as_f64()).or_else(|| number(live, name))
}

/// The checks against the live module: each limit within the module's ROM
/// range, MinPos <= MaxPos, the ramp's velocity and acceleration positive
/// and within the limits the restore leaves, a parameter the firmware
/// lacks, and a Config change that would take a protection away.
pub fn check_live(file: &Device, live: &Device) -> Vec<Problem> {
    let mut out = Vec::new();
    let mut problem = |name: &str, message: String| {
        out.push(Problem { device: file.address(), name: name.into(), message });
    };
    for (name, s) in file.restorable() {
        if !live.settings.contains_key(name) && table::param_by_name(name).is_some() {
            problem(name, "the module's firmware does not have it".into());
            continue;
        }
        let Some(x) = s.value.as_f64() else { continue };
        if let Some((_, lo, hi)) = ROM_RANGE.iter().find(|(n, _, _)| n == name) {
            let lo_v = lo.and_then(|l| number(live, l)).unwrap_or(0.0);
            if let Some(hi_v) = number(live, hi) {
                if x < lo_v || x > hi_v {
                    problem(
                        name,
                        format!(
                            "{x} {} is outside the module's range {lo_v} to {hi_v} ({}..{hi})",
                            s.unit,
                            lo.unwrap_or("0")
                        ),
                    );
                }
            }
        }
    }
    if let (Some(lo), Some(hi)) = (after(file, live, "MinPos"), after(file, live, "MaxPos")) {
        if lo > hi {
            problem("MinPos", format!("MinPos {lo} would lie above MaxPos {hi}"));
        }
    }
    let inc = number(live, "IncRatio").unwrap_or(f64::NAN);
    for (name, limit) in [("TargetVelInc", "MaxVel"), ("TargetAccInc", "MaxAcc")] {
        let Some(x) = file.settings.get(name).filter(|s| s.restore).and_then(|s| s.value.as_f64()) else { continue };
        if x <= 0.0 {
            problem(
                name,
                format!(
                    "{x} must be positive (it is the ramp's {})",
                    if name == "TargetVelInc" { "velocity" } else { "acceleration" }
                ),
            );
        } else if let Some(l) = after(file, live, limit) {
            let ticks = (l * inc).abs();
            if x > ticks * (1.0 + 1e-6) + 1.0 {
                problem(name, format!("{x} ticks exceeds {limit} {l} ({ticks:.0} ticks)"));
            }
        }
    }
    if let (Some(want), Some(have)) =
        (file.settings.get(CONFIG).filter(|s| s.restore).and_then(|s| s.value.as_u64()), number(live, CONFIG))
    {
        let change = config_change(want as u32, have as u32);
        let removed = change.removed_safeties();
        if !removed.is_empty() {
            problem(CONFIG, format!("{} (change it with set-config --force)", removed.join("; ")));
        }
    }
    out
}

/// Config as flags to set and clear, so that the device layer's safety
/// rules apply to each; the type bits are hardware and never changed.
fn config_change(want: u32, have: u32) -> device::ConfigChange {
    let hw = config::LINEAR | config::LINEAR_SCREW;
    device::ConfigChange { set: want & !have & !hw, clear: have & !want & !hw, raw: None }
}

/// The order of the writes for this file on this module.
pub fn order(file: &Device, live: &Device) -> Vec<&'static str> {
    let mut out = vec![CONFIG];
    // MaxPos first when the new range lies above the old one, so that the
    // module does not limit the new MinPos to the old MaxPos.
    let min_first = match (after(file, live, "MinPos"), number(live, "MaxPos")) {
        (Some(new_min), Some(old_max)) => new_min <= old_max,
        _ => true,
    };
    if min_first {
        out.extend(POSITION);
    } else {
        out.extend(POSITION.iter().rev());
    }
    out.extend(LIMITS);
    out.extend(BOUND);
    out.extend(SERVO);
    out
}

/// A restore writes only to a module at rest (CubeState without MOTION).
pub fn ensure_at_rest(cubes: &mut Cubes, m: ModuleId) -> Result<(), Error> {
    if cubes.state(m)? & state::MOTION != 0 {
        return Err(Error::Refused(format!(
            "module {m} is moving; a restore writes limits only to a module at rest (halt it first); nothing was written"
        )));
    }
    Ok(())
}

/// Writes the file's settings that differ from the live module, in
/// [`order`], each read back. `skip` names the settings found invalid
/// (`--skip-invalid`). Refused as a whole, before any write, while the
/// module is moving. `stop` is asked before each value: once it says why,
/// the rest are not written.
pub fn restore(
    cubes: &mut Cubes,
    m: ModuleId,
    file: &Device,
    live: &Device,
    skip: &BTreeSet<String>,
    stop: Stop<'_>,
) -> Result<Vec<ValueResult>, Error> {
    ensure_at_rest(cubes, m)?;
    let mut out = Vec::new();
    let mut stopped = None;
    for name in order(file, live) {
        if let Some(why) = stopped.clone().or_else(stop) {
            out.extend(not_reached(file, live, name, skip, &why));
            stopped = Some(why);
            continue;
        }
        match step(file, live, name, skip) {
            None => {}
            Some(Step::Done(r)) => out.push(r),
            Some(Step::Write(s, r)) => {
                let before = r.before.clone();
                out.push(write(cubes, m, name, &s.value, &before, r));
            }
        }
    }
    Ok(out)
}

fn write(
    cubes: &mut Cubes,
    m: ModuleId,
    name: &str,
    wanted: &serde_json::Value,
    before: &serde_json::Value,
    r: ValueResult,
) -> ValueResult {
    if name == CONFIG {
        let (Some(w), Some(b)) = (wanted.as_u64(), before.as_u64()) else {
            return r.failed(&"not a 32-bit word", crate::session::ErrorKind::Usage);
        };
        return match cubes.write_config(m, config_change(w as u32, b as u32)) {
            Ok(kept) => r.read_back(kept.into()),
            Err(Error::ConfigNotKept { kept, .. }) => r.read_back(kept.into()),
            Err(e) => {
                let kind = e.kind();
                r.failed(&e, kind)
            }
        };
    }
    let (d, value) = match wire_value(name, wanted) {
        Ok(v) => v,
        Err(e) => return r.failed(&e, crate::session::ErrorKind::Usage),
    };
    match cubes.write_param(m, d, value, false) {
        Ok(Some(held)) => r.read_back(serde_json::to_value(held).unwrap_or(serde_json::Value::Null)),
        Ok(None) => {
            let mut r = r.read_back(wanted.clone());
            r.outcome = Outcome::Written;
            r
        }
        Err(e) => {
            let kind = e.kind();
            r.failed(&e, kind)
        }
    }
}
