//! What `cdios-*` puts on the wire, byte for byte, against a hand-written
//! slcan responder on a pty (no simulator involved).

use crate::common;

use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use axisctl::link::{pty, ByteLink};

/// A minimal slcan adapter: acknowledges setup commands, collects the
/// transmitted frame lines, and answers each frame line with `answer(line)`.
struct Responder {
    master: pty::PtyMaster,
    pending: Vec<u8>,
    lines: Vec<String>,
}

impl Responder {
    fn new() -> (Self, String) {
        let (master, path) = pty::open_pair().unwrap();
        (Self { master, pending: Vec::new(), lines: Vec::new() }, path)
    }

    /// Runs until `child` exits; returns the frame lines the tool sent.
    fn serve(&mut self, mut child: Child, mut answer: impl FnMut(&str) -> Option<String>) -> (i32, String, String) {
        let deadline = Instant::now() + Duration::from_secs(10);
        let mut buf = [0u8; 256];
        loop {
            assert!(Instant::now() < deadline, "tool did not finish; lines {:?}", self.lines);
            if let Some(status) = child.try_wait().unwrap() {
                let out = child.wait_with_output().unwrap();
                return (
                    status.code().unwrap_or(-1),
                    String::from_utf8_lossy(&out.stdout).into(),
                    String::from_utf8_lossy(&out.stderr).into(),
                );
            }
            let n = self.master.read(&mut buf, Duration::from_millis(5)).unwrap_or(0);
            self.pending.extend_from_slice(&buf[..n]);
            while let Some(i) = self.pending.iter().position(|b| *b == b'\r') {
                let raw: Vec<u8> = self.pending.drain(..=i).collect();
                let line = String::from_utf8_lossy(&raw[..raw.len() - 1]).to_string();
                // Every command, frames included, is acknowledged with CR.
                let mut reply = b"\r".to_vec();
                if line.starts_with('t') {
                    if let Some(a) = answer(&line) {
                        reply.extend_from_slice(a.as_bytes());
                        reply.push(b'\r');
                    }
                }
                let _ = self.master.write_all(&reply);
                self.lines.push(line);
            }
        }
    }

    fn frames(&self) -> Vec<&str> {
        self.lines.iter().filter(|l| l.starts_with('t')).map(String::as_str).collect()
    }
}

fn spawn(args: &[&str]) -> Child {
    common::bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()
}

/// The node's confirmation: the command's code and module, the rest 0.
fn confirm(line: &str) -> Option<String> {
    line.strip_prefix("t2018").map(|d| format!("t1818{}000000000000", &d[..4]))
}

/// A node that answers nothing before its NMT start (pre-operational).
fn after_nmt(started: &mut bool, line: &str) -> Option<String> {
    *started |= line == "t00020101";
    if *started {
        confirm(line)
    } else {
        None
    }
}

#[test]
fn goto_sends_nmt_then_the_contract_frame() {
    let (mut r, path) = Responder::new();
    let child = spawn(&["--link", &format!("slcan:{path}"), "--json", "cdios-goto", "-m", "1", "--node", "1", "5000"]);
    let mut started = false;
    let (code, out, err) = r.serve(child, |l| after_nmt(&mut started, l));
    assert_eq!(code, 0, "{err}");
    // The status read of module 1 goes unanswered, so NMT start node 1 (`000#0101`), the read
    // again (answered), then 23h selector 0, module 1, 5000 = 0x1388 little-endian.
    let probe = "t20182601000000000000";
    assert_eq!(r.frames(), [probe, "t00020101", probe, "t20182301008813000000"]);
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(
        (doc["node"].as_u64(), doc["module"].as_u64(), doc["requested"].as_i64()),
        (Some(1), Some(1), Some(5000))
    );
    assert_eq!(doc["acknowledged"], true);
}

