//! The CLI of issue 25's open items and issue 22's PA-CONTROL speed limits:
//! `pac-speed` / `pac-accel` checked against the limits `pac-online` read.

use crate::common;

use common::{bin, run_with_stdin, Sim};

/// The frames a `--log` recorded as sent, as hex text.
fn sent(log: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines().filter_map(|l| l.split_once(" tx ").map(|(_, hex)| hex.to_string())).collect()
}

/// "0A8D" as the PA-CONTROL line carries it (ASCII, hex-logged).
fn code_hex(code: &str) -> String {
    code.bytes().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

fn sends(log: &std::path::Path, code: &str) -> bool {
    sent(log).iter().any(|f| f.contains(&code_hex(code)))
}

/// A private lock directory of the test's own (0700, or it is not used),
/// so the kept limits of one test never meet another's.
fn lock_dir() -> tempfile::TempDir {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o700)).unwrap();
    dir
}

fn isolated(dir: &std::path::Path) -> impl Fn(&[&str]) -> common::Run + '_ {
    move |args: &[&str]| {
        let out = bin().env("AXISCTL_LOCK_DIR", dir).args(args).output().expect("run axisctl");
        common::Run {
            code: out.status.code().unwrap_or(-1),
            stdout: String::from_utf8_lossy(&out.stdout).into(),
            stderr: String::from_utf8_lossy(&out.stderr).into(),
        }
    }
}

#[test]
fn pac_speed_outside_the_limits_read_by_pac_online_is_refused_and_nothing_is_sent() {
    let sim = Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    let dir = lock_dir();
    let ax = isolated(dir.path());
    let kept = || {
        std::fs::read_dir(dir.path())
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".pac-limits"))
            .count()
    };
    let r = ax(&["--link", link, "pac-online"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(kept(), 1, "kept beside the lock");

    for (args, what) in [(["pac-speed", "1", "1e9"], "speed 1000000000"), (["pac-accel", "2", "1e9"], "acceleration")] {
        let log = dir.path().join(format!("{}.log", args[0]));
        let mut all = vec!["--link", link, "--log", log.to_str().unwrap()];
        all.extend(args);
        let r = ax(&all);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(what) && r.stderr.contains("limits"), "{}", r.stderr);
        assert!(r.stderr.contains("nothing was sent"), "{}", r.stderr);
        assert!(sent(&log).is_empty(), "{args:?} sent nothing at all: {:?}", sent(&log));
    }

    // The simulated controller's limits for axis 1's speed are 0.1 to 50000.
    let log = dir.path().join("ok.log");
    let r = ax(&["--link", link, "--log", log.to_str().unwrap(), "--json", "pac-speed", "1", "50000"]);
    assert_eq!(r.code, 0, "the maximum itself goes out: {}", r.stderr);
    assert!(sends(&log, "0A8D"), "{:?}", sent(&log));
    assert!(!r.stderr.contains("not known"), "the limits were known: {}", r.stderr);
    let r = ax(&["--link", link, "pac-speed", "1", "50000.5"]);
    assert_eq!(r.code, 2, "just above: {}", r.stderr);

    // pac-offline forgets them: online again by another way, the controller checks.
    assert_eq!(ax(&["--link", link, "pac-offline"]).code, 0);
    assert_eq!(kept(), 0, "the kept limits are gone");
    assert_eq!(ax(&["--link", link, "pac-raw", "0603", "0"]).code, 0);
    let log = dir.path().join("unknown.log");
    let r = ax(&["--link", link, "--log", log.to_str().unwrap(), "pac-speed", "1", "1e9"]);
    assert!(r.stderr.contains("not known here"), "the fallback is said: {}", r.stderr);
    assert!(sends(&log, "0A8D"), "without limits the value goes out: {:?}", sent(&log));
    assert_ne!(r.code, 0, "and the controller refuses it: {}", r.stderr);
}

