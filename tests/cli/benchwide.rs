//! Whole-bench `backup`, `diff` and `restore` through the real binary,
//! against `axisctl sim` served on ptys (PowerCube and Cdios share the slcan
//! pty, the PA-CONTROL has its own): one file holds every device of every
//! link; a device of the file that is not on the bench is reported, never
//! skipped. Every process runs under a deadline.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Stdio;

use common::{Run, Sim};
use serde_json::Value;

fn run(args: &[&str]) -> Run {
    let mut c = common::bin();
    c.args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
    common::wait_bounded(c.spawn().unwrap(), 120, args).run()
}

fn ok(r: &Run, what: &str) {
    assert_eq!(r.code, 0, "{what}: stdout {}\nstderr {}", r.stdout, r.stderr);
}

fn valid(def: &str, doc: &Value) {
    if let Some(e) = common::schema_errors(&common::schema(def), doc) {
        panic!("{def}: {e}\n{doc:#}");
    }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The served bench: (the slcan link of PowerCube and Cdios, the PA-CONTROL's serial link).
fn served() -> (Sim, String, String) {
    let sim = Sim::start(&[], 3);
    let (can, serial) = (sim.link("powercube").to_string(), sim.link("pac").to_string());
    assert_eq!(sim.link("cdios"), can, "one CAN pty");
    (sim, can, serial)
}

/// `--link A --link B ARGS...`, or `--bench FILE ARGS...`.
fn on(bench: &[&str], args: &[&str]) -> Run {
    run(&[bench, args].concat())
}

/// Each device of a backup or diff document: `family:address link`.
fn devices(doc: &Value) -> Vec<String> {
    doc["devices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| {
            let at: Vec<String> =
                ["node", "module", "axis"].iter().filter_map(|k| d.get(*k).map(|v| format!("{k} {v}"))).collect();
            format!("{} {} {}", d["family"].as_str().unwrap(), at.join(" "), d["link"].as_str().unwrap())
        })
        .collect()
}

/// Every device of the served bench, each on its own link.
fn whole_bench(can: &str, serial: &str) -> Vec<String> {
    let mut want: Vec<String> = [3, 5, 17].iter().map(|m| format!("powercube module {m} {can}")).collect();
    want.extend([0, 1].iter().map(|m| format!("cdios node 1 module {m} {can}")));
    want.push(format!("pac  {serial}"));
    want.extend([1, 2, 3].iter().map(|a| format!("pac axis {a} {serial}")));
    want
}

/// The writes in a `--log` (PowerCube SetExtended, PA-CONTROL 0700/0800
/// parameter writes) and in a `--trace` (Cdios `set_*`, the EEPROM store).
fn writes(log: &Path, trace: &str) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let mut out: Vec<String> = text
        .lines()
        .filter_map(|l| l.split_whitespace().last().map(|f| (l, f)))
        .filter(|(l, f)| {
            let (id, data) = f.split_once('#').unwrap_or(("", ""));
            let cube =
                u32::from_str_radix(id, 16).is_ok_and(|id| (0x0E0..=0x0FF).contains(&id)) && data.starts_with("08");
            let pac = l.split_once(" tx ").is_some_and(|(_, hex)| {
                let hex = hex.to_uppercase();
                hex.starts_with("01 02 30 37 30 30 3B") || hex.starts_with("01 02 30 38 30 30 3B")
            });
            cube || pac
        })
        .map(|(l, _)| l.to_string())
        .collect();
    out.extend(
        trace
            .lines()
            .filter(|l| l.starts_with("-> ") && (l.contains(" set_") || l.contains(" store_configuration")))
            .map(str::to_string),
    );
    out
}

/// One setting changed on a device of each family, each on its link.
fn change_one_per_family(can: &str, serial: &str) {
    for args in [
        &["--link", can, "set-param", "-m", "5", "MaxVel", "0.5"][..],
        &["--link", can, "cdios-config", "-m", "1", "speeds.slope=20"],
        &["--link", serial, "pac-axis-param", "3", "acceleration", "2500"],
    ] {
        ok(&run(args), &args.join(" "));
    }
}

