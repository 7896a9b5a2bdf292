//! Streams keep the contract too: every JSON Lines output (`sim`, `monitor`,
//! `cdios-watch`, `--progress-json`) is one `$defs/stream_line` per line of
//! the published schema, with the same envelope as the documents.

use crate::common;

use std::io::{BufRead, BufReader, Write};
use std::process::Stdio;
use std::time::{Duration, Instant};

use common::{run, schema, schema_errors};
use serde_json::Value;
use serialport::SerialPort;

/// Each line of `text`, parsed and checked against the stream schema.
fn stream_lines(what: &str, text: &str) -> Vec<Value> {
    let line = schema("stream_line");
    let lines: Vec<Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{what}: not JSON ({e}): {l}")))
        .collect();
    assert!(!lines.is_empty(), "{what}: no lines");
    for v in &lines {
        if let Some(e) = schema_errors(&line, v) {
            panic!("{what}: {v} breaks the schema:\n{e}");
        }
    }
    lines
}

#[test]
fn sim_announces_each_served_link_as_a_stream_line() {
    let mut child = common::bin().args(["--json", "sim"]).stdout(Stdio::piped()).spawn().unwrap();
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut text = String::new();
    for _ in 0..3 {
        out.read_line(&mut text).unwrap();
    }
    let _ = child.kill();
    let _ = child.wait();
    let lines = stream_lines("sim", &text);
    let families: Vec<&str> = lines.iter().map(|l| l["family"].as_str().unwrap()).collect();
    assert_eq!(families, ["powercube", "cdios", "pac"]);
    for l in &lines {
        // Pasted unquoted into a shell, a link must stay one word.
        assert!(!l["link"].as_str().unwrap().contains(['&', ' ', ';']), "{l}");
    }
}

