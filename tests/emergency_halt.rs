//! The emergency halt from another terminal, through the real binary against
//! `axisctl sim` over ptys: while a `--wait` or the dashboard holds the port,
//! `halt`, `pac-stop` and `cdios-stop` from a second process ask the holder
//! (found through its lock file) to halt and let go, then send their own
//! halt. A process that is not axisctl is never signalled, and a stale lock
//! is ignored. Every test has a lock directory of its own
//! (`AXISCTL_LOCK_DIR`), and every process runs under a deadline.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use axisctl::link::lock::{self, Holder};
use common::tmux::Tmux;
use common::{Run, Sim};

/// A lock directory for one test.
struct Locks(tempfile::TempDir);

impl Locks {
    fn new() -> Self {
        Self(tempfile::tempdir().unwrap())
    }

    fn dir(&self) -> &Path {
        self.0.path()
    }

    fn cmd(&self) -> Command {
        let mut c = common::bin();
        c.env(lock::DIR_ENV, self.dir());
        c
    }

    fn run(&self, args: &[&str]) -> Run {
        let child = self.cmd().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        let out = wait_output(child, 20, args);
        Run {
            code: out.status.code().unwrap_or(-1),
            stdout: String::from_utf8_lossy(&out.stdout).into(),
            stderr: String::from_utf8_lossy(&out.stderr).into(),
        }
    }

    /// The lock file of a `slcan:` / `serial:` link's device.
    fn file_of(&self, link: &str) -> PathBuf {
        lock::lock_path_in(self.dir(), &lock::canonical(tty(link)))
    }
}

fn tty(link: &str) -> &str {
    let path = link.split_once(':').unwrap().1;
    path.split('?').next().unwrap()
}

fn wait_output(child: Child, secs: u64, what: &[&str]) -> std::process::Output {
    let pid = child.id() as i32;
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(child.wait_with_output());
    });
    match rx.recv_timeout(Duration::from_secs(secs)) {
        Ok(out) => out.unwrap(),
        Err(_) => {
            // SAFETY: kill(2) on the child this test started.
            unsafe { libc::kill(pid, libc::SIGKILL) };
            panic!("axisctl {what:?} hung for {secs} s");
        }
    }
}

/// A supervised `--wait` motion in the background, started with `--trace`:
/// returned once the motion frame (a trace line containing `trigger`) left.
struct Holding {
    child: Child,
    stderr: std::thread::JoinHandle<String>,
}

