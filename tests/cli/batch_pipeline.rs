//! `axisctl batch` pipelines consecutive PowerCube `get-param` lines on a
//! CAN link: their requests leave in one burst. Through the real binary:
//! the output is the one-shots' output byte for byte, each line sends the
//! frames its one-shot sends, and a failure in the middle of a group is
//! reported as the line alone would report it.

use crate::common;

use std::io::Write;
use std::path::Path;
use std::process::Stdio;

use common::{bin, run_with_stdin, Run, Sim};
use serde_json::{json, Value};

/// `axisctl GLOBAL LINE` as a one-shot process.
fn one_shot(global: &[&str], line: &str) -> Run {
    let args: Vec<&str> = global.iter().copied().chain(line.split_whitespace()).collect();
    common::run(&args)
}

/// Reads of several modules, rotary and linear (17), one or more
/// parameters, one module or a list, and states; the measurement (its
/// firmware version is read first) and `info` run on their own in between.
const LINES: [&str; 10] = [
    "get-param -m 3 ActPos",
    "get-param -m 17 ActPos ActVel",
    "state -m 5",
    "get-param -m 3,5,17 ActPos Config",
    "state -m 17,3",
    "get-param -m 5 MaxPos MinPos",
    "get-param -m 5 ActFTemp",
    "get-param -m 17,3 MaxVel",
    "info -m 3",
    "state -m 3",
];

fn script(lines: &[&str]) -> String {
    lines.iter().map(|l| format!("{l}\n")).collect()
}

fn json_lines(stdout: &str) -> Vec<Value> {
    stdout.lines().map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not a JSON line ({e}): {l}"))).collect()
}

/// The batch's stdout against the one-shots', human and `--json`.
fn assert_same_as_one_shots(link: &str) {
    let r = run_with_stdin(&["--link", link, "batch", "-"], &script(&LINES));
    assert_eq!(r.code, 0, "{}", r.stderr);
    let mut alone = String::new();
    for line in LINES {
        let o = one_shot(&["--link", link], line);
        assert_eq!(o.code, 0, "{line}: {}", o.stderr);
        alone.push_str(&o.stdout);
    }
    assert_eq!(r.stdout, alone);
    assert!(r.stdout.contains(" m\n") && r.stdout.contains(" rad\n"), "linear and rotary units: {}", r.stdout);

    let r = run_with_stdin(&["--link", link, "--json", "batch", "-"], &script(&LINES));
    assert_eq!(r.code, 0, "{}", r.stderr);
    let got = json_lines(&r.stdout);
    assert_eq!(got.len(), LINES.len(), "{}", r.stdout);
    for (i, (line, g)) in LINES.iter().zip(&got).enumerate() {
        let o = one_shot(&["--link", link, "--json"], line);
        // The command as reported is quoted where it needs it (`'3,5,17'`).
        let want = json!({"line": i + 1, "command": g["command"], "result": o.json()});
        assert_eq!(g, &want, "line {}", i + 1);
    }
    assert_eq!(got[1]["result"]["params"]["ActPos"]["unit"], "m");
    assert_eq!(got[3]["result"]["devices"][0]["params"]["ActPos"]["unit"], "rad");
    assert_eq!(got[4]["result"]["devices"][1]["module"], 17, "in id order");
}

/// Groups that start after line 1 (issue 22, item 9): lines 2 to 5 and 7
/// to 8, each read answering with another value (MaxVel, MaxAcc, MinPos of
/// three modules), so that a line shown from another line's answers, or a
/// group's answers counted from line 1, prints a value its one-shot does
/// not.
const LATER: [&str; 8] = [
    "info -m 3",
    "get-param -m 17 MaxVel",
    "get-param -m 3 MaxAcc",
    "state -m 5",
    "get-param -m 5 MaxVel MinPos",
    "get-config -m 3",
    "get-param -m 3 MaxVel",
    "get-param -m 17 MaxAcc ActPos",
];

