//! A device refusal under --json carries what the device said, typed: the
//! family, the refused command and the manual's code and text.

mod common;

use common::run;
use serde_json::{json, Value};

fn error_of(args: &[&str]) -> Value {
    let r = run(args);
    assert_eq!(r.code, 5, "{args:?}: {} {}", r.stdout, r.stderr);
    assert!(r.stdout.is_empty(), "{}", r.stdout);
    let doc: Value = serde_json::from_str(r.stderr.trim()).unwrap_or_else(|e| panic!("{e}: {}", r.stderr));
    assert_eq!(doc["error"]["kind"], "device");
    doc["error"].clone()
}

// The bench's PA-CONTROL has 3 axes: 190C for axis 9 answers QUIT 20h.
#[test]
fn pa_control_quit_under_json() {
    let e = error_of(&["--link", "sim", "--json", "pac-raw", "190C", "9", "0"]);
    assert_eq!(
        e["device"],
        json!({"family": "pa-control", "command": "190C", "quit": 32, "text": "axis number unknown"})
    );
    let msg = e["message"].as_str().unwrap();
    assert!(msg.ends_with("command error 0x20 (32): axis number unknown"), "{msg}");
}

// The bench's Cdios node has modules 0 and 1: 26h to module 7 is general error 1.
#[test]
fn cdios_error_reply_under_json() {
    let e = error_of(&["--link", "sim", "--json", "cdios-status", "-m", "7"]);
    assert_eq!(
        e["device"],
        json!({
            "family": "cdios",
            "command": 0x26,
            "module": 7,
            "general": 1,
            "general_name": "NO_MODULE",
            "general_text": "no module at that module id",
            "errors": [],
            "unknown_bits": []
        })
    );
}

// A goto before the motor is enabled: general error 0, the bit says why.
#[test]
fn cdios_command_error_bits_under_json() {
    let e = error_of(&["--link", "sim", "--json", "cdios-goto", "-m", "1", "5000"]);
    let d = &e["device"];
    assert_eq!((d["command"].as_u64(), d["module"].as_u64(), d["general"].as_u64()), (Some(0x23), Some(1), Some(0)));
    assert_eq!(
        d["errors"],
        json!([{"name": "MOTOR_NOT_ENABLED", "meaning": "motor is not enabled", "status": 1, "bit": 7}])
    );
    let msg = e["message"].as_str().unwrap();
    assert!(msg.ends_with("refused goto absolute position=5000: MOTOR_NOT_ENABLED (motor is not enabled)"), "{msg}");
}

#[test]
fn other_errors_carry_no_device_object() {
    let r = run(&["--link", "sim", "--json", "--timeout", "20", "state", "-m", "9"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let doc: Value = serde_json::from_str(r.stderr.trim()).unwrap();
    assert_eq!(doc["error"]["kind"], "timeout");
    assert!(doc["error"].get("device").is_none(), "{doc}");
}

// docs/json.md shows refusals as the binary prints them: each block after an
// `<!-- error: ARGS -->` line is the exact error object of `axisctl ARGS`.
#[test]
fn documented_refusals_are_real_output() {
    let md = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/json.md")).unwrap();
    let mut checked = 0;
    let mut lines = md.lines();
    while let Some(line) = lines.next() {
        let Some(args) = line.strip_prefix("<!-- error: ").and_then(|l| l.strip_suffix(" -->")) else { continue };
        assert_eq!(lines.next().map(str::trim), Some("```json"), "a JSON block follows {line}");
        let body: Vec<&str> = lines.by_ref().take_while(|l| l.trim() != "```").collect();
        let documented: Value = serde_json::from_str(&body.join("\n")).unwrap_or_else(|e| panic!("{args}: {e}"));
        let args: Vec<&str> = args.split_whitespace().collect();
        assert_eq!(documented["error"], error_of(&args), "docs/json.md: `axisctl {}`", args.join(" "));
        checked += 1;
    }
    assert!(checked >= 2, "only {checked} documented refusals");
}
