//! The motion supervisor through the real binary against `axisctl sim` over
//! ptys: a signal at the worst instants (between the motion frame and its
//! acknowledge, during a long poll), every halting signal's exit code, an
//! output that fails mid-wait, and a lost motion acknowledge under --wait.
//! After each, the device must stand still. Every process runs under a
//! deadline: a hang fails the test instead of the suite.

mod common;

use std::io::Read;
use std::process::Stdio;
use std::time::Duration;

use common::{signal_when, wait_bounded, Ended, Run, Sim};

fn run_bounded(args: &[&str]) -> Run {
    let child = common::bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    wait_bounded(child, 60, args).run()
}

/// PowerCube module 3 stands: HALTED set and no MOTION.
fn cube_stands(link: &str) -> bool {
    let st = run_bounded(&["--link", link, "--json", "state", "-m", "3"]);
    let raw = st.json()["state"]["raw"].as_u64().unwrap();
    raw & 0x800 == 0 && raw & 0x4 != 0
}

/// Each of `modules` stands, halted: HALTED set and no MOTION.
fn assert_halted(link: &str, modules: &[&str]) {
    for m in modules {
        let raw = module_state(link, m);
        assert!(raw & 0x800 == 0 && raw & 0x4 != 0, "module {m} halted and standing: {raw:#x}");
    }
}

const RAMP: [&str; 8] = ["move-ramp", "-m", "3", "2.0", "--vel", "0.2", "--force", "--wait"];

fn ramp_args<'a>(link: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut all = vec!["--link", link, "--timeout", "3000"];
    all.extend_from_slice(extra);
    all.extend_from_slice(&RAMP);
    all
}

#[test]
fn sigint_between_the_motion_frame_and_its_acknowledge_halts_and_exits_130() {
    // Config, state and TargetVel pass; the SetMotion acknowledge comes 1.5 s late.
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "delay=1500ms,skip=3,count=1"], 1);
    let link = s.link("powercube");
    let r = signal_when(&ramp_args(link, &[]), "SetMotion", Duration::from_millis(100), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("module 3 halted"), "{}", r.stderr);
    assert!(cube_stands(link), "module 3 still moving");
}

#[test]
fn sigterm_sighup_and_sigquit_during_a_wait_halt_with_their_exit_codes() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    for (sig, code) in [(libc::SIGTERM, 143), (libc::SIGHUP, 129), (libc::SIGQUIT, 131)] {
        let r = signal_when(&ramp_args(link, &[]), "SetMotion", Duration::from_millis(400), sig);
        assert_eq!((r.code, r.killed_by), (code, None), "signal {sig}: {}", r.stderr);
        assert!(r.stderr.contains("module 3 halted"), "signal {sig}: {}", r.stderr);
        assert!(cube_stands(link), "signal {sig}: module 3 still moving");
        let reset = run_bounded(&["--link", link, "reset", "-m", "3"]);
        assert_eq!(reset.code, 0, "{}", reset.stderr);
    }
}

#[test]
fn ctrl_c_acts_at_once_whatever_the_poll() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let mut args = ramp_args(link, &[]);
    args.extend(["--poll", "60000"]);
    let r = signal_when(&args, "SetMotion", Duration::from_millis(500), libc::SIGINT);
    assert_eq!(r.code, 130, "{}", r.stderr);
    assert!(r.reaction < Duration::from_millis(1500), "took {:?} to react", r.reaction);
    assert!(cube_stands(link), "module 3 still moving");
}

#[test]
fn a_full_stdout_mid_wait_halts_and_fails_without_a_panic() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    let child =
        common::bin().args(ramp_args(link, &[])).stdout(Stdio::from(full)).stderr(Stdio::piped()).spawn().unwrap();
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("output failed") && stderr.contains("module 3 halted"), "{stderr}");
    assert!(cube_stands(link), "module 3 still moving");
}

