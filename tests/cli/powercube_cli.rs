//! The CLI binary against `axisctl sim` over real ptys, on RS232 and slcan,
//! and against the in-process `--link sim`.

use crate::common;

use common::{run, Sim};

/// Both served transports for the same bench.
fn sims() -> Vec<Sim> {
    vec![Sim::start(&["--powercube", "pty-serial"], 1), Sim::start(&["--powercube", "pty-slcan"], 1)]
}

#[test]
fn scan_finds_exactly_the_simulated_ids() {
    for sim in sims() {
        let link = sim.link("powercube");
        // A patient scan (an answer may start 200 ms late): a loaded machine
        // must not make a present module look absent.
        let r = run(&["--link", link, "--json", "--timeout", "1600", "scan"]);
        assert_eq!(r.code, 0, "{link}: {}", r.stderr);
        let ids: Vec<u64> =
            r.json()["devices"].as_array().unwrap().iter().map(|m| m["module"].as_u64().unwrap()).collect();
        assert_eq!(ids, [3, 5, 17], "{link}");
        let m17 = &r.json()["devices"][2];
        assert_eq!(m17["kind"], "linear");
        assert_eq!(m17["version"], 13592);
    }
}

#[test]
fn home_wait_sets_home_ok() {
    for sim in sims() {
        let link = sim.link("powercube");
        let r = run(&["--link", link, "--json", "home", "-m", "17", "--wait"]);
        assert_eq!(r.code, 0, "{link}: {}", r.stderr);
        let flags = r.json()["state"]["flags"].clone();
        assert!(flags.as_array().unwrap().iter().any(|f| f == "STATE_HOME_OK"), "{link}: {flags}");
        let st = run(&["--link", link, "--json", "state", "-m", "17"]);
        assert_eq!(st.code, 0);
        assert!(st.json()["state"]["raw"].as_u64().unwrap() & 0x2 != 0, "HOME_OK after homing");
    }
}

#[test]
fn move_ramp_wait_ends_at_the_target() {
    for sim in sims() {
        let link = sim.link("powercube");
        assert_eq!(run(&["--link", link, "home", "-m", "3", "--wait"]).code, 0);
        let r =
            run(&["--link", link, "--json", "move-ramp", "-m", "3", "0.75", "--vel", "1.0", "--acc", "2", "--wait"]);
        assert_eq!(r.code, 0, "{link}: {}", r.stderr);
        let pos = r.json()["position"]["value"].as_f64().unwrap();
        assert!((pos - 0.75).abs() < 1e-3, "{link}: ended at {pos}");
        assert_eq!(r.json()["position"]["unit"], "rad", "module 3 is rotary");
        let p = run(&["--link", link, "--json", "get-param", "-m", "3", "ActPos"]);
        let act = p.json()["params"]["ActPos"]["value"].as_f64().unwrap();
        assert!((act - 0.75).abs() < 1e-3, "{link}: ActPos {act}");
    }
}

#[test]
fn set_param_then_get_param() {
    for sim in sims() {
        let link = sim.link("powercube");
        let r = run(&["--link", link, "--json", "set-param", "-m", "5", "MaxVel", "0.5"]);
        assert_eq!(r.code, 0, "{link}: {}", r.stderr);
        let g = run(&["--link", link, "--json", "get-param", "-m", "5", "maxvel", "0x45"]);
        assert_eq!(g.code, 0, "{}", g.stderr);
        let doc = g.json();
        assert_eq!(doc["module"], 5);
        assert_eq!(doc["params"]["MaxVel"]["value"].as_f64().unwrap(), 0.5);
        assert_eq!(doc["params"]["MaxVel"]["id"], 72);
        assert_eq!(doc["params"]["MaxVel"]["type"], "float");
        assert!(doc["params"]["MinPos"]["value"].is_number());
    }
}

#[test]
fn absent_module_is_exit_4() {
    for sim in sims() {
        let link = sim.link("powercube");
        let r = run(&["--link", link, "--json", "state", "-m", "9"]);
        assert_eq!(r.code, 4, "{link}: {} {}", r.stdout, r.stderr);
        assert!(r.stdout.is_empty());
        let err: serde_json::Value = serde_json::from_str(r.stderr.trim()).unwrap();
        assert_eq!(err["error"]["kind"], "timeout");
    }
}

