//! The document, the diff engine and the PowerCube restore plan, the last
//! against the simulated contract bench.

use std::collections::BTreeSet;
use std::sync::Arc;

use super::*;
use crate::clock::{Clock, VirtualClock};
use crate::device::powercube::Cubes;
use crate::proto::powercube::ModuleId;
use crate::session::powercube::PowerCube;
use crate::sim::bench::Bench;

fn cube_doc(settings: &[(&str, serde_json::Value, bool)]) -> Document {
    let mut dev = Device::new(Family::PowerCube, "sim");
    dev.module = Some(17);
    dev.identity.insert("serial".into(), 17.into());
    for (name, value, restore) in settings {
        dev.settings.insert((*name).into(), Setting::new(value.clone(), "m/s", *restore));
    }
    Document { schema: SCHEMA.into(), created_by: "test".into(), link: "sim".into(), devices: vec![dev] }
}

#[test]
fn a_document_reads_back_as_written() {
    let doc = cube_doc(&[("MaxVel", 0.1.into(), true), ("DefMaxVel", 0.2.into(), false)]);
    let text = serde_json::to_string_pretty(&doc).unwrap();
    assert_eq!(parse("f", &text).unwrap(), doc);
    assert!(text.contains("\"module\": 17") && !text.contains("\"axis\""), "{text}");
}

#[test]
fn a_newer_schema_or_another_document_is_refused() {
    let doc = cube_doc(&[]);
    let mut v = serde_json::to_value(&doc).unwrap();
    v["schema"] = "axisctl-backup/2".into();
    assert!(matches!(parse("f", &v.to_string()), Err(ParseError::Newer(..))));
    v["schema"] = "something-else/1".into();
    assert!(matches!(parse("f", &v.to_string()), Err(ParseError::NotBackup(..))));
    assert!(matches!(parse("f", "{\"schema\": "), Err(ParseError::NotJson(..))));
    assert!(matches!(parse("f", "{\"devices\": []}"), Err(ParseError::NotBackup(..))));
    v["schema"] = SCHEMA.into();
    v["devices"][0]["family"] = "toaster".into();
    assert!(matches!(parse("f", &v.to_string()), Err(ParseError::NotBackup(..))));
    let twice = Document { devices: vec![doc.devices[0].clone(), doc.devices[0].clone()], ..doc };
    let e = parse("f", &serde_json::to_string(&twice).unwrap()).unwrap_err();
    assert!(e.to_string().contains("twice"), "{e}");
}

/// Two links of a bench may each have a module 17: one device each, paired
/// by link; a link whose name changed (a new pty) is paired by address in
/// the file's order.
#[test]
fn one_address_on_two_links_is_two_devices() {
    let on = |link: &str, v: f64| {
        let mut d = cube_doc(&[("MaxVel", v.into(), true)]).devices.remove(0);
        d.link = link.into();
        d
    };
    let doc = |devices| Document { devices, ..cube_doc(&[]) };
    let file = doc(vec![on("slcan:/dev/a", 0.1), on("slcan:/dev/b", 0.2)]);
    let text = serde_json::to_string(&file).unwrap();
    assert_eq!(parse("f", &text).unwrap(), file);
    let twice = doc(vec![on("slcan:/dev/a", 0.1), on("slcan:/dev/a", 0.2)]);
    let e = parse("f", &serde_json::to_string(&twice).unwrap()).unwrap_err();
    assert!(e.to_string().contains("powercube module 17 on slcan:/dev/a is in it twice"), "{e}");

    // Live, in the other order: each compared with its own link's device.
    let live = doc(vec![on("slcan:/dev/b", 0.2), on("slcan:/dev/a", 0.1)]);
    assert!(diff(&file, &live).iter().all(|d| d.differences.is_empty()), "{:?}", diff(&file, &live));
    let live = doc(vec![on("slcan:/dev/b", 0.25), on("slcan:/dev/a", 0.1)]);
    let d = diff(&file, &live);
    let differs: Vec<_> = d.iter().filter(|d| !d.differences.is_empty()).map(|d| d.link.as_str()).collect();
    assert_eq!(differs, ["slcan:/dev/b"]);
    // The links renamed: paired in order.
    let live = doc(vec![on("slcan:/dev/c", 0.1), on("slcan:/dev/d", 0.25)]);
    let d = diff(&file, &live);
    assert_eq!(d.len(), 2, "{d:?}");
    assert_eq!(d[1].differences.len(), 1);
    assert!(d[0].differences.is_empty());
}

