//! Every limit a move is checked against, through the real binary: a value
//! past the module's limit is refused with exit 2 naming the limit, and no
//! motion (nor TargetVel / TargetAcc) leaves; the same move within the limit
//! goes out, so the refusal is the check and not something else.
//! Module 17 of the bench is linear: MinPos 0, MaxPos 1, MaxVel 0.1,
//! MaxAcc 0.5, MaxCur 5.

use crate::common;

use common::run;

/// Runs a command on the in-process bench with `--trace`.
fn traced(args: &[&str]) -> common::Run {
    let mut all = vec!["--link", "sim", "--trace"];
    all.extend_from_slice(args);
    run(&all)
}

fn assert_refused(args: &[&str], limit: &str) {
    let r = traced(args);
    assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
    assert!(r.stderr.contains(&format!("module 17's {limit}")), "{args:?} names {limit}: {}", r.stderr);
    for sent in ["SetMotion", "SetExtended"] {
        assert!(!r.stderr.contains(sent), "{args:?}: {sent} left:\n{}", r.stderr);
    }
}

fn assert_sent(args: &[&str]) {
    let r = traced(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    assert!(r.stderr.contains("-> ") && r.stderr.contains("SetMotion"), "{args:?}:\n{}", r.stderr);
}

#[test]
fn ramp_acceleration_is_checked_against_max_acc() {
    assert_refused(&["move-ramp", "-m", "17", "0.5", "--acc", "0.6"], "MaxAcc");
    assert_sent(&["move-ramp", "-m", "17", "0.5", "--acc", "0.5"]);
}

#[test]
fn ramp_velocity_is_checked_against_max_vel() {
    assert_refused(&["move-ramp", "-m", "17", "0.5", "--vel", "0.2"], "MaxVel");
    assert_sent(&["move-ramp", "-m", "17", "0.5", "--vel", "0.1"]);
}

#[test]
fn step_targets_are_checked_against_min_and_max_pos() {
    assert_refused(&["move-step", "-m", "17", "--time", "500", "1.5"], "MaxPos");
    assert_refused(&["move-step", "-m", "17", "--time", "500", "--", "-0.5"], "MinPos");
    assert_sent(&["move-step", "-m", "17", "--time", "500", "1.0"]);
}

#[test]
fn velocity_moves_are_checked_against_max_vel_both_ways() {
    assert_refused(&["move-vel", "-m", "17", "0.2"], "MaxVel");
    assert_refused(&["move-vel", "-m", "17", "--", "-0.2"], "MaxVel");
    assert_sent(&["move-vel", "-m", "17", "--", "-0.1"]);
}

#[test]
fn current_moves_are_checked_against_max_cur_both_ways() {
    assert_refused(&["move-cur", "-m", "17", "6"], "MaxCur");
    assert_refused(&["move-cur", "-m", "17", "--", "-6"], "MaxCur");
    assert_sent(&["move-cur", "-m", "17", "--", "-5"]);
}

#[test]
fn force_skips_the_module_limits_only() {
    let r = traced(&["move-vel", "-m", "17", "--force", "0.2"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(!r.stderr.contains("GetExtended MaxVel"), "no limits read with --force:\n{}", r.stderr);
}
