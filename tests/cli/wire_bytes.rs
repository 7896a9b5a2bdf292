//! What leaves the binary, byte for byte, against a hand-written responder
//! on a pty (no simulator involved): the issue's "done when" frames.

use crate::common;

use std::process::Stdio;
use std::time::{Duration, Instant};

use axisctl::link::{pty, ByteLink};

fn read_until(master: &mut pty::PtyMaster, mut done: impl FnMut(&[u8]) -> bool) -> Vec<u8> {
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    let deadline = Instant::now() + Duration::from_secs(5);
    while !done(&got) {
        assert!(Instant::now() < deadline, "timed out; got {got:02x?}");
        let n = master.read(&mut buf, Duration::from_millis(50)).unwrap();
        got.extend_from_slice(&buf[..n]);
    }
    got
}

#[test]
fn serial_home_sends_the_manual_frame() {
    let (mut master, path) = pty::open_pair().unwrap();
    let child = common::bin()
        .args(["--link", &format!("serial:{path}"), "--json", "home", "-m", "17"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let sent = read_until(&mut master, |b| b.len() >= 6);
    // Manual section 9, "Home", Send.
    assert_eq!(sent, [0x02, 0x06, 0x21, 0x01, 0x28, 0x03]);
    // Manual section 9, "Home", Ack.
    master.write_all(&[0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03]).unwrap();
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc["module"], 17);
}

#[test]
fn slcan_home_sends_the_can_frame() {
    let (mut master, path) = pty::open_pair().unwrap();
    let child = common::bin()
        .args(["--link", &format!("slcan:{path}"), "home", "-m", "17"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Answer every setup command with OK until the frame arrives.
    let mut lines: Vec<String> = Vec::new();
    let mut pending = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut buf = [0u8; 256];
    while !lines.iter().any(|l| l.starts_with('t')) {
        assert!(Instant::now() < deadline, "no frame; lines {lines:?}");
        let n = master.read(&mut buf, Duration::from_millis(50)).unwrap();
        pending.extend_from_slice(&buf[..n]);
        while let Some(i) = pending.iter().position(|b| *b == b'\r') {
            let line: Vec<u8> = pending.drain(..=i).collect();
            let line = String::from_utf8_lossy(&line[..line.len() - 1]).to_string();
            if !line.starts_with('t') {
                master.write_all(b"\r").unwrap();
            }
            lines.push(line);
        }
    }
    assert!(lines.contains(&"S8".to_string()), "1 Mbit/s by default: {lines:?}");
    assert!(lines.contains(&"O".to_string()), "channel opened: {lines:?}");
    // Module 17, Home: id 0x0F1, one byte 01.
    assert_eq!(lines.last().unwrap(), "t0F1101");
    master.write_all(b"\rt0B1101\r").unwrap();
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
}

/// The broadcast a command sends over `serial:`, as the pty sees it.
fn serial_broadcast(args: &[&str]) -> Vec<u8> {
    let (mut master, path) = pty::open_pair().unwrap();
    let link = format!("serial:{path}");
    let mut all = vec!["--link", &link];
    all.extend_from_slice(args);
    let child = common::bin().args(&all).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let sent = read_until(&mut master, |b| b.last() == Some(&0x03));
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    sent
}

#[test]
fn serial_broadcasts_carry_cmd_and_a_zero_as_the_vendor_library_sends_them() {
    // Module 0, length 2, data [02, 00]: TELID 04 02 and the data's 02 escaped.
    assert_eq!(serial_broadcast(&["halt", "--all"]), [0x02, 0x04, 0x10, 0x82, 0x10, 0x82, 0x00, 0x08, 0x03]);
    // Reset: data [00, 00], BCC 04 + 02.
    assert_eq!(serial_broadcast(&["reset", "--all"]), [0x02, 0x04, 0x10, 0x82, 0x00, 0x00, 0x06, 0x03]);
}