#[test]
fn the_diff_compares_restored_settings_and_identity_only() {
    let a = cube_doc(&[("MaxVel", 0.1.into(), true), ("ActPos", 0.5.into(), false), ("MaxAcc", 1.into(), true)]);
    let mut b = cube_doc(&[("MaxVel", 0.100000001.into(), true), ("ActPos", 0.7.into(), false)]);
    let d = diff(&a, &b);
    assert_eq!(d.len(), 1);
    assert_eq!(
        d[0].differences,
        vec![Difference { name: "MaxAcc".into(), unit: "m/s".into(), left: Some(1.into()), right: None }]
    );
    b.devices[0].identity.insert("serial".into(), 18.into());
    b.devices[0].settings.insert("MaxAcc".into(), Setting::new(1.into(), "m/s", true));
    let d = diff(&a, &b);
    assert_eq!(d[0].differences[0].name, "identity.serial");
    assert_eq!(d[0].differences.len(), 1);
    b.devices[0].module = Some(5);
    let d = diff(&a, &b);
    assert_eq!(d.len(), 2, "a device on one side only is one entry each");
    assert!(d.iter().all(|x| !x.differences.is_empty()));
    assert!(diff(&a, &a).iter().all(|x| x.differences.is_empty()));
}

#[test]
fn values_compare_within_a_floats_precision() {
    assert!(same_value(&0.1.into(), &0.1f32.to_string().parse::<f64>().unwrap().into()));
    assert!(!same_value(&0.1.into(), &0.11.into()));
    assert!(same_value(&5.into(), &5.0.into()));
    assert!(!same_value(&"3.5.18".into(), &"3.5.19".into()));
    assert!(same_value(&0.into(), &0.0.into()));
}

#[test]
fn the_file_checks_name_type_and_access() {
    let doc = cube_doc(&[
        ("MaxVel", 0.1.into(), true),
        ("ActPos", 0.5.into(), true),
        ("NoSuchThing", 1.into(), true),
        ("ActC0", 1.5.into(), true),
        ("ActDamp", "x".into(), true),
        ("ActIMaxVel", 100.into(), true),
        ("maxacc", 1.into(), true),
        ("Whatever", 1.into(), false),
    ]);
    let problems = powercube::check_file(&doc.devices[0]);
    let names: Vec<&str> = problems.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["ActC0", "ActDamp", "ActIMaxVel", "ActPos", "NoSuchThing", "maxacc"], "{problems:?}");
    assert!(problems[3].message.contains("read-only"), "{}", problems[3]);
}

struct Rig {
    cubes: Cubes,
    _bench: Bench,
}

fn rig() -> Rig {
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let bench = Bench::contract(Arc::clone(&clock));
    let cubes = Cubes::new(PowerCube::over_can(Box::new(bench.bus.open())).with_clock(clock));
    Rig { cubes, _bench: bench }
}

fn m17() -> ModuleId {
    ModuleId::new(17).unwrap()
}

/// Module 17 as a fresh simulated bench holds it.
fn cube_on_the_simulator() -> Device {
    powercube::capture(&mut rig().cubes, m17(), "sim").unwrap()
}

fn set(dev: &mut Device, name: &str, value: serde_json::Value) {
    dev.settings.get_mut(name).unwrap().value = value;
}

#[test]
fn capture_restore_round_trip_on_the_simulator() {
    let mut r = rig();
    let saved = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    assert_eq!(saved.identity["type"], "linear");
    assert!(saved.settings["MaxVel"].restore && !saved.settings["DefMaxVel"].restore);
    assert_eq!(saved.settings["MaxVel"].unit, "m/s");
    assert!(powercube::check_file(&saved).is_empty());
    // Change two settings on the module, then restore the saved ones.
    let mut changed = saved.clone();
    set(&mut changed, "MaxVel", 0.05.into());
    set(&mut changed, "ActC0", 7.into());
    let live = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    assert!(powercube::check_live(&changed, &live).is_empty());
    let res = powercube::restore(&mut r.cubes, m17(), &changed, &live, &BTreeSet::new(), &|| None).unwrap();
    let written: Vec<&str> = res.iter().filter(|v| v.outcome == Outcome::Written).map(|v| v.name.as_str()).collect();
    assert_eq!(written, ["MaxVel", "ActC0"]);
    let live = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    let doc = |d: &Device| Document {
        schema: SCHEMA.into(),
        created_by: String::new(),
        link: "sim".into(),
        devices: vec![d.clone()],
    };
    assert_eq!(diff(&doc(&saved), &doc(&live))[0].differences.len(), 2);
    let res = powercube::restore(&mut r.cubes, m17(), &saved, &live, &BTreeSet::new(), &|| None).unwrap();
    assert!(res.iter().all(|v| matches!(v.outcome, Outcome::Written | Outcome::Unchanged)), "{res:?}");
    let live = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    assert!(diff(&doc(&saved), &doc(&live))[0].differences.is_empty());
}

