//! The bench through the real binary: several `--link`s, a bench file
//! (`--bench`, `AXISCTL_BENCH`, `axisctl.toml`), a per-family command finding
//! its family's link, and the whole-bench `scan` and `halt --all` against
//! `axisctl sim` served on ptys (PowerCube and Cdios share the slcan pty, the
//! PA-CONTROL has its own). Every process runs under a deadline; waits are
//! on device states, never fixed sleeps.

use crate::common;

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use common::bench::bench_file;
use common::{Run, Sim};

fn run_in(dir: Option<&Path>, env: &[(&str, &str)], args: &[&str]) -> Run {
    let mut c = common::bin();
    c.args(args).envs(env.iter().copied()).stdout(Stdio::piped()).stderr(Stdio::piped());
    if let Some(d) = dir {
        c.current_dir(d);
    }
    common::wait_bounded(c.spawn().unwrap(), 60, args).run()
}

fn run(args: &[&str]) -> Run {
    run_in(None, &[], args)
}

/// The document follows the published schema (each device object carries
/// its family's envelope).
fn valid(doc: &serde_json::Value) {
    if let Some(e) = common::schema_errors(&common::schema("document"), doc) {
        panic!("{doc}\nbreaks the schema:\n{e}");
    }
}

fn ok(r: &Run, what: &str) {
    assert_eq!(r.code, 0, "{what}: {}{}", r.stdout, r.stderr);
}

/// The served bench: (the slcan link of PowerCube and Cdios, the PA-CONTROL's serial link).
fn served() -> (Sim, String, String) {
    let sim = Sim::start(&[], 3);
    let (can, serial) = (sim.link("powercube").to_string(), sim.link("pac").to_string());
    assert_eq!(sim.link("cdios"), can, "one CAN pty");
    (sim, can, serial)
}

/// Polls `test` on a state read until it holds, for up to 20 s.
fn until(what: &str, mut test: impl FnMut() -> Option<String>) {
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let Some(why_not) = test() else { return };
        assert!(Instant::now() < deadline, "{what}: {why_not}");
        std::thread::yield_now();
    }
}

/// Whether each family's moved device moves: PowerCube module 5, Cdios
/// node 1 module 0, PA-CONTROL axis 2; each `Some(state)` while it moves.
fn moving(links: &[&str]) -> [Option<String>; 3] {
    let read = |args: &[&str]| {
        let mut all: Vec<&str> = links.iter().flat_map(|l| ["--link", l]).collect();
        all.push("--json");
        all.extend(args);
        let r = run(&all);
        ok(&r, &args.join(" "));
        r.json()
    };
    let cube = read(&["state", "-m", "5"])["state"]["flags"].to_string();
    let motor = read(&["cdios-status", "-m", "0"])["state"]["flags"].to_string();
    let axis = read(&["pac-axis", "2"]);
    [
        cube.contains("STATE_MOTION").then_some(cube),
        motor.contains("RUNNING").then_some(motor),
        (axis["axis_status"] == 1).then(|| axis["axis_status_text"].to_string()),
    ]
}

/// A move on each family: PowerCube `move-vel`, Cdios `cdios-start`,
/// PA-CONTROL `pac-move` in online mode; returned once all three move.
fn start_moves(links: &[&str]) {
    let mut prefix: Vec<&str> = links.iter().flat_map(|l| ["--link", l]).collect();
    let state = run(&[&prefix[..], &["--json", "pac-state"]].concat());
    let online = state.json()["mode"] == "online";
    for args in [
        &["reset", "-m", "5"][..],
        &["move-vel", "-m", "5", "0.1"],
        &["cdios-enable", "-m", "0"],
        &["cdios-start", "-m", "0", "--option", "to-speed", "--speed", "1200"],
        if online { &["pac-state"] } else { &["pac-online"] },
        &["pac-no-ref", "2"],
        &["pac-move", "2", "9000"],
    ] {
        let n = prefix.len();
        prefix.extend(args);
        ok(&run(&prefix), &args.join(" "));
        prefix.truncate(n);
    }
    until("every family moves", || {
        let m = moving(links);
        m.iter().any(Option::is_none).then(|| format!("{m:?}"))
    });
}

