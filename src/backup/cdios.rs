//! Cdios 6168: per module of a node, its type and version (the
//! controller's identify) and its settings: the servo configuration
//! (`speeds.maximum_speed`, `traject0.speed2`, ... as `cdios-config` names
//! them, raw values in the manual's units), the event mask and timers
//! (`events.mask1`..`mask4`, `events.position_interval`, ...), the
//! digital outputs (`outputs.digital`) and the analog outputs in mV
//! (`outputs.analog1`, `outputs.analog2`, 16h, read back with selector
//! 80h / 90h).
//!
//! Analog output #1 is the motor regulating voltage while the motor is
//! enabled (status 3 bit 7), and the module refuses to set it then. Taken
//! from an enabled module, its value is that moment's regulating voltage,
//! not a setting: it is kept for information only (`restore: false`), so
//! that no restore ever puts a stale drive voltage on the amplifier's
//! input. A file's #1 against a module whose motor is enabled now is a
//! problem listed before the first write.
//!
//! Order: the servo configuration first, one selector at a time in the
//! table's order (speeds before the trajects whose speeds lie within them),
//! each written whole through the device layer after its range checks;
//! then the event setup; the outputs last (digital, then analog), since
//! they act on whatever is wired to them. Nothing is written while the
//! motor runs. The EEPROM store (05h) is never part of a restore:
//! [`store`] is its own step.

use std::collections::{BTreeMap, BTreeSet};

use crate::device::cdios::config::{self as servo, Assignments};
use crate::device::cdios::{analog_request, field_value, Error, EventChange, EventSetup, Node};
use crate::family::Family;
use crate::proto::cdios::table::{self, STATUS_FLAGS};
use crate::proto::cdios::{AnalogOutput, ModuleId, ServoConfig, ServoPart};

use super::{same_value, step, stopping, Device, Problem, Setting, Step, Stop, ValueResult};

/// The identity a restore compares: the module's type.
pub const IDENTITY: [&str; 1] = ["type"];

const MASKS: [&str; 4] = ["mask1", "mask2", "mask3", "mask4"];
const TIMERS: [&str; 4] = ["position_interval", "position_on_change", "speed_interval", "speed_on_change"];
const OUTPUTS: &str = "outputs.digital";
/// The analog outputs' settings, in the order a restore writes them.
const ANALOG: [(&str, AnalogOutput); 2] =
    [("outputs.analog1", AnalogOutput::One), ("outputs.analog2", AnalogOutput::Two)];
/// The 16h row and field an analog output is checked with.
const ANALOG_FIELD: (&str, &str) = ("set_analog_output", "value");
/// The status flag (3, bit 7) under which the module drives analog output #1.
const ENABLED: &str = "ENABLED";

/// The flags of status byte 1 that say the motor runs.
const RUNNING: [&str; 3] = ["RUNNING_FORWARD", "RUNNING_REVERSE", "RUNNING_TO_END_SWITCH"];

fn event_names() -> impl Iterator<Item = String> {
    MASKS.iter().chain(&TIMERS).map(|k| format!("events.{k}"))
}

/// An event setup's values in the order of [`event_names`].
fn event_values(ev: &EventSetup) -> [i64; 8] {
    let t = ev.timers;
    [
        ev.masks[0].into(),
        ev.masks[1].into(),
        ev.masks[2].into(),
        ev.masks[3].into(),
        t.position_interval.into(),
        t.position_on_change.into(),
        t.speed_interval.into(),
        t.speed_on_change.into(),
    ]
}

/// The unit of the analog outputs, as the table gives it (mV).
fn analog_unit() -> &'static str {
    table::command(ANALOG_FIELD.0).and_then(|d| d.field(ANALOG_FIELD.1)).map_or("", |f| f.unit)
}