#[test]
fn live_checks_find_values_the_module_would_limit() {
    let live = cube_on_the_simulator();
    let def_max = live.settings["DefMaxPos"].value.as_f64().unwrap();
    let mut file = live.clone();
    set(&mut file, "MaxPos", (def_max + 1.0).into());
    set(&mut file, "TargetVelInc", 0.into());
    set(&mut file, "MinPos", (def_max + 0.5).into());
    let names: Vec<String> = powercube::check_live(&file, &live).into_iter().map(|p| p.name).collect();
    assert_eq!(names, ["MaxPos", "MinPos", "TargetVelInc"]);
    // A Config that switches limit switch 1 off takes a protection away.
    let mut file = live.clone();
    let word = live.settings["Config"].value.as_u64().unwrap() as u32;
    set(&mut file, "Config", (word & !crate::proto::powercube::flags::config::SW1_ENABLED).into());
    let sw1_on = word & crate::proto::powercube::flags::config::SW1_ENABLED != 0;
    assert_eq!(powercube::check_live(&file, &live).len(), usize::from(sw1_on));
}

#[test]
fn a_new_range_above_the_old_one_writes_max_pos_first() {
    let live = cube_on_the_simulator();
    let old_max = live.settings["MaxPos"].value.as_f64().unwrap();
    let mut file = live.clone();
    set(&mut file, "MinPos", (old_max + 0.1).into());
    let order = powercube::order(&file, &live);
    assert_eq!(&order[..3], ["Config", "MaxPos", "MinPos"]);
    assert_eq!(&powercube::order(&live, &live)[..3], ["Config", "MinPos", "MaxPos"]);
    let tv = order.iter().position(|n| *n == "TargetVelInc").unwrap();
    assert!(order.iter().position(|n| *n == "MaxVel").unwrap() < tv, "limits before the values within them");
}

fn pac_axis(settings: &[(&str, f64)]) -> Device {
    let mut dev = Device::new(Family::Pac, "sim");
    dev.axis = Some(2);
    for (name, v) in settings {
        dev.settings.insert((*name).into(), Setting::new((*v).into(), "AE", true));
    }
    dev
}

#[test]
fn pac_order_puts_units_before_the_area_and_the_area_before_the_speeds() {
    let live = pac_axis(&[("traverse-area-min", 0.0), ("traverse-area-max", 100.0)]);
    let order = pac::order(&live, &live);
    let at = |n: &str| order.iter().position(|x| *x == n).unwrap();
    assert!(at("gear-factor") < at("traverse-area-min"));
    assert!(at("traverse-area-min") < at("traverse-area-max"));
    assert!(at("traverse-area-max") < at("traverse-speed"));
    assert!(at("traverse-area-max") < at("acceleration"));
    let above = pac_axis(&[("traverse-area-min", 200.0), ("traverse-area-max", 300.0)]);
    let order = pac::order(&above, &live);
    let at = |n: &str| order.iter().position(|x| *x == n).unwrap();
    assert!(at("traverse-area-max") < at("traverse-area-min"), "max first when the new area lies above");
    let mut ctrl = Device::new(Family::Pac, "sim");
    ctrl.settings.insert("language".into(), Setting::new(1.into(), "", true));
    assert!(!pac::order(&ctrl, &ctrl).contains(&"number-of-axes"), "the configuration is never written");
}

#[test]
fn pac_file_checks() {
    let dev = pac_axis(&[("traverse-speed", 10.0), ("p-share", 1.0), ("direction-of-rotation", 3.0), ("nope", 1.0)]);
    let names: Vec<String> = pac::check_file(&dev).into_iter().map(|p| p.name).collect();
    assert_eq!(names, ["direction-of-rotation", "nope", "p-share"]);
    let mut ctrl = Device::new(Family::Pac, "sim");
    ctrl.settings.insert("language".into(), Setting::new(1.5.into(), "", true));
    ctrl.settings.insert("number-of-axes".into(), Setting::new(2.into(), "", true));
    ctrl.settings.insert("autostart".into(), Setting::new(0.into(), "", true));
    let names: Vec<String> = pac::check_file(&ctrl).into_iter().map(|p| p.name).collect();
    assert_eq!(names, ["language", "number-of-axes"]);
}

