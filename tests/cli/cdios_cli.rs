//! The `cdios-*` commands against the simulated Cdios node: in-process
//! (`--link sim`), served by `axisctl sim` on an slcan pty (shared with the
//! PowerCube modules), and the session against the bench's node on virtual time.

use crate::common;

use std::process::Stdio;
use std::sync::Arc;
use std::time::{Duration, Instant};

use axisctl::clock::{Clock, VirtualClock};
use axisctl::link::CanLink;
use axisctl::proto::cdios::{Address, Command, GotoMode, ModuleId, NodeId, PositionSource};
use axisctl::proto::CanFrame;
use axisctl::session::cdios::Cdios;
use axisctl::sim::bench::Bench;
use axisctl::sim::shared::lock;
use common::{run, Run, Sim};
use serde_json::Value;

fn cdios_sim() -> Sim {
    Sim::start(&["--cdios", "pty-slcan"], 1)
}

fn ok(r: &Run, what: &str) {
    assert_eq!(r.code, 0, "{what}: {} {}", r.stdout, r.stderr);
}

fn flags(doc: &Value) -> Vec<String> {
    doc["state"]["flags"].as_array().unwrap().iter().map(|f| f.as_str().unwrap().to_string()).collect()
}

#[test]
fn in_process_sim_answers_status_and_position() {
    let r = run(&["--link", "sim", "--json", "cdios-status", "-m", "0"]);
    ok(&r, "status");
    let doc = r.json();
    assert_eq!((doc["node"].as_u64(), doc["module"].as_u64()), (Some(1), Some(0)));
    assert_eq!(doc["family"], "cdios");
    let raw = doc["state"]["raw"].as_u64().unwrap();
    assert!(raw <= u64::from(u32::MAX), "4 status bytes: {raw}");
    assert!(flags(&doc).contains(&"POSITION_NOT_INITIALIZED".to_string()), "{doc}");
    let p = run(&["--link", "sim", "--json", "cdios-position", "-m", "1"]);
    ok(&p, "position");
    assert_eq!(p.json()["position"], serde_json::json!({"value": 0, "unit": "counts"}));
}

#[test]
fn absent_module_is_general_error_1_exit_5() {
    let r = run(&["--link", "sim", "--json", "cdios-status", "-m", "7"]);
    assert_eq!(r.code, 5, "{} {}", r.stdout, r.stderr);
    assert!(r.stdout.is_empty());
    let err: Value = serde_json::from_str(r.stderr.trim()).unwrap();
    assert_eq!(err["error"]["kind"], "device");
    let msg = err["error"]["message"].as_str().unwrap();
    assert!(msg.contains("general error 1") && msg.contains("no module at that module id"), "{msg}");
}

#[test]
fn enable_then_goto_wait_reaches_the_target() {
    let sim = cdios_sim();
    let link = sim.link("cdios");
    ok(&run(&["--link", link, "cdios-enable", "-m", "1"]), "enable");
    let r = run(&["--link", link, "--json", "cdios-goto", "-m", "1", "5000", "--wait"]);
    ok(&r, "goto --wait");
    let doc = r.json();
    assert_eq!((doc["position"]["value"].as_i64(), doc["target"]["value"].as_i64()), (Some(5000), Some(5000)), "{doc}");
    assert!(!flags(&doc).contains(&"GOTO_ACTIVE".to_string()));
    let r =
        run(&["--link", link, "--json", "cdios-goto", "-m", "1", "-1500", "--relative", "--speed", "800", "--wait"]);
    ok(&r, "relative goto --wait");
    assert_eq!(r.json()["target"]["value"], 3500);
    let p = run(&["--link", link, "--json", "cdios-position", "-m", "1", "--all"]);
    ok(&p, "position --all");
    assert_eq!(
        (p.json()["position"]["value"].as_i64(), p.json()["setpoint"]["value"].as_i64()),
        (Some(3500), Some(3500))
    );
}