fn halt_all_stops_every_family(links: &[&str], bench: Option<&str>) {
    start_moves(links);
    let mut args: Vec<&str> = match bench {
        Some(file) => vec!["--bench", file],
        None => links.iter().flat_map(|l| ["--link", l]).collect(),
    };
    args.extend(["--json", "halt", "--all"]);
    let r = run(&args);
    ok(&r, "halt --all");
    let doc = r.json();
    valid(&doc);
    let steps = doc["steps"].as_array().unwrap();
    let said =
        |address: &str| steps.iter().find(|s| s["address"] == address).map(|s| (s["ok"].clone(), s["result"].clone()));
    assert_eq!(said("powercube:5"), Some((true.into(), "halted".into())), "{doc}");
    assert_eq!(said("cdios:1/0"), Some((true.into(), "fast stop".into())), "{doc}");
    assert_eq!(said("pac:2"), Some((true.into(), "stopped (0A9A)".into())), "{doc}");
    assert!(steps.iter().any(|s| s["address"].is_null() && s["result"] == "broadcast Halt sent"), "{doc}");
    until("every device at rest after halt --all", || {
        let m = moving(links);
        m.iter().any(Option::is_some).then(|| format!("{m:?}"))
    });
}

/// One `halt --all` over two links stops a move on each family, and says
/// what it stopped; the same with a bench file naming both links.
#[test]
fn halt_all_over_the_bench_leaves_every_device_at_rest() {
    let (_sim, can, serial) = served();
    halt_all_stops_every_family(&[&can, &serial], None);
    let dir = tempfile::tempdir().unwrap();
    let file = bench_file(dir.path(), &format!("[[link]]\nspec = \"{can}\"\n[[link]]\nspec = \"{serial}\"\n"));
    halt_all_stops_every_family(&[&can, &serial], Some(&file));
}

/// The human report names each device stopped and its link.
#[test]
fn halt_all_says_what_it_stopped() {
    let (_sim, can, serial) = served();
    let r = run(&["--link", &can, "--link", &serial, "halt", "--all"]);
    ok(&r, "halt --all");
    for row in ["powercube (all)", "powercube:3 ", "cdios:1/0 ", "cdios:1/1 "] {
        assert!(r.stdout.lines().any(|l| l.starts_with(row) && l.contains(&can)), "{row}: {}", r.stdout);
    }
    assert!(r.stdout.lines().any(|l| l.starts_with("pac") && l.contains(&serial)), "{}", r.stdout);
}

/// The whole-bench scan lists every device of every family with its
/// address, name and link; an expected device that does not answer is
/// listed as missing, and the scan exits 4.
#[test]
fn scan_lists_the_whole_bench_and_the_missing() {
    let (_sim, can, serial) = served();
    let dir = tempfile::tempdir().unwrap();
    let text = format!(
        "[[link]]\nspec = \"{can}\"\nfamilies = [\"powercube\", \"cdios\"]\n\
         devices = {{ shoulder = \"powercube:3\", gripper = \"cdios:1/0\" }}\n\
         [[link]]\nspec = \"{serial}\"\ndevices = {{ slide = \"pac:2\" }}\n"
    );
    let file = bench_file(dir.path(), &text);
    let r = run(&["--bench", &file, "--json", "scan"]);
    ok(&r, "scan");
    let doc = r.json();
    valid(&doc);
    let got: Vec<(String, String, String)> = doc["devices"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| (d["address"].as_str().unwrap().into(), d["name"].to_string(), d["link"].as_str().unwrap().into()))
        .collect();
    let want = |a: &str, n: &str, l: &str| (a.to_string(), n.to_string(), l.to_string());
    assert_eq!(
        got,
        [
            want("powercube:3", "\"shoulder\"", &can),
            want("powercube:5", "null", &can),
            want("powercube:17", "null", &can),
            want("cdios:1/0", "\"gripper\"", &can),
            want("cdios:1/1", "null", &can),
            want("pac", "null", &serial),
            want("pac:1", "null", &serial),
            want("pac:2", "\"slide\"", &serial),
            want("pac:3", "null", &serial),
        ],
        "{doc}"
    );
    assert_eq!(doc["missing"], serde_json::json!([]));

    // Module 9 and axis 7 are not on the simulated bench.
    let file = bench_file(
        dir.path(),
        &format!(
            "{text}\n[[link]]\nspec = \"sim\"\nfamilies = [\"powercube\"]\ndevices = {{ wrist = \"powercube:9\" }}\n"
        ),
    );
    let r = run(&["--bench", &file, "--json", "scan"]);
    assert_eq!(r.code, 4, "{}{}", r.stdout, r.stderr);
    valid(&r.json());
    assert_eq!(
        r.json()["missing"],
        serde_json::json!([{"address": "powercube:9", "name": "wrist", "family": "powercube", "link": "sim", "module": 9}])
    );
    assert!(r.stderr.contains("expected but not answering: wrist (powercube:9 on sim)"), "{}", r.stderr);
    let r = run(&["--bench", &file, "scan"]);
    assert_eq!(r.code, 4);
    assert!(
        r.stdout.lines().any(|l| l.starts_with("powercube:9") && l.contains("wrist") && l.contains("missing")),
        "{}",
        r.stdout
    );
}

