//! `axisctl commission` through the binary on the simulated bench: the
//! report and its schema, failures the plan provokes, `--dry-run` and
//! Ctrl-C during a test move.

use crate::common;

use std::collections::BTreeSet;
use std::io::Read;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use common::{bin, run};
use serde_json::Value;

fn report_schema() -> jsonschema::Validator {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/schema/commission-report.schema.json")).unwrap();
    jsonschema::validator_for(&serde_json::from_str(&text).unwrap()).unwrap()
}

fn read_report(dir: &Path) -> Value {
    let text = std::fs::read_to_string(dir.join("report.json")).expect("report.json written");
    let report: Value = serde_json::from_str(&text).unwrap();
    if let Some(e) = common::schema_errors(&report_schema(), &report) {
        panic!("report.json breaks its schema:\n{e}");
    }
    report
}

fn checks(report: &Value) -> &Vec<Value> {
    report["checks"].as_array().unwrap()
}

fn check<'a>(report: &'a Value, device: &str, name: &str) -> &'a Value {
    checks(report)
        .iter()
        .find(|c| c["device"] == device && c["check"] == name)
        .unwrap_or_else(|| panic!("no check {name} of {device}"))
}

fn measured<'a>(c: &'a Value, name: &str) -> &'a Value {
    c["measured"].as_array().unwrap().iter().find(|m| m["name"] == name).unwrap_or_else(|| panic!("no {name} in {c}"))
}

fn with_status(report: &Value, status: &str) -> BTreeSet<String> {
    checks(report)
        .iter()
        .filter(|c| c["status"] == status)
        .map(|c| format!("{} {}", c["device"].as_str().unwrap(), c["check"].as_str().unwrap()))
        .collect()
}

/// The default plan of the simulated bench, as TOML to edit.
fn default_plan() -> toml::Table {
    let r = run(&["--link", "sim", "commission", "--print-plan"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    r.stdout.parse().expect("the printed plan is TOML")
}

fn device<'a>(plan: &'a mut toml::Table, at: &str) -> &'a mut toml::Table {
    plan["device"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .map(|d| d.as_table_mut().unwrap())
        .find(|d| d["address"].as_str() == Some(at))
        .unwrap()
}

/// The `commission --help` examples that commission the whole simulated
/// bench, run here as written (and left out of the run of every help
/// example in tests/cli/json_docs.rs: the run takes a minute).
pub const WHOLE_BENCH_EXAMPLES: [&str; 2] = [
    "axisctl --link sim commission --print-plan > plan.toml",
    "axisctl --link sim commission --plan plan.toml --out handover --yes",
];

#[test]
fn the_simulated_bench_passes_and_every_file_is_written() {
    let _busy = common::heavy::slot();
    let help = run(&["commission", "--help"]).stdout;
    for line in WHOLE_BENCH_EXAMPLES {
        assert!(help.lines().any(|l| l.trim() == line), "not an example of commission --help: {line}");
    }
    let dir = tempfile::tempdir().unwrap();
    let failed = common::pool::failing_lines(&WHOLE_BENCH_EXAMPLES.map(String::from), dir.path(), 180);
    assert!(failed.is_empty(), "{failed:?}");
    let out = dir.path().join("handover");
    let report = read_report(&out);
    assert_eq!((report["complete"].as_bool(), report["passed"].as_bool()), (Some(true), Some(true)));
    // Every device of every family of the bench, each with the checks its
    // family has (a 6168 has no reference drive).
    let moving = ["powercube:3", "powercube:5", "powercube:17", "pac:1", "pac:2", "pac:3", "cdios:1/0", "cdios:1/1"];
    for m in moving {
        let homes = !m.starts_with("cdios");
        for name in ["identity", "settings", "limits", "home", "move_forward", "move_back", "halt", "backup"] {
            if name == "home" && !homes {
                continue;
            }
            assert_eq!(check(&report, m, name)["status"], "pass", "{m} {name}");
        }
        for mv in ["move_forward", "move_back"] {
            let c = check(&report, m, mv);
            for fig in ["rise_time", "overshoot", "settling_time", "steady_state_error", "time_to_reach"] {
                assert!(measured(c, fig)["value"].is_number(), "{m} {mv} {fig}: {c}");
            }
            let csv = out.join(c["recording"].as_str().unwrap());
            let text = std::fs::read_to_string(&csv).unwrap();
            let header = match m.split(':').next() {
                Some("powercube") => "t [s],ActPos",
                Some("pac") => "t [s],position [AE],speed [AE/s],status,following_error [AE]",
                _ => "t [s],position [counts],setpoint [counts],speed [rpm],rpm_error [rpm]",
            };
            assert!(text.starts_with(header), "{}", csv.display());
            assert!(text.lines().count() > 20, "a recording of samples: {}", csv.display());
            // At most 2000 samples a second, though the in-process bus
            // answers at once (src/commission/powercube.rs MIN_SAMPLE_GAP).
            let t = times(&text);
            let rate = (t.len() - 1) as f64 / (t[t.len() - 1] - t[0]);
            assert!(rate <= 2050.0, "{}: {rate:.0} samples a second", csv.display());
        }
        // The ramp is a trapezoid: no overshoot, and it ends on its target.
        let fwd = check(&report, m, "move_forward");
        assert_eq!(measured(fwd, "overshoot")["value"], 0.0);
        let halt = measured(check(&report, m, "halt"), "time_to_standstill")["value"].as_f64().unwrap();
        assert!((0.0..=1.2).contains(&halt), "{m} halt {halt}");
        assert_eq!(check(&report, m, "backup")["file"], "backup.json");
    }
    // The PA-CONTROL records its following error; the controller itself
    // has its identity and backup.
    assert!(measured(check(&report, "pac:2", "move_forward"), "peak_following_error")["value"].is_number());
    assert_eq!(check(&report, "pac", "identity")["status"], "pass");
    assert_eq!(check(&report, "pac", "backup")["status"], "pass");
    // The simulated ramps are exact trapezoids: their figures in closed
    // form, within two sampling steps of the recording. A PowerCube plan
    // gives its speed and acceleration; a PA-CONTROL axis moves at its
    // traverse speed and acceleration (the plan's expected settings).
    for d in report["plan"]["device"].as_array().unwrap() {
        let mv = &d["move"];
        let at = d["address"].as_str().unwrap();
        if !mv.is_object() || at.starts_with("cdios") {
            continue;
        }
        let values = &d["settings"]["values"];
        let setting = |k: &str, name: &str| mv[k].as_f64().or_else(|| values[name]["value"].as_f64()).unwrap();
        let (dist, v, a) =
            (mv["distance"].as_f64().unwrap(), setting("vel", "traverse-speed"), setting("acc", "acceleration"));
        let total = if dist >= v * v / a { dist / v + v / a } else { 2.0 * (dist / a).sqrt() };
        // The time a ramp takes to cover (or to have left) `x` of its distance from an end.
        let from_end = |x: f64| if x <= v * v / (2.0 * a) { (2.0 * x / a).sqrt() } else { v / (2.0 * a) + x / v };
        let rise = total - 2.0 * from_end(0.1 * dist);
        let settle = total - from_end(0.02 * dist);
        for name in ["move_forward", "move_back"] {
            let c = check(&report, at, name);
            let tol = 2.0 * largest_gap(&out, c) + 1e-3;
            let got = |f: &str| measured(c, f)["value"].as_f64().unwrap();
            assert!((got("rise_time") - rise).abs() <= tol, "{at} {name}: rise {} vs {rise}", got("rise_time"));
            assert!(
                (got("settling_time") - settle).abs() <= tol,
                "{at} {name}: settling {} vs {settle}",
                got("settling_time")
            );
        }
    }
    // The identity measured is the module's own (serial 12328 + id).
    assert_eq!(measured(check(&report, "powercube:5", "identity"), "serial")["value"], 12333);
    let backup: Value = serde_json::from_str(&std::fs::read_to_string(out.join("backup.json")).unwrap()).unwrap();
    assert_eq!(backup["schema"], "axisctl-backup/1");
    // Three PowerCube modules, the PA-CONTROL and its three axes, two 6168s.
    assert_eq!(backup["devices"].as_array().unwrap().len(), 9);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(
        html.contains("PASSED") && html.matches("<svg").count() == 3 * moving.len(),
        "three plots per moving device"
    );
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.starts_with("# Commissioning report: PASSED"));
    // The plan written beside the report runs again as a plan.
    let again = std::fs::read_to_string(out.join("plan.toml")).unwrap();
    assert!(again.contains("address = \"powercube:17\""));
}

