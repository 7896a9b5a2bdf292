//! Interop with software nobody here wrote: python-can's slcan interface
//! against `axisctl sim`, and python-can's LogReader on our `--log` files.
//! Needs `pip install python-can pyserial` (.ci/run installs them).

use crate::common;

use std::process::Command;

fn python(script: &str, args: &[&str]) -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/");
    let out = Command::new("python3")
        .arg(format!("{path}{script}"))
        .args(args)
        .output()
        .expect("python3 is needed for the interop tests");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{script} failed (is python-can installed? pip install python-can pyserial):\n{stderr}"
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn python_can_slcan_talks_to_the_simulator() {
    let sim = common::Sim::start(&["--powercube", "pty-slcan"], 1);
    let tty = sim.link("powercube").strip_prefix("slcan:").unwrap().to_string();
    let lines: Vec<String> = python("slcan_client.py", &[&tty]).lines().map(String::from).collect();
    // DefCubeVersion 0x3518, Home acknowledged, then CubeState with MOTION (homing under way).
    assert_eq!(lines[0], "0B1#0A1D1835");
    assert_eq!(lines[1], "0B1#01");
    assert!(lines[2].starts_with("0B1#0A27"), "{lines:?}");
    let state = u32::from_str_radix(&lines[2][8..], 16).unwrap().swap_bytes();
    assert!(state & 0x800 != 0, "homing: STATE_MOTION in {state:#x}");
}

#[test]
fn python_can_reads_our_log_files_frame_for_frame() {
    // LogReader picks the format by extension, as for candump's own files.
    let log = tempfile::Builder::new().suffix(".log").tempfile().unwrap();
    let p = log.path().to_str().unwrap();
    for args in [&["home", "-m", "17"][..], &["get-param", "-m", "3", "--all"], &["halt", "--all"]] {
        let mut full = vec!["--link", "sim", "--log", p];
        full.extend_from_slice(args);
        assert_eq!(common::run(&full).code, 0);
    }
    let ours: Vec<String> = std::fs::read_to_string(log.path())
        .unwrap()
        .lines()
        .map(|l| l.split_whitespace().nth(2).unwrap().to_string())
        .collect();
    let theirs: Vec<String> = python("read_log.py", &[p]).lines().map(String::from).collect();
    assert!(ours.len() > 100, "get-param --all logs every read: {}", ours.len());
    assert_eq!(theirs, ours);
}

/// `monitor --filter ID:MASK` passes what python-can's own CAN filters (the
/// SocketCAN can_id / can_mask semantics) pass, frame for frame, on a log of
/// PowerCube and Cdios traffic.
#[test]
fn monitor_filters_pass_what_python_cans_filters_pass() {
    let log = tempfile::Builder::new().suffix(".log").tempfile().unwrap();
    let p = log.path().to_str().unwrap();
    for args in [
        &["home", "-m", "17"][..],
        &["get-param", "-m", "3,5", "ActPos"],
        &["halt", "--all"],
        &["cdios-status", "-m", "0"],
    ] {
        let mut full = vec!["--link", "sim", "--log", p];
        full.extend_from_slice(args);
        assert_eq!(common::run(&full).code, 0, "{args:?}");
    }
    for filters in [&["0E0:7E0"][..], &["0A0:7E0", "100:7FF"], &["181:7FF", "201:7FF"], &["0C3:7FF"], &["000:000"]] {
        let mut args = vec!["monitor", "--from-log", p, "--candump"];
        for f in filters {
            args.extend(["--filter", f]);
        }
        let r = common::run(&args);
        assert_eq!(r.code, 0, "{}", r.stderr);
        let ours: Vec<String> = r.stdout.lines().map(|l| l.split_whitespace().nth(2).unwrap().to_string()).collect();
        let mut script_args = vec![p];
        script_args.extend_from_slice(filters);
        let theirs: Vec<String> = python("filter_log.py", &script_args).lines().map(String::from).collect();
        assert!(!theirs.is_empty(), "{filters:?} passes something");
        assert_eq!(ours, theirs, "{filters:?}");
    }
}
