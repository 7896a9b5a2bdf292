//! `backup`, `diff` and `restore` through the real binary: against the
//! in-process bench (`--link sim`, a fresh bench per process) and against
//! served simulators, whose state carries over between commands.

use crate::common;

use std::path::{Path, PathBuf};

use common::{run, Run, Sim};
use serde_json::Value;

fn ok(r: &Run, what: &str) {
    assert_eq!(r.code, 0, "{what}: stdout {}\nstderr {}", r.stdout, r.stderr);
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn path(dir: &tempfile::TempDir, name: &str) -> PathBuf {
    dir.path().join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn read_json(p: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

fn write_json(p: &Path, v: &Value) {
    std::fs::write(p, serde_json::to_string_pretty(v).unwrap()).unwrap();
}

/// The device of `family` at `key` = `id` in a backup document.
fn device<'a>(doc: &'a mut Value, family: &str, key: &str, id: u64) -> &'a mut Value {
    doc["devices"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|d| d["family"] == family && d[key] == id)
        .unwrap_or_else(|| panic!("no {family} {key} {id}"))
}

fn valid(def: &str, doc: &Value) {
    if let Some(errors) = common::schema_errors(&common::schema(def), doc) {
        panic!("{def}: {errors}\n{doc:#}");
    }
}

/// The PowerCube SetExtended frames (a write) in a candump `--log`: request
/// ids 0x0E0..=0x0FF with command byte 08.
fn cube_writes(log: &Path) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_whitespace().last())
        .filter(|f| {
            let (id, data) = f.split_once('#').unwrap_or(("", ""));
            u32::from_str_radix(id, 16).is_ok_and(|id| (0x0E0..=0x0FF).contains(&id)) && data.starts_with("08")
        })
        .map(str::to_string)
        .collect()
}

fn lines(log: &Path) -> usize {
    std::fs::read_to_string(log).map(|t| t.lines().count()).unwrap_or(0)
}

fn outcomes(report: &Value, family: &str, key: &str, id: u64) -> Vec<(String, String)> {
    report["devices"].as_array().unwrap().iter().find(|d| d["family"] == family && d[key] == id).unwrap()["results"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["outcome"] != "unchanged")
        .map(|r| (r["name"].as_str().unwrap().to_string(), r["outcome"].as_str().unwrap().to_string()))
        .collect()
}

// ---- PowerCube ----

#[test]
fn powercube_backup_holds_identity_and_settings_with_units_and_validates() {
    let dir = tmp();
    let file = path(&dir, "bench.json");
    let r = run(&["--link", "sim", "--json", "backup", "--family", "powercube", "--out", s(&file)]);
    ok(&r, "backup");
    valid("document", &r.json());
    assert_eq!(r.json()["devices"].as_array().unwrap().len(), 3, "{}", r.stdout);
    let mut doc = read_json(&file);
    valid("backup_document", &doc);
    assert_eq!(doc["schema"], "axisctl-backup/1");
    let m17 = device(&mut doc, "powercube", "module", 17);
    assert_eq!(m17["identity"]["type"], "linear");
    assert!(m17["identity"]["serial"].is_u64());
    assert_eq!(m17["settings"]["MaxVel"]["unit"], "m/s");
    assert_eq!(m17["settings"]["MaxVel"]["restore"], true);
    assert_eq!(m17["settings"]["DefMaxVel"]["restore"], false, "read-only values are marked");
    assert!(m17["settings"].get("ActPos").is_none(), "live values are no setting");
    // Without --out the document itself is the output.
    let r = run(&["--link", "sim", "backup", "-m", "3"]);
    ok(&r, "backup -m 3");
    let doc = r.json();
    assert_eq!(doc["devices"].as_array().unwrap().len(), 1);
    assert_eq!(doc["devices"][0]["identity"]["type"], "rotary");
    assert_eq!(doc["devices"][0]["settings"]["MaxVel"]["unit"], "rad/s");
}

#[test]
fn powercube_restore_on_the_in_process_bench_writes_reads_back_and_diffs_empty() {
    let dir = tmp();
    let saved = path(&dir, "saved.json");
    ok(&run(&["--link", "sim", "backup", "--family", "powercube", "--out", s(&saved)]), "backup");
    // The file wants other values than the fresh bench holds.
    let mut doc = read_json(&saved);
    let m17 = device(&mut doc, "powercube", "module", 17);
    m17["settings"]["MaxVel"]["value"] = 0.07.into();
    m17["settings"]["ActC0"]["value"] = 31.into();
    let changed = path(&dir, "changed.json");
    write_json(&changed, &doc);
    let r = run(&["--link", "sim", "diff", s(&changed)]);
    ok(&r, "diff");
    assert!(r.stdout.contains("MaxVel") && r.stdout.contains("0.07") && r.stdout.contains("m/s"), "{}", r.stdout);
    assert!(r.stdout.contains("2 differences on 1 device"), "{}", r.stdout);
    let r = run(&["--link", "sim", "--json", "diff", s(&changed)]);
    ok(&r, "diff --json");
    valid("document", &r.json());
    valid("diff_report", &r.json());
    assert_eq!(r.json()["differs"], true);
    let log = path(&dir, "restore.log");
    let r = run(&["--link", "sim", "--json", "--log", s(&log), "restore", s(&changed)]);
    ok(&r, "restore");
    valid("document", &r.json());
    valid("restore_report", &r.json());
    let rep = r.json();
    assert_eq!(
        outcomes(&rep, "powercube", "module", 17),
        [("MaxVel".into(), "written".into()), ("ActC0".into(), "written".into())]
    );
    assert_eq!(rep["summary"]["written"], 2);
    assert_eq!(cube_writes(&log).len(), 2, "one SetExtended per changed value");
    // The original file against a fresh bench: no difference.
    let r = run(&["--link", "sim", "--json", "diff", s(&saved)]);
    ok(&r, "diff saved");
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
    assert!(run(&["--link", "sim", "diff", s(&saved)]).stdout.starts_with("no differences"));
}

