//! The motion supervisor through the real binary against `axisctl sim` over
//! ptys: a signal at the worst instants (between the motion frame and its
//! acknowledge, during a long poll), every halting signal's exit code, an
//! output that fails mid-wait, and a lost motion acknowledge under --wait.
//! After each, the device must stand still. Every process runs under a
//! deadline: a hang fails the test instead of the suite.

use crate::common;

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

/// 0603 sent raw (1 answer; pac-online reads the speed limits first) and
/// pac-no-ref (2) pass, then the state read of pac-move; the 0A94
/// acknowledge is lost. The axis took the move, so it must be stopped and
/// the message must say so.
#[test]
fn pac_lost_move_acknowledge_under_wait_stops_the_axis_and_says_so() {
    let s = Sim::start(&["--pac", "pty-serial", "--fault", "drop=1,skip=4,count=1"], 1);
    let link = s.link("pac");
    for args in [&["pac-raw", "0603", "0"][..], &["pac-no-ref", "2"][..]] {
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
/// before `pac-move` (every answer of this simulator is 600 ms late, 500 ms after the signal); no
/// 0A94 goes out.
#[test]
fn pac_a_signal_during_the_checks_before_the_move_sends_no_move() {
    let s = Sim::start(&["--pac", "pty-serial", "--fault", "delay=600ms"], 1);
    let link = s.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"][..]] {
        let mut all = vec!["--link", link, "--timeout", "2000"];
        all.extend_from_slice(args);
        let r = run_bounded(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let args = ["--link", link, "--timeout", "2000", "pac-move", "2", "100", "--wait"];
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

/// A `--wait` move under watch: its `--trace` lines come one by one on
/// `lines` (all of them are also kept for the end), and it runs in a
/// process group of its own, as a shell puts a job.
struct Watched {
    child: std::process::Child,
    lines: std::sync::mpsc::Receiver<String>,
    stderr: std::thread::JoinHandle<String>,
}

impl Watched {
    /// Starts `axisctl --trace ARGS`; `setup` runs in the child before exec.
    fn start(args: &[&str], setup: impl FnMut() -> std::io::Result<()> + Send + Sync + 'static) -> Self {
        use std::io::BufRead;
        use std::os::unix::process::CommandExt;
        let mut cmd = common::bin();
        cmd.arg("--trace").args(args).stdout(Stdio::null()).stderr(Stdio::piped()).process_group(0);
        // SAFETY: `setup` makes only async-signal-safe calls.
        unsafe {
            cmd.pre_exec(setup);
        }
        let mut child = cmd.spawn().unwrap();
        let err = child.stderr.take().unwrap();
        let (tx, lines) = std::sync::mpsc::channel();
        let stderr = std::thread::spawn(move || {
            let mut text = String::new();
            for line in std::io::BufReader::new(err).lines().map_while(Result::ok) {
                let _ = tx.send(line.clone());
                text.push_str(&line);
                text.push('\n');
            }
            text
        });
        Self { child, lines, stderr }
    }

    /// Returns once the motion frame is acknowledged and the wait has had
    /// an answer to its first poll: the module is moving, watched.
    fn until_the_wait_polls(&self) {
        self.until_polled_after_motion(1);
    }

    /// Returns once the `nth` motion frame is acknowledged and the next
    /// answer is in (the first poll of its wait).
    fn until_polled_after_motion(&self, nth: usize) {
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        let (mut motions, mut answers_since_motion) = (0, 0);
        while motions < nth || answers_since_motion < 2 {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            let line = self.lines.recv_timeout(left).expect("the wait polls within 20 s");
            if line.starts_with("-> ") && line.contains("SetMotion") {
                motions += 1;
                answers_since_motion = 0;
            } else if line.starts_with("<- ") {
                answers_since_motion += 1;
            }
        }
    }

    fn pid(&self) -> i32 {
        self.child.id() as i32
    }

    fn signal(&self, sig: i32) {
        // SAFETY: the child is ours and not reaped yet.
        assert_eq!(unsafe { libc::kill(self.pid(), sig) }, 0);
    }

    /// Waits until the process is stopped (state T in /proc); fails if it
    /// ends or is not stopped within 20 s.
    fn until_stopped(&mut self) {
        let deadline = std::time::Instant::now() + Duration::from_secs(20);
        loop {
            let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.pid())).unwrap();
            let state = stat.rsplit(')').next().unwrap().trim_start().chars().next();
            if state == Some('T') {
                return;
            }
            assert!(self.child.try_wait().unwrap().is_none(), "the process ended instead of stopping");
            assert!(std::time::Instant::now() < deadline, "not stopped within 20 s (state {state:?})");
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    fn end(self, what: &[&str]) -> Ended {
        let mut ended = wait_bounded(self.child, 20, what);
        ended.stderr = self.stderr.join().unwrap();
        ended
    }
}

/// The wall-clock instant of the first line of the `--log` at `log` at or
/// after `since` that contains `frame` (lines start `(secs.micros)`).
fn logged_after(log: &std::path::Path, frame: &str, since: std::time::SystemTime) -> Option<std::time::SystemTime> {
    let text = std::fs::read_to_string(log).ok()?;
    text.lines().filter(|l| l.contains(frame)).find_map(|l| {
        let at = log_stamp(l)?;
        (at >= since).then_some(at)
    })
}

fn log_stamp(line: &str) -> Option<std::time::SystemTime> {
    let stamp = line.strip_prefix('(')?.split(')').next()?;
    let (secs, micros) = stamp.split_once('.')?;
    Some(std::time::UNIX_EPOCH + Duration::new(secs.parse().ok()?, micros.parse::<u32>().ok()? * 1000))
}

fn temp_log(name: &str) -> std::path::PathBuf {
    let log = std::env::temp_dir().join(format!("axisctl-sup-{}-{name}.log", std::process::id()));
    let _ = std::fs::remove_file(&log);
    log
}

/// Halt (0x02) to module 3 (0x0E0 + 3), as candump writes it.
const HALT_FRAME: &str = " 0E3#02";

/// A job-control stop signal (SIGTSTP: Ctrl-Z) during a wait: the module is
/// halted first (the Halt frame within 1 s of the signal, by the `--log`
/// stamps), then the process stops, with the port released: the module is
/// read standing while the process is stopped. A SIGTERM that comes while
/// it is stopped, then SIGCONT: it ends with 148, the motion not resumed.
#[test]
fn sigtstp_during_a_wait_halts_first_then_stops_and_continued_exits_148() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let log = temp_log("tstp");
    let mut args = vec!["--log", log.to_str().unwrap()];
    args.extend(ramp_args(link, &[]));
    let mut w = Watched::start(&args, || Ok(()));
    w.until_the_wait_polls();
    let t0 = std::time::SystemTime::now();
    w.signal(libc::SIGTSTP);
    w.until_stopped();
    let halt = logged_after(&log, HALT_FRAME, t0).expect("a Halt frame after the signal");
    let took = halt.duration_since(t0).unwrap();
    eprintln!("SIGTSTP to the Halt frame: {took:?}");
    assert!(took < Duration::from_secs(1), "the Halt frame went out {took:?} after SIGTSTP");
    assert!(cube_stands(link), "module 3 still moving while axisctl is stopped");
    w.signal(libc::SIGTERM);
    w.signal(libc::SIGCONT);
    let r = w.end(&args);
    let _ = std::fs::remove_file(&log);
    assert_eq!((r.code, r.signal), (148, None), "{}", r.stderr);
    assert!(r.stderr.contains("interrupted: module 3 halted"), "{}", r.stderr);
    assert!(
        r.stderr.contains("SIGTSTP: stopping; continued, axisctl ends (the motion is not resumed)"),
        "{}",
        r.stderr
    );
    assert!(cube_stands(link), "module 3 moved again after SIGCONT");
}

/// SIGTTIN and SIGTTOU (a background job that reads or writes its terminal
/// under `stty tostop`) stop a process as SIGTSTP does: halt first, then
/// stop; continued, exit 149 / 150, with `--json` an error document of the
/// kind `interrupted` that the schema allows.
#[test]
fn sigttin_and_sigttou_during_a_wait_halt_first_then_stop() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let schema = common::schema("error_document");
    for (sig, code) in [(libc::SIGTTIN, 149), (libc::SIGTTOU, 150)] {
        let log = temp_log("ttio");
        let mut args = vec!["--json", "--log", log.to_str().unwrap()];
        args.extend(ramp_args(link, &[]));
        let mut w = Watched::start(&args, || Ok(()));
        w.until_the_wait_polls();
        let t0 = std::time::SystemTime::now();
        w.signal(sig);
        w.until_stopped();
        let halt = logged_after(&log, HALT_FRAME, t0).expect("a Halt frame after the signal");
        let took = halt.duration_since(t0).unwrap();
        eprintln!("signal {sig} to the Halt frame: {took:?}");
        assert!(took < Duration::from_secs(1), "signal {sig}: the Halt frame went out {took:?} after it");
        assert!(cube_stands(link), "signal {sig}: module 3 still moving while axisctl is stopped");
        w.signal(libc::SIGCONT);
        let r = w.end(&args);
        let _ = std::fs::remove_file(&log);
        assert_eq!((r.code, r.signal), (code, None), "signal {sig}: {}", r.stderr);
        let doc = r.stderr.lines().find_map(|l| serde_json::from_str::<serde_json::Value>(l).ok());
        let doc = doc.unwrap_or_else(|| panic!("signal {sig}: no error document: {}", r.stderr));
        assert_eq!(doc["error"]["kind"], "interrupted", "{doc}");
        assert_eq!(doc["error"]["exit_code"], code, "{doc}");
        assert!(doc["error"]["message"].as_str().unwrap().contains("interrupted: module 3 halted"), "{doc}");
        assert_eq!(common::schema_errors(&schema, &doc), None, "{doc}");
        let reset = run_bounded(&["--link", link, "reset", "-m", "3"]);
        assert_eq!(reset.code, 0, "{}", reset.stderr);
    }
}

/// The supervised signals blocked, as a parent may leave them.
fn block_supervised_signals() -> std::io::Result<()> {
    // SAFETY: sigemptyset / sigaddset on a local set, then sigprocmask.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT, libc::SIGTSTP, libc::SIGXFSZ] {
            libc::sigaddset(&mut set, sig);
        }
        if libc::sigprocmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) != 0 {
            return Err(std::io::Error::last_os_error());
        }
    }
    Ok(())
}