/// The differences of a `diff --json`: `device setting`.
fn differences(doc: &Value) -> Vec<String> {
    let mut out = Vec::new();
    for (d, at) in doc["devices"].as_array().unwrap().iter().zip(devices(doc)) {
        for x in d["differences"].as_array().unwrap() {
            out.push(format!("{} {}", at.rsplit_once(' ').unwrap().0, x["name"].as_str().unwrap()));
        }
    }
    out
}

fn bench_round_trip(bench: &[&str], can: &str, serial: &str, dir: &Path) {
    let file = dir.join("b.json");
    let r = on(bench, &["--json", "backup", "--out", s(&file)]);
    ok(&r, "backup");
    assert_eq!(devices(&r.json()), whole_bench(can, serial), "{}", r.stdout);
    let saved: Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    valid("backup_document", &saved);
    assert_eq!(devices(&saved), whole_bench(can, serial));

    let r = on(bench, &["--json", "diff", s(&file)]);
    ok(&r, "diff");
    valid("diff_report", &r.json());
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
    assert_eq!(devices(&r.json()), whole_bench(can, serial));
    let r = on(bench, &["diff", s(&file)]);
    ok(&r, "diff");
    assert_eq!(r.stdout.trim(), "no differences (9 devices)");

    // A change on each family, each link: the diff names the three; a dry
    // run shows them and writes nothing; the restore writes them back.
    change_one_per_family(can, serial);
    let r = on(bench, &["--json", "diff", s(&file)]);
    ok(&r, "diff after the changes");
    assert_eq!(
        differences(&r.json()),
        ["powercube module 5 MaxVel", "cdios node 1 module 1 speeds.slope", "pac axis 3 acceleration"],
        "{}",
        r.stdout
    );
    let log = dir.join("dry.log");
    let _ = std::fs::remove_file(&log);
    let r = on(bench, &["--trace", "--log", s(&log), "restore", s(&file), "--dry-run"]);
    ok(&r, "restore --dry-run");
    assert!(r.stdout.contains("dry run: nothing was written"), "{}", r.stdout);
    assert_eq!(writes(&log, &r.stderr), Vec::<String>::new(), "a dry run sends no write");
    assert!(std::fs::read_to_string(&log).unwrap().contains(" tx "), "the dry run read the PA-CONTROL on its line");
    let r = on(bench, &["--json", "diff", s(&file)]);
    assert_eq!(differences(&r.json()).len(), 3, "{}", r.stdout);

    let log = dir.join("restore.log");
    let _ = std::fs::remove_file(&log);
    let r = on(bench, &["--trace", "--log", s(&log), "--json", "restore", s(&file)]);
    ok(&r, "restore");
    assert_eq!(r.json()["summary"]["written"], 3, "{}", r.stdout);
    assert_eq!(writes(&log, &r.stderr).len(), 3, "one write per change: {:#?}", writes(&log, &r.stderr));
    let r = on(bench, &["--json", "diff", s(&file)]);
    ok(&r, "diff after the restore");
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
}

/// `--link CAN --link SERIAL backup` saves every PowerCube module, every
/// Cdios module and the PA-CONTROL with its axes in one file; `diff` with
/// the same links finds no difference; `restore --dry-run` writes nothing;
/// the same with a bench file naming both links.
#[test]
fn one_backup_holds_every_device_of_every_link() {
    let (_sim, can, serial) = served();
    let dir = tempfile::tempdir().unwrap();
    bench_round_trip(&["--link", &can, "--link", &serial], &can, &serial, dir.path());
    let file = dir.path().join("bench.toml");
    std::fs::write(&file, format!("[[link]]\nspec = \"{can}\"\n[[link]]\nspec = \"{serial}\"\n")).unwrap();
    bench_round_trip(&["--bench", s(&file)], &can, &serial, dir.path());
}