#[test]
fn status_flags_while_moving_and_stop() {
    let sim = cdios_sim();
    let link = sim.link("cdios");
    ok(&run(&["--link", link, "cdios-enable", "-m", "0"]), "enable");
    ok(&run(&["--link", link, "cdios-goto", "-m", "0", "400000"]), "goto");
    let st = run(&["--link", link, "--json", "cdios-status", "-m", "0"]);
    ok(&st, "status");
    let f = flags(&st.json());
    for want in ["GOTO_ACTIVE", "RUNNING_FORWARD", "ENABLED"] {
        assert!(f.contains(&want.to_string()), "{want} while moving: {f:?}");
    }
    assert!(st.json()["motor_speed"]["value"].as_u64().unwrap() > 0);
    // A goto while one runs with a sin2 slope or a START is refused; a STOP ends it.
    ok(&run(&["--link", link, "cdios-stop", "-m", "0", "--option", "fast"]), "stop");
    let st = run(&["--link", link, "--json", "cdios-status", "-m", "0"]);
    let f = flags(&st.json());
    assert!(!f.contains(&"GOTO_ACTIVE".to_string()) && !f.contains(&"RUNNING_FORWARD".to_string()), "{f:?}");
}

#[test]
fn ctrl_c_during_goto_wait_stops_the_motor_and_exits_130() {
    let sim = cdios_sim();
    let link = sim.link("cdios").to_string();
    ok(&run(&["--link", &link, "cdios-enable", "-m", "0"]), "enable");
    let child = common::bin()
        .args(["--link", &link, "cdios-goto", "-m", "0", "1000000", "--wait"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(700));
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("stopped"));
    let st = run(&["--link", &link, "--json", "cdios-status", "-m", "0"]);
    assert!(!flags(&st.json()).contains(&"GOTO_ACTIVE".to_string()), "{}", st.stdout);
    let p =
        run(&["--link", &link, "--json", "cdios-position", "-m", "0"]).json()["position"]["value"].as_i64().unwrap();
    assert!(p > 0 && p < 1_000_000, "stopped on the way: {p}");
}

#[test]
fn store_configuration_takes_its_eeprom_time_and_needs_a_disabled_motor() {
    let sim = cdios_sim();
    let link = sim.link("cdios");
    ok(&run(&["--link", link, "cdios-config", "-m", "1", "slope=20", "speeds.maximum_speed=6000"]), "config set");
    let r = run(&["--link", link, "--json", "cdios-store", "-m", "1"]);
    ok(&r, "store");
    let ms = r.json()["elapsed_ms"].as_u64().unwrap();
    // Manual 05h: programming takes 260 up to 750 ms, then the reply.
    assert!((250..=900).contains(&ms), "store took {ms} ms");
    let c = run(&["--link", link, "--json", "cdios-config", "-m", "1", "speeds"]);
    assert_eq!(c.json()["config"]["speeds"]["slope"], 20);
    assert_eq!(c.json()["config"]["speeds"]["maximum_speed"], 6000);
    ok(&run(&["--link", link, "cdios-enable", "-m", "1"]), "enable");
    let r = run(&["--link", link, "cdios-store", "-m", "1"]);
    assert_eq!(r.code, 5, "store with the motor enabled: {} {}", r.stdout, r.stderr);
}

#[test]
fn powercube_and_cdios_share_one_slcan_pty() {
    let sim = Sim::start(&[], 2);
    let (pc, cd) = (sim.link("powercube"), sim.link("cdios"));
    assert_eq!(pc, cd, "one bus, one pty");
    let scan = run(&["--link", pc, "--json", "scan"]);
    ok(&scan, "scan");
    let ids: Vec<u64> =
        scan.json()["devices"].as_array().unwrap().iter().map(|m| m["module"].as_u64().unwrap()).collect();
    assert_eq!(ids, [3, 5, 17]);
    let id = run(&["--link", cd, "--json", "cdios-identify"]);
    ok(&id, "identify");
    let present: Vec<u64> = id.json()["modules"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["present"] == true)
        .map(|m| m["module"].as_u64().unwrap())
        .collect();
    assert_eq!(present, [0, 1]);
    ok(&run(&["--link", pc, "state", "-m", "17"]), "state");
    ok(&run(&["--link", cd, "cdios-enable", "-m", "0"]), "enable");
    ok(&run(&["--link", pc, "get-param", "-m", "5", "ActPos"]), "get-param");
    let g = run(&["--link", cd, "--json", "cdios-goto", "-m", "0", "1200", "--wait"]);
    ok(&g, "goto");
    assert_eq!(g.json()["position"]["value"], 1200);
    ok(&run(&["--link", pc, "home", "-m", "3"]), "home");
    ok(&run(&["--link", cd, "cdios-status", "-m", "1"]), "status");
}

/// Sent frames (NMT and commands to node 1) of one command, from its `--log`.
fn sent_frames(link: &str, args: &[&str]) -> (i32, Vec<String>) {
    let (r, frames) = logged_frames(link, args);
    (r.code, frames.into_iter().filter(|f| f.starts_with("000#") || f.starts_with("201#")).collect())
}

