//! Settings that act like motion or that remove a safety, through the real
//! binary: `set-param` of targets and currents is checked like a move,
//! `set-config` wants `--force` to take a protection away, `watchdog on/off`
//! looks before it toggles, and a scan that finds nobody fails.
//! Module 17 of the bench is linear: MinPos 0, MaxPos 1, MaxVel 0.1,
//! MaxAcc 0.5, MaxCur 5.

use crate::common;

use std::time::Duration;

use common::{run, Run, Sim};

fn traced(args: &[&str]) -> Run {
    let mut all = vec!["--link", "sim", "--trace"];
    all.extend_from_slice(args);
    run(&all)
}

/// Refused with exit 2 naming `why`, and no write left the link.
fn assert_refused(args: &[&str], why: &str) {
    let r = traced(args);
    assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
    assert!(r.stderr.contains(why), "{args:?} names {why}: {}", r.stderr);
    for sent in ["-> 0E", "SetExtended", "SetMotion"] {
        assert!(!r.stderr.contains(sent), "{args:?}: {sent} left:\n{}", r.stderr);
    }
}

fn assert_written(args: &[&str]) -> Run {
    let r = traced(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    assert!(r.stderr.contains("SetExtended"), "{args:?}:\n{}", r.stderr);
    r
}

#[test]
fn set_param_targets_are_checked_against_the_module_limits() {
    assert_refused(&["set-param", "-m", "17", "TargetVel", "5"], "module 17's MaxVel = 0.1");
    assert_refused(&["set-param", "-m", "17", "TargetAcc", "0.6"], "module 17's MaxAcc = 0.5");
    assert_refused(&["set-param", "-m", "17", "TargetPos", "1.5"], "module 17's MaxPos = 1");
    assert_refused(&["set-param", "-m", "17", "TargetPos", "-0.5"], "module 17's MinPos = 0");
    assert_refused(&["set-param", "-m", "17", "Cur", "100"], "module 17's MaxCur = 5");
    assert_refused(&["set-param", "-m", "17", "Cur", "-6"], "module 17's MaxCur = 5");
    assert_refused(&["set-param", "-m", "17", "TargetVelInc", "100000000"], "module 17's ActIMaxVel");
    assert_written(&["set-param", "-m", "17", "TargetVel", "0.1"]);
    assert_written(&["set-param", "-m", "17", "TargetAcc", "0.5"]);
    assert_written(&["set-param", "-m", "17", "TargetPos", "1"]);
    assert_written(&["set-param", "-m", "17", "Cur", "-5"]);
}

#[test]
fn set_param_velocity_and_acceleration_must_be_positive() {
    assert_refused(&["set-param", "-m", "17", "TargetVel", "0"], "must be positive");
    assert_refused(&["set-param", "-m", "17", "--force", "TargetAcc", "-0.1"], "must be positive");
}

#[test]
fn raw_current_keeps_the_manuals_range_even_with_force() {
    assert_refused(&["set-param", "-m", "17", "RawCur", "30000"], "the manual's range -500 to 500");
    assert_refused(&["set-param", "-m", "17", "--force", "RawCur", "-501"], "the manual's range -500 to 500");
    assert_written(&["set-param", "-m", "17", "RawCur", "-500"]);
}

#[test]
fn force_skips_only_the_module_limits_and_the_readback_shows_the_clamp() {
    let r = assert_written(&["set-param", "-m", "17", "--force", "MaxCur", "7"]);
    assert!(!r.stderr.contains("GetExtended MaxVel"), "a limit itself is not checked:\n{}", r.stderr);
    // The module clamps a target velocity to MaxVel; TargetVel is write-only,
    // TargetVelInc is read back.
    let r = run(&["--link", "sim", "--json", "set-param", "-m", "17", "--force", "TargetVelInc", "100000000"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let doc = r.json();
    assert_eq!(doc["value"], 100000000);
    let held = doc["held"].as_i64().unwrap();
    assert!(held > 0 && held < 100000000, "the module clamped it: {doc}");
    let w = run(&["--link", "sim", "--json", "set-param", "-m", "17", "TargetVel", "0.05"]);
    assert_eq!(w.json()["held"], serde_json::Value::Null, "write-only: {}", w.stdout);
    let plain = run(&["--link", "sim", "set-param", "-m", "17", "--force", "TargetVelInc", "100000000"]);
    assert!(plain.stdout.contains("the module reads back"), "{}", plain.stdout);
}

#[test]
fn set_config_that_removes_a_safety_needs_force_and_says_what_it_does() {
    assert_refused(&["set-config", "-m", "17", "+disable-ack"], "every acknowledge");
    assert_refused(&["set-config", "-m", "17", "-sw1-enabled"], "limit switch 1 off");
    assert_refused(&["set-config", "-m", "17", "-sw2-enabled"], "limit switch 2 off");
    assert_refused(&["set-config", "-m", "17", "+watchdog-enable"], "without switching it online");
    assert_refused(&["set-config", "-m", "17", "-watchdog-enable"], "takes the watchdog out of action");
    assert_refused(&["set-config", "-m", "17", "--raw", "0xffffffff"], "--raw replaces the whole Config word");
    assert_refused(&["set-config", "-m", "17", "+brake-present", "+disable-ack"], "--force");
    // Harmless flags need nothing, and --force lets the others through, on
    // either side of the flags.
    assert_written(&["set-config", "-m", "17", "+brake-present"]);
    for args in
        [["set-config", "-m", "17", "--force", "-sw1-enabled"], ["set-config", "-m", "17", "-sw1-enabled", "--force"]]
    {
        let r = run(&[&["--link", "sim", "--json"], &args[..]].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        assert_eq!(r.json()["config"]["raw"].as_u64().unwrap() & 0x800, 0, "SW1_ENABLED cleared");
    }
}

#[test]
fn scan_in_which_nothing_answered_is_exit_4() {
    let r = run(&["--link", "sim", "--json", "scan", "--ids", "1-2"]);
    assert_eq!(r.code, 4, "{} {}", r.stdout, r.stderr);
    assert!(r.stdout.is_empty(), "{}", r.stdout);
    let err: serde_json::Value = serde_json::from_str(r.stderr.trim()).unwrap();
    assert_eq!(err["error"]["kind"], "timeout");
    assert!(err["error"]["message"].as_str().unwrap().contains("no PowerCube module answered on ids 1,2"), "{err}");
    assert_eq!(run(&["--link", "sim", "scan", "--ids", "16-17"]).code, 0, "one answered");
}

fn comm_error(link: &str, m: &str) -> bool {
    let st = run(&["--link", link, "--json", "state", "-m", m]);
    assert_eq!(st.code, 0, "{}", st.stderr);
    st.json()["state"]["errors"].as_array().unwrap().iter().any(|e| e == "STATE_COMM_ERROR")
}

/// No refresh for longer than the 50 ms period: an online watchdog trips.
fn outlast_the_watchdog() {
    std::thread::sleep(Duration::from_millis(120));
}

#[test]
fn watchdog_off_on_an_offline_watchdog_sends_no_toggle() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube");
    let run_ok = |args: &[&str]| {
        let r = run(&[&["--link", link, "--trace"], args].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        r
    };
    run_ok(&["watchdog", "on", "-m", "5"]);
    let off = run_ok(&["watchdog", "off", "-m", "5"]);
    assert!(!off.stderr.contains("Watchdog"), "off clears the flag, no 0x07:\n{}", off.stderr);
    let again = run_ok(&["watchdog", "off", "-m", "5"]);
    assert!(again.stdout.contains("already off"), "{}", again.stdout);
    assert!(!again.stderr.contains("SetExtended") && !again.stderr.contains("Watchdog"), "{}", again.stderr);
    outlast_the_watchdog();
    assert!(!comm_error(link, "5"), "a second `off` must not switch the watchdog on");
}

#[test]
fn watchdog_on_on_an_online_watchdog_is_a_no_op() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube");
    for (i, changed) in [(0, true), (1, false)] {
        let r = run(&["--link", link, "--json", "watchdog", "on", "-m", "5"]);
        assert_eq!(r.code, 0, "{i}: {}", r.stderr);
        assert_eq!(r.json()["changed"], changed, "{i}: {}", r.stdout);
    }
    outlast_the_watchdog();
    assert!(comm_error(link, "5"), "a second `on` must leave the watchdog online (it trips unrefreshed)");
}
