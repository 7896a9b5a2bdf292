//! `axisctl monitor`: a whole simulated commissioning session, logged with
//! `--log`, replays through the decoder with every frame decoded.

use crate::common;

use common::run;

/// A commissioning session against one served bench (PowerCube and Cdios on
/// one slcan bus), logged with --log.
fn session_log() -> tempfile::NamedTempFile {
    let log = tempfile::Builder::new().suffix(".log").tempfile().unwrap();
    let p = log.path().to_str().unwrap();
    let sim = common::Sim::start(&[], 3);
    let link = sim.link("powercube");
    let steps: &[&[&str]] = &[
        &["scan"],
        &["info", "-m", "17"],
        &["home", "-m", "17", "--wait"],
        &["set-param", "-m", "17", "TargetAcc", "0.5"],
        &["move-ramp", "-m", "3", "0.3", "--vel", "1", "--acc", "2", "--wait"],
        &["get-param", "-m", "5", "--all"],
        &["set-config", "-m", "5", "+brake-present"],
        &["dio", "-m", "5", "--out", "3"],
        &["watchdog", "on", "-m", "5"],
        &["halt", "--all"],
        &["reset", "--all"],
        &["cdios-identify"],
        &["cdios-enable", "-m", "0"],
        &["cdios-goto", "-m", "0", "2000", "--wait"],
        &["cdios-status", "-m", "0"],
        &["cdios-position", "-m", "1", "--all"],
        &["cdios-outputs", "-m", "1", "--set", "5"],
        &["cdios-config", "-m", "0"],
        &["cdios-enable", "-m", "1"],
        &["cdios-goto", "-m", "1", "5000"],
        &["cdios-stop", "-m", "1"],
    ];
    for s in steps {
        let mut args = vec!["--link", link, "--log", p];
        args.extend_from_slice(s);
        let r = run(&args);
        assert_eq!(r.code, 0, "{s:?}: {}", r.stderr);
    }
    log
}

#[test]
fn a_whole_session_replays_with_every_frame_decoded() {
    let log = session_log();
    let p = log.path().to_str().unwrap();
    let logged = std::fs::read_to_string(log.path()).unwrap().lines().count();
    let r = run(&["--json", "monitor", "--from-log", p, "--stats"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines: Vec<serde_json::Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let (frames, stats) = lines.split_at(lines.len() - 1);
    assert_eq!(frames.len(), logged);
    for f in frames {
        assert!(f["family"] == "powercube" || f["family"] == "cdios", "{f}");
        assert!(f.get("decode_error").is_none() && f.get("error").is_none(), "undecoded: {f}");
        assert!(!f["summary"].as_str().unwrap().is_empty(), "{f}");
    }
    assert_eq!(stats[0]["stats"]["frames"].as_u64().unwrap() as usize, logged);
    assert_eq!(stats[0]["stats"]["errors"], 0);
    assert!(frames.iter().any(|f| f["kind"] == "broadcast"));
    for kind in ["nmt", "command", "reply"] {
        assert!(frames.iter().any(|f| f["family"] == "cdios" && f["kind"] == kind), "no Cdios {kind}");
    }
    assert!(frames.iter().any(|f| f["summary"].as_str().unwrap().contains("STATE_HOME_OK")));
}

#[test]
fn filters_and_candump_output() {
    let log = session_log();
    let p = log.path().to_str().unwrap();
    let only17 = run(&["--json", "monitor", "--from-log", p, "--module", "17"]);
    assert!(only17.stdout.lines().all(|l| l.contains("\"module\":17")));
    assert!(only17.stdout.lines().count() > 10);
    let ids = run(&["--json", "monitor", "--from-log", p, "--id", "100"]);
    assert_eq!(ids.stdout.lines().count(), 2, "the two broadcasts:\n{}", ids.stdout);
    let none = run(&["monitor", "--from-log", p, "--family", "other"]);
    assert_eq!(none.stdout, "");
    let cdios = run(&["--json", "monitor", "--from-log", p, "--family", "cdios"]);
    assert!(cdios.stdout.lines().count() > 10);
    assert!(cdios.stdout.lines().all(|l| l.contains("\"family\":\"cdios\"")));
    // --candump reproduces the log it read.
    let again = run(&["monitor", "--from-log", p, "--candump"]);
    assert_eq!(again.stdout, std::fs::read_to_string(log.path()).unwrap());
    assert_eq!(run(&["monitor", "--from-log", p, "--family", "bogus"]).code, 2);
    assert_eq!(run(&["--json", "monitor", "--from-log", p, "--candump"]).code, 2);
}

// A frame that does not decode is said under `decode_error`: `error` is the
// command's failure (`jq -e .error`), and the replay succeeded.
#[test]
fn an_undecodable_frame_is_a_decode_error_not_an_error() {
    let log = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(log.path(), "(1700000000.000000) can0 0E3#FF01\n").unwrap();
    let r = run(&["--json", "monitor", "--from-log", log.path().to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let line: serde_json::Value = serde_json::from_str(r.stdout.trim()).unwrap();
    assert_eq!(line["decode_error"], "unknown command id 0xff", "{line}");
    assert!(line.get("error").is_none(), "{line}");
}

/// `--from-log -` reads standard input, as candump's tools chain; a log is
/// streamed, so a line that never ends is refused at its bound, not read
/// into memory.
#[test]
fn a_log_on_standard_input_is_replayed_and_a_line_without_end_is_refused() {
    let log = "(1700000000.000000) can0 0E3#01\n(1700000000.000100) can0 0A3#01\n";
    let r = common::run_with_stdin(&["--json", "monitor", "--from-log", "-"], log);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.lines().count(), 2, "{}", r.stdout);
    // The tool stops reading at the bound, so the input is a file, not a
    // pipe whose writer would see EPIPE.
    let endless = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(endless.path(), "(".repeat(1 << 20)).unwrap();
    let out = common::bin()
        .args(["monitor", "--from-log", "-"])
        .stdin(std::fs::File::open(endless.path()).unwrap())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("standard input:1: line longer than 4096 bytes"), "{stderr}");
}

/// The in-process bench has nobody else on its bus: the monitor says so
/// instead of waiting without a word.
#[test]
fn monitoring_the_in_process_bench_says_nothing_will_show() {
    let r = run(&["--link", "sim", "monitor", "--for", "0.05"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("the in-process bench has no other client"), "{}", r.stderr);
}

/// `--timestamps` counts the time column as candump's -t a|d|z does.
#[test]
fn timestamps_absolute_delta_and_zero() {
    let log = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(
        log.path(),
        "(1700000000.250000) can0 0E3#01\n(1700000000.750000) can0 0A3#01\n(1700000001.000000) can0 0E3#01\n",
    )
    .unwrap();
    let p = log.path().to_str().unwrap();
    let column = |how: &str| -> Vec<String> {
        let r = run(&["monitor", "--from-log", p, "--timestamps", how]);
        assert_eq!(r.code, 0, "{}", r.stderr);
        r.stdout.lines().map(|l| l.split_whitespace().next().unwrap().to_string()).collect()
    };
    assert_eq!(column("absolute"), ["1700000000.250000", "1700000000.750000", "1700000001.000000"]);
    assert_eq!(column("delta"), ["0.000000", "0.500000", "0.250000"]);
    assert_eq!(column("zero"), ["0.000000", "0.500000", "0.750000"]);
    // A filter that is none is refused before anything is read.
    let r = run(&["monitor", "--from-log", p, "--filter", "0E0"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("write ID:MASK"), "{}", r.stderr);
}