#[test]
fn groups_that_start_after_line_1_show_each_line_from_its_own_answers() {
    for link in ["sim", "sim-served"] {
        let sim = (link == "sim-served").then(|| Sim::start(&["--powercube", "pty-slcan"], 1));
        let link = sim.as_ref().map_or("sim", |s| s.link("powercube"));
        let r = run_with_stdin(&["--link", link, "batch", "-"], &script(&LATER));
        assert_eq!(r.code, 0, "{}", r.stderr);
        let alone: String = LATER.iter().map(|l| one_shot(&["--link", link], l).stdout).collect();
        assert_eq!(r.stdout, alone);
        let r = run_with_stdin(&["--link", link, "--json", "batch", "-"], &script(&LATER));
        let got = json_lines(&r.stdout);
        assert_eq!(got.len(), LATER.len(), "{}", r.stdout);
        for (i, (line, g)) in LATER.iter().zip(&got).enumerate() {
            let want =
                json!({"line": i + 1, "command": line, "result": one_shot(&["--link", link, "--json"], line).json()});
            assert_eq!(g, &want, "line {}", i + 1);
        }
        let values: Vec<&Value> = [(1, "MaxVel"), (2, "MaxAcc"), (6, "MaxVel"), (7, "MaxAcc")]
            .iter()
            .map(|(i, p)| &got[*i]["result"]["params"][*p]["value"])
            .collect();
        let mut distinct = values.clone();
        distinct.dedup();
        assert_eq!(distinct.len(), values.len(), "the reads answer with different values: {values:?}");
    }
}

#[test]
fn pipelined_lines_print_what_the_one_shots_print() {
    assert_same_as_one_shots("sim");
}

#[test]
fn pipelined_lines_on_a_served_slcan_link_print_what_the_one_shots_print() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    assert_same_as_one_shots(sim.link("powercube"));
}

/// The frames of a `--log` traffic log, as `ID#DATA`.
fn frames(log: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines().filter_map(|l| l.split_whitespace().nth(2).map(str::to_string)).collect()
}

/// A PowerCube acknowledge (`0x0A0 + M`), not a request.
fn is_answer(frame: &str) -> bool {
    let id = u32::from_str_radix(frame.split('#').next().unwrap(), 16).unwrap();
    id & !0x1f == 0x0a0
}

fn sent(frames: &[String]) -> Vec<String> {
    frames.iter().filter(|f| !is_answer(f)).cloned().collect()
}

// The group sent ahead is the one read next: its burst is not sent again
// on a new session (a mutant of that match sent the second group twice).
#[test]
fn a_group_sent_ahead_is_not_sent_again() {
    let dir = tempfile::tempdir().unwrap();
    // 20 lines of two requests: a group of 16 (32 requests), then one of 4.
    let lines = ["get-param -m 3 ActPos"; 20];
    let log = dir.path().join("batch.log");
    let r = run_with_stdin(&["--link", "sim", "--log", log.to_str().unwrap(), "batch", "-"], &script(&lines));
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.matches("ActPos ").count(), 20, "{}", r.stdout);
    assert_eq!(sent(&frames(&log)).len(), 40, "each line's two requests, once");
}

#[test]
fn a_group_s_requests_leave_before_its_first_answer_and_each_line_sends_its_one_shot_frames() {
    let dir = tempfile::tempdir().unwrap();
    let lines = ["get-param -m 3 ActPos", "get-param -m 17 ActPos ActVel", "state -m 5", "get-param -m 3 ActPos"];
    let log = dir.path().join("batch.log");
    let r = run_with_stdin(&["--link", "sim", "--log", log.to_str().unwrap(), "batch", "-"], &script(&lines));
    assert_eq!(r.code, 0, "{}", r.stderr);
    let got = frames(&log);
    let first_answer = got.iter().position(|f| is_answer(f)).expect("answers");
    // One line alone sends 1 to 3 requests, then waits for their answers.
    assert_eq!(first_answer, 8, "every request of the group leaves before the first answer: {got:?}");

    let mut alone = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let log = dir.path().join(format!("alone{i}.log"));
        let o = one_shot(&["--link", "sim", "--log", log.to_str().unwrap()], line);
        assert_eq!(o.code, 0, "{}", o.stderr);
        alone.extend(frames(&log));
    }
    assert_eq!(sent(&got), sent(&alone), "the same requests, the Config read of each line included");
    assert_eq!(got.len(), alone.len(), "and as many answers: {got:?}");
}

