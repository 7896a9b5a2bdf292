//! `-d/--device` on the whole-bench commands (`backup`, `diff`, `restore`,
//! ...): exactly the devices named, of any family and on any link of the
//! bench, by address or by the name a bench file gives. A device named that
//! the command cannot take is a usage error (exit 2) before anything is
//! sent; one that does not answer is named (exit 4).

use crate::common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::bench::{two_cube_links, SIM_BENCH};
use common::{run, Run, Sim};
use serde_json::Value;

// The simulated bench with names (docs/sim-bench.toml): shoulder =
// powercube:3, elbow = powercube:5, slide = pac:2, gripper = cdios:1/0.

fn ok(r: &Run, what: &str) {
    assert_eq!(r.code, 0, "{what}: stdout {}\nstderr {}", r.stdout, r.stderr);
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

/// A device of a backup, diff or restore document as `-d` writes it.
fn address(d: &Value) -> String {
    let family = d["family"].as_str().unwrap();
    match family {
        "powercube" => format!("powercube:{}", d["module"]),
        "cdios" => format!("cdios:{}/{}", d["node"], d["module"]),
        _ => match d.get("axis") {
            Some(a) => format!("pac:{a}"),
            None => "pac".into(),
        },
    }
}

fn addresses(doc: &Value) -> Vec<String> {
    doc["devices"].as_array().unwrap().iter().map(address).collect()
}

/// The PowerCube modules a candump `--log` has frames of (request ids
/// 0x0C0 + module, answers 0x0A0 + module).
fn cube_modules(log: &Path) -> BTreeSet<u32> {
    common::logged_frames(log)
        .into_iter()
        .filter_map(|(_, f)| u32::from_str_radix(f.split_once('#')?.0, 16).ok())
        .filter(|id| (0x0A0..=0x0DF).contains(id))
        .map(|id| id & 0x1F)
        .collect()
}

fn logged(log: &Path) -> String {
    std::fs::read_to_string(log).unwrap_or_default()
}

#[test]
fn backup_d_saves_exactly_the_devices_named_as_the_whole_backup_has_them() {
    let dir = tempfile::tempdir().unwrap();
    let (all, some, log) = (dir.path().join("all.json"), dir.path().join("some.json"), dir.path().join("frames.log"));
    ok(&run(&["--bench", SIM_BENCH, "backup", "--out", s(&all)]), "whole backup");
    let r = run(&[
        "--bench",
        SIM_BENCH,
        "--json",
        "--log",
        s(&log),
        "backup",
        "-d",
        "shoulder,pac:3,gripper,pac,powercube:3",
        "--out",
        s(&some),
    ]);
    ok(&r, "backup -d");
    let named = ["powercube:3", "pac:3", "cdios:1/0", "pac"];
    assert_eq!(addresses(&r.json()), named, "each once, in the order named: {}", r.stdout);
    let (all, some) = (read_json(&all), read_json(&some));
    assert_eq!(addresses(&some), named);
    // The same devices as the whole backup saves them, in the same shape.
    for d in some["devices"].as_array().unwrap() {
        let whole = all["devices"].as_array().unwrap().iter().find(|w| address(w) == address(d)).unwrap();
        assert_eq!(d, whole, "{}", address(d));
    }
    assert_eq!(some["schema"], all["schema"]);
    assert_eq!(cube_modules(&log), BTreeSet::from([3]), "no frame of another module: {}", logged(&log));
}

#[test]
fn backup_d_names_a_device_that_does_not_answer_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b.json");
    let r = run(&["--bench", SIM_BENCH, "backup", "-d", "shoulder,powercube:9,cdios:1/5,pac:7", "--out", s(&out)]);
    assert_eq!(r.code, 4, "{}{}", r.stdout, r.stderr);
    for absent in ["powercube:9 (on sim)", "cdios:1/5 (on sim)", "pac:7 (on sim)", "no backup was written"] {
        assert!(r.stderr.contains(absent), "{absent}: {}", r.stderr);
    }
    assert!(!r.stderr.contains("powercube:3"), "the one that answered is not missing: {}", r.stderr);
    assert!(!out.exists(), "no backup is written");
}

