//! The race harness of the motion supervisor: for each family, a `--wait`
//! motion against a served simulator whose answers are sometimes late, and
//! SIGINT, SIGTERM, SIGHUP or SIGQUIT at a random instant (before the motion
//! frame, between the frame and its acknowledge, during the wait). After
//! every run the device must stand still (or never have moved), and the
//! exit code must be the signal's (128 + its number), or the process died of
//! the signal before anything moved, or the motion had ended (exit 0) before
//! the signal came.
//!
//! `AXISCTL_RACE_RUNS` sets the runs per family (default 20, what CI runs;
//! `scripts/race.sh` runs 200), `AXISCTL_RACE_SEED` the seed.

mod common;

use std::process::Stdio;
use std::time::{Duration, Instant};

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

fn quiet(args: &[&str]) -> (i32, String) {
    let out = common::bin().args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).output().unwrap();
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
}

fn cube_stands(link: &str) -> bool {
    let (code, out) = quiet(&["--link", link, "--json", "state", "-m", "3"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_default();
    code == 0 && v["state"]["raw"].as_u64().is_some_and(|raw| raw & 0x800 == 0)
}

fn pac_stands(link: &str) -> bool {
    let (code, out) = quiet(&["--link", link, "--timeout", "1000", "--json", "pac-axis", "2"]);
    let v: serde_json::Value = serde_json::from_str(&out).unwrap_or_default();
    code == 0 && v["axis_status"].as_u64().is_some_and(|s| s != 1)
}

fn cdios_stands(link: &str) -> bool {
    let (code, out) = quiet(&["--link", link, "--json", "cdios-status", "-m", "0"]);
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
    },
    Family {
        name: "pac",
        sim: &["--pac", "pty-serial", "--fault", "delay=200ms@0.3"],
        prepare: &[&["--timeout", "2000", "pac-online"], &["--timeout", "2000", "pac-no-ref", "2"]],
        moves: [
            &["--timeout", "2000", "pac-move", "2", "900", "--force", "--wait"],
            &["--timeout", "2000", "pac-move", "2", "100", "--force", "--wait"],
        ],
        stands: pac_stands,
        after: &[],
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
    },
];

#[derive(Debug, Default)]
struct Tally {
    runs: u64,
    moving_after_exit: u64,
    wrong_exit: Vec<String>,
    died_of_signal: u64,
    finished_first: u64,
    worst_reaction: Duration,
}

fn race(f: &Family, runs: u64, seed: u64) -> Tally {
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
        let sig = SIGNALS[rng.below(4) as usize];
        let after = Duration::from_millis(rng.below(900));
        let args = with_link(f.moves[(i % 2) as usize]);
        let mut child = common::bin().args(&args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
        std::thread::sleep(after);
        let t0 = Instant::now();
        unsafe { libc::kill(child.id() as i32, sig) };
        let deadline = t0 + Duration::from_secs(15);
        let status = loop {
            if let Some(st) = child.try_wait().unwrap() {
                break st;
            }
            assert!(Instant::now() < deadline, "{}: run {i} hung after signal {sig}", f.name);
            std::thread::sleep(Duration::from_millis(2));
        };
        t.worst_reaction = t.worst_reaction.max(t0.elapsed());
        t.runs += 1;
        use std::os::unix::process::ExitStatusExt;
        match (status.code(), status.signal()) {
            (Some(c), None) if c == 128 + sig => {}
            (None, Some(s)) if s == sig => t.died_of_signal += 1,
            // The motion ended before the signal came (a short move).
            (Some(0), None) => t.finished_first += 1,
            other => {
                let mut err = String::new();
                let _ = std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err);
                t.wrong_exit.push(format!("run {i} signal {sig} after {after:?}: {other:?} {err}"));
            }
        }
        if !(f.stands)(&link) {
            t.moving_after_exit += 1;
        }
        for a in f.after {
            let _ = quiet(&with_link(a).iter().map(String::as_str).collect::<Vec<_>>());
        }
    }
    t
}

#[test]
fn signals_at_random_instants_never_leave_a_device_moving() {
    let runs = env_u64("AXISCTL_RACE_RUNS", 20);
    let seed = env_u64("AXISCTL_RACE_SEED", 0x5eed);
    let handles: Vec<_> = FAMILIES
        .iter()
        .enumerate()
        .map(|(i, _)| std::thread::spawn(move || (FAMILIES[i].name, race(&FAMILIES[i], runs, seed + i as u64))))
        .collect();
    let mut failed = Vec::new();
    for h in handles {
        let (name, t) = h.join().unwrap();
        eprintln!(
            "race {name}: {} runs, {} moving after exit, {} died of the signal before the motion, \
             {} done before the signal, {} wrong exits, worst signal-to-exit {:?}",
            t.runs,
            t.moving_after_exit,
            t.died_of_signal,
            t.finished_first,
            t.wrong_exit.len(),
            t.worst_reaction
        );
        if t.moving_after_exit > 0 || !t.wrong_exit.is_empty() {
            failed.push(format!("{name}: {t:?}"));
        }
    }
    assert!(failed.is_empty(), "{failed:#?}");
}
