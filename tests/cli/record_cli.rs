//! `axisctl record` through the real binary: the JSON Lines and CSV it
//! streams (every line validated against `$defs/record_line`), bad input
//! refused before anything is sent, and a motion started with `-- MOTION`
//! on the same link that is halted on every way out: Ctrl-C, a closed
//! stdout, a full disk, the end of the recording while it still moves.
//! Against the in-process `--link sim` and against `axisctl sim` on ptys.

use crate::common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::{run, Run, Sim};
use serde_json::Value;

fn record_line_schema() -> jsonschema::Validator {
    common::schema("record_line")
}

/// Every stdout line: a valid record line, `seq` counting from 0, `t`
/// never going back.
fn checked_lines(r: &Run) -> Vec<Value> {
    let schema = record_line_schema();
    let lines: Vec<Value> = r.stdout.lines().map(|l| serde_json::from_str(l).expect("a JSON line")).collect();
    let mut last_t = -1.0;
    for (i, l) in lines.iter().enumerate() {
        if let Some(e) = common::schema_errors(&schema, l) {
            panic!("line {i} breaks $defs/record_line: {e}\n{l}");
        }
        assert_eq!(l["seq"], i as u64, "{l}");
        let t = l["t"].as_f64().unwrap();
        assert!(t >= last_t, "time went back at line {i}: {t} < {last_t}");
        last_t = t;
    }
    lines
}

fn wait_bounded(mut child: Child, secs: u64) -> i32 {
    let deadline = Instant::now() + Duration::from_secs(secs);
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            return st.code().unwrap_or(-1);
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("axisctl record hung for {secs} s");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The candump lines of a `--log` file, `ID#DATA` only.
fn frames(log: &Path) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_whitespace().nth(2).map(str::to_string))
        .collect()
}

/// Module 17 (CAN id 0x0F1 for requests): a SetMotion (0x0B) went out and a
/// Halt (0x02) followed it.
fn halted_after_motion(log: &Path) -> bool {
    let f = frames(log);
    let motion = f.iter().position(|x| x.starts_with("0F1#0B"));
    motion.is_some_and(|i| f[i..].iter().any(|x| x == "0F1#02"))
}

fn temp(name: &str) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    (dir, p)
}