/// A backup of every device, then changes to three of them on a served
/// bench of two links: `diff -d` compares, and `restore -d` writes, the
/// devices named only, on whichever link each is.
#[test]
fn diff_and_restore_d_limit_to_the_devices_named_on_a_served_bench_of_two_links() {
    let sim = Sim::start(&[], 3);
    let (can, serial) = (sim.link("powercube").to_string(), sim.link("pac").to_string());
    let links = ["--link", &can, "--link", &serial];
    let with = |args: &[&str]| {
        let mut all = links.to_vec();
        all.extend_from_slice(args);
        run(&all)
    };
    let dir = tempfile::tempdir().unwrap();
    let saved: PathBuf = dir.path().join("bench.json");
    let r = with(&["--json", "backup", "-d", "powercube:3,pac:3,cdios:1/1", "--out", s(&saved)]);
    ok(&r, "backup -d on two links");
    assert_eq!(addresses(&r.json()), ["powercube:3", "pac:3", "cdios:1/1"]);
    let doc = r.json();
    let on: Vec<&str> = doc["devices"].as_array().unwrap().iter().map(|d| d["link"].as_str().unwrap()).collect();
    assert_eq!(on, [can.as_str(), serial.as_str(), can.as_str()]);
    ok(&with(&["set-param", "-m", "3", "ActC0", "40"]), "set-param");
    ok(&with(&["pac-axis-param", "3", "acceleration", "2500"]), "pac-axis-param");
    ok(&with(&["cdios-config", "-m", "1", "speeds.slope=20"]), "cdios-config");
    let differing = |r: &Run| -> Vec<String> {
        r.json()["devices"].as_array().unwrap().iter().filter(|d| d["differs"] == true).map(address).collect()
    };
    let r = with(&["--json", "diff", s(&saved), "-d", "pac:3,powercube:3"]);
    ok(&r, "diff -d");
    assert_eq!(addresses(&r.json()), ["powercube:3", "pac:3"], "the file's order: {}", r.stdout);
    assert_eq!(differing(&r), ["powercube:3", "pac:3"]);
    // A dry run of two of them writes nothing: the three still differ after it.
    let r = with(&["--json", "restore", s(&saved), "-d", "pac:3,cdios:1/1", "--dry-run"]);
    ok(&r, "restore -d --dry-run");
    assert_eq!((r.json()["summary"]["written"].as_u64(), r.json()["dry_run"].as_bool()), (Some(0), Some(true)));
    assert_eq!(addresses(&r.json()), ["pac:3", "cdios:1/1"]);
    assert_eq!(differing(&with(&["--json", "diff", s(&saved)])), ["powercube:3", "pac:3", "cdios:1/1"]);
    let r = with(&["--json", "restore", s(&saved), "-d", "pac:3,cdios:1/1"]);
    ok(&r, "restore -d");
    assert_eq!(r.json()["summary"]["written"], 2, "{}", r.stdout);
    let r = with(&["--json", "diff", s(&saved)]);
    assert_eq!(differing(&r), ["powercube:3"], "the module not named is left as it was: {}", r.stdout);
}