#[test]
fn a_serial_and_an_overshoot_band_the_plan_misses_fail_exactly_those_checks() {
    let _busy = common::heavy::slot();
    let dir = tempfile::tempdir().unwrap();
    let mut plan = default_plan();
    // The PowerCube modules: the other families' checks of this plan are
    // the_simulated_bench_passes_and_every_file_is_written's.
    plan["device"]
        .as_array_mut()
        .unwrap()
        .retain(|d| d["address"].as_str().is_some_and(|a| a.starts_with("powercube")));
    device(&mut plan, "powercube:5")["identity"]["serial"] = toml::Value::Integer(4711);
    let m17 = device(&mut plan, "powercube:17");
    m17["move"]["overshoot_percent"] = toml::Value::Table(toml::toml! { min = 1.0 max = 5.0 });
    // Shorter: module 3 keeps its read checks only, no halt tests.
    for at in ["powercube:3", "powercube:5", "powercube:17"] {
        device(&mut plan, at).remove("halt");
    }
    let m3 = device(&mut plan, "powercube:3");
    m3.remove("move");
    m3.remove("home");
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, toml::to_string(&plan).unwrap()).unwrap();
    let out = dir.path().join("r");
    let r = run(&[
        "--link",
        "sim",
        "commission",
        "--plan",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--yes",
    ]);
    assert_eq!(r.code, 5, "the device-fault code\n{}\n{}", r.stdout, r.stderr);
    let report = read_report(&out);
    assert_eq!(report["passed"], false);
    assert_eq!(
        with_status(&report, "fail"),
        BTreeSet::from([
            "powercube:5 identity".to_string(),
            "powercube:17 move_forward".to_string(),
            "powercube:17 move_back".to_string(),
        ])
    );
    let serial = measured(check(&report, "powercube:5", "identity"), "serial");
    assert_eq!(
        (serial["value"].as_u64(), serial["limit"].as_str(), serial["pass"].as_bool()),
        (Some(12333), Some("4711"), Some(false))
    );
    // Not the module ordered: it is not moved.
    assert_eq!(check(&report, "powercube:5", "home")["status"], "skipped");
    for mv in ["move_forward", "move_back"] {
        let o = measured(check(&report, "powercube:17", mv), "overshoot");
        assert_eq!(
            (o["value"].as_f64(), o["limit"].as_str(), o["pass"].as_bool()),
            (Some(0.0), Some("1 .. 5"), Some(false))
        );
        // Only the overshoot is out.
        let c = check(&report, "powercube:17", mv);
        let out: Vec<&str> = c["measured"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|m| m["pass"] == false)
            .map(|m| m["name"].as_str().unwrap())
            .collect();
        assert_eq!(out, ["overshoot"]);
    }
    assert!(r.stderr.contains("commissioning failed: powercube:5 identity, powercube:17 move_forward"), "{}", r.stderr);
}

/// PowerCube requests go to 0x0E0 + module; SetMotion is 0x0B, Home 0x01.
fn motion_frames(log: &Path) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_whitespace().nth(2))
        .filter(|f| {
            let (id, data) = f.split_once('#').unwrap_or(("", ""));
            let id = u32::from_str_radix(id, 16).unwrap_or(0);
            (0x0E1..=0x0FF).contains(&id) && (data.starts_with("0B") || data.starts_with("01"))
        })
        .map(str::to_string)
        .collect()
}

/// Every frame of a `--log` that moves a device or changes the mode it
/// moves in, of any family: PowerCube SetMotion and Home; a Cdios goto
/// (23h), start (24h, the enable too) or stop (25h) to a module of node 1
/// (0x201); a PA-CONTROL command line (the serial lines logged as hex) of
/// a mode change (0602, 0603) or an axis command 0A8x / 0A9x.
fn motions_of_any_family(log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let mut out = motion_frames(log);
    for line in text.lines() {
        let mut words = line.split_whitespace().skip(1);
        match words.next() {
            Some("tx") => {
                let bytes: Vec<u8> = words.filter_map(|w| u8::from_str_radix(w, 16).ok()).collect();
                let ascii = String::from_utf8_lossy(&bytes).into_owned();
                let code = ascii.trim_start_matches(['\x01', '\x02']).split(';').next().unwrap_or("").to_string();
                if code == "0602" || code == "0603" || code.starts_with("0A8") || code.starts_with("0A9") {
                    out.push(format!("PA-CONTROL {code}"));
                }
            }
            Some(_) => {
                let frame = line.split_whitespace().nth(2).unwrap_or("");
                if let Some(data) = frame.strip_prefix("201#") {
                    if data.starts_with("23") || data.starts_with("24") || data.starts_with("25") {
                        out.push(frame.to_string());
                    }
                }
            }
            None => {}
        }
    }
    out
}