#[test]
fn an_absent_module_fails_its_line_as_alone_and_stops_the_rest_unless_keep_going() {
    let lines = ["get-param -m 3 ActPos", "get-param -m 9 ActPos", "get-param -m 17 ActPos"];
    let global = ["--link", "sim", "--timeout", "20", "--retries", "1"];
    let alone = one_shot(&global, lines[1]);
    assert_eq!(alone.code, 4, "{}", alone.stderr);
    let message = alone.stderr.trim().strip_prefix("axisctl: ").unwrap();

    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("stopped.log");
    let args: Vec<&str> = global.iter().copied().chain(["--log", log.to_str().unwrap(), "batch", "-"]).collect();
    let r = run_with_stdin(&args, &script(&lines));
    assert_eq!(r.code, alone.code, "{}", r.stderr);
    assert_eq!(r.stdout, one_shot(&global, lines[0]).stdout, "line 3 was read but prints nothing");
    assert_eq!(r.stderr, format!("axisctl: line 2 ({}): {message}\n", lines[1]));
    assert!(frames(&log).iter().any(|f| f == "0D1#0A3C"), "line 3's read went out in the burst");

    let log = dir.path().join("batch.log");
    let args: Vec<&str> =
        global.iter().copied().chain(["--log", log.to_str().unwrap(), "batch", "--keep-going", "-"]).collect();
    let r = run_with_stdin(&args, &script(&lines));
    assert_eq!(r.code, alone.code, "{}", r.stderr);
    assert_eq!(r.stdout, one_shot(&global, lines[0]).stdout + &one_shot(&global, lines[2]).stdout);
    assert_eq!(r.stderr, format!("axisctl: line 2 ({}): {message}\n", lines[1]));
    // The unanswered read went out once in the burst and once more on its own
    // (--retries 1), as alone; the other lines' frames once each.
    let mut want = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let log = dir.path().join(format!("alone{i}.log"));
        let args: Vec<&str> = global.iter().copied().chain(["--log", log.to_str().unwrap()]).collect();
        one_shot(&args, line);
        want.extend(frames(&log));
    }
    let (mut got, mut want) = (frames(&log), want);
    got.sort();
    want.sort();
    assert_eq!(got, want);
    assert_eq!(got.iter().filter(|f| f.starts_with("0C9#0A3C")).count(), 2, "{got:?}");
}

#[test]
fn a_failure_in_the_middle_of_a_group_follows_the_schema_under_json() {
    let v = common::schema("batch_line");
    let lines = ["get-param -m 3 ActPos", "get-param -m 5,9 ActPos", "get-param -m 17 ActPos"];
    let global = ["--link", "sim", "--json", "--timeout", "20"];
    let alone = one_shot(&global, lines[1]);
    assert_eq!(alone.code, 4);

    let args: Vec<&str> = global.iter().copied().chain(["batch", "-"]).collect();
    let r = run_with_stdin(&args, &script(&lines));
    assert_eq!(r.code, 4, "{}", r.stderr);
    let got = json_lines(&r.stdout);
    assert_eq!(got.len(), 2, "line 3 prints nothing: {}", r.stdout);
    for l in &got {
        assert_eq!(common::schema_errors(&v, l), None, "{l}");
    }
    let alone: Value = serde_json::from_str(&alone.stderr).expect("the error object");
    assert_eq!(got[1], json!({"line": 2, "command": "get-param -m '5,9' ActPos", "error": alone["error"]}));
    assert_eq!(got[1]["error"]["module"], 9);

    let args: Vec<&str> = global.iter().copied().chain(["batch", "--keep-going", "-"]).collect();
    let r = run_with_stdin(&args, &script(&lines));
    assert_eq!(r.code, 4, "{}", r.stderr);
    let got = json_lines(&r.stdout);
    assert_eq!(got.len(), 3, "{}", r.stdout);
    for l in &got {
        assert_eq!(common::schema_errors(&v, l), None, "{l}");
    }
    assert_eq!(got[2]["result"], one_shot(&global, lines[2]).json());
}