fn cdios_module(settings: &[(&str, serde_json::Value)]) -> Device {
    let mut dev = Device::new(Family::Cdios, "sim");
    dev.node = Some(1);
    dev.module = Some(0);
    for (name, v) in settings {
        dev.settings.insert((*name).into(), Setting::new(v.clone(), "", true));
    }
    dev
}

#[test]
fn cdios_file_checks_use_the_tables_ranges() {
    let dev = cdios_module(&[
        ("speeds.maximum_speed", 8000.into()),
        ("speeds.minimum_speed", 0.into()),
        ("events.mask1", 256.into()),
        ("events.position_on_change", 2.into()),
        ("outputs.digital", 1.5.into()),
        ("speeds.nope", 1.into()),
        ("outputs.digital2", 1.into()),
    ]);
    let names: Vec<String> = cdios::check_file(&dev).into_iter().map(|p| p.name).collect();
    assert_eq!(
        names,
        [
            "events.mask1",
            "events.position_on_change",
            "outputs.digital",
            "outputs.digital2",
            "speeds.minimum_speed",
            "speeds.nope"
        ]
    );
}

#[test]
fn cdios_live_checks_only_look_at_changed_selectors() {
    let live = cdios_module(&[
        ("speeds.minimum_speed", 50.into()),
        ("speeds.maximum_speed", 8000.into()),
        ("speeds.slope", 10.into()),
    ]);
    assert!(cdios::check_live(&live, &live).is_empty());
    let mut file = live.clone();
    file.settings.get_mut("speeds.slope").unwrap().value = 20.into();
    assert!(cdios::check_live(&file, &live).is_empty(), "a valid change");
}

#[test]
fn a_value_the_module_does_not_keep_is_reported_clamped() {
    let mut r = rig();
    let live = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    // The type bits are hardware: a Config word without LINEAR is written
    // as flags (LINEAR untouched), and the module keeps its own word.
    let word = live.settings["Config"].value.as_u64().unwrap() as u32;
    let linear = crate::proto::powercube::flags::config::LINEAR;
    assert_ne!(word & linear, 0);
    let mut file = live.clone();
    set(&mut file, "Config", u64::from(word & !linear).into());
    let res = powercube::restore(&mut r.cubes, m17(), &file, &live, &BTreeSet::new(), &|| None).unwrap();
    let config = res.iter().find(|v| v.name == "Config").unwrap();
    assert_eq!(config.outcome, Outcome::Clamped, "{config:?}");
    assert_eq!(config.after, serde_json::Value::from(word));
    assert_eq!(summary(&res)[3], (Outcome::Clamped, 1));
}

// Issue 22, item 9: each limit's ROM minimum (DefMinPos for MinPos and
// MaxPos, DefMinVel, DefMinAcc) is checked, not only the maximum; a value
// at the minimum itself is within the range. The module here starts its
// travel at 0.2 m, so that DefMinPos is not the 0 a missing minimum reads as.
#[test]
fn a_limit_below_the_modules_rom_minimum_is_refused() {
    let mut live = cube_on_the_simulator();
    set(&mut live, "DefMinPos", 0.2.into());
    set(&mut live, "MinPos", 0.2.into());
    assert!(powercube::check_live(&live, &live).is_empty());
    for (name, rom) in
        [("MinPos", "DefMinPos"), ("MaxPos", "DefMinPos"), ("MaxVel", "DefMinVel"), ("MaxAcc", "DefMinAcc")]
    {
        let min = live.settings[rom].value.as_f64().unwrap();
        assert!(min > 0.0, "{rom} {min}");
        let mut file = live.clone();
        set(&mut file, name, (min * 0.5).into());
        let problems = powercube::check_live(&file, &live);
        let p = problems.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("{name} below {rom}: {problems:?}"));
        assert!(p.message.contains(&format!("outside the module's range {min} to ")), "{p}");
        assert!(p.message.contains(&format!("({rom}..")), "{p}");
        // At the minimum itself: no problem of its own (a ramp above the
        // new MaxVel may be one of TargetVelInc's).
        set(&mut file, name, min.into());
        let problems = powercube::check_live(&file, &live);
        assert!(!problems.iter().any(|p| p.name == name && p.message.contains("range")), "{name}: {problems:?}");
    }
}