#[test]
fn the_motion_reader_sees_the_motions_of_every_family() {
    // Guard of the dry-run test: the same reader finds each family's
    // motions in the log of a run that moves.
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    let plan = "[[device]]\naddress = \"pac:1\"\nbackup = false\nlimits = false\n\
                move = { distance = 100.0, window = [0.0, 10000.0] }\n\
                [[device]]\naddress = \"cdios:1/0\"\nbackup = false\n\
                move = { distance = 500.0, window = [-5000.0, 5000.0] }\n";
    std::fs::write(&file, plan).unwrap();
    let (out, log) = (dir.path().join("r"), dir.path().join("moved.log"));
    let args = ["--link", "sim", "--log", log.to_str().unwrap(), "commission", "--plan", file.to_str().unwrap()];
    let r = run(&[&args[..], &["--out", out.to_str().unwrap(), "--yes"]].concat());
    assert_eq!(r.code, 0, "{}", r.stderr);
    let seen = motions_of_any_family(&log);
    for want in
        ["PA-CONTROL 0603", "PA-CONTROL 0A83", "PA-CONTROL 0A94", "PA-CONTROL 0A81", "201#24", "201#23", "201#25"]
    {
        assert!(seen.iter().any(|s| s.starts_with(want)), "{want} in {seen:?}");
    }
}

