//! The one error object of --json: every failure, argument errors included,
//! is `{"error": {...}}` on stderr with the exit code, the address of the
//! device when there is one and, for a refusal, what the device said.

use crate::common;

use common::run;
use serde_json::{json, Value};

/// The published schema's error document.
fn error_schema() -> jsonschema::Validator {
    common::schema("error_document")
}

/// The error object of a failed run: alone on stderr, nothing on stdout,
/// valid against the schema and carrying the process's exit code.
fn error_with(args: &[&str], code: i32) -> Value {
    let r = run(args);
    assert_eq!(r.code, code, "{args:?}: {} {}", r.stdout, r.stderr);
    assert!(r.stdout.is_empty(), "{}", r.stdout);
    assert_eq!(r.stderr.trim().lines().count(), 1, "one line: {}", r.stderr);
    let doc: Value = serde_json::from_str(r.stderr.trim()).unwrap_or_else(|e| panic!("{e}: {}", r.stderr));
    let errors: Vec<String> = error_schema().iter_errors(&doc).map(|e| e.to_string()).collect();
    assert!(errors.is_empty(), "{args:?}: {doc} breaks the schema: {errors:?}");
    assert_eq!(doc["error"]["exit_code"], code);
    doc["error"].clone()
}

fn error_of(args: &[&str]) -> Value {
    let e = error_with(args, 5);
    assert_eq!(e["kind"], "device");
    e
}

// The bench's PA-CONTROL has 3 axes: 190C for axis 9 answers QUIT 20h.
#[test]
fn pa_control_quit_under_json() {
    let e = error_of(&["--link", "sim", "--json", "pac-raw", "190C", "9", "0"]);
    assert_eq!(
        e["device"],
        json!({"family": "pac", "command_code": "190C", "code": 32, "name": null, "text": "axis number unknown",
               "details": [], "unknown_bits": 0})
    );
    let msg = e["message"].as_str().unwrap();
    assert!(msg.ends_with("command error 0x20 (32): axis number unknown"), "{msg}");
}

// The bench's Cdios node has modules 0 and 1: 26h to module 7 is general error 1.
#[test]
fn cdios_error_reply_under_json() {
    let e = error_of(&["--link", "sim", "--json", "cdios-status", "-m", "7"]);
    assert_eq!((&e["family"], &e["node"], &e["module"]), (&json!("cdios"), &json!(1), &json!(7)));
    assert_eq!(
        e["device"],
        json!({
            "family": "cdios",
            "command_code": "26",
            "code": 1,
            "name": "NO_MODULE",
            "text": "no module at that module id",
            "details": [],
            "unknown_bits": 0
        })
    );
}

// A goto before the motor is enabled: general error 0, the bit says why.
#[test]
fn cdios_command_error_bits_under_json() {
    let e = error_of(&["--link", "sim", "--json", "cdios-goto", "-m", "1", "5000"]);
    let d = &e["device"];
    assert_eq!((d["command_code"].as_str(), e["module"].as_u64(), d["code"].as_u64()), (Some("23"), Some(1), Some(0)));
    assert_eq!(
        d["details"],
        json!([{"name": "MOTOR_NOT_ENABLED", "mask": 128, "class": "error", "description": "motor is not enabled"}])
    );
    let msg = e["message"].as_str().unwrap();
    assert!(msg.ends_with("refused goto absolute position=5000: MOTOR_NOT_ENABLED (motor is not enabled)"), "{msg}");
}

// The bench's controller has 3 axes: axis 9 is the controller's refusal,
// with the axis and the controller's code.
#[test]
fn an_axis_the_controller_lacks_under_json() {
    let e = error_of(&["--link", "sim", "--json", "pac-axis", "9"]);
    assert_eq!((&e["family"], &e["axis"]), (&json!("pac"), &json!(9)));
    assert_eq!((&e["device"]["code"], &e["device"]["text"]), (&json!(32), &json!("axis number unknown")));
}

#[test]
fn other_errors_carry_the_address_but_no_device_object() {
    let e = error_with(&["--link", "sim", "--json", "--timeout", "20", "state", "-m", "9"], 4);
    assert_eq!(e["kind"], "timeout");
    assert_eq!((&e["family"], &e["module"]), (&json!("powercube"), &json!(9)));
    assert!(e.get("device").is_none(), "{e}");
}

// A link that cannot be opened and a missing link: the same object, with
// their own kinds and exit codes.
#[test]
fn link_errors_under_json() {
    let e = error_with(&["--link", "serial:/dev/axisctl-none", "--json", "state", "-m", "3"], 3);
    assert_eq!(e["kind"], "link");
    assert_eq!(e["link"], "serial:/dev/axisctl-none", "the error names the link: {e}");
    assert!(e["message"].as_str().unwrap().contains("/dev/axisctl-none"), "{e}");
    let r = common::bin().env_remove("AXISCTL_LINK").args(["--json", "state", "-m", "3"]).output().unwrap();
    assert_eq!(r.status.code(), Some(2));
    let doc: Value = serde_json::from_slice(&r.stderr).unwrap();
    assert_eq!((&doc["error"]["kind"], &doc["error"]["exit_code"]), (&json!("usage"), &json!(2)), "{doc}");
}