/// `--trace ... 2>&1 | head`: the reader goes away mid-wait.
#[test]
fn a_closed_trace_pipe_mid_wait_halts_without_a_panic() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let mut all = vec!["--trace"];
    all.extend(ramp_args(link, &[]));
    let mut child = common::bin().args(&all).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let mut err = child.stderr.take().unwrap();
    let mut head = [0u8; 200];
    let _ = err.read(&mut head);
    std::thread::sleep(Duration::from_millis(300));
    drop(err);
    let Ended { code, signal: killed_by, .. } = wait_bounded(child, 15, &all);
    assert_eq!((code, killed_by), (1, None), "not a panic (101) nor a signal");
    assert!(cube_stands(link), "module 3 still moving");
}

#[test]
fn pac_progress_json_into_a_closed_pipe_stops_the_axis_without_a_panic() {
    let s = Sim::start(&["--pac", "pty-serial"], 1);
    let link = s.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"][..]] {
        let mut all = vec!["--link", link, "--timeout", "1000"];
        all.extend_from_slice(args);
        let r = run_bounded(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let args = ["--link", link, "--timeout", "1000", "pac-move", "2", "900", "--wait", "--progress-json"];
    let mut child = common::bin().args(args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let mut err = child.stderr.take().unwrap();
    let mut head = [0u8; 20];
    let _ = err.read(&mut head);
    drop(err);
    let Ended { code, signal: killed_by, .. } = wait_bounded(child, 15, &args);
    assert_eq!((code, killed_by), (1, None), "not a panic (101) nor a signal");
    let a = run_bounded(&["--link", link, "--timeout", "1000", "--json", "pac-axis", "2"]);
    assert_eq!(a.code, 0, "{}", a.stderr);
    assert_eq!(a.json()["axis_status"].as_u64().map(|s| s != 1), Some(true), "not moving: {}", a.stdout);
}

/// Config, state and TargetVel pass; the SetMotion acknowledge is lost. The
/// module took the motion, so it must be halted and the message must say so.
#[test]
fn a_lost_motion_acknowledge_under_wait_halts_and_says_so() {
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "drop=1,skip=3,count=1"], 1);
    let link = s.link("powercube");
    let r = run_bounded(&ramp_args(link, &[]));
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("may have been moving") && r.stderr.contains("module 3 halted"), "{}", r.stderr);
    assert!(cube_stands(link), "module 3 still moving");
}

/// The disk under `--log` fills up mid-wait (a file size limit here): the
/// traffic goes on, the module is halted, and the failure is reported after.
#[test]
fn a_log_that_fills_the_disk_mid_wait_never_blocks_the_halt() {
    use std::os::unix::process::CommandExt;
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let log = std::env::temp_dir().join(format!("axisctl-sup-{}-full.log", std::process::id()));
    let _ = std::fs::remove_file(&log);
    let mut all = vec!["--log", log.to_str().unwrap()];
    all.extend(ramp_args(link, &[]));
    let mut cmd = common::bin();
    cmd.args(&all).stdout(Stdio::null()).stderr(Stdio::piped());
    // SAFETY: only async-signal-safe calls between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            // Writes past 1000 bytes fail with EFBIG instead of killing the process.
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let lim = libc::rlimit { rlim_cur: 1000, rlim_max: 1000 };
            libc::setrlimit(libc::RLIMIT_FSIZE, &lim);
            Ok(())
        });
    }
    let out = cmd.spawn().unwrap().wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let _ = std::fs::remove_file(&log);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("--log") && stderr.contains("module 3 halted"), "{stderr}");
    assert!(cube_stands(link), "module 3 still moving");
}