#[test]
fn a_dry_run_sends_no_motion_frame_and_lists_the_motions() {
    let dir = tempfile::tempdir().unwrap();
    let (out, log) = (dir.path().join("r"), dir.path().join("dry.log"));
    let r = run(&[
        "--link",
        "sim",
        "--log",
        log.to_str().unwrap(),
        "commission",
        "--out",
        out.to_str().unwrap(),
        "--dry-run",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let frames = std::fs::read_to_string(&log).unwrap();
    assert!(frames.lines().count() > 50, "the reads went out");
    assert_eq!(motions_of_any_family(&log), Vec::<String>::new());
    let report = read_report(&out);
    assert_eq!(report["dry_run"], true);
    for at in ["powercube:17", "pac:2", "cdios:1/1"] {
        assert_eq!(check(&report, at, "move_forward")["status"], "skipped", "{at}");
        assert_eq!(check(&report, at, "halt")["status"], "skipped", "{at}");
        assert_eq!(check(&report, at, "identity")["status"], "pass", "{at}");
    }
    assert_eq!(check(&report, "pac:2", "home")["status"], "skipped");
    let motions: Vec<&str> = report["motions"].as_array().unwrap().iter().map(|m| m.as_str().unwrap()).collect();
    assert!(motions.contains(&"powercube:17: home"), "{motions:?}");
    assert!(motions.contains(&"pac:2: reference drive (0A84)"), "{motions:?}");
    assert!(motions.iter().any(|m| m.starts_with("cdios:1/0: goto 5000 counts")), "{motions:?}");
    assert!(r.stderr.contains("powercube:17: ramp 0.1 m from where it stands and back"), "{}", r.stderr);
    // The same run that would move asks first; a script's stdin cannot answer.
    let log2 = dir.path().join("asked.log");
    let r = run(&["--link", "sim", "--log", log2.to_str().unwrap(), "commission", "--out", out.to_str().unwrap()]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("give --yes"), "{}", r.stderr);
    assert_eq!(motions_of_any_family(&log2), Vec::<String>::new());
}

#[test]
fn ctrl_c_during_the_second_test_move_halts_it_and_leaves_an_incomplete_report() {
    let _busy = common::heavy::slot();
    let dir = tempfile::tempdir().unwrap();
    let mut plan = default_plan();
    for at in ["powercube:3", "powercube:5", "powercube:17"] {
        device(&mut plan, at).remove("halt");
    }
    // Module 3's moves slow and long (about 4 s each), so that the signal
    // lands in the second one however late a loaded host lets the test see it.
    let mv = device(&mut plan, "powercube:3")["move"].as_table_mut().unwrap();
    for key in ["rise_time_s", "settling_time_s", "time_to_reach_s"] {
        mv.remove(key);
    }
    mv.insert("distance".into(), toml::Value::Float(1.2));
    mv.insert("vel".into(), toml::Value::Float(0.3));
    mv.insert("timeout_s".into(), toml::Value::Float(60.0));
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, toml::to_string(&plan).unwrap()).unwrap();
    let (out, log) = (dir.path().join("r"), dir.path().join("run.log"));
    let mut child = bin()
        .args(["--link", "sim", "--log", log.to_str().unwrap(), "commission", "--plan", file.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap(), "--yes"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Module 3's second SetMotion (0x0E3, 0x0B) is the start of move_back.
    let deadline = Instant::now() + Duration::from_secs(60);
    // The log grows by thousands of samples a second: it is read on from
    // where the last look ended, so that a look stays short on a loaded
    // host and the signal lands while the move still runs.
    let (mut seen, mut sent) = (0usize, 0usize);
    let second = loop {
        let mut text = Vec::new();
        if let Ok(mut f) = std::fs::File::open(&log) {
            use std::io::Seek;
            let _ = f.seek(std::io::SeekFrom::Start(seen as u64)).and_then(|_| f.read_to_end(&mut text));
        }
        // Only whole lines: the writer may be inside one.
        let upto = text.iter().rposition(|b| *b == b'\n').map_or(0, |i| i + 1);
        let fresh = String::from_utf8_lossy(&text[..upto]).into_owned();
        seen += upto;
        sent += fresh.lines().filter_map(|l| l.split_whitespace().nth(2)).filter(|f| f.starts_with("0E3#0B")).count();
        if sent >= 2 {
            break sent;
        }
        assert!(Instant::now() < deadline, "no second test move of module 3 within 60 s");
        assert!(child.try_wait().unwrap().is_none(), "the run ended before its second move");
        // Polls the log (the event), not a wait for a guessed time: the move lasts over a second.
        std::thread::sleep(Duration::from_millis(2));
    };
    assert_eq!(second, 2);
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let ended = common::wait_bounded(child, 30, &["commission"]);
    assert_eq!(ended.code, 130, "{}", ended.stderr);
    let text = std::fs::read_to_string(&log).unwrap();
    let frames: Vec<&str> = text.lines().filter_map(|l| l.split_whitespace().nth(2)).collect();
    let last_motion = frames.iter().rposition(|f| f.starts_with("0E3#0B")).unwrap();
    let after: Vec<&&str> = frames[last_motion..].iter().take(40).collect();
    assert!(
        frames[last_motion..].contains(&"0E3#02"),
        "a Halt to module 3 after its last SetMotion: {after:?}\n{}",
        ended.stderr
    );
    let report = read_report(&out);
    assert_eq!((report["complete"].as_bool(), report["passed"].as_bool()), (Some(false), Some(false)));
    assert!(report["ended"].as_str().unwrap().contains("SIGINT"), "{}", report["ended"]);
    let back = check(&report, "powercube:3", "move_back");
    assert_eq!(back["status"], "fail");
    assert!(back["detail"].as_str().unwrap().starts_with("interrupted"), "{back}");
    assert_eq!(check(&report, "powercube:3", "move_forward")["status"], "pass");
    assert!(!checks(&report).iter().any(|c| c["device"] == "powercube:5"), "nothing after the interruption");
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(html.contains("INCOMPLETE"));
    let mut s = String::new();
    std::fs::File::open(out.join("report.md")).unwrap().read_to_string(&mut s).unwrap();
    assert!(s.starts_with("# Commissioning report: INCOMPLETE"));
}

#[test]
fn a_bad_plan_is_refused_before_anything_is_sent() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bad.log");
    let cases = [
        ("[[device]]\naddress = \"powercube:3\"\nsnap = true\n", "line 3"),
        ("[[device]]\naddress = \"pac:1\"\nidentity = { serial = 5 }\n", "no type, serial number or firmware"),
        ("[[device]]\naddress = \"pac\"\nmove = { distance = 1.0, window = [0.0, 9.0] }\n", "does not move"),
        ("[[device]]\naddress = \"cdios:1/0\"\nhome = { timeout_s = 9 }\n", "no reference drive"),
        ("[[device]]\naddress = \"powercube:3\"\nsettings = { values = { MaxVelo = { value = 1.0 } } }\n", "MaxVelo"),
        ("[[device]]\naddress = \"powercube:3\"\nsettings = { backup = \"missing.json\" }\n", "missing.json"),
    ];
    for (text, want) in cases {
        let file = dir.path().join("p.toml");
        std::fs::write(&file, text).unwrap();
        let out = dir.path().join("r");
        let r = run(&[
            "--link",
            "sim",
            "--log",
            log.to_str().unwrap(),
            "commission",
            "--plan",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--yes",
        ]);
        assert_eq!(r.code, 2, "{text}: {}", r.stderr);
        assert!(r.stderr.contains(want), "{text}: {}", r.stderr);
        assert_eq!(std::fs::read_to_string(&log).unwrap_or_default(), "", "nothing sent for {text}");
    }
}

/// The plan of docs/guide.md "Commissioning" runs as written on the
/// simulated bench (its backup file taken there first) and passes.
#[test]
fn the_guides_plan_runs_as_written() {
    let _busy = common::heavy::slot();
    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/guide.md")).unwrap();
    let section = guide.split("\n## Commissioning\n").nth(1).unwrap().split("\n## ").next().unwrap();
    let plan = section.split("```toml\n").nth(1).unwrap().split("```").next().unwrap();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("plan.toml"), plan).unwrap();
    let arm = dir.path().join("arm.json");
    let r = run(&["--link", "sim", "backup", "--out", arm.to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let out = dir.path().join("r");
    let plan_file = dir.path().join("plan.toml");
    let r = run(&[
        "--link",
        "sim",
        "commission",
        "--plan",
        plan_file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--yes",
    ]);
    assert_eq!(r.code, 0, "{}\n{}", r.stdout, r.stderr);
    let report = read_report(&out);
    let names: Vec<&str> = checks(&report).iter().map(|c| c["check"].as_str().unwrap()).collect();
    assert_eq!(names, ["identity", "settings", "limits", "home", "move_forward", "move_back", "halt", "backup"]);
    // The file's settings and the inline one were compared.
    let settings = check(&report, "powercube:17", "settings");
    assert!(settings["measured"].as_array().unwrap().len() > 10, "{settings}");
    assert_eq!(measured(settings, "MaxVel")["limit"], "0.1 ± 0.001");
}

/// The guide's second plan, of a PA-CONTROL axis and a Cdios module, runs
/// as written on the simulated bench and passes every check it names.
#[test]
fn the_guides_plan_of_the_other_families_runs_as_written() {
    let _busy = common::heavy::slot();
    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/guide.md")).unwrap();
    let section = guide.split("\n## Commissioning\n").nth(1).unwrap().split("\n## ").next().unwrap();
    let plan = section.split("```toml\n").nth(2).unwrap().split("```").next().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, plan).unwrap();
    let out = dir.path().join("r");
    let r = run(&[
        "--link",
        "sim",
        "commission",
        "--plan",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--yes",
    ]);
    assert_eq!(r.code, 0, "{}\n{}", r.stdout, r.stderr);
    let report = read_report(&out);
    let names = |at: &str| -> Vec<String> {
        checks(&report).iter().filter(|c| c["device"] == at).map(|c| c["check"].as_str().unwrap().to_string()).collect()
    };
    assert_eq!(
        names("pac:1"),
        ["identity", "settings", "limits", "home", "move_forward", "move_back", "halt", "backup"]
    );
    assert_eq!(names("cdios:1/0"), ["identity", "settings", "limits", "move_forward", "move_back", "halt", "backup"]);
    assert_eq!(measured(check(&report, "cdios:1/0", "identity"), "kind")["value"], "0x44");
}

#[test]
fn the_watchdog_check_sees_it_trip_and_recover() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, "[[device]]\naddress = \"powercube:3\"\nwatchdog = true\nbackup = false\n").unwrap();
    let out = dir.path().join("r");
    let r = run(&[
        "--link",
        "sim",
        "commission",
        "--plan",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--yes",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let report = read_report(&out);
    let c = check(&report, "powercube:3", "watchdog");
    assert_eq!(measured(c, "tripped")["value"], true, "{c}");
    assert_eq!(measured(c, "recovered after reset")["value"], true, "{c}");
}

/// A bench served by `axisctl sim` (slcan) gives the report `--link sim`
/// gives: the same checks with the same verdicts, the figures within what
/// the slower link's sampling changes; a second run on it gives it again.
#[test]
fn a_served_bench_gives_the_same_report_as_the_in_process_one() {
    let _busy = common::heavy::slot();
    let dir = tempfile::tempdir().unwrap();
    let mut plan = default_plan();
    plan["device"].as_array_mut().unwrap().retain(|d| d["address"].as_str() == Some("powercube:17"));
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, toml::to_string(&plan).unwrap()).unwrap();
    let sim = common::Sim::start(&[], 3);
    let mut reports = Vec::new();
    // Served twice: the first run leaves the module ready (the halt test's
    // Halt reset), so the second moves it all the same.
    let served = sim.link("powercube");
    for (name, link) in [("in-process", "sim"), ("served", served), ("served again", served)] {
        let out = dir.path().join(name);
        // A served simulator is another process, which a loaded machine can starve.
        let r = common::run_served(&[
            "--link",
            link,
            "commission",
            "--plan",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--yes",
        ]);
        assert_eq!(r.code, 0, "{name}: {}\n{}", r.stdout, r.stderr);
        reports.push(read_report(&out));
    }
    let dirs = ["in-process", "served", "served again"].map(|n| dir.path().join(n));
    for (b, b_dir) in reports.iter().zip(&dirs).skip(1) {
        same_within_tolerance((&dirs[0], checks(&reports[0])), (b_dir, checks(b)));
    }
}

/// The issue's done-when for every family: a bench served by `axisctl
/// sim`, its CAN families on one slcan pty and the PA-CONTROL on a serial
/// pty, gives the report `--link sim` gives, within the tolerances.
#[test]
fn a_served_slcan_and_serial_bench_gives_the_same_report_for_every_family() {
    let _busy = common::heavy::slot();
    let dir = tempfile::tempdir().unwrap();
    let mut plan = default_plan();
    let wanted = ["powercube:17", "pac", "pac:1", "cdios:1/0"];
    plan["device"].as_array_mut().unwrap().retain(|d| wanted.contains(&d["address"].as_str().unwrap_or("")));
    assert_eq!(plan["device"].as_array().unwrap().len(), wanted.len());
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, toml::to_string(&plan).unwrap()).unwrap();
    let sim = common::Sim::start(&[], 3);
    assert_eq!(sim.link("powercube"), sim.link("cdios"), "the CAN families share one slcan pty");
    let served = [sim.link("powercube"), sim.link("pac")];
    assert!(served[0].starts_with("slcan:") && served[1].starts_with("serial:"), "{served:?}");
    let mut reports = Vec::new();
    for (name, links) in [("in-process", vec!["sim"]), ("served", served.to_vec())] {
        let out = dir.path().join(name);
        let mut args: Vec<&str> = links.iter().flat_map(|l| ["--link", *l]).collect();
        args.extend(["commission", "--plan", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--yes"]);
        let r = common::run_served(&args);
        assert_eq!(r.code, 0, "{name}: {}\n{}", r.stdout, r.stderr);
        reports.push(read_report(&out));
    }
    let devices: BTreeSet<&str> = checks(&reports[1]).iter().map(|c| c["device"].as_str().unwrap()).collect();
    assert_eq!(devices, BTreeSet::from(wanted));
    // Each device of the final backup names the link it is on.
    let text = std::fs::read_to_string(dir.path().join("served").join("backup.json")).unwrap();
    let backup: Value = serde_json::from_str(&text).unwrap();
    for d in backup["devices"].as_array().unwrap() {
        let want = if d["family"] == "pac" { served[1] } else { served[0] };
        assert_eq!(d["link"], want, "{d}");
    }
    same_within_tolerance(
        (&dir.path().join("in-process"), checks(&reports[0])),
        (&dir.path().join("served"), checks(&reports[1])),
    );
}

/// The first column of a recording's CSV: when each sample was read, in s.
fn times(csv: &str) -> Vec<f64> {
    csv.lines().skip(1).map(|l| l.split(',').next().unwrap().parse().unwrap()).collect()
}

/// The largest step between two samples of a check's recording, in s.
fn largest_gap(dir: &Path, c: &Value) -> f64 {
    let Some(file) = c["recording"].as_str() else { return 0.0 };
    let t = times(&std::fs::read_to_string(dir.join(file)).unwrap());
    t.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max)
}

/// The same checks and verdicts; each time figure within two sampling
/// steps of each recording (a crossing is interpolated between the two
/// samples around it, so each side is off by at most a step of its own),
/// positions within 1e-4, the overshoot within 1 %. A 6168's speed is
/// read as it ramps (no plateau to sample), so its peak is compared within
/// 5 %, or within what sampling hides when that is more: both runs make
/// the same motion, and each recording's highest sample is below its true
/// peak by at most half the step around that sample times the recording's
/// steepest rate, so the two differ by at most the larger of those.
fn same_within_tolerance((a_dir, a): (&Path, &[Value]), (b_dir, b): (&Path, &[Value])) {
    assert_eq!(a.len(), b.len());
    let times = ["rise_time", "settling_time", "time_to_reach", "time_to_standstill"];
    let fixed = [("overshoot", 1.0), ("steady_state_error", 1e-4), ("peak_speed", 1e-3)];
    for (x, y) in a.iter().zip(b) {
        assert_eq!((&x["check"], &x["status"]), (&y["check"], &y["status"]));
        let steps = 2.0 * (largest_gap(a_dir, x) + largest_gap(b_dir, y)) + 1e-3;
        let all = times.iter().map(|f| (*f, steps)).chain(fixed);
        let ramping = x["device"].as_str().is_some_and(|d| d.starts_with("cdios"));
        for (fig, tol) in all {
            let find = |c: &Value| c["measured"].as_array().and_then(|m| m.iter().find(|m| m["name"] == fig).cloned());
            if let (Some(p), Some(q)) = (find(x), find(y)) {
                let (p, q) = (p["value"].as_f64().unwrap(), q["value"].as_f64().unwrap());
                let tol = if ramping && fig == "peak_speed" {
                    let (a_speed, b_speed) = (column(a_dir, x, "speed"), column(b_dir, y, "speed"));
                    let hidden = |s: &[(f64, f64)]| steepest(s) * gap_at_the_peak(s) / 2.0;
                    (0.05 * p.abs()).max(hidden(&a_speed).max(hidden(&b_speed)))
                } else {
                    tol
                };
                assert!((p - q).abs() <= tol, "{} {fig}: in-process {p}, served {q} (tolerance {tol})", x["check"]);
            }
        }
    }
}

#[test]
fn json_streams_one_line_per_check_then_the_outcome() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let r = run(&["--link", "sim", "--json", "commission", "--out", out.to_str().unwrap(), "--dry-run"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let stream = common::schema("stream_line");
    let lines: Vec<Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    for l in &lines {
        assert!(common::schema_errors(&stream, l).is_none(), "{l}");
    }
    let report = read_report(&out);
    let (last, each) = lines.split_last().unwrap();
    assert_eq!(each.len(), checks(&report).len(), "one line per check");
    for (line, c) in each.iter().zip(checks(&report)) {
        assert_eq!((&line["check"]["device"], &line["check"]["check"]), (&c["device"], &c["check"]));
    }
    assert_eq!(last["summary"], report["summary"]);
    assert_eq!((last["complete"].as_bool(), last["passed"].as_bool()), (Some(true), Some(true)));
    assert!(r.stderr.contains("would make these motions"), "the list still goes to stderr");
}

/// A module whose following error trips it mid-move (`sim --fault
/// trip=300ms`: STATE_TOW_ERROR once it has moved 300 ms) fails its test
/// move with the fault's name, is halted, and is not moved again.
#[test]
fn a_module_that_faults_mid_move_fails_its_move_and_is_halted() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    let plan = "[[device]]\naddress = \"powercube:3\"\nbackup = false\n\
                [device.move]\ndistance = 0.6\nwindow = [-3.0, 3.0]\nvel = 0.5\n\
                [device.halt]\ndistance = 0.6\nafter_s = 0.2\nstandstill_s = { max = 0.5 }\n";
    std::fs::write(&file, plan).unwrap();
    let sim = common::Sim::start(&["--fault", "trip=300ms"], 3);
    let (out, log) = (dir.path().join("r"), dir.path().join("trip.log"));
    let link = sim.link("powercube");
    let args = ["--link", link, "--log", log.to_str().unwrap(), "commission", "--plan", file.to_str().unwrap()];
    let r = run(&[&args[..], &["--out", out.to_str().unwrap(), "--yes"]].concat());
    assert_eq!(r.code, 5, "{}\n{}", r.stdout, r.stderr);
    let report = read_report(&out);
    assert_eq!(with_status(&report, "fail"), BTreeSet::from(["powercube:3 move_forward".to_string()]));
    let detail = check(&report, "powercube:3", "move_forward")["detail"].as_str().unwrap().to_string();
    assert!(detail.contains("STATE_TOW_ERROR") && detail.ends_with(", halted"), "{detail}");
    for later in ["move_back", "halt"] {
        assert_eq!(check(&report, "powercube:3", later)["status"], "skipped", "{later}");
    }
    let text = std::fs::read_to_string(&log).unwrap();
    let frames: Vec<&str> = text.lines().filter_map(|l| l.split_whitespace().nth(2)).collect();
    let motion = frames.iter().position(|f| f.starts_with("0E3#0B")).expect("the move went out");
    assert!(frames[motion..].contains(&"0E3#02"), "a Halt after the move");
    assert_eq!(frames.iter().filter(|f| f.starts_with("0E3#0B")).count(), 1, "never moved again");
}

#[test]
fn a_planned_module_that_does_not_answer_fails_and_its_other_checks_are_said_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, "[[device]]\naddress = \"powercube:9\"\nhome = { timeout_s = 5 }\n").unwrap();
    let out = dir.path().join("r");
    let r = run(&[
        "--link",
        "sim",
        "commission",
        "--plan",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--yes",
    ]);
    assert_eq!(r.code, 5, "{}", r.stderr);
    let report = read_report(&out);
    assert_eq!(with_status(&report, "fail"), BTreeSet::from(["powercube:9 identity".to_string()]));
    assert_eq!(
        with_status(&report, "skipped"),
        BTreeSet::from(["powercube:9 limits", "powercube:9 home", "powercube:9 backup"].map(String::from))
    );
    assert!(check(&report, "powercube:9", "identity")["detail"].as_str().unwrap().contains("no answer from module 9"));
}

