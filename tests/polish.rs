//! The CLI of issue 25's open items and issue 22's PA-CONTROL speed limits:
//! `pac-speed` / `pac-accel` checked against the limits `pac-online` read.

mod common;

use common::{bin, run_with_stdin, Sim};

/// The frames a `--log` recorded as sent, as hex text.
fn sent(log: &std::path::Path) -> Vec<String> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines().filter_map(|l| l.split_once(" tx ").map(|(_, hex)| hex.to_string())).collect()
}

/// "0A8D" as the PA-CONTROL line carries it (ASCII, hex-logged).
fn code_hex(code: &str) -> String {
    code.bytes().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

fn sends(log: &std::path::Path, code: &str) -> bool {
    sent(log).iter().any(|f| f.contains(&code_hex(code)))
}

/// A private lock directory of the test's own (0700, or it is not used),
/// so the kept limits of one test never meet another's.
fn lock_dir() -> tempfile::TempDir {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o700)).unwrap();
    dir
}

fn isolated(dir: &std::path::Path) -> impl Fn(&[&str]) -> common::Run + '_ {
    move |args: &[&str]| {
        let out = bin().env("AXISCTL_LOCK_DIR", dir).args(args).output().expect("run axisctl");
        common::Run {
            code: out.status.code().unwrap_or(-1),
            stdout: String::from_utf8_lossy(&out.stdout).into(),
            stderr: String::from_utf8_lossy(&out.stderr).into(),
        }
    }
}

#[test]
fn pac_speed_outside_the_limits_read_by_pac_online_is_refused_and_nothing_is_sent() {
    let sim = Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    let dir = lock_dir();
    let ax = isolated(dir.path());
    let kept = || {
        std::fs::read_dir(dir.path())
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().ends_with(".pac-limits"))
            .count()
    };
    let r = ax(&["--link", link, "pac-online"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(kept(), 1, "kept beside the lock");

    for (args, what) in [(["pac-speed", "1", "1e9"], "speed 1000000000"), (["pac-accel", "2", "1e9"], "acceleration")] {
        let log = dir.path().join(format!("{}.log", args[0]));
        let mut all = vec!["--link", link, "--log", log.to_str().unwrap()];
        all.extend(args);
        let r = ax(&all);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(what) && r.stderr.contains("limits"), "{}", r.stderr);
        assert!(r.stderr.contains("nothing was sent"), "{}", r.stderr);
        assert!(sent(&log).is_empty(), "{args:?} sent nothing at all: {:?}", sent(&log));
    }

    // The simulated controller's limits for axis 1's speed are 0.1 to 50000.
    let log = dir.path().join("ok.log");
    let r = ax(&["--link", link, "--log", log.to_str().unwrap(), "--json", "pac-speed", "1", "50000"]);
    assert_eq!(r.code, 0, "the maximum itself goes out: {}", r.stderr);
    assert!(sends(&log, "0A8D"), "{:?}", sent(&log));
    assert!(!r.stderr.contains("not known"), "the limits were known: {}", r.stderr);
    let r = ax(&["--link", link, "pac-speed", "1", "50000.5"]);
    assert_eq!(r.code, 2, "just above: {}", r.stderr);

    // pac-offline forgets them: online again by another way, the controller checks.
    assert_eq!(ax(&["--link", link, "pac-offline"]).code, 0);
    assert_eq!(kept(), 0, "the kept limits are gone");
    assert_eq!(ax(&["--link", link, "pac-raw", "0603", "0"]).code, 0);
    let log = dir.path().join("unknown.log");
    let r = ax(&["--link", link, "--log", log.to_str().unwrap(), "pac-speed", "1", "1e9"]);
    assert!(r.stderr.contains("not known here"), "the fallback is said: {}", r.stderr);
    assert!(sends(&log, "0A8D"), "without limits the value goes out: {:?}", sent(&log));
    assert_ne!(r.code, 0, "and the controller refuses it: {}", r.stderr);
}

#[test]
fn a_batch_checks_pac_speed_against_the_limits_its_pac_online_read() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("batch.log");
    let r = run_with_stdin(
        &["--link", "sim", "--log", log.to_str().unwrap(), "batch"],
        "pac-online\npac-speed 1 100\npac-speed 1 1e9\npac-state\n",
    );
    assert_ne!(r.code, 0, "{}", r.stderr);
    assert!(r.stderr.contains("line 3") && r.stderr.contains("outside axis 1's limits"), "{}", r.stderr);
    let speeds = sent(&log).iter().filter(|f| f.contains(&code_hex("0A8D"))).count();
    assert_eq!(speeds, 1, "only line 2's speed went out: {:?}", sent(&log));
}

#[test]
fn a_garbled_limits_file_is_not_trusted() {
    let sim = Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    let dir = lock_dir();
    let ax = isolated(dir.path());
    let r = ax(&["--link", link, "pac-online"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let listing: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
    let file = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.to_string_lossy().ends_with(".pac-limits"))
        .unwrap_or_else(|| panic!("pac-online kept the limits beside the lock: {listing:?} {}", r.stderr));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.starts_with("axisctl-pac-limits 1\n257 0.1 50000\n"), "{text}");
    std::fs::write(&file, text.replace("257 0.1 50000", "257 0.1 fifty")).unwrap();
    let r = ax(&["--link", link, "pac-speed", "1", "60000"]);
    assert!(r.stderr.contains("not known here"), "{}", r.stderr);
}
