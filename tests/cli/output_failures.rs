//! Output that cannot be written never panics (exit 101): a reader that
//! went away (`| head -c 1`) ends the command quietly with exit 0, a full
//! disk (`> /dev/full`) is exit 1 with a message, and a stderr that cannot
//! be written leaves the exit code as it was. Every command family, with
//! and without `--json`, against the in-process bench.

use crate::common;

use std::io::Read;
use std::process::{Command, Stdio};

/// Representative commands of every family that print on stdout and end
/// by themselves.
const COMMANDS: &[&[&str]] = &[
    // offline
    &["decode", "cube-state", "0xffffffff"],
    &["decode", "config", "0x00000001"],
    &["decode", "pac-ext-axis-status", "0xffff"],
    &["decode", "cdios-status", "81008010"],
    // PowerCube
    &["scan"],
    &["info", "-m", "17"],
    &["state", "-m", "17"],
    &["get-param", "-m", "17", "ActPos", "CubeState"],
    &["get-config", "-m", "17"],
    &["dio", "-m", "17"],
    &["home", "-m", "17"],
    &["halt", "-m", "17"],
    &["move-ramp", "-m", "17", "0.01"],
    // PA-CONTROL
    &["pac-state"],
    &["pac-error"],
    &["pac-axis", "2"],
    &["pac-axes"],
    &["pac-online"],
    &["pac-in", "1"],
    // Cdios
    &["cdios-identify"],
    &["cdios-status", "-m", "0"],
    &["cdios-position", "-m", "0"],
    &["cdios-config", "-m", "0"],
    &["cdios-events", "-m", "0"],
    &["cdios-outputs", "-m", "0"],
    &["cdios-watch", "-m", "0", "--for", "0.3"],
    // the bus monitor
    &["monitor", "--from-log", "BUS_LOG", "--stats"],
    // a recording drawn (it writes the SVG, then says so on stdout)
    &["plot", "STEP_CSV", "--svg", "PLOT_SVG"],
    // the interface itself
    &["completions", "bash"],
    &["man"],
    &["params"],
    &["flags", "config"],
];

/// A candump log of a few frames for `monitor --from-log`, written once
/// for every test of the process (under cargo's scratch directory).
fn bus_log() -> &'static str {
    static LOG: std::sync::OnceLock<()> = std::sync::OnceLock::new();
    const PATH: &str = concat!(env!("CARGO_TARGET_TMPDIR"), "/output-failures-bus.log");
    LOG.get_or_init(|| {
        let frames: String =
            (0..40).map(|i| format!("(1700000000.{i:06}) can0 0F1#01\n(1700000000.{i:06}) can0 0B1#01\n")).collect();
        std::fs::write(PATH, frames).unwrap();
    });
    PATH
}

fn axisctl(json: bool, args: &[&str]) -> Command {
    let mut c = common::bin();
    let args: Vec<&str> = args
        .iter()
        .map(|a| match *a {
            "BUS_LOG" => bus_log(),
            "PLOT_SVG" => concat!(env!("CARGO_TARGET_TMPDIR"), "/output-failures-plot.svg"),
            "STEP_CSV" => concat!(env!("CARGO_MANIFEST_DIR"), "/docs/examples/step.csv"),
            a => a,
        })
        .collect();
    // Examples write files (`backup --out bench.json`): never into the checkout.
    let cwd = concat!(env!("CARGO_TARGET_TMPDIR"), "/output-failures-cwd");
    std::fs::create_dir_all(cwd).unwrap();
    c.current_dir(cwd);
    // The help examples name their link (`--link sim`, `--link sim?pac=online`).
    let (link, args) = match args.as_slice() {
        [flag, link, rest @ ..] if *flag == "--link" => (*link, rest.to_vec()),
        _ => ("sim", args.clone()),
    };
    c.args(["--link", link]);
    if json {
        c.arg("--json");
    }
    c.args(args);
    c
}

fn each(mut f: impl FnMut(bool, &[&str])) {
    for json in [false, true] {
        for args in COMMANDS {
            f(json, args);
        }
    }
}