/// A run of the default plan's `address` alone against a simulator served
/// with `faults` (on its `family`'s link): it must exit 5. Its report, and
/// the directory holding it and its recordings (`r/`).
fn faulted_run(address: &str, family: &str, faults: &str) -> (tempfile::TempDir, Value) {
    let dir = tempfile::tempdir().unwrap();
    let mut plan = default_plan();
    plan["device"].as_array_mut().unwrap().retain(|d| d["address"].as_str() == Some(address));
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, toml::to_string(&plan).unwrap()).unwrap();
    let sim = common::Sim::start(&["--fault", faults], 3);
    let out = dir.path().join("r");
    let args = ["--link", sim.link(family), "commission", "--plan", file.to_str().unwrap()];
    let r = run(&[&args[..], &["--out", out.to_str().unwrap(), "--yes"]].concat());
    assert_eq!(r.code, 5, "{}\n{}", r.stdout, r.stderr);
    (dir, read_report(&out))
}

/// The names of a check's figures that missed their limits.
fn failing(c: &Value) -> Vec<String> {
    c["measured"].as_array().unwrap().iter().filter(|m| m["pass"] == false).map(|m| m["name"].to_string()).collect()
}

/// How far the overshoot a recording measures may be from the `pct` the
/// fault asked for: 1 %, plus what sampling hides. The fault rings as a sine
/// of half period 0.15 s (the simulators' `RING_HALF_S`) whose first peak
/// is `pct` past the target; with the samples around it at most `gap` apart
/// one lies within `gap / 2` of that peak and reads at least
/// `cos(pi gap / 2 / 0.15)` of it. The recording must see the ring at all:
/// samples under half its half period apart.
fn ring_tolerance(pct: f64, gap: f64) -> f64 {
    const HALF_S: f64 = 0.15;
    assert!(gap < HALF_S / 2.0, "samples {:.0} ms apart cannot see a ring of 150 ms half periods", gap * 1e3);
    1.0 + pct * (1.0 - (std::f64::consts::PI * gap / 2.0 / HALF_S).cos())
}