impl Holding {
    fn start(locks: &Locks, args: &[&str], trigger: &str) -> Self {
        let mut child =
            locks.cmd().arg("--trace").args(args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
        let (tx, rx) = mpsc::channel();
        let err = child.stderr.take().unwrap();
        let trigger = trigger.to_string();
        let stderr = std::thread::spawn(move || {
            let mut text = String::new();
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                if line.starts_with("-> ") && line.contains(&trigger) {
                    let _ = tx.send(());
                }
                text.push_str(&line);
                text.push('\n');
            }
            text
        });
        rx.recv_timeout(Duration::from_secs(10)).expect("the motion frame left");
        // Into the wait, past the motion's acknowledge.
        std::thread::sleep(Duration::from_millis(300));
        Self { child, stderr }
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Exit code (`None`: killed by a signal) and stderr, once it ended.
    fn end(mut self, secs: u64) -> (Option<i32>, String) {
        let deadline = Instant::now() + Duration::from_secs(secs);
        let status = loop {
            if let Some(st) = self.child.try_wait().unwrap() {
                break st;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!("the holder did not end within {secs} s");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        (status.code(), self.stderr.join().unwrap())
    }
}

/// PowerCube module 3 stands: HALTED set and no MOTION.
fn cube_stands(locks: &Locks, link: &str) -> bool {
    let st = locks.run(&["--link", link, "--json", "state", "-m", "3"]);
    assert_eq!(st.code, 0, "{}", st.stderr);
    let raw = st.json()["state"]["raw"].as_u64().unwrap();
    raw & 0x800 == 0 && raw & 0x4 != 0
}

const RAMP: [&str; 10] = ["--timeout", "3000", "move-ramp", "-m", "3", "2.0", "--vel", "0.2", "--force", "--wait"];

fn ramp_args(link: &str) -> Vec<&str> {
    let mut all = vec!["--link", link];
    all.extend_from_slice(&RAMP);
    all
}

#[test]
fn halt_from_a_second_process_stops_a_move_ramp_wait_that_holds_the_port() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let holder = Holding::start(&locks, &ramp_args(link), "SetMotion");
    let pid = holder.pid();
    // Any other command is refused, and is told who holds the port.
    let busy = locks.run(&["--link", link, "state", "-m", "3"]);
    assert_eq!(busy.code, 3, "{}", busy.stderr);
    assert!(busy.stderr.contains(&format!("held by axisctl, PID {pid} (")), "{}", busy.stderr);
    assert!(busy.stderr.contains("move-ramp -m 3"), "{}", busy.stderr);

    let h = locks.run(&["--link", link, "halt", "-m", "3"]);
    assert_eq!(h.code, 0, "{}", h.stderr);
    let (code, stderr) = holder.end(10);
    assert_eq!(code, Some(143), "the holder halts on SIGTERM and exits 143: {stderr}");
    assert!(stderr.contains("module 3 halted"), "{stderr}");
    let lines: Vec<&str> = h.stdout.lines().collect();
    assert_eq!(lines.len(), 2, "{}", h.stdout);
    assert!(lines[0].contains(&format!("was held by axisctl PID {pid} (")), "{}", h.stdout);
    assert!(lines[0].contains("SIGTERM") && lines[0].ends_with("it exited"), "{}", h.stdout);
    assert_eq!(lines[1], "module 3: halt acknowledged");
    assert!(cube_stands(&locks, link), "module 3 still moving");
    assert!(!locks.file_of(link).exists(), "the holder's lock went with it");
}

#[test]
fn pac_stop_from_a_second_process_stops_a_pac_move_wait_that_holds_the_line() {
    let locks = Locks::new();
    let s = Sim::start(&["--pac", "pty-serial"], 1);
    let link = s.link("pac");
    for args in [&["pac-online"][..], &["pac-no-ref", "2"][..]] {
        let mut all = vec!["--link", link, "--timeout", "1000"];
        all.extend_from_slice(args);
        let r = locks.run(&all);
        assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    }
    let holder =
        Holding::start(&locks, &["--link", link, "--timeout", "1000", "pac-move", "2", "900", "--wait"], "0A94");
    let pid = holder.pid();
    let stop = locks.run(&["--link", link, "--timeout", "1000", "--json", "pac-stop-axis", "2", "--wait"]);
    assert_eq!(stop.code, 0, "{}", stop.stderr);
    let (code, stderr) = holder.end(10);
    assert_eq!(code, Some(143), "{stderr}");
    let doc = stop.json();
    assert_eq!(doc["holder"]["pid"], pid, "{doc}");
    assert_eq!((&doc["holder"]["signalled"], &doc["holder"]["exited"]), (&true.into(), &true.into()), "{doc}");
    assert!(doc["holder"]["what"].as_str().unwrap().contains("pac-move 2 900 --wait"), "{doc}");
    assert_eq!(doc["command_code"], "0A93", "{doc}");
    let a = locks.run(&["--link", link, "--timeout", "1000", "--json", "pac-axis", "2"]);
    assert_eq!(a.code, 0, "{}", a.stderr);
    assert_ne!(a.json()["axis_status"], 1, "axis 2 still moving: {}", a.stdout);

    // pac-stop (the controller's stop) takes the line over the same way.
    let holder =
        Holding::start(&locks, &["--link", link, "--timeout", "1000", "pac-move", "2", "100", "--wait"], "0A94");
    let stop = locks.run(&["--link", link, "--timeout", "1000", "pac-stop"]);
    assert_eq!(stop.code, 0, "{}", stop.stderr);
    assert!(stop.stdout.contains(&format!("was held by axisctl PID {}", holder.pid())), "{}", stop.stdout);
    assert_eq!(holder.end(10).0, Some(143));
    let a = locks.run(&["--link", link, "--timeout", "1000", "--json", "pac-axis", "2"]);
    assert_ne!(a.json()["axis_status"], 1, "axis 2 still moving: {}", a.stdout);
}

#[test]
fn cdios_stop_from_a_second_process_stops_a_cdios_goto_wait_that_holds_the_port() {
    let locks = Locks::new();
    let s = Sim::start(&["--cdios", "pty-slcan"], 1);
    let link = s.link("cdios");
    let on = locks.run(&["--link", link, "cdios-enable", "-m", "0"]);
    assert_eq!(on.code, 0, "{}", on.stderr);
    let holder =
        Holding::start(&locks, &["--link", link, "cdios-goto", "-m", "0", "1000000", "--wait"], "goto absolute");
    let pid = holder.pid();
    let stop = locks.run(&["--link", link, "--json", "cdios-stop", "-m", "0", "--option", "fast"]);
    assert_eq!(stop.code, 0, "{}", stop.stderr);
    let (code, stderr) = holder.end(10);
    assert_eq!(code, Some(143), "{stderr}");
    let doc = stop.json();
    assert_eq!((&doc["holder"]["pid"], &doc["command"]), (&pid.into(), &"cdios-stop".into()), "{doc}");
    // The holder's own stop came first: the node refuses a second one with
    // MOTOR_NOT_RUNNING, which after a takeover is the state asked for.
    assert_eq!(doc["already_stopped"], true, "{doc}");
    let st = locks.run(&["--link", link, "--json", "cdios-status", "-m", "0"]);
    let flags = st.json()["state"]["flags"].to_string();
    assert!(!flags.contains("GOTO_ACTIVE") && !flags.contains("RUNNING_FORWARD"), "{flags}");
}

/// A holder that cannot let go in time (stopped with SIGSTOP, so the SIGTERM
/// stays pending): the halt gives up after its bound with exit 3 and names
/// it. Once continued, the holder acts on the SIGTERM and halts.
#[test]
fn a_holder_that_does_not_let_go_in_time_is_exit_3_naming_it() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let holder = Holding::start(&locks, &ramp_args(link), "SetMotion");
    let pid = holder.pid();
    // SAFETY: kill(2) on the holder this test started.
    assert_eq!(unsafe { libc::kill(pid as i32, libc::SIGSTOP) }, 0);
    let t0 = Instant::now();
    let r = locks.run(&["--link", link, "halt", "--all"]);
    let took = t0.elapsed();
    // SAFETY: as above.
    assert_eq!(unsafe { libc::kill(pid as i32, libc::SIGCONT) }, 0);
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(r.stderr.contains(&format!("held by axisctl PID {pid} (")), "{}", r.stderr);
    assert!(r.stderr.contains("did not release it within 5 s"), "{}", r.stderr);
    assert!(took >= Duration::from_secs(5) && took < Duration::from_secs(10), "gave up after {took:?}");
    assert_eq!(holder.end(10).0, Some(143), "the pending SIGTERM halts it once continued");
    assert!(cube_stands(&locks, link), "module 3 still moving");
}

/// Holds `link`'s tty exclusively from this test process (not through
/// axisctl, so no lock file is written).
fn hold_exclusively(link: &str) -> serialport::TTYPort {
    serialport::TTYPort::open(&serialport::new(tty(link), 115_200)).expect("open the pty exclusively")
}

#[test]
fn a_holder_that_is_not_axisctl_is_never_signalled() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let _port = hold_exclusively(link);