#[test]
fn a_batch_checks_pac_speed_against_the_limits_its_pac_online_read() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("batch.log");
    let r = run_with_stdin(
        &["--link", "sim", "--log", log.to_str().unwrap(), "batch"],
        "pac-online\npac-speed 1 100\npac-speed 1 1e9\npac-state\n",
    );
    assert_ne!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("line 3") && r.stderr.contains("outside axis 1's limits"), "{}", r.stderr);
    let speeds = sent(&log).iter().filter(|f| f.contains(&code_hex("0A8D"))).count();
    assert_eq!(speeds, 1, "only line 2's speed went out: {:?}", sent(&log));
}

#[test]
fn a_garbled_limits_file_is_not_trusted() {
    let sim = Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    let dir = lock_dir();
    let ax = isolated(dir.path());
    let r = ax(&["--link", link, "pac-online"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let listing: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
    let file = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().ends_with(".pac-limits"))
        .unwrap_or_else(|| panic!("pac-online kept the limits beside the lock: {listing:?} {}", r.stderr));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.starts_with("axisctl-pac-limits 1\n257 0.1 50000\n"), "{text}");
    std::fs::write(&file, text.replace("257 0.1 50000", "257 0.1 fifty")).unwrap();
    let r = ax(&["--link", link, "pac-speed", "1", "60000"]);
    assert!(r.stderr.contains("not known here"), "{}", r.stderr);
}

/// A session log with error frames as `candump -e -L` writes them.
const ERROR_LOG: &str = "\
(1700000000.000000) can0 0F1#01
(1700000000.010000) can0 0A3#0A3C0000803F
(1700000000.020000) can0 20000004#0004000000000000
(1700000000.030000) can0 0F1#01
(1700000000.040000) can0 20000040#0000000000000000
(1700000000.070000) can0 0F1#01
";

#[test]
fn monitor_names_error_frames_in_text_json_and_candump_lines() {
    let r = run_with_stdin(&["monitor", "--from-log", "-"], ERROR_LOG);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(lines.len(), 6, "{}", r.stdout);
    assert!(lines[2].contains("error") && lines[2].contains("bus error: controller: rx warning"), "{}", lines[2]);
    assert!(lines[4].contains("bus error: bus off"), "{}", lines[4]);

    // Error frames are the bus's: an id filter keeps them, as candump -e does.
    let r = run_with_stdin(&["--json", "monitor", "--from-log", "-", "--filter", "0A3:7FF"], ERROR_LOG);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let schema = common::schema("stream_line");
    let docs: Vec<serde_json::Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    for d in &docs {
        assert_eq!(common::schema_errors(&schema, d), None, "{d}");
    }
    let kinds: Vec<&str> = docs.iter().map(|d| d["kind"].as_str().unwrap()).collect();
    assert_eq!(kinds, ["ack", "error", "error"]);
    assert_eq!(docs[2]["frame"], "20000040#0000000000000000");
    assert_eq!(docs[2]["family"], serde_json::Value::Null);
    assert_eq!(docs[2]["details"]["problems"], serde_json::json!(["bus off"]));
    // `--family powercube` leaves them out.
    let r = run_with_stdin(&["--json", "monitor", "--from-log", "-", "--family", "powercube"], ERROR_LOG);
    assert!(!r.stdout.contains("\"error\""), "{}", r.stdout);

    // Replayed to candump lines, the log comes out as it went in.
    let r = run_with_stdin(&["monitor", "--from-log", "-", "--candump"], ERROR_LOG);
    assert_eq!(r.stdout, ERROR_LOG);
}

