//! The `pac-*` commands: byte-exact against hand-written responders on a pty
//! (wire frames, CHECK rules, refusals, Ctrl-C), and end to end against
//! `axisctl sim --pac pty-serial` and the in-process `--link sim`.

use crate::common;

use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use axisctl::link::{pty, ByteLink};
use axisctl::proto::pac::frame::EncodeOptions;
use axisctl::proto::pac::{Ack, CheckRule, Command, CommandDecoder, Par2, Request};
use common::{run, Sim};

fn hex(s: &str) -> Vec<u8> {
    s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
}

fn ack(status: u16, be: bool, q_par: Par2, rule: CheckRule) -> Ack {
    Ack { quit: 0, be, status, error: 0, q_par, check_rule: rule }
}

/// Each request as received: its raw bytes and what it decoded to.
type Seen = Arc<Mutex<Vec<(Vec<u8>, Request)>>>;

/// A hand-written controller on a pty: every request (raw bytes and
/// decoded) is recorded; `answer` decides the acknowledge (`None`: silence).
struct Responder {
    path: String,
    stop: Arc<AtomicBool>,
    seen: Seen,
    thread: Option<JoinHandle<()>>,
}

impl Responder {
    fn start(mut answer: impl FnMut(&Request) -> Option<Ack> + Send + 'static) -> Self {
        let (mut master, path) = pty::open_pair().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let seen: Seen = Arc::new(Mutex::new(Vec::new()));
        let (st, sn) = (Arc::clone(&stop), Arc::clone(&seen));
        let thread = std::thread::spawn(move || {
            let mut dec = CommandDecoder::new();
            let mut raw = Vec::new();
            let mut buf = [0u8; 256];
            while !st.load(Ordering::SeqCst) {
                let n = master.read(&mut buf, Duration::from_millis(10)).unwrap_or(0);
                raw.extend_from_slice(&buf[..n]);
                dec.push(&buf[..n]);
                while let Some(item) = dec.next() {
                    let Ok(req) = item else { continue };
                    let bytes = std::mem::take(&mut raw);
                    sn.lock().unwrap().push((bytes, req));
                    if let Some(a) = answer(&req) {
                        master.write_all(&a.encode().unwrap()).unwrap();
                    }
                }
            }
        });
        Self { path, stop, seen, thread: Some(thread) }
    }

    fn link(&self) -> String {
        format!("serial:{}", self.path)
    }

    fn seen(&self) -> Vec<(Vec<u8>, Request)> {
        self.seen.lock().unwrap().clone()
    }

    fn codes(&self) -> Vec<u16> {
        self.seen()
            .iter()
            .filter_map(|(_, r)| match r {
                Request::Command { command, .. } => Some(command.code),
                Request::Poll => None,
            })
            .collect()
    }
}