#[test]
fn out_of_range_target_is_exit_2_and_sends_no_motion() {
    for sim in sims() {
        let link = sim.link("powercube");
        let log = tempfile::NamedTempFile::new().unwrap();
        let logp = log.path().to_str().unwrap();
        let r = run(&["--link", link, "--log", logp, "move-ramp", "-m", "17", "5.0"]);
        assert_eq!(r.code, 2, "{link}: {}", r.stderr);
        assert!(r.stderr.contains("MaxPos"), "names the limit: {}", r.stderr);
        let traffic = std::fs::read_to_string(log.path()).unwrap();
        assert!(!traffic.is_empty(), "the limits were read, so the log has frames");
        // SetMotion is command 0x0b: no frame carries it.
        let motion = traffic.lines().any(|l| l.contains("#0B") || l.contains(" 0b 04") || l.contains(" 0b 09"));
        assert!(!motion, "{link}: a motion frame left:\n{traffic}");
        let pos = run(&["--link", link, "--json", "get-param", "-m", "17", "ActPos"]).json()["params"]["ActPos"]
            ["value"]
            .as_f64()
            .unwrap();
        assert_eq!(pos, 0.0, "the module did not move");
    }
}

#[test]
fn module_in_error_is_exit_5() {
    // Slcan only: the watchdog is a CAN feature.
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube");
    let r = run(&["--link", link, "watchdog", "on", "-m", "5"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    std::thread::sleep(std::time::Duration::from_millis(120)); // no refresh: the watchdog trips
    let st = run(&["--link", link, "--json", "state", "-m", "5"]);
    let errors = st.json()["state"]["errors"].clone();
    assert!(errors.as_array().unwrap().iter().any(|e| e == "STATE_COMM_ERROR"), "{errors}");
    let mv = run(&["--link", link, "move-ramp", "-m", "5", "0.1"]);
    assert_eq!(mv.code, 5, "{}", mv.stderr);
    assert!(mv.stderr.contains("STATE_COMM_ERROR"), "{}", mv.stderr);
}

#[test]
fn in_process_sim_scan_lists_3_5_17() {
    let r = run(&["--link", "sim", "scan"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let ids: Vec<&str> = r.stdout.lines().skip(1).map(|l| l.split_whitespace().next().unwrap()).collect();
    assert_eq!(ids, ["3", "5", "17"], "{}", r.stdout);
}

#[test]
fn usage_errors_are_exit_2() {
    assert_eq!(run(&["scan"]).code, 2, "missing link");
    assert!(run(&["scan"]).stderr.contains("--link sim"));
    assert_eq!(run(&["--link", "bogus:x", "scan"]).code, 2);
    assert_eq!(run(&["--link", "sim", "state", "-m", "32"]).code, 2);
    assert_eq!(run(&["--link", "sim", "set-param", "-m", "3", "ActPos", "1"]).code, 2, "read-only");
    assert_eq!(run(&["--link", "sim", "set-param", "-m", "3", "MaxVel", "fast"]).code, 2, "not a float");
    assert_eq!(run(&["--link", "sim", "get-param", "-m", "3", "NoSuchParam"]).code, 2);
    assert_eq!(run(&["--link", "sim", "set-config", "-m", "3", "+no-such-flag"]).code, 2);
}

#[test]
fn unopenable_link_is_exit_3() {
    let r = run(&["--link", "serial:/dev/does-not-exist", "--json", "scan"]);
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(r.stderr.contains("/dev/does-not-exist"));
}

#[test]
fn ctrl_c_during_wait_halts_the_module_and_exits_130() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube").to_string();
    let child = common::bin()
        .args(["--link", &link, "move-ramp", "-m", "3", "2.0", "--vel", "0.2", "--wait"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // One client at a time on an slcan tty (as on a real adapter): no polling
    // from here while the wait runs. The move takes 10 s; interrupt it early.
    std::thread::sleep(std::time::Duration::from_millis(700));
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(String::from_utf8_lossy(&out.stderr).contains("halted"));
    let st = run(&["--link", &link, "--json", "state", "-m", "3"]).json();
    let raw = st["state"]["raw"].as_u64().unwrap();
    assert!(raw & 0x4 != 0, "STATE_HALTED set: {st}");
    assert!(raw & 0x800 == 0, "not moving: {st}");
    let pos = run(&["--link", &link, "--json", "get-param", "-m", "3", "ActPos"]).json()["params"]["ActPos"]["value"]
        .as_f64()
        .unwrap();
    assert!(pos > 0.0 && pos < 2.0, "stopped on the way: {pos}");
}

#[test]
fn broadcasts_reach_every_module() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube");
    assert_eq!(run(&["--link", link, "halt", "--all"]).code, 0);
    for m in ["3", "5", "17"] {
        let raw = run(&["--link", link, "--json", "state", "-m", m]).json()["state"]["raw"].as_u64().unwrap();
        assert!(raw & 0x4 != 0, "module {m} halted by the broadcast");
    }
    assert_eq!(run(&["--link", link, "reset", "--all"]).code, 0);
    for m in ["3", "5", "17"] {
        let raw = run(&["--link", link, "--json", "state", "-m", m]).json()["state"]["raw"].as_u64().unwrap();
        assert!(raw & 0x4 == 0, "module {m} reset by the broadcast");
    }
}

#[test]
fn trace_shows_frames_both_ways() {
    let r = run(&["--link", "sim", "--trace", "state", "-m", "17"]);
    assert_eq!(r.code, 0);
    assert!(r.stderr.contains("-> 0D1#0A27"), "{}", r.stderr);
    assert!(r.stderr.contains("<- 0B1#0A27"), "{}", r.stderr);
}

#[test]
fn log_file_is_candump_format() {
    let log = tempfile::NamedTempFile::new().unwrap();
    let r = run(&["--link", "sim", "--log", log.path().to_str().unwrap(), "home", "-m", "17"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let text = std::fs::read_to_string(log.path()).unwrap();
    let frames: Vec<&str> = text.lines().map(|l| l.split_whitespace().nth(2).unwrap()).collect();
    assert_eq!(frames, ["0F1#01", "0B1#01"], "{text}");
    for l in text.lines() {
        let (ts, rest) = l.split_once(' ').unwrap();
        assert!(ts.starts_with('(') && ts.ends_with(')') && ts.contains('.'), "{l}");
        assert!(rest.starts_with("sim0 "), "{l}");
    }
}

#[test]
fn decode_is_offline_and_shows_both_names_of_bit_27() {
    let r = run(&["--json", "decode", "cube-state", "0x08800001"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let d = r.json();
    let flags: Vec<&str> = d["flags"].as_array().unwrap().iter().map(|f| f.as_str().unwrap()).collect();
    assert!(flags.contains(&"STATE_LOGIC_VOLT") && flags.contains(&"STATE_POW_SETUP_ERR"), "{flags:?}");
    assert!(flags.contains(&"STATE_POW_INTEGRAL_ERR"), "bit 23 per the errata: {flags:?}");
    assert_eq!(run(&["decode", "no-such-kind", "1"]).code, 2);
    let c = run(&["--json", "decode", "config", "brake-present|linear"]).json();
    assert_eq!(c["raw"], 0x0002_0008);
}

#[test]
fn def_a0_reads_as_the_vendor_library_reads_it() {
    let r = run(&["--link", "sim", "--json", "get-param", "-m", "3", "DefA0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["params"]["DefA0"]["type"], "int16");
    let all = run(&["--link", "sim", "--json", "get-param", "-m", "3", "--all"]);
    assert!(all.json()["params"]["DefA0"].is_object(), "--all reads it too");
}

#[test]
fn firmware_before_4_6_has_no_temperature_and_supplies() {
    // Module 3 runs 4.6.01, module 17 keeps 3.5.18.
    let new = run(&["--link", "sim", "--json", "info", "-m", "3"]);
    assert_eq!(new.code, 0, "{}", new.stderr);
    assert_eq!(new.json()["version_text"], "4.6.01");
    assert_eq!(new.json()["params"]["ActFTemp"]["value"], 35.0);
    assert_eq!(new.json()["params"]["ActFTemp"]["unit"], "°C");
    let old = run(&["--link", "sim", "--json", "info", "-m", "17"]);
    assert_eq!(old.code, 0, "{}", old.stderr);
    assert_eq!(old.json()["version_text"], "3.5.18");
    for p in ["ActFTemp", "ActFMotorSupply", "ActFLogicSupply"] {
        assert!(old.json()["params"][p]["value"].is_null(), "{p}: {}", old.json());
    }
    let text = run(&["--link", "sim", "info", "-m", "17"]);
    assert!(text.stdout.contains("- (firmware 3.5.18)"), "{}", text.stdout);
    // Asked by name: refused with the reason, not a timeout.
    let r = run(&["--link", "sim", "get-param", "-m", "17", "ActFTemp"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("firmware 3.5.18, which has no ActFTemp"), "{}", r.stderr);
    let all = run(&["--link", "sim", "--json", "get-param", "-m", "17", "--all"]);
    assert_eq!(all.code, 0, "{}", all.stderr);
    assert!(all.json()["params"].get("ActFTemp").is_none());
    assert!(all.json()["params"]["ActPos"].is_object());
}

#[test]
fn synchronized_ramp_of_three_modules_starts_at_the_one_broadcast() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube");
    for m in ["3", "5", "17"] {
        assert_eq!(run(&["--link", link, "set-config", "-m", m, "+sync-motion"]).code, 0);
    }
    // Alone, a module in sync mode takes its target and holds it.
    let r = run(&["--link", link, "move-ramp", "-m", "3", "0.3"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    std::thread::sleep(std::time::Duration::from_millis(300));
    let st = run(&["--link", link, "--json", "state", "-m", "3"]);
    assert_eq!(st.json()["state"]["raw"].as_u64().unwrap() & 0x800, 0, "no motion without the broadcast");
    // Waiting for it is refused before anything is sent.
    let r = run(&["--link", link, "--trace", "move-ramp", "-m", "5", "0.3", "--wait"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("module 5 is in sync mode") && r.stderr.contains("nothing was sent"), "{}", r.stderr);
    assert!(!r.stderr.contains("SetMotion"), "{}", r.stderr);
    // Each module's target, then StartMotion once; all end where asked.
    let r = run(&[
        "--link",
        link,
        "--json",
        "--trace",
        "move-ramp",
        "-m",
        "3,5,17",
        "--sync",
        "0.5",
        "-0.5",
        "0.25",
        "--wait",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let sent: Vec<&str> = r.stderr.lines().filter(|l| l.contains("SetMotion") || l.contains("broadcast")).collect();
    assert_eq!(sent.len(), 4, "{}", r.stderr);
    // docs/guide.md, "Synchronized moves", frame for frame.
    for (line, frame) in sent.iter().zip(["0E3#0B040000003F", "0E5#0B04000000BF", "0F1#0B040000803E", "100#0F00"]) {
        assert!(line.contains(frame), "{frame} in {sent:?}");
    }
    let at: Vec<f64> =
        r.json()["devices"].as_array().unwrap().iter().map(|m| m["position"]["value"].as_f64().unwrap()).collect();
    for (got, want) in at.iter().zip([0.5, -0.5, 0.25]) {
        assert!((got - want).abs() < 1e-3, "{at:?}");
    }
}

#[test]
fn synchronized_ramp_input_is_checked_before_anything_is_sent() {
    // Positions must pair with modules; several modules need --sync.
    for args in [
        &["move-ramp", "-m", "3,5", "--sync", "0.5"][..],
        &["move-ramp", "-m", "3,5", "0.5", "0.5"],
        &["move-ramp", "-m", "3,3", "--sync", "0.5", "0.5"],
        &["move-ramp", "-m", "3,40", "--sync", "0.5", "0.5"],
    ] {
        let mut all = vec!["--link", "sim"];
        all.extend_from_slice(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
    }
    // Not in sync mode (the in-process bench's modules are not): refused.
    let r = run(&["--link", "sim", "move-ramp", "-m", "3,5", "--sync", "0.5", "0.5"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("+sync-motion"), "{}", r.stderr);
    // The manual: sync motion is valid only on CAN.
    let sim = Sim::start(&["--powercube", "pty-serial"], 1);
    let r = run(&["--link", sim.link("powercube"), "move-ramp", "-m", "3,5", "--sync", "0.5", "0.5"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("CAN feature"), "{}", r.stderr);
}

/// `axisctl --trace sim`: a frame the simulator leaves unanswered is named
/// on its stderr, so the caller waiting out its timeout sees why.
#[test]
fn sim_trace_names_the_vendor_librarys_unknown_save_parameters() {
    use std::io::{BufRead, BufReader, Read};

    use axisctl::link::serial::SerialLink;
    use axisctl::link::{ByteLink, LinkSpec};

    let mut child = common::bin()
        .args(["--trace", "sim", "--powercube", "pty-serial"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let uri = serde_json::from_str::<serde_json::Value>(&line).unwrap()["link"].as_str().unwrap().to_string();
    let Ok(LinkSpec::Serial { path, .. }) = uri.parse() else { panic!("{uri}") };
    let mut link = SerialLink::open(&path, 9600, axisctl::link::SerialFormat::F8N1).unwrap();
    // The library's SaveParameters to module 3: TELID 04 61, [10] escaped, BCC 75.
    link.write_all(&[0x02, 0x04, 0x61, 0x10, 0x90, 0x75, 0x03]).unwrap();
    let mut buf = [0u8; 64];
    assert_eq!(link.read(&mut buf, std::time::Duration::from_millis(300)).unwrap(), 0, "no answer");
    unsafe {
        libc::kill(child.id() as i32, libc::SIGTERM);
    }
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let _ = child.wait();
    assert!(err.contains("sim: module 3: [10] not answered: unknown command id 0x10"), "{err}");
}
