//! The emergency halt from another terminal, through the real binary against
//! `axisctl sim` over ptys: while a `--wait` or the dashboard holds the port,
//! `halt`, `pac-stop` and `cdios-stop` from a second process ask the holder
//! (found through its lock file) to halt and let go, then send their own
//! halt. A process that is not axisctl is never signalled, and a stale lock
//! is ignored. Every test has a lock directory of its own
//! (`AXISCTL_LOCK_DIR`, or `XDG_RUNTIME_DIR` and `TMPDIR` set per process
//! where the test is about them), and every process runs under a deadline.

use crate::common;

use std::io::{BufRead, BufReader};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use axisctl::link::lock::{self, Holder};
use common::tmux::Tmux;
use common::{Run, Sim};

/// A directory of the test's own, private (mode 0700) as a lock directory must be.
fn private_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::set_permissions(dir.path(), std::fs::Permissions::from_mode(0o700)).unwrap();
    dir
}

/// The lock environment of one test's processes: a lock directory of its
/// own, or (`shell`) no `AXISCTL_LOCK_DIR` and the runtime and temporary
/// directories a person's shell would have, under the test's own root.
struct Locks {
    dir: Option<tempfile::TempDir>,
    env: Vec<(&'static str, Option<PathBuf>)>,
}

impl Locks {
    fn new() -> Self {
        let dir = private_dir();
        let env = vec![(lock::DIR_ENV, Some(dir.path().to_path_buf()))];
        Self { dir: Some(dir), env }
    }

    fn shell(xdg: Option<&Path>, tmp: &Path) -> Self {
        let env = vec![
            (lock::DIR_ENV, None),
            ("XDG_RUNTIME_DIR", xdg.map(Path::to_path_buf)),
            ("TMPDIR", Some(tmp.to_path_buf())),
        ];
        Self { dir: None, env }
    }

    fn dir(&self) -> &Path {
        self.dir.as_ref().expect("a lock directory of its own").path()
    }

    fn cmd(&self) -> Command {
        let mut c = common::bin();
        for (k, v) in &self.env {
            match v {
                Some(v) => c.env(k, v),
                None => c.env_remove(k),
            };
        }
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
        Self::spawn(locks.cmd(), args, trigger)
    }