#[test]
fn lines_on_rs232_run_one_at_a_time() {
    // A PowerCube on a serial line is half-duplex: nothing to pipeline, and
    // the output is still the one-shots'.
    let sim = Sim::start(&["--powercube", "pty-serial"], 1);
    let link = sim.link("powercube");
    let lines = ["get-param -m 3 ActPos", "get-param -m 17 ActPos"];
    let r = run_with_stdin(&["--link", link, "batch", "-"], &script(&lines));
    assert_eq!(r.code, 0, "{}", r.stderr);
    let alone: String = lines.iter().map(|l| one_shot(&["--link", link], l).stdout).collect();
    assert_eq!(r.stdout, alone);
}

#[test]
fn a_signal_stops_pipelined_reads_after_the_line_that_was_shown() {
    // At wire speed 20000 lines take seconds: the signal comes while bursts go out.
    let sim = Sim::start(&["--powercube", "pty-slcan", "--wire-speed"], 1);
    let mut child = bin()
        .args(["--link", sim.link("powercube"), "batch", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Written beside the run: the batch reads its lines as it runs them.
    let mut stdin = child.stdin.take().unwrap();
    let text = script(&["get-param -m 3 ActPos"; 20_000]);
    std::thread::spawn(move || drop(stdin.write_all(text.as_bytes())));
    let mut out = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut shown = 0;
    let mut line = String::new();
    while shown < 40 {
        line.clear();
        assert!(std::io::BufRead::read_line(&mut out, &mut line).unwrap() > 0, "the batch ended early");
        shown += usize::from(line.starts_with("ActPos"));
    }
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut out, &mut rest).unwrap();
    shown += rest.lines().filter(|l| l.starts_with("ActPos")).count();
    let ended = common::wait_bounded(child, 20, &["batch"]);
    assert_eq!(ended.code, 130, "{}", ended.stderr);
    let after: usize = ended
        .stderr
        .split("after line ")
        .nth(1)
        .and_then(|s| s.split(';').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{}", ended.stderr));
    assert_eq!(shown, after, "every line up to the stop was shown, none after it: {}", ended.stderr);
    assert!(after < 20_000, "{}", ended.stderr);
}

// A group that follows another at once goes out before the first group's
// answers are read (the bus stays busy while its lines are shown); the
// lines still print what their one-shots print, across every group. The
// bench runs at 5 kbit/s so that no answer is back before the next group
// leaves (at once, the answers would already wait when it goes).
#[test]
fn the_next_group_goes_out_before_this_one_is_read_and_every_line_prints_as_alone() {
    let gp = "get-param -m 3,5,17 ActPos ActVel MaxVel";
    let lines: Vec<&str> = [gp, "state -m 17,3"].iter().copied().cycle().take(12).collect();
    let alone: String = lines.iter().map(|l| one_shot(&["--link", "sim"], l).stdout).collect();
    let r = run_with_stdin(&["--link", "sim", "batch", "-"], &script(&lines));
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout, alone);

    // 12 + 12 requests, then 12 + 2 in the next group.
    let sent_first = |lines: &[&str]| {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("ahead.log");
        let out = bin()
            .env("AXISCTL_SIM_WIRE_SPEED", "bitrate=5000")
            .args(["--link", "sim", "--timeout", "5000", "--log", log.to_str().unwrap(), "batch", "-"])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .and_then(|mut child| {
                child.stdin.take().unwrap().write_all(script(lines).as_bytes())?;
                child.wait_with_output()
            })
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let got = frames(&log);
        (got.iter().position(|f| is_answer(f)), got)
    };
    let (first_answer, got) = sent_first(&[gp, gp, gp, "state -m 17,3"]);
    assert_eq!(first_answer, Some(24 + 14), "the second group left before the first answer: {got:?}");
    // A line that runs on its own between two groups: the second waits.
    let (first_answer, got) = sent_first(&[gp, gp, "info -m 3", gp, "state -m 17,3"]);
    assert_eq!(first_answer, Some(24), "{got:?}");
}
