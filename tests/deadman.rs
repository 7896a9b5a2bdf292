//! The dead-man backstop through the real binary against `axisctl sim`
//! serving PowerCube modules on an slcan pty: a waited motion keeps the
//! module watchdog refreshed (the broadcast `100#0700` in `--log`), so a
//! process killed mid-motion leaves the module halted by its watchdog, and a
//! motion that ends by itself leaves no COMM_ERROR behind.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::{bin, run, wait_bounded, Run};

/// `axisctl sim --powercube WHERE` at `chrt -f 30` where the system allows
/// it (as `scripts/watchdog-jitter.sh` runs it): the simulator stands in
/// for the modules' own controllers, which no load on the host delays; a
/// simulator starved by a busy test machine would see refreshes late that
/// were sent on time. Stopped on drop.
struct Sim {
    child: Child,
    link: String,
}

impl Sim {
    fn start(args: &[&str], _links: usize) -> Self {
        let fifo = Command::new("chrt").args(["-f", "30", "true"]).status().is_ok_and(|s| s.success());
        let mut cmd = if fifo {
            let mut c = Command::new("chrt");
            c.args(["-f", "30", env!("CARGO_BIN_EXE_axisctl")]);
            c
        } else {
            Command::new(env!("CARGO_BIN_EXE_axisctl"))
        };
        cmd.env_remove("AXISCTL_LINK").env("NO_COLOR", "1").env("AXISCTL_TIMEOUT", "400");
        let mut child = cmd.arg("sim").args(args).stdout(Stdio::piped()).spawn().expect("start axisctl sim");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
        let v: serde_json::Value = serde_json::from_str(&line).expect("sim prints JSON lines");
        Self { child, link: v["link"].as_str().unwrap().to_string() }
    }

    fn link(&self, _family: &str) -> &str {
        &self.link
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        unsafe {
            libc::kill(self.child.id() as i32, libc::SIGTERM);
        }
        let _ = self.child.wait();
    }
}

const COMM_ERROR: u64 = 0x20;
const HALTED: u64 = 0x4;
const MOTION: u64 = 0x800;
const WATCHDOG_ENABLE: u64 = 0x0100_0000;

/// When each watchdog refresh went out.
fn refreshes(log: &Path) -> Vec<f64> {
    common::logged_frames(log).into_iter().filter(|(_, f)| f == "100#0700").map(|(t, _)| t).collect()
}

/// Whether the bench rather than the tool was too slow during `log`: the
/// simulated modules answer within a millisecond or two, so an answer more
/// than 25 ms after the request it answers means the pty between them (or
/// the simulator) was starved by the
/// load on the host (its kernel side runs at ordinary priority, whatever
/// the two processes run at). The refreshes it carried then reached the
/// simulated module late as well, and its watchdog tripped on them.
fn bench_starved(log: &Path) -> bool {
    let mut asked: Option<f64> = None;
    for (t, f) in common::logged_frames(log) {
        if f.starts_with("0C") || f.starts_with("0E") {
            asked.get_or_insert(t);
        } else if f.starts_with("0A") && asked.take().is_some_and(|a| t - a > 0.025) {
            return true;
        }
    }
    false
}

/// A module that tripped (`tripped`) during an attempt on an overloaded
/// host: the tool was not run for 50 ms or more (a gap of that size between
/// two refreshes in `log`; the refresh cadence itself is tested on virtual
/// time, `device::powercube::deadman::tests`), or the bench was starved.
/// Such an attempt proves nothing either way and is run again. A trip with
/// every refresh in time on a bench answering in time fails the test.
fn spoiled(log: &Path, tripped: bool, what: &str) -> Result<(), String> {
    if !tripped {
        return Ok(());
    }
    let sent = refreshes(log);
    assert!(!sent.is_empty(), "{what}: the module tripped and no refresh was sent");
    let gap = common::max_gap(&sent);
    if gap >= 0.050 {
        return Err(format!("{what}: the tool was not run for {:.1} ms (an overloaded host)", gap * 1e3));
    }
    assert!(bench_starved(log), "{what}: the module tripped, refreshed in time, on a bench answering in time");
    Err(format!("{what}: the module tripped on a starved bench (longest refresh gap sent {:.1} ms)", gap * 1e3))
}