    fn spawn(mut cmd: Command, args: &[&str], trigger: &str) -> Self {
        let mut child = cmd.arg("--trace").args(args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
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

/// The state letter of a process (`/proc/PID/stat` field 3).
fn proc_state(pid: u32) -> Option<char> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    text[text.rfind(')')? + 1..].split_whitespace().next()?.chars().next()
}

fn wait_state(pid: u32, want: char) {
    let deadline = Instant::now() + Duration::from_secs(20);
    while proc_state(pid) != Some(want) {
        assert!(Instant::now() < deadline, "PID {pid} never reached state {want}: {:?}", proc_state(pid));
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// A holder stopped as Ctrl-Z stops it (SIGSTOP here: a SIGTSTP is dropped
/// in an orphaned process group, which a test runner may be) would keep the
/// SIGTERM pending and the port held: the halt continues it with SIGCONT,
/// so it halts what it drives and lets go.
#[test]
fn a_stopped_holder_is_continued_and_halts() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let holder = Holding::start(&locks, &ramp_args(link), "SetMotion");
    let pid = holder.pid();
    // SAFETY: kill(2) on the holder this test started.
    assert_eq!(unsafe { libc::kill(pid as i32, libc::SIGSTOP) }, 0);
    wait_state(pid, 'T');
    let r = locks.run(&["--link", link, "halt", "--all"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains(&format!("was held by axisctl PID {pid} (")), "{}", r.stdout);
    let (code, stderr) = holder.end(10);
    assert_eq!(code, Some(143), "{stderr}");
    assert!(stderr.contains("module 3 halted"), "{stderr}");
    assert!(cube_stands(&locks, link), "module 3 still moving");
}

/// A holder that is asked but cannot act on it: its `--trace` goes into a
/// pipe of one page that nobody reads once the motion frame left, so it
/// hangs in write(2) (a wait piped into a pager that was paused). Since
/// arming unblocks the signals and the halt sends SIGCONT with SIGTERM, an
/// axisctl holder that still runs always lets go; one stuck in the kernel
/// does not. Returns the holder's PID, the child and the pipe's reader.
fn stuck_holder(locks: &Locks, link: &str) -> (Child, std::fs::File) {
    use std::os::fd::AsRawFd;
    let mut child =
        locks.cmd().arg("--trace").args(ramp_args(link)).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let err = child.stderr.take().unwrap();
    // SAFETY: fcntl(2) on the pipe this test owns; one page is its minimum.
    unsafe { libc::fcntl(err.as_raw_fd(), libc::F_SETPIPE_SZ, 4096) };
    let mut reader = BufReader::new(std::fs::File::from(std::os::fd::OwnedFd::from(err)));
    let deadline = Instant::now() + Duration::from_secs(10);
    let mut line = String::new();
    while !(line.starts_with("-> ") && line.contains("SetMotion")) {
        line.clear();
        assert!(reader.read_line(&mut line).unwrap() > 0 && Instant::now() < deadline, "the motion frame left");
    }
    let pid = child.id();
    let deadline = Instant::now() + Duration::from_secs(20);
    while !in_syscall(pid, &[libc::SYS_write]) {
        assert!(Instant::now() < deadline, "the holder never filled its trace pipe");
        std::thread::sleep(Duration::from_millis(5));
    }
    (child, reader.into_inner())
}

/// Whether process `pid` waits in one of `calls` (its main thread, per /proc).
fn in_syscall(pid: u32, calls: &[libc::c_long]) -> bool {
    let text = std::fs::read_to_string(format!("/proc/{pid}/syscall")).unwrap_or_default();
    text.split_whitespace().next().and_then(|n| n.parse::<libc::c_long>().ok()).is_some_and(|n| calls.contains(&n))
}

/// Ends a holder this test started.
fn kill_and_reap(mut child: Child) {
    let _ = child.kill();
    let _ = child.wait();
}

/// The adapter is unplugged while the halt waits for the holder to let go:
/// the halt ends with that error, not after its 5 s as if the port were
/// still held (only "busy" is tried again).
#[test]
fn a_port_that_goes_away_during_a_takeover_ends_it_with_that_error() {
    let locks = Locks::new();
    let mut s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube").to_string();
    let (holder, _pipe) = stuck_holder(&locks, &link);
    let mut halt = locks.cmd();
    let halt =
        halt.args(["--link", &link, "halt", "--all"]).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    // The halt sleeps between its tries only once it found the port busy
    // and asked the holder.
    let deadline = Instant::now() + Duration::from_secs(20);
    while !in_syscall(halt.id(), &[libc::SYS_nanosleep, libc::SYS_clock_nanosleep]) {
        assert!(Instant::now() < deadline, "the halt never waited for the holder");
        std::thread::sleep(Duration::from_millis(2));
    }
    s.unplug();
    let out = wait_output(halt, 20, &["halt", "--all"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(!stderr.contains("did not release") && !stderr.contains("device busy"), "{stderr}");
    assert!(stderr.contains(tty(&link)), "{stderr}");
    kill_and_reap(holder);
}

/// A holder that cannot let go in time (stuck in a write): the halt gives
/// up after its bound with exit 3 and names it, having signalled it once.
#[test]
fn a_holder_that_does_not_let_go_in_time_is_exit_3_naming_it() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let (holder, _pipe) = stuck_holder(&locks, link);
    let pid = holder.id();
    let t0 = Instant::now();
    let r = locks.run(&["--link", link, "halt", "--all"]);
    let took = t0.elapsed();
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(r.stderr.contains(&format!("held by axisctl PID {pid} (")), "{}", r.stderr);
    assert!(r.stderr.contains("was sent SIGTERM but did not release it within 5 s"), "{}", r.stderr);
    assert!(took >= Duration::from_secs(5) && took < Duration::from_secs(10), "gave up after {took:?}");
    assert!(in_syscall(pid, &[libc::SYS_write]), "the holder is still stuck, holding the port");
    kill_and_reap(holder);
    let h = locks.run(&["--link", link, "halt", "--all"]);
    assert_eq!(h.code, 0, "{}", h.stderr);
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
        let forged =
            Holder { pid, start, exe, what: "dashboard".into(), device: lock::canonical(tty(link)), halting: false };
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
        halting: false,
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

/// A count for a race harness: `var` when set (a long run by hand), else `ci`.
fn runs(var: &str, ci: usize) -> usize {
    std::env::var(var).ok().and_then(|v| v.parse().ok()).unwrap_or(ci)
}

/// A child killed when the test ends, whichever way.
struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// A holder that has exited but is not reaped (a zombie: its ports are
/// closed), and a live axisctl process whose PID a lock names with another
/// start time (a reused PID): neither is taken for the holder of a port
/// someone else holds, neither is signalled, and the halt says the lock's
/// process has exited.
#[test]
fn a_zombie_or_reused_pid_in_the_lock_is_never_taken_for_the_holder() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let _port = hold_exclusively(link);
    let lock_of = |pid: u32, start: u64| Holder {
        pid,
        start,
        exe: PathBuf::from(env!("CARGO_BIN_EXE_axisctl")),
        what: "dashboard".into(),
        device: lock::canonical(tty(link)),
        halting: false,
    };
    let mut zombie = KillOnDrop(locks.cmd().arg("--version").stdout(Stdio::null()).spawn().unwrap());
    let zpid = zombie.0.id();
    let zstart = lock::proc_start(zpid).unwrap().unwrap();
    wait_state(zpid, 'Z');
    let mut live = KillOnDrop(
        locks
            .cmd()
            .args(["sim", "--powercube", "pty-slcan"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let lpid = live.0.id();
    let lstart = lock::proc_start(lpid).unwrap().unwrap();
    for (pid, start) in [(zpid, zstart), (lpid, lstart + 1)] {
        std::fs::write(locks.file_of(link), lock_of(pid, start).to_text()).unwrap();
        let r = locks.run(&["--link", link, "halt", "--all"]);
        assert_eq!(r.code, 3, "{}", r.stderr);
        assert!(r.stderr.contains(&format!("its lock names PID {pid}, which has exited")), "{}", r.stderr);
        assert!(r.stderr.contains("nothing was signalled") && !r.stderr.contains("SIGTERM"), "{}", r.stderr);
        assert!(r.stdout.is_empty(), "{}", r.stdout);
    }
    assert!(live.0.try_wait().unwrap().is_none(), "the live axisctl {lpid} was signalled");
    assert_eq!(proc_state(zpid), Some('Z'), "the zombie is still there, unreaped");
    assert!(zombie.0.wait().unwrap().success());
}

/// Someone else made `$TMPDIR/axisctl-UID` first: open to all, or a
/// symlink. The holder's lock goes to a private directory beside it (said
/// once on stderr), and `halt --all` still finds and stops the holder.
/// Without `AXISCTL_LOCK_DIR` and `XDG_RUNTIME_DIR`, with a `TMPDIR` of the
/// test's own, so the real `/tmp` is left alone.
#[test]
fn a_planted_temporary_lock_directory_never_silences_the_lock() {
    // SAFETY: getuid cannot fail.
    let uid = unsafe { libc::getuid() };
    for planted_as in ["open to all", "symlink"] {
        let root = tempfile::tempdir().unwrap();
        let tmp = root.path().join("tmp");
        std::fs::create_dir(&tmp).unwrap();
        let planted = tmp.join(format!("axisctl-{uid}"));
        let elsewhere = root.path().join("elsewhere");
        std::fs::create_dir(&elsewhere).unwrap();
        std::fs::set_permissions(&elsewhere, std::fs::Permissions::from_mode(0o700)).unwrap();
        match planted_as {
            "open to all" => {
                std::fs::create_dir(&planted).unwrap();
                std::fs::set_permissions(&planted, std::fs::Permissions::from_mode(0o777)).unwrap();
            }
            _ => std::os::unix::fs::symlink(&elsewhere, &planted).unwrap(),
        }
        let locks = Locks::shell(None, &tmp);
        let s = Sim::start(&["--powercube", "pty-slcan"], 1);
        let link = s.link("powercube");
        let holder = Holding::start(&locks, &ramp_args(link), "SetMotion");
        let pid = holder.pid();
        let h = locks.run(&["--link", link, "halt", "--all"]);
        assert_eq!(h.code, 0, "{planted_as}: {}", h.stderr);
        assert!(h.stdout.contains(&format!("was held by axisctl PID {pid} (")), "{}", h.stdout);
        let (code, stderr) = holder.end(10);
        assert_eq!(code, Some(143), "{stderr}");
        let told = format!("axisctl: lock directory {} is not used (", planted.display());
        assert_eq!(stderr.matches(&told).count(), 1, "{planted_as}: said once: {stderr}");
        assert!(stderr.contains(&format!("lock files go to {}/axisctl-{uid}-", tmp.display())), "{stderr}");
        assert!(cube_stands(&locks, link), "module 3 still moving");
        assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 0, "a lock went through the symlink");
        if planted_as == "open to all" {
            assert_eq!(std::fs::read_dir(&planted).unwrap().count(), 0, "a lock went to the planted directory");
        }
    }
}

/// A holder started with `XDG_RUNTIME_DIR` is halted from a shell without
/// it (su, cron), and the other way round.
#[test]
fn a_halt_finds_the_holder_with_or_without_xdg_runtime_dir() {
    let root = tempfile::tempdir().unwrap();
    let (xdg, tmp) = (root.path().join("xdg"), root.path().join("tmp"));
    for d in [&xdg, &tmp] {
        std::fs::create_dir(d).unwrap();
    }
    let with = Locks::shell(Some(&xdg), &tmp);
    let without = Locks::shell(None, &tmp);
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    for (holds, halts) in [(&with, &without), (&without, &with)] {
        let reset = holds.run(&["--link", link, "reset", "-m", "3"]);
        assert_eq!(reset.code, 0, "{}", reset.stderr);
        let holder = Holding::start(holds, &ramp_args(link), "SetMotion");
        let pid = holder.pid();
        let h = halts.run(&["--link", link, "halt", "--all"]);
        assert_eq!(h.code, 0, "{}", h.stderr);
        assert!(h.stdout.contains(&format!("was held by axisctl PID {pid} (")), "{}", h.stdout);
        assert_eq!(holder.end(10).0, Some(143));
        assert!(cube_stands(halts, link), "module 3 still moving");
    }
}

/// `halt --all` while a loop of `state` opens and closes the port: each
/// halt meets the port busy with its lock not written yet, removed already,
/// or naming a `state` that is exiting, and tries again within its 5 s.
/// None is refused. `AXISCTL_TEST_HALT_RUNS` sets the count (20 here).
#[test]
fn halt_all_against_a_state_loop_is_never_refused() {
    let n = runs("AXISCTL_TEST_HALT_RUNS", 20);
    let locks = Arc::new(Locks::new());
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube").to_string();
    let stop = Arc::new(AtomicBool::new(false));
    let states = Arc::new(AtomicUsize::new(0));
    let looping = {
        let (locks, link, stop, states) = (Arc::clone(&locks), link.clone(), Arc::clone(&stop), Arc::clone(&states));
        std::thread::spawn(move || {
            while !stop.load(Ordering::SeqCst) {
                let state = locks
                    .cmd()
                    .args(["--link", &link, "state", "-m", "3"])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn();
                let _ = wait_output(state.unwrap(), 20, &["state"]);
                states.fetch_add(1, Ordering::SeqCst);
            }
        })
    };
    let deadline = Instant::now() + Duration::from_secs(10);
    while states.load(Ordering::SeqCst) < 3 {
        assert!(Instant::now() < deadline, "the state loop does not run");
        std::thread::sleep(Duration::from_millis(10));
    }
    let (mut refused, mut took_over) = (Vec::new(), 0);
    // At least `n` halts, and on until one has met the port busy (the race
    // this is about), at most ten times as many.
    let mut i = 0;
    while (i < n || took_over == 0) && i < 10 * n {
        i += 1;
        let h = locks.run(&["--link", &link, "halt", "--all"]);
        if h.code != 0 {
            refused.push(format!("run {i}: exit {}: {}", h.code, h.stderr.trim()));
        } else if h.stdout.contains("was held by axisctl PID") {
            took_over += 1;
        }
    }
    stop.store(true, Ordering::SeqCst);
    looping.join().unwrap();
    let states = states.load(Ordering::SeqCst);
    eprintln!("{i} halt --all against {states} state runs: {} refused, {took_over} took the port over", refused.len());
    assert!(refused.is_empty(), "{} of {i} refused:\n{}", refused.len(), refused.join("\n"));
    assert!(took_over > 0, "no halt met the port busy: the loop did not race");
}

/// Two emergency halts at once while a `--wait` holds the port: both go
/// out and exit 0 (the later one waits for the earlier one, an emergency
/// halt, to let go instead of signalling it), the holder halts.
/// `AXISCTL_TEST_TWO_HALT_TRIALS` sets the trials (3 here).
#[test]
fn two_halts_at_once_both_succeed() {
    let locks = Locks::new();
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    for trial in 0..runs("AXISCTL_TEST_TWO_HALT_TRIALS", 3) {
        let reset = locks.run(&["--link", link, "reset", "-m", "3"]);
        assert_eq!(reset.code, 0, "{}", reset.stderr);
        let holder = Holding::start(&locks, &ramp_args(link), "SetMotion");
        let spawn = |args: &[&str]| {
            locks.cmd().args(["--link", link]).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap()
        };
        let (a, b) = (spawn(&["halt", "--all"]), spawn(&["halt", "-m", "3"]));
        for (name, child) in [("halt --all", a), ("halt -m 3", b)] {
            let out = wait_output(child, 20, &[name]);
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(0), "trial {trial}, {name}: {stderr}");
        }
        let (code, stderr) = holder.end(10);
        assert_eq!(code, Some(143), "trial {trial}: {stderr}");
        assert!(cube_stands(&locks, link), "trial {trial}: module 3 still moving");
    }
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