// A restore told to stop (a signal) after its first write writes nothing
// more: every later value it would have written is `NotWritten`, with the
// reason, and the module holds them as they were.
#[test]
fn a_restore_told_to_stop_writes_nothing_more_and_reports_the_rest_not_written() {
    let mut r = rig();
    let live = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    let mut file = live.clone();
    set(&mut file, "MaxVel", 0.05.into());
    set(&mut file, "ActC0", 7.into());
    set(&mut file, "ActDamp", 9.into());
    let asked = std::cell::Cell::new(0);
    let stop = || {
        asked.set(asked.get() + 1);
        (asked.get() > 1).then(|| "stopped by SIGTERM".to_string())
    };
    let res = powercube::restore(&mut r.cubes, m17(), &file, &live, &BTreeSet::new(), &stop).unwrap();
    let changed: Vec<(&str, Outcome)> =
        res.iter().filter(|v| v.outcome != Outcome::Unchanged).map(|v| (v.name.as_str(), v.outcome)).collect();
    // Config is first in the order (unchanged): the stop comes before MaxVel.
    assert_eq!(
        changed,
        [("MaxVel", Outcome::NotWritten), ("ActC0", Outcome::NotWritten), ("ActDamp", Outcome::NotWritten)]
    );
    assert!(res
        .iter()
        .filter(|v| v.outcome == Outcome::NotWritten)
        .all(|v| v.message.as_deref() == Some("stopped by SIGTERM")));
    assert_eq!(summary(&res)[5], (Outcome::NotWritten, 3));
    let after = powercube::capture(&mut r.cubes, m17(), "sim").unwrap();
    for name in ["MaxVel", "ActC0", "ActDamp"] {
        assert_eq!(after.settings[name].value, live.settings[name].value, "{name} was not written");
    }
    // Asked once per value until it says stop, then no more.
    assert_eq!(asked.get(), 2);
}

// A device the restore did not reach: each value is unchanged, skipped or
// not written, never written.
#[test]
fn a_device_not_reached_has_every_value_it_would_write_not_written() {
    let live = cube_on_the_simulator();
    let mut file = live.clone();
    set(&mut file, "MaxVel", 0.05.into());
    set(&mut file, "ActC0", 7.into());
    let skip: BTreeSet<String> = ["ActC0".to_string()].into();
    let res = not_written(&file, &live, &skip, "the link was lost");
    assert_eq!(res.len(), file.restorable().count());
    let get = |n: &str| res.iter().find(|v| v.name == n).unwrap();
    assert_eq!(
        (get("MaxVel").outcome, get("MaxVel").message.as_deref()),
        (Outcome::NotWritten, Some("the link was lost"))
    );
    assert_eq!(get("ActC0").outcome, Outcome::Skipped);
    assert_eq!(get("MaxAcc").outcome, Outcome::Unchanged);
    assert_eq!(summary(&res)[5].1, 1);
}

/// Module 0 of the contract node on a fresh simulated bench, and its node.
fn cdios_rig() -> (crate::device::cdios::Node, Bench) {
    use crate::device::cdios::Node;
    use crate::proto::cdios::NodeId;
    use crate::session::cdios::Cdios;
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let bench = Bench::contract(Arc::clone(&clock));
    let s = Cdios::new(Box::new(bench.bus.open())).with_clock(clock);
    (Node::new(s, NodeId::new(1).unwrap(), crate::session::RetryPolicy::default()), bench)
}