/// One `--link` to the CAN adapter: the backup holds the Cdios node beside
/// the PowerCubes, read over the one open port (not "device busy" from our
/// own second open), and `--family powercube,cdios` says the same.
#[test]
fn a_can_link_backup_holds_the_cdios_node_on_the_same_adapter() {
    let (_sim, can, _serial) = served();
    let want: Vec<String> = whole_bench(&can, "-").into_iter().filter(|d| !d.starts_with("pac")).collect();
    let cdios: Vec<String> = want.iter().filter(|d| d.starts_with("cdios")).cloned().collect();
    for (family, wanted) in
        [(&[][..], &want), (&["--family", "powercube,cdios"], &want), (&["--family", "cdios"], &cdios)]
    {
        let r = run(&[&["--link", &can, "--json", "--trace", "backup"][..], family].concat());
        ok(&r, &format!("backup {family:?}"));
        assert_eq!(&devices(&r.json()), wanted, "{family:?}");
        assert!(r.stderr.contains("identify"), "the Cdios node was asked over the link: {}", r.stderr);
    }
}

fn write(dir: &Path, name: &str, doc: &Value) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(doc).unwrap()).unwrap();
    p
}

/// A device of the file that is not on the bench is reported: `diff`
/// compares the others and exits 4 (no answer) or 2 (no link of the bench
/// reaches its family), naming each; `restore` writes nothing.
#[test]
fn a_device_of_the_file_missing_from_the_bench_is_reported() {
    let (_sim, can, serial) = served();
    let dir = tempfile::tempdir().unwrap();
    let r = run(&["--link", &can, "--link", &serial, "backup"]);
    ok(&r, "backup");
    let mut doc = r.json();
    // Module 5 becomes module 9, which no simulator serves.
    let m5 = doc["devices"].as_array_mut().unwrap().iter_mut().find(|d| d["module"] == 5 && d["family"] == "powercube");
    m5.unwrap()["module"] = 9.into();
    let file = write(dir.path(), "nine.json", &doc);

    let r = run(&["--link", &can, "--link", &serial, "--json", "diff", s(&file)]);
    assert_eq!(r.code, 4, "{}{}", r.stdout, r.stderr);
    assert_eq!(r.stdout, "", "stdout stays empty on a failure");
    let err: Value = serde_json::from_str(&r.stderr).unwrap();
    let report = &err["error"]["report"];
    valid("diff_report", report);
    assert_eq!(report["missing"].as_array().unwrap().len(), 1, "{report}");
    assert_eq!(report["missing"][0]["module"], 9);
    assert_eq!(report["missing"][0]["link"], can.as_str());
    assert_eq!(report["devices"].as_array().unwrap().len(), 8, "the others were compared");
    assert_eq!(report["differs"], false);
    assert!(err["error"]["message"].as_str().unwrap().starts_with("1 device of "), "{err}");

    let r = run(&["--link", &can, "--link", &serial, "diff", s(&file)]);
    assert_eq!(r.code, 4);
    assert!(r.stdout.contains("no differences (8 devices)"), "{}", r.stdout);
    assert!(r.stdout.contains("powercube module 9 (on "), "{}", r.stdout);

    // The PA-CONTROL is on no link of a CAN-only bench: exit 2, and the
    // CAN devices are compared.
    let r = run(&["--link", &can, "--json", "diff", s(&file)]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    let err: Value = serde_json::from_str(&r.stderr).unwrap();
    assert_eq!(err["error"]["report"]["missing"].as_array().unwrap().len(), 5, "{err}");
    assert!(err["error"]["message"].as_str().unwrap().contains("no link of the bench carries the PA-CONTROL"));

    // A restore writes every device of its file or none.
    let (i, _) = doc["devices"].as_array().unwrap().iter().enumerate().find(|(_, d)| d["module"] == 3).unwrap();
    doc["devices"][i]["settings"]["MaxVel"]["value"] = 0.25.into();
    let file = write(dir.path(), "changed.json", &doc);
    for dry in [true, false] {
        let log = dir.path().join(format!("restore-{dry}.log"));
        let mut args = vec!["--link", &can, "--link", &serial, "--log", s(&log), "--trace", "restore", s(&file)];
        if dry {
            args.push("--dry-run");
        }
        let r = run(&args);
        assert_eq!(r.code, 4, "{}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains("powercube module 9 (on "), "{}", r.stderr);
        assert!(r.stderr.contains("nothing was written"), "{}", r.stderr);
        assert_eq!(writes(&log, &r.stderr), Vec::<String>::new());
    }
}

/// A device the bench file expects is never left out of a backup: one that
/// does not answer fails it with exit 4, and no file is written.
#[test]
fn a_backup_missing_an_expected_device_is_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let bench = dir.path().join("bench.toml");
    std::fs::write(
        &bench,
        "[[link]]\nspec = \"sim\"\ndevices = { wrist = \"powercube:9\", gripper = \"cdios:1/0\" }\n",
    )
    .unwrap();
    let out = dir.path().join("b.json");
    let r = run(&["--bench", s(&bench), "backup", "--out", s(&out)]);
    assert_eq!(r.code, 4, "{}{}", r.stdout, r.stderr);
    assert!(r.stderr.contains("expected but not answering: wrist (powercube module 9 on sim)"), "{}", r.stderr);
    assert!(!out.exists());
    std::fs::write(&bench, "[[link]]\nspec = \"sim\"\ndevices = { gripper = \"cdios:1/0\" }\n").unwrap();
    ok(&run(&["--bench", s(&bench), "backup", "--out", s(&out)]), "every expected device answers");
}

/// `backup --out -` writes the document to stdout, and `diff -` and
/// `restore -` read it from stdin.
#[test]
fn out_dash_is_stdout_and_dash_is_stdin() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let r = run(&["--link", "sim", "backup", "--out", "-"]);
    ok(&r, "backup --out -");
    valid("backup_document", &r.json());
    assert!(!dir.path().join("-").exists() && !Path::new("-").exists(), "no file named -");
    for args in [&["diff", "-"][..], &["restore", "-", "--dry-run"]] {
        let mut child = common::bin()
            .args([&["--link", "sim", "--json"][..], args].concat())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        child.stdin.take().unwrap().write_all(r.stdout.as_bytes()).unwrap();
        let done = common::wait_bounded(child, 60, args).run();
        ok(&done, &args.join(" "));
        assert_eq!(done.json()["differs"], false, "{}", done.stdout);
    }
}

/// On a bench of several links, a per-family document (and its error
/// object) names the link its family used, not every link joined; from a
/// bench file too, where no `--link` was given at all.
#[test]
fn a_family_document_names_its_own_link() {
    let (_sim, can, serial) = served();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bench.toml");
    std::fs::write(&file, format!("[[link]]\nspec = \"{can}\"\n[[link]]\nspec = \"{serial}\"\n")).unwrap();
    for bench in [&["--link", &can, "--link", &serial][..], &["--bench", s(&file)]] {
        for (args, link) in [
            (&["pac-state"][..], &serial),
            (&["pac-axis", "2"], &serial),
            (&["state", "-m", "3"], &can),
            (&["cdios-status", "-m", "0"], &can),
        ] {
            let r = on(bench, &[&["--json"][..], args].concat());
            ok(&r, &args.join(" "));
            assert_eq!(r.json()["link"], link.as_str(), "{args:?} {bench:?}: {}", r.stdout);
        }
        // Module 9 does not answer: the error object names the PowerCube's link.
        let r = on(bench, &["--json", "state", "-m", "9"]);
        assert_eq!(r.code, 4, "{}", r.stderr);
        let err: Value = serde_json::from_str(&r.stderr).unwrap();
        assert_eq!(err["error"]["link"], can.as_str(), "{err}");
    }
}

/// `record DEVICE.VALUE...` reads devices of different links and families
/// in one recording: each line one sample with one `t`, every device with
/// its own link, and the values follow the devices (a PowerCube turning
/// at constant speed is seen rising).
#[test]
fn one_recording_over_every_link() {
    let (_sim, can, serial) = served();
    ok(&run(&["--link", &can, "reset", "-m", "5"]), "reset");
    ok(&run(&["--link", &can, "move-vel", "-m", "5", "0.1"]), "move-vel");
    let r = run(&[
        "--link",
        &can,
        "--link",
        &serial,
        "--json",
        "record",
        "powercube:5.ActPos",
        "pac:2.position",
        "cdios:1/0.position",
        "powercube:5.ActVel",
        "--rate",
        "50",
        "--count",
        "5",
    ]);
    ok(&r, "record");
    ok(&run(&["--link", &can, "halt", "-m", "5"]), "halt");
    let lines: Vec<Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 5, "{}", r.stdout);
    let (mut last_t, mut last_pos) = (-1.0, f64::NEG_INFINITY);
    for (i, l) in lines.iter().enumerate() {
        valid("record_line", l);
        assert_eq!(l["seq"], i as u64);
        let t = l["t"].as_f64().unwrap();
        assert!(t >= last_t, "stamps never go back: {}", r.stdout);
        last_t = t;
        let envs: Vec<(String, String)> = l["devices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| (d["family"].as_str().unwrap().to_string(), d["link"].as_str().unwrap().to_string()))
            .collect();
        let want = [("powercube", &can), ("pac", &serial), ("cdios", &can)].map(|(f, l)| (f.to_string(), l.clone()));
        assert_eq!(envs, want, "one object per device, each on its link");
        let cube = &l["devices"][0]["values"];
        assert_eq!((cube["ActPos"]["unit"].as_str(), cube["ActVel"]["unit"].as_str()), (Some("rad"), Some("rad/s")));
        assert_eq!(l["devices"][1]["values"]["position"]["unit"], "AE");
        assert!(l["devices"][2]["values"]["position"].get("value").is_some(), "{l}");
        let pos = cube["ActPos"]["value"].as_f64().unwrap();
        assert!(pos > last_pos, "module 5 turns: {}", r.stdout);
        last_pos = pos;
    }
    // The rate is kept over the three links: 5 samples at 50 Hz span 80 ms at least.
    assert!(last_t >= 0.08 - 1e-6, "{}", r.stdout);
}

/// The bench form of `record` checks every name before a link opens: a bad
/// one exits 2 with nothing sent.
#[test]
fn a_bad_bench_recording_sends_nothing() {
    let (_sim, can, serial) = served();
    for (values, says) in [
        (&["pac.position"][..], "pac is the controller"),
        (&["powercube:3.ActPos", "ActVel"], "names no device"),
        (&["powercube:3.NoSuch"], "NoSuch"),
        (&["pac:2.ActPos"], "no value \"ActPos\" to record here"),
        (&["cdios:1/0.position", "powercube:99.ActPos"], "powercube:99"),
        (&["wrist.ActPos"], "\"wrist\" is not a device of the bench"),
    ] {
        let r = run(&[&["--link", &can, "--link", &serial, "--trace", "record", "--count", "1"][..], values].concat());
        assert_eq!(r.code, 2, "{values:?}: {}", r.stderr);
        assert!(r.stderr.contains(says), "{values:?}: {}", r.stderr);
        assert!(!r.stderr.lines().any(|l| l.starts_with("-> ")), "nothing sent: {}", r.stderr);
    }
    let r = run(&["--link", &can, "record", "powercube:3.ActPos", "--", "move-vel", "-m", "3", "0.1"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("nothing was sent"), "{}", r.stderr);
}

/// The help's bench-file example of `record` runs as written: the names of
/// docs/sim-bench.toml stand for their devices.
#[test]
fn the_documented_bench_recording_runs() {
    let args = "--bench docs/sim-bench.toml --json record shoulder.ActPos slide.position gripper.position --count 5";
    let help = run(&["record", "--help"]);
    assert!(help.stdout.contains(&format!("axisctl {args}")), "{}", help.stdout);
    let r = run(&args.split(' ').collect::<Vec<_>>());
    ok(&r, args);
    let lines: Vec<Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert_eq!(lines.len(), 5);
    for l in &lines {
        valid("record_line", l);
        let d = &l["devices"];
        assert_eq!((d[0]["module"].as_u64(), d[1]["axis"].as_u64()), (Some(3), Some(2)), "{l}");
        assert_eq!((d[2]["node"].as_u64(), d[2]["module"].as_u64()), (Some(1), Some(0)), "{l}");
    }
}

/// The dashboard started on a bench of two links (and from a bench file
/// naming them) shows every device of every link: the PowerCube modules
/// and the Cdios modules of the CAN adapter, the PA-CONTROL axes of the
/// serial line, each link in the status bar.
#[test]
fn the_dashboard_of_a_bench_shows_every_device_of_every_link() {
    let (_sim, can, serial) = served();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("bench.toml");
    std::fs::write(&file, format!("[[link]]\nspec = \"{can}\"\n[[link]]\nspec = \"{serial}\"\n")).unwrap();
    let bin = env!("CARGO_BIN_EXE_axisctl");
    // One terminal for both runs: a tmux server that just lost its last
    // session may refuse a new one.
    let t = common::tmux::Tmux::start("benchwide", 200, 40, &[]);
    t.wait_for("READY$");
    for (run, bench) in [format!("--link {can} --link {serial}"), format!("--bench {}", s(&file))].iter().enumerate() {
        // A generous timeout, as every test gives: a module found late on a loaded
        // machine must not be taken for absent by the start-up scan.
        t.keys(&[&format!("clear; {bin} --timeout 1000 {bench} dashboard; echo RUN{run}=$?"), "Enter"]);
        // Each link's devices are found by its own worker: wait until every one shows.
        let port = can.trim_start_matches("slcan:");
        let wants =
            ["module 3", "module 5", "module 17", "axis 1", "axis 3", "node 1 mod 0", "node 1 mod 1", &serial, port];
        t.wait_until(&format!("every device and link of {bench}"), |screen| wants.iter().all(|w| screen.contains(w)));
        t.keys(&["q"]);
        t.wait_for(&format!("RUN{run}=0"));
    }
}

/// Two links of a bench each with modules 3, 5 and 17 (the in-process
/// bench and a served one): six devices in one backup, each compared and
/// restored on its own link.
#[test]
fn the_same_module_ids_on_two_links_are_two_devices() {
    let (_sim, can, _serial) = served();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("two.json");
    let bench = ["--link", "sim", "--link", &can];
    let r = on(&bench, &["--json", "backup", "--family", "powercube", "--out", s(&file)]);
    ok(&r, "backup");
    let want: Vec<String> =
        ["sim", &can].iter().flat_map(|l| [3, 5, 17].map(|m| format!("powercube module {m} {l}"))).collect();
    assert_eq!(devices(&r.json()), want);
    let r = on(&bench, &["--json", "diff", s(&file)]);
    ok(&r, "diff");
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
    ok(&run(&["--link", &can, "set-param", "-m", "5", "MaxVel", "0.5"]), "set-param");
    let r = on(&bench, &["--json", "diff", s(&file)]);
    ok(&r, "diff");
    let changed: Vec<String> = r.json()["devices"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d["differs"] == true)
        .map(|d| format!("{} {}", d["module"], d["link"].as_str().unwrap()))
        .collect();
    assert_eq!(changed, [format!("5 {can}")], "{}", r.stdout);
    let r = on(&bench, &["--json", "restore", s(&file)]);
    ok(&r, "restore");
    assert_eq!(r.json()["summary"]["written"], 1, "{}", r.stdout);
    let doc = r.json();
    let written: Vec<&str> = doc["devices"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|d| d["results"].as_array().unwrap().iter().any(|x| x["outcome"] == "written"))
        .map(|d| d["link"].as_str().unwrap())
        .collect();
    assert_eq!(written, [can.as_str()], "written on the served link only");
    let r = on(&bench, &["--json", "diff", s(&file)]);
    assert_eq!(r.json()["differs"], false, "{}", r.stdout);
}