/// A wait started with INT, TERM, HUP, QUIT blocked (a mask inherited
/// from the parent): Ctrl-C still halts it (130), and so does the
/// emergency halt from a second process, whose SIGTERM the holder acts on
/// (143) instead of leaving it pending while the module moves on.
#[test]
fn a_wait_started_with_the_signals_blocked_still_halts_on_them() {
    use std::os::unix::process::CommandExt;
    // The blocked mask does reach the child through this harness.
    let mut probe = std::process::Command::new("grep");
    probe.args(["^SigBlk", "/proc/self/status"]);
    // SAFETY: block_supervised_signals makes only async-signal-safe calls.
    let out = unsafe { probe.pre_exec(block_supervised_signals) }.output().unwrap();
    let blk = String::from_utf8_lossy(&out.stdout);
    let mask = u64::from_str_radix(blk.trim().trim_start_matches("SigBlk:").trim(), 16).unwrap();
    for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT] {
        assert!(mask & (1 << (sig - 1)) != 0, "signal {sig} blocked in the child: {blk}");
    }

    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let args = ramp_args(link, &[]);
    let w = Watched::start(&args, block_supervised_signals);
    w.until_the_wait_polls();
    w.signal(libc::SIGINT);
    let r = w.end(&args);
    assert_eq!((r.code, r.signal), (130, None), "{}", r.stderr);
    assert!(r.stderr.contains("module 3 halted"), "{}", r.stderr);
    assert!(cube_stands(link), "module 3 still moving");
    let reset = run_bounded(&["--link", link, "reset", "-m", "3"]);
    assert_eq!(reset.code, 0, "{}", reset.stderr);

    let w = Watched::start(&args, block_supervised_signals);
    w.until_the_wait_polls();
    let halt = run_bounded(&["--link", link, "halt", "-m", "3"]);
    assert_eq!(halt.code, 0, "the emergency halt: {}", halt.stderr);
    assert!(halt.stderr.contains("it exited") || halt.stdout.contains("it exited"), "{}\n{}", halt.stdout, halt.stderr);
    let r = w.end(&args);
    assert_eq!((r.code, r.signal), (143, None), "{}", r.stderr);
    assert!(r.stderr.contains("module 3 halted"), "{}", r.stderr);
    assert!(cube_stands(link), "module 3 still moving");
}

