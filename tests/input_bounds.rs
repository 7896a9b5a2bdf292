//! Values that would make a command unsafe or endless are refused before
//! anything is sent (exit 2): a motion value the wire cannot carry even with
//! --force, a wait that can never end or cannot be timed, answer timeouts
//! and retry counts outside what a bench can use.

mod common;

use common::run;

/// Runs with --trace: any frame sent would show as a `->` line on stderr.
fn refused_unsent(args: &[&str]) -> String {
    let mut all = vec!["--link", "sim", "--trace"];
    all.extend_from_slice(args);
    let r = run(&all);
    assert_eq!(r.code, 2, "{args:?}: {} {}", r.stdout, r.stderr);
    assert!(!r.stderr.lines().any(|l| l.starts_with("->")), "{args:?} sent frames:\n{}", r.stderr);
    r.stderr
}

#[test]
fn force_never_sends_a_motion_value_the_wire_float_cannot_carry() {
    for args in [
        &["move-ramp", "-m", "17", "1e39", "--force"][..],
        &["move-vel", "-m", "17", "1e39", "--force"],
        &["move-vel", "-m", "17", "-1e39", "--force"],
        &["move-ramp", "-m", "17", "0.1", "--vel", "1e39", "--force"],
        &["move-cur", "-m", "17", "1e39"],
    ] {
        let err = refused_unsent(args);
        assert!(err.contains("does not fit the wire's 32-bit float"), "{args:?}: {err}");
    }
}

#[test]
fn a_wait_that_cannot_be_timed_is_refused_before_the_move() {
    for t in ["inf", "nan", "1e300", "-1"] {
        refused_unsent(&["move-ramp", "-m", "17", "0.1", "--wait", "--wait-timeout", t]);
        refused_unsent(&["pac-move", "2", "100", "--wait", "--wait-timeout", t]);
        refused_unsent(&["cdios-goto", "-m", "0", "100", "--wait", "--wait-timeout", t]);
    }
    for t in ["0", "0.0", "-0", "1e-9"] {
        refused_unsent(&["move-ramp", "-m", "17", "0.1", "--wait", "--wait-timeout", t]);
        refused_unsent(&["home", "-m", "17", "--wait", "--wait-timeout", t]);
        refused_unsent(&["pac-move", "2", "100", "--wait", "--wait-timeout", t]);
        refused_unsent(&["pac-ref", "2", "--wait", "--wait-timeout", t]);
        let err = refused_unsent(&["cdios-goto", "-m", "0", "100", "--wait", "--wait-timeout", t]);
        assert!(err.contains("is outside 0.001 to 86400 s"), "{err}");
    }
    for p in ["0", "18446744073709551615"] {
        refused_unsent(&["move-ramp", "-m", "17", "0.1", "--wait", "--poll", p]);
    }
}

/// A step in no time is a jump: refused, for every form of the step.
#[test]
fn a_step_in_no_time_is_refused_before_the_move() {
    for args in [
        &["move-step", "-m", "17", "0.1", "--time", "0"][..],
        &["move-step", "-m", "17", "0.1", "--time", "0", "--force"],
        &["move-step", "-m", "17", "100", "--time", "0", "--ticks", "--relative"],
    ] {
        let err = refused_unsent(args);
        assert!(err.contains("\"0\" is not a number from 1 to 65535 ms"), "{args:?}: {err}");
    }
    refused_unsent(&["move-step", "-m", "17", "0.1", "--time", "65536"]);
    let r = run(&["--link", "sim", "move-step", "-m", "17", "0.1", "--time", "1"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
}

#[test]
fn answer_timeouts_and_retries_stay_within_what_a_bench_can_use() {
    for args in [
        &["--timeout", "0", "scan"][..],
        &["--timeout", "18446744073709551615", "scan"],
        &["--retries", "4294967295", "get-param", "-m", "17", "ActPos"],
        &["--retries", "1000000", "scan"],
    ] {
        refused_unsent(args);
    }
    assert_eq!(
        run(&["--link", "sim", "--retries", "10", "--timeout", "60000", "get-param", "-m", "17", "ActPos"]).code,
        0
    );
}
