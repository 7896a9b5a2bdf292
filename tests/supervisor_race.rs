//! The race harness of the motion supervisor: for each family, a `--wait`
//! motion against a served simulator whose answers are sometimes late, and
//! at a random instant (before the motion frame, between the frame and its
//! acknowledge, during the wait) one of:
//! - SIGINT, SIGTERM, SIGHUP or SIGQUIT;
//! - an output that fails: stdout on `/dev/full`, the `--trace` pipe closed
//!   by its reader, or a `--log` file that hits a file size limit (a full
//!   disk) after a random number of bytes.
//!
//! After every run the device must stand still (or never have moved). The
//! exit code must be the signal's (128 + its number), or the process died of
//! the signal before anything moved, or the motion had ended (exit 0) before
//! the signal came; an output failure exits 1.
//!
//! Every signalled run writes `--log`, whose lines carry wall-clock
//! timestamps: the time from the signal (taken on the same clock just before
//! kill(2)) to the first halt frame in the log is what a signal costs the
//! moving axis; the harness reports its median and worst per family.
//!
//! `AXISCTL_RACE_RUNS` sets the runs per family (default 20, what CI runs;
//! `scripts/race.sh` runs 200), `AXISCTL_RACE_SEED` the seed,
//! `AXISCTL_RACE_LANES` how many simulators per family share them (default
//! 2), `AXISCTL_RACE_ONLY` one family's name to race it alone, and
//! `AXISCTL_BIN` the binary under test (`scripts/race.sh` runs a copy, so a
//! rebuild meanwhile changes nothing).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::Sim;

const SIGNALS: [i32; 4] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT];

/// A small deterministic generator: a seed replays the same instants.
struct Rng(u64);

impl Rng {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }
}

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// The binary under test: `AXISCTL_BIN`, or the one cargo built.
fn bin() -> Command {
    match std::env::var_os("AXISCTL_BIN") {
        Some(path) => {
            let mut c = Command::new(path);
            c.env_remove("AXISCTL_LINK").env("NO_COLOR", "1").env("AXISCTL_TIMEOUT", "400");
            c
        }
        None => common::bin(),
    }
}

fn quiet(args: &[&str]) -> (i32, String) {
    let out = bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into())
}

/// What one family needs: how to prepare, move and tell it stands.
struct Family {
    name: &'static str,
    sim: &'static [&'static str],
    prepare: &'static [&'static [&'static str]],
    moves: [&'static [&'static str]; 2],
    stands: fn(&str) -> bool,
    after: &'static [&'static [&'static str]],
    /// What the motion frame and the halt frame look like in a `--log` line.
    motion_frame: &'static str,
    halt_frame: &'static str,
    /// The signal or the pipe's end comes within this long of the start.
    window_ms: u64,
}

