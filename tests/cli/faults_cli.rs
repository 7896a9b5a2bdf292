//! The real binary against `axisctl sim --fault` over ptys: exit codes and
//! messages per fault, requests counted in `--log` / `--trace`, the adapter
//! unplugged mid-command, Ctrl-C during every `--wait`, and a device that
//! faults mid-move. Every process runs under a deadline: a hang fails the
//! test instead of the suite.

use crate::common;

use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::{Run, Sim};

/// Runs axisctl, killing it (and failing) if it outlives `secs`.
fn bounded(args: &[&str], secs: u64) -> (Run, Duration) {
    let t0 = Instant::now();
    let child = common::bin()
        .env_remove("AXISCTL_TIMEOUT")
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = wait_bounded(child, secs, args);
    (out, t0.elapsed())
}

fn wait_bounded(child: Child, secs: u64, what: &[&str]) -> Run {
    common::wait_bounded(child, secs, what).run()
}

fn sim(family_args: &[&str], fault: &str, seed: &str) -> Sim {
    let mut args = family_args.to_vec();
    args.extend_from_slice(&["--fault", fault, "--fault-seed", seed]);
    Sim::start(&args, 1)
}

fn log_path(name: &str) -> std::path::PathBuf {
    let p = std::env::temp_dir().join(format!("axisctl-faults-{}-{name}.log", std::process::id()));
    let _ = std::fs::remove_file(&p);
    p
}

/// candump -l lines `(t) iface ID#DATA`: (id, data bytes).
fn logged_frames(path: &std::path::Path) -> Vec<(u32, Vec<u8>)> {
    std::fs::read_to_string(path)
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.split_whitespace().nth(2))
        .filter_map(|f| {
            let (id, data) = f.split_once('#')?;
            let bytes = (0..data.len() / 2).map(|i| u8::from_str_radix(&data[2 * i..2 * i + 2], 16).unwrap()).collect();
            Some((u32::from_str_radix(id, 16).ok()?, bytes))
        })
        .collect()
}

fn sent_lines(stderr: &str) -> usize {
    stderr.lines().filter(|l| l.starts_with("-> ")).count()
}

// ---- lost, late, wrong-module and cut answers: exit codes, retries ----