#[test]
fn no_nmt_and_node_id_move_the_can_ids() {
    let (mut r, path) = Responder::new();
    let child = spawn(&["--link", &format!("slcan:{path}"), "cdios-position", "-m", "3", "--node", "5", "--no-nmt"]);
    let (code, out, err) = r.serve(child, |l| {
        // Read current position of module 3 on node 5: -1200 = 0xFFFFFB50.
        assert_eq!(l, "t20582103000000000000");
        Some("t185821030050FBFFFF00".into())
    });
    assert_eq!(code, 0, "{err}");
    assert_eq!(r.frames().len(), 1);
    assert!(out.contains("-1200"), "{out}");
}

#[test]
fn an_error_reply_is_exit_5_with_the_bits_decoded_and_motion_is_not_repeated() {
    let (mut r, path) = Responder::new();
    let child = spawn(&["--link", &format!("slcan:{path}"), "--json", "cdios-goto", "-m", "1", "-200"]);
    // The node runs: it answers the status read that asks it first. Then the
    // manual's 23h error A3h: error status bit 7 "Motor is not enabled".
    let (code, out, err) = r.serve(child, |l| {
        l.starts_with("t201").then(|| {
            if l.starts_with("t201826") {
                confirm(l).unwrap()
            } else {
                "t1818A301000080000000".to_string()
            }
        })
    });
    assert_eq!(code, 5, "{out} {err}");
    assert!(out.is_empty());
    let doc: serde_json::Value = serde_json::from_str(err.trim()).unwrap();
    assert_eq!(doc["error"]["kind"], "device");
    assert!(doc["error"]["message"].as_str().unwrap().contains("MOTOR_NOT_ENABLED"), "{err}");
    assert_eq!(r.frames(), ["t20182601000000000000", "t201823010038FFFFFF00"], "no NMT start, the goto once");
}

#[test]
fn events_and_powercube_frames_do_not_answer_a_read() {
    let (mut r, path) = Responder::new();
    let child = spawn(&[
        "--link",
        &format!("slcan:{path}"),
        "--json",
        "--timeout",
        "300",
        "cdios-status",
        "-m",
        "0",
        "--no-nmt",
    ]);
    let (code, out, err) = r.serve(child, |l| match &l[5..9] {
        // A status event of module 0, a PowerCube ack, then the reply.
        "2600" if &l[9..11] == "00" => Some("t18186600000000000000\rt0A33080464\rt18182600008100801000".into()),
        "2600" => Some("t18182600022C01F6FF00".into()),
        _ => None,
    });
    assert_eq!(code, 0, "{err}");
    let doc: serde_json::Value = serde_json::from_str(&out).unwrap();
    // Status bytes 81 00 80 10, status 1 the low byte of raw.
    assert_eq!(doc["state"]["raw"], 0x1080_0081);
    assert_eq!(doc["motor_speed"]["value"], 300);
    assert_eq!(doc["rpm_error"]["value"], -10);
    assert!(doc["state"]["flags"].as_array().unwrap().iter().any(|f| f == "GOTO_ACTIVE"));
}

#[test]
fn out_of_range_input_sends_nothing() {
    for args in [
        &["cdios-goto", "-m", "1", "5000", "--speed", "32768"][..],
        &["cdios-goto", "-m", "16", "5000"],
        &["cdios-analog", "-m", "0", "--output", "1", "--set", "10001"],
        &["cdios-start", "-m", "0", "--option", "to-speed", "--speed", "30001"],
        &["cdios-config", "-m", "0", "maximum_speed=49"],
        &["cdios-config", "-m", "0", "traject0.speed1=40000"],
        &["cdios-events", "-m", "0", "--position-interval", "8"],
        &["cdios-traject", "-m", "0", "2"],
        &["cdios-outputs", "-m", "0", "--set", "16"],
        &["cdios-status", "-m", "0", "--node", "128"],
    ] {
        let (mut r, path) = Responder::new();
        let link = format!("slcan:{path}");
        let mut full = vec!["--link", link.as_str()];
        full.extend_from_slice(args);
        let (code, _, err) = r.serve(spawn(&full), |_| None);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(r.frames().is_empty(), "{args:?} sent {:?}", r.frames());
        assert!(err.contains(" to ") && !err.contains("..=") || err.contains("1 and 2"), "{args:?}: {err}");
    }
}