/// The logged frames of one command: the host's (0x000, 0x201) and the
/// node's answers (0x181), in order.
fn logged_frames(link: &str, args: &[&str]) -> (Run, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("can.log");
    let mut full = vec!["--link", link, "--log", log.to_str().unwrap()];
    full.extend_from_slice(args);
    let r = run(&full);
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    let frames = text.lines().filter_map(|l| l.split_whitespace().last()).map(str::to_string).collect();
    (r, frames)
}

/// A node that does not answer (pre-operational, as after power-up: the
/// simulated node ignores commands until NMT start) is started and given its
/// settle time; the motion goes out only after the node has answered. A
/// running node gets no NMT start: one read asks it, then the command.
#[test]
fn a_motion_goes_only_to_a_node_that_answered_and_a_running_node_gets_no_nmt() {
    let sim = cdios_sim();
    let link = sim.link("cdios");
    let (r, frames) = logged_frames(link, &["--trace", "cdios-enable", "-m", "0"]);
    ok(&r, "enable");
    let probe = "201#2600000000000000";
    let at = |f: &str| frames.iter().position(|x| x == f);
    let enable = at("201#2400000005000000").expect("enable sent");
    let nmt = at("000#0101").expect("NMT start sent");
    assert_eq!(frames[..nmt], [probe], "first the probe, unanswered: {frames:?}");
    let answer = frames.iter().position(|f| f.starts_with("181#26")).expect("the probe answered");
    assert!(nmt < answer && answer < enable, "NMT, the answer, then the motion: {frames:?}");
    assert_eq!(frames[nmt + 1], probe, "{frames:?}");
    assert!(r.stderr.contains("NMT start node 1"), "{}", r.stderr);
    // Running now: no NMT, one read, then the command.
    let (r, frames) = logged_frames(link, &["cdios-disable", "-m", "0"]);
    ok(&r, "disable");
    assert!(!frames.iter().any(|f| f.starts_with("000#")), "{frames:?}");
    assert_eq!(frames.iter().filter(|f| f.starts_with("201#")).collect::<Vec<_>>(), [probe, "201#2500000500000000"]);
    assert!(frames[1].starts_with("181#26"), "the probe's answer before the command: {frames:?}");
}