/// Reads one module: identity from the controller's slot, then its servo
/// configuration, event setup and outputs.
pub fn capture(node: &mut Node, m: ModuleId, ty: i64, version: i64, link: &str) -> Result<Device, Error> {
    let mut dev = Device::new(Family::Cdios, link);
    dev.node = Some(node.id().get());
    dev.module = Some(m.get());
    dev.identity.insert("type".into(), ty.into());
    dev.identity.insert("version".into(), version.into());
    let groups: Vec<String> = servo::GROUPS.iter().map(|g| g.to_string()).collect();
    for (part, reply) in node.read_config(m, &groups)? {
        for f in servo::set_row(part).value_fields() {
            let name = format!("{}.{}", servo::group_of(part), servo::key_of(part, f));
            let v = reply.get(f.key).unwrap_or(0);
            dev.settings.insert(name, Setting::new(v.into(), f.unit, true));
        }
    }
    let ev = node.events(m, &EventChange::default())?;
    for (name, v) in event_names().zip(event_values(&ev)) {
        dev.settings.insert(name, Setting::new(v.into(), "", true));
    }
    let out = node.outputs(m, None, false)?;
    dev.settings.insert(OUTPUTS.into(), Setting::new(out.into(), "", true));
    // Like every probe of a node, this status read clears status 3 bit 0
    // (POSITION_ZEROED); no other read tells whether the motor is enabled.
    let enabled = node.status(m)?.flags.contains(&ENABLED);
    let outs: Vec<AnalogOutput> = ANALOG.iter().map(|(_, o)| *o).collect();
    for (r, (name, o)) in node.analog(m, &outs, None)?.into_iter().zip(ANALOG) {
        let regulating = enabled && o == AnalogOutput::One;
        dev.settings.insert(name.into(), Setting::new(r.millivolts.into(), analog_unit(), !regulating));
    }
    Ok(dev)
}

/// The servo configuration field of a setting name.
fn servo_field(name: &str) -> Option<(ServoPart, &'static crate::proto::cdios::table::Field)> {
    servo::fields().into_iter().find(|(.., full)| full == name).map(|(p, f, _)| (p, f))
}

/// The table row and field that range-check an event or output setting.
fn io_field(name: &str) -> Option<(&'static str, &'static str)> {
    if name == OUTPUTS {
        return Some(("set_digital_outputs", "outputs"));
    }
    if ANALOG.iter().any(|(n, _)| *n == name) {
        return Some(ANALOG_FIELD);
    }
    let key = name.strip_prefix("events.")?;
    MASKS.iter().chain(&TIMERS).find(|k| **k == key).map(|k| ("set_event_mask", *k))
}

fn integer(v: &serde_json::Value) -> Option<i64> {
    v.as_i64().or_else(|| v.as_f64().filter(|x| x.fract() == 0.0).map(|x| x as i64))
}

/// The checks that need only the file: a known name and an integer within
/// the manual's range (the table's, through the device layer).
pub fn check_file(dev: &Device) -> Vec<Problem> {
    let mut out = Vec::new();
    for (name, s) in dev.restorable() {
        let problem = match (integer(&s.value), servo_field(name), io_field(name)) {
            (None, ..) => Some(format!("{} is not an integer", s.value)),
            (Some(v), Some((_, f)), _) => f.check(v).err().map(|e| e.to_string()),
            (Some(v), None, Some((row, key))) => {
                if matches!(key, "position_on_change" | "speed_on_change") && !(0..=1).contains(&v) {
                    Some(format!("{v} is not 0 or 1"))
                } else if (row, key) == ANALOG_FIELD {
                    field_value::<i16>(row, key, v).err().map(|e| e.to_string())
                } else {
                    field_value::<u8>(row, key, v).err().map(|e| e.to_string())
                }
            }
            (Some(_), None, None) => Some(format!("unknown setting {name:?}")),
        };
        out.extend(problem.map(|message| Problem { device: dev.address(), name: name.clone(), message }));
    }
    out
}

/// The servo changes of the file, by selector: the fields whose value
/// differs from the module's.
fn servo_changes(file: &Device, live: &Device, skip: &BTreeSet<String>) -> BTreeMap<u8, (ServoPart, Assignments)> {
    let mut out: BTreeMap<u8, (ServoPart, Assignments)> = BTreeMap::new();
    for (part, f, name) in servo::fields() {
        let Some(v) = file.settings.get(&name).filter(|s| s.restore).and_then(|s| integer(&s.value)) else {
            continue;
        };
        if skip.contains(&name) || live.settings.get(&name).is_some_and(|l| same_value(&l.value, &v.into())) {
            continue;
        }
        out.entry(part.selector()).or_insert((part, Vec::new())).1.push((f.key, v));
    }
    out
}