// clap's rejections are errors like any other under --json: one object,
// kind usage, exit 2, nothing sent.
#[test]
fn argument_errors_are_json_objects_under_json() {
    for (args, argument) in [
        (&["--link", "sim", "--json", "pac-axis", "17"][..], Some("<AXIS[,AXIS...]|all>")),
        (&["--link", "sim", "--json", "state", "-m", "0"], Some("--module <ID[,ID...]|all>")),
        (&["--link", "sim", "--json", "state"], None),
        (&["--link", "sim", "--json", "pac-axis"], None),
        (&["--link", "sim", "--json", "--timeout", "abc", "state", "-m", "3"], Some("--timeout <MS>")),
        (&["--link", "sim", "--json", "frobnicate"], None),
        (&["--link", "sim", "home", "--json", "-m", "32"], Some("--module <ID>")),
    ] {
        let e = error_with(args, 2);
        assert_eq!(e["kind"], "usage", "{args:?}");
        assert!(!e["message"].as_str().unwrap().starts_with("error:"), "{e}");
        if let Some(a) = argument {
            assert_eq!(e["argument"], a, "{args:?}: {e}");
        }
    }
    // Without --json (and after `--`, where it is a value) the error stays text.
    let r = run(&["--link", "sim", "state", "-m", "0"]);
    assert_eq!(r.code, 2);
    // In the tool's one error style, as every other error.
    assert!(r.stderr.starts_with("axisctl: invalid value '0' for '--module"), "{}", r.stderr);
}

// docs/json.md shows errors as the binary prints them: each block after an
// `<!-- error: ARGS -->` line is the exact error object of `axisctl ARGS`.
#[test]
fn documented_errors_are_real_output() {
    let md = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/json.md")).unwrap();
    let mut checked = 0;
    let mut lines = md.lines();
    while let Some(line) = lines.next() {
        let Some(args) = line.strip_prefix("<!-- error: ").and_then(|l| l.strip_suffix(" -->")) else { continue };
        assert_eq!(lines.next().map(str::trim), Some("```json"), "a JSON block follows {line}");
        let body: Vec<&str> = lines.by_ref().take_while(|l| l.trim() != "```").collect();
        let documented: Value = serde_json::from_str(&body.join("\n")).unwrap_or_else(|e| panic!("{args}: {e}"));
        let args: Vec<&str> = args.split_whitespace().collect();
        let code = documented["error"]["exit_code"].as_i64().unwrap_or(-1) as i32;
        assert_eq!(documented["error"], error_with(&args, code), "docs/json.md: `axisctl {}`", args.join(" "));
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} documented errors");
}

// The environment's link matters only to commands that talk to a device: an
// offline command runs whatever AXISCTL_LINK holds, and a command that needs
// the link says which variable held the bad value.
#[test]
fn a_bad_axisctl_link_fails_only_commands_that_use_a_link_and_is_named() {
    let offline: &[&[&str]] =
        &[&["decode", "cube-state", "1"], &["params"], &["flags", "brake"], &["completions", "bash"], &["man"]];
    for args in offline {
        let r = common::bin().env("AXISCTL_LINK", "bogus").args(*args).output().unwrap();
        assert_eq!(r.status.code(), Some(0), "{args:?}: {}", String::from_utf8_lossy(&r.stderr));
    }
    let r = common::bin().env("AXISCTL_LINK", "bogus").args(["--json", "state", "-m", "3"]).output().unwrap();
    assert_eq!(r.status.code(), Some(2));
    let doc: Value = serde_json::from_slice(&r.stderr).unwrap();
    let message = doc["error"]["message"].as_str().unwrap();
    assert!(message.starts_with("AXISCTL_LINK: bad link \"bogus\""), "{doc}");
    let r = common::bin().args(["--link", "bogus", "state", "-m", "3"]).output().unwrap();
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("--link: bad link \"bogus\""));
}

// -q prints no results (the exit status says how it went; errors still go to
// stderr); -v / --verbose is --trace, not a misspelled --version.
#[test]
fn quiet_prints_no_results_and_verbose_is_the_trace() {
    let r = run(&["--link", "sim", "-q", "state", "-m", "3"]);
    assert_eq!((r.code, r.stdout.as_str()), (0, ""), "{}", r.stderr);
    let r = run(&["--link", "sim", "-q", "state", "-m", "9"]);
    assert_eq!((r.code, r.stdout.as_str()), (4, ""));
    assert!(r.stderr.starts_with("axisctl: "), "the error is still said: {}", r.stderr);
    assert_eq!(run(&["--link", "sim", "-q", "--json", "state", "-m", "3"]).code, 2, "-q and --json conflict");
    for flag in ["-v", "--verbose"] {
        let r = run(&["--link", "sim", flag, "state", "-m", "3"]);
        assert_eq!(r.code, 0, "{}", r.stderr);
        assert!(r.stderr.contains("-> 0C3#0A27 GetExtended CubeState to module 3"), "{flag}: {}", r.stderr);
        assert!(r.stdout.contains("CubeState"), "{flag}: {}", r.stdout);
    }
}