/// With several links, each per-family command finds the link of its
/// family; a family on no link is a usage error naming the links, and
/// nothing is opened.
#[test]
fn per_family_commands_take_their_family_link() {
    let (_sim, can, serial) = served();
    // The stops open their link through the takeover path, on the family's link too.
    for args in [
        &["pac-state"][..],
        &["cdios-identify"],
        &["state", "-m", "3"],
        &["halt", "-m", "3"],
        &["cdios-stop", "-m", "0", "--option", "fast"],
    ] {
        let mut all = vec!["--link", &can, "--link", &serial, "--json"];
        all.extend(args);
        let r = run(&all);
        ok(&r, &args.join(" "));
    }
    let r = run(&["--link", &can, "--link", "slcan:/dev/axisctl-no-such-tty", "pac-state"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains(&format!(
            "no link of the bench carries the PA-CONTROL: {can} (powercube, cdios), slcan:/dev/axisctl-no-such-tty \
             (powercube, cdios)"
        )),
        "{}",
        r.stderr
    );
    // In home position the controller's status answers (nothing moves, nothing to
    // stop): it was reached on its line.
    let r = run(&["--link", &can, "--link", &serial, "pac-stop-axis", "2"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert!(r.stdout.contains("PA-CONTROL in home position: nothing moves"), "{}", r.stdout);
    let r = run(&["--link", &can, "--link", &can, "scan"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("is given twice"), "{}", r.stderr);
}

/// `AXISCTL_LINK` holds several links separated by commas or spaces;
/// `AXISCTL_BENCH` and `axisctl.toml` name a bench file; `--link` wins over
/// a bench file (which is then not read at all).
#[test]
fn where_the_bench_comes_from() {
    let (_sim, can, serial) = served();
    let dir = tempfile::tempdir().unwrap();
    for sep in [",", " ", " , "] {
        let env = format!("{can}{sep}{serial}");
        let r = run_in(None, &[("AXISCTL_LINK", &env)], &["--json", "pac-state"]);
        ok(&r, &env);
    }
    let file = bench_file(dir.path(), &format!("[[link]]\nspec = \"{serial}\"\n"));
    ok(&run_in(None, &[("AXISCTL_BENCH", &file)], &["pac-state"]), "AXISCTL_BENCH");
    let r = run_in(None, &[("AXISCTL_BENCH", &file)], &["state", "-m", "3"]);
    assert_eq!(r.code, 2, "the bench file's link carries only the PA-CONTROL: {}", r.stderr);
    assert!(r.stderr.contains("no link of the bench carries the PowerCube"), "{}", r.stderr);

    std::fs::write(dir.path().join("axisctl.toml"), format!("[[link]]\nspec = \"{can}\"\n")).unwrap();
    ok(&run_in(Some(dir.path()), &[], &["cdios-identify"]), "axisctl.toml");
    std::fs::write(dir.path().join("axisctl.toml"), "[[link]]\nspec = \"sim\"\nspeed = 3\n").unwrap();
    let r = run_in(Some(dir.path()), &[], &["cdios-identify"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("bench file axisctl.toml, line 3: unknown field `speed`"), "{}", r.stderr);
    // --link and --bench given: the links win, the broken file is not read.
    ok(&run_in(Some(dir.path()), &[], &["--link", &serial, "--bench", "axisctl.toml", "pac-state"]), "--link wins");
    ok(&run_in(Some(dir.path()), &[("AXISCTL_LINK", &serial)], &["pac-state"]), "AXISCTL_LINK over axisctl.toml");
    // Offline commands never read it.
    ok(&run_in(Some(dir.path()), &[], &["decode", "cube-state", "0"]), "offline");
}

/// docs/sim-bench.toml, the guide's and json.md's example, runs as written
/// and names the devices it says.
#[test]
fn the_documented_bench_file_runs() {
    let r = run(&["--bench", "docs/sim-bench.toml", "--json", "scan"]);
    ok(&r, "scan");
    let doc = r.json();
    valid(&doc);
    let named: Vec<(&str, &str)> = doc["devices"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|d| Some((d["name"].as_str()?, d["address"].as_str().unwrap())))
        .collect();
    assert_eq!(
        named,
        [("shoulder", "powercube:3"), ("elbow", "powercube:5"), ("slide", "pac:2"), ("gripper", "cdios:1/0")],
        "{doc}"
    );
    let r = run(&["--bench", "docs/sim-bench.toml", "--json", "halt", "--all"]);
    ok(&r, "halt --all");
    valid(&r.json());
    let r = run(&["--bench", "docs/sim-bench.toml", "--json", "halt", "-d", "slide,shoulder"]);
    ok(&r, "halt -d");
    let doc = r.json();
    valid(&doc);
    let steps: Vec<(&str, &str, &str)> = doc["steps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["name"].as_str().unwrap(), s["address"].as_str().unwrap(), s["result"].as_str().unwrap()))
        .collect();
    assert_eq!(steps, [("slide", "pac:2", "already at rest"), ("shoulder", "powercube:3", "halted")], "{doc}");
    assert_eq!(doc["all"], false, "{doc}");
}

/// `halt -d` stops exactly the devices named, of every family and link,
/// and nothing else: with a move running on each family, naming the
/// PA-CONTROL axis and the Cdios motor stops those two while the PowerCube
/// module runs on, until it is named too (by its bench file name). Named
/// again at rest, each is stopped again or "already at rest", exit 0.
#[test]
fn halt_d_stops_exactly_the_devices_named() {
    let (_sim, can, serial) = served();
    let links = [can.as_str(), serial.as_str()];
    start_moves(&links);
    let r = run(&["--link", &can, "--link", &serial, "--json", "halt", "-d", "pac:2,cdios:1/0"]);
    ok(&r, "halt -d pac:2,cdios:1/0");
    let doc = r.json();
    valid(&doc);
    let said: Vec<(&str, bool)> =
        doc["steps"].as_array().unwrap().iter().map(|s| (s["address"].as_str().unwrap(), s["ok"] == true)).collect();
    assert_eq!(said, [("pac:2", true), ("cdios:1/0", true)], "{doc}");
    until("the axis and the motor at rest, the module still moving", || {
        let m = moving(&links);
        (m[0].is_none() || m[1].is_some() || m[2].is_some()).then(|| format!("{m:?}"))
    });
    let dir = tempfile::tempdir().unwrap();
    let file = bench_file(
        dir.path(),
        &format!(
            "[[link]]\nspec = \"{can}\"\ndevices = {{ elbow = \"powercube:5\" }}\n[[link]]\nspec = \"{serial}\"\n"
        ),
    );
    ok(&run(&["--bench", &file, "halt", "-d", "elbow"]), "halt -d elbow");
    until("every device at rest", || {
        let m = moving(&links);
        m.iter().any(Option::is_some).then(|| format!("{m:?}"))
    });
    let r = run(&["--bench", &file, "halt", "-d", "elbow,pac:2,cdios:1/0"]);
    ok(&r, "halt -d at rest");
    // The PA-CONTROL in online mode sends its axis stop again (harmless at rest).
    for (row, result) in [("powercube:5", "halted"), ("pac:2", ""), ("cdios:1/0", "already at rest")] {
        assert!(r.stdout.lines().any(|l| l.starts_with(row) && l.ends_with(result)), "{row}: {}", r.stdout);
    }
    assert!(!r.stdout.contains("FAILED"), "{}", r.stdout);
}

/// A bad device anywhere in the list is refused before any link opens:
/// exit 2, not one frame in the trace, and the good devices are not stopped
/// either (the list is one command).
#[test]
fn halt_d_with_a_bad_device_sends_nothing() {
    let (_sim, can, serial) = served();
    for (bad, says) in [
        ("powercube:3,powercube:40", "module id 1 to 31"),
        ("pac:2,wrist", "\"wrist\" is not a device of the bench"),
        ("cdios:1/0,cdios:0/0", "cdios:0/0"),
    ] {
        let r = run(&["--link", &can, "--link", &serial, "--trace", "halt", "-d", bad]);
        assert_eq!(r.code, 2, "{bad}: {}", r.stderr);
        assert!(r.stderr.contains(says), "{bad}: {}", r.stderr);
        assert!(!r.stderr.lines().any(|l| l.starts_with("-> ")), "{bad}: a frame went out: {}", r.stderr);
    }
}

/// A port held by another axisctl process (a `pac-move --wait`) is taken
/// over by the whole-bench `halt --all` as by `pac-stop`: the holder is
/// asked to halt and let go, the report names it, and the axis is at rest.
#[test]
fn halt_all_takes_a_held_port_over() {
    use std::io::{BufRead, BufReader};
    use std::sync::mpsc;

    let (_sim, can, serial) = served();
    let locks = tempfile::tempdir().unwrap();
    let lock_env = [(axisctl::link::lock::DIR_ENV, locks.path().to_str().unwrap())];
    let pac = |args: &[&str]| {
        let all = [&["--link", &can, "--link", &serial, "--timeout", "1000"][..], args].concat();
        run_in(None, &lock_env, &all)
    };
    if pac(&["--json", "pac-state"]).json()["mode"] != "online" {
        ok(&pac(&["pac-online"]), "pac-online");
    }
    ok(&pac(&["pac-no-ref", "2"]), "pac-no-ref");
    let mut holder = common::bin()
        .envs(lock_env)
        .args(["--link", &serial, "--timeout", "1000", "--trace", "pac-move", "2", "9000", "--wait"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = mpsc::channel();
    let err = holder.stderr.take().unwrap();
    // Into the wait: the move's frame left and an answer came after it.
    std::thread::spawn(move || {
        let mut moved = false;
        for line in BufReader::new(err).lines().map_while(Result::ok) {
            moved |= line.starts_with("-> ") && line.contains("0A94");
            if moved && line.starts_with("<- ") {
                let _ = tx.send(());
            }
        }
    });
    rx.recv_timeout(Duration::from_secs(20)).expect("the move is under way");
    let r = pac(&["--json", "halt", "--all"]);
    let status = common::wait_bounded(holder, 20, &["pac-move"]);
    ok(&r, "halt --all");
    let doc = r.json();
    valid(&doc);
    let holders = doc["holders"].as_array().unwrap();
    assert_eq!(holders.len(), 1, "{doc}");
    assert_eq!((&holders[0]["signalled"], &holders[0]["exited"]), (&true.into(), &true.into()), "{doc}");
    assert!(holders[0]["what"].as_str().unwrap().contains("pac-move 2 9000 --wait"), "{doc}");
    assert_eq!(status.code, 143, "the holder ended on SIGTERM after its own halt: {}", status.stderr);
    until("axis 2 at rest", || {
        let a = pac(&["--json", "pac-axis", "2"]);
        (a.json()["axis_status"] == 1).then_some(a.stdout)
    });
}