/// A column of a check's recording, as (t, value) samples.
fn column(dir: &Path, c: &Value, name: &str) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(dir.join(c["recording"].as_str().unwrap())).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let at = header.iter().position(|h| h.starts_with(name)).unwrap_or_else(|| panic!("no {name} in {header:?}"));
    let value = |l: &str, i: usize| l.split(',').nth(i).unwrap().parse::<f64>().unwrap();
    text.lines().skip(1).map(|l| (value(l, 0), value(l, at))).collect()
}

/// The larger of the two steps between the sample farthest from the first
/// one (a peak) and its neighbours, in s: the true peak lies within one of
/// them.
fn gap_at_the_peak(samples: &[(f64, f64)]) -> f64 {
    let from = samples[0].1;
    let far = |j: usize| (samples[j].1 - from).abs();
    let i = (0..samples.len()).max_by(|&a, &b| far(a).total_cmp(&far(b))).unwrap();
    let t = |j: usize| samples[j.min(samples.len() - 1)].0;
    (t(i) - t(i.saturating_sub(1))).max(t(i + 1) - t(i))
}

/// The steepest change between two samples, per s.
fn steepest(samples: &[(f64, f64)]) -> f64 {
    samples
        .windows(2)
        .filter(|w| w[1].0 > w[0].0)
        .map(|w| ((w[1].1 - w[0].1) / (w[1].0 - w[0].0)).abs())
        .fold(0.0, f64::max)
}

