//! `axisctl batch`: many command lines, one process, one open link; its
//! JSON Lines, its exit codes, and the halt of everything it moved when a
//! signal ends it. Through the real binary, on `--link sim` and on served
//! simulators.

use crate::common;

use std::io::{BufRead, BufReader, Write};
use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use axisctl::link::ByteLink;
use common::{bin, run_with_stdin, Sim};
use serde_json::Value;

fn script(text: &str) -> tempfile::NamedTempFile {
    let mut f = tempfile::NamedTempFile::new().unwrap();
    f.write_all(text.as_bytes()).unwrap();
    f
}

fn lines(stdout: &str) -> Vec<Value> {
    stdout.lines().map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("not a JSON line ({e}): {l}"))).collect()
}

/// The validator of `$defs/batch_line` in the published schema.
fn batch_line_schema() -> jsonschema::Validator {
    common::schema("batch_line")
}

fn assert_valid(v: &jsonschema::Validator, line: &Value) {
    if let Some(e) = common::schema_errors(v, line) {
        panic!("{line} breaks $defs/batch_line:\n{e}");
    }
}

#[test]
fn a_file_runs_line_by_line_on_one_bench() {
    // The home of line 2 is what line 4 reads: the lines share one bench.
    let f = script("# a commissioning step\nreset -m 17\nhome -m 17 --wait\n\nstate -m 17   # HOME_OK now\n");
    let r = common::run(&["--link", "sim", "batch", f.path().to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("home done"), "{}", r.stdout);
    assert!(r.stdout.contains("STATE_HOME_OK"), "{}", r.stdout);
    assert!(r.stderr.is_empty(), "{}", r.stderr);
}

#[test]
fn json_lines_from_stdin_follow_the_schema_and_the_docs() {
    let v = batch_line_schema();
    let r = run_with_stdin(
        &["--link", "sim", "--json", "--timeout", "20", "batch", "--keep-going", "-"],
        "get-param -m 17 ActPos\nhalt -m 17\nstate -m 9   # no such module\n",
    );
    assert_eq!(r.code, 4, "the first failure's code (a timeout): {}", r.stderr);
    let got = lines(&r.stdout);
    assert_eq!(got.len(), 3, "{}", r.stdout);
    for (i, l) in got.iter().enumerate() {
        assert_valid(&v, l);
        assert_eq!(l["line"], i + 1);
    }
    assert_eq!(got[0]["command"], "get-param -m 17 ActPos");
    assert_eq!(got[0]["result"]["params"]["ActPos"]["unit"], "m");
    assert_eq!(got[1]["result"]["acknowledged"], true);
    assert_eq!(got[2]["command"], "state -m 9", "without the comment");
    assert_eq!(got[2]["error"]["kind"], "timeout");
    assert_eq!(got[2]["error"]["module"], 9);
    // The documented lines (docs/json.md, batch) have the real shapes.
    let md = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/json.md")).unwrap();
    let section = md.split("<!-- batch lines -->").nth(1).expect("docs/json.md documents the batch lines");
    let documented: Vec<Value> = section
        .lines()
        .skip_while(|l| l.trim() != "```jsonl")
        .skip(1)
        .take_while(|l| l.trim() != "```")
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(documented.len(), got.len());
    for (d, g) in documented.iter().zip(&got) {
        assert_valid(&v, d);
        assert_eq!(keys(d), keys(g), "{d} against {g}");
    }
}

/// The keys, recursively, as dotted paths.
fn keys(v: &Value) -> Vec<String> {
    let mut out = Vec::new();
    fn walk(v: &Value, at: &str, out: &mut Vec<String>) {
        if let Value::Object(m) = v {
            for (k, x) in m {
                let p = format!("{at}.{k}");
                out.push(p.clone());
                walk(x, &p, out);
            }
        }
    }
    walk(v, "$", &mut out);
    out
}

#[test]
fn the_first_failure_stops_the_batch_unless_keep_going() {
    let text = "get-param -m 17 ActPos\nstate -m 9\nget-param -m 3 ActPos\n";
    let r = run_with_stdin(&["--link", "sim", "--json", "--timeout", "20", "batch"], text);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let got = lines(&r.stdout);
    assert_eq!(got.len(), 2, "line 3 never ran: {}", r.stdout);
    assert_eq!(got[1]["error"]["exit_code"], 4);

    let r = run_with_stdin(&["--link", "sim", "--json", "--timeout", "20", "batch", "--keep-going"], text);
    assert_eq!(r.code, 4, "still the first failure's code: {}", r.stderr);
    let got = lines(&r.stdout);
    assert_eq!(got.len(), 3, "{}", r.stdout);
    assert_eq!(got[2]["result"]["module"], 3);

    // Without --json the failure is said on stderr with its line.
    let r = run_with_stdin(&["--link", "sim", "--timeout", "20", "batch"], text);
    assert_eq!(r.code, 4);
    assert!(r.stderr.contains("line 2 (state -m 9): no answer from module 9"), "{}", r.stderr);
}

#[test]
fn a_bad_line_anywhere_runs_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let text =
        "move-ramp -m 17 0.1\nget-param -m 17 ActPos\nmove-rmap -m 17 0.2\nget-param -m 40 ActPos\n'unbalanced\n";
    let r = run_with_stdin(&["--link", "sim", "--json", "--log", log.to_str().unwrap(), "batch"], text);
    assert_eq!(r.code, 2, "{}", r.stderr);
    let got = lines(&r.stdout);
    let v = batch_line_schema();
    got.iter().for_each(|l| assert_valid(&v, l));
    let bad: Vec<u64> = got.iter().map(|l| l["line"].as_u64().unwrap()).collect();
    assert_eq!(bad, [3, 4, 5], "every bad line is named: {}", r.stdout);
    assert!(got.iter().all(|l| l["error"]["kind"] == "usage"));
    assert!(got[0]["error"]["message"].as_str().unwrap().contains("move-ramp"), "a suggestion: {}", got[0]);
    assert_eq!(got[1]["error"]["argument"], "--module <ID[,ID...]|all>");
    let sent = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(sent.is_empty(), "nothing was sent: {sent}");
}