#[test]
fn powercube_round_trip_on_served_simulators() {
    let sim = Sim::start(&[], 3);
    let link = sim.link("powercube");
    let dir = tmp();
    let saved = path(&dir, "saved.json");
    ok(&run(&["--link", link, "backup", "-m", "3,17", "--out", s(&saved)]), "backup");
    ok(&run(&["--link", link, "set-param", "-m", "17", "MaxVel", "0.05"]), "set-param");
    ok(&run(&["--link", link, "set-param", "-m", "3", "ActC0", "40"]), "set-param");
    ok(&run(&["--link", link, "set-config", "-m", "17", "+brake-present"]), "set-config");
    let r = run(&["--link", link, "--json", "diff", s(&saved)]);
    ok(&r, "diff");
    let names: Vec<&str> = r.json()["devices"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|d| d["differences"].as_array().unwrap().iter().map(|x| x["name"].as_str().unwrap()))
        .map(|n| Box::leak(n.to_string().into_boxed_str()) as &str)
        .collect();
    assert_eq!(names, ["ActC0", "Config", "MaxVel"], "{}", r.stdout);
    // A dry run shows the diff and sends no write.
    let log = path(&dir, "dry.log");
    let r = run(&["--link", link, "--log", s(&log), "restore", s(&saved), "--dry-run"]);
    ok(&r, "dry run");
    assert!(r.stdout.contains("MaxVel") && r.stdout.contains("dry run"), "{}", r.stdout);
    assert!(lines(&log) > 0, "the dry run read the bench");
    assert_eq!(cube_writes(&log), Vec::<String>::new());
    let r = run(&["--link", link, "--json", "restore", s(&saved)]);
    ok(&r, "restore");
    valid("document", &r.json());
    valid("restore_report", &r.json());
    assert_eq!(
        outcomes(&r.json(), "powercube", "module", 17),
        [("Config".into(), "written".into()), ("MaxVel".into(), "written".into())]
    );
    assert_eq!(outcomes(&r.json(), "powercube", "module", 3), [("ActC0".into(), "written".into())]);
    let r = run(&["--link", link, "--json", "diff", s(&saved)]);
    ok(&r, "diff after");
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
}

#[test]
fn bad_files_exit_2_and_send_nothing() {
    let dir = tmp();
    let saved = path(&dir, "saved.json");
    ok(&run(&["--link", "sim", "backup", "-m", "17", "--out", s(&saved)]), "backup");
    let mut newer = read_json(&saved);
    newer["schema"] = "axisctl-backup/2".into();
    let newer_file = path(&dir, "newer.json");
    write_json(&newer_file, &newer);
    let broken = path(&dir, "broken.json");
    std::fs::write(&broken, "{\"schema\": \"axisctl-backup/1\", \"devices\": [").unwrap();
    let mut unknown = read_json(&saved);
    unknown["devices"][0]["settings"]["NoSuchParam"] = serde_json::json!({"unit": "", "value": 1, "restore": true});
    unknown["devices"][0]["settings"]["ActPos"] = serde_json::json!({"unit": "m", "value": 1, "restore": true});
    unknown["devices"][0]["settings"]["ActC0"]["value"] = 1.5.into();
    let unknown_file = path(&dir, "unknown.json");
    write_json(&unknown_file, &unknown);
    for (file, says) in [
        (&newer_file, "newer axisctl"),
        (&broken, "is not JSON"),
        (&unknown_file, "3 invalid values"),
        (&path(&dir, "missing.json"), "cannot read"),
    ] {
        for cmd in ["restore", "diff"] {
            let log = path(&dir, "bad.log");
            let _ = std::fs::remove_file(&log);
            let r = run(&["--link", "sim", "--json", "--log", s(&log), cmd, s(file)]);
            if cmd == "diff" && file == &unknown_file {
                ok(&r, "a diff does not validate");
                continue;
            }
            assert_eq!(r.code, 2, "{cmd} {file:?}: {}", r.stderr);
            assert!(r.stdout.is_empty());
            let err: Value = serde_json::from_str(&r.stderr).unwrap();
            assert!(err["error"]["message"].as_str().unwrap().contains(says), "{}", r.stderr);
            assert_eq!(lines(&log), 0, "{cmd} {file:?}: no frame left");
        }
    }
    // The invalid values are listed, each.
    let r = run(&["--link", "sim", "restore", s(&unknown_file)]);
    for name in ["NoSuchParam", "ActPos", "ActC0"] {
        assert!(r.stderr.contains(name), "{}", r.stderr);
    }
}