fn stderr_of(child: std::process::Child) -> (i32, String) {
    let out = child.wait_with_output().expect("wait for axisctl");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn dev_full() -> Stdio {
    Stdio::from(std::fs::OpenOptions::new().write(true).open("/dev/full").expect("/dev/full"))
}

/// The reader closes at once, before the first line: every write fails
/// with EPIPE.
#[test]
fn a_closed_stdout_ends_every_command_quietly() {
    each(|json, args| {
        let mut child = axisctl(json, args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        drop(child.stdout.take());
        let (code, stderr) = stderr_of(child);
        assert_eq!(code, 0, "json={json} {args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "json={json} {args:?}: {stderr}");
    });
}

/// `| head -c 1`: the reader takes one byte, then goes away mid-output.
#[test]
fn head_c_1_never_makes_a_command_fail() {
    each(|json, args| {
        let mut child = axisctl(json, args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        let mut out = child.stdout.take().unwrap();
        let mut one = [0u8; 1];
        assert_eq!(out.read(&mut one).unwrap(), 1, "json={json} {args:?} printed nothing");
        drop(out);
        let (code, stderr) = stderr_of(child);
        assert_eq!(code, 0, "json={json} {args:?}: {stderr}");
    });
}

#[test]
fn a_full_disk_is_exit_1_with_a_message() {
    each(|json, args| {
        let child = axisctl(json, args).stdout(dev_full()).stderr(Stdio::piped()).spawn().unwrap();
        let (code, stderr) = stderr_of(child);
        assert_eq!(code, 1, "json={json} {args:?}: {stderr}");
        assert!(stderr.contains("cannot write the output") && stderr.contains("No space left"), "{args:?}: {stderr}");
    });
}

#[test]
fn help_version_and_sim_into_a_full_disk_fail_too() {
    for args in [&["--help"][..], &["--version"], &["pac-move", "--help"], &["sim"]] {
        let child = common::bin().args(args).stdout(dev_full()).stderr(Stdio::piped()).spawn().unwrap();
        let (code, stderr) = stderr_of(child);
        assert_eq!(code, 1, "{args:?}: {stderr}");
        assert!(stderr.contains("cannot write the output"), "{args:?}: {stderr}");
    }
}

/// Failures whose message goes to a full or closed stderr: the exit code
/// is the failure's, not a panic's.
#[test]
fn errors_to_a_broken_stderr_keep_their_exit_code() {
    let failures: &[(&[&str], i32)] = &[
        (&["pac-axis", "9"], 5),
        (&["state", "-m", "4"], 4),
        (&["get-param", "-m", "17", "NoSuchParam"], 2),
        (&["info", "-m", "99"], 2),
        (&["decode", "cube-state", "zz"], 2),
        (&["no-such-command"], 2),
    ];
    for json in [false, true] {
        for (args, expected) in failures {
            let full = axisctl(json, args).stdout(Stdio::null()).stderr(dev_full()).spawn().unwrap();
            assert_eq!(stderr_of(full).0, *expected, "json={json} {args:?} 2>/dev/full");
            let mut closed = axisctl(json, args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
            drop(closed.stderr.take());
            assert_eq!(closed.wait().unwrap().code(), Some(*expected), "json={json} {args:?} 2>&-");
        }
    }
}

/// Every `--link sim` example of docs/json*.md (every command that has
/// one, far more than the list above), in its JSON and its human form: run
/// normally, then into a full disk, then into a reader that is gone. No run
/// may panic; a run that printed and succeeded must fail with exit 1 on the
/// full disk and end quietly (exit 0) on the closed pipe.
#[test]
fn every_documented_sim_example_survives_a_full_disk_and_a_closed_pipe() {
    let _busy = common::heavy::slot();
    let docs = concat!(env!("CARGO_MANIFEST_DIR"), "/docs");
    let mut lines: Vec<String> = Vec::new();
    for entry in std::fs::read_dir(docs).unwrap() {
        let path = entry.unwrap().path();
        if !path.file_name().unwrap().to_string_lossy().starts_with("json") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        lines.extend(text.lines().filter_map(|l| l.strip_prefix("$ axisctl --link sim ")).map(str::to_string));
    }
    assert!(lines.len() > 50, "found only {} examples", lines.len());
    // A few at a time: each runs its own in-process bench.
    let checked = std::sync::atomic::AtomicUsize::new(0);
    common::pool::each(&lines, |line| {
        let words: Vec<&str> = line.split_whitespace().collect();
        let human: Vec<&str> = words.iter().copied().filter(|w| *w != "--json").collect();
        for args in [&words, &human] {
            let run = |stdout: Stdio| {
                let mut c = common::bin();
                c.args(["--link", "sim"]).args(args.iter()).stdout(stdout).stderr(Stdio::piped());
                c
            };
            let normal = run(Stdio::piped()).output().unwrap();
            let code = normal.status.code().unwrap_or(-1);
            assert_ne!(code, 101, "{args:?}: {}", String::from_utf8_lossy(&normal.stderr));
            let (full, full_err) = stderr_of(run(dev_full()).spawn().unwrap());
            assert_ne!(full, 101, "{args:?} > /dev/full: {full_err}");
            let mut child = run(Stdio::piped()).spawn().unwrap();
            drop(child.stdout.take());
            let (closed, closed_err) = stderr_of(child);
            assert_ne!(closed, 101, "{args:?} | closed: {closed_err}");
            if code == 0 && !normal.stdout.is_empty() {
                assert_eq!(full, 1, "{args:?} > /dev/full: {full_err}");
                if args.contains(&"--wait") || args.contains(&"keepalive") {
                    // A supervised motion (or the watchdog keep-alive) whose
                    // output cannot be written is stopped (docs/safety.md
                    // § 5): exit 1 saying so, or 0 if nothing was written
                    // before it ended.
                    let halted = closed == 1 && closed_err.contains("so the motion was stopped");
                    assert!(closed == 0 || halted, "{args:?} | closed: {closed} {closed_err}");
                } else {
                    assert_eq!(closed, 0, "{args:?} | closed: {closed_err}");
                }
                checked.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            }
        }
    });
    let checked = checked.into_inner();
    assert!(checked > 50, "only {checked} examples printed and succeeded");
}

/// What runs until stopped, or needs a terminal, and is proved elsewhere.
/// Commands whose help examples name a real adapter and that a fresh
/// in-process bench refuses (a traject needs configuring first): still run
/// through a full disk and a closed pipe, for the exit code 101 alone.
const REFUSED_ON_A_FRESH_BENCH: &[&[&str]] = &[&["cdios-traject", "-m", "0", "0"]];

const NOT_ONE_SHOT: &[(&str, &str)] = &[
    ("sim", "serves until stopped: help_version_and_sim_into_a_full_disk_fail_too"),
    ("dashboard", "a terminal UI: its failed draws halt (tui tests, docs/safety.md)"),
    ("watchdog keepalive", "runs until stopped: every_documented_sim_example_... covers --for"),
];

/// `for c in $(every command); do axisctl --link sim ... | head -c 1; done`
/// never exits 101: every subcommand the binary has is run through a full
/// disk and a reader that is gone, by the examples of its own help or the
/// list above, so a new command cannot be added without its coverage.
#[test]
fn every_subcommand_survives_a_full_disk_and_a_closed_pipe() {
    let _busy = common::heavy::slot();
    let mut subs = Vec::new();
    common::subcommands_and_sim_examples(&[], &mut subs);
    assert!(subs.len() > 70, "found only {} subcommands", subs.len());
    let not_one_shot =
        |words: &str| NOT_ONE_SHOT.iter().any(|(p, _)| words == *p || words.starts_with(&format!("{p} ")));
    let mut uncovered = Vec::new();
    let mut runs = Vec::new();
    for (path, examples) in &subs {
        if not_one_shot(path) {
            continue;
        }
        let listed = COMMANDS
            .iter()
            .chain(REFUSED_ON_A_FRESH_BENCH)
            .any(|c| c.join(" ").starts_with(&format!("{path} ")) || c.join(" ") == *path);
        if examples.is_empty() && !listed {
            uncovered.push(path.clone());
        }
        for words in examples {
            let command: Vec<&str> =
                words.iter().map(String::as_str).skip(2).skip_while(|w| w.starts_with("--")).collect();
            if !not_one_shot(&command.join(" ")) {
                runs.extend([false, true].map(|json| (json, words.clone())));
            }
        }
    }
    for args in REFUSED_ON_A_FRESH_BENCH {
        let words: Vec<String> = args.iter().map(|a| a.to_string()).collect();
        runs.extend([false, true].map(|json| (json, words.clone())));
    }
    assert!(runs.len() > 100, "only {} example runs", runs.len());
    // A few at a time: most of the time goes into the simulated motions.
    common::pool::each(&runs, |(json, words)| {
        let json = *json;
        let words: Vec<&str> = words.iter().map(String::as_str).collect();
        let mut full = axisctl(json, &words).stdout(dev_full()).stderr(Stdio::piped()).spawn().unwrap();
        let (code, err) = stderr_with_deadline(&mut full, &words);
        assert_ne!(code, 101, "json={json} {words:?} > /dev/full: {err}");
        let mut closed = axisctl(json, &words).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        drop(closed.stdout.take());
        let (code, err) = stderr_with_deadline(&mut closed, &words);
        assert_ne!(code, 101, "json={json} {words:?} | closed: {err}");
        assert!(!err.contains("panicked"), "json={json} {words:?}: {err}");
    });
    assert!(uncovered.is_empty(), "subcommands with no --link sim example and not in COMMANDS: {uncovered:?}");
}

/// The exit code and stderr of a child that must end within 60 s.
fn stderr_with_deadline(child: &mut std::process::Child, words: &[&str]) -> (i32, String) {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while child.try_wait().unwrap().is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("{words:?} still running after 60 s");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (child.wait().unwrap().code().unwrap_or(-1), err)
}

/// A commissioning run whose JSON lines cannot be written stops at the
/// next motion (halted), marks its report incomplete and exits 1 for the
/// output, not 5 as if the device had failed the check the stop cut short.
#[test]
fn a_commissioning_run_whose_output_fails_stops_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m3");
    let args = ["--json", "commission", "-d", "powercube:3", "--out", out.to_str().unwrap(), "--yes"];
    let child = axisctl(false, &args).stdout(dev_full()).stderr(Stdio::piped()).spawn().unwrap();
    let (code, err) = stderr_of(child);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("so the motion was stopped") && err.contains("marked incomplete"), "{err}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(report["complete"], false);
    assert!(report["ended"].as_str().unwrap().starts_with("output failed"), "{}", report["ended"]);
}