/// The checks against the module: each changed selector, merged over the
/// module's values, must make a configuration the module takes.
pub fn check_live(file: &Device, live: &Device) -> Vec<Problem> {
    let mut out = Vec::new();
    for (part, new) in servo_changes(file, live, &BTreeSet::new()).into_values() {
        let group = servo::group_of(part);
        let live_of = |k: &str| {
            let f = servo::set_row(part).value_fields().find(|f| f.key == k)?;
            live.settings.get(&format!("{group}.{}", servo::key_of(part, f))).and_then(|s| integer(&s.value))
        };
        if let Err(e) = ServoConfig::from_values(part, |k| {
            new.iter().find(|(nk, _)| *nk == k).map(|(_, v)| *v).or_else(|| live_of(k))
        }) {
            out.push(Problem { device: file.address(), name: group, message: e.to_string() });
        }
    }
    // An analog output the module drives itself (#1 of an enabled motor)
    // cannot be set: the module would refuse it halfway through a restore.
    for (name, o) in ANALOG {
        let Some(v) = wanted(file, name) else { continue };
        if live.settings.get(name).is_some_and(|l| !l.restore && !same_value(&l.value, &v.into())) {
            out.push(Problem {
                device: file.address(),
                name: name.into(),
                message: format!(
                    "the motor is enabled, so analog output #{} is its regulating voltage and cannot be set \
                     (cdios-disable first)",
                    o.to_u8()
                ),
            });
        }
    }
    out
}

fn wanted(file: &Device, name: &str) -> Option<i64> {
    file.settings.get(name).filter(|s| s.restore).and_then(|s| integer(&s.value))
}

/// A restore writes only to a module whose motor does not run.
pub fn ensure_at_rest(node: &mut Node, m: ModuleId) -> Result<(), Error> {
    let st = node.status(m)?;
    if let Some(f) = st.flags.iter().find(|f| RUNNING.contains(f)) {
        debug_assert!(STATUS_FLAGS.iter().any(|s| s.name == *f));
        return Err(Error::Refused(format!(
            "module {m} reports {f}; a restore writes only to a module at rest (stop it first); nothing was written"
        )));
    }
    Ok(())
}