/// A module that overshoots (`sim --fault overshoot=20`: each ramp rings
/// 20 % of its step past the target) and halts slowly (`slow-halt=800ms`)
/// fails exactly its overshoot figures and its halt time, with the
/// measured values, exit 5; everything else of the default plan passes.
#[test]
fn an_overshooting_module_that_halts_slowly_fails_exactly_those_figures() {
    let _busy = common::heavy::slot();
    let (dir, report) = faulted_run("powercube:17", "powercube", "overshoot=20,slow-halt=800ms");
    let out = dir.path().join("r");
    assert_eq!(
        with_status(&report, "fail"),
        BTreeSet::from(["move_forward", "move_back", "halt"].map(|c| format!("powercube:17 {c}")))
    );
    for mv in ["move_forward", "move_back"] {
        let c = check(&report, "powercube:17", mv);
        assert_eq!(failing(c), ["\"overshoot\""], "{c}");
        let o = measured(c, "overshoot");
        let v = o["value"].as_f64().unwrap();
        let tol = ring_tolerance(20.0, gap_at_the_peak(&column(&out, c, "ActPos")));
        assert!((v - 20.0).abs() <= tol, "{mv}: overshoot {v} %, the fault's 20 % within {tol}");
        assert_eq!(o["limit"], "<= 5");
    }
    let halt = check(&report, "powercube:17", "halt");
    assert_eq!(failing(halt), ["\"time_to_standstill\""], "{halt}");
    let secs = measured(halt, "time_to_standstill")["value"].as_f64().unwrap();
    let tol = 2.0 * largest_gap(&out, halt) + 1e-3;
    assert!((secs - 0.8).abs() <= tol, "halt time {secs} s, the fault's 0.8 s within {tol}");
}

fn files_in(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect()
}

