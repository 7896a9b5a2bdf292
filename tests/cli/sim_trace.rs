//! `axisctl sim --trace` / `--log`: what the served links carry, decoded and
//! logged as the client's own `--trace` / `--log` show it, with the link and
//! the direction (the client's: `->` / `tx` what it sent).

use crate::common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use common::run;

/// `axisctl [global] sim [args]`, its stderr into a file; killed on drop.
struct Served {
    child: Child,
    links: Vec<(String, String)>,
    stderr: PathBuf,
    _dir: tempfile::TempDir,
}

impl Served {
    fn start(global: &[&str], args: &[&str], expect_links: usize) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let stderr = dir.path().join("sim.err");
        let mut child = common::bin()
            .args(global)
            .arg("sim")
            .args(args)
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&stderr).unwrap())
            .spawn()
            .unwrap();
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let links = (0..expect_links)
            .map(|_| {
                let v: serde_json::Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
                (v["family"].as_str().unwrap().to_string(), v["link"].as_str().unwrap().to_string())
            })
            .collect();
        Self { child, links, stderr, _dir: dir }
    }

    fn link(&self, family: &str) -> &str {
        &self.links.iter().find(|(f, _)| f == family).unwrap().1
    }

    /// The trace once it holds every line wanted (the simulator writes it
    /// from its own threads), or as it is after 10 s.
    fn trace_with(&self, wanted: &[&str]) -> String {
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            let text = std::fs::read_to_string(&self.stderr).unwrap_or_default();
            if wanted.iter().all(|w| text.lines().any(|l| l.starts_with(w))) || Instant::now() > deadline {
                return text;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn log_lines(path: &Path) -> Vec<String> {
    std::fs::read_to_string(path).unwrap_or_default().lines().map(str::to_string).collect()
}

/// The log lines without their timestamps.
fn untimed(lines: &[String]) -> Vec<String> {
    lines.iter().map(|l| l.split_once(") ").map_or(l.clone(), |(_, rest)| rest.to_string())).collect()
}

/// The bytes of the serial lines going `dir` (`tx` / `rx`), joined;
/// `iface`: the sim's lines name their line before the direction.
fn serial_bytes(lines: &[String], iface: Option<&str>, dir: &str) -> Vec<String> {
    let head = match iface {
        Some(i) => format!("{i} {dir} "),
        None => format!("{dir} "),
    };
    untimed(lines)
        .iter()
        .filter_map(|l| l.strip_prefix(&head))
        .flat_map(|hex| hex.split_whitespace().map(str::to_string).collect::<Vec<_>>())
        .collect()
}

#[test]
fn the_sims_trace_and_log_show_the_requests_and_answers_of_every_served_link() {
    let dir = tempfile::tempdir().unwrap();
    let sim_log = dir.path().join("sim.log");
    let sim = Served::start(&["--trace", "--log", sim_log.to_str().unwrap()], &[], 3);
    let (can, pac) = (sim.link("cdios").to_string(), sim.link("pac").to_string());
    assert_eq!(sim.link("powercube"), can, "PowerCube and Cdios share the slcan bus");

    let can_log = dir.path().join("can.log");
    let r = run(&["--link", &can, "--log", can_log.to_str().unwrap(), "cdios-status", "-m", "0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let r = run(&["--link", &can, "--log", can_log.to_str().unwrap(), "get-param", "-m", "3", "ActPos"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let pac_log = dir.path().join("pac.log");
    let r = run(&["--link", &pac, "--log", pac_log.to_str().unwrap(), "pac-state"]);
    assert_eq!(r.code, 0, "{}", r.stderr);

    let ask = format!("{can} -> 201#2600000000000000");
    let status = format!("{can} <- 181#2600000000");
    let get = format!("{can} -> 0C3#0A3C");
    let got = format!("{can} <- 0A3#0A3C");
    let state = format!("{pac} -> <SOH><STX>190B;0;0;0<ETX>");
    let state_ack = format!("{pac} <- <SOH><STX>0;");
    let trace = sim.trace_with(&[&ask, &status, &get, &got, &state, &state_ack]);
    for (want, decoded) in [
        (&ask, "read_status"),
        (&status, "read_status status1="),
        (&get, "GetExtended ActPos"),
        (&got, "ActPos = 0"),
        (&state, "190B get-state"),
        (&state_ack, "QUIT 0"),
    ] {
        let line = trace.lines().find(|l| l.starts_with(want.as_str()));
        assert!(line.is_some_and(|l| l.contains(decoded)), "{want} ... {decoded}:\n{trace}");
    }
    assert!(trace.contains(&format!("sim: --log names {can} slcan0")), "{trace}");
    assert!(trace.contains(&format!("sim: --log names {pac} serial0")), "{trace}");

    // The log: the client's lines, with the served link's name. CAN frames in
    // the same order, as `candump -l` lines of `slcan0`.
    let sim_lines = log_lines(&sim_log);
    let sim_can: Vec<String> = untimed(&sim_lines).into_iter().filter(|l| l.starts_with("slcan0 ")).collect();
    assert_eq!(sim_can, untimed(&log_lines(&can_log)), "{sim_lines:#?}");
    assert!(sim_can.iter().any(|l| l == "slcan0 201#2600000000000000"), "{sim_can:?}");
    assert!(sim_can.iter().any(|l| l.starts_with("slcan0 181#26")), "{sim_can:?}");
    // Serial: the bytes each way are the client's (chunks may be cut elsewhere).
    let client = log_lines(&pac_log);
    for dir in ["tx", "rx"] {
        let sim_bytes = serial_bytes(&sim_lines, Some("serial0"), dir);
        assert!(!sim_bytes.is_empty(), "{dir}: {sim_lines:#?}");
        assert_eq!(sim_bytes, serial_bytes(&client, None, dir), "{dir}");
    }
}

#[test]
fn the_sims_trace_decodes_powercube_rs232_both_ways() {
    let dir = tempfile::tempdir().unwrap();
    let sim_log = dir.path().join("sim.log");
    let sim = Served::start(&["--trace", "--log", sim_log.to_str().unwrap()], &["--powercube", "pty-serial"], 1);
    let link = sim.link("powercube").to_string();
    let r = run(&["--link", &link, "get-param", "-m", "3", "ActPos"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    // Manual: GetExtended (0Ah) ActPos (3Ch) to module 3, and its answer.
    let ask = format!("{link} -> 02 04 62 0a 3c ac 03 GetExtended ActPos to module 3");
    let answer = format!("{link} <- 02 08 66 0a 3c");
    let trace = sim.trace_with(&[&ask, &answer]);
    assert!(trace.lines().any(|l| l == ask), "{trace}");
    assert!(trace.lines().any(|l| l.starts_with(&answer) && l.ends_with("ActPos = 0 from module 3")), "{trace}");
    let lines = untimed(&log_lines(&sim_log));
    assert!(lines.iter().any(|l| l.starts_with("serial0 tx 02 04 62 0A 3C AC 03")), "{lines:?}");
    assert!(lines.iter().any(|l| l.starts_with("serial0 rx 02 08 66 0A 3C")), "{lines:?}");
    // A broadcast (module address 0) carries [cmd, param]: the modules carry
    // it out, and the trace names it as such, not as a malformed command.
    let r = run(&["--link", &link, "halt", "--all"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let halt = format!("{link} -> 02 04 10 82 10 82 00 08 03 Halt to all");
    let trace = sim.trace_with(&[&halt]);
    assert!(trace.lines().any(|l| l == halt), "{trace}");
}

/// Without `--trace` and `--log` the simulator says nothing about its traffic.
#[test]
fn without_trace_or_log_the_sim_is_quiet() {
    let sim = Served::start(&[], &["--cdios", "pty-slcan"], 1);
    let r = run(&["--link", sim.link("cdios"), "cdios-status", "-m", "0"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    std::thread::sleep(Duration::from_millis(200));
    let text = std::fs::read_to_string(&sim.stderr).unwrap();
    assert!(text.is_empty(), "{text}");
}
