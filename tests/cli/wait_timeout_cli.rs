//! A `--wait` that runs out while the device answers every poll is a wait
//! timeout (exit 7, kind `wait_timeout`), not a lost answer (exit 4): the
//! message says the device was still busy and was stopped, and afterwards
//! it stands. For every family's waits, against `axisctl sim` over ptys.
//! Each wait timeout is far shorter than the motion it gives up (seconds),
//! so a loaded machine cannot let the motion end first.

use crate::common;

use std::process::Stdio;

use common::{wait_bounded, Run, Sim};
use serde_json::Value;

/// Under a deadline, with a generous answer timeout: no answer may be
/// late enough on a loaded machine to end the wait another way.
fn run_bounded(args: &[&str]) -> Run {
    let mut all = vec!["--timeout", "2000"];
    all.extend_from_slice(args);
    let child = common::bin().args(&all).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    wait_bounded(child, 120, &all).run()
}

fn ok(args: &[&str]) -> Value {
    let r = run_bounded(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    if r.stdout.trim_start().starts_with('{') {
        r.json()
    } else {
        Value::Null
    }
}

/// Runs a wait that must run out: exit 7, the `--json` error of kind
/// `wait_timeout`, nothing on stdout; returns the message.
fn runs_out(args: &[&str]) -> String {
    let mut all = vec!["--json"];
    all.extend_from_slice(args);
    let r = run_bounded(&all);
    assert_eq!(r.code, 7, "{args:?}: {} {}", r.stdout, r.stderr);
    assert!(r.stdout.is_empty(), "{args:?}: {}", r.stdout);
    let err: Value = serde_json::from_str(r.stderr.trim()).unwrap_or_else(|e| panic!("{e}: {}", r.stderr));
    assert_eq!((&err["error"]["kind"], &err["error"]["exit_code"]), (&Value::from("wait_timeout"), &Value::from(7)));
    assert!(common::schema_errors(&common::schema("error_document"), &err).is_none(), "{err}");
    let msg = err["error"]["message"].as_str().unwrap().to_string();
    assert!(!msg.contains("no answer"), "every poll was answered: {msg}");
    msg
}

/// PowerCube module `m` stands, halted: HALTED set and no MOTION.
fn assert_halted(link: &str, m: &str) {
    let raw = ok(&["--link", link, "--json", "state", "-m", m])["state"]["raw"].as_u64().unwrap();
    assert!(raw & 0x800 == 0 && raw & 0x4 != 0, "module {m} halted and standing: {raw:#x}");
}

#[test]
fn a_powercube_ramp_and_homing_that_run_out_are_wait_timeouts_and_halt_the_module() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    // 2 rad at 0.2 rad/s: ten seconds of motion.
    let msg = runs_out(&[
        "--link",
        link,
        "move-ramp",
        "-m",
        "3",
        "2.0",
        "--vel",
        "0.2",
        "--force",
        "--wait",
        "--wait-timeout",
        "0.5",
    ]);
    assert_eq!(msg, "wait timed out after 0.5 s: module 3 was still moving (it answered every poll); module 3 halted");
    assert_halted(link, "3");
    // Homing takes about two seconds in the simulator.
    let msg = runs_out(&["--link", link, "home", "-m", "17", "--wait", "--wait-timeout", "0.3"]);
    assert_eq!(
        msg,
        "wait timed out after 0.3 s: module 17 was still homing (it answered every poll); module 17 halted"
    );
    assert_halted(link, "17");
}

#[test]
fn a_synchronized_ramp_that_runs_out_halts_every_module_of_it() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    for m in ["3", "5"] {
        ok(&["--link", link, "set-config", "-m", m, "+sync-motion"]);
    }
    let msg = runs_out(&[
        "--link",
        link,
        "move-ramp",
        "-m",
        "3,5",
        "--sync",
        "2.0",
        "-2.0",
        "--vel",
        "0.2",
        "--force",
        "--wait",
        "--wait-timeout",
        "0.5",
    ]);
    assert!(
        msg.starts_with(
            "wait timed out after 0.5 s: module 3 was still moving (it answered every poll); module 3 halted; "
        ) && msg.ends_with("module 5 halted too"),
        "{msg}"
    );
    assert_halted(link, "3");
    assert_halted(link, "5");
}

