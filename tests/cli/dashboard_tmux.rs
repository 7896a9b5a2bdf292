//! The real binary in a real terminal: `axisctl --link sim dashboard` inside
//! tmux at 80x24, driven with keys, read back with capture-pane, quit, and
//! the shell's terminal checked to be back to normal. Needs tmux (.ci/run
//! installs it); without it the test fails and says so.

use crate::common;

use std::process::Command;
use std::time::{Duration, Instant};

use common::tmux::Tmux;

fn smoke(w: u16, h: u16) {
    let snapshots = tempfile::tempdir().unwrap();
    let t = Tmux::start("dashboard", w, h, &[]);
    t.wait_for("READY$");
    let dir = snapshots.path().display();
    t.keys(&[&format!("{} --link sim dashboard --snapshot-dir {dir}", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    // The list fills in as each family's devices answer.
    let wanted =
        ["module 17", "PowerCube", "PA-CONTROL", "Cdios", "axis 3", "node 1 mod 1", "sim CAN", "sim RS232", "HALT ALL"];
    t.wait_until(&format!("a device list showing each of {wanted:?}"), |s| wanted.iter().all(|w| s.contains(w)));
    // tmux reports the mode a moment after the screen shows it.
    let deadline = Instant::now() + Duration::from_secs(5);
    while t.display("#{alternate_on}") != "1" {
        assert!(Instant::now() < deadline, "the dashboard runs on the alternate screen:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
    // Home module 3 (selected first), see it move.
    t.keys(&["h"]);
    t.wait_for("Home acknowledged");
    t.wait_for("moving");
    // The chart of module 3 while it homes, then a snapshot of it to SVG.
    t.keys(&["c"]);
    t.wait_for("Chart · PowerCube 3 · last 30 s");
    t.wait_for("position");
    t.keys(&["p"]);
    let screen = t.wait_for("chart written to");
    let written: Vec<_> = std::fs::read_dir(snapshots.path()).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(written.len(), 1, "one snapshot: {written:?}\n{screen}");
    let name = written[0].file_name().unwrap().to_string_lossy().to_string();
    assert!(name.starts_with("axisctl-chart-powercube-3-") && name.ends_with("Z.svg"), "{name}");
    let svg = std::fs::read_to_string(&written[0]).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{svg}");
    for label in ["position [rad]", "velocity [rad/s]", "current [A]"] {
        assert!(svg.contains(label), "no {label:?} in the snapshot:\n{svg}");
    }
    // The overview: every device in one table, then back to the list.
    t.keys(&["c", "v"]);
    // Its title can be drawn before every row has its first reading.
    let wanted = ["Overview · 9 device(s)", "PowerCube 17", "PA axis 3", "Cdios 1/1", " rad/s", " AE/s", " rpm"];
    t.wait_until(&format!("an overview showing each of {wanted:?}"), |s| wanted.iter().all(|w| s.contains(w)));
    t.keys(&["v"]);
    t.wait_for("Devices");
    // The help, and any key closes it.
    t.keys(&["?"]);
    t.wait_for("Keys (any key closes)");
    t.keys(&["x"]);
    // Halt everything.
    t.keys(&["Space"]);
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let screen = t.capture();
        // The three PowerCube rows of the device list say so.
        if screen.matches("halted").count() >= 3 {
            break;
        }
        assert!(Instant::now() < deadline, "not every PowerCube shows halted:\n{screen}");
        std::thread::sleep(Duration::from_millis(50));
    }
    // Quit: the shell is back, on the normal screen, in cooked mode.
    t.keys(&["q"]);
    let deadline = Instant::now() + Duration::from_secs(10);
    while t.display("#{alternate_on}") != "0" {
        assert!(Instant::now() < deadline, "still on the alternate screen:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
    // Typed as DO''NE so that only the output says DONE.
    t.keys(&["s=$?; clear; echo exit=$s; stty -a | tr ' ' '\\n' | grep -x -e icanon -e echo -e -icanon -e -echo; echo DO''NE", "Enter"]);
    let screen = t.wait_for("DONE");
    let lines: Vec<&str> = screen.lines().map(str::trim).collect();
    assert!(lines.contains(&"exit=0"), "the dashboard exits 0:\n{screen}");
    assert!(lines.contains(&"icanon") && lines.contains(&"echo"), "terminal left in raw mode:\n{screen}");
    assert!(!lines.contains(&"-icanon") && !lines.contains(&"-echo"), "terminal left in raw mode:\n{screen}");
    assert!(!screen.contains("Devices"), "the dashboard is still on screen:\n{screen}");
}

/// A panic in the UI thread leaves the terminal usable too (the panic hook
/// restores it before the message is printed).
#[test]
fn a_panic_restores_the_terminal() {
    let t = Tmux::start("dashboard", 80, 24, &[]);
    t.wait_for("READY$");
    t.keys(&[&format!("AXISCTL_TEST_PANIC_KEY=1 {} --link sim dashboard", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    t.wait_for("module 17");
    t.keys(&["!"]);
    let deadline = Instant::now() + Duration::from_secs(10);
    while t.display("#{alternate_on}") != "0" {
        assert!(Instant::now() < deadline, "still on the alternate screen after the panic:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
    t.keys(&["s=$?; stty -a | tr ' ' '\\n' | grep -x -e icanon -e -icanon; echo code=$s DO''NE", "Enter"]);
    let screen = t.wait_for("DONE");
    assert!(screen.contains("test panic requested"), "the panic message is readable:\n{screen}");
    let lines: Vec<&str> = screen.lines().map(str::trim).collect();
    assert!(lines.contains(&"icanon") && !lines.contains(&"-icanon"), "terminal left in raw mode:\n{screen}");
    assert!(screen.contains("code=101 DONE"), "a panic exits 101:\n{screen}");
}

#[test]
fn dashboard_runs_and_restores_the_terminal_80x24() {
    smoke(80, 24);
}

#[test]
fn dashboard_runs_and_restores_the_terminal_200x50() {
    smoke(200, 50);
}

/// `axisctl --log FILE --link sim dashboard` records the traffic of every
/// link it polls: the sim CAN bus (PowerCube and Cdios) and the PA-CONTROL line.
#[test]
fn log_records_every_link_of_the_dashboard() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("dashboard.log");
    let t = Tmux::start("dashboard", 80, 24, &[]);
    t.wait_for("READY$");
    t.keys(&[&format!("{} --log {} --link sim dashboard", env!("CARGO_BIN_EXE_axisctl"), log.display()), "Enter"]);
    t.wait_for("module 17");
    t.wait_for("axis 3");
    t.keys(&["q"]);
    // Keys typed before the dashboard has left would be read by it.
    let deadline = Instant::now() + Duration::from_secs(10);
    while t.display("#{alternate_on}") != "0" {
        assert!(Instant::now() < deadline, "still on the alternate screen:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
    t.keys(&["echo DO''NE", "Enter"]);
    t.wait_for("DONE");
    let text = std::fs::read_to_string(&log).expect("the log file");
    let families: Vec<_> = text
        .lines()
        .filter_map(|l| axisctl::proto::candump::parse_candump_line(l).ok())
        .filter_map(|(_, _, frame)| axisctl::monitor::describe(&frame).family)
        .collect();
    for f in [axisctl::family::Family::PowerCube, axisctl::family::Family::Cdios] {
        assert!(families.contains(&f), "no {f} frame in the log:\n{text}");
    }
    // PA-CONTROL frames open with SOH STX.
    assert!(text.lines().any(|l| l.contains(") tx 01 02 ")), "no PA-CONTROL request in the log:\n{text}");
    assert!(text.lines().any(|l| l.contains(") rx 01 02 ")), "no PA-CONTROL answer in the log:\n{text}");
}

/// SIGTERM and SIGHUP (terminal closed, SSH dropped) while an axis the
/// dashboard started moves: the dashboard says it halted what it moved,
/// leaves raw mode and the alternate screen, and exits 128 + the signal.
fn ends_on(signal: i32, name: &str, code: i32) {
    let t = Tmux::start("dashboard", 80, 24, &[]);
    t.wait_for("READY$");
    t.keys(&[&format!("{} --link sim dashboard", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    t.wait_for("module 17");
    t.keys(&["h"]);
    t.wait_for("Home acknowledged");
    let pid = t.program_pid();
    // SAFETY: kill(2) on the pid of the dashboard this test started.
    assert_eq!(unsafe { libc::kill(pid, signal) }, 0);
    let deadline = Instant::now() + Duration::from_secs(10);
    while t.display("#{alternate_on}") != "0" {
        assert!(Instant::now() < deadline, "still on the alternate screen after {name}:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
    t.keys(&["s=$?; stty -a | tr ' ' '\\n' | grep -x -e icanon -e -icanon; echo code=$s DO''NE", "Enter"]);
    let screen = t.wait_for("DONE");
    assert!(screen.contains(&format!("{name}: halted what the dashboard moved")), "{screen}");
    let lines: Vec<&str> = screen.lines().map(str::trim).collect();
    assert!(lines.contains(&"icanon") && !lines.contains(&"-icanon"), "terminal left in raw mode:\n{screen}");
    assert!(screen.contains(&format!("code={code} DONE")), "{name} exits {code}:\n{screen}");
}

#[test]
fn sigterm_halts_restores_the_terminal_and_exits_143() {
    ends_on(libc::SIGTERM, "SIGTERM", 143);
}

#[test]
fn sighup_halts_restores_the_terminal_and_exits_129() {
    ends_on(libc::SIGHUP, "SIGHUP", 129);
}

/// A snapshot directory that does not exist is bad input: exit 2 before
/// any link is opened or the terminal taken.
#[test]
fn a_missing_snapshot_dir_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let gone = dir.path().join("gone");
    let out = Command::new(env!("CARGO_BIN_EXE_axisctl"))
        .args(["--link", "sim", "dashboard", "--snapshot-dir"])
        .arg(&gone)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(&format!("--snapshot-dir {}: no such directory", gone.display())), "{err}");
}

/// SIGTSTP sent with kill (the Ctrl-Z key is only a key in the raw
/// terminal) while an axis the dashboard started moves: it halts what it
/// moved and restores the terminal as on SIGTERM, then the process stops
/// (bash reports the job stopped); `fg` ends it with 148, nothing resumed.
#[test]
fn sigtstp_halts_restores_the_terminal_then_stops_and_fg_exits_148() {
    let t = Tmux::start("dashboard", 80, 24, &[]);
    t.wait_for("READY$");
    t.keys(&[&format!("{} --link sim dashboard", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    t.wait_for("module 17");
    t.keys(&["h"]);
    t.wait_for("Home acknowledged");
    let pid = t.program_pid();
    // SAFETY: kill(2) on the pid of the dashboard this test started.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGTSTP) }, 0);
    let screen = t.wait_until("the job stopped, back in bash", |s| s.matches("READY$").count() >= 2);
    assert_eq!(t.display("#{alternate_on}"), "0", "the alternate screen is left:\n{screen}");
    assert!(screen.contains("SIGTSTP: halted what the dashboard moved"), "{screen}");
    assert!(screen.contains("Stopped"), "bash reports the job stopped:\n{screen}");
    t.keys(&["fg", "Enter"]);
    t.wait_until("the return to bash after fg", |s| s.matches("READY$").count() >= 3);
    t.keys(&["echo code=$? DO''NE", "Enter"]);
    let screen = t.wait_for("DONE");
    assert!(screen.contains("code=148 DONE"), "continued, the dashboard exits 148:\n{screen}");
}