/// The tests of this file one at a time: each runs a simulator at real-time
/// priority and a tool that raises its own, which on a small machine would
/// otherwise take turns starving each other.
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// Runs `attempt` (each on a new simulator) until one is not spoiled by an
/// overloaded host; at most 8 times.
fn attempts<T>(mut attempt: impl FnMut() -> Result<T, String>) -> T {
    let _serial = one_at_a_time();
    let mut spoilt = Vec::new();
    for _ in 0..8 {
        match attempt() {
            Ok(t) => return t,
            Err(e) => {
                eprintln!("run again: {e}");
                spoilt.push(e);
            }
        }
    }
    panic!("every attempt ran on an overloaded host: {spoilt:?}");
}

fn ok(r: Run) -> serde_json::Value {
    assert_eq!(r.code, 0, "{}", r.stderr);
    r.json()
}

fn state(link: &str) -> u64 {
    ok(run(&["--link", link, "--json", "state", "-m", "3"]))["state"]["raw"].as_u64().unwrap()
}

fn act_pos(link: &str) -> f64 {
    let v = ok(run(&["--link", link, "--json", "get-param", "-m", "3", "ActPos"]));
    v["params"]["ActPos"]["value"].as_f64().unwrap_or_else(|| panic!("{v}"))
}

fn config(link: &str) -> u64 {
    ok(run(&["--link", link, "--json", "get-config", "-m", "3"]))["config"]["raw"].as_u64().unwrap()
}

/// `move-ramp --wait --deadman` killed with SIGKILL while the module
/// cruises at 0.2 rad/s: nothing halts it but its watchdog, which the dead
/// process no longer refreshes. A second process finds COMM_ERROR and
/// HALTED and the position no longer changing; the instant it stopped is
/// worked out from the positions the module reported (its last ActPos
/// answer before the kill, the position it stands at, and the speed) and
/// must lie within 100 ms of the kill.
#[test]
fn sigkill_mid_motion_leaves_the_module_halted_by_its_watchdog() {
    attempts(sigkill_mid_motion);
}

