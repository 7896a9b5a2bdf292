//! One JSON vocabulary: the decoders and the commands give the same result
//! for the same word, and a PowerCube move's target carries its unit.

use crate::common;

use common::run;
use serde_json::Value;

/// The keys of the one state shape, taken out of a document that has it
/// at the top level (`decode`).
fn state_part(doc: &Value) -> Value {
    let keys = ["raw", "flags", "errors", "warnings", "details", "unknown_bits"];
    keys.iter().map(|k| (k.to_string(), doc[*k].clone())).collect::<serde_json::Map<_, _>>().into()
}

#[test]
fn pac_axis_and_decode_give_the_same_extended_axis_status() {
    // The simulated axes give different words: power pack ready, limit
    // switches, an axis status.
    let r = run(&["--link", "sim", "--json", "pac-axis", "all"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let devices = r.json()["devices"].as_array().cloned().unwrap();
    assert!(devices.len() >= 3, "{devices:?}");
    let mut words = Vec::new();
    for d in devices {
        let state = &d["state"];
        let raw = state["raw"].as_u64().unwrap();
        let decoded = run(&["--json", "decode", "pac-ext-axis-status", &raw.to_string()]);
        assert_eq!(decoded.code, 0, "{}", decoded.stderr);
        assert_eq!(&state_part(&decoded.json()), state, "axis {}: word {raw:#010x}", d["axis"]);
        words.push(raw);
    }
    // A word with every field saying something: both limit switches
    // activated (their bytes 0), the power pack ready, the axis moving and
    // a reserved bit of the axis status set.
    let word = 0x0100_0011u32;
    let decoded = run(&["--json", "decode", "pac-ext-axis-status", &word.to_string()]).json();
    let flags: Vec<&str> = decoded["flags"].as_array().unwrap().iter().filter_map(Value::as_str).collect();
    assert_eq!(flags, ["POWER_PACK_READY", "POSITIVE_LIMIT_ACTIVATED", "NEGATIVE_LIMIT_ACTIVATED", "AXIS_MOVING"]);
    assert_eq!(decoded["unknown_bits"], 0x10, "{decoded}");
    assert_eq!(decoded["warnings"].as_array().unwrap().len(), 2, "{decoded}");
}

#[test]
fn state_gives_the_short_state_in_the_shape_decode_gives_it() {
    let r = run(&["--link", "sim", "--json", "state", "-m", "17"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let short = &r.json()["short_state"];
    let raw = short["raw"].as_u64().expect("short_state is the state shape");
    let decoded = run(&["--json", "decode", "short-state", &raw.to_string()]);
    assert_eq!(&state_part(&decoded.json()), short);
    // The module is not homed: bit 0, SHORT_NOT_OK.
    assert_eq!(short["flags"], serde_json::json!(["SHORT_NOT_OK"]), "{short}");
    // decode profibus-image gives its short state in the same shape.
    let image = run(&["--json", "decode", "profibus-image", "0a3c0000403f00000010270000040012"]).json();
    let keys = |v: &Value| v.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
    assert_eq!(keys(&image["short_state"]), keys(short));
}

/// A refused Cdios command and `decode cdios-error` of the reply it got
/// (read back from the --log) say the same: the refusal shape.
#[test]
fn decode_cdios_error_gives_what_the_refused_command_reported() {
    let log = tempfile::Builder::new().suffix(".log").tempfile().unwrap();
    let p = log.path().to_str().unwrap();
    let r = run(&["--link", "sim", "--json", "--log", p, "cdios-goto", "-m", "0", "5000"]);
    assert_eq!(r.code, 5, "the motor is not enabled: {}", r.stderr);
    let err: Value = serde_json::from_str(r.stderr.lines().last().unwrap()).unwrap();
    let device = err["error"]["device"].as_object().unwrap().clone();
    let text = std::fs::read_to_string(log.path()).unwrap();
    // `(t) sim0 181#A300000080000000`: the error reply (code | 0x80).
    let reply = text.lines().filter_map(|l| l.split('#').nth(1)).find(|d| d.starts_with("A3")).unwrap();
    let decoded = run(&["--json", "decode", "cdios-error", reply]);
    assert_eq!(decoded.code, 0, "{}", decoded.stderr);
    let decoded = decoded.json();
    for (k, v) in &device {
        assert_eq!(&decoded[k], v, "{k}: decode says {decoded}, the command said {device:?}");
    }
    assert_eq!((&decoded["module"], &decoded["manual_command"]), (&0.into(), &"Goto position".into()));
    assert!(common::schema_errors(&common::schema("document"), &decoded).is_none(), "{decoded}");
}

#[test]
fn a_powercube_moves_target_carries_the_modules_unit() {
    let target = |args: &[&str]| {
        let r = run(&[&["--link", "sim", "--json"][..], args].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        r.json()["target"].clone()
    };
    // Module 17 is linear, 3 rotary.
    assert_eq!(target(&["move-ramp", "-m", "17", "0.1"]), serde_json::json!({"value": 0.1, "unit": "m"}));
    assert_eq!(
        target(&["move-step", "-m", "3", "0.2", "--time", "500"]),
        serde_json::json!({"value": 0.2, "unit": "rad"})
    );
    assert_eq!(
        target(&["move-ramp", "-m", "3", "1000", "--ticks"]),
        serde_json::json!({"value": 1000.0, "unit": "ticks"})
    );

    let sim = common::Sim::start(&[], 3);
    let link = sim.link("powercube");
    for m in ["3", "17"] {
        let r = run(&["--link", link, "set-config", "-m", m, "+sync-motion"]);
        assert_eq!(r.code, 0, "{}", r.stderr);
    }
    let r = run(&["--link", link, "--json", "move-ramp", "-m", "3,17", "--sync", "0.05", "0.02"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let units: Vec<Value> =
        r.json()["devices"].as_array().unwrap().iter().map(|d| d["target"]["unit"].clone()).collect();
    assert_eq!(units, ["rad", "m"]);
}

/// The unit comes from a read of the module's Config that precedes the
/// motion frame: a failed read sends no motion, and nothing is read after it.
#[test]
fn the_targets_unit_is_read_before_the_motion_frame() {
    let r = run(&["--link", "sim", "--json", "--trace", "move-ramp", "-m", "17", "0.1"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let sent: Vec<&str> = r.stderr.lines().filter(|l| l.starts_with("->")).collect();
    let config = sent.iter().position(|l| l.contains("GetExtended Config")).expect("the Config is read");
    let motion = sent.iter().position(|l| l.contains("SetMotion")).expect("the motion is sent");
    assert!(config < motion, "{sent:#?}");
    assert_eq!(motion, sent.len() - 1, "nothing is sent after the motion: {sent:#?}");
}

/// The other status words the commands give: CubeState (`state`) and the
/// Cdios status bytes (`cdios-status`, status 1 the low byte of `raw`).
#[test]
fn state_and_cdios_status_give_what_decode_gives_for_their_word() {
    // Homed, so that CubeState has a flag set (one bench for both lines).
    let mut child = common::bin()
        .args(["--link", "sim", "--json", "batch"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    use std::io::Write;
    child.stdin.take().unwrap().write_all(b"home -m 3 --wait\nstate -m 3\n").unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{out:?}");
    let last: Value = serde_json::from_str(String::from_utf8_lossy(&out.stdout).lines().last().unwrap()).unwrap();
    let state = &last["result"]["state"];
    assert!(state["flags"].as_array().unwrap().iter().any(|f| f == "STATE_HOME_OK"), "{state}");
    let raw = state["raw"].as_u64().unwrap();
    assert_eq!(&state_part(&run(&["--json", "decode", "cube-state", &raw.to_string()]).json()), state);

    let r = run(&["--link", "sim?cdios=enabled", "--json", "cdios-status", "-m", "0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let state = &r.json()["state"];
    let raw = u32::try_from(state["raw"].as_u64().unwrap()).unwrap();
    assert!(state["flags"].as_array().unwrap().iter().any(|f| f == "ENABLED"), "{state}");
    let bytes: String = raw.to_le_bytes().iter().map(|b| format!("{b:02x}")).collect();
    assert_eq!(&state_part(&run(&["--json", "decode", "cdios-status", &bytes]).json()), state, "{bytes}");
}

/// An extended motion acknowledge (`monitor`, `send`, `decode
/// profibus-image`) gives its short state and DIO byte in the state shape,
/// as `decode short-state` and `decode dio` give them.
#[test]
fn a_motion_acknowledges_short_state_and_dio_are_state_objects() {
    let log = tempfile::Builder::new().suffix(".log").tempfile().unwrap();
    // FRAMP_ACK of module 17: position 0.75, short state 0x20, DIO 0x11.
    std::fs::write(log.path(), "(1.000000) can0 0B1#0B0E0000403F2011\n").unwrap();
    let r = run(&["--json", "monitor", "--from-log", log.path().to_str().unwrap()]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let details = &r.json()["details"];
    for (key, kind, raw) in [("short_state", "short-state", "0x20"), ("dio", "dio", "0x11")] {
        let decoded = run(&["--json", "decode", kind, raw]).json();
        assert_eq!(&state_part(&decoded), &details[key], "{key}");
    }
    assert!(common::schema_errors(&common::schema("stream_line"), &r.json()).is_none(), "{}", r.stdout);
}