#[test]
fn a_pac_move_and_reference_drive_that_run_out_are_wait_timeouts_and_stop_the_axis() {
    let s = Sim::start(&["--pac", "pty-serial"], 1);
    let link = s.link("pac");
    ok(&["--link", link, "pac-online"]);
    let msg = runs_out(&["--link", link, "pac-ref", "1", "--wait", "--wait-timeout", "0.3"]);
    assert!(
        msg.starts_with("wait timed out after 0.3 s: PA-CONTROL was still running 0A84")
            && msg.contains("(it answered every poll); axis 1 stopped at "),
        "{msg}"
    );
    let axis = ok(&["--link", link, "--json", "pac-axis", "1"]);
    assert_eq!(axis["axis_status"], 2, "axis 1 stopped: {axis}");
    ok(&["--link", link, "pac-ref", "2", "--wait"]);
    let msg = runs_out(&["--link", link, "pac-move", "2", "5000", "--wait", "--wait-timeout", "0.3"]);
    assert!(
        msg.starts_with(
            "wait timed out after 0.3 s: PA-CONTROL axis 2 was still moving (it answered every poll); axis 2 stopped at "
        ),
        "{msg}"
    );
    let axis = ok(&["--link", link, "--json", "pac-axis", "2"]);
    assert_eq!(axis["axis_status"], 2, "axis 2 stopped: {axis}");
    let stopped_at = axis["position"]["value"].as_f64().unwrap();
    assert!(stopped_at > 0.0 && stopped_at < 5000.0, "stopped on the way: {axis}");
}

#[test]
fn a_cdios_goto_and_traject_that_run_out_are_wait_timeouts_and_stop_the_motor() {
    let s = Sim::start(&["--cdios", "pty-slcan"], 1);
    let link = s.link("cdios");
    ok(&["--link", link, "cdios-enable", "-m", "0"]);
    let msg = runs_out(&["--link", link, "cdios-goto", "-m", "0", "1000000", "--wait", "--wait-timeout", "0.5"]);
    assert_eq!(
        msg,
        "wait timed out after 0.5 s: node 1 module 0 was still running the goto (it answered every poll); \
         node 1 module 0 stopped (fast stop)"
    );
    let at = ok(&["--link", link, "--json", "cdios-position", "-m", "0"])["position"]["value"].as_i64().unwrap();
    assert!(at > 0 && at < 1_000_000, "stopped on the way: {at}");
    assert_stands(link);

    // A traject to 200000 more at 1000 rpm: far longer than the wait.
    let end = format!("traject1.end_position={}", at + 200_000);
    ok(&["--link", link, "cdios-config", "-m", "0", &end, "traject1.length=1", "traject1.initial_speed=1000"]);
    let msg = runs_out(&["--link", link, "cdios-traject", "-m", "0", "1", "--wait", "--wait-timeout", "0.5"]);
    assert_eq!(
        msg,
        "wait timed out after 0.5 s: node 1 module 0 was still running the traject (it answered every poll); \
         node 1 module 0 stopped (fast stop)"
    );
    assert_stands(link);
    let now = ok(&["--link", link, "--json", "cdios-position", "-m", "0"])["position"]["value"].as_i64().unwrap();
    assert!(now > at && now < at + 200_000, "stopped on the way: {at} -> {now}");
}

/// Cdios module 0 runs no goto or traject and its motor turns neither way.
fn assert_stands(link: &str) {
    let st = ok(&["--link", link, "--json", "cdios-status", "-m", "0"]);
    let flags: Vec<&str> = st["state"]["flags"].as_array().unwrap().iter().filter_map(Value::as_str).collect();
    let moving = ["GOTO_ACTIVE", "TRAJECT_RUNNING", "RUNNING_FORWARD", "RUNNING_REVERSE"];
    assert!(!flags.iter().any(|f| moving.contains(f)), "{flags:?}");
}
