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

/// Runs axisctl with `args`, standard input endless `endless` bytes when
/// given (the writer goes on until the pipe closes), reaping it with wait4 to
/// read its own peak memory. Returns (exit code, stderr, peak RSS in KiB,
/// seconds).
// Reaped by wait4, which std's wait cannot do: it would not give the rusage.
#[allow(clippy::zombie_processes)]
fn run_measured(args: &[&str], endless: Option<u8>) -> (i32, String, i64, f64) {
    use std::io::{Read, Write};
    use std::process::Stdio;
    let start = std::time::Instant::now();
    let mut child = common::bin()
        .args(args)
        .stdin(if endless.is_some() { Stdio::piped() } else { Stdio::null() })
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    if let (Some(byte), Some(mut input)) = (endless, child.stdin.take()) {
        // Until the reader closes the pipe: an error ends the writer.
        std::thread::spawn(move || {
            let block = vec![byte; 1 << 16];
            while input.write_all(&block).is_ok() {}
        });
    }
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let (mut status, mut usage) = (0, unsafe { std::mem::zeroed::<libc::rusage>() });
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32, "wait4");
    let code = if libc::WIFEXITED(status) { libc::WEXITSTATUS(status) } else { -1 };
    (code, err, usage.ru_maxrss, start.elapsed().as_secs_f64())
}

const BACKUP: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/examples/module17.json");

// Issue 22, item 7: an endless file or pipe given as a backup, a recording,
// a bench file, a commissioning plan
// or a batch line is refused at its ceiling (exit 2, nothing sent), in
// bounded memory and at once; before, `diff /dev/zero x.json` grew by
// about 1.4 GB/s until killed.
#[test]
fn endless_input_is_refused_at_its_ceiling_in_bounded_memory() {
    for (args, endless, said) in [
        (&["diff", "/dev/zero", BACKUP][..], None, "/dev/zero is larger than 4 MiB, the most a backup may be"),
        (&["diff", BACKUP, "/dev/zero"], None, "/dev/zero is larger than 4 MiB"),
        (&["--link", "sim", "--trace", "restore", "-"], Some(b'['), "standard input is larger than 4 MiB"),
        (
            &["plot", "/dev/zero", "--svg", "/dev/null"],
            None,
            "/dev/zero is larger than 32 MiB, the most a recording may be",
        ),
        (&["--link", "sim", "--trace", "batch", "-"], Some(b'x'), "line 1 is longer than 64 KiB"),
        (
            &["--bench", "/dev/zero", "--trace", "state", "-m", "3"],
            None,
            "larger than 1 MiB, the most a bench file may be",
        ),
        (
            &["--link", "sim", "--trace", "commission", "--plan", "-", "--dry-run", "--out", "/nonexistent/report"],
            Some(b'#'),
            "standard input is larger than 1 MiB, the most a plan may be",
        ),
    ] {
        let (code, err, rss_kib, secs) = run_measured(args, endless);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(said), "{args:?}: {err}");
        assert!(!err.lines().any(|l| l.starts_with("->")), "{args:?} sent frames:\n{err}");
        // A debug build of axisctl starts at about 10 MB; the ceilings add
        // at most 2 x 32 MiB for the recording (its bytes and their text).
        let most = if args[0] == "plot" { 100 << 10 } else { 50 << 10 };
        assert!(rss_kib < most, "{args:?}: peak {rss_kib} KiB");
        eprintln!("{args:?}: exit {code}, peak RSS {rss_kib} KiB, {secs:.2} s");
        assert!(secs < 30.0, "{args:?}: {secs:.1} s");
    }
}

// Issue 22, item 8: a backup that gives a key twice in one object (two
// values for one setting: JSON readers differ on which counts) is refused
// before the link opens, by restore and by diff.
#[test]
fn a_backup_with_a_key_given_twice_is_refused_before_anything_is_sent() {
    let text = std::fs::read_to_string(BACKUP).unwrap();
    let twice = text.replacen("\"ActC0\": {", "\"ActC0\": {\"value\": 12, ", 1);
    assert_ne!(twice, text);
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("twice.json");
    std::fs::write(&file, &twice).unwrap();
    let f = file.to_str().unwrap();
    for args in [&["restore", f][..], &["restore", f, "--dry-run"], &["diff", f]] {
        let err = refused_unsent(args);
        assert!(err.contains(&format!("{f} is ambiguous: \"value\" is given twice in one object at line")), "{err}");
        assert!(err.ends_with("; nothing was sent\n"), "{err}");
    }
    let r = run(&["diff", f, BACKUP]);
    assert_eq!(r.code, 2, "{}", r.stderr);
}