#[test]
fn lost_answers_exit_4_after_three_reads_on_every_family() {
    // PowerCube over slcan: the reads counted in the candump log.
    let s = sim(&["--powercube", "pty-slcan"], "drop=1", "1");
    let log = log_path("drop-can");
    let (r, took) =
        bounded(&["--link", s.link("powercube"), "--log", log.to_str().unwrap(), "get-param", "-m", "3", "ActPos"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("no answer from module 3 to GetExtended ActPos within 100 ms"), "{}", r.stderr);
    // ActPos is 0x3C; Config (0x0C, read along for the units) is never reached.
    let gets = logged_frames(&log).iter().filter(|(id, d)| *id == 0x0C3 && d[..2] == [0x0A, 0x3C]).count();
    assert_eq!(gets, 3, "1 + 2 retries");
    assert!(took < Duration::from_secs(3), "{took:?}");
    // --retries counts the pipelined attempt too (it used to add one more).
    let log = log_path("drop-can-0");
    let l = log.to_str().unwrap();
    let (r, _) =
        bounded(&["--link", s.link("powercube"), "--log", l, "--retries", "0", "get-param", "-m", "3", "ActPos"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let gets = logged_frames(&log).iter().filter(|(id, d)| *id == 0x0C3 && d[..2] == [0x0A, 0x3C]).count();
    assert_eq!(gets, 1, "--retries 0: sent once");
    // PowerCube over RS232 and the PA-CONTROL: counted in --trace.
    let s = sim(&["--powercube", "pty-serial"], "drop=1", "1");
    let (r, _) = bounded(&["--link", s.link("powercube"), "--trace", "get-param", "-m", "3", "ActPos"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let act_pos = r.stderr.lines().filter(|l| l.starts_with("-> ") && l.contains("GetExtended ActPos")).count();
    assert_eq!(act_pos, 3, "{}", r.stderr);
    let s = sim(&["--pac", "pty-serial"], "drop=1", "1");
    let (r, _) = bounded(&["--link", s.link("pac"), "--trace", "pac-state"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert_eq!(sent_lines(&r.stderr), 3, "{}", r.stderr);
    assert!(r.stderr.contains("no answer from PA-CONTROL"), "{}", r.stderr);
    // Cdios: the status read once (it asks the node; no answer), NMT start,
    // then the status read three times.
    let s = sim(&["--cdios", "pty-slcan"], "drop=1", "1");
    let log = log_path("drop-cdios");
    let (r, _) = bounded(&["--link", s.link("cdios"), "--log", log.to_str().unwrap(), "cdios-status", "-m", "0"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let frames = logged_frames(&log);
    let read = |(id, d): &&(u32, Vec<u8>)| *id == 0x201 && d.first() == Some(&0x26);
    let nmt = frames.iter().position(|(id, _)| *id == 0).expect("NMT start");
    assert_eq!(frames[..nmt].iter().filter(read).count(), 1, "{frames:?}");
    assert_eq!(frames[nmt..].iter().filter(read).count(), 3, "{frames:?}");
}

/// The move's acknowledge is lost after the state check went through: one
/// SetMotion frame, exit 4, no second try; the module moves all the same.
#[test]
fn a_lost_motion_acknowledge_is_exit_4_and_never_resent() {
    let s = sim(&["--powercube", "pty-slcan"], "drop=1,skip=1", "1");
    let link = s.link("powercube");
    let log = log_path("motion");
    let (r, _) =
        bounded(&["--link", link, "--log", log.to_str().unwrap(), "move-ramp", "-m", "3", "0.5", "--force"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("SetMotion FRAMP_MODE 0.5 to module 3"), "{}", r.stderr);
    let motions = logged_frames(&log).iter().filter(|(id, d)| *id == 0x0E3 && d.first() == Some(&0x0B)).count();
    assert_eq!(motions, 1, "sent exactly once");
}

#[test]
fn answers_from_another_module_are_exit_4() {
    let s = sim(&["--powercube", "pty-slcan"], "wrong-module=1", "1");
    let (r, _) = bounded(&["--link", s.link("powercube"), "state", "-m", "3"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let s = sim(&["--cdios", "pty-slcan"], "wrong-module=1", "1");
    let (r, _) = bounded(&["--link", s.link("cdios"), "cdios-status", "-m", "0"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
}

#[test]
fn late_answers_are_exit_4_without_a_hang() {
    let s = sim(&["--pac", "pty-serial"], "delay=400ms", "1");
    let (r, took) = bounded(&["--link", s.link("pac"), "--trace", "pac-state"], 10);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert_eq!(sent_lines(&r.stderr), 3, "{}", r.stderr);
    assert!(took < Duration::from_secs(3), "{took:?}");
}

/// A cut CAN acknowledge that still names its command is a malformed
/// answer: exit 6, after the retries.
#[test]
fn cut_answers_are_exit_6_malformed() {
    let s = sim(&["--powercube", "pty-slcan"], "truncate=1", "5");
    let (r, _) = bounded(&["--link", s.link("powercube"), "--json", "get-param", "-m", "3", "ActPos"], 10);
    assert_eq!(r.code, 6, "{}", r.stderr);
    let e: serde_json::Value = serde_json::from_str(r.stderr.trim()).unwrap();
    assert_eq!(e["error"]["kind"], "malformed", "{e}");
    assert!(e["error"]["message"].as_str().unwrap().contains("malformed answer from module 3"), "{e}");
}

/// Noise before every answer and every answer twice: the commands work.
#[test]
fn garbage_and_duplicates_are_skipped() {
    for (args, fam) in
        [(&["--powercube", "pty-serial"][..], "powercube"), (&["--powercube", "pty-slcan"][..], "powercube")]
    {
        let s = sim(args, "garbage=1,duplicate=1", "3");
        let (r, _) = bounded(&["--link", s.link(fam), "--json", "info", "-m", "17"], 10);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
        assert_eq!(r.json()["kind"], "linear");
    }
    let s = sim(&["--pac", "pty-serial"], "garbage=1,duplicate=1", "3");
    let (r, _) = bounded(&["--link", s.link("pac"), "--json", "pac-state"], 10);
    assert_eq!(r.code, 0, "{}", r.stderr);
}

// ---- the adapter unplugged ----

/// The sim dies while the client waits for an answer (delayed 30 s): the
/// client sees the pty close and exits 3 at once with a clear message.
#[test]
fn unplugged_adapter_mid_command_is_exit_3_at_once() {
    let cases: [(&[&str], &str, &[&str]); 4] = [
        (&["--powercube", "pty-slcan"], "powercube", &["get-param", "-m", "3", "ActPos"]),
        (&["--powercube", "pty-serial"], "powercube", &["get-param", "-m", "3", "ActPos"]),
        (&["--pac", "pty-serial"], "pac", &["pac-state"]),
        (&["--cdios", "pty-slcan"], "cdios", &["cdios-status", "-m", "0"]),
    ];
    for (sim_args, fam, cmd) in cases {
        let mut s = sim(sim_args, "delay=30s", "1");
        let link = s.link(fam).to_string();
        let mut args = vec!["--link", &link, "--timeout", "20000", "--trace"];
        args.extend_from_slice(cmd);
        let mut child = common::bin()
            .env_remove("AXISCTL_TIMEOUT")
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Unplug only once the request is out (--trace says so on stderr).
        let mut err = std::io::BufReader::new(child.stderr.take().unwrap());
        let mut seen = String::new();
        let deadline = Instant::now() + Duration::from_secs(10);
        while !seen.lines().any(|l| l.starts_with("-> ") && !l.contains("NMT")) {
            assert!(Instant::now() < deadline, "{sim_args:?}: no request sent: {seen}");
            use std::io::BufRead;
            let mut line = String::new();
            if err.read_line(&mut line).unwrap() == 0 {
                panic!("{sim_args:?}: client ended early: {seen}");
            }
            seen.push_str(&line);
        }
        std::thread::sleep(Duration::from_millis(100));
        s.unplug();
        let t0 = Instant::now();
        child.stderr = Some(err.into_inner());
        let mut r = wait_bounded(child, 5, &args);
        r.stderr = seen + &r.stderr;
        assert_eq!(r.code, 3, "{sim_args:?}: {}", r.stderr);
        assert!(r.stderr.contains("link closed (adapter unplugged?)"), "{sim_args:?}: {}", r.stderr);
        assert!(t0.elapsed() < Duration::from_secs(2), "{sim_args:?}: {:?}", t0.elapsed());
    }
}

// ---- Ctrl-C during every --wait ----

fn interrupt_after(args: &[&str], ms: u64) -> Run {
    let child = common::bin()
        .env_remove("AXISCTL_TIMEOUT")
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(ms));
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    wait_bounded(child, 10, args)
}

/// Runs axisctl with `--trace` and sends SIGINT `ms` after the request
/// line naming `trigger` shows on stderr: a signal during the wait itself,
/// however long the start took on a loaded machine.
fn interrupt_when(args: &[&str], trigger: &str, ms: u64) -> Run {
    let r = common::signal_when(args, trigger, Duration::from_millis(ms), libc::SIGINT);
    Run { code: r.code, stdout: r.stdout, stderr: r.stderr }
}

#[test]
fn ctrl_c_during_home_wait_halts_and_exits_130() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube").to_string();
    let r = interrupt_after(&["--link", &link, "home", "-m", "3", "--wait"], 500);
    assert_eq!(r.code, 130, "{}", r.stderr);
    assert!(r.stderr.contains("module 3 halted"), "{}", r.stderr);
    let (st, _) = bounded(&["--link", &link, "--json", "state", "-m", "3"], 10);
    let raw = st.json()["state"]["raw"].as_u64().unwrap();
    assert!(raw & 0x4 != 0 && raw & 0x800 == 0 && raw & 0x2 == 0, "halted before homing ended: {raw:#x}");
}

#[test]
fn ctrl_c_during_pac_ref_wait_stops_and_exits_130() {
    let s = Sim::start(&["--pac", "pty-serial"], 1);
    let link = s.link("pac").to_string();
    let (r, _) = bounded(&["--link", &link, "--timeout", "1000", "pac-online"], 10);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let r = interrupt_when(&["--link", &link, "--timeout", "1000", "pac-ref", "2", "--wait"], "0A84", 300);
    assert_eq!(r.code, 130, "{}", r.stderr);
    assert!(r.stderr.contains("axis 2 stopped"), "{}", r.stderr);
    let (a, _) = bounded(&["--link", &link, "--timeout", "1000", "--json", "pac-axis", "2"], 10);
    assert_eq!(a.code, 0, "{}", a.stderr);
    assert_eq!(a.json()["axis_status"].as_u64().map(|s| s != 1), Some(true), "not moving: {}", a.stdout);
}

#[test]
fn ctrl_c_during_cdios_traject_wait_stops_and_exits_130() {
    let s = Sim::start(&["--cdios", "pty-slcan"], 1);
    let link = s.link("cdios").to_string();
    for args in [
        &[
            "cdios-config",
            "-m",
            "0",
            "traject0.end_position=1000000",
            "traject0.length=1",
            "traject0.initial_speed=500",
        ][..],
        &["cdios-enable", "-m", "0"][..],
    ] {
        let mut all = vec!["--link", link.as_str()];
        all.extend_from_slice(args);
        let (r, _) = bounded(&all, 10);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let r = interrupt_after(&["--link", &link, "cdios-traject", "-m", "0", "0", "--wait"], 600);
    assert_eq!(r.code, 130, "{}", r.stderr);
    assert!(r.stderr.contains("stopped (fast stop)"), "{}", r.stderr);
    let (st, _) = bounded(&["--link", &link, "--json", "cdios-status", "-m", "0"], 10);
    let flags = st.json()["state"]["flags"].clone();
    assert!(flags.is_array(), "{}", st.stdout);
    let flags = flags.to_string();
    assert!(!flags.contains("TRAJECT_RUNNING") && !flags.contains("RUNNING_FORWARD"), "{flags}");
}

// ---- a device faulting mid-move ends the wait with exit 5 ----

#[test]
fn powercube_tow_error_mid_move_is_exit_5_with_the_flags() {
    let s = sim(&["--powercube", "pty-slcan"], "trip=400ms", "1");
    let (r, _) = bounded(
        &["--link", s.link("powercube"), "--json", "move-ramp", "-m", "3", "2.0", "--vel", "0.2", "--wait"],
        20,
    );
    assert_eq!(r.code, 5, "{}", r.stderr);
    let e: serde_json::Value = serde_json::from_str(r.stderr.trim()).unwrap();
    assert_eq!(e["error"]["kind"], "device");
    let msg = e["error"]["message"].as_str().unwrap();
    assert!(msg.contains("STATE_TOW_ERROR") && msg.contains("STATE_ERROR"), "{msg}");
    // The CubeState the module reported, typed, for scripts.
    let device = &e["error"]["device"];
    assert_eq!(device["family"], "powercube", "{e}");
    let errors: Vec<&str> = device["details"].as_array().unwrap().iter().filter_map(|d| d["name"].as_str()).collect();
    assert!(errors.contains(&"STATE_TOW_ERROR") && errors.contains(&"STATE_ERROR"), "{e}");
    assert!(device["code"].as_u64().is_some_and(|c| c & 1 == 1), "the CubeState word; STATE_ERROR is bit 0: {e}");
    assert_eq!(
        (&e["error"]["module"], &e["error"]["exit_code"]),
        (&serde_json::json!(3), &serde_json::json!(5)),
        "{e}"
    );
}

#[test]
fn cdios_motor_fault_mid_goto_is_exit_5_with_the_flags() {
    let s = sim(&["--cdios", "pty-slcan"], "trip=400ms", "1");
    let link = s.link("cdios");
    let (r, _) = bounded(&["--link", link, "cdios-enable", "-m", "0"], 10);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let (r, _) = bounded(&["--link", link, "cdios-goto", "-m", "0", "1000000", "--wait"], 20);
    assert_eq!(r.code, 5, "{}", r.stderr);
    assert!(r.stderr.contains("MOTOR_DOES_NOT_RUN"), "{}", r.stderr);
}

#[test]
fn pac_axis_fault_mid_move_is_exit_5_with_the_status() {
    let s = sim(&["--pac", "pty-serial"], "trip=400ms", "1");
    let link = s.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"][..]] {
        let mut all = vec!["--link", link, "--timeout", "1000"];
        all.extend_from_slice(args);
        let (r, _) = bounded(&all, 10);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let (r, _) = bounded(&["--link", link, "--timeout", "1000", "pac-move", "2", "900", "--wait"], 20);
    assert_eq!(r.code, 5, "{}", r.stderr);
    assert!(r.stderr.contains("status 4"), "{}", r.stderr);
}

/// The polls of a --wait stop being answered: the module is halted before
/// the command gives up with the poll's exit code. (Answers 1..4 are the
/// Config check (not in sync mode), the state check, TargetVel and the move;
/// the next four, the poll and its retries, are lost; the Halt is answered.)
#[test]
fn a_wait_that_loses_the_module_halts_it_first() {
    let s = sim(&["--powercube", "pty-slcan"], "drop=1,skip=4,count=4", "1");
    let link = s.link("powercube");
    let (r, _) = bounded(&["--link", link, "move-ramp", "-m", "3", "2.0", "--vel", "0.2", "--force", "--wait"], 20);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("lost track of module 3 while moving (module 3 halted)"), "{}", r.stderr);
    let (st, _) = bounded(&["--link", link, "--json", "state", "-m", "3"], 10);
    let raw = st.json()["state"]["raw"].as_u64().unwrap();
    assert!(raw & 0x4 != 0 && raw & 0x800 == 0, "halted, not moving: {raw:#x}");
}