/// `(ulimit -f 1; axisctl --log f.log move-ramp ... --wait)`: the write that
/// crosses the limit raises SIGXFSZ, whose default would end the process
/// with the module moving. It fails with EFBIG instead: the module is
/// halted and the failure reported (exit 1), not a death by SIGXFSZ. The
/// log cannot hold the Halt frame, so the time is bounded from its last
/// line to the exit, after the halt's acknowledge.
#[test]
fn a_log_past_ulimit_f_halts_instead_of_dying_of_sigxfsz() {
    use std::os::unix::process::CommandExt;
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let log = temp_log("xfsz");
    let mut all = vec!["--log", log.to_str().unwrap()];
    all.extend(ramp_args(link, &[]));
    let mut cmd = common::bin();
    cmd.args(&all).stdout(Stdio::null()).stderr(Stdio::piped());
    // SAFETY: only async-signal-safe calls between fork and exec.
    unsafe {
        cmd.pre_exec(|| {
            // What `ulimit -f 1` leaves: the default SIGXFSZ, 1024 bytes.
            libc::signal(libc::SIGXFSZ, libc::SIG_DFL);
            let lim = libc::rlimit { rlim_cur: 1024, rlim_max: 1024 };
            libc::setrlimit(libc::RLIMIT_FSIZE, &lim);
            Ok(())
        });
    }
    let r = wait_bounded(cmd.spawn().unwrap(), 30, &all);
    let exited = std::time::SystemTime::now();
    let text = std::fs::read_to_string(&log).unwrap();
    let _ = std::fs::remove_file(&log);
    assert_eq!((r.code, r.signal), (1, None), "{}", r.stderr);
    assert!(r.stderr.contains("File too large") && r.stderr.contains("module 3 halted"), "{}", r.stderr);
    assert!(cube_stands(link), "module 3 still moving");
    assert!(text.len() <= 1024 && text.contains(" 0E3#0B"), "the SetMotion frame is logged: {text}");
    let last = text.lines().filter_map(log_stamp).next_back().expect("stamped lines");
    let took = exited.duration_since(last).unwrap();
    eprintln!("last logged line to the exit: {took:?}");
    assert!(took < Duration::from_secs(1), "halted and exited {took:?} after the last line the log took");
}