    // No lock at all: another program. Nothing is signalled.
    let r = locks.run(&["--link", link, "halt", "--all"]);
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(r.stderr.contains("no axisctl lock names its holder"), "{}", r.stderr);

    // A lock naming a live `sleep`, honest or claiming to be axisctl.
    let mut sleep = Command::new("sleep").arg("60").spawn().unwrap();
    let pid = sleep.id();
    let start = lock::proc_start(pid).unwrap().unwrap();
    let sleep_exe = std::fs::read_link(format!("/proc/{pid}/exe")).unwrap();
    for exe in [sleep_exe, PathBuf::from(env!("CARGO_BIN_EXE_axisctl"))] {
        let forged = Holder { pid, start, exe, what: "dashboard".into(), device: lock::canonical(tty(link)) };
        std::fs::write(locks.file_of(link), forged.to_text()).unwrap();
        for args in [&["halt", "--all"][..], &["--json", "halt", "-m", "3"][..]] {
            let mut all = vec!["--link", link];
            all.extend_from_slice(args);
            let r = locks.run(&all);
            assert_eq!(r.code, 3, "{args:?}: {}", r.stderr);
            assert!(r.stderr.contains(&format!("PID {pid}, which is not axisctl")), "{}", r.stderr);
            assert!(r.stderr.contains("was not signalled"), "{}", r.stderr);
            assert!(r.stdout.is_empty(), "{}", r.stdout);
        }
        std::thread::sleep(Duration::from_millis(100));
        assert!(sleep.try_wait().unwrap().is_none(), "sleep {pid} was signalled");
    }
    sleep.kill().unwrap();
    sleep.wait().unwrap();
}