// A Cdios restore asks before each write (a servo selector, the event
// setup, the digital outputs, an analog output): once told to stop, the rest is not written and says
// why, and the module keeps what it held.
#[test]
fn a_cdios_restore_told_to_stop_writes_nothing_more() {
    let m = crate::proto::cdios::ModuleId::new(0).unwrap();
    for stop_at in [1, 2, 3, 4] {
        let (mut node, _bench) = cdios_rig();
        let live = cdios::capture(&mut node, m, 0, 0, "sim").unwrap();
        let mut file = live.clone();
        set(&mut file, "speeds.maximum_speed", 6000.into());
        set(&mut file, "events.mask3", 128.into());
        set(&mut file, "outputs.digital", 5.into());
        set(&mut file, "outputs.analog2", 2500.into());
        let asked = std::cell::Cell::new(0);
        let stop = || {
            asked.set(asked.get() + 1);
            (asked.get() >= stop_at).then(|| "stopped by SIGINT".to_string())
        };
        let res = cdios::restore(&mut node, m, &file, &live, &BTreeSet::new(), &stop).unwrap();
        let outcome = |n: &str| res.iter().find(|v| v.name == n).unwrap().outcome;
        let names = ["speeds.maximum_speed", "events.mask3", "outputs.digital", "outputs.analog2"];
        for (i, name) in names.iter().enumerate() {
            let want = if i + 1 < stop_at { Outcome::Written } else { Outcome::NotWritten };
            assert_eq!(outcome(name), want, "stop at ask {stop_at}: {name}");
        }
        assert_eq!(asked.get(), stop_at, "asked once per write until told to stop");
        let after = cdios::capture(&mut node, m, 0, 0, "sim").unwrap();
        for (i, name) in names.iter().enumerate() {
            let held = if i + 1 < stop_at { &file } else { &live };
            assert_eq!(after.settings[*name].value, held.settings[*name].value, "stop at {stop_at}: {name}");
        }
    }
}

#[test]
fn the_one_address_in_the_backups_form() {
    use crate::address::Address as One;
    let said: Vec<String> = [
        One::PowerCube { module: 3 },
        One::Pac { axis: None },
        One::Pac { axis: Some(2) },
        One::Cdios { node: 1, module: 0 },
    ]
    .into_iter()
    .map(|a| Address::from(a).to_string())
    .collect();
    assert_eq!(said, ["powercube module 3", "pac", "pac axis 2", "cdios node 1 module 0"]);
}

/// The contract bench's PA-CONTROL, as `restore` opens it.
fn pac_rig() -> (crate::device::pac::Controller, Bench) {
    use crate::link::SerialFormat;
    use crate::session::pac::Pac;
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let bench = Bench::contract(Arc::clone(&clock));
    let pac = Pac::new(Box::new(bench.pac_link(Arc::clone(&clock))), 9600, SerialFormat::F7N1).with_clock(clock);
    (crate::device::pac::Controller::new(pac), bench)
}

// The checks against the controller: a changed value at either end of the
// controller's own limits (1802 / 1801) passes and one past either end is
// refused; the traverse area's min may reach its max but not lie above it.
#[test]
fn pac_live_checks_keep_the_controllers_limits_and_the_area_in_order() {
    use crate::proto::pac::table;
    let (mut c, _bench) = pac_rig();
    let live = pac::capture_axis(&mut c, 1, "sim").unwrap();
    assert!(pac::check_live(&mut c, &live, &live).unwrap().is_empty(), "what the axis holds passes");
    let def = table::AXIS_PARAMS.iter().find(|p| p.name == "traverse-speed").unwrap();
    let par1 = table::axis_param_par1(1, def.number);
    let (lo, hi) = (c.read_f64(0x1802, par1).unwrap(), c.read_f64(0x1801, par1).unwrap());
    let held = live.settings["traverse-speed"].value.as_f64().unwrap();
    assert!(lo < held && held < hi, "the limits {lo} to {hi} hold {held} strictly inside");
    for (v, refused) in [(lo - 1.0, true), (lo, false), (hi, false), (hi + 1.0, true)] {
        let mut file = live.clone();
        set(&mut file, "traverse-speed", v.into());
        let problems = pac::check_live(&mut c, &file, &live).unwrap();
        let said: Vec<&str> = problems.iter().map(|p| p.message.as_str()).collect();
        if refused {
            assert_eq!(problems.len(), 1, "{v}: {said:?}");
            assert_eq!(problems[0].name, "traverse-speed");
            assert!(said[0].contains("outside the controller's limits"), "{said:?}");
        } else {
            assert!(problems.is_empty(), "{v} lies within {lo} to {hi}: {said:?}");
        }
    }
    let max = live.settings["traverse-area-max"].value.as_f64().unwrap();
    let mut area = |min: f64| {
        let mut file = live.clone();
        set(&mut file, "traverse-area-min", min.into());
        let problems = pac::check_live(&mut c, &file, &live).unwrap();
        problems.into_iter().filter(|p| p.message.contains("traverse area min")).count()
    };
    assert_eq!(area(max), 0, "min may equal max");
    assert_eq!(area(max + 1.0), 1, "min above max is refused");
}