fn sigkill_mid_motion() -> Result<(), String> {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube").to_string();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let vel = 0.2;
    let mut child = bin()
        .args(["--link", &link, "--log", log.to_str().unwrap(), "move-ramp", "-m", "3", "3.0", "--vel", "0.2"])
        .args(["--acc", "3", "--wait", "--deadman"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Moving at full speed (the ramp up lasts 67 ms): ActPos past 0.1 rad.
    let deadline = Instant::now() + Duration::from_secs(30);
    while !common::logged_positions_of_module_3(&log).iter().any(|(_, p)| *p > 0.1) {
        if let Some(st) = child.try_wait().unwrap() {
            spoiled(&log, st.code() == Some(5), "before the kill")?;
            panic!("the move ended before the kill: {st}");
        }
        assert!(Instant::now() < deadline, "never saw module 3 move: {:?}", common::logged_frames(&log));
        std::thread::sleep(Duration::from_millis(5));
    }
    unsafe {
        libc::kill(child.id() as i32, libc::SIGKILL);
    }
    let killed = SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64();
    let ended = wait_bounded(child, 15, &["move-ramp"]);
    if ended.signal.is_none() {
        // It ended by itself just before the kill.
        spoiled(&log, ended.code == 5, "just before the kill")?;
    }
    assert_eq!(ended.signal, Some(libc::SIGKILL), "exit {}", ended.code);

    // The module trips 50 ms after the last refresh, which may still be
    // ahead when the first read arrives.
    let deadline = Instant::now() + Duration::from_secs(5);
    let raw = loop {
        let raw = state(&link);
        if raw & COMM_ERROR != 0 || Instant::now() > deadline {
            break raw;
        }
    };
    assert_eq!(raw & (COMM_ERROR | HALTED | MOTION), COMM_ERROR | HALTED, "state {raw:#x}");
    let stood = act_pos(&link);
    let again = act_pos(&link);
    assert_eq!(stood, again, "the module still moves");

    let refreshed = refreshes(&log);
    let (t_pos, p) = *common::logged_positions_of_module_3(&log).last().unwrap();
    let stopped = t_pos + (stood - f64::from(p)) / vel;
    let last_refresh = *refreshed.last().unwrap();
    eprintln!(
        "refreshes {} (longest gap {:.1} ms); SIGKILL {:.1} ms after the last refresh; module stopped {:.1} ms \
         after the SIGKILL, {:.1} ms after the last refresh",
        refreshed.len(),
        common::max_gap(&refreshed) * 1e3,
        (killed - last_refresh) * 1e3,
        (stopped - killed) * 1e3,
        (stopped - last_refresh) * 1e3
    );
    if stopped - killed > 0.100 && bench_starved(&log) {
        return Err(format!("stopped {:.1} ms after the kill, on a starved bench", (stopped - killed) * 1e3));
    }
    assert!(stopped - killed <= 0.100, "stopped {:.1} ms after the kill", (stopped - killed) * 1e3);
    assert!(stood < 1.0, "it went on for seconds: stands at {stood}");
    // The watchdog stays on: it was the only thing left to stop the module.
    assert_ne!(config(&link) & WATCHDOG_ENABLE, 0);
    Ok(())
}

/// A waited move with the watchdog switched on for it ends by itself with
/// exit 0 and no COMM_ERROR: the wait refreshed it, at most 50 ms apart.
/// Afterwards the watchdog is off again, as it was found, so the module
/// does not trip once refreshes stop.
#[test]
fn a_waited_move_with_the_watchdog_on_ends_without_comm_error_and_leaves_it_off() {
    attempts(waited_move);
}

fn waited_move() -> Result<(), String> {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    assert_eq!(config(link) & WATCHDOG_ENABLE, 0);
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let r = run(&["--link", link, "--log", log.to_str().unwrap(), "--json", "move-ramp", "-m", "3", "0.5"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let before = refreshes(&log).len();
    assert_eq!(before, 0, "no refresh for a motion that is not waited for");
    let r = run(&[
        "--link",
        link,
        "--log",
        log.to_str().unwrap(),
        "--trace",
        "--json",
        "move-ramp",
        "-m",
        "3",
        "-0.5",
        "--vel",
        "1",
        "--wait",
        "--deadman",
    ]);
    spoiled(&log, r.code == 5 && r.stderr.contains("STATE_COMM_ERROR"), "the waited move")?;
    let stderr = r.stderr.clone();
    let doc = ok(r);
    assert_eq!(doc["done"], true, "{doc}");
    let raw = doc["state"]["raw"].as_u64().unwrap();
    assert_eq!(raw & COMM_ERROR, 0, "state at the end {raw:#x}");
    assert!(stderr.contains("watchdog refresh every 20 ms from here"), "{stderr}");
    let refreshed = refreshes(&log);
    let gap = common::max_gap(&refreshed);
    eprintln!("{} refreshes, longest gap {:.1} ms", refreshed.len(), gap * 1e3);
    assert!(refreshed.len() >= 20, "{} refreshes over a 1 s ramp", refreshed.len());
    assert!(gap < 0.050, "longest gap between refreshes {:.1} ms", gap * 1e3);
    assert_eq!(config(link) & WATCHDOG_ENABLE, 0, "switched off again");
    // Well past the watchdog's 50 ms since the last refresh: no trip.
    let last = *refreshed.last().unwrap();
    let now = || SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64();
    if now() < last + 0.2 {
        std::thread::sleep(Duration::from_secs_f64(last + 0.2 - now()));
    }
    assert_eq!(state(link) & (COMM_ERROR | HALTED), 0);
    Ok(())
}

/// `home --wait --deadman`: the same backstop for homing.
#[test]
fn home_wait_with_the_deadman_refreshes_until_homed_and_switches_it_off() {
    attempts(home_wait);
}

fn home_wait() -> Result<(), String> {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let r = run(&["--link", link, "--log", log.to_str().unwrap(), "--json", "home", "-m", "3", "--wait", "--deadman"]);
    spoiled(&log, r.code == 5 && r.stderr.contains("STATE_COMM_ERROR"), "the waited homing")?;
    let doc = ok(r);
    assert_eq!(doc["state"]["raw"].as_u64().unwrap() & COMM_ERROR, 0, "{doc}");
    let refreshed = refreshes(&log);
    assert!(refreshed.len() >= 40, "homing takes about 1.7 s: {} refreshes", refreshed.len());
    assert!(common::max_gap(&refreshed) < 0.050, "longest gap {:.1} ms", common::max_gap(&refreshed) * 1e3);
    assert_eq!(config(link) & WATCHDOG_ENABLE, 0, "switched off again");
    Ok(())
}

/// `move-ramp --sync --wait --deadman` on two modules in sync mode.
#[test]
fn a_synchronized_waited_move_with_the_deadman_switches_both_watchdogs_and_back() {
    attempts(synchronized_move);
}

fn synchronized_move() -> Result<(), String> {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    for m in ["3", "5"] {
        let r = run(&["--link", link, "set-config", "-m", m, "+sync-motion"]);
        assert_eq!(r.code, 0, "{}", r.stderr);
    }
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let args = ["--link", link, "--log", log.to_str().unwrap(), "--json", "move-ramp", "-m", "3,5", "--sync"];
    let r = run(&[&args[..], &["0.5", "-0.5", "--wait", "--deadman"]].concat());
    spoiled(&log, r.code == 5 && r.stderr.contains("STATE_COMM_ERROR"), "the synchronized move")?;
    let doc = ok(r);
    for d in doc["devices"].as_array().unwrap() {
        assert_eq!(d["state"]["raw"].as_u64().unwrap() & COMM_ERROR, 0, "{d}");
    }
    // Both toggles in one burst, then the refreshes.
    let sent: Vec<String> = common::logged_frames(&log).into_iter().map(|(_, f)| f).collect();
    let first_refresh = sent.iter().position(|f| f == "100#0700").expect("refreshed");
    let toggles: Vec<usize> =
        sent.iter().enumerate().filter(|(_, f)| *f == "0E3#07" || *f == "0E5#07").map(|(i, _)| i).collect();
    assert_eq!(toggles.len(), 2, "one 0x07 each, never again: {sent:?}");
    assert!(toggles.iter().all(|i| *i < first_refresh), "{sent:?}");
    assert!(common::max_gap(&refreshes(&log)) < 0.050);
    for m in ["3", "5"] {
        let c = ok(run(&["--link", link, "--json", "get-config", "-m", m]))["config"]["raw"].as_u64().unwrap();
        assert_eq!(c & WATCHDOG_ENABLE, 0, "module {m} switched off again");
    }
    Ok(())
}

/// `--deadman` needs a wait (clap) and a CAN link; refused with exit 2
/// before anything is sent.
#[test]
fn deadman_without_wait_or_on_rs232_is_refused_before_sending() {
    let _serial = one_at_a_time();
    let r = run(&["--link", "sim", "move-ramp", "-m", "3", "0.5", "--deadman"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("--wait"), "{}", r.stderr);
    let s = Sim::start(&["--powercube", "pty-serial"], 1);
    let link = s.link("powercube");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let r =
        run(&["--link", link, "--log", log.to_str().unwrap(), "move-ramp", "-m", "3", "0.5", "--wait", "--deadman"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("--deadman: the watchdog is a CAN feature"), "{}", r.stderr);
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(!text.contains(" tx "), "sent: {text}");
}

/// Ctrl-Z (here SIGSTOP, which cannot be caught either) freezes the waiting
/// process: its refreshes stop, so the watchdog halts the module. Resumed,
/// the wait finds COMM_ERROR and ends with exit 5, and the watchdog it
/// switched on is switched off again.
#[test]
fn a_stopped_wait_leaves_the_module_halted_and_ends_with_exit_5_when_resumed() {
    attempts(stopped_wait);
}

fn stopped_wait() -> Result<(), String> {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube").to_string();
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let mut child = bin()
        .args(["--link", &link, "--log", log.to_str().unwrap(), "move-ramp", "-m", "3", "3.0", "--vel", "0.2"])
        .args(["--wait", "--deadman"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    while !common::logged_positions_of_module_3(&log).iter().any(|(_, p)| *p > 0.1) {
        if let Some(st) = child.try_wait().unwrap() {
            spoiled(&log, st.code() == Some(5), "before the stop")?;
            panic!("the move ended before the stop: {st}");
        }
        assert!(Instant::now() < deadline, "never saw module 3 move");
        std::thread::sleep(Duration::from_millis(5));
    }
    let pid = child.id() as i32;
    unsafe {
        libc::kill(pid, libc::SIGSTOP);
    }
    // The stopped process holds the port: the log shows the refreshes end,
    // and the watchdog trips 50 ms after the last one. Resumed only once
    // that is well past.
    let sent = || refreshes(&log).len();
    let mut seen = sent();
    let mut quiet_since = Instant::now();
    while quiet_since.elapsed() < Duration::from_millis(300) {
        assert!(Instant::now() < deadline + Duration::from_secs(10), "refreshes never stopped");
        std::thread::sleep(Duration::from_millis(10));
        if sent() != seen {
            seen = sent();
            quiet_since = Instant::now();
        }
    }
    unsafe {
        libc::kill(pid, libc::SIGCONT);
    }
    let ended = wait_bounded(child, 30, &["move-ramp"]);
    assert_eq!(ended.code, 5, "{}", ended.stderr);
    assert!(ended.stderr.contains("STATE_COMM_ERROR"), "{}", ended.stderr);
    assert_eq!(config(&link) & WATCHDOG_ENABLE, 0, "switched off again");
    let raw = state(&link);
    assert_eq!(raw & (COMM_ERROR | MOTION), COMM_ERROR, "halted by the watchdog: {raw:#x}");
    Ok(())
}

/// Without `--deadman`, a wait refreshes a watchdog that is on already:
/// `watchdog on` and a waited `move-ramp` in one batch (one process, so the
/// watchdog switched online is kept alive from the start of the move). The
/// move ends with exit 0 and no COMM_ERROR; the watchdog is left on, so
/// once the batch is over nothing refreshes it and the module trips.
#[test]
fn a_wait_refreshes_a_watchdog_that_is_on_and_leaves_it_on() {
    attempts(auto_refresh);
}

fn auto_refresh() -> Result<(), String> {
    let s = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = s.link("powercube");
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let lines = "watchdog on -m 3\nmove-ramp -m 3 0.5 --wait\n";
    let r = common::run_with_stdin(&["--link", link, "--log", log.to_str().unwrap(), "batch"], lines);
    let sent = common::logged_frames(&log);
    let online = sent.iter().find(|(_, f)| f == "0E3#07").expect("0x07 sent").0;
    let first = refreshes(&log).first().copied();
    if r.code == 5 && first.is_some_and(|t| t - online >= 0.050) {
        // Between the two lines nothing refreshes: a host too slow to get
        // from the one to the other within 50 ms tripped the module first.
        return Err(format!("the move's first refresh came {:?} s after 0x07", first.map(|t| t - online)));
    }
    spoiled(&log, r.code == 5, "the waited move")?;
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
    assert!(r.stdout.contains("move-ramp done"), "{}", r.stdout);
    let refreshed = refreshes(&log);
    assert!(refreshed.len() >= 20, "{} refreshes", refreshed.len());
    assert!(common::max_gap(&refreshed) < 0.050);
    assert_ne!(config(link) & WATCHDOG_ENABLE, 0, "left on");
    let deadline = Instant::now() + Duration::from_secs(5);
    while state(link) & COMM_ERROR == 0 {
        assert!(Instant::now() < deadline, "the watchdog left on never tripped");
    }
    Ok(())
}