/// pac-online (1 answer) and pac-no-ref (2) pass, then the state read of
/// pac-move; the 0A94 acknowledge is lost. The axis took the move, so it
/// must be stopped and the message must say so.
#[test]
fn pac_lost_move_acknowledge_under_wait_stops_the_axis_and_says_so() {
    let s = Sim::start(&["--pac", "pty-serial", "--fault", "drop=1,skip=4,count=1"], 1);
    let link = s.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"][..]] {
        let mut all = vec!["--link", link, "--timeout", "1000"];
        all.extend_from_slice(args);
        let r = run_bounded(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let r = run_bounded(&["--link", link, "--timeout", "1000", "pac-move", "2", "100", "--force", "--wait"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("may have been moving") && r.stderr.contains("axis 2 stopped"), "{}", r.stderr);
    let a = run_bounded(&["--link", link, "--timeout", "1000", "--json", "pac-axis", "2"]);
    assert_eq!(a.code, 0, "{}", a.stderr);
    assert_eq!(a.json()["axis_status"].as_u64().map(|s| s != 1), Some(true), "not moving: {}", a.stdout);
}

/// cdios-enable (1 answer) passes; the goto's answer is lost. The motor
/// took the goto, so it must be stopped and the message must say so.
#[test]
fn cdios_lost_goto_answer_under_wait_stops_the_motor_and_says_so() {
    // Answers: the enable's status read and the enable, the goto's status read, then the
    // goto's answer is lost.
    let s = Sim::start(&["--cdios", "pty-slcan", "--fault", "drop=1,skip=3,count=1"], 1);
    let link = s.link("cdios");
    let on = run_bounded(&["--link", link, "cdios-enable", "-m", "0"]);
    assert_eq!(on.code, 0, "{}", on.stderr);
    let r = run_bounded(&["--link", link, "cdios-goto", "-m", "0", "1000000", "--wait"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("may have been moving") && r.stderr.contains("stopped (fast stop)"), "{}", r.stderr);
    let st = run_bounded(&["--link", link, "--json", "cdios-status", "-m", "0"]);
    let flags = st.json()["state"]["flags"].clone();
    assert!(flags.is_array(), "{}", st.stdout);
    let flags = flags.to_string();
    assert!(!flags.contains("GOTO_ACTIVE") && !flags.contains("RUNNING_FORWARD"), "{flags}");
}

/// The Home acknowledge is lost under --wait: the module may be homing, so
/// it is halted and the message says so.
#[test]
fn a_lost_home_acknowledge_under_wait_halts_and_says_so() {
    // The first answer is Config's (is the watchdog on?), the second Home's.
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "drop=1,skip=1,count=1"], 1);
    let link = s.link("powercube");
    let r = run_bounded(&["--link", link, "--timeout", "1000", "home", "-m", "3", "--wait"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(r.stderr.contains("may have been moving") && r.stderr.contains("module 3 halted"), "{}", r.stderr);
    assert!(cube_stands(link), "module 3 still homing");
}

/// PowerCube module `m` (`"3"`) stands: no MOTION flag. `homed`: HOME_OK.
fn module_state(link: &str, m: &str) -> u64 {
    let st = run_bounded(&["--link", link, "--json", "state", "-m", m]);
    assert_eq!(st.code, 0, "{}", st.stderr);
    st.json()["state"]["raw"].as_u64().unwrap()
}

/// `home --all --wait`: the presence probes (modules 3, 5 and 17 answer)
/// pass, module 3's Home is acknowledged, module 5's acknowledge is lost.
/// Both may be homing, so both are halted and the message says so; module
/// 17 is never sent a Home.
#[test]
fn a_lost_home_acknowledge_of_home_all_under_wait_halts_the_modules_homed_so_far() {
    // Three presence answers, three Configs (is the watchdog on?), Home to 3, Home to 5.
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "drop=1,skip=7,count=1"], 1);
    let link = s.link("powercube");
    let r = run_bounded(&["--link", link, "--trace", "--timeout", "1000", "home", "--all", "--wait"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(
        r.stderr
            .contains("Home to module 5 was not acknowledged; the module may have been moving: modules 3, 5 halted"),
        "{}",
        r.stderr
    );
    let homes: Vec<&str> = r.stderr.lines().filter(|l| l.starts_with("-> ") && l.contains("Home")).collect();
    assert_eq!(homes.len(), 2, "one acknowledged Home each to modules 3 and 5, none to 17: {homes:?}");
    assert!(homes[0].contains("0E3#") && homes[1].contains("0E5#"), "{homes:?}");
    assert_halted(link, &["3", "5"]);
}

/// `home --all --wait` when module 3's presence answer is lost: a Home
/// broadcast would start it with nobody waiting for it. It is not sent a
/// Home at all; the modules that answered are homed and waited for.
#[test]
fn home_all_under_wait_never_starts_a_module_it_does_not_watch() {
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "drop=1,count=1"], 1);
    let link = s.link("powercube");
    let r = run_bounded(&["--link", link, "--trace", "--timeout", "1000", "home", "--all", "--wait"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("module 5: home done") && r.stdout.contains("module 17: home done"), "{}", r.stdout);
    assert!(!r.stderr.contains("100#"), "no broadcast: {}", r.stderr);
    let raw = module_state(link, "3");
    assert!(raw & 0x800 == 0 && raw & 0x2 == 0, "module 3 neither moving nor homed: {raw:#x}");
}

/// `move-ramp --sync --wait`: module 3's target is acknowledged, module 5's
/// acknowledge is lost. Both may hold a target that a later start broadcast
/// would start, so both are halted (which drops it), no start broadcast
/// goes out, and the message says so, exit 4.
#[test]
fn a_lost_acknowledge_of_a_sync_load_under_wait_halts_the_loaded_modules() {
    // set-config takes 3 answers per module; then the load: Config and
    // CubeState of 3 and 5, SetMotion to 3, SetMotion to 5 (the 12th answer).
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "drop=1,skip=11,count=1"], 1);
    let link = s.link("powercube");
    for m in ["3", "5"] {
        let r = run_bounded(&["--link", link, "set-config", "-m", m, "+sync-motion"]);
        assert_eq!(r.code, 0, "{}", r.stderr);
    }
    let args = ["--link", link, "--trace", "--timeout", "1000", "move-ramp", "-m", "3,5", "--sync", "0.5", "-0.5"];
    let r = run_bounded(&[&args[..], &["--force", "--wait"]].concat());
    assert_eq!(r.code, 4, "{}", r.stderr);
    assert!(
        r.stderr.contains("module 5 did not take its target (modules 3, 5 halted, no start broadcast sent)"),
        "{}",
        r.stderr
    );
    assert!(!r.stderr.contains("-> 100#"), "no start broadcast: {}", r.stderr);
    assert_halted(link, &["3", "5"]);
}