/// The other signals whose default would end the process with the module
/// moving (`kill -USR1` is a habit from `dd`): each halts it and exits
/// with 128 + the signal.
#[test]
fn the_other_ending_signals_halt_with_their_exit_codes() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let args = ramp_args(link, &[]);
    for sig in [libc::SIGUSR1, libc::SIGUSR2, libc::SIGALRM, libc::SIGVTALRM, libc::SIGPROF, libc::SIGIO, libc::SIGPWR]
    {
        let w = Watched::start(&args, || Ok(()));
        w.until_the_wait_polls();
        w.signal(sig);
        let r = w.end(&args);
        assert_eq!((r.code, r.signal), (128 + sig, None), "signal {sig}: {}", r.stderr);
        assert!(r.stderr.contains("interrupted: module 3 halted"), "signal {sig}: {}", r.stderr);
        assert!(cube_stands(link), "signal {sig}: module 3 still moving");
        let reset = run_bounded(&["--link", link, "reset", "-m", "3"]);
        assert_eq!(reset.code, 0, "{}", reset.stderr);
    }
}

/// Ctrl-Z during a batch: every device its lines moved (module 3 set
/// moving without a wait, module 5 waited for) is halted, the port is
/// released, then the process stops; continued, it exits 148.
#[test]
fn sigtstp_during_a_batch_halts_what_its_lines_moved_then_stops() {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let lines = temp_log("batch-lines");
    std::fs::write(&lines, "move-vel -m 3 0.1\nmove-ramp -m 5 3 --vel 0.01 --force --wait\n").unwrap();
    let args = ["--link", link, "--timeout", "3000", "batch", lines.to_str().unwrap()];
    let mut w = Watched::start(&args, || Ok(()));
    w.until_polled_after_motion(2);
    w.signal(libc::SIGTSTP);
    w.until_stopped();
    for m in ["3", "5"] {
        let raw = module_state(link, m);
        assert!(raw & 0x800 == 0 && raw & 0x4 != 0, "module {m} halted and standing while stopped: {raw:#x}");
    }
    w.signal(libc::SIGCONT);
    let r = w.end(&args);
    let _ = std::fs::remove_file(&lines);
    assert_eq!((r.code, r.signal), (148, None), "{}", r.stderr);
    assert!(r.stderr.contains("stopped by SIGTSTP after line"), "{}", r.stderr);
    assert!(r.stderr.contains("`halt -m 3`") && r.stderr.contains("`halt -m 5`"), "{}", r.stderr);
}