#[test]
fn monitor_table_has_one_row_per_id_with_count_period_and_rate() {
    let r = run_with_stdin(&["monitor", "--from-log", "-", "--table"], ERROR_LOG);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(lines.len(), 5, "a header and 4 ids, printed once at the end into a pipe: {}", r.stdout);
    assert!(lines[0].starts_with("ID") && lines[0].contains("COUNT") && lines[0].contains("PERIOD"), "{}", lines[0]);
    let row = |id: &str| lines.iter().find(|l| l.starts_with(id)).unwrap_or_else(|| panic!("{id}: {}", r.stdout));
    let f1: Vec<&str> = row("0F1").split_whitespace().collect();
    // 3 frames at 0, 30 and 70 ms: the last period 40 ms, 2 periods in 70 ms.
    assert_eq!(&f1[..5], ["0F1", "3", "40.0", "28.6", "01"], "{}", row("0F1"));
    assert!(row("0F1").ends_with("Home"));
    assert!(row("0A3").contains("ActPos = 1"));
    assert!(row("20000040").contains("bus off"));

    for other in ["--json", "--candump"] {
        let args: Vec<&str> = if other == "--json" {
            vec!["--json", "monitor", "--from-log", "-", "--table"]
        } else {
            vec!["monitor", "--from-log", "-", "--table", "--candump"]
        };
        let r = run_with_stdin(&args, ERROR_LOG);
        assert_eq!(r.code, 2, "{other}: {}", r.stderr);
        assert!(r.stdout.is_empty());
    }
}

#[test]
fn send_refuses_motion_without_force_and_sends_nothing() {
    let dir = tempfile::tempdir().unwrap();
    for (frame, why) in [
        ("0F1#01", "Home starts a motion of PowerCube module 17"),
        ("100#0100", "broadcast starts every PowerCube module"),
        ("0E3#0A3C", "does not decode"),
        ("0A94;1;1;100.0", "may start a motion"),
    ] {
        let log = dir.path().join("refused.log");
        let r = common::run(&["--link", "sim?pac=online", "--log", log.to_str().unwrap(), "send", frame]);
        assert_eq!(r.code, 2, "{frame}: {}", r.stderr);
        assert!(r.stderr.contains(why) && r.stderr.contains("--force"), "{frame}: {}", r.stderr);
        assert!(sent(&log).is_empty(), "{frame}: nothing sent: {:?}", sent(&log));
    }
    for bad in ["0F1", "0F1#1", "20000004#00", "0A94;1;x;1", "nonsense"] {
        let r = common::run(&["--link", "sim", "send", bad]);
        assert_eq!(r.code, 2, "{bad}: {}", r.stderr);
    }
}