#[test]
fn every_command_sends_the_manual_bytes() {
    let sim = cdios_sim();
    let link = sim.link("cdios");
    let nmt = "000#0101";
    // The status read of module 0 that asks the node first; the read of the
    // identify (selector 0) when the controller is addressed.
    let probe = "201#2600000000000000";
    let id0 = "201#01FF000000000000";
    // (args, accepted exit codes, expected sent frames; a trailing ".." means "then more").
    // The simulated node starts pre-operational: the first command's probe goes
    // unanswered, so NMT start, then the probe again; from then on the node
    // runs and every command is its probe (or its own status read) and its bytes.
    let cases: &[(&[&str], &[i32], &[&str])] = &[
        (
            &["cdios-identify"],
            &[0],
            &[
                id0,
                nmt,
                id0,
                "201#01FF000000000000",
                "201#01FF010000000000",
                "201#01FF020000000000",
                "201#01FF030000000000",
                "201#01FF040000000000",
                "201#01FF050000000000",
                "201#01FF060000000000",
                "201#01FF070000000000",
            ],
        ),
        (&["cdios-status", "-m", "0"], &[0], &["201#2600000000000000", "201#2600020000000000"]),
        (&["cdios-position", "-m", "0", "--source", "setpoint"], &[0], &[probe, "201#2100020000000000"]),
        (
            &["cdios-position", "-m", "0", "--all"],
            &[0],
            &[probe, "201#2100000000000000", "201#2100010000000000", "201#2100020000000000"],
        ),
        // 22h, -1200 = FFFFFB50 little-endian.
        (&["cdios-set-position", "-m", "0", "-1200"], &[0], &[probe, "201#22000050FBFFFF00"]),
        // 24h option 5.
        (&["cdios-enable", "-m", "0"], &[0], &[probe, "201#2400000005000000"]),
        // The configured speeds are read (20h selector 80h) to check --speed against them, then
        // 23h selector 8 (speed 500 = 01F4), then selector 0 (1000 = 03E8), then the wait's reads.
        (
            &["cdios-goto", "-m", "0", "1000", "--speed", "500", "--wait"],
            &[0],
            &[
                probe,
                "201#2000800000000000",
                "201#230008F401000000",
                "201#230000E803000000",
                "201#2100020000000000",
                "..",
            ],
        ),
        // --force skips that check and its read; the manual's bytes are the same.
        (
            &["cdios-goto", "-m", "0", "1000", "--speed", "500", "--force", "--wait"],
            &[0],
            &[probe, "201#230008F401000000", "201#230000E803000000", "201#2100020000000000", ".."],
        ),
        // Selector 2: relative to the current position, -200 = FFFFFF38.
        (&["cdios-goto", "-m", "0", "-200", "--relative"], &[0], &[probe, "201#23000238FFFFFF00"]),
        (&["cdios-stop", "-m", "0", "--option", "fast"], &[0, 5], &[probe, "201#2500000200000000"]),
        // Selector 5: setpoint relative, latched (moves on SYNC only).
        (&["cdios-goto", "-m", "0", "300", "--setpoint-relative", "--latched"], &[0], &[probe, "201#2300052C01000000"]),
        (&["cdios-traject", "-m", "0", "1"], &[0, 5], &[probe, "201#2300060100000000"]),
        // 24h reverse, option 3, MotorSpeed 1000.
        (
            &["cdios-start", "-m", "0", "--option", "to-speed", "--speed", "1000", "--direction", "reverse"],
            &[0, 5],
            &[probe, "201#2400000103E80300"],
        ),
        (&["cdios-stop", "-m", "0"], &[0, 5], &[probe, "201#2500000100000000"]),
        (&["cdios-disable", "-m", "0"], &[0], &[probe, "201#2500000500000000"]),
        // 20h selector 0 is written whole: minimum 50 (0032), maximum 8000 (1F40), slope 20.
        (
            &["cdios-config", "-m", "0", "slope=20"],
            &[0],
            &[probe, "201#2000800000000000", "201#2000003200401F14", "201#2000800000000000"],
        ),
        (
            &["cdios-outputs", "-m", "0", "--set", "0b0101", "--latched"],
            &[0],
            &[probe, "201#1000010500000000", "201#1000800000000000"],
        ),
        // 16h selector 10h: output 2 direct, -2500 mV = F63C.
        (
            &["cdios-analog", "-m", "0", "--output", "2", "--set", "-2500"],
            &[0],
            &[probe, "201#1600103CF6000000", "201#1600900000000000"],
        ),
        // 27h: mask 1 bit 7; timers: position interval 6, on change (bit 3).
        (
            &[
                "cdios-events",
                "-m",
                "0",
                "--mask",
                "GOTO_ACTIVE",
                "--position-interval",
                "6",
                "--position-on-change",
                "true",
            ],
            &[0],
            &[probe, "201#2700800000000000", "201#270000800000000E", "201#2700800000000000"],
        ),
        (&["cdios-store", "-m", "0", "--defaults"], &[0], &[probe, "201#0500014344530000"]),
        (&["cdios-watch", "-m", "0", "--count", "1"], &[0], &[probe, "201#2600000000000000", "201#2100000000000000"]),
        (&["cdios-status", "-m", "0", "--no-nmt"], &[0], &["201#2600000000000000", "201#2600020000000000"]),
    ];
    for (args, codes, want) in cases {
        let (code, got) = sent_frames(link, args);
        assert!(codes.contains(&code), "{args:?}: exit {code}");
        match want.split_last() {
            Some((&"..", head)) => assert_eq!(&got[..head.len().min(got.len())], head, "{args:?}"),
            _ => assert_eq!(got, *want, "{args:?}"),
        }
    }
}

/// The session against the bench's own Cdios node, on virtual time.
fn bench_session(bench: &Bench, clock: &Arc<VirtualClock>) -> Cdios {
    let clock: Arc<dyn Clock> = clock.clone();
    Cdios::new(Box::new(bench.bus.open())).with_clock(clock)
}

#[test]
fn session_waits_out_the_eeprom_for_reads_and_refuses_motion_meanwhile() {
    let clock = Arc::new(VirtualClock::new());
    let bench = Bench::contract(clock.clone());
    let (node, m0) = (NodeId::new(1).unwrap(), ModuleId::new(0).unwrap());
    let mut s = bench_session(&bench, &clock);
    s.start_node(node).unwrap();
    // Another client on the bus stores the configuration; we do not wait for it.
    let mut other = bench.bus.open();
    other.send(&CanFrame::new(0x201, &[0x05, 0, 0, 0x43, 0x44, 0x53, 0, 0]).unwrap()).unwrap();
    let t0 = clock.now();
    assert!(lock(&bench.cdios).eeprom_busy(t0));
    let e =
        s.transact(node, Address::Module(m0), &Command::Goto { mode: GotoMode::Absolute, position: 5 }).unwrap_err();
    assert_eq!(e.kind(), axisctl::session::ErrorKind::Device);
    assert!(e.to_string().contains("EEPROM"), "{e}");
    assert_eq!(s.read_position(node, m0, PositionSource::Current).unwrap(), 0);
    assert!(!lock(&bench.cdios).eeprom_busy(clock.now()), "the read came back after the EEPROM was done");
    assert!(clock.now() - t0 >= Duration::from_millis(260));
}