fn cube_stands(link: &str) -> bool {
    let (code, out) = quiet(&["--link", link, "--timeout", "2000", "--json", "state", "-m", "3"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_default();
    code == 0 && v["state"]["raw"].as_u64().is_some_and(|raw| raw & 0x800 == 0)
}

fn pac_stands(link: &str) -> bool {
    let (code, out) = quiet(&["--link", link, "--timeout", "600", "--json", "pac-axis", "2"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_default();
    code == 0 && v["axis_status"].as_u64().is_some_and(|s| s != 1)
}

fn cdios_stands(link: &str) -> bool {
    // A long timeout: a late answer (the simulator delays 30 % of them)
    // must not be taken for a device that does not answer, nor a failed
    // read for a moving motor.
    let (code, out) = quiet(&["--link", link, "--timeout", "2000", "--json", "cdios-status", "-m", "0"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_default();
    let flags = v["state"]["flags"].to_string();
    code == 0 && v["state"]["flags"].is_array() && !flags.contains("GOTO_ACTIVE") && !flags.contains("RUNNING")
}

const FAMILIES: [Family; 3] = [
    Family {
        name: "powercube",
        sim: &["--powercube", "pty-slcan", "--fault", "delay=200ms@0.3"],
        prepare: &[],
        moves: [
            &["--timeout", "2000", "move-ramp", "-m", "3", "2.0", "--vel", "0.2", "--force", "--wait"],
            &["--timeout", "2000", "move-ramp", "-m", "3", "0.0", "--vel", "0.2", "--force", "--wait"],
        ],
        stands: cube_stands,
        after: &[&["--timeout", "2000", "reset", "-m", "3"]],
        // SetMotion (0x0B) and Halt (0x02) to module 3 (0x0E0 + 3).
        motion_frame: " 0E3#0B",
        halt_frame: " 0E3#02",
        window_ms: 900,
    },
    Family {
        name: "pac",
        sim: &["--pac", "pty-serial", "--fault", "delay=200ms@0.3"],
        prepare: &[&["--timeout", "2000", "pac-online"], &["--timeout", "2000", "pac-no-ref", "2"]],
        moves: [
            // A session first waits one answer timeout for a quiet line:
            // a short timeout lets signals land after the motion frame too.
            &["--timeout", "600", "pac-move", "2", "900", "--force", "--wait"],
            &["--timeout", "600", "pac-move", "2", "100", "--force", "--wait"],
        ],
        stands: pac_stands,
        after: &[],
        // SOH STX "0A94" (move) and "0A93" (stop the axis).
        motion_frame: "tx 01 02 30 41 39 34",
        halt_frame: "tx 01 02 30 41 39 33",
        window_ms: 1500,
    },
    Family {
        name: "cdios",
        sim: &["--cdios", "pty-slcan", "--fault", "delay=200ms@0.3"],
        prepare: &[],
        moves: [
            &["--timeout", "2000", "cdios-goto", "-m", "0", "1000000", "--wait"],
            &["--timeout", "2000", "cdios-goto", "-m", "0", "0", "--wait"],
        ],
        stands: cdios_stands,
        after: &[&["--timeout", "2000", "cdios-enable", "-m", "0"]],
        // Goto (0x23) and Stop (0x25) to node 1 (0x200 + 1).
        motion_frame: " 201#23",
        halt_frame: " 201#25",
        window_ms: 900,
    },
];

/// What ends a run early.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Hit {
    Signal(i32),
    /// stdout is /dev/full.
    FullStdout,
    /// The reader of `--trace` (on stderr) goes away.
    ClosedTrace,
    /// The `--log` file may not grow beyond this many bytes.
    FullLog(u64),
}

impl Hit {
    fn pick(rng: &mut Rng) -> Self {
        match rng.below(7) {
            i @ 0..=3 => Self::Signal(SIGNALS[i as usize]),
            4 => Self::FullStdout,
            5 => Self::ClosedTrace,
            _ => Self::FullLog(200 + rng.below(1300)),
        }
    }
}

#[derive(Debug, Default)]
struct Tally {
    runs: u64,
    signalled: u64,
    output_failures: u64,
    moving_after_exit: u64,
    wrong_exit: Vec<String>,
    died_of_signal: u64,
    finished_first: u64,
    /// Signalled runs that ended on a lost motion acknowledge (exit 4).
    ack_lost: u64,
    /// Signal to the first halt frame in `--log`, for the runs whose motion
    /// frame had gone out before the signal.
    to_halt: Vec<Duration>,
    /// The same for the runs whose motion frame went out after the signal
    /// (the signal came while the link was being opened or read): the
    /// motion is sent, then halted.
    to_halt_sent_late: Vec<Duration>,
    /// Signalled runs that ended with the signal's code and no motion frame
    /// in `--log`: the signal came during the checks, so nothing was sent.
    unsent: u64,
    worst_exit: Duration,
}

impl Tally {
    fn merge(&mut self, o: Tally) {
        self.runs += o.runs;
        self.signalled += o.signalled;
        self.output_failures += o.output_failures;
        self.moving_after_exit += o.moving_after_exit;
        self.wrong_exit.extend(o.wrong_exit);
        self.died_of_signal += o.died_of_signal;
        self.finished_first += o.finished_first;
        self.ack_lost += o.ack_lost;
        self.to_halt.extend(o.to_halt);
        self.to_halt_sent_late.extend(o.to_halt_sent_late);
        self.unsent += o.unsent;
        self.worst_exit = self.worst_exit.max(o.worst_exit);
    }

    fn summary(&self, name: &str) -> String {
        let spread = |v: &[Duration]| {
            let mut sorted = v.to_vec();
            sorted.sort();
            let ms = |d: &Duration| format!("{:.1} ms", d.as_secs_f64() * 1e3);
            match (sorted.get(sorted.len() / 2), sorted.last()) {
                (Some(median), Some(worst)) => {
                    format!("{} halts, median {}, worst {}", sorted.len(), ms(median), ms(worst))
                }
                _ => "no halts".into(),
            }
        };
        format!(
            "race {name}: {} runs ({} signals, {} output failures), {} moving after exit, {} wrong exits; \
             signal to halt frame: {}; signal before the motion frame, halted after it: {}; \
             stopped before the motion frame, nothing sent: {}; worst signal to exit {:.1} ms; {} died of the signal before the motion, {} ended before the hit, \
             {} lost a motion acknowledge meanwhile",
            self.runs,
            self.signalled,
            self.output_failures,
            self.moving_after_exit,
            self.wrong_exit.len(),
            spread(&self.to_halt),
            spread(&self.to_halt_sent_late),
            self.unsent,
            self.worst_exit.as_secs_f64() * 1e3,
            self.died_of_signal,
            self.finished_first,
            self.ack_lost,
        )
    }
}

/// Starts one run's client with its outputs wired for `hit`.
fn spawn(args: &[String], hit: Hit, log: &Path) -> Child {
    use std::os::unix::process::CommandExt;
    let mut cmd = bin();
    if hit == Hit::ClosedTrace {
        cmd.arg("--trace");
    }
    cmd.arg("--log").arg(log).args(args).stderr(Stdio::piped());
    match hit {
        Hit::FullStdout => cmd.stdout(std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap()),
        _ => cmd.stdout(Stdio::null()),
    };
    if let Hit::FullLog(bytes) = hit {
        // SAFETY: only async-signal-safe calls between fork and exec.
        unsafe {
            cmd.pre_exec(move || {
                // Writes past the limit fail with EFBIG instead of killing the process.
                libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
                let lim = libc::rlimit { rlim_cur: bytes, rlim_max: bytes };
                libc::setrlimit(libc::RLIMIT_FSIZE, &lim);
                Ok(())
            });
        }
    }
    cmd.spawn().unwrap()
}

fn wait_bounded(child: &mut Child, what: &str) -> ExitStatus {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        if let Some(st) = child.try_wait().unwrap() {
            return st;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("{what} hung");
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The wall-clock instant of the first line of `log` at or after `since`
/// that contains `frame`.
fn first_frame_after(log: &Path, frame: &str, since: SystemTime) -> Option<SystemTime> {
    let text = std::fs::read_to_string(log).ok()?;
    text.lines().filter(|l| l.contains(frame)).find_map(|l| {
        let stamp = l.strip_prefix('(')?.split(')').next()?;
        let (secs, micros) = stamp.split_once('.')?;
        let at = UNIX_EPOCH + Duration::new(secs.parse().ok()?, micros.parse::<u32>().ok()? * 1000);
        (at >= since).then_some(at)
    })
}

fn race(f: &Family, runs: u64, seed: u64, dir: &Path) -> Tally {
    let dir = dir.join(format!("{}-{seed}", f.name));
    std::fs::create_dir_all(&dir).unwrap();
    let sim = Sim::start(f.sim, 1);
    let link = sim.link(f.name).to_string();
    let with_link = |args: &[&str]| {
        let mut all = vec!["--link", link.as_str()];
        all.extend_from_slice(args);
        all.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    for args in f.prepare.iter().chain(f.after) {
        let (code, _) = quiet(&with_link(args).iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(code, 0, "{}: {args:?}", f.name);
    }
    let mut rng = Rng(seed | 1);
    let mut t = Tally::default();
    for i in 0..runs {
        let hit = Hit::pick(&mut rng);
        let after = Duration::from_millis(rng.below(f.window_ms));
        let args = with_link(f.moves[(i % 2) as usize]);
        let log: PathBuf = dir.join(format!("{i}.log"));
        let mut child = spawn(&args, hit, &log);
        let mut trace = child.stderr.take();
        let what = format!("{}: run {i} ({hit:?} after {after:?})", f.name);
        let mut signalled_at = None;
        let mut t0 = Instant::now();
        match hit {
            Hit::Signal(sig) => {
                std::thread::sleep(after);
                t0 = Instant::now();
                signalled_at = Some(SystemTime::now());
                unsafe { libc::kill(child.id() as i32, sig) };
            }
            Hit::ClosedTrace => {
                std::thread::sleep(after);
                drop(trace.take());
            }
            Hit::FullStdout | Hit::FullLog(_) => {}
        }
        let status = wait_bounded(&mut child, &what);
        let mut err = String::new();
        if let Some(mut e) = trace.take() {
            let _ = std::io::Read::read_to_string(&mut e, &mut err);
        }
        t.runs += 1;
        use std::os::unix::process::ExitStatusExt;
        let expected = match (hit, status.code(), status.signal()) {
            (Hit::Signal(sig), Some(c), None) if c == 128 + sig => {
                t.worst_exit = t.worst_exit.max(t0.elapsed());
                true
            }
            (Hit::Signal(sig), None, Some(s)) if s == sig => {
                t.died_of_signal += 1;
                true
            }
            (_, Some(1), None) => !matches!(hit, Hit::Signal(_)),
            // The motion's acknowledge was lost (on a loaded machine the late
            // answers can outlast --timeout): that failure, reported with the
            // halt, ends the run rather than the signal kept meanwhile.
            (Hit::Signal(_), Some(4), None) if err.contains("may have been moving") => {
                t.ack_lost += 1;
                true
            }
            // The motion ended before the signal or the failure came (exit 5:
            // the Cdios motor ran into its end switch).
            (_, Some(0 | 5), None) => {
                t.finished_first += 1;
                true
            }
            _ => false,
        };
        if matches!(hit, Hit::Signal(_)) {
            t.signalled += 1;
        } else {
            t.output_failures += 1;
        }
        if !expected {
            t.wrong_exit.push(format!("{what}: {:?} {:?} {err}", status.code(), status.signal()));
        }
        if let (Some(since), Hit::Signal(sig)) = (signalled_at, hit) {
            let unsent = status.code() == Some(128 + sig)
                && first_frame_after(&log, f.motion_frame, SystemTime::UNIX_EPOCH).is_none();
            t.unsent += u64::from(unsent);
            if let Some(at) = first_frame_after(&log, f.halt_frame, since) {
                let took = at.duration_since(since).unwrap_or_default();
                match first_frame_after(&log, f.motion_frame, since) {
                    Some(_) => t.to_halt_sent_late.push(took),
                    None => t.to_halt.push(took),
                }
            }
        }
        let _ = std::fs::remove_file(&log);
        if !(f.stands)(&link) {
            t.moving_after_exit += 1;
            t.wrong_exit.push(format!("{what}: the device still moves"));
        }
        for a in f.after {
            let _ = quiet(&with_link(a).iter().map(String::as_str).collect::<Vec<_>>());
        }
    }
    t
}

#[test]
fn signals_and_output_failures_at_random_instants_never_leave_a_device_moving() {
    let runs = env_u64("AXISCTL_RACE_RUNS", 20);
    let seed = env_u64("AXISCTL_RACE_SEED", 0x5eed);
    let dir = std::env::temp_dir().join(format!("axisctl-race-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Each family's runs are shared among lanes, each with a simulator of
    // its own: a run mostly waits, so lanes cut the wall time.
    let lanes = env_u64("AXISCTL_RACE_LANES", 2).max(1);
    let only = std::env::var("AXISCTL_RACE_ONLY").ok();
    let handles: Vec<_> = (0..FAMILIES.len())
        .filter(|i| only.as_deref().is_none_or(|name| name == FAMILIES[*i].name))
        .map(|i| {
            let lane_handles: Vec<_> = (0..lanes)
                .map(|lane| {
                    let dir = dir.clone();
                    let share = runs / lanes + u64::from(lane < runs % lanes);
                    let seed = seed + 1000 * lane + i as u64;
                    std::thread::spawn(move || race(&FAMILIES[i], share, seed, &dir))
                })
                .collect();
            (FAMILIES[i].name, lane_handles)
        })
        .collect();
    let mut failed = Vec::new();
    for (name, lane_handles) in handles {
        let mut t = Tally::default();
        for h in lane_handles {
            t.merge(h.join().unwrap());
        }
        eprintln!("{}", t.summary(name));
        for w in &t.wrong_exit {
            eprintln!("  wrong: {}", w.trim_end().replace('\n', "\n    "));
        }
        if t.moving_after_exit > 0 || !t.wrong_exit.is_empty() {
            failed.push(format!("{name}: {t:?}"));
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failed.is_empty(), "{failed:#?}");
}

// ---- PA-CONTROL answers later than the timeout (issue 22) ----
//
// The simulator delays 30 % of its answers by 200 ms, twice the clients'
// answer timeout: every such answer arrives after its exchange gave up. A
// signal comes at a random instant of `pac-move --wait`, `pac-ref --wait`
// or `record -- pac-move`; after each run the harness asks the simulator
// (with a timeout the delay never outlasts) whether the axis moves, whether
// the controller is still busy with a start-and-wait command (a fresh
// command is refused, QUIT 0x14), and whether a final report the run
// printed ("in position" at P, referenced at P) is what the axis shows.
// `AXISCTL_RACE_LATE_RUNS` sets the signalled runs per command (default 4,
// what CI runs; `scripts/race.sh` runs 120).

/// One command raced on the delayed simulator.
struct LateRace {
    name: &'static str,
    /// The run's arguments after `--link L`, for run `i`.
    args: fn(u64) -> Vec<&'static str>,
    /// Brings the axis where the run starts (run `i`), with a timeout the
    /// delay never outlasts.
    prepare: fn(u64) -> Vec<&'static [&'static str]>,
    window_ms: u64,
}

const LATE_TIMEOUT: &str = "97";

const LATE_RACES: [LateRace; 3] = [
    LateRace {
        name: "pac-move --wait",
        // No --force: the traverse area is read before the move, as in the issue.
        args: |i| {
            vec!["--timeout", LATE_TIMEOUT, "--json", "pac-move", "2", if i % 2 == 0 { "900" } else { "100" }, "--wait"]
        },
        prepare: |_| vec![],
        window_ms: 2000,
    },
    LateRace {
        name: "pac-ref --wait",
        args: |_| vec!["--timeout", LATE_TIMEOUT, "--json", "pac-ref", "2", "--wait"],
        // 40 AE from the reference switch: a drive of about a second.
        prepare: |_| vec![&["--timeout", "2000", "pac-move", "2", "40", "--force", "--wait"]],
        window_ms: 1500,
    },
    LateRace {
        name: "record -- pac-move",
        args: |i| {
            let target = if i % 2 == 0 { "900" } else { "100" };
            vec![
                "--timeout",
                LATE_TIMEOUT,
                "--json",
                "record",
                "--axis",
                "2",
                "position",
                "--for",
                "1s",
                "--",
                "pac-move",
                "2",
                target,
            ]
        },
        prepare: |_| vec![],
        window_ms: 2000,
    },
];

/// What the simulator says about axis 2, asked with a timeout the delay
/// never outlasts: `Err` with the refusal text when the controller is busy.
fn pac_axis_2(link: &str) -> Result<(u64, f64), String> {
    let out = bin()
        .args(["--link", link, "--timeout", "600", "--json", "pac-axis", "2"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    match (v["axis_status"].as_u64(), v["position"]["value"].as_f64()) {
        (Some(s), Some(p)) if out.status.success() => Ok((s, p)),
        _ => Err(format!("{:?}: {}", out.status.code(), String::from_utf8_lossy(&out.stderr).trim())),
    }
}

#[derive(Debug, Default)]
struct LateTally {
    runs: u64,
    moving_after_exit: u64,
    wrong_in_position: u64,
    busy_after_exit: u64,
    /// Exit code (or `-N` for death by signal N) and how often.
    exits: std::collections::BTreeMap<i32, u64>,
    late_answers_dropped: u64,
    wrong: Vec<String>,
}

impl LateTally {
    fn summary(&self, name: &str) -> String {
        let exits: Vec<String> = self.exits.iter().map(|(c, n)| format!("{n} x {c}")).collect();
        format!(
            "race late {name}: {} signalled runs, {} moving after exit, {} wrong final reports, {} controllers left busy; \
             {} late answers dropped; exits: {}",
            self.runs,
            self.moving_after_exit,
            self.wrong_in_position,
            self.busy_after_exit,
            self.late_answers_dropped,
            exits.join(", "),
        )
    }
}

fn race_late(r: &LateRace, runs: u64, seed: u64) -> LateTally {
    let sim = Sim::start(&["--pac", "pty-serial", "--fault", "delay=200ms@0.3", "--fault-seed", &seed.to_string()], 1);
    let link = sim.link("pac").to_string();
    let quiet_on = |args: &[&str]| {
        let mut all = vec!["--link", link.as_str()];
        all.extend_from_slice(args);
        quiet(&all)
    };
    for args in [&["--timeout", "2000", "pac-online"][..], &["--timeout", "2000", "pac-no-ref", "2"]] {
        assert_eq!(quiet_on(args).0, 0, "{}: {args:?}", r.name);
    }
    let mut rng = Rng(seed | 1);
    let mut t = LateTally::default();
    for i in 0..runs {
        if let Some(args) = (r.prepare)(i).into_iter().find(|args| quiet_on(args).0 != 0) {
            // Left busy or moving by the run before (counted there).
            t.wrong.push(format!("{}: run {i}: {args:?} failed", r.name));
            quiet_on(&["--timeout", "2000", "pac-stop-axis", "2", "--wait"]);
            continue;
        }
        let sig = SIGNALS[rng.below(4) as usize];
        let after = Duration::from_millis(rng.below(r.window_ms));
        let mut cmd = bin();
        cmd.arg("--link").arg(&link).arg("--trace").args((r.args)(i));
        let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
        let what = format!("{}: run {i} (signal {sig} after {after:?})", r.name);
        std::thread::sleep(after);
        unsafe { libc::kill(child.id() as i32, sig) };
        let (mut out, mut err) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
        let reader = std::thread::spawn(move || {
            let mut s = String::new();
            let _ = std::io::Read::read_to_string(&mut err, &mut s);
            s
        });
        let mut stdout = String::new();
        let _ = std::io::Read::read_to_string(&mut out, &mut stdout);
        let status = wait_bounded(&mut child, &what);
        let trace = reader.join().unwrap();
        t.runs += 1;
        use std::os::unix::process::ExitStatusExt;
        let code = status.code().unwrap_or_else(|| -status.signal().unwrap_or(0));
        *t.exits.entry(code).or_default() += 1;
        t.late_answers_dropped += trace.matches("dropped a late answer").count() as u64;
        let fail = |t: &mut LateTally, why: String| {
            let tail: Vec<&str> = trace.lines().rev().take(12).collect();
            let tail: Vec<&str> = tail.into_iter().rev().collect();
            t.wrong.push(format!("{what}: {why}\n  exit {code}, stdout {}\n  {}", stdout.trim(), tail.join("\n  ")));
        };
        let now = match pac_axis_2(&link) {
            Ok(v) => Some(v),
            Err(e) if e.contains("0x14") => {
                t.busy_after_exit += 1;
                fail(&mut t, format!("the controller is left busy: {e}"));
                // Free it for the next run: a stop ends the wait (polled).
                quiet_on(&["--timeout", "2000", "pac-stop-axis", "2", "--wait"]);
                pac_axis_2(&link).ok()
            }
            Err(e) => panic!("{what}: cannot read axis 2 afterwards: {e}"),
        };
        let Some((status_now, position_now)) = now else { continue };
        if status_now == 1 {
            t.moving_after_exit += 1;
            fail(&mut t, format!("the axis still moves (at {position_now})"));
            quiet_on(&["--timeout", "2000", "pac-stop-axis", "2", "--wait"]);
        }
        // A final report (exit 0) must be what the axis shows: it stands,
        // where the report says (pac-move: at the target, in position).
        if code == 0 && !r.name.starts_with("record") {
            let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap_or_default();
            let said = v["position"]["value"].as_f64();
            let in_position = v["axis_status"].as_u64().is_none_or(|s| s == 0);
            let at_target =
                v["target"]["value"].as_f64().is_none_or(|target| said.is_some_and(|p| (p - target).abs() < 1e-3));
            let agrees = said.is_some_and(|p| (p - position_now).abs() < 1e-3);
            if !(in_position && at_target && agrees && status_now == 0) {
                t.wrong_in_position += 1;
                fail(&mut t, format!("reported {stdout:?}, the axis shows status {status_now} at {position_now}"));
            }
        }
    }
    t
}

#[test]
fn late_pac_answers_never_leave_an_axis_moving_a_controller_busy_or_a_wrong_report() {
    let runs = env_u64("AXISCTL_RACE_LATE_RUNS", 4);
    let seed = env_u64("AXISCTL_RACE_SEED", 0x5eed);
    let only = std::env::var("AXISCTL_RACE_ONLY").ok();
    if only.as_deref().is_some_and(|o| o != "pac") {
        return;
    }
    let handles: Vec<_> = (0..LATE_RACES.len())
        .map(|i| std::thread::spawn(move || race_late(&LATE_RACES[i], runs, seed + 100 * i as u64)))
        .collect();
    let mut failed = Vec::new();
    for (i, h) in handles.into_iter().enumerate() {
        let t = h.join().unwrap();
        let name = LATE_RACES[i].name;
        eprintln!("{}", t.summary(name));
        for w in &t.wrong {
            eprintln!("  wrong: {}", w.trim_end().replace('\n', "\n    "));
        }
        if !t.wrong.is_empty() {
            failed.push(format!("{name}: {} wrong", t.wrong.len()));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}