impl Drop for Responder {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn code_of(req: &Request) -> Option<u16> {
    match req {
        Request::Command { command, .. } => Some(command.code),
        Request::Poll => None,
    }
}

// Manual 3.4.3 command 1: start online mode goes out byte for byte as the
// manual's CHECK says (its printed bytes misspell the code; specs README),
// and the manual's acknowledge is understood.
#[test]
fn wire_pac_online_sends_the_manual_frame() {
    let r = Responder::start(|req| {
        code_of(req)?;
        Some(Ack::decode(&hex("01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04")).unwrap())
    });
    let out = run(&["--link", &r.link(), "--json", "pac-online"]);
    assert_eq!(out.code, 0, "{}", out.stderr);
    let seen = r.seen();
    // Before it only the status read (190B): online already (31), so the
    // speed limits, readable in home position only, are not read.
    assert_eq!(seen.len(), 2, "the status read and 0603: {seen:?}");
    assert_eq!(seen[0].0, hex("01 02 31 39 30 42 3B 30 3B 30 3B 30 03 31 31 33 04"));
    assert_eq!(seen[1].0, hex("01 02 30 36 30 33 3B 30 3B 30 3B 30 03 31 34 04"));
    assert_eq!(out.json()["operating_status"], 31);
}

#[test]
fn wire_check_with_etx_on_request() {
    let r = Responder::start(|req| code_of(req).map(|_| ack(1, true, Par2::Int(0), CheckRule::Strict)));
    let out = run(&["--link", &r.link(), "--pac-check-etx", "pac-state"]);
    assert_eq!(out.code, 0, "{}", out.stderr);
    let mut expected = Vec::new();
    Command::new(0x190B, 0, Par2::Int(0))
        .encode_with(&EncodeOptions { check_rule: CheckRule::WithEtx, ..Default::default() }, &mut expected)
        .unwrap();
    assert_eq!(r.seen()[0].0, expected);
    assert_ne!(expected, Command::new(0x190B, 0, Par2::Int(0)).encode().unwrap(), "the two rules differ here");
    match r.seen()[0].1 {
        Request::Command { check_rule, .. } => assert_eq!(check_rule, CheckRule::WithEtx),
        Request::Poll => panic!("a poll"),
    }
}

#[test]
fn both_check_rules_are_accepted_and_traced() {
    for (rule, note) in [(CheckRule::Strict, "CHECK without ETX"), (CheckRule::WithEtx, "CHECK with ETX")] {
        let r = Responder::start(move |req| code_of(req).map(|_| ack(31, true, Par2::Int(0), rule)));
        let out = run(&["--link", &r.link(), "--json", "--trace", "pac-state"]);
        assert_eq!(out.code, 0, "{rule:?}: {}", out.stderr);
        assert_eq!(out.json()["operating_status"], 31);
        assert_eq!(out.json()["operating_status_text"], "ONLINE");
        assert!(out.stderr.contains(note), "{rule:?}: trace {}", out.stderr);
    }
}

#[test]
fn command_error_is_exit_5_with_number_and_text() {
    let r = Responder::start(|req| match code_of(req)? {
        0x190B => Some(ack(31, true, Par2::Int(0), CheckRule::Strict)),
        _ => Some(Ack { quit: 0x41, ..ack(31, true, Par2::Float(0.0), CheckRule::Strict) }),
    });
    let out = run(&["--link", &r.link(), "pac-move", "2", "99999", "--force"]);
    assert_eq!(out.code, 5, "{}", out.stderr);
    assert!(out.stderr.contains("0x41 (65): position outside range"), "{}", out.stderr);
    assert_eq!(r.codes(), [0x190B, 0x0A94], "the move was sent once");
}

#[test]
fn command_not_valid_in_the_mode_is_refused_unsent() {
    // Home position: moves need online mode.
    let r = Responder::start(|req| code_of(req).map(|_| ack(1, true, Par2::Int(0), CheckRule::Strict)));
    let out = run(&["--link", &r.link(), "pac-move", "2", "10"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
    assert!(out.stderr.contains("not valid in home position mode"), "{}", out.stderr);
    assert_eq!(r.codes(), [0x190B], "only the mode was read");
    // Bad values never reach the line.
    let out = run(&["--link", &r.link(), "pac-out", "3", "2"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
    let out = run(&["--link", &r.link(), "pac-speed", "1", "-5"]);
    assert_eq!(out.code, 2, "{}", out.stderr);
    assert_eq!(r.codes(), [0x190B], "nothing more was sent");
}

#[test]
fn move_outside_the_traverse_area_is_refused_unsent() {
    let r = Responder::start(|req| match req {
        Request::Command { command, .. } => Some(match command.code {
            0x1913 => ack(31, true, Par2::Float(0.0), CheckRule::Strict),
            0x1914 => ack(31, true, Par2::Float(1000.0), CheckRule::Strict),
            _ => ack(31, true, Par2::Int(0), CheckRule::Strict),
        }),
        Request::Poll => None,
    });
    // Above the maximum and below the minimum alike.
    for target in ["1000.5", "-0.5"] {
        let out = run(&["--link", &r.link(), "pac-move", "1", target]);
        assert_eq!(out.code, 2, "{target}: {}", out.stderr);
        assert!(out.stderr.contains("traverse area 0 to 1000"), "{target}: {}", out.stderr);
        assert!(!r.codes().contains(&0x0A94), "{target}");
    }
}

fn wait_for(child: &mut Child, secs: u64) -> std::process::Output {
    let deadline = Instant::now() + Duration::from_secs(secs);
    while child.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "child did not exit");
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut stdout = String::new();
    let mut stderr = String::new();
    use std::io::Read;
    child.stdout.take().unwrap().read_to_string(&mut stdout).unwrap();
    child.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
    std::process::Output { status: child.wait().unwrap(), stdout: stdout.into(), stderr: stderr.into() }
}

/// Ctrl-C during `pac-move --wait`: 0A93 goes out, then exit 130.
#[test]
fn ctrl_c_during_move_wait_stops_the_axis() {
    let stopped = Arc::new(AtomicBool::new(false));
    let s2 = Arc::clone(&stopped);
    let pos = Arc::new(Mutex::new(0.0f64));
    let r = Responder::start(move |req| {
        let Request::Command { command, .. } = req else { return None };
        let mut p = pos.lock().unwrap();
        let a = |q| ack(31, true, q, CheckRule::Strict);
        Some(match command.code {
            0x1913 => a(Par2::Float(-1e6)),
            0x1914 => a(Par2::Float(1e6)),
            0x0A94 => a(Par2::Float(*p)),
            0x1910 => a(Par2::Int(if s2.load(Ordering::SeqCst) { 2 } else { 1 })),
            0x190C => {
                *p += 1.0;
                a(Par2::Float(*p))
            }
            0x0A93 => {
                s2.store(true, Ordering::SeqCst);
                a(Par2::Float(*p))
            }
            _ => a(Par2::Int(0)),
        })
    });
    let mut child = common::bin()
        .args(["--link", &r.link(), "--json", "pac-move", "3", "500000", "--wait", "--progress-json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(10);
    while r.codes().iter().filter(|c| **c == 0x190C).count() < 3 {
        assert!(Instant::now() < deadline, "no move polling: {:04X?}", r.codes());
        std::thread::sleep(Duration::from_millis(10));
    }
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = wait_for(&mut child, 10);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stopped.load(Ordering::SeqCst), "0A93 was sent: {:04X?}", r.codes());
    let stop = r.seen().into_iter().find(|(_, q)| code_of(q) == Some(0x0A93)).unwrap();
    assert_eq!(
        stop.1,
        Request::Command { command: Command::new(0x0A93, 3, Par2::Float(0.0)), check_rule: CheckRule::Strict }
    );
    assert!(stderr.contains("axis 3 stopped"), "{stderr}");
    assert!(out.stdout.is_empty(), "nothing on stdout after an interrupt");
}

// ---------------------------------------------------------------------------
// Against the simulator

fn pac_sim() -> Sim {
    Sim::start(&["--pac", "pty-serial"], 1)
}

/// The simulator shares two cores with the other tests: a generous answer
/// timeout keeps a busy machine from turning into exit 4.
fn srun(args: &[&str]) -> common::Run {
    let mut all = vec!["--timeout", "1000"];
    all.extend_from_slice(args);
    run(&all)
}

fn ok(args: &[&str]) -> serde_json::Value {
    let r = srun(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    r.json()
}

#[test]
fn sim_link_is_announced_7n1() {
    let sim = pac_sim();
    let link = sim.link("pac");
    // 9600 7N1 is the PA-CONTROL's default, left out: no `&` for the shell.
    assert!(link.starts_with("serial:/dev/") && !link.contains(['?', '&']), "{link}");
    let r = srun(&["--link", link, "--json", "pac-state"]);
    assert_eq!(r.code, 0, "the defaults reach the controller: {}", r.stderr);
}

#[test]
fn sim_online_reference_and_move_with_live_position() {
    let sim = pac_sim();
    let link = sim.link("pac");
    assert_eq!(ok(&["--link", link, "--json", "pac-state"])["operating_status"], 1);
    assert_eq!(ok(&["--link", link, "--json", "pac-online"])["operating_status"], 31);
    let r = ok(&["--link", link, "--json", "pac-ref", "2", "--wait"]);
    assert_eq!(r["done"], true);
    let r = srun(&["--link", link, "--json", "pac-move", "2", "200", "--wait", "--progress-json"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let end = r.json();
    assert!((end["position"]["value"].as_f64().unwrap() - 200.0).abs() < 1e-3, "{end}");
    assert_eq!(end["axis_status"], 0);
    let positions: Vec<f64> = r
        .stderr
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter_map(|v| v["progress"]["position"]["value"].as_f64())
        .collect();
    let distinct: std::collections::BTreeSet<i64> = positions.iter().map(|p| (p * 1000.0) as i64).collect();
    assert!(distinct.len() >= 3, "several live positions: {positions:?}");
    assert!(positions.windows(2).all(|w| w[1] >= w[0] - 1e-9), "monotonic towards the target: {positions:?}");
    let axis = ok(&["--link", link, "--json", "pac-axis", "2"]);
    assert_eq!(axis["axis"], 2);
    assert!((axis["position"]["value"].as_f64().unwrap() - 200.0).abs() < 1e-3, "{axis}");
    assert_eq!(axis["axis_status"], 0);
    assert_eq!(
        (&axis["position"]["unit"], &axis["speed"]["unit"]),
        (&serde_json::json!("AE"), &serde_json::json!("AE/s"))
    );
    let flags = &axis["state"]["flags"];
    assert!(flags.as_array().unwrap().iter().any(|f| f == "POWER_PACK_READY"), "{axis}");
}

#[test]
fn sim_target_outside_the_traverse_area_is_error_65() {
    let sim = pac_sim();
    let link = sim.link("pac");
    ok(&["--link", link, "--json", "pac-online"]);
    ok(&["--link", link, "--json", "pac-no-ref", "1"]);
    let max = ok(&["--link", link, "--json", "pac-axis", "1"])["traverse_max"]["value"].as_f64().unwrap();
    let beyond = format!("{}", max + 100.0);
    let r = srun(&["--link", link, "pac-move", "1", &beyond]);
    assert_eq!(r.code, 2, "checked locally first: {}", r.stderr);
    let r = srun(&["--link", link, "pac-move", "1", &beyond, "--force"]);
    assert_eq!(r.code, 5, "{}", r.stderr);
    assert!(r.stderr.contains("(65)") && r.stderr.contains("position outside range"), "{}", r.stderr);
}

#[test]
fn sim_mode_refusal_registers_flags_and_check_rules() {
    let sim = pac_sim();
    let link = sim.link("pac");
    // Home position: a move is refused before anything is sent.
    let r = srun(&["--link", link, "pac-move", "1", "10"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("not valid in home position"), "{}", r.stderr);
    // An integer register stays an integer.
    assert_eq!(ok(&["--link", link, "--json", "pac-reg", "N5", "12345"])["value"].as_i64(), Some(12345));
    assert_eq!(ok(&["--link", link, "--json", "pac-reg", "n5"])["value"].as_i64(), Some(12345));
    assert_eq!(ok(&["--link", link, "--json", "pac-reg", "R3", "-2.5"])["value"], -2.5);
    assert_eq!(ok(&["--link", link, "--json", "pac-flag", "17", "1"])["value"], 1);
    assert_eq!(ok(&["--link", link, "--json", "pac-flag", "17"])["value"], 1);
    let w = ok(&["--link", link, "--json", "pac-flag", "17", "0x0005", "--word"]);
    assert_eq!(w["word"], 5);
    assert_eq!(w["set"], serde_json::json!([17, 19]));
    assert_eq!(ok(&["--link", link, "--json", "pac-out", "2", "1"])["value"], 1);
    // The other CHECK rule is understood by the controller too.
    let r = ok(&["--link", link, "--json", "--pac-check-etx", "pac-reg", "N5"]);
    assert_eq!(r["value"].as_i64(), Some(12345));
    let raw = ok(&["--link", link, "--json", "pac-raw", "1906", "5"]);
    assert_eq!(raw["q_par"].as_i64(), Some(12345), "TYP 0 stays an integer: {raw}");
    assert_eq!(raw["quit"], 0);
}

#[test]
fn in_process_sim_answers_pac_state() {
    let r = srun(&["--link", "sim", "--json", "pac-state"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["operating_status"], 1);
    assert!(r.json()["operating_status_text"].as_str().unwrap().contains("home"));
    assert_eq!(r.json()["controller_error"], 0);
    assert!(r.json().get("error").is_none(), "a success carries no error key");
}

/// A one-shot command on a clean line sends at once: the quiet-line wait
/// (one answer timeout, at most 1 s) is only for a line with input pending.
#[test]
fn sim_one_shot_on_a_clean_line_does_not_wait_for_quiet() {
    let sim = pac_sim();
    let link = sim.link("pac");
    ok(&["--link", link, "--json", "pac-state"]);
    let t0 = Instant::now();
    let r = run(&["--link", link, "--timeout", "60000", "--json", "pac-state"]);
    let took = t0.elapsed();
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(took < Duration::from_millis(900), "a 1 s quiet-line wait came back: {took:?}");
}

/// Issue 12: a client SIGKILLed while its 190C (a position, float) is on
/// the wire at 9600 baud. Every answer comes 400 ms late, so the killed
/// client's answer reaches the line while the next client waits for its
/// own: every later run still reads its own values, none is shifted by one.
#[test]
fn sim_a_killed_client_does_not_poison_the_line() {
    let sim = Sim::start(&["--pac", "pty-serial", "--wire-speed", "--fault", "delay=400ms"], 1);
    let link = sim.link("pac").to_string();
    let slow = |args: &[&str]| {
        let mut all = vec!["--link", &link, "--timeout", "3000", "--json"];
        all.extend_from_slice(args);
        let r = run(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        r.json()
    };
    let axis = slow(&["pac-axis", "2"]);
    let state = slow(&["pac-state"]);

    let mut killed = common::bin()
        .args(["--link", &link, "--timeout", "3000", "--trace", "pac-axis", "2"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = std::io::BufReader::new(killed.stderr.take().unwrap());
    let mut line = String::new();
    use std::io::BufRead;
    while !line.starts_with("-> ") {
        line.clear();
        assert!(err.read_line(&mut line).unwrap() > 0, "the client ended before sending");
    }
    assert!(line.contains("190C"), "{line}");
    std::thread::sleep(Duration::from_millis(50));
    killed.kill().unwrap();
    killed.wait().unwrap();

    // 190B reads an integer: the stale position arrives while it waits.
    for _ in 0..2 {
        assert_eq!(slow(&["pac-state"]), state);
    }
    for _ in 0..2 {
        assert_eq!(slow(&["pac-axis", "2"]), axis);
    }
}

/// Stops are idempotent: a controller in home position has nothing moving,
/// so `pac-stop` and `pac-stop-axis` exit 0 and say so; online they stop.
#[test]
fn stops_of_a_controller_at_rest_exit_0_and_say_so() {
    for args in [&["pac-stop"][..], &["pac-stop-axis", "2"], &["pac-stop-axis", "2", "--wait"]] {
        let mut all = vec!["--link", "sim", "--json"];
        all.extend_from_slice(args);
        let r = run(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        assert_eq!(r.json()["already_stopped"], true, "{args:?}: {}", r.stdout);
        let mut online = vec!["--link", "sim?pac=online", "--json"];
        online.extend_from_slice(args);
        let r = run(&online);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        let doc = r.json();
        assert_eq!(
            (doc["already_stopped"].as_bool(), doc["acknowledged"].as_bool()),
            (Some(false), Some(true)),
            "{args:?}"
        );
    }
}

// Issue 21, item 6: `command` is the axisctl subcommand as typed, in one
// process and on a batch line alike; the manual's name has its own key.
#[test]
fn command_is_the_subcommand_and_the_manual_name_has_its_own_key() {
    let r = run(&["--link", "sim", "--json", "pac-online"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(
        (r.json()["command"].as_str(), r.json()["manual_command"].as_str()),
        (Some("pac-online"), Some("start-online"))
    );
    let r = common::run_with_stdin(&["--link", "sim", "--json", "batch", "-"], "pac-online\npac-raw 0A81 0\n");
    assert_eq!(r.code, 0, "{}", r.stderr);
    let lines: Vec<serde_json::Value> = r.stdout.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    let names: Vec<_> =
        lines.iter().map(|l| (l["result"]["command"].clone(), l["result"]["manual_command"].clone())).collect();
    assert_eq!(
        names,
        [
            (serde_json::json!("pac-online"), serde_json::json!("start-online")),
            (serde_json::json!("pac-raw"), serde_json::json!("abort-online"))
        ]
    );
}