#[test]
fn json_lines_carry_every_module_value_with_its_unit() {
    let r = run(&["--link", "sim", "--json", "record", "-m", "3,17", "ActPos", "ActVel", "Cur", "--count", "5"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = checked_lines(&r);
    assert_eq!(lines.len(), 5);
    let devices = lines[0]["devices"].as_array().unwrap();
    assert_eq!(devices.iter().map(|d| d["module"].as_u64().unwrap()).collect::<Vec<_>>(), [3, 17]);
    // Module 3 is rotary, 17 linear (the simulated bench).
    assert_eq!(devices[0]["values"]["ActPos"]["unit"], "rad");
    assert_eq!(devices[1]["values"]["ActPos"]["unit"], "m");
    assert_eq!(devices[1]["values"]["ActVel"]["unit"], "m/s");
    assert_eq!(devices[1]["values"]["Cur"]["unit"], "A");
    assert_eq!(devices[1]["family"], "powercube");
    assert_eq!(devices[1]["link"], "sim");
}

#[test]
fn a_parameter_the_firmware_lacks_records_null_and_is_never_asked() {
    // Module 17 of the simulated bench has no ActFTemp (an older firmware);
    // module 3 has it.
    let (_dir, log) = temp("lacks.log");
    let r = run(&[
        "--link",
        "sim",
        "--log",
        log.to_str().unwrap(),
        "--json",
        "record",
        "-m",
        "3,17",
        "ActFTemp",
        "--count",
        "2",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = checked_lines(&r);
    assert!(lines[1]["devices"][0]["values"]["ActFTemp"]["value"].is_number(), "{}", lines[1]);
    assert!(lines[1]["devices"][1]["values"]["ActFTemp"]["value"].is_null(), "{}", lines[1]);
    assert!(!frames(&log).iter().any(|f| f.starts_with("0F1#0A72")), "ActFTemp asked of module 17");
}

#[test]
fn csv_names_each_column_with_its_unit() {
    let r = run(&["--link", "sim", "record", "--format", "csv", "--axis", "2", "position", "speed", "--count", "3"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let rows: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(rows[0], "t [s],axis 2 position [AE],axis 2 speed [AE/s]");
    assert_eq!(rows.len(), 4);
    assert!(rows[1..].iter().all(|l| l.split(',').count() == 3 && l.split(',').all(|c| c.parse::<f64>().is_ok())));
    let r = run(&[
        "--link", "sim", "record", "--format", "csv", "--node", "1", "-m", "0", "position", "speed", "--count", "2",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.lines().next(), Some("t [s],node 1 module 0 position [counts],node 1 module 0 speed [rpm]"));
}

#[test]
fn a_rate_spaces_the_samples() {
    let r = run(&["--link", "sim", "--json", "record", "-m", "17", "ActPos", "--rate", "50", "--count", "6"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let t: Vec<f64> = checked_lines(&r).iter().map(|l| l["t"].as_f64().unwrap()).collect();
    // Sample n is due at n / 50 s and never taken before it.
    assert!(t.iter().enumerate().all(|(n, t)| *t >= n as f64 / 50.0 - 1e-6), "{t:?}");
}

#[test]
fn bad_input_is_exit_2_and_sends_nothing() {
    let (_dir, log) = temp("bad.log");
    let log_s = log.to_str().unwrap();
    for args in [
        &["record", "-m", "17", "ActPoz", "--count", "1"][..],
        &["record", "--axis", "2", "ActPos", "--count", "1"],
        &["record", "--node", "1", "position"],
        &["record", "ActPos", "--count", "1"],
        &["record", "-m", "17", "ActPos", "--count", "0"],
        &["record", "-m", "17", "ActPos", "--count", "2", "--for", "1s"],
        &["record", "-m", "17", "ActPos", "--rate", "0"],
        &["record", "-m", "17", "ActPos", "--", "get-param", "-m", "17", "ActPos"],
        &["record", "-m", "17", "ActPos", "--", "pac-move", "2", "150"],
        &["record", "-m", "17", "ActPos", "--", "move-ramp", "-m", "17", "nan"],
        &["record", "-m", "17", "ActPos", "--", "move-ramp", "-m", "3,5", "--sync", "0.1", "0.1"],
        &["record", "-m", "17", "ActPos", "--", "move-ramp", "-m", "99", "0.1"],
    ] {
        let mut all = vec!["--link", "sim", "--log", log_s];
        all.extend_from_slice(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(frames(&log).is_empty(), "{args:?} sent {:?}", frames(&log));
    }
}

#[test]
fn a_move_is_recorded_and_halted_when_the_recording_ends_while_it_moves() {
    let (_dir, log) = temp("ramp.log");
    let r = run(&[
        "--link",
        "sim",
        "--log",
        log.to_str().unwrap(),
        "--json",
        "record",
        "-m",
        "17",
        "ActPos",
        "ActVel",
        "--rate",
        "50",
        "--for",
        "0.5s",
        "--",
        "move-vel",
        "-m",
        "17",
        "0.02",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = checked_lines(&r);
    let vel = |l: &Value| l["devices"][0]["values"]["ActVel"]["value"].as_f64().unwrap();
    assert_eq!(vel(&lines[0]), 0.0, "the first sample is taken before the move starts");
    assert!(vel(lines.last().unwrap()) > 0.01, "the response is recorded: {:?}", lines.last());
    assert!(r.stderr.contains("module 17 halted"), "{}", r.stderr);
    assert!(halted_after_motion(&log), "{:?}", frames(&log));
}

#[test]
fn a_move_that_ended_before_the_recording_is_not_halted() {
    let (_dir, log) = temp("short.log");
    let r = run(&[
        "--link",
        "sim",
        "--log",
        log.to_str().unwrap(),
        "record",
        "-m",
        "17",
        "ActPos",
        "--rate",
        "20",
        "--for",
        "1.5s",
        "--",
        "move-ramp",
        "-m",
        "17",
        "0.005",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(!r.stderr.contains("halted"), "{}", r.stderr);
    assert!(!halted_after_motion(&log), "{:?}", frames(&log));
}

/// Starts `record ... -- move-vel` (which never ends by itself) and hands
/// the child once `n` samples were read from its stdout.
fn recording_a_move(link: &str, log: &Path, n: usize) -> (Child, BufReader<std::process::ChildStdout>) {
    recording_a_move_at(link, log, n, &["--rate", "20"])
}

/// [`recording_a_move`] with `rate` (`--rate N`, or nothing: back to back).
fn recording_a_move_at(
    link: &str,
    log: &Path,
    n: usize,
    rate: &[&str],
) -> (Child, BufReader<std::process::ChildStdout>) {
    let mut child = common::bin()
        .args(["--link", link, "--log", log.to_str().unwrap(), "--json", "record", "-m", "17", "ActPos", "ActVel"])
        .args(rate)
        .args(["--", "move-vel", "-m", "17", "0.01"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    for _ in 0..n {
        let mut line = String::new();
        assert!(out.read_line(&mut line).unwrap() > 0, "the recording ended early");
    }
    (child, out)
}

fn stderr_of(child: &mut Child) -> String {
    let mut s = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut s).unwrap();
    s
}

/// The module stands: CubeState without MOTION, read by another process.
fn cube_17_stands(link: &str) -> bool {
    let st = run(&["--link", link, "--json", "state", "-m", "17"]);
    st.json()["state"]["raw"].as_u64().unwrap() & 0x800 == 0
}

#[test]
fn ctrl_c_during_a_recorded_move_halts_it_and_exits_130() {
    let sim = Sim::start(&[], 3);
    let link = sim.link("powercube");
    let (_dir, log) = temp("ctrl-c.log");
    let (mut child, _out) = recording_a_move(link, &log, 4);
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let err_reader = stderr_of(&mut child);
    assert_eq!(wait_bounded(child, 10), 130, "{err_reader}");
    assert!(err_reader.contains("interrupted: module 17 halted"), "{err_reader}");
    assert!(halted_after_motion(&log), "{:?}", frames(&log));
    assert!(cube_17_stands(link));
}

// Back to back, a read burst is always in flight when the signal comes:
// the halt goes out past it and the module stops.
#[test]
fn ctrl_c_during_a_back_to_back_recorded_move_halts_it() {
    let sim = Sim::start(&[], 3);
    let link = sim.link("powercube");
    let (_dir, log) = temp("ctrl-c-ahead.log");
    let (mut child, _out) = recording_a_move_at(link, &log, 50, &[]);
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let err = stderr_of(&mut child);
    assert_eq!(wait_bounded(child, 10), 130, "{err}");
    assert!(err.contains("interrupted: module 17 halted"), "{err}");
    assert!(halted_after_motion(&log), "{:?}", frames(&log));
    assert!(cube_17_stands(link));
}

// Back to back, the next sample's burst goes out before the answers of the
// current one are read: module 17's ActPos request (0x0D1) goes out twice
// before its first answer (0x0B1) is read. With --rate one sample's answers
// are read before the next is asked. The in-process bench runs at 2 kbit/s,
// so an answer takes some 70 ms of wire time to come: the host has sent the
// next burst long before (an answer already queued would be read, and
// logged, as the next burst goes out).
#[test]
fn back_to_back_the_next_burst_goes_out_before_the_current_answers_are_read() {
    for (rate, ahead) in [(&[][..], true), (&["--rate", "1000"][..], false)] {
        let (_dir, log) = temp("ahead.log");
        let out = common::bin()
            .env("AXISCTL_SIM_WIRE_SPEED", "bitrate=2000")
            .args(["--link", "sim", "--timeout", "2000", "--log", log.to_str().unwrap(), "--json", "record"])
            .args(["-m", "17", "ActPos", "--count", "4"])
            .args(rate)
            .output()
            .unwrap();
        let r = Run {
            code: out.status.code().unwrap_or(-1),
            stdout: String::from_utf8_lossy(&out.stdout).into(),
            stderr: String::from_utf8_lossy(&out.stderr).into(),
        };
        assert_eq!(r.code, 0, "{}", r.stderr);
        assert_eq!(checked_lines(&r).len(), 4);
        let seen: Vec<String> =
            frames(&log).into_iter().filter(|f| f.starts_with("0D1#0A3C") || f.starts_with("0B1#0A3C")).collect();
        let requests_first = seen.iter().take_while(|f| f.starts_with("0D1")).count();
        assert_eq!(requests_first, if ahead { 2 } else { 1 }, "{rate:?}: {seen:?}");
        let answered = seen.iter().filter(|f| f.starts_with("0B1")).count();
        assert!(answered >= 4, "{rate:?}: {seen:?}");
    }
}

#[test]
fn ctrl_c_ends_an_open_ended_recording_without_a_motion_with_exit_0() {
    let mut child = common::bin()
        .args(["--link", "sim", "--json", "record", "-m", "17", "ActPos", "--rate", "100"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut first = String::new();
    out.read_line(&mut first).unwrap();
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).unwrap();
    assert_eq!(wait_bounded(child, 10), 0);
    // Every line written is whole: the signal ends the recording between samples.
    let r = Run { code: 0, stdout: first + &rest, stderr: String::new() };
    assert!(!checked_lines(&r).is_empty());
}

#[test]
fn a_closed_stdout_during_a_recorded_move_halts_it() {
    let sim = Sim::start(&[], 3);
    let link = sim.link("powercube");
    let (_dir, log) = temp("closed.log");
    let (mut child, out) = recording_a_move(link, &log, 3);
    drop(out);
    let err = stderr_of(&mut child);
    let code = wait_bounded(child, 10);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("output failed") && err.contains("module 17 halted"), "{err}");
    assert!(halted_after_motion(&log), "{:?}", frames(&log));
    assert!(cube_17_stands(link));
}

#[test]
fn a_full_disk_never_lets_the_move_start() {
    let (_dir, log) = temp("full.log");
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    let child = common::bin()
        .args(["--link", "sim", "--log", log.to_str().unwrap(), "--json", "record", "-m", "17", "ActPos"])
        .args(["--", "move-vel", "-m", "17", "0.01"])
        .stdout(full)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    assert_eq!(wait_bounded(child, 10), 1);
    assert!(!frames(&log).iter().any(|f| f.starts_with("0F1#0B")), "a motion went out: {:?}", frames(&log));
}

/// `axisctl ARGS` against a served simulator, with an answer timeout far
/// above any answer a loaded machine delays (no timeout is checked here: a
/// late answer must not fail the test), under a deadline.
fn run_served(args: &[&str]) -> Run {
    let mut all = vec!["--timeout", "5000"];
    all.extend_from_slice(args);
    let child = common::bin().args(&all).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    common::wait_bounded(child, 120, &all).run()
}

// The recordings are counted (--count), not timed (--for): their samples
// are due every 50 ms (--rate 20; one that comes late is followed by the
// overdue ones at once), so the last is taken at least 1.95 s after the
// first, however slow the machine. The motion starts after the first
// sample; only an answer more than a second and a half late could leave
// it no time to show in the last.
#[test]
fn served_pac_and_cdios_moves_are_recorded_on_the_same_link() {
    let sim = Sim::start(&[], 3);
    let pac = sim.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"]] {
        let r = run_served(&[&["--link", pac][..], args].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let r = run_served(&[
        "--link", pac, "--json", "record", "--axis", "2", "position", "speed", "--rate", "20", "--count", "40", "--",
        "pac-move", "2", "250",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = checked_lines(&r);
    assert_eq!(lines.len(), 40, "{}", r.stdout);
    let pos = |l: &Value| l["devices"][0]["values"]["position"]["value"].as_f64().unwrap();
    assert_eq!(lines[0]["devices"][0]["axis"], 2);
    assert_eq!(lines[0]["devices"][0]["values"]["position"]["unit"], "AE");
    assert!(pos(lines.last().unwrap()) > pos(&lines[0]), "{}", r.stdout);
    assert!(r.stderr.contains("axis 2 at t = "), "{}", r.stderr);

    let cdios = sim.link("cdios");
    let r = run_served(&["--link", cdios, "cdios-enable", "-m", "0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let r = run_served(&[
        "--link",
        cdios,
        "--json",
        "record",
        "--node",
        "1",
        "-m",
        "0",
        "position",
        "speed",
        "--rate",
        "20",
        "--count",
        "40",
        "--",
        "cdios-goto",
        "-m",
        "0",
        "3000",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = checked_lines(&r);
    assert_eq!(lines.len(), 40, "{}", r.stdout);
    let pos = |l: &Value| l["devices"][0]["values"]["position"]["value"].as_f64().unwrap();
    assert_eq!(lines[0]["devices"][0]["node"], 1);
    assert_eq!(lines[0]["devices"][0]["values"]["speed"]["unit"], "rpm");
    assert!(pos(lines.last().unwrap()) > pos(&lines[0]), "{}", r.stdout);
}

#[test]
fn served_powercube_over_slcan_records_json_lines() {
    let sim = Sim::start(&[], 3);
    let r = run(&[
        "--link",
        sim.link("powercube"),
        "--json",
        "record",
        "-m",
        "3,5,17",
        "ActPos",
        "ActVel",
        "--count",
        "20",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(checked_lines(&r).len(), 20);
}

/// Starts `record` of one served family with a long motion after `--`,
/// reads `n` samples, sends SIGINT; returns the exit code and stderr.
fn interrupt_after(args: &[&str], n: usize) -> (i32, String) {
    let mut child = common::bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    for _ in 0..n {
        let mut line = String::new();
        assert!(out.read_line(&mut line).unwrap() > 0, "the recording ended early");
    }
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let err = stderr_of(&mut child);
    (wait_bounded(child, 15), err)
}

#[test]
fn ctrl_c_during_a_recorded_pac_move_stops_the_axis() {
    let sim = Sim::start(&[], 3);
    let pac = sim.link("pac");
    assert_eq!(run(&["--link", pac, "pac-online"]).code, 0);
    assert_eq!(run(&["--link", pac, "pac-no-ref", "2"]).code, 0);
    let (code, err) = interrupt_after(
        &["--link", pac, "--json", "record", "--axis", "2", "position", "--rate", "10", "--", "pac-move", "2", "9000"],
        4,
    );
    assert_eq!(code, 130, "{err}");
    assert!(err.contains("interrupted: axis 2 stopped"), "{err}");
    // 0A9A decelerates: the axis comes to a standstill well short of the
    // target it would take many seconds to reach.
    let deadline = Instant::now() + Duration::from_secs(5);
    let axis = loop {
        let axis = run(&["--link", pac, "--json", "pac-axis", "2"]).json();
        if axis["axis_status"] != 1 || Instant::now() > deadline {
            break axis;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_ne!(axis["axis_status"], 1, "still moving: {axis}");
    assert!(axis["position"]["value"].as_f64().unwrap() < 5000.0, "{axis}");
}

#[test]
fn ctrl_c_during_a_recorded_cdios_goto_stops_the_motor() {
    let sim = Sim::start(&[], 3);
    let cdios = sim.link("cdios");
    assert_eq!(run(&["--link", cdios, "cdios-enable", "-m", "0"]).code, 0);
    let (code, err) = interrupt_after(
        &[
            "--link",
            cdios,
            "--json",
            "record",
            "--node",
            "1",
            "-m",
            "0",
            "position",
            "--rate",
            "10",
            "--",
            "cdios-goto",
            "-m",
            "0",
            "2000000",
        ],
        4,
    );
    assert_eq!(code, 130, "{err}");
    assert!(err.contains("interrupted: module 0 fast stop sent"), "{err}");
    let pos = |r: Run| r.json()["position"]["value"].as_i64().unwrap_or_else(|| panic!("{}", r.stdout));
    let stopped_at = pos(run(&["--link", cdios, "--json", "cdios-position", "-m", "0"]));
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(pos(run(&["--link", cdios, "--json", "cdios-position", "-m", "0"])), stopped_at, "still running");
}