/// SIGINT while `home --all --wait` waits for module 3: every module of
/// the Home is halted, not only the one waited for, and the message says so.
#[test]
fn sigint_during_home_all_wait_halts_every_module_of_the_home() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let args = ["--link", link, "--timeout", "1000", "home", "--all", "--wait"];
    let r = signal_when(&args, "Home to module 17", Duration::from_millis(300), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("interrupted: module 3 halted; modules 5, 17 halted too"), "{}", r.stderr);
    assert_halted(link, &["3", "5", "17"]);
}

/// SIGINT while `home --all --wait` is still sending its Homes (module 5's
/// acknowledge comes 1.5 s late): no further Home goes out, and the modules
/// homed so far are halted.
#[test]
fn sigint_while_home_all_sends_its_homes_sends_no_more_and_halts_those_sent() {
    // Three presence answers, three Configs, Home to 3, then Home to 5's.
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "delay=1500ms,skip=7,count=1"], 1);
    let link = s.link("powercube");
    let args = ["--link", link, "--timeout", "3000", "home", "--all", "--wait"];
    let r = signal_when(&args, "Home to module 5", Duration::from_millis(100), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("interrupted before Home to module 17: modules 3, 5 halted"), "{}", r.stderr);
    assert!(!r.stderr.contains("Home to module 17\n"), "no Home to module 17: {}", r.stderr);
    assert_halted(link, &["3", "5"]);
}