#[test]
fn a_stale_lock_is_ignored_and_replaced() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let mut gone = Command::new("true").spawn().unwrap();
    let dead = gone.id();
    gone.wait().unwrap();
    let stale = Holder {
        pid: dead,
        start: 1,
        exe: PathBuf::from(env!("CARGO_BIN_EXE_axisctl")),
        what: "dashboard".into(),
        device: lock::canonical(tty(link)),
    };
    let file = locks.file_of(link);

    // A free port with a stale lock: the lock does not matter, and the
    // open replaces it (then removes its own).
    std::fs::write(&file, stale.to_text()).unwrap();
    let r = locks.run(&["--link", link, "--json", "halt", "-m", "3"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.json().get("holder").is_none(), "{}", r.stdout);
    assert!(!file.exists(), "the stale lock was replaced, then removed with its holder");

    // A busy port whose lock is stale: held by someone else, whom nothing names.
    let port = hold_exclusively(link);
    std::fs::write(&file, stale.to_text()).unwrap();
    let r = locks.run(&["--link", link, "halt", "--all"]);
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(r.stderr.contains(&format!("PID {dead}, which has exited")), "{}", r.stderr);
    drop(port);

    // A real holder over a stale lock: its own lock replaced the stale one.
    let reset = locks.run(&["--link", link, "reset", "-m", "3"]);
    assert_eq!(reset.code, 0, "{}", reset.stderr);
    let holder = Holding::start(&locks, &ramp_args(link), "SetMotion");
    let now = Holder::parse(&std::fs::read_to_string(&file).unwrap()).unwrap();
    assert_eq!(now.pid, holder.pid());
    let h = locks.run(&["--link", link, "halt", "--all"]);
    assert_eq!(h.code, 0, "{}", h.stderr);
    assert_eq!(holder.end(10).0, Some(143));
    assert!(cube_stands(&locks, link), "module 3 still moving");
}

// ---- the dashboard in a real terminal ----

#[test]
fn halt_all_from_a_second_terminal_ends_the_dashboard_and_halts_the_module_it_moved() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let t = Tmux::start("ehalt", 100, 30, &[]);
    t.wait_for("READY$");
    t.keys(&[
        &format!(
            "{}={} {} --link {link} dashboard",
            lock::DIR_ENV,
            locks.dir().display(),
            env!("CARGO_BIN_EXE_axisctl")
        ),
        "Enter",
    ]);
    t.wait_for("module 17");
    // Home module 3 (selected first) from the dashboard, and see it move.
    t.keys(&["h"]);
    t.wait_for("Home acknowledged");
    t.wait_for("moving");
    let dashboard = Holder::parse(&std::fs::read_to_string(locks.file_of(link)).unwrap()).unwrap();
    assert!(dashboard.what.ends_with("dashboard"), "{dashboard:?}");

    let h = locks.run(&["--link", link, "--json", "halt", "--all"]);
    assert_eq!(h.code, 0, "{}", h.stderr);
    let doc = h.json();
    assert_eq!(doc["holder"]["pid"], dashboard.pid, "{doc}");
    assert_eq!(doc["holder"]["exited"], true, "{doc}");
    assert_eq!((&doc["broadcast"], &doc["command"]), (&true.into(), &"halt".into()), "{doc}");

    // The dashboard left, restored the terminal, said what it did and exited 143.
    let deadline = Instant::now() + Duration::from_secs(10);
    while t.display("#{alternate_on}") != "0" {
        assert!(Instant::now() < deadline, "the dashboard is still on screen:\n{}", t.capture());
        std::thread::sleep(Duration::from_millis(50));
    }
    t.keys(&["echo code=$? DO''NE", "Enter"]);
    let screen = t.wait_for("DONE");
    assert!(screen.contains("SIGTERM: halted what the dashboard moved"), "{screen}");
    assert!(screen.contains("code=143 DONE"), "{screen}");
    assert!(!locks.file_of(link).exists(), "the dashboard's lock went with it");
    assert!(cube_stands(&locks, link), "module 3 still moving");
}
