//! Remote buses over socketcand: `axisctl sim --socketcand` serves the
//! simulated CAN bench as the daemon does, the real binary drives it over a
//! `socketcand:` link, python-can's socketcand client reads from it, and
//! daemons that refuse, close or talk nonsense end the command with exit 3,
//! never a hang. A connection cut during a waited PowerCube move leaves the
//! module to its watchdog (`--deadman`) or says it may still move.

use crate::common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::{bin, run, wait_bounded, Sim};

fn served() -> (Sim, String) {
    let sim = Sim::start(&["--socketcand", "127.0.0.1:0"], 2);
    let link = sim.link("powercube").to_string();
    assert_eq!(sim.link("cdios"), link, "one bus carries both CAN families");
    (sim, link)
}

fn ok(args: &[&str]) -> serde_json::Value {
    let r = run(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    r.json()
}

/// Done when: `sim --socketcand 127.0.0.1:0` prints a `socketcand:` link,
/// `scan` lists 3, 5 and 17 over it, `cdios-status` and `record` work, and
/// a `monitor` on a second connection sees the traffic of a third.
#[test]
fn the_served_bus_carries_every_can_command_and_several_clients() {
    let (_sim, link) = served();
    assert!(link.starts_with("socketcand:127.0.0.1:") && link.ends_with("/can0"), "{link}");
    let scan = ok(&["--link", &link, "--json", "scan"]);
    let ids: Vec<u64> = scan["devices"].as_array().unwrap().iter().map(|m| m["module"].as_u64().unwrap()).collect();
    assert_eq!(ids, [3, 5, 17], "{scan}");
    let status = ok(&["--link", &link, "--json", "cdios-status", "-m", "0"]);
    assert!(status.to_string().contains("READY_INPUT_ACTIVE"), "{status}");
    let r = run(&["--link", &link, "--json", "record", "-m", "17", "ActPos", "--count", "5"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.stdout.lines().count(), 5, "{}", r.stdout);

    // A monitor on its own connection sees what another client asks.
    let mut monitor = bin()
        .args(["--link", &link, "monitor", "--candump", "--id", "0C3", "--count", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    // Asked again until the monitor, connected at some point, has seen one.
    while monitor.try_wait().unwrap().is_none() {
        assert!(Instant::now() < deadline, "the monitor never saw module 3 asked");
        ok(&["--link", &link, "--json", "get-param", "-m", "3", "DefCubeVersion"]);
    }
    let ended = wait_bounded(monitor, 10, &["monitor"]);
    assert_eq!(ended.code, 0, "{}", ended.stderr);
    assert!(ended.stdout.contains("0C3#0A1D"), "{}", ended.stdout);
}

/// python-can's own socketcand interface, against the simulator's server:
/// module 3's DefCubeVersion and Cdios module 0's status, the answers
/// axisctl itself reads over the same link.
#[test]
fn python_cans_socketcand_client_reads_a_powercube_and_a_cdios() {
    let (_sim, link) = served();
    let rest = link.strip_prefix("socketcand:").unwrap();
    let (hostport, bus) = rest.split_once('/').unwrap();
    let (host, port) = hostport.rsplit_once(':').unwrap();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/socketcand_client.py");
    let out = Command::new("python3").args([script, host, port, bus]).output().expect("python3");
    assert!(
        out.status.success(),
        "python-can failed (pip install python-can):\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<String> = String::from_utf8_lossy(&out.stdout).lines().map(String::from).collect();
    let version = ok(&["--link", &link, "--json", "get-param", "-m", "3", "DefCubeVersion"]);
    let v = version["params"]["DefCubeVersion"]["value"].as_u64().unwrap() as u16;
    let [lo, hi] = v.to_le_bytes();
    assert_eq!(lines[0], format!("0A3#0A1D{lo:02X}{hi:02X}"), "{lines:?}");
    // status 4 = 0x90: READY_INPUT_ACTIVE and POSITION_NOT_INITIALIZED, as cdios-status reads it.
    assert_eq!(lines[1], "181#2600000000009000", "{lines:?}");
    let status = ok(&["--link", &link, "--json", "cdios-status", "-m", "0"]);
    assert!(status.to_string().contains("POSITION_NOT_INITIALIZED"), "{status}");
}

/// A port nobody listens on: exit 3 at once, the address and the cause named.
#[test]
fn a_refused_connection_exits_3_at_once() {
    let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let link = format!("socketcand:127.0.0.1:{port}/can0");
    let t0 = Instant::now();
    let r = run(&["--link", &link, "get-param", "-m", "3", "ActPos"]);
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(t0.elapsed() < Duration::from_secs(3), "{:?}", t0.elapsed());
    assert!(r.stderr.contains(&format!("127.0.0.1:{port}")) && r.stderr.contains("connection refused"), "{}", r.stderr);
}

#[test]
fn a_bus_the_daemon_does_not_serve_exits_3() {
    let (_sim, link) = served();
    let other = link.replace("/can0", "/can7");
    let r = run(&["--link", &other, "scan"]);
    assert_eq!(r.code, 3, "{}", r.stderr);
    assert!(r.stderr.contains("refused to open bus can7: could not open bus"), "{}", r.stderr);
}

/// A daemon of our own making: greets with `greeting`, opens any bus, and
/// on the first frame the client sends does `then` (close, or garbage).
fn fake_daemon(greeting: &'static [u8], then: Option<&'static [u8]>) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        let Ok((mut s, _)) = listener.accept() else { return };
        let _ = s.write_all(greeting);
        let mut seen = Vec::new();
        let mut buf = [0u8; 512];
        while let Ok(n @ 1..) = s.read(&mut buf) {
            seen.extend_from_slice(&buf[..n]);
            let text = String::from_utf8_lossy(&seen).into_owned();
            let Some(end) = text.find('>') else { continue };
            let msg = text[..=end].to_string();
            seen.drain(..=end);
            let reply: &[u8] = match msg.trim() {
                "< open can0 >" | "< rawmode >" => b"< ok >",
                "< echo >" => b"< echo >",
                _ => match then {
                    Some(bytes) => bytes,
                    None => return,
                },
            };
            let _ = s.write_all(reply);
        }
        // Held open until the client goes: a daemon that never speaks.
        let _ = s.read(&mut buf);
    });
    format!("socketcand:127.0.0.1:{port}/can0")
}

/// A daemon that closes, one that sends garbage, one that never greets:
/// each a clear message and exit 3 within seconds.
#[test]
fn a_daemon_that_closes_talks_nonsense_or_stays_silent_fails_the_command_with_exit_3() {
    for (greeting, then, says) in [
        (&b"< hi >"[..], None, "closed the connection"),
        (b"< hi >", Some(&b"\x00\x01not socketcand\r\n"[..]), "no socketcand message"),
        (b"", None, "did not answer the greeting"),
        (b"HTTP/1.1 400 Bad Request\r\n\r\n", None, "no socketcand message"),
    ] {
        let link = fake_daemon(greeting, then);
        let child = bin()
            .args(["--link", &link, "get-param", "-m", "3", "ActPos"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let ended = wait_bounded(child, 20, &["get-param over", &link]);
        assert_eq!(ended.code, 3, "{says}: {}", ended.stderr);
        assert!(ended.stderr.contains(says), "{says}: {}", ended.stderr);
    }
}

/// Between the tool and the simulated daemon: forwards both ways until
/// [`Proxy::cut`], which closes both connections, as a daemon that goes
/// away (or a network that drops) does.
struct Proxy {
    link: String,
    conns: std::sync::Arc<std::sync::Mutex<Vec<TcpStream>>>,
}

impl Proxy {
    fn start(target: &str) -> Self {
        let rest = target.strip_prefix("socketcand:").unwrap();
        let (hostport, bus) = rest.split_once('/').unwrap();
        let upstream = hostport.to_string();
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let link = format!("socketcand:{}/{bus}", listener.local_addr().unwrap());
        let conns: std::sync::Arc<std::sync::Mutex<Vec<TcpStream>>> = Default::default();
        let held = std::sync::Arc::clone(&conns);
        std::thread::spawn(move || {
            for client in listener.incoming() {
                let Ok(client) = client else { return };
                let server = TcpStream::connect(&upstream).unwrap();
                client.set_nodelay(true).unwrap();
                server.set_nodelay(true).unwrap();
                held.lock().unwrap().extend([client.try_clone().unwrap(), server.try_clone().unwrap()]);
                for (mut from, mut to) in [(client.try_clone().unwrap(), server.try_clone().unwrap()), (server, client)]
                {
                    std::thread::spawn(move || {
                        let mut buf = [0u8; 4096];
                        while let Ok(n @ 1..) = from.read(&mut buf) {
                            if to.write_all(&buf[..n]).is_err() {
                                break;
                            }
                        }
                        let _ = to.shutdown(Shutdown::Both);
                    });
                }
            }
        });
        Self { link, conns }
    }

    /// Closes every connection; the wall-clock instant, as `--log` stamps.
    fn cut(&self) -> f64 {
        for c in self.conns.lock().unwrap().iter() {
            let _ = c.shutdown(Shutdown::Both);
        }
        SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64()
    }
}

/// A network with `delay` each way: every chunk is forwarded that long
/// after it was read, in order.
fn slow_network(target: &str, delay: Duration) -> String {
    let rest = target.strip_prefix("socketcand:").unwrap();
    let (hostport, bus) = rest.split_once('/').unwrap();
    let upstream = hostport.to_string();
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let link = format!("socketcand:{}/{bus}", listener.local_addr().unwrap());
    std::thread::spawn(move || {
        for client in listener.incoming() {
            let Ok(client) = client else { return };
            let server = TcpStream::connect(&upstream).unwrap();
            for (mut from, mut to) in [(client.try_clone().unwrap(), server.try_clone().unwrap()), (server, client)] {
                let (tx, rx) = std::sync::mpsc::channel::<(Instant, Vec<u8>)>();
                std::thread::spawn(move || {
                    let mut buf = [0u8; 4096];
                    while let Ok(n @ 1..) = from.read(&mut buf) {
                        let _ = tx.send((Instant::now() + delay, buf[..n].to_vec()));
                    }
                });
                std::thread::spawn(move || {
                    for (due, bytes) in rx {
                        // The emulated wire's own time, not a wait for an event.
                        std::thread::sleep(due.saturating_duration_since(Instant::now()));
                        if to.write_all(&bytes).is_err() {
                            break;
                        }
                    }
                    let _ = to.shutdown(Shutdown::Both);
                });
            }
        }
    });
    link
}

/// 150 ms each way, three times the 100 ms answer timeout: the round trip
/// measured at the open is added to it, so the answers count; with the
/// allowance set to nothing (`?rtt=0`) the same read times out (exit 4).
#[test]
fn a_slow_network_is_not_a_silent_device() {
    let (_sim, link) = served();
    let slow = slow_network(&link, Duration::from_millis(150));
    let timeout_default = |args: &[&str]| {
        let mut cmd = bin();
        cmd.env_remove("AXISCTL_TIMEOUT").args(args).stdout(Stdio::piped()).stderr(Stdio::piped());
        wait_bounded(cmd.spawn().unwrap(), 30, args).run()
    };
    let r = timeout_default(&["--link", &slow, "--json", "get-param", "-m", "3", "DefCubeVersion"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["params"]["DefCubeVersion"]["value"].as_u64(), Some(17921));
    let fixed = format!("{slow}?rtt=0");
    let r = timeout_default(&["--link", &fixed, "--retries", "0", "get-param", "-m", "3", "DefCubeVersion"]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let fixed = format!("{slow}?rtt=400");
    let r = timeout_default(&["--link", &fixed, "get-param", "-m", "3", "DefCubeVersion"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
}

const COMM_ERROR: u64 = 0x20;
const HALTED: u64 = 0x4;
const MOTION: u64 = 0x800;

fn state(link: &str) -> u64 {
    ok(&["--link", link, "--json", "state", "-m", "3"])["state"]["raw"].as_u64().unwrap()
}

fn act_pos(link: &str) -> f64 {
    ok(&["--link", link, "--json", "get-param", "-m", "3", "ActPos"])["params"]["ActPos"]["value"].as_f64().unwrap()
}

/// A waited `move-ramp` of module 3 at 0.2 rad/s through a proxy, cut once
/// the module cruises: the tool's exit and stderr, the instant of the cut,
/// and the log. `Err` when the host was too loaded for the attempt to mean
/// anything (the tool not run for 50 ms between two refreshes).
struct Cut {
    code: i32,
    stderr: String,
    at: f64,
    log: tempfile::TempDir,
}

fn cut_during_move(sim_link: &str, deadman: bool) -> Result<Cut, String> {
    let proxy = Proxy::start(sim_link);
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("traffic.log");
    let mut args = vec!["--link", &proxy.link, "--log", log.to_str().unwrap(), "move-ramp", "-m", "3", "3.0"];
    args.extend(["--vel", "0.2", "--acc", "3", "--wait"]);
    if deadman {
        args.push("--deadman");
    }
    let mut child = bin().args(&args).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let deadline = Instant::now() + Duration::from_secs(30);
    // Cruising (the ramp up lasts 67 ms): ActPos past 0.1 rad.
    while !common::logged_positions_of_module_3(&log).iter().any(|(_, p)| *p > 0.1) {
        if child.try_wait().unwrap().is_some() {
            let mut err = String::new();
            child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
            return Err(format!("the move ended before the cut: {err}"));
        }
        assert!(Instant::now() < deadline, "never saw module 3 move: {:?}", common::logged_frames(&log));
        std::thread::yield_now();
    }
    let at = proxy.cut();
    let ended = wait_bounded(child, 20, &["move-ramp over a cut link"]);
    if deadman {
        let refreshes: Vec<f64> =
            common::logged_frames(&log).into_iter().filter(|(_, f)| f == "100#0700").map(|(t, _)| t).collect();
        if common::max_gap(&refreshes) >= 0.050 {
            return Err(format!("the tool was not run for {:.1} ms", common::max_gap(&refreshes) * 1e3));
        }
    }
    Ok(Cut { code: ended.code, stderr: ended.stderr, at, log: dir })
}

/// Up to five attempts of [`cut_during_move`], each on a simulator of its
/// own: a spoiled attempt can leave module 3 in error (its watchdog tripped
/// while the tool was not run), and a module in error refuses every move
/// after it. The simulator and link of the attempt that counted.
fn attempts(deadman: bool) -> (Sim, String, Cut) {
    let mut spoilt = Vec::new();
    for _ in 0..5 {
        let (sim, link) = served();
        match cut_during_move(&link, deadman) {
            Ok(c) => return (sim, link, c),
            Err(e) => {
                eprintln!("run again: {e}");
                spoilt.push(e);
            }
        }
    }
    panic!("every attempt spoiled by the load on the host: {spoilt:?}");
}

/// Done when: the server's connection closes during a waited move with
/// `--deadman`: no halt can be sent, the module's watchdog stops it, at
/// rest within 100 ms of the cut (worked out from its reported positions
/// and speed); the tool exits 3 naming the lost link and the backstop.
#[test]
fn a_connection_cut_mid_move_with_the_deadman_leaves_the_module_halted_by_its_watchdog() {
    let (_sim, link, cut) = attempts(true);
    eprintln!("{}", cut.stderr);
    assert_eq!(cut.code, 3, "{}", cut.stderr);
    assert!(cut.stderr.contains("closed the connection"), "{}", cut.stderr);
    assert!(cut.stderr.contains("its watchdog halts it"), "{}", cut.stderr);
    assert!(!cut.stderr.contains("MAY STILL MOVE"), "{}", cut.stderr);

    let deadline = Instant::now() + Duration::from_secs(5);
    let raw = loop {
        let raw = state(&link);
        if raw & COMM_ERROR != 0 || Instant::now() > deadline {
            break raw;
        }
    };
    assert_eq!(raw & (COMM_ERROR | HALTED | MOTION), COMM_ERROR | HALTED, "state {raw:#x}");
    let stood = act_pos(&link);
    assert_eq!(stood, act_pos(&link), "the module still moves");
    let (t_pos, p) = *common::logged_positions_of_module_3(&cut.log.path().join("traffic.log")).last().unwrap();
    let stopped = t_pos + (stood - f64::from(p)) / 0.2;
    eprintln!("module 3 at rest {:.1} ms after the cut", (stopped - cut.at) * 1e3);
    assert!(stopped - cut.at <= 0.100, "at rest {:.1} ms after the cut", (stopped - cut.at) * 1e3);
    assert!(stood < 1.0, "it went on for seconds: stands at {stood}");
}

/// Without the dead-man nothing can stop the module once the connection is
/// gone: the tool says so plainly, exits 3, and the module is indeed still
/// moving (halted here afterwards).
#[test]
fn a_connection_cut_mid_move_without_the_deadman_says_the_module_may_still_move() {
    let (_sim, link, cut) = attempts(false);
    eprintln!("{}", cut.stderr);
    assert_eq!(cut.code, 3, "{}", cut.stderr);
    assert!(cut.stderr.contains("THE MODULE MAY STILL MOVE"), "{}", cut.stderr);
    let raw = state(&link);
    assert_ne!(raw & MOTION, 0, "nothing stopped it: state {raw:#x}");
    assert_eq!(run(&["--link", &link, "halt", "-m", "3"]).code, 0);
}

/// The sim prints its link once per CAN family, as the other served links.
#[test]
fn the_announcement_is_one_json_line_per_family() {
    let mut child = bin().args(["sim", "--socketcand", "127.0.0.1:0"]).stdout(Stdio::piped()).spawn().unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let first: serde_json::Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    let second: serde_json::Value = serde_json::from_str(&lines.next().unwrap().unwrap()).unwrap();
    // The address taken: exit 3 naming it, nothing announced.
    let taken =
        first["link"].as_str().unwrap().strip_prefix("socketcand:").unwrap().trim_end_matches("/can0").to_string();
    let r = run(&["sim", "--socketcand", &taken]);
    assert_eq!((r.code, r.stdout.as_str()), (3, ""), "{}", r.stderr);
    assert!(r.stderr.contains(&taken), "{}", r.stderr);
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let ended = wait_bounded(child, 10, &["sim"]);
    assert_eq!(ended.code, 0);
    assert_eq!(first["family"], "powercube");
    assert_eq!(second["family"], "cdios");
    assert_eq!(first["link"], second["link"]);
    let r = run(&["sim", "--socketcand", "not-an-address"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("expected IP:PORT"), "{}", r.stderr);
}

/// The dashboard in a real terminal (tmux) on the served link: it finds the
/// PowerCube modules and the Cdios node, homes module 3 over the network
/// and sees it move, and quits back to the shell.
#[test]
fn the_dashboard_runs_over_a_socketcand_link() {
    let (_sim, link) = served();
    let t = common::tmux::Tmux::start("socketcand-dashboard", 100, 30, &[]);
    t.wait_for("READY$");
    t.keys(&[&format!("{} --link {link} dashboard", env!("CARGO_BIN_EXE_axisctl")), "Enter"]);
    let screen = t.wait_for("module 17");
    for want in ["PowerCube", "Cdios", "node 1 mod 1"] {
        assert!(screen.contains(want), "{want:?} missing:\n{screen}");
    }
    t.keys(&["h"]);
    t.wait_for("Home acknowledged");
    t.wait_for("moving");
    t.keys(&["q"]);
    t.wait_until("the normal screen after quitting", |_| t.display("#{alternate_on}") == "0");
    t.keys(&["echo exit=$?", "Enter"]);
    let screen = t.wait_for("exit=");
    assert!(screen.contains("exit=0"), "the dashboard exits 0:\n{screen}");
}

/// A batch and a bench file take the link as any other: the batch's lines
/// share one connection, and a bench file naming the remote bus and its
/// devices scans them by name.
#[test]
fn a_batch_and_a_bench_file_use_the_remote_bus() {
    let (_sim, link) = served();
    let r = common::run_with_stdin(
        &["--link", &link, "batch", "-"],
        "get-param -m 3 DefCubeVersion\ncdios-status -m 0\nstate -m 17\n",
    );
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("17921") && r.stdout.contains("READY_INPUT_ACTIVE"), "{}", r.stdout);
    let dir = tempfile::tempdir().unwrap();
    let bench = dir.path().join("remote.toml");
    std::fs::write(
        &bench,
        format!("[[link]]\nspec = \"{link}\"\ndevices = {{ shoulder = \"powercube:3\", gripper = \"cdios:1/0\" }}\n"),
    )
    .unwrap();
    let r = run(&["--bench", bench.to_str().unwrap(), "--json", "scan"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let text = r.stdout;
    assert!(text.contains("\"shoulder\"") && text.contains("\"gripper\""), "{text}");
}

/// Issue 24: the commissioning run works over a remote bus like over the
/// local ones: every planned check of every module passes, moves recorded
/// and halted over TCP.
#[test]
fn the_commissioning_run_passes_over_the_remote_bus() {
    let _busy = common::heavy::slot();
    let (_sim, link) = served();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("report");
    let r = common::run_served(&["--link", &link, "commission", "--out", out.to_str().unwrap(), "--yes"]);
    assert_eq!(r.code, 0, "{}\n{}", r.stdout, r.stderr);
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!((report["complete"].as_bool(), report["passed"].as_bool()), (Some(true), Some(true)), "{report}");
    let checks = report["checks"].as_array().unwrap();
    for m in ["powercube:3", "powercube:5", "powercube:17"] {
        for name in ["identity", "settings", "limits", "home", "move_forward", "move_back", "halt", "backup"] {
            let c = checks.iter().find(|c| c["device"] == m && c["check"] == name);
            assert_eq!(c.map(|c| c["status"].clone()), Some(serde_json::json!("pass")), "{m} {name}");
        }
    }
}

/// The monitor stamps a remote frame with the daemon's time, when its bus
/// received it, not when it crossed the network: a daemon of our own sends
/// one frame stamped 1000.5 s.
#[test]
fn the_monitor_shows_the_daemons_time_stamp() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        let Ok((mut s, _)) = listener.accept() else { return };
        let _ = s.write_all(b"< hi >");
        let (mut seen, mut buf, mut echoes) = (String::new(), [0u8; 512], 0);
        while let Ok(n @ 1..) = s.read(&mut buf) {
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
            while let Some(end) = seen.find('>') {
                let msg: String = seen.drain(..=end).collect();
                let reply: &[u8] = match msg.trim() {
                    "< echo >" => b"< echo >",
                    _ => b"< ok >",
                };
                let _ = s.write_all(reply);
                // Once the link has measured the round trip (its echoes), a frame.
                echoes += usize::from(msg.trim() == "< echo >");
                if echoes == 4 {
                    let _ = s.write_all(b"< frame 0A3 1000.500000 0A1D0146 >");
                }
            }
        }
    });
    let link = format!("socketcand:127.0.0.1:{port}/can0");
    let r = run(&["--link", &link, "--json", "monitor", "--count", "1", "--for", "20"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let line: serde_json::Value = serde_json::from_str(r.stdout.lines().next().unwrap_or("")).unwrap();
    assert_eq!((line["frame"].as_str(), line["timestamp"].as_f64()), (Some("0A3#0A1D0146"), Some(1000.5)), "{line}");
}