#[test]
fn monitor_frames_and_stats_of_a_replay_follow_the_schema() {
    let log = tempfile::Builder::new().suffix(".log").tempfile().unwrap();
    let p = log.path().to_str().unwrap();
    for args in [
        &["state", "-m", "3"][..],
        &["set-param", "-m", "17", "TargetVel", "0.05"],
        &["cdios-status", "-m", "0"],
        &["cdios-enable", "-m", "1"],
    ] {
        let r = run(&[&["--link", "sim", "--log", p][..], args].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    // A frame no family claims, and one of a family that does not decode.
    let mut f = std::fs::OpenOptions::new().append(true).open(log.path()).unwrap();
    writeln!(f, "(1.000000) can0 7FF#00\n(1.000100) can0 0A3#FF").unwrap();

    let r = run(&["--json", "monitor", "--from-log", p, "--stats"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = stream_lines("monitor --from-log", &r.stdout);
    let (frames, stats) = lines.split_at(lines.len() - 1);
    assert_eq!(stats[0]["stats"]["frames"], frames.len());
    assert!(frames.iter().all(|f| f.get("link").is_none()), "a replay has no link");
    let other = &frames[frames.len() - 2];
    assert_eq!(other["family"], Value::Null, "{other}");
    assert!(frames.iter().any(|f| f["family"] == "powercube") && frames.iter().any(|f| f["family"] == "cdios"));
    assert!(frames.last().unwrap().get("decode_error").is_some(), "{}", frames.last().unwrap());
}

/// A live monitor names the link it listens on, like every document. The
/// test plays a CAN adapter on a pty that never acknowledges commands (as a
/// CANable 1 does) and puts two frames on its bus until both are shown.
#[test]
fn a_live_monitor_names_its_link_on_every_frame() {
    let (mut adapter, host) = serialport::TTYPort::pair().expect("pty pair");
    let link = format!("slcan:{}", host.name().unwrap());
    let mut child = common::bin()
        .args(["--json", "--link", &link, "monitor", "--count", "2"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(out).unwrap());
    let deadline = Instant::now() + Duration::from_secs(20);
    while child.try_wait().unwrap().is_none() && Instant::now() < deadline {
        adapter.write_all(b"t0A360A3C0000803F\rt7FF100\r").unwrap();
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let status = child.wait().unwrap();
    let text = reader.join().unwrap();
    assert!(status.success(), "{status}: {text}");
    let lines = stream_lines("live monitor", &text);
    assert_eq!(lines.len(), 2, "{text}");
    for l in &lines {
        assert_eq!(l["link"], link.as_str(), "{l}");
    }
    assert!(lines.iter().any(|l| l["family"] == "powercube" && l["module"] == 3), "{text}");
    assert!(lines.iter().any(|l| l["family"] == Value::Null), "{text}");
}

#[test]
fn cdios_watch_statuses_and_events_follow_the_schema() {
    let sim = common::Sim::start(&[], 3);
    let link = sim.link("cdios");
    let events = ["--link", link, "cdios-events", "-m", "0", "--mask", "GOTO_ACTIVE", "--position-interval", "3"];
    let r = run(&events);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let r = run(&["--link", link, "--json", "cdios-watch", "-m", "0", "--count", "6"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines = stream_lines("cdios-watch", &r.stdout);
    assert!(lines.iter().any(|l| l["kind"] == "status"), "{}", r.stdout);
    assert!(lines.iter().any(|l| l["kind"] == "event"), "{}", r.stdout);
    for l in &lines {
        assert_eq!((l["family"].as_str(), l["link"].as_str(), &l["node"]), (Some("cdios"), Some(link), &1.into()));
    }
}

#[test]
fn pac_progress_lines_follow_the_schema() {
    let sim = common::Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    for args in [&["pac-online"][..], &["pac-ref", "2", "--wait"]] {
        let r = run(&[&["--link", link][..], args].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let progress = |args: &[&str]| {
        let r = run(&[&["--link", link, "--json"][..], args, &["--wait", "--progress-json"]].concat());
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        stream_lines("--progress-json", &r.stderr)
    };
    let moving = progress(&["pac-move", "2", "150"]);
    assert!(moving.iter().all(|l| l["progress"]["position"]["unit"] == "AE"), "{moving:?}");
    let referencing = progress(&["pac-ref", "2"]);
    assert!(referencing.iter().all(|l| l["progress"]["polls"].is_u64()), "{referencing:?}");
    for l in moving.iter().chain(&referencing) {
        assert_eq!((l["progress"]["link"].as_str(), &l["progress"]["axis"]), (Some(link), &2.into()));
    }
}

// The stream schema is no formality: the shapes of 0.1 and lines without
// their envelope are rejected.
#[test]
fn the_stream_schema_rejects_lines_without_the_contract() {
    let line = schema("stream_line");
    let good = serde_json::json!({"progress": {"family": "pac", "link": "sim", "axis": 2, "elapsed_ms": 150,
                                               "axis_status": 1, "position": {"value": 37.5, "unit": "AE"}}});
    assert_eq!(schema_errors(&line, &good), None);
    for bad in [
        serde_json::json!({"progress": {"axis": 2, "axis_status": 1, "elapsed_ms": 150, "position": 37.5}}),
        serde_json::json!({"progress": {"family": "pac", "link": "sim", "axis": 2, "elapsed_ms": 1, "axis_status": 1,
                                        "position": 37.5}}),
        serde_json::json!({"family": "other", "kind": "raw", "summary": "", "timestamp": 1.0, "frame": "7FF#00"}),
        serde_json::json!({"family": "powercube", "kind": "ack", "summary": "", "timestamp": 1.0}),
        serde_json::json!({"family": "powercube", "kind": "raw", "summary": "", "timestamp": 1.0, "frame": "0A3#FF",
                           "error": "unknown command id 0xff"}),
        serde_json::json!({"type": "event", "t_ms": 1, "module": 0, "node": 1, "code": 97, "data": [97, 0, 0, 0, 0, 0, 0, 0]}),
        serde_json::json!({"family": "cdios", "link": "sim", "node": 1, "module": 0, "type": "status", "t_ms": 1,
                           "position": 0, "status": [0, 0, 0, 0]}),
        serde_json::json!({"family": "pac", "link": "serial:/dev/pts/1?baud=9600&format=7N1", "axes": 3}),
        serde_json::json!({"stats": {"frames": 1}}),
    ] {
        assert!(schema_errors(&line, &bad).is_some(), "accepted {bad}");
    }
}