#[test]
fn lines_that_cannot_run_in_a_batch_and_options_on_a_line_are_refused() {
    let lines = [
        "dashboard",
        "sim",
        "batch",
        "shell",
        "commission --out c --yes",
        "get-param -m 17 ActPos --timeout 5",
        "--json scan",
    ];
    for line in lines {
        let r = run_with_stdin(&["--link", "sim", "batch"], &format!("get-param -m 17 ActPos\n{line}\n"));
        assert_eq!(r.code, 2, "{line}: {}", r.stderr);
        assert!(r.stdout.is_empty(), "line 1 did not run either: {}", r.stdout);
        assert!(r.stderr.contains("line 2"), "{line}: {}", r.stderr);
    }
    let r = common::run(&["--link", "sim", "batch", "/nonexistent/commands.txt"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
}

#[test]
fn help_lines_print_the_help_and_offline_lines_need_no_link() {
    let r = run_with_stdin(&["batch"], "decode cube-state 0x02\nhelp get-param\n");
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("STATE_HOME_OK"), "{}", r.stdout);
    assert!(r.stdout.contains("Usage: axisctl get-param"), "{}", r.stdout);
}

/// A pty that plays an slcan adapter that never answers: everything the
/// batch writes is collected, so the adapter's setup can be counted.
struct FakeAdapter {
    path: String,
    stop: Arc<AtomicBool>,
    reader: std::thread::JoinHandle<Vec<u8>>,
}

impl FakeAdapter {
    fn start() -> Self {
        let (mut master, path) = axisctl::link::pty::open_pair().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = Arc::clone(&stop);
        let reader = std::thread::spawn(move || {
            let mut got = Vec::new();
            let mut buf = [0u8; 4096];
            while !flag.load(Ordering::SeqCst) {
                if let Ok(n) = master.read(&mut buf, Duration::from_millis(20)) {
                    got.extend_from_slice(&buf[..n]);
                }
            }
            got
        });
        Self { path, stop, reader }
    }

    fn written(self) -> String {
        std::thread::sleep(Duration::from_millis(100));
        self.stop.store(true, Ordering::SeqCst);
        String::from_utf8_lossy(&self.reader.join().unwrap()).into_owned()
    }
}

#[test]
fn the_link_is_opened_once_for_every_line() {
    let adapter = FakeAdapter::start();
    let link = format!("slcan:{}", adapter.path);
    let r = run_with_stdin(
        &["--link", &link, "--timeout", "5", "--retries", "0", "batch", "--keep-going"],
        "state -m 17\nstate -m 3\nget-param -m 5 ActPos\n",
    );
    assert_eq!(r.code, 4, "nothing answers: {}", r.stderr);
    assert_eq!(r.stderr.matches("no answer").count(), 3, "every line ran: {}", r.stderr);
    let written = adapter.written();
    // The adapter's setup (close, bitrate, open) goes out once: one open.
    assert_eq!(written.matches("O\r").count(), 1, "{written:?}");
    assert_eq!(written.matches("S8\r").count(), 1, "{written:?}");
    assert!(written.matches("\rt").count() >= 3, "three requests: {written:?}");
}

#[test]
fn served_simulators_keep_their_state_between_lines() {
    let sim = Sim::start(&[], 3);
    let (pc, pac) = (sim.link("powercube"), sim.link("pac"));
    let v = batch_line_schema();
    let text = "reset -m 17\nhome -m 17 --wait\nmove-ramp -m 17 0.05 --vel 0.05 --wait\nget-param -m 17 ActPos\n";
    let r = run_with_stdin(&["--link", pc, "--json", "batch"], text);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let got = lines(&r.stdout);
    got.iter().for_each(|l| assert_valid(&v, l));
    let pos = got[3]["result"]["params"]["ActPos"]["value"].as_f64().unwrap();
    assert!((pos - 0.05).abs() < 1e-3, "{}", got[3]);

    let r = run_with_stdin(&["--link", pac, "--json", "batch"], "pac-state\npac-axis 2\npac-axes\n");
    assert_eq!(r.code, 0, "{}", r.stderr);
    let got = lines(&r.stdout);
    assert_eq!(got.len(), 3);
    got.iter().for_each(|l| assert_valid(&v, l));
    assert_eq!(got[1]["result"]["axis"], 2);
}

/// Starts a batch on the served PowerCube link and waits until it printed
/// `acks` acknowledgements (the moves of its first lines are out).
fn start_moving(sim: &Sim, text: &str, acks: usize) -> (Child, Vec<String>) {
    start_on(sim.link("powercube"), text, "acknowledged", acks)
}

/// Starts a batch on `link` and waits until `n` lines of its output say `marker`.
fn start_on(link: &str, text: &str, marker: &str, n: usize) -> (Child, Vec<String>) {
    let mut child = bin()
        .args(["--link", link, "batch", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    feed(&mut child, text);
    let mut out = BufReader::new(child.stdout.take().unwrap()).lines();
    let mut seen = Vec::new();
    while seen.iter().filter(|l: &&String| l.contains(marker)).count() < n {
        seen.push(out.next().expect("batch output").unwrap());
    }
    // The rest is read on, as a terminal would: a closed pipe is a stop of its own.
    std::thread::spawn(move || out.for_each(drop));
    (child, seen)
}

/// Writes the batch's input beside it: the batch reads it as it runs.
fn feed(child: &mut Child, text: &str) {
    let (mut input, text) = (child.stdin.take().unwrap(), text.to_string());
    std::thread::spawn(move || drop(input.write_all(text.as_bytes())));
}

fn state(sim: &Sim, m: &str) -> Value {
    let r = common::run(&["--link", sim.link("powercube"), "--json", "state", "-m", m]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    r.json()["state"].clone()
}

fn wait_exit(child: &mut Child) -> (i32, String) {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
            return (status.code().unwrap_or(-1), err);
        }
        assert!(Instant::now() < deadline, "the batch did not end");
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[test]
fn a_signal_halts_every_device_the_batch_moved() {
    for (sig, code) in [(libc::SIGINT, 130), (libc::SIGTERM, 143)] {
        let sim = Sim::start(&[], 3);
        // Lines 1 and 2 start moves without waiting; line 3 waits on a slow one.
        let text = "move-ramp -m 17 0.5 --vel 0.01\nmove-vel -m 3 0.1\nmove-ramp -m 5 3 --vel 0.01 --wait\nget-param -m 3 ActPos\n";
        let (mut child, _) = start_moving(&sim, text, 2);
        std::thread::sleep(Duration::from_millis(300));
        unsafe { libc::kill(child.id() as i32, sig) };
        let (got, err) = wait_exit(&mut child);
        assert_eq!(got, code, "{err}");
        assert!(err.contains("halted: `halt -m 17`, `halt -m 3`, `halt -m 5`"), "{err}");
        for m in ["17", "3", "5"] {
            let s = state(&sim, m);
            assert!(s["flags"].as_array().unwrap().iter().any(|f| f == "STATE_HALTED"), "module {m}: {s}");
            assert!(!s["flags"].as_array().unwrap().iter().any(|f| f == "STATE_MOTION"), "module {m}: {s}");
        }
    }
}

// A batch holds its port for its whole life; `halt` from another terminal
// takes it over as from any holder: the batch halts what it moved, exits
// 143 and lets go, and the halt goes out.
#[test]
fn an_emergency_halt_from_another_terminal_ends_a_batch_that_holds_the_port() {
    let sim = Sim::start(&[], 3);
    let text = "move-vel -m 3 0.1\nmove-ramp -m 5 3 --vel 0.01 --wait\nget-param -m 3 ActPos\n";
    let (mut child, _) = start_moving(&sim, text, 1);
    std::thread::sleep(Duration::from_millis(300));
    let r = common::run(&["--link", sim.link("powercube"), "--json", "halt", "-m", "3"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["holder"]["pid"], child.id(), "{}", r.stdout);
    let (code, err) = wait_exit(&mut child);
    assert_eq!(code, 143, "{err}");
    assert!(err.contains("halted: `halt -m 3`, `halt -m 5`"), "{err}");
    for m in ["3", "5"] {
        let s = state(&sim, m);
        assert!(!s["flags"].as_array().unwrap().iter().any(|f| f == "STATE_MOTION"), "module {m}: {s}");
    }
}

/// Reads `what` every 200 ms until two reads agree (the device stands; a
/// stop may decelerate first), for at most 5 s; the value it stands at.
fn comes_to_rest(link: &str, what: &[&str], pointer: &str) -> Value {
    let read = || {
        let r = common::run(&[&["--link", link, "--json"], what].concat());
        assert_eq!(r.code, 0, "{}", r.stderr);
        r.json().pointer(pointer).cloned().unwrap_or(Value::Null)
    };
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut last = read();
    loop {
        std::thread::sleep(Duration::from_millis(200));
        let now = read();
        if now == last {
            return now;
        }
        assert!(Instant::now() < deadline, "{what:?} still changing: {last} then {now}");
        last = now;
    }
}

#[test]
fn a_signal_halts_the_pac_axes_and_cdios_motors_the_batch_moved() {
    let sim = Sim::start(&[], 3);
    // Cdios: a motor started at speed (no end), then a PowerCube wait.
    let text =
        "cdios-enable -m 0\ncdios-start -m 0 --option to-speed --speed 1200\nmove-ramp -m 5 3 --vel 0.01 --wait\n";
    let (mut child, _) = start_on(sim.link("cdios"), text, "confirmed", 2);
    std::thread::sleep(Duration::from_millis(300));
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let (code, err) = wait_exit(&mut child);
    assert_eq!(code, 130, "{err}");
    assert!(err.contains("halted: `cdios-stop --node 1 -m 0 --option fast`, `halt -m 5`"), "{err}");
    comes_to_rest(sim.link("cdios"), &["cdios-position", "-m", "0"], "/position");

    // PA-CONTROL: axis 2 sent off without a wait; reads follow.
    let text = format!("pac-online\npac-ref 2 --wait\npac-move 2 900\n{}", "pac-state\n".repeat(20_000));
    let (mut child, seen) = start_on(sim.link("pac"), &text, "AE", 2);
    std::thread::sleep(Duration::from_millis(100));
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let (code, err) = wait_exit(&mut child);
    assert_eq!(code, 143, "{seen:?} {err}");
    assert!(err.contains("halted: `pac-stop`, `pac-stop-axis 2`\n"), "{err}");
    let at = comes_to_rest(sim.link("pac"), &["pac-axis", "2"], "/position/value");
    assert!(at.as_f64().unwrap() < 900.0, "axis 2 was stopped on its way: {at} ({seen:?} {err})");
}

// A device the batch cannot reach for its halt (a Cdios line on a
// PA-CONTROL line failed, yet it counts as a motion line) is named with the
// reason; the other halts still go out.
#[test]
fn a_halt_that_cannot_reach_its_device_says_why_and_the_others_still_go_out() {
    let sim = Sim::start(&[], 3);
    let text =
        format!("pac-online\npac-no-ref 2\ncdios-goto -m 0 100\npac-move 2 9000\n{}", "pac-state\n".repeat(20_000));
    let mut child = bin()
        .args(["--link", sim.link("pac"), "batch", "--keep-going", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    feed(&mut child, &text);
    let mut out = BufReader::new(child.stdout.take().unwrap()).lines();
    while !out.next().expect("batch output").unwrap().contains("0A94 started") {}
    std::thread::spawn(move || out.for_each(drop));
    std::thread::sleep(Duration::from_millis(100));
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let (code, err) = wait_exit(&mut child);
    assert_eq!(code, 143, "{err}");
    let failed = format!(
        "halted: `pac-stop`, `cdios-stop --node 1 -m 0 --option fast` failed: {} is a serial link; the Cdios is on \
         CAN (socketcan:, slcan:, socketcand: or sim), `pac-stop-axis 2`\n",
        sim.link("pac")
    );
    assert!(err.contains(&failed), "{err}");
    let at = comes_to_rest(sim.link("pac"), &["pac-axis", "2"], "/position/value");
    assert!(at.as_f64().unwrap() < 9000.0, "axis 2 was stopped on its way: {at} ({err})");
}

fn flags(s: &Value) -> Vec<String> {
    s["flags"].as_array().unwrap().iter().map(|f| f.as_str().unwrap().to_string()).collect()
}

// Issue 22, item 3: a batch that stops on a failed line (a read that times
// out, a target out of range found when its line runs) halts what its
// earlier lines moved, since the `halt` further down will not run. The
// state is read after the batch has ended: module 3 stands, halted. No read
// retry makes the absent module fail fast (one timeout) without a short
// timeout that a loaded machine could trip on the lines before it.
#[test]
fn a_failed_line_halts_what_the_earlier_lines_moved() {
    let sim = Sim::start(&[], 3);
    let v = batch_line_schema();
    for (failing, code) in [("get-param -m 9 ActPos", 4), ("move-ramp -m 3 99", 2)] {
        let text = format!("reset -m 3\nmove-vel -m 3 0.2\n{failing}\nhalt -m 3\n");
        let r = run_with_stdin(&["--link", sim.link("powercube"), "--retries", "0", "batch", "-"], &text);
        assert_eq!(r.code, code, "{failing}: {}", r.stderr);
        assert!(r.stderr.ends_with("axisctl: stopped after line 3 failed; halted: `halt -m 3`\n"), "{}", r.stderr);
        let s = state(&sim, "3");
        assert!(flags(&s).contains(&"STATE_HALTED".into()), "{failing}: {s}");
        assert!(!flags(&s).contains(&"STATE_MOTION".into()), "{failing}: {s}");

        let r = run_with_stdin(&["--link", sim.link("powercube"), "--json", "--retries", "0", "batch", "-"], &text);
        assert_eq!(r.code, code, "{}", r.stderr);
        let got = lines(&r.stdout);
        got.iter().for_each(|l| assert_valid(&v, l));
        assert_eq!(got.len(), 4, "{}", r.stdout);
        assert_eq!(got[3], serde_json::json!({"line": 3, "command": null, "halted": [{"stop": "halt -m 3"}]}));
        assert!(!flags(&state(&sim, "3")).contains(&"STATE_MOTION".into()));
    }
}

// --keep-going runs on past a failure and halts nothing: the last message
// (and JSON line) names what may still move, and the exit code is the
// first failure's.
#[test]
fn keep_going_halts_nothing_and_names_what_may_still_move() {
    let sim = Sim::start(&[], 3);
    let text = "reset -m 3\nmove-vel -m 3 0.2\nget-param -m 9 ActPos\nstate -m 3\n";
    let args = ["--link", sim.link("powercube"), "--retries", "0", "batch", "--keep-going", "-"];
    let r = run_with_stdin(&args, text);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(
        r.stderr.ends_with(
            "axisctl: --keep-going ran every line past a failure; not halted, may still move: `halt -m 3`\n"
        ),
        "{}",
        r.stderr
    );
    assert!(flags(&state(&sim, "3")).contains(&"STATE_MOTION".into()), "left moving, as the batch said");

    let r = run_with_stdin(&[&args[..4], &["--json"], &args[4..]].concat(), text);
    let got = lines(&r.stdout);
    got.iter().for_each(|l| assert_valid(&batch_line_schema(), l));
    assert_eq!(got.last().unwrap(), &serde_json::json!({"line": 4, "command": null, "may_move": ["halt -m 3"]}));
    // A batch without a failure says nothing of what it left moving.
    // (Only the warning that module 5 was never homed.)
    let r = run_with_stdin(&args, "move-vel -m 5 0.1\n");
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.lines().all(|l| l.contains("was not homed")), "{}", r.stderr);
}

// A batch longer than one window (10 000 lines) is parsed and run a window
// at a time: the first window runs before the second is read; a bad line in
// the second stops the batch before any of its lines, and what the first
// moved is halted.
#[test]
fn a_long_batch_runs_by_windows_and_a_bad_line_in_a_later_one_halts_the_earlier_moves() {
    let sim = Sim::start(&[], 3);
    let text = format!("reset -m 3\nmove-vel -m 3 0.2\n{}no-such-command\nhalt -m 5\n", "# pad\n".repeat(9_998));
    let r = run_with_stdin(&["--link", sim.link("powercube"), "batch", "-"], &text);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stdout.contains("FVEL_MODE 0.2 acknowledged"), "the first window ran: {}", r.stdout);
    assert!(r.stderr.contains("axisctl: line 10001 (no-such-command): "), "{}", r.stderr);
    assert!(
        r.stderr.ends_with(
            "axisctl: lines after 2 were not run: fix the lines above\naxisctl: stopped after line 2 failed; halted: `halt -m 3`\n"
        ),
        "{}",
        r.stderr
    );
    assert!(!flags(&state(&sim, "3")).contains(&"STATE_MOTION".into()));
}

// A line longer than 64 KiB (an endless line from a pipe) is refused as
// bad input when it is read, with nothing of its window run.
#[test]
fn a_line_past_the_line_limit_is_refused_and_nothing_of_its_window_runs() {
    let text = format!("halt -m 17\nstate -m 17 {}\n", "x".repeat(70_000));
    let r = run_with_stdin(&["--link", "sim", "--trace", "batch", "-"], &text);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains("standard input: line 2 is longer than 64 KiB, the most a batch line may be; it was not run"),
        "{}",
        r.stderr
    );
    assert!(!r.stderr.lines().any(|l| l.starts_with("->")), "line 1 was not run either: {}", r.stderr);
}

/// A file saved with a byte order mark runs as it reads; `--bench` and
/// `--quiet` on a line are refused as the other global options are (they
/// apply to the whole batch), instead of being taken and ignored.
#[test]
fn a_byte_order_mark_is_no_part_of_the_first_command_and_bench_or_quiet_on_a_line_are_refused() {
    let file = script("\u{feff}state -m 3\nstate -m 5\n");
    let r = common::run(&["--link", "sim", "batch", file.path().to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.matches("CubeState").count(), 2, "{}", r.stdout);
    for (line, flag) in [("state -m 3 --bench x.toml\n", "--bench"), ("state -m 3 -q\n", "--quiet")] {
        let r = run_with_stdin(&["--link", "sim", "batch", "-"], line);
        assert_eq!(r.code, 2, "{line:?}: {}", r.stderr);
        assert!(r.stderr.contains(&format!("{flag} on a line: give it to batch or shell itself")), "{}", r.stderr);
    }
}