/// A rerun into the same `--out` replaces the earlier report whole: the
/// earlier run's recordings and backup are gone when the new plan makes
/// none, a file of the user's is kept (and said), and a directory holding
/// no report is refused before anything is sent.
#[test]
fn a_rerun_into_the_same_out_leaves_no_file_of_the_earlier_run() {
    let _busy = common::heavy::slot();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r");
    let mut plan = default_plan();
    plan["device"].as_array_mut().unwrap().retain(|d| d["address"].as_str() == Some("powercube:3"));
    device(&mut plan, "powercube:3").remove("halt");
    let moving = dir.path().join("moving.toml");
    std::fs::write(&moving, toml::to_string(&plan).unwrap()).unwrap();
    let commission = |plan: &Path, extra: &[&str]| {
        let args = ["--link", "sim", "commission", "--plan", plan.to_str().unwrap(), "--out", out.to_str().unwrap()];
        run(&[&args[..], extra].concat())
    };
    let r = commission(&moving, &["--yes"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let first = files_in(&out);
    let csvs: Vec<&String> = first.iter().filter(|f| f.ends_with(".csv")).collect();
    assert_eq!(csvs.len(), 2, "{first:?}");
    assert!(first.contains("backup.json"));
    std::fs::write(out.join("notes.txt"), "signed by").unwrap();
    // The second plan reads one module and moves nothing, backs nothing up.
    let reading = dir.path().join("reading.toml");
    std::fs::write(&reading, "[[device]]\naddress = \"powercube:5\"\nbackup = false\n").unwrap();
    let r = commission(&reading, &[]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(
        files_in(&out),
        BTreeSet::from(["notes.txt", "plan.toml", "report.html", "report.json", "report.md"].map(String::from))
    );
    assert!(r.stderr.contains("also holds notes.txt"), "{}", r.stderr);
    let report = read_report(&out);
    assert!(checks(&report).iter().all(|c| c["device"] == "powercube:5"));
    // A directory of other files is nobody's report: refused, nothing sent.
    let foreign = dir.path().join("photos");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("bench.jpg"), "").unwrap();
    let log = dir.path().join("refused.log");
    let args = ["--link", "sim", "--log", log.to_str().unwrap(), "commission", "--out", foreign.to_str().unwrap()];
    let r = run(&[&args[..], &["--yes"]].concat());
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("bench.jpg") && r.stderr.contains("nothing was sent"), "{}", r.stderr);
    assert_eq!(std::fs::read_to_string(&log).unwrap_or_default(), "", "nothing sent");
    assert_eq!(files_in(&foreign), BTreeSet::from(["bench.jpg".to_string()]));
}

/// The same faults on a PA-CONTROL axis (`overshoot=20`: each positioning
/// rings 20 % of its step past the target; `slow-halt=1500ms`: a stop
/// brakes over 1.5 s, past the default plan's 1.2 s): exactly its two
/// moves' overshoot and its halt time fail, with the measured values.
#[test]
fn a_pa_control_axis_that_overshoots_and_stops_slowly_fails_exactly_those_figures() {
    let _busy = common::heavy::slot();
    let (dir, report) = faulted_run("pac:1", "pac", "overshoot=20,slow-halt=1500ms");
    let out = dir.path().join("r");
    assert_eq!(
        with_status(&report, "fail"),
        BTreeSet::from(["move_forward", "move_back", "halt"].map(|c| format!("pac:1 {c}")))
    );
    for mv in ["move_forward", "move_back"] {
        let c = check(&report, "pac:1", mv);
        assert_eq!(failing(c), ["\"overshoot\""], "{c}");
        let v = measured(c, "overshoot")["value"].as_f64().unwrap();
        let tol = ring_tolerance(20.0, gap_at_the_peak(&column(&out, c, "position")));
        assert!((v - 20.0).abs() <= tol, "{mv}: overshoot {v} %, the fault's 20 % within {tol}");
    }
    let halt = check(&report, "pac:1", "halt");
    assert_eq!(failing(halt), ["\"time_to_standstill\""], "{halt}");
    let secs = measured(halt, "time_to_standstill")["value"].as_f64().unwrap();
    let tol = 2.0 * largest_gap(&out, halt) + 1e-3;
    assert!((secs - 1.5).abs() <= tol, "stop time {secs} s, the fault's 1.5 s within {tol}");
}

/// The PA-CONTROL command codes a `--log` shows sent, in order.
fn pac_codes_sent(log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines()
        .filter_map(|line| {
            let mut words = line.split_whitespace().skip(1);
            (words.next() == Some("tx")).then(|| {
                let bytes: Vec<u8> = words.filter_map(|w| u8::from_str_radix(w, 16).ok()).collect();
                let ascii = String::from_utf8_lossy(&bytes).into_owned();
                ascii.trim_start_matches(['\x01', '\x02']).split(';').next().unwrap_or("").to_string()
            })
        })
        .collect()
}

/// The CAN frames of a `--log`, in order.
fn can_frames(log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines().filter_map(|l| l.split_whitespace().nth(2)).filter(|f| f.contains('#')).map(str::to_string).collect()
}

/// Runs `plan` on `--link sim` with `--log`, sends SIGINT once `moving`
/// sees the motion in the log, and returns the log and the report.
fn interrupted_run(plan: &str, moving: &dyn Fn(&Path) -> bool) -> (tempfile::TempDir, std::path::PathBuf, Value) {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, plan).unwrap();
    let (out, log) = (dir.path().join("r"), dir.path().join("run.log"));
    let mut child = bin()
        .args(["--link", "sim", "--log", log.to_str().unwrap(), "commission", "--plan", file.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap(), "--yes"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !moving(&log) {
        assert!(Instant::now() < deadline, "no motion within 60 s");
        assert!(child.try_wait().unwrap().is_none(), "the run ended before its motion");
        // Polls the log (the event); the motion lasts seconds.
        std::thread::sleep(Duration::from_millis(2));
    }
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let ended = common::wait_bounded(child, 30, &["commission"]);
    assert_eq!(ended.code, 130, "{}", ended.stderr);
    let report = read_report(&out);
    assert_eq!((report["complete"].as_bool(), report["passed"].as_bool()), (Some(false), Some(false)));
    (dir, log, report)
}

/// Ctrl-C during a PA-CONTROL axis's move stops the axis (0A93 after the
/// move's 0A94), takes the controller back to home position (0A81), and
/// leaves a report marked incomplete; the same during a Cdios goto
/// fast-stops the motor (25h option 2 after the goto's 23h) and disables
/// it again (the run had enabled it).
#[test]
fn ctrl_c_during_a_pa_control_move_or_a_cdios_goto_stops_it() {
    let plan = "[[device]]\naddress = \"pac:1\"\nbackup = false\n\
                move = { distance = 5000.0, window = [0.0, 10000.0], timeout_s = 60 }\n";
    let (_dir, log, report) = interrupted_run(plan, &|log| pac_codes_sent(log).iter().any(|c| c == "0A94"));
    let codes = pac_codes_sent(&log);
    let moved = codes.iter().position(|c| c == "0A94").unwrap();
    let stop = codes[moved..].iter().position(|c| c == "0A93").map(|i| moved + i);
    assert!(stop.is_some(), "a stop 0A93 after the move: {:?}", &codes[moved..]);
    assert!(codes[stop.unwrap()..].contains(&"0A81".to_string()), "back to home position after the stop");
    let c = check(&report, "pac:1", "move_forward");
    assert!(c["detail"].as_str().unwrap().starts_with("interrupted, stopped (0A93)"), "{c}");

    let plan = "[[device]]\naddress = \"cdios:1/0\"\nbackup = false\n\
                move = { distance = 10000.0, window = [-20000.0, 20000.0], vel = 200 }\n";
    let goto = |f: &String| f.starts_with("201#23");
    let (_dir, log, report) = interrupted_run(plan, &|log| can_frames(log).iter().any(goto));
    let frames = can_frames(&log);
    let moved = frames.iter().position(goto).unwrap();
    let after: Vec<&String> = frames[moved..].iter().filter(|f| f.starts_with("201#25")).collect();
    assert!(after.first().is_some_and(|f| f.starts_with("201#25000002")), "a fast stop first: {after:?}");
    assert!(after.iter().any(|f| f.starts_with("201#25000005")), "then disabled again: {after:?}");
    let c = check(&report, "cdios:1/0", "move_forward");
    assert!(c["detail"].as_str().unwrap().starts_with("interrupted, fast-stopped"), "{c}");
}

/// The PA-CONTROL limits check fails when the traverse area is none (its
/// minimum set above its maximum on a served controller), with the
/// measured width beside its limit, and nothing else fails.
#[test]
fn a_pa_control_axis_whose_traverse_area_is_none_fails_its_limits() {
    let sim = common::Sim::start(&[], 3);
    let link = sim.link("pac");
    let r = run(&["--link", link, "pac-axis-param", "1", "traverse-area-min", "20000"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("plan.toml");
    std::fs::write(&file, "[[device]]\naddress = \"pac:1\"\nlimits = true\nbackup = false\n").unwrap();
    let out = dir.path().join("r");
    let r =
        run(&["--link", link, "commission", "--plan", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--yes"]);
    assert_eq!(r.code, 5, "{}\n{}", r.stdout, r.stderr);
    let report = read_report(&out);
    assert_eq!(with_status(&report, "fail"), BTreeSet::from(["pac:1 limits".to_string()]));
    let width = measured(check(&report, "pac:1", "limits"), "traverse-area-max - traverse-area-min");
    assert_eq!(
        (width["value"].as_f64(), width["limit"].as_str(), width["pass"].as_bool()),
        (Some(-10000.0), Some("> 0"), Some(false))
    );
}