/// SIGINT while `move-ramp --sync --wait` loads the targets (module 5's
/// acknowledge comes 1.5 s late): no start broadcast goes out, so nothing
/// moves, and the loaded modules are halted, which drops what they hold.
#[test]
fn sigint_during_a_sync_load_sends_no_start_and_halts_the_loaded_modules() {
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "delay=1500ms,skip=11,count=1"], 1);
    let link = s.link("powercube");
    for m in ["3", "5"] {
        let r = run_bounded(&["--link", link, "set-config", "-m", m, "+sync-motion"]);
        assert_eq!(r.code, 0, "{}", r.stderr);
    }
    let args =
        ["--link", link, "--timeout", "3000", "move-ramp", "-m", "3,5", "--sync", "0.5", "-0.5", "--force", "--wait"];
    let r = signal_when(&args, "SetMotion FRAMP_MODE -0.5 to module 5", Duration::from_millis(100), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("interrupted before the StartMotion broadcast: modules 3, 5 halted"), "{}", r.stderr);
    assert!(!r.stderr.contains("-> 100#"), "no start broadcast: {}", r.stderr);
    assert_halted(link, &["3", "5"]);
}

/// A signal while the checks before a motion still read the module (here
/// its CubeState answer is 1.5 s late): the motion frame is never sent, so
/// nothing moves and nothing needs a halt; the exit is still 130.
#[test]
fn a_signal_during_the_checks_before_the_motion_sends_no_motion() {
    let s = Sim::start(&["--powercube", "pty-slcan", "--fault", "delay=1500ms,skip=1,count=1"], 1);
    let link = s.link("powercube");
    let r = signal_when(&ramp_args(link, &[]), "CubeState", Duration::from_millis(100), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("nothing was sent"), "{}", r.stderr);
    let sent_motion = r.stderr.lines().any(|l| l.starts_with("-> ") && l.contains("SetMotion"));
    assert!(!sent_motion, "the motion frame went out: {}", r.stderr);
    assert_eq!(module_state(link, "3") & 0x800, 0, "module 3 moves");
}

/// The same on the PA-CONTROL: the signal comes while the mode is read
/// before `pac-move` (every answer of this simulator is 1.5 s late); no
/// 0A94 goes out.
#[test]
fn pac_a_signal_during_the_checks_before_the_move_sends_no_move() {
    let s = Sim::start(&["--pac", "pty-serial", "--fault", "delay=1500ms"], 1);
    let link = s.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"][..]] {
        let mut all = vec!["--link", link, "--timeout", "3000"];
        all.extend_from_slice(args);
        let r = run_bounded(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let args = ["--link", link, "--timeout", "3000", "pac-move", "2", "100", "--wait"];
    let r = signal_when(&args, "190B", Duration::from_millis(100), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("nothing moved"), "{}", r.stderr);
    let sent_move = r.stderr.lines().any(|l| l.starts_with("-> ") && l.contains("0A94"));
    assert!(!sent_move, "the move went out: {}", r.stderr);
}

/// The same on Cdios: the signal comes during the 100 ms the node is given
/// to settle after its NMT start, before the goto; no goto goes out. The
/// node runs (the enable started it), so the goto's status read would get no
/// NMT start: its answer is lost (`drop`, after the enable's two answers),
/// and a node that does not answer is started again.
#[test]
fn cdios_a_signal_while_the_node_starts_sends_no_goto() {
    let s = Sim::start(&["--cdios", "pty-slcan", "--fault", "drop=1,skip=2,count=1"], 1);
    let link = s.link("cdios");
    let on = run_bounded(&["--link", link, "cdios-enable", "-m", "0"]);
    assert_eq!(on.code, 0, "{}", on.stderr);
    let args = ["--link", link, "cdios-goto", "-m", "0", "1000000", "--wait"];
    let r = signal_when(&args, "NMT start", Duration::from_millis(20), libc::SIGINT);
    assert_eq!((r.code, r.killed_by), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("nothing moved"), "{}", r.stderr);
    let sent_goto = r.stderr.lines().any(|l| l.starts_with("-> ") && l.contains("goto"));
    assert!(!sent_goto, "the goto went out: {}", r.stderr);
}