#[test]
fn send_decodes_the_frame_and_its_answers() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("send.log");
    let r = common::run(&["--link", "sim", "--log", log.to_str().unwrap(), "send", "0C3#0A3C", "--listen", "2000"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(
        r.stderr.contains("-> 0C3#0A3C") && r.stderr.contains("GetExtended ActPos"),
        "decoded before: {}",
        r.stderr
    );
    assert!(r.stdout.starts_with("<- 0A3#0A3C") && r.stdout.contains("ActPos = "), "{}", r.stdout);
    assert!(std::fs::read_to_string(&log).unwrap().contains(" 0C3#0A3C"), "logged");

    let r = common::run(&["--link", "sim", "--json", "send", "0C3#0A3C"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let doc = r.json();
    assert_eq!(common::schema_errors(&common::schema("document"), &doc), None, "{doc}");
    assert_eq!((doc["command"].as_str(), doc["motion"].as_bool()), (Some("send"), Some(false)));
    assert_eq!(doc["sent"]["device"], "powercube:3");
    assert_eq!(doc["answers"][0]["kind"], "ack", "{doc}");
    assert_eq!(doc["answers"][0]["details"]["param"], "ActPos");

    // With --force a motion goes out, and its acknowledge comes back.
    let log = dir.path().join("forced.log");
    let r = common::run(&[
        "--link",
        "sim",
        "--log",
        log.to_str().unwrap(),
        "send",
        "--force",
        "0F1#01",
        "--listen",
        "2000",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("Home ok"), "{}", r.stdout);
    assert!(std::fs::read_to_string(&log).unwrap().contains(" 0F1#01"));

    // A PA-CONTROL command goes as pac-raw's.
    let r = common::run(&["--link", "sim", "send", "190C;1;0;0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.starts_with("190C get-actual-pos: QUIT 0"), "{}", r.stdout);
}

#[test]
fn a_powercube_scan_on_a_pac_control_line_hints_at_the_other_protocol() {
    let sim = Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    let r = common::run(&["--link", link, "scan"]);
    assert_eq!(r.code, 6, "{}", r.stderr);
    assert!(r.stderr.contains("another protocol on this line?"), "{}", r.stderr);
    assert!(r.stderr.contains(&format!("try `axisctl --link {link} pac-state`")), "{}", r.stderr);
    let r = common::run(&["--link", link, "--json", "scan"]);
    let err: serde_json::Value = serde_json::from_str(r.stderr.lines().last().unwrap()).unwrap();
    assert_eq!(err["error"]["kind"], "malformed");
    assert!(err["error"]["message"].as_str().unwrap().contains("pac-state"), "{err}");
    // The hint follows the suggestion it makes: pac-state answers there.
    assert_eq!(common::run(&["--link", link, "pac-state"]).code, 0);
}

#[test]
fn moving_a_module_that_was_never_homed_warns_first_and_still_moves() {
    let r = run_with_stdin(
        &["--link", "sim", "--trace", "batch"],
        "move-ramp -m 3 0.05 --wait\nhome -m 3 --wait\nmove-ramp -m 3 0.1 --wait\n",
    );
    assert_eq!(r.code, 0, "a warning, not a refusal: {}", r.stderr);
    let lines: Vec<&str> = r.stderr.lines().collect();
    let warned: Vec<usize> =
        lines.iter().enumerate().filter(|(_, l)| l.contains("was not homed")).map(|(i, _)| i).collect();
    assert_eq!(warned.len(), 1, "only before the move ahead of the home: {}", r.stderr);
    assert!(lines[warned[0]].starts_with("axisctl: warning: module 3 was not homed (CubeState lacks HOME_OK)"));
    let first_motion = lines.iter().position(|l| l.starts_with("->") && l.contains("SetMotion")).expect("a motion");
    assert!(warned[0] < first_motion, "said before the motion went out: {}", r.stderr);
    assert!(r.stdout.contains("home done"), "{}", r.stdout);
}

/// Candidates bash's completion function offers for `axisctl WORDS...`, with
/// `AXISCTL_BENCH` naming `bench`.
fn complete_bash_on_bench(bench: &std::path::Path, words: &[&str]) -> Vec<String> {
    common::bash_completion(words, &[("AXISCTL_BENCH", bench.to_str().unwrap())])
        .iter()
        .map(|l| l.split_whitespace().next().unwrap_or("").to_string())
        .collect()
}

#[test]
fn bash_completes_module_ids_from_the_bench_file() {
    let bench = std::path::Path::new(common::bench::SIM_BENCH);
    let got = complete_bash_on_bench(bench, &["state", "-m", ""]);
    assert_eq!(got, ["3", "5"], "shoulder and elbow of docs/sim-bench.toml");
    let got = complete_bash_on_bench(bench, &["get-param", "-m", "3,"]);
    assert_eq!(got, ["3,3", "3,5"]);
}

#[test]
fn bash_completes_devices_from_the_bench_file() {
    let bench = std::path::Path::new(common::bench::SIM_BENCH);
    let got = complete_bash_on_bench(bench, &["state", "-d", ""]);
    assert_eq!(got, ["elbow", "powercube:3", "powercube:5", "shoulder"], "the PowerCube devices, by name and address");
    let got = complete_bash_on_bench(bench, &["cdios-status", "-d", "g"]);
    assert_eq!(got, ["gripper"]);
    let got = complete_bash_on_bench(bench, &["halt", "-d", "shoulder,s"]);
    assert_eq!(got, ["shoulder,shoulder", "shoulder,slide"], "any family for halt -d, after the comma");
    // The whole-bench commands' -d: any family.
    for command in [
        &["backup"][..],
        &["diff", "b.json"],
        &["restore", "b.json"],
        &["commission"],
        &["dashboard"],
        &["monitor"],
        &["scan"],
    ] {
        let mut words = command.to_vec();
        words.extend(["-d", "s"]);
        assert_eq!(complete_bash_on_bench(bench, &words), ["shoulder", "slide"], "{command:?}");
    }
}