#[test]
fn session_with_confirmations_off() {
    let clock = Arc::new(VirtualClock::new());
    let bench = Bench::contract(clock.clone());
    lock(&bench.cdios).set_confirm(false);
    let (node, m1) = (NodeId::new(1).unwrap(), ModuleId::new(1).unwrap());
    let mut s = bench_session(&bench, &clock);
    s.set_confirm(false);
    let enable = Command::Start {
        sync: false,
        direction: axisctl::proto::cdios::Direction::Forward,
        option: axisctl::proto::cdios::StartOption::Enable,
        motor_speed: 0,
    };
    assert!(s.transact(node, Address::Module(m1), &enable).unwrap().is_none());
    let goto = Command::Goto { mode: GotoMode::Absolute, position: 2000 };
    assert!(s.transact(node, Address::Module(m1), &goto).unwrap().is_none());
    // A second goto while the first runs with... the error still comes.
    let set = Command::SetPosition { position: 1 };
    let e = s.transact(node, Address::Module(m1), &set).unwrap_err();
    assert!(e.to_string().contains("MOTOR_RUNNING"), "{e}");
    // Reads are answered whatever 'Confirm' says.
    let t0: Instant = clock.now();
    let r = s.read_status(node, m1).unwrap();
    assert!(r.flags.contains(&"GOTO_ACTIVE"), "{r:?}");
    assert!(clock.now() - t0 < Duration::from_millis(100));
}

/// A bench link on which, right after each request, an error reply to
/// another command of the same module (25h, general error 1) arrives first.
struct ForeignErrorFirst {
    inner: Box<dyn CanLink>,
    pending: Option<CanFrame>,
}

impl CanLink for ForeignErrorFirst {
    fn send(&mut self, frame: &CanFrame) -> Result<(), axisctl::link::LinkError> {
        self.inner.send(frame)?;
        if frame.id() == 0x201 && frame.data()[0] != 0x25 {
            self.pending = Some(CanFrame::new(0x181, &[0xA5, frame.data()[1], 0, 1, 0, 0, 0, 0]).unwrap());
        }
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, axisctl::link::LinkError> {
        match self.pending.take() {
            Some(f) => Ok(Some(f)),
            None => self.inner.recv(timeout),
        }
    }
}

#[test]
fn an_error_reply_to_another_command_does_not_fail_this_one() {
    let clock = Arc::new(VirtualClock::new());
    let bench = Bench::contract(clock.clone());
    let (node, m1) = (NodeId::new(1).unwrap(), ModuleId::new(1).unwrap());
    let dyn_clock: Arc<dyn Clock> = clock.clone();
    let link = ForeignErrorFirst { inner: Box::new(bench.bus.open()), pending: None };
    let mut s = Cdios::new(Box::new(link)).with_clock(dyn_clock);
    s.start_node(node).unwrap();
    // A read and a command: each is answered after an error reply about 25h.
    assert_eq!(s.read_position(node, m1, PositionSource::Current).unwrap(), 0);
    let goto = Command::Goto { mode: GotoMode::Absolute, position: 0 };
    let r = s.transact(node, Address::Module(m1), &goto);
    // The goto's own refusal (the motor is not enabled), not the one about 25h.
    let e = r.unwrap_err().to_string();
    assert!(e.contains("MOTOR_NOT_ENABLED") && !e.contains("no module"), "{e}");
}

/// Stops are idempotent: on the fresh bench every motor stands, and a stop
/// of it succeeds and says so (`cdios-stop ... && halt --all` goes on).
#[test]
fn a_stop_of_a_motor_at_rest_exits_0_and_says_it_was_at_rest() {
    let r = common::run(&["--link", "sim", "--json", "cdios-stop", "-m", "0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["already_stopped"], true, "{}", r.stdout);
    let r = common::run(&["--link", "sim", "cdios-stop", "-m", "1", "--option", "fast"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("the motor was at rest already"), "{}", r.stdout);
}