/// Writes the file's settings that differ from the module's, in the order
/// of the module doc, each read back; `skip` names the invalid ones. `stop`
/// is asked before each write: once it says why, the rest are not written.
pub fn restore(
    node: &mut Node,
    m: ModuleId,
    file: &Device,
    live: &Device,
    skip: &BTreeSet<String>,
    stop: Stop<'_>,
) -> Result<Vec<ValueResult>, Error> {
    ensure_at_rest(node, m)?;
    let mut out = Vec::new();
    let mut stopped = None;
    let result = |name: &str| ValueResult::against(name, &file.settings[name], live);
    // Servo configuration, one selector at a time.
    let changes = servo_changes(file, live, skip);
    // Every field gets its result here: unchanged unless written below.
    for (.., name) in servo::fields() {
        if wanted(file, &name).is_none() {
            continue;
        }
        let r = result(&name);
        out.push(if skip.contains(&name) { r.skipped("invalid (see the problems); not written") } else { r });
    }
    for (selector, (part, assignments)) in &changes {
        let one: BTreeMap<u8, (ServoPart, Assignments)> = [(*selector, (*part, assignments.clone()))].into();
        let group = servo::group_of(*part);
        // `Err`: not written, for the reason the restore stopped.
        let written = match stopping(&mut stopped, stop) {
            Some(why) => Err(why),
            None => Ok(node.write_config(m, &one).and_then(|_| node.read_config(m, std::slice::from_ref(&group)))),
        };
        for (key, _) in assignments {
            let f = servo::set_row(*part).value_fields().find(|f| f.key == *key).expect("a field of the part");
            let name = format!("{group}.{}", servo::key_of(*part, f));
            let Some(slot) = out.iter_mut().find(|r| r.name == name) else { continue };
            let r = slot.clone();
            *slot = match &written {
                Ok(Ok(replies)) => {
                    let held = replies.iter().find(|(p, _)| p == part).and_then(|(_, rep)| rep.get(key));
                    r.read_back(held.map_or(serde_json::Value::Null, Into::into))
                }
                Ok(Err(e)) => r.failed(e, e.kind()),
                Err(why) => r.not_written(why),
            };
        }
    }
    // The event setup, written whole when any of it changes.
    let ev_names: Vec<String> = event_names().collect();
    let ev_changed: Vec<&String> = ev_names
        .iter()
        .filter(|n| !skip.contains(*n))
        .filter(|n| {
            wanted(file, n).is_some_and(|v| live.settings.get(*n).is_none_or(|l| !same_value(&l.value, &v.into())))
        })
        .collect();
    let ev_results = if ev_changed.is_empty() {
        None
    } else if let Some(why) = stopping(&mut stopped, stop) {
        Some(Err(why))
    } else {
        let val = |k: &str| -> Option<i64> {
            let n = format!("events.{k}");
            if skip.contains(&n) {
                None
            } else {
                wanted(file, &n)
            }
        };
        let masks = if MASKS.iter().any(|k| val(k).is_some()) {
            let old = |i: usize| live.settings.get(&ev_names[i]).and_then(|s| integer(&s.value)).unwrap_or(0);
            Some([0, 1, 2, 3].map(|i| val(MASKS[i]).unwrap_or(old(i)) as u8))
        } else {
            None
        };
        let change = EventChange {
            masks,
            position_interval: val("position_interval").map(|v| v as u8),
            position_on_change: val("position_on_change").map(|v| v != 0),
            speed_interval: val("speed_interval").map(|v| v as u8),
            speed_on_change: val("speed_on_change").map(|v| v != 0),
        };
        Some(Ok(node.events(m, &change)))
    };
    for (i, name) in ev_names.iter().enumerate() {
        if wanted(file, name).is_none() {
            continue;
        }
        let r = result(name);
        out.push(if skip.contains(name) {
            r.skipped("invalid (see the problems); not written")
        } else if !ev_changed.contains(&name) {
            r
        } else {
            match ev_results.as_ref().expect("written when changed") {
                Ok(Ok(ev)) => r.read_back(event_values(ev)[i].into()),
                Ok(Err(e)) => r.failed(e, e.kind()),
                Err(why) => r.not_written(why),
            }
        });
    }
    // The outputs last.
    if let Some(v) = wanted(file, OUTPUTS) {
        let r = result(OUTPUTS);
        out.push(if skip.contains(OUTPUTS) {
            r.skipped("invalid (see the problems); not written")
        } else if live.settings.get(OUTPUTS).is_some_and(|l| same_value(&l.value, &v.into())) {
            r
        } else if let Some(why) = stopping(&mut stopped, stop) {
            r.not_written(&why)
        } else {
            match node.outputs(m, Some(v as u8), false) {
                Ok(held) => r.read_back(held.into()),
                Err(e) => r.failed(&e, e.kind()),
            }
        });
    }
    for (name, o) in ANALOG {
        out.extend(step(file, live, name, skip).map(|s| match s {
            Step::Done(r) => r,
            Step::Write(_, r) if stopping(&mut stopped, stop).is_some() => {
                r.not_written(stopped.as_deref().unwrap_or_default())
            }
            Step::Write(s, r) => {
                let written = integer(&s.value)
                    .ok_or_else(|| Error::Refused(format!("{} is not an integer", s.value)))
                    .and_then(|v| analog_request(Some(o.to_u8().into()), Some(v), false))
                    .and_then(|(outs, set)| node.analog(m, &outs, set));
                match written {
                    Ok(held) => r.read_back(held.first().map_or(serde_json::Value::Null, |h| h.millivolts.into())),
                    Err(e) => r.failed(&e, e.kind()),
                }
            }
        }));
    }
    Ok(out)
}

/// The EEPROM store (05h) of one module: the explicit step after a restore.
pub fn store(node: &mut Node, m: ModuleId) -> Result<(), Error> {
    node.store(m, false).map(|_| ())
}