#[test]
fn values_outside_the_modules_range_are_listed_and_skipped_only_when_asked() {
    let dir = tmp();
    let saved = path(&dir, "saved.json");
    ok(&run(&["--link", "sim", "backup", "-m", "17", "--out", s(&saved)]), "backup");
    let mut doc = read_json(&saved);
    doc["devices"][0]["settings"]["MaxPos"]["value"] = 99.into();
    doc["devices"][0]["settings"]["MaxVel"]["value"] = 0.07.into();
    let file = path(&dir, "range.json");
    write_json(&file, &doc);
    let log = path(&dir, "range.log");
    let r = run(&["--link", "sim", "--log", s(&log), "restore", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("MaxPos: 99 m is outside the module's range"), "{}", r.stderr);
    assert_eq!(cube_writes(&log), Vec::<String>::new(), "nothing written");
    let r = run(&["--link", "sim", "--json", "restore", s(&file), "--skip-invalid"]);
    ok(&r, "--skip-invalid");
    valid("document", &r.json());
    valid("restore_report", &r.json());
    assert_eq!(
        outcomes(&r.json(), "powercube", "module", 17),
        [("MaxPos".into(), "skipped".into()), ("MaxVel".into(), "written".into())]
    );
    assert_eq!(r.json()["problems"][0]["name"], "MaxPos");
}

#[test]
fn a_file_of_another_module_is_refused_unless_to_names_the_target() {
    let dir = tmp();
    let m3 = path(&dir, "m3.json");
    ok(&run(&["--link", "sim", "backup", "-m", "3", "--out", s(&m3)]), "backup");
    // Module 5 is another rotary module with its own serial number.
    let mut doc = read_json(&m3);
    doc["devices"][0]["module"] = 5.into();
    doc["devices"][0]["settings"]["ActC0"]["value"] = 33.into();
    let moved = path(&dir, "moved.json");
    write_json(&moved, &doc);
    let log = path(&dir, "mismatch.log");
    let r = run(&["--link", "sim", "--log", s(&log), "restore", s(&moved)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("taken from another device") && r.stderr.contains("serial"), "{}", r.stderr);
    assert_eq!(cube_writes(&log), Vec::<String>::new());
    // The linear module 17 is of another type too; --to passes the
    // identity check, not the module's ranges.
    let r = run(&["--link", "sim", "restore", s(&m3), "--to", "17", "--dry-run"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("MaxPos: 3.1 rad is outside the module's range 0 to 1"), "{}", r.stderr);
    doc["devices"][0]["module"] = 17.into();
    write_json(&moved, &doc);
    let r = run(&["--link", "sim", "restore", s(&moved)]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("type \"rotary\" in the file, \"linear\" on the device"), "{}", r.stderr);
    // --to writes the file's one device to the module named.
    let r = run(&["--link", "sim", "--json", "restore", s(&m3), "--to", "5"]);
    ok(&r, "restore --to 5");
    assert_eq!(r.json()["devices"][0]["module"], 5);
    let r = run(&["--link", "sim", "restore", s(&saved_all(&dir)), "--to", "5"]);
    assert_eq!(r.code, 2, "--to needs a file of one device: {}", r.stderr);
}

fn saved_all(dir: &tempfile::TempDir) -> PathBuf {
    let p = path(dir, "all.json");
    ok(&run(&["--link", "sim", "backup", "--family", "powercube", "--out", s(&p)]), "backup");
    p
}

#[test]
fn two_files_diff_without_a_link() {
    let dir = tmp();
    let a = saved_all(&dir);
    let mut doc = read_json(&a);
    device(&mut doc, "powercube", "module", 5)["settings"]["MaxAcc"]["value"] = 1.25.into();
    let b = path(&dir, "b.json");
    write_json(&b, &doc);
    let r = run(&["--json", "diff", s(&a), s(&b)]);
    ok(&r, "diff two files");
    valid("document", &r.json());
    valid("diff_report", &r.json());
    let d = &r.json()["devices"];
    let m5 = d.as_array().unwrap().iter().find(|d| d["module"] == 5).unwrap();
    assert_eq!(m5["differences"][0]["name"], "MaxAcc");
    assert_eq!(m5["differences"][0]["unit"], "rad/s²");
    assert_eq!(m5["differences"][0]["right"], 1.25);
    assert_eq!(r.json()["differs"], true);
    let r = run(&["--json", "diff", s(&a), s(&a)]);
    assert_eq!(r.json()["differs"], false);
}

#[test]
fn the_documented_backup_file_is_valid_and_restores() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/examples/module17.json");
    valid("backup_document", &read_json(Path::new(file)));
    let r = run(&["--link", "sim", "--json", "restore", file]);
    ok(&r, "restore the documented file");
    assert_eq!(r.json()["summary"]["written"], 2, "{}", r.stdout);
    // The schema is no formality: a setting without restore, a newer
    // schema name and a device without its address are rejected.
    let mut doc = read_json(Path::new(file));
    doc["devices"][0]["settings"]["MaxVel"].as_object_mut().unwrap().remove("restore");
    assert!(common::schema("backup_document").iter_errors(&doc).next().is_some());
    let mut doc = read_json(Path::new(file));
    doc["schema"] = "backup".into();
    assert!(common::schema("backup_document").iter_errors(&doc).next().is_some());
    let mut doc = read_json(Path::new(file));
    doc["devices"][0].as_object_mut().unwrap().remove("module");
    assert!(common::schema("backup_document").iter_errors(&doc).next().is_some());
}

// ---- PA-CONTROL ----

/// The PA-CONTROL write frames (0700 system, 0800 axis parameter) sent, in
/// a serial `--log` (`(time) tx 01 02 30 37 30 30 3B ...`: SOH STX "0700;").
fn pac_writes(log: &Path) -> usize {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_once(" tx ").map(|(_, hex)| hex.to_uppercase()))
        .filter(|hex| hex.starts_with("01 02 30 37 30 30 3B") || hex.starts_with("01 02 30 38 30 30 3B"))
        .count()
}

#[test]
fn pac_backup_restore_round_trip_on_the_in_process_bench() {
    let dir = tmp();
    let saved = path(&dir, "pac.json");
    let r = run(&["--link", "sim", "--json", "backup", "--family", "pac", "--out", s(&saved)]);
    ok(&r, "backup");
    valid("document", &r.json());
    let mut doc = read_json(&saved);
    valid("backup_document", &doc);
    let devices = doc["devices"].as_array().unwrap();
    assert_eq!(devices.len(), 4, "the controller and its 3 axes");
    assert_eq!(devices[0]["identity"]["axes"], 3);
    assert!(devices[0].get("axis").is_none());
    assert_eq!(devices[2]["settings"]["traverse-speed"]["unit"], "AE/s");
    assert!(devices[2]["settings"].get("p-share").is_none(), "unused parameters are left out");
    device(&mut doc, "pac", "axis", 2)["settings"]["traverse-speed"]["value"] = 1500.0.into();
    device(&mut doc, "pac", "axis", 2)["settings"]["traverse-area-max"]["value"] = 9000.0.into();
    doc["devices"][0]["settings"]["language"]["value"] = 2.into();
    let changed = path(&dir, "changed.json");
    write_json(&changed, &doc);
    let log = path(&dir, "dry.log");
    let r = run(&["--link", "sim", "--log", s(&log), "restore", s(&changed), "--dry-run"]);
    ok(&r, "dry run");
    assert!(r.stdout.contains("3 differences on 2 devices"), "{}", r.stdout);
    assert!(lines(&log) > 0, "read");
    assert_eq!(pac_writes(&log), 0, "a dry run writes nothing");
    let log = path(&dir, "restore.log");
    let r = run(&["--link", "sim", "--json", "--log", s(&log), "restore", s(&changed)]);
    ok(&r, "restore");
    valid("restore_report", &r.json());
    assert_eq!(pac_writes(&log), 3, "one write per changed value");
    let rep = r.json();
    let ctrl: Vec<_> =
        rep["devices"][0]["results"].as_array().unwrap().iter().filter(|x| x["outcome"] == "written").collect();
    assert_eq!(ctrl.len(), 1);
    assert_eq!(
        outcomes(&rep, "pac", "axis", 2),
        [("traverse-area-max".into(), "written".into()), ("traverse-speed".into(), "written".into())],
        "the area before the speeds"
    );
    let r = run(&["--link", "sim", "--json", "diff", s(&saved)]);
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
}

#[test]
fn pac_values_outside_the_controllers_limits_and_another_controller_are_refused() {
    let dir = tmp();
    let saved = path(&dir, "pac.json");
    ok(&run(&["--link", "sim", "backup", "--family", "pac", "--out", s(&saved)]), "backup");
    let mut doc = read_json(&saved);
    device(&mut doc, "pac", "axis", 1)["settings"]["traverse-speed"]["value"] = 1e9.into();
    device(&mut doc, "pac", "axis", 1)["settings"]["direction-of-rotation"]["value"] = 2.0.into();
    device(&mut doc, "pac", "axis", 3)["settings"]["acceleration"]["value"] = 500.0.into();
    let file = path(&dir, "bad.json");
    write_json(&file, &doc);
    // direction-of-rotation 2 is wrong in the file alone: refused before the link opens.
    let log = path(&dir, "bad.log");
    let r = run(&["--link", "sim", "--log", s(&log), "restore", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("direction-of-rotation") && r.stderr.contains("nothing was sent"), "{}", r.stderr);
    assert_eq!(lines(&log), 0);
    device(&mut doc, "pac", "axis", 1)["settings"]["direction-of-rotation"]["value"] = 0.0.into();
    write_json(&file, &doc);
    let r = run(&["--link", "sim", "--log", s(&log), "restore", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("traverse-speed: 1000000000 AE/s is outside the controller's limits"), "{}", r.stderr);
    assert_eq!(pac_writes(&log), 0);
    let r = run(&["--link", "sim", "--json", "restore", s(&file), "--skip-invalid"]);
    ok(&r, "--skip-invalid");
    assert_eq!(outcomes(&r.json(), "pac", "axis", 1), [("traverse-speed".into(), "skipped".into())]);
    assert_eq!(outcomes(&r.json(), "pac", "axis", 3), [("acceleration".into(), "written".into())]);
    // A file of a controller with another number of axes.
    let mut doc = read_json(&saved);
    doc["devices"][0]["identity"]["axes"] = 2.into();
    write_json(&file, &doc);
    let r = run(&["--link", "sim", "restore", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("axes 2 in the file, 3 on the device"), "{}", r.stderr);
}

// ---- Cdios ----

/// The Cdios writes a command sent, from its `--trace` (requests decoded
/// by the table's name: `set_*`, `store_configuration`).
fn cdios_writes(stderr: &str) -> Vec<String> {
    stderr
        .lines()
        .filter(|l| l.starts_with("-> ") && (l.contains(" set_") || l.contains(" store_configuration")))
        .map(|l| l.split_whitespace().nth(1).unwrap_or("").to_string())
        .collect()
}

fn cdios_backup(dir: &tempfile::TempDir) -> PathBuf {
    let saved = path(dir, "cdios.json");
    ok(&run(&["--link", "sim", "backup", "--family", "cdios", "--out", s(&saved)]), "backup");
    saved
}

#[test]
fn cdios_backup_restore_round_trip_and_the_store_only_when_asked() {
    let dir = tmp();
    let saved = cdios_backup(&dir);
    let mut doc = read_json(&saved);
    valid("backup_document", &doc);
    let m0 = device(&mut doc, "cdios", "module", 0);
    assert_eq!(m0["node"], 1);
    assert!(m0["identity"]["type"].is_i64() && m0["identity"]["version"].is_i64());
    assert_eq!(m0["settings"]["speeds.maximum_speed"]["unit"], "rpm");
    for name in ["events.mask1", "events.speed_on_change", "outputs.digital", "traject1.speed3"] {
        assert!(m0["settings"].get(name).is_some(), "{name}");
    }
    m0["settings"]["speeds.maximum_speed"]["value"] = 6000.into();
    m0["settings"]["traject0.speed2"]["value"] = 100.into();
    m0["settings"]["events.mask3"]["value"] = 128.into();
    m0["settings"]["outputs.digital"]["value"] = 5.into();
    let changed = path(&dir, "changed.json");
    write_json(&changed, &doc);
    let r = run(&["--link", "sim", "--trace", "restore", s(&changed), "--dry-run", "--store"]);
    ok(&r, "dry run");
    assert!(r.stdout.contains("4 differences on 1 device"), "{}", r.stdout);
    assert_eq!(cdios_writes(&r.stderr), Vec::<String>::new(), "a dry run writes and stores nothing");
    let r = run(&["--link", "sim", "--json", "--trace", "restore", s(&changed)]);
    ok(&r, "restore");
    valid("restore_report", &r.json());
    assert_eq!(
        outcomes(&r.json(), "cdios", "module", 0),
        [
            ("speeds.maximum_speed".into(), "written".into()),
            ("traject0.speed2".into(), "written".into()),
            ("events.mask3".into(), "written".into()),
            ("outputs.digital".into(), "written".into()),
        ]
    );
    let writes = cdios_writes(&r.stderr);
    assert_eq!(writes.len(), 4, "one per selector, the event setup and the outputs: {writes:?}");
    assert!(!writes.iter().any(|w| w.starts_with("201#05")), "no store without --store: {writes:?}");
    assert!(r.json()["devices"][0].get("stored").is_none());
    // The outputs are written last.
    assert!(writes.last().unwrap().starts_with("201#10"), "{writes:?}");
    let r = run(&["--link", "sim", "--json", "--trace", "restore", s(&changed), "--store"]);
    ok(&r, "restore --store");
    let stores: Vec<String> = cdios_writes(&r.stderr).into_iter().filter(|w| w.starts_with("201#05")).collect();
    assert_eq!(stores.len(), 2, "one store per module of the file, after the writes: {stores:?}");
    assert_eq!(r.json()["devices"][0]["stored"], true);
    let r = run(&["--link", "sim", "--json", "diff", s(&saved)]);
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
}

#[test]
fn cdios_invalid_values_another_module_type_and_to() {
    let dir = tmp();
    let saved = cdios_backup(&dir);
    let mut doc = read_json(&saved);
    device(&mut doc, "cdios", "module", 0)["settings"]["speeds.maximum_speed"]["value"] = 99999.into();
    device(&mut doc, "cdios", "module", 0)["settings"]["events.speed_on_change"]["value"] = 2.into();
    device(&mut doc, "cdios", "module", 1)["settings"]["outputs.digital"]["value"] = 3.into();
    let file = path(&dir, "bad.json");
    write_json(&file, &doc);
    let r = run(&["--link", "sim", "--trace", "restore", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("speeds.maximum_speed") && r.stderr.contains("events.speed_on_change"), "{}", r.stderr);
    assert!(!r.stderr.contains("-> "), "refused before the link opened: {}", r.stderr);
    let r = run(&["--link", "sim", "--json", "--trace", "restore", s(&file), "--skip-invalid"]);
    ok(&r, "--skip-invalid");
    assert_eq!(outcomes(&r.json(), "cdios", "module", 1), [("outputs.digital".into(), "written".into())]);
    let skipped = outcomes(&r.json(), "cdios", "module", 0);
    assert!(skipped.iter().all(|(_, o)| o == "skipped") && skipped.len() == 2, "{skipped:?}");
    // Another module type at that address is refused; --to names the target.
    let mut doc = read_json(&saved);
    doc["devices"].as_array_mut().unwrap().truncate(1);
    doc["devices"][0]["identity"]["type"] = 0x45.into();
    doc["devices"][0]["settings"]["outputs.digital"]["value"] = 1.into();
    write_json(&file, &doc);
    let r = run(&["--link", "sim", "--trace", "restore", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("type 69 in the file, 68 on the device"), "{}", r.stderr);
    assert_eq!(cdios_writes(&r.stderr), Vec::<String>::new());
    let r = run(&["--link", "sim", "--json", "restore", s(&file), "--to", "1"]);
    ok(&r, "--to 1");
    assert_eq!(r.json()["devices"][0]["module"], 1);
    assert_eq!(outcomes(&r.json(), "cdios", "module", 1), [("outputs.digital".into(), "written".into())]);
}

#[test]
fn the_whole_simulated_bench_in_one_file() {
    let dir = tmp();
    let all = path(&dir, "bench.json");
    let r = run(&["--link", "sim", "--json", "backup", "--out", s(&all)]);
    ok(&r, "backup");
    let families: Vec<&str> = r.json()["devices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| match d["family"].as_str().unwrap() {
            "powercube" => "powercube",
            "pac" => "pac",
            _ => "cdios",
        })
        .collect();
    assert_eq!(families, ["powercube", "powercube", "powercube", "pac", "pac", "pac", "pac", "cdios", "cdios"]);
    valid("backup_document", &read_json(&all));
    // Without --out the document is the output, a document of the contract too.
    let r = run(&["--link", "sim", "--json", "backup"]);
    ok(&r, "backup to stdout");
    valid("backup_document", &r.json());
    valid("document", &r.json());
    let r = run(&["--link", "sim", "--json", "restore", s(&all)]);
    ok(&r, "restore");
    assert_eq!(r.json()["summary"]["written"], 0);
    assert_eq!(r.json()["differs"], false);
}

#[test]
fn cdios_and_pac_round_trip_on_served_simulators() {
    let sim = Sim::start(&[], 3);
    let dir = tmp();
    for (family, link, change) in [
        (
            "cdios",
            sim.link("cdios"),
            &[&["cdios-config", "-m", "1", "speeds.slope=20"][..], &["cdios-events", "-m", "0", "--mask", "ENABLED"]][..],
        ),
        (
            "pac",
            sim.link("pac"),
            &[&["pac-axis-param", "3", "acceleration", "2500"][..], &["pac-sys-param", "language", "2"]],
        ),
    ] {
        let saved = path(&dir, &format!("{family}.json"));
        ok(&run(&["--link", link, "backup", "--family", family, "--out", s(&saved)]), "backup");
        for args in change {
            let mut full = vec!["--link", link];
            full.extend_from_slice(args);
            ok(&run(&full), &format!("{args:?}"));
        }
        let r = run(&["--link", link, "--json", "diff", s(&saved)]);
        ok(&r, "diff");
        let n: usize =
            r.json()["devices"].as_array().unwrap().iter().map(|d| d["differences"].as_array().unwrap().len()).sum();
        assert_eq!(n, 2, "{family}: {}", r.stdout);
        let r = run(&["--link", link, "--json", "restore", s(&saved)]);
        ok(&r, "restore");
        assert_eq!(r.json()["summary"]["written"], 2, "{family}: {}", r.stdout);
        let r = run(&["--link", link, "--json", "diff", s(&saved)]);
        assert_eq!(r.json()["differs"], false, "{family}: {}", r.stdout);
    }
}

/// The differences of the device at `key` = `id` in a `diff --json`:
/// name, unit, the file's value and the live one.
fn differences(report: &Value, key: &str, id: u64) -> Vec<(String, String, Value, Value)> {
    report["devices"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d[key] == id)
        .flat_map(|d| {
            d["differences"].as_array().unwrap().iter().map(|x| {
                (
                    x["name"].as_str().unwrap().into(),
                    x["unit"].as_str().unwrap().into(),
                    x["left"].clone(),
                    x["right"].clone(),
                )
            })
        })
        .collect()
}

// Manual 16h: both analog outputs are set (selector 00h / 10h) and read back
// (80h / 90h); #1 only while the motor is not enabled.
#[test]
fn cdios_analog_outputs_round_trip_and_output_1_of_an_enabled_motor() {
    let sim = Sim::start(&[], 3);
    let link = sim.link("cdios");
    let dir = tmp();
    let saved = path(&dir, "cdios.json");
    let analog = |o: &str, mv: &str| run(&["--link", link, "cdios-analog", "-m", "0", "--output", o, "--set", mv]);
    ok(&analog("1", "-1500"), "set #1");
    ok(&run(&["--link", link, "backup", "--family", "cdios", "--out", s(&saved)]), "backup");
    let mut doc = read_json(&saved);
    valid("backup_document", &doc);
    let m0 = device(&mut doc, "cdios", "module", 0);
    assert_eq!(m0["settings"]["outputs.analog1"], serde_json::json!({"unit": "mV", "value": -1500, "restore": true}));
    assert_eq!(m0["settings"]["outputs.analog2"], serde_json::json!({"unit": "mV", "value": 0, "restore": true}));

    ok(&analog("1", "2000"), "change #1");
    ok(&analog("2", "2500"), "change #2");
    let r = run(&["--link", link, "--json", "diff", s(&saved)]);
    ok(&r, "diff");
    assert_eq!(
        differences(&r.json(), "module", 0),
        [
            ("outputs.analog1".into(), "mV".into(), (-1500).into(), 2000.into()),
            ("outputs.analog2".into(), "mV".into(), 0.into(), 2500.into()),
        ]
    );
    let r = run(&["--link", link, "--json", "--trace", "restore", s(&saved)]);
    ok(&r, "restore");
    valid("restore_report", &r.json());
    assert_eq!(
        outcomes(&r.json(), "cdios", "module", 0),
        [("outputs.analog1".into(), "written".into()), ("outputs.analog2".into(), "written".into())]
    );
    // -1500 mV = FA24h, little-endian; each write is read back.
    assert_eq!(cdios_writes(&r.stderr), ["201#16000024FA000000", "201#1600100000000000"]);
    assert!(r.stderr.contains("-> 201#1600800000000000") && r.stderr.contains("-> 201#1600900000000000"));
    let r = run(&["--link", link, "--json", "diff", s(&saved)]);
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);

    // A value outside -10000..10000 mV is refused before the link opens.
    let mut doc = read_json(&saved);
    device(&mut doc, "cdios", "module", 0)["settings"]["outputs.analog2"]["value"] = 10001.into();
    let bad = path(&dir, "bad.json");
    write_json(&bad, &doc);
    let r = run(&["--link", link, "--trace", "restore", s(&bad)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("outputs.analog2") && !r.stderr.contains("-> "), "{}", r.stderr);

    // Enabled, the motor drives #1: a backup keeps it for information only,
    // and a restore that would change it is refused before any write.
    ok(&run(&["--link", link, "cdios-enable", "-m", "0"]), "enable");
    let enabled = path(&dir, "enabled.json");
    ok(&run(&["--link", link, "backup", "--family", "cdios", "--out", s(&enabled)]), "backup enabled");
    let mut doc = read_json(&enabled);
    assert_eq!(device(&mut doc, "cdios", "module", 0)["settings"]["outputs.analog1"]["restore"], false);
    assert_eq!(device(&mut doc, "cdios", "module", 1)["settings"]["outputs.analog1"]["restore"], true);
    let r = run(&["--link", link, "--trace", "restore", s(&saved)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("outputs.analog1: the motor is enabled"), "{}", r.stderr);
    assert_eq!(cdios_writes(&r.stderr), Vec::<String>::new());
    let r = run(&["--link", link, "--json", "restore", s(&saved), "--skip-invalid"]);
    ok(&r, "--skip-invalid");
    assert_eq!(outcomes(&r.json(), "cdios", "module", 0), [("outputs.analog1".into(), "skipped".into())]);
}

#[test]
fn a_moving_module_stops_the_restore_before_any_write() {
    let sim = Sim::start(&[], 3);
    let link = sim.link("powercube");
    let dir = tmp();
    let saved = path(&dir, "m3-5.json");
    ok(&run(&["--link", link, "backup", "-m", "3,5", "--out", s(&saved)]), "backup");
    let mut doc = read_json(&saved);
    for d in doc["devices"].as_array_mut().unwrap() {
        d["settings"]["ActC0"]["value"] = 41.into();
    }
    write_json(&saved, &doc);
    // Module 5 moves; module 3, first in the file, gets no write either.
    ok(&run(&["--link", link, "move-vel", "-m", "5", "0.05"]), "move-vel");
    let log = path(&dir, "moving.log");
    let r = run(&["--link", link, "--log", s(&log), "restore", s(&saved)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("module 5 is moving") && r.stderr.contains("nothing was written"), "{}", r.stderr);
    assert_eq!(cube_writes(&log), Vec::<String>::new());
    ok(&run(&["--link", link, "halt", "-m", "5"]), "halt");
    let r = run(&["--link", link, "--json", "restore", s(&saved)]);
    ok(&r, "restore at rest");
    for m in [3, 5] {
        assert_eq!(outcomes(&r.json(), "powercube", "module", m), [("ActC0".into(), "written".into())]);
    }
}

/// PowerCube answers (ids 0x0A0..=0x0BF) in a candump `--log` before the
/// first SetExtended request.
fn answers_before_first_write(log: &Path) -> usize {
    let text = std::fs::read_to_string(log).unwrap();
    let frames: Vec<(u32, String)> = text
        .lines()
        .filter_map(|l| {
            l.split_whitespace()
                .last()?
                .split_once('#')
                .map(|(i, d)| (u32::from_str_radix(i, 16).unwrap(), d.to_string()))
        })
        .collect();
    let first = frames.iter().position(|(id, d)| (0x0E0..=0x0FF).contains(id) && d.starts_with("08")).unwrap();
    frames[..first].iter().filter(|(id, _)| (0x0A0..=0x0BF).contains(id)).count()
}

#[test]
fn a_write_without_its_answer_is_failed_the_others_go_on_and_the_exit_code_is_the_failures() {
    let dir = tmp();
    let file = path(&dir, "m3.json");
    // The same restore on a healthy bench says which answer the first write gets.
    let healthy = Sim::start(&[], 3);
    ok(&run(&["--link", healthy.link("powercube"), "backup", "-m", "3", "--out", s(&file)]), "backup");
    let mut doc = read_json(&file);
    doc["devices"][0]["settings"]["ActC0"]["value"] = 44.into();
    doc["devices"][0]["settings"]["ActDamp"]["value"] = 5.into();
    write_json(&file, &doc);
    let log = path(&dir, "healthy.log");
    ok(&run(&["--link", healthy.link("powercube"), "--log", s(&log), "restore", s(&file)]), "healthy restore");
    let skip = answers_before_first_write(&log);
    // Now that answer is lost.
    let faulty = Sim::start(&["--fault", &format!("drop=1,skip={skip},count=1")], 3);
    let r = run(&["--link", faulty.link("powercube"), "--json", "restore", s(&file)]);
    assert_eq!(r.code, 4, "the first failure's class: {}", r.stderr);
    assert!(r.stdout.is_empty(), "nothing on stdout on a failure: {}", r.stdout);
    let err: Value = serde_json::from_str(&r.stderr).unwrap();
    valid("error_document", &err);
    assert!(err["error"]["message"].as_str().unwrap().contains("ActC0"), "{}", r.stderr);
    // What was written is reported with the error.
    let report = &err["error"]["report"];
    valid("restore_report", report);
    assert_eq!(
        outcomes(report, "powercube", "module", 3),
        [("ActC0".into(), "failed".into()), ("ActDamp".into(), "written".into())],
        "a write is never sent twice; the next value still goes"
    );
    assert_eq!(report["summary"]["failed"], 1);
}

#[test]
fn a_backup_piped_into_diff_on_stdin() {
    use std::io::Write;
    use std::process::Stdio;
    let saved = run(&["--link", "sim", "backup", "-m", "17"]);
    ok(&saved, "backup");
    let mut child = common::bin()
        .args(["--link", "sim", "--json", "diff", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    child.stdin.take().unwrap().write_all(saved.stdout.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["left"], "-");
    assert_eq!(v["differs"], false, "{v}");
}

// ---- A restore that stops on the way (issue 22, item 6) ----

/// The six settings changed in each PowerCube module of a backup of the
/// served modules 3, 5 and 17: 18 values to write.
const CHANGED: [&str; 6] = ["MaxVel", "MaxAcc", "ActC0", "ActDamp", "ActA0", "ActSyncTime"];

/// A backup of the served modules with [`CHANGED`] changed, and the live values.
fn eighteen_changes(sim: &Sim, dir: &tempfile::TempDir) -> (PathBuf, Value) {
    let saved = path(dir, "saved.json");
    let link = sim.link("powercube");
    ok(&run(&["--link", link, "backup", "--family", "powercube", "--out", s(&saved)]), "backup");
    let live = read_json(&saved);
    let mut doc = live.clone();
    for m in [3, 5, 17] {
        let d = device(&mut doc, "powercube", "module", m);
        for name in CHANGED {
            let v = &mut d["settings"][name]["value"];
            *v = match name {
                "MaxVel" | "MaxAcc" => (v.as_f64().unwrap() * 0.5).into(),
                _ => (v.as_i64().unwrap() + 1).into(),
            };
        }
    }
    let file = path(dir, "changed.json");
    write_json(&file, &doc);
    (file, live)
}

/// The value each module holds now, read by another process.
fn held(link: &str, m: u64, name: &str) -> Value {
    let r = run(&["--link", link, "--json", "get-param", "-m", &m.to_string(), name]);
    ok(&r, "get-param");
    r.json()["params"][name]["value"].clone()
}

/// Starts `args` with --trace and, once a sent frame's trace line contains
/// `trigger`, calls `then`; the run's end, bounded.
fn when_sent(args: &[&str], trigger: &str, then: impl FnOnce(u32)) -> common::Ended {
    use std::io::{BufRead, BufReader};
    let mut child = common::bin()
        .arg("--trace")
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap()).lines();
    let mut seen = String::new();
    loop {
        let line = err.next().unwrap_or_else(|| panic!("ended before {trigger}:\n{seen}")).unwrap();
        seen.push_str(&line);
        seen.push('\n');
        if line.starts_with("-> ") && line.contains(trigger) {
            break;
        }
    }
    then(child.id());
    let rest = std::thread::spawn(move || err.map_while(Result::ok).map(|l| l + "\n").collect::<String>());
    let mut ended = common::wait_bounded(child, 30, args);
    ended.stderr = seen + &rest.join().unwrap() + &ended.stderr;
    ended
}

/// Each value's outcome in the report of one module.
fn module_outcomes(report: &Value, m: u64) -> Vec<(String, String)> {
    outcomes(report, "powercube", "module", m)
}

// SIGTERM (an emergency halt from another terminal) right after the first
// write to module 5: the restore ends after the value being written, with
// exit 143 and the report of every value: module 3 written, module 5 in
// part, module 17 not written, human and --json (error.report); the
// modules hold what the report says.
#[test]
fn a_signal_during_a_restore_reports_what_was_written_and_what_was_not() {
    for json in [true, false] {
        // Each answer 40 ms late: the 18 writes and their read-backs take
        // well over a second, so the signal lands before module 17.
        let sim = Sim::start(&["--fault", "delay=40ms"], 3);
        let dir = tmp();
        let (file, live) = eighteen_changes(&sim, &dir);
        let link = sim.link("powercube");
        let mut args = vec!["--link", link, "--timeout", "500", "restore", s(&file)];
        if json {
            args.insert(0, "--json");
        }
        // 0E5#0848: the SetExtended of MaxVel, the first write to module 5.
        let ended = when_sent(&args, "0E5#0848", |pid| unsafe {
            libc::kill(pid as i32, libc::SIGTERM);
        });
        assert_eq!(ended.code, 143, "{}", ended.stderr);
        let not_written = || CHANGED.map(|n| (n.to_string(), "not_written".to_string()));
        if json {
            assert_eq!(ended.stdout, "", "stdout stays empty on a failure");
            let err: Value =
                ended.stderr.lines().rfind(|l| l.starts_with('{')).map(|l| serde_json::from_str(l).unwrap()).unwrap();
            valid("error", &err["error"]);
            assert_eq!(err["error"]["kind"], "interrupted", "{err}");
            let report = &err["error"]["report"];
            valid("restore_report", report);
            let three = module_outcomes(report, 3);
            assert_eq!(three.len(), 6, "{three:?}");
            assert!(three.iter().all(|(_, o)| o == "written"), "{three:?}");
            let five = module_outcomes(report, 5);
            assert_eq!(five.iter().find(|(n, _)| n == "MaxVel").unwrap().1, "written", "{five:?}");
            assert!(five.iter().any(|(_, o)| o == "not_written"), "{five:?}");
            let mut seventeen = module_outcomes(report, 17);
            seventeen.sort();
            let mut want = not_written().to_vec();
            want.sort();
            assert_eq!(seventeen, want);
            assert_eq!(
                report["summary"]["not_written"].as_u64().unwrap(),
                6 + five.iter().filter(|(_, o)| o == "not_written").count() as u64
            );
        } else {
            for name in CHANGED {
                let line = format!("powercube module 17: {name} = ");
                let said = ended
                    .stdout
                    .lines()
                    .find(|l| l.starts_with(&line))
                    .unwrap_or_else(|| panic!("{line}: {}", ended.stdout));
                assert!(said.ends_with(": not written (the restore stopped on SIGTERM)"), "{said}");
            }
            assert!(ended.stdout.contains("powercube module 3: ActSyncTime = 1: written (was 0)"), "{}", ended.stdout);
            assert!(ended.stdout.contains(" not written\n"), "the counts: {}", ended.stdout);
            assert!(
                ended.stderr.ends_with("axisctl: interrupted: the restore stopped on SIGTERM\n"),
                "{}",
                ended.stderr
            );
        }
        let mut doc = live.clone();
        let before = device(&mut doc, "powercube", "module", 17)["settings"]["MaxVel"]["value"].clone();
        assert_eq!(held(link, 17, "MaxVel"), before, "module 17 was not written");
        assert_ne!(held(link, 3, "MaxVel"), device(&mut doc, "powercube", "module", 3)["settings"]["MaxVel"]["value"]);
    }
}

// The link lost after the first write to module 5: the restore says what
// it wrote before, what failed and what it did not reach (exit 3), and the
// --json error carries the report.
#[test]
fn a_link_lost_during_a_restore_reports_what_was_written_and_what_was_not() {
    let mut sim = Sim::start(&["--fault", "delay=40ms"], 3);
    let dir = tmp();
    let (file, _) = eighteen_changes(&sim, &dir);
    let link = sim.link("powercube").to_string();
    let args = ["--json", "--link", &link, "--timeout", "500", "restore", s(&file)];
    let ended = when_sent(&args, "0E5#0848", |_| sim.unplug());
    assert_eq!(ended.code, 3, "{}", ended.stderr);
    let err: Value =
        ended.stderr.lines().rfind(|l| l.starts_with('{')).map(|l| serde_json::from_str(l).unwrap()).unwrap();
    valid("error", &err["error"]);
    assert_eq!(err["error"]["kind"], "link", "{err}");
    let report = &err["error"]["report"];
    valid("restore_report", report);
    assert!(module_outcomes(report, 3).iter().all(|(_, o)| o == "written"));
    let five = module_outcomes(report, 5);
    assert!(five.iter().all(|(_, o)| o == "failed" || o == "not_written" || o == "written"), "{five:?}");
    let seventeen = module_outcomes(report, 17);
    assert_eq!(seventeen.len(), 6, "{seventeen:?}");
    assert!(seventeen.iter().all(|(_, o)| o == "not_written"), "{seventeen:?}");
}

// Issue 22, item 9: a restore writes nothing to a Cdios module whose motor
// runs, and says so value by value (the report goes with the error), nor
// to a PA-CONTROL outside home position. The traces show no write.
#[test]
fn a_restore_to_a_running_cdios_motor_or_a_pac_outside_home_position_writes_nothing() {
    let sim = Sim::start(&[], 3);
    let dir = tmp();
    let (cdios, pac) = (sim.link("cdios"), sim.link("pac"));
    let saved = path(&dir, "cdios.json");
    ok(&run(&["--link", cdios, "backup", "--family", "cdios", "--out", s(&saved)]), "backup");
    let mut doc = read_json(&saved);
    device(&mut doc, "cdios", "module", 0)["settings"]["speeds.maximum_speed"]["value"] = 6000.into();
    let changed = path(&dir, "cdios-changed.json");
    write_json(&changed, &doc);
    ok(&run(&["--link", cdios, "cdios-enable", "-m", "0"]), "enable");
    ok(&run(&["--link", cdios, "cdios-start", "-m", "0", "--option", "to-speed", "--speed", "1200"]), "start");
    // --skip-invalid: analog output #1 of an enabled motor is a problem of its own.
    let r = run(&["--link", cdios, "--json", "--trace", "restore", s(&changed), "--skip-invalid"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert_eq!(cdios_writes(&r.stderr), Vec::<String>::new(), "nothing written to a running motor");
    let err: Value = serde_json::from_str(r.stderr.lines().find(|l| l.starts_with('{')).unwrap()).unwrap();
    valid("error", &err["error"]);
    assert!(err["error"]["message"].as_str().unwrap().contains("module 0 reports RUNNING_FORWARD"), "{err}");
    let report = &err["error"]["report"];
    valid("restore_report", report);
    assert_eq!(
        outcomes(report, "cdios", "module", 0),
        [("outputs.analog1".into(), "skipped".into()), ("speeds.maximum_speed".into(), "not_written".into())]
    );
    assert_eq!(report["summary"]["written"], 0);
    ok(&run(&["--link", cdios, "cdios-stop", "-m", "0", "--option", "fast"]), "stop");

    let saved = path(&dir, "pac.json");
    ok(&run(&["--link", pac, "backup", "--family", "pac", "--out", s(&saved)]), "backup");
    let mut doc = read_json(&saved);
    device(&mut doc, "pac", "axis", 2)["settings"]["traverse-speed"]["value"] = 1500.0.into();
    let changed = path(&dir, "pac-changed.json");
    write_json(&changed, &doc);
    ok(&run(&["--link", pac, "pac-online"]), "online");
    let log = path(&dir, "pac.log");
    let r = run(&["--link", pac, "--log", s(&log), "restore", s(&changed)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("in home position only"), "{}", r.stderr);
    assert!(r.stderr.contains("nothing was written"), "{}", r.stderr);
    assert_eq!(pac_writes(&log), 0, "no parameter written outside home position");
    ok(&run(&["--link", pac, "pac-offline"]), "offline");
    ok(&run(&["--link", pac, "restore", s(&changed)]), "in home position it writes");
}

/// `restore --to` takes an address of the file's family, checked against
/// the registry's id range before the link opens: nothing is sent.
#[test]
fn restore_to_an_address_outside_the_familys_range_is_refused_and_sends_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let text = |p: &std::path::Path| p.to_str().unwrap().to_string();
    for (family, save, to, said) in [
        ("powercube", ["-m", "3"], "0", "--to 0: a PowerCube address is a module id"),
        ("cdios", ["--node", "1"], "16", "--to 16: a Cdios address is a module id"),
    ] {
        let file = dir.path().join(format!("{family}.json"));
        let r = common::run(&["--link", "sim", "backup", "--family", family, save[0], save[1], "--out", &text(&file)]);
        assert_eq!(r.code, 0, "{family} backup: {}", r.stderr);
        // --to needs a file of one device.
        let mut doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        doc["devices"].as_array_mut().unwrap().truncate(1);
        std::fs::write(&file, doc.to_string()).unwrap();
        let log = dir.path().join(format!("{family}.log"));
        let r = common::run(&["--link", "sim", "--log", &text(&log), "restore", &text(&file), "--to", to]);
        assert_eq!(r.code, 2, "{family}: {}", r.stderr);
        assert!(r.stderr.contains(said), "{family}: {}", r.stderr);
        let logged = std::fs::read_to_string(&log).unwrap_or_default();
        assert!(logged.trim().is_empty(), "{family}: nothing sent, logged:\n{logged}");
    }
}