/// Every refusal of `-d` by backup, diff and restore is exit 2 with the
/// reason, and nothing goes out: the log stays empty.
#[test]
fn a_device_backup_diff_or_restore_cannot_take_is_refused_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let (file, log) = (dir.path().join("two.json"), dir.path().join("frames.log"));
    ok(&run(&["--bench", SIM_BENCH, "backup", "-d", "shoulder,slide", "--out", s(&file)]), "backup");
    let file = s(&file);
    for (args, why) in [
        (&["backup", "-d", "wrist"][..], "\"wrist\" is not a device of the bench"),
        (&["backup", "-d", "shoulder", "-m", "3"], "cannot be used with"),
        (&["backup", "-d", "shoulder", "--family", "pac"], "cannot be used with"),
        (&["backup", "-d", "powercube:32"], "module id 1 to 31"),
        (&["diff", file, "-d", "elbow"], "elbow (powercube:5) is not a device of"),
        (&["diff", file, "-d", "cdios:1/0"], "cdios:1/0 is not a device of"),
        (&["restore", file, "-d", "slide,pac:1", "--dry-run"], "pac:1 is not a device of"),
        (&["restore", file, "-d", "shoulder,gripper"], "gripper (cdios:1/0) is not a device of"),
    ] {
        let mut all = vec!["--bench", SIM_BENCH, "--log", s(&log)];
        all.extend(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(why), "{args:?}: {}", r.stderr);
    }
    // The one --link of old carries the CAN families only.
    let r = run(&["--link", "slcan:/dev/axisctl-no-such-tty", "backup", "-d", "pac:2"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    assert!(r.stderr.contains("no link of the bench carries the PA-CONTROL"), "{}", r.stderr);
    assert_eq!(logged(&log), "", "nothing is sent");
}

/// `restore -d` picks one device of a file of several, which `--to` then
/// writes to another address.
#[test]
fn restore_d_picks_the_one_device_to_writes() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("all.json");
    ok(&run(&["--link", "sim", "backup", "--family", "powercube", "--out", s(&file)]), "backup");
    let r = run(&["--link", "sim", "restore", s(&file), "--to", "9", "--dry-run"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    let mut doc = read_json(&file);
    doc["devices"][0]["settings"]["ActC0"]["value"] = 40.into();
    write_json(&file, &doc);
    let r = run(&["--link", "sim", "--json", "restore", s(&file), "-d", "powercube:3", "--to", "5", "--dry-run"]);
    ok(&r, "restore -d --to");
    assert_eq!(addresses(&r.json()), ["powercube:5"], "{}", r.stdout);
    assert_eq!(r.json()["differs"], true, "module 3's file against module 5: {}", r.stdout);
}

// ---- commission ----

fn planned(doc: &Value) -> Vec<&str> {
    doc["plan"]["device"].as_array().unwrap().iter().map(|d| d["address"].as_str().unwrap()).collect()
}

/// The devices a commissioning report has checks of, each once in order.
fn checked(report: &Path) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for c in read_json(report)["checks"].as_array().unwrap() {
        let d = c["device"].as_str().unwrap().to_string();
        if !out.contains(&d) {
            out.push(d);
        }
    }
    out
}

#[test]
fn commission_d_plans_and_runs_only_the_devices_named() {
    let _busy = common::heavy::slot();
    let r = run(&["--bench", SIM_BENCH, "--json", "commission", "--print-plan", "-d", "gripper,slide,shoulder"]);
    ok(&r, "print-plan -d");
    assert_eq!(planned(&r.json()), ["powercube:3", "pac:2", "cdios:1/0"], "{}", r.stdout);
    let dir = tempfile::tempdir().unwrap();
    let (out, log) = (dir.path().join("m3"), dir.path().join("frames.log"));
    let r = run(&[
        "--link",
        "sim",
        "--json",
        "--log",
        s(&log),
        "commission",
        "-d",
        "powercube:3",
        "--out",
        s(&out),
        "--yes",
    ]);
    let report = std::fs::read_to_string(out.join("report.json")).unwrap_or_default();
    assert_eq!(r.code, 0, "commission -d: {}\nreport: {report}", r.stderr);
    assert_eq!(checked(&out.join("report.json")), ["powercube:3"]);
    assert_eq!(addresses(&read_json(&out.join("backup.json"))), ["powercube:3"]);
    assert_eq!(cube_modules(&log), BTreeSet::from([3]), "no frame of another module");
}

/// With a plan file, `-d` runs the plan's entries of those devices; one the
/// plan does not have is refused before anything is sent.
#[test]
fn commission_d_takes_the_plans_devices_and_refuses_others_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let (plan, log) = (dir.path().join("plan.toml"), dir.path().join("frames.log"));
    let r = run(&["--bench", SIM_BENCH, "commission", "--print-plan", "-d", "shoulder,elbow"]);
    ok(&r, "print-plan");
    std::fs::write(&plan, &r.stdout).unwrap();
    let out = dir.path().join("dry");
    let r =
        run(&["--bench", SIM_BENCH, "commission", "--plan", s(&plan), "-d", "elbow", "--dry-run", "--out", s(&out)]);
    ok(&r, "commission --plan -d --dry-run");
    assert_eq!(checked(&out.join("report.json")), ["powercube:5"]);
    let out = dir.path().join("never");
    for (args, code, why) in [
        (&["--plan", s(&plan), "-d", "gripper"][..], 2, "cdios:1/0 is not a device of the plan"),
        (&["--plan", s(&plan), "-d", "wrist"], 2, "\"wrist\" is not a device of the bench"),
        (&["-d", "cdios:1/5,pac:7"], 4, "not found on the bench, so not planned: cdios:1/5, pac:7"),
    ] {
        let mut all = vec!["--bench", SIM_BENCH, "--log", s(&log), "commission", "--out", s(&out), "--yes"];
        all.extend(args);
        let r = run(&all);
        assert_eq!(r.code, code, "{args:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(why), "{args:?}: {}", r.stderr);
        assert!(!out.exists(), "{args:?}: no report");
        if code == 2 {
            assert_eq!(logged(&log), "", "{args:?}: nothing is sent");
        }
    }
}

/// A plan of devices on two links of a served bench, for the devices named.
#[test]
fn commission_d_plans_devices_on_two_served_links() {
    let sim = Sim::start(&[], 3);
    let (can, serial) = (sim.link("powercube"), sim.link("pac"));
    let r = run(&[
        "--link",
        can,
        "--link",
        serial,
        "--json",
        "commission",
        "--print-plan",
        "-d",
        "cdios:1/1,pac:3,powercube:17",
    ]);
    ok(&r, "print-plan -d on two links");
    assert_eq!(planned(&r.json()), ["powercube:17", "pac:3", "cdios:1/1"], "{}", r.stdout);
}

/// Each family runs on the link its devices named are on, beside the
/// links of the other families; one family's devices on two links are refused.
#[test]
fn commission_d_runs_each_family_on_the_link_of_its_devices() {
    let dir = tempfile::tempdir().unwrap();
    let file = two_cube_links(dir.path());
    let r = run(&["--bench", &file, "--json", "commission", "--print-plan", "-d", "arm,pac:1"]);
    ok(&r, "print-plan -d arm");
    assert_eq!(planned(&r.json()), ["powercube:3", "pac:1"]);
    // Without -d the PowerCube's first link is the missing port.
    let r = run(&["--bench", &file, "commission", "--print-plan"]);
    assert_eq!(r.code, 3, "{}{}", r.stdout, r.stderr);
    let r = run(&["--bench", &file, "commission", "--print-plan", "-d", "arm,far"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    assert!(
        r.stderr.contains("powercube:3 is on sim and powercube:5 on slcan:/dev/axisctl-no-such-tty"),
        "{}",
        r.stderr
    );
}

// ---- dashboard ----

/// The dashboard over a served bench of two links shows the devices named
/// and no other (src/commands/dashboard.rs has the in-process cases).
#[test]
fn dashboard_d_shows_the_devices_named_on_two_served_links() {
    let sim = Sim::start(&[], 3);
    let (can, serial) = (sim.link("powercube"), sim.link("pac"));
    let t = common::tmux::Tmux::start("device-bench", 120, 30, &[]);
    t.wait_for("READY$");
    let bin = env!("CARGO_BIN_EXE_axisctl");
    t.keys(&[&format!("{bin} --link {can} --link {serial} dashboard -d powercube:5,pac:2,cdios:1/1"), "Enter"]);
    t.wait_for("node 1 mod 1");
    t.keys(&["v"]);
    let screen = t.wait_for("Overview · 4 device(s)");
    for want in ["PowerCube 5", "PA-CONTROL", "PA axis 2", "Cdios 1/1"] {
        assert!(screen.contains(want), "{want:?} missing:\n{screen}");
    }
    for other in ["PowerCube 3", "PowerCube 17", "PA axis 1", "PA axis 3", "Cdios 1/0"] {
        assert!(!screen.contains(other), "{other:?} shown:\n{screen}");
    }
    t.keys(&["q"]);
}

// ---- monitor ----

/// The device a monitor line is of, as `-d` writes it.
fn frame_device(l: &Value) -> Option<String> {
    match l["family"].as_str()? {
        "powercube" => Some(format!("powercube:{}", l.get("module")?)),
        "cdios" => Some(format!("cdios:{}/{}", l.get("node")?, l.get("module")?)),
        _ => None,
    }
}

#[test]
fn monitor_d_shows_only_the_frames_of_the_devices_named() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bus.log");
    for args in [&["state", "-m", "3,5,17"][..], &["cdios-status", "-m", "0"], &["cdios-status", "-m", "1"]] {
        let mut all = vec!["--link", "sim", "--log", s(&log)];
        all.extend_from_slice(args);
        ok(&run(&all), &format!("{args:?}"));
    }
    let r = run(&["--json", "monitor", "--from-log", s(&log), "-d", "powercube:3,cdios:1/0"]);
    ok(&r, "monitor -d");
    let lines: Vec<Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let seen: BTreeSet<Option<String>> = lines.iter().map(frame_device).collect();
    assert_eq!(seen, BTreeSet::from([Some("powercube:3".into()), Some("cdios:1/0".into())]), "{}", r.stdout);
    // The bench file's names are the same devices.
    let by_name = run(&["--bench", SIM_BENCH, "--json", "monitor", "--from-log", s(&log), "-d", "shoulder,gripper"]);
    assert_eq!(by_name.stdout, r.stdout);
}

/// Live, on a bench of a CAN link and a serial line, the monitor listens to
/// the link of the devices named (without -d it takes one link only). The
/// test plays the CAN adapter on a pty (it never acknowledges commands, as
/// a CANable 1) and puts frames of modules 3 and 5 on its bus.
#[test]
fn monitor_d_listens_to_the_link_of_its_devices() {
    use serialport::SerialPort;
    use std::io::Write;
    use std::process::Stdio;
    use std::time::{Duration, Instant};
    let (mut adapter, host) = serialport::TTYPort::pair().expect("pty pair");
    let can = format!("slcan:{}", host.name().unwrap());
    let links = ["--link", &can, "--link", "serial:/dev/axisctl-no-such-tty"];
    let r = run(&[&links[..], &["monitor", "--count", "1"]].concat());
    assert_eq!(r.code, 2, "one link without -d: {}", r.stderr);
    let mut child = common::bin()
        .args(links)
        .args(["--json", "monitor", "-d", "powercube:3", "--count", "3"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(out).unwrap());
    let deadline = Instant::now() + Duration::from_secs(20);
    while child.try_wait().unwrap().is_none() && Instant::now() < deadline {
        adapter.write_all(b"t0A560A3C0000803F\rt0A360A3C0000803F\r").unwrap();
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let status = child.wait().unwrap();
    let text = reader.join().unwrap();
    assert!(status.success(), "{status}: {text}");
    let lines: Vec<Value> = text.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 3, "{text}");
    for l in &lines {
        assert_eq!((frame_device(l).as_deref(), l["link"].as_str()), (Some("powercube:3"), Some(can.as_str())), "{l}");
    }
}

#[test]
fn a_device_the_monitor_cannot_show_is_refused_before_listening() {
    let dir = tempfile::tempdir().unwrap();
    let file = two_cube_links(dir.path());
    for (args, why) in [
        (&["--bench", SIM_BENCH, "monitor", "-d", "slide"][..], "slide (pac:2) is a PA-CONTROL device"),
        (&["--bench", SIM_BENCH, "monitor", "--from-log", "-", "-d", "pac:2"], "pac:2 is a PA-CONTROL device"),
        (&["--bench", SIM_BENCH, "monitor", "-d", "wrist"], "\"wrist\" is not a device of the bench"),
        (&["--link", "sim", "monitor", "-d", "powercube:3", "-m", "3"], "cannot be used with"),
        (&["--bench", &file, "monitor", "-d", "arm,far"], "the monitor listens to one link"),
    ] {
        let r = run(args);
        assert_eq!(r.code, 2, "{args:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(why), "{args:?}: {}", r.stderr);
    }
}

// ---- scan ----

fn scanned(doc: &Value, key: &str) -> Vec<(String, String)> {
    doc[key]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| (d["address"].as_str().unwrap().to_string(), d["link"].as_str().unwrap().to_string()))
        .collect()
}

#[test]
fn scan_d_probes_only_the_devices_named_and_lists_the_silent_ones_missing() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("frames.log");
    let r = run(&["--bench", SIM_BENCH, "--json", "--log", s(&log), "scan", "-d", "shoulder,slide,cdios:1/1"]);
    ok(&r, "scan -d");
    let sim = |a: &str| (a.to_string(), "sim".to_string());
    assert_eq!(scanned(&r.json(), "devices"), [sim("powercube:3"), sim("pac:2"), sim("cdios:1/1")]);
    assert_eq!(r.json()["devices"][0]["name"], "shoulder");
    assert_eq!(scanned(&r.json(), "missing"), []);
    assert_eq!(common::schema_errors(&common::schema("scan_bench"), &r.json()), None);
    assert_eq!(cube_modules(&log), BTreeSet::from([3]), "no other module probed");
    let r = run(&["--bench", SIM_BENCH, "--json", "scan", "-d", "shoulder,powercube:9,cdios:4/0,pac:7"]);
    assert_eq!(r.code, 4, "{}{}", r.stdout, r.stderr);
    assert_eq!(scanned(&r.json(), "devices"), [sim("powercube:3")]);
    assert_eq!(scanned(&r.json(), "missing"), [sim("powercube:9"), sim("cdios:4/0"), sim("pac:7")]);
    assert!(r.stderr.contains("named but not answering: powercube:9 (on sim), cdios:4/0 (on sim), pac:7 (on sim)"));
    let r = run(&["--bench", SIM_BENCH, "--log", s(&log), "scan", "-d", "shoulder,wrist"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    let r = run(&["--link", "sim", "scan", "-d", "powercube:3", "-m", "3"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
}

#[test]
fn scan_d_finds_devices_on_two_served_links() {
    let sim = Sim::start(&[], 3);
    let (can, serial) = (sim.link("powercube"), sim.link("pac"));
    let r = run(&["--link", can, "--link", serial, "--json", "scan", "-d", "cdios:1/0,pac:1,powercube:17"]);
    ok(&r, "scan -d on two links");
    let on = |a: &str, l: &str| (a.to_string(), l.to_string());
    assert_eq!(scanned(&r.json(), "devices"), [on("cdios:1/0", can), on("pac:1", serial), on("powercube:17", can)]);
}

// ---- halt ----

/// `halt -d` resolves its devices as the other whole-bench commands do: a
/// family the one `--link` cannot carry is refused before any port opens
/// (the port here does not exist: opening it would be exit 3).
#[test]
fn halt_d_refuses_a_family_the_link_cannot_carry_before_opening() {
    let r = run(&["--link", "slcan:/dev/axisctl-no-such-tty", "halt", "-d", "powercube:3,pac:2"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    assert!(r.stderr.contains("no link of the bench carries the PA-CONTROL"), "{}", r.stderr);
}
