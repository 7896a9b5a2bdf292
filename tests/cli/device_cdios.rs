//! `-d/--device` on the Cdios commands: `cdios:NODE/MODULE` or a bench
//! file's name stands for `--node N -m ID` and gives the same document; a
//! list names exactly the (node, module) pairs given, in that order; on
//! `cdios-identify` it names the node of the module. A device the command
//! cannot take is a usage error (exit 2) before anything is sent.

use crate::common;

use std::path::Path;

use common::{run, run_with_stdin};
use serde_json::Value;

/// The simulated bench with its motors enabled, its Cdios modules named
/// (and a PA-CONTROL axis and a PowerCube module, for the refusals).
fn bench(dir: &Path) -> String {
    common::bench::bench_file(
        dir,
        "[[link]]\nspec = \"sim?cdios=enabled\"\n\
         devices = { gripper = \"cdios:1/0\", wrist = \"cdios:1/1\", slide = \"pac:2\", shoulder = \"powercube:3\" }\n",
    )
}

/// `args` on the bench file, with --json; exit 0 and the document.
fn doc(file: &str, args: &[&str]) -> Value {
    let mut all = vec!["--bench", file, "--json"];
    all.extend(args);
    let r = run(&all);
    assert_eq!(r.code, 0, "{args:?}: {}{}", r.stdout, r.stderr);
    r.json()
}

#[test]
fn cdios_commands_take_a_device_as_they_take_node_and_module() {
    let dir = tempfile::tempdir().unwrap();
    let file = bench(dir.path());
    for (by_id, by_device) in [
        (&["cdios-status", "-m", "0"][..], &["cdios-status", "-d", "gripper"][..]),
        (&["cdios-status", "--node", "1", "-m", "1"], &["cdios-status", "-d", "cdios:1/1"]),
        (&["cdios-position", "-m", "0", "--all"], &["cdios-position", "--device", "gripper", "--all"]),
        (&["cdios-config", "--node", "1", "-m", "1", "speeds"], &["cdios-config", "-d", "wrist", "speeds"]),
        (&["cdios-outputs", "-m", "0"], &["cdios-outputs", "-d", "gripper"]),
        (&["cdios-events", "-m", "1"], &["cdios-events", "-d", "wrist"]),
        (&["cdios-set-position", "-m", "0", "250"], &["cdios-set-position", "-d", "gripper", "250"]),
        // Node-level: the node of the module named.
        (&["cdios-identify", "--node", "1"], &["cdios-identify", "-d", "gripper"]),
    ] {
        assert_eq!(doc(&file, by_id), doc(&file, by_device), "{by_device:?}");
    }
}

/// A list read gives the objects `--node N -m ID` gives, for the modules
/// named, in the order named (`-m 1,0` reads in id order).
#[test]
fn a_list_of_devices_reads_the_modules_named_in_the_order_named() {
    let dir = tempfile::tempdir().unwrap();
    let file = bench(dir.path());
    let listed = doc(&file, &["cdios-status", "-d", "wrist,gripper"]);
    let one = |m: &str| doc(&file, &["cdios-status", "--node", "1", "-m", m]);
    assert_eq!(listed, serde_json::json!({"devices": [one("1"), one("0")]}));
    let by_ids = doc(&file, &["cdios-status", "-m", "1,0"]);
    assert_eq!(by_ids["devices"][0]["module"], 0, "the shorthand reads in id order: {by_ids}");
    // Each device once; two names of one device are still a list.
    let twice = doc(&file, &["cdios-position", "-d", "gripper,cdios:1/0"]);
    assert_eq!(twice, serde_json::json!({"devices": [doc(&file, &["cdios-position", "-m", "0"])]}));
}

/// Devices on two nodes: exactly the pairs named, in the order named. The
/// bench has node 1 only, so node 2 is asked after node 1's module 1 was
/// read, and its silence is the command's error; node 1's module 0 (which
/// `--node 1,2 -m 0,1` would read first) is never asked for.
#[test]
fn devices_on_two_nodes_are_read_pair_by_pair() {
    let r = run(&[
        "--link",
        "sim",
        "--json",
        "--trace",
        "--retries",
        "0",
        "cdios-position",
        "-d",
        "cdios:1/1,cdios:2/0,cdios:1/0",
    ]);
    assert_eq!(r.code, 4, "{}", r.stderr);
    let sent: Vec<&str> = r.stderr.lines().filter(|l| l.starts_with("-> ")).collect();
    let read = sent.iter().position(|l| l.ends_with("read_position current to node 1 module 1"));
    let node2_first = sent.iter().position(|l| l.contains("node 2"));
    assert!(read.is_some() && node2_first > read, "node 1 module 1 read, then node 2 asked: {sent:?}");
    assert!(!sent.iter().any(|l| l.contains("node 1 module 0")), "not named, not asked: {sent:?}");
    let error: Value = serde_json::from_str(r.stderr.lines().last().unwrap()).unwrap();
    assert_eq!((&error["error"]["node"], &error["error"]["module"]), (&2.into(), &0.into()), "{error}");
}

/// A waited goto by name is the goto of `--node 1 -m 0` (the wait's time
/// aside), and a stop of the motor at rest succeeds and says so.
#[test]
fn a_goto_and_a_stop_take_a_device() {
    let dir = tempfile::tempdir().unwrap();
    let file = bench(dir.path());
    let goto = |args: &[&str]| {
        let mut d = doc(&file, args);
        assert!(d.as_object_mut().unwrap().remove("elapsed_ms").is_some(), "{d}");
        d
    };
    let by_device = goto(&["cdios-goto", "-d", "gripper", "1200", "--wait"]);
    assert_eq!(by_device, goto(&["cdios-goto", "--node", "1", "-m", "0", "1200", "--wait"]));
    assert_eq!((&by_device["module"], &by_device["position"]["value"]), (&0.into(), &1200.into()), "{by_device}");

    let stop = doc(&file, &["cdios-stop", "-d", "wrist"]);
    assert_eq!(stop, doc(&file, &["cdios-stop", "-m", "1"]));
    assert_eq!((&stop["module"], &stop["already_stopped"]), (&1.into(), &true.into()), "{stop}");
}

/// `record --node/-m` with a goto named by its device: the motor recorded
/// is the one that moves. A goto on another node than the recording's is
/// refused before anything is sent.
#[test]
fn record_takes_a_goto_named_by_its_device() {
    let dir = tempfile::tempdir().unwrap();
    let file = bench(dir.path());
    let r = run(&[
        "--bench",
        &file,
        "--json",
        "record",
        "--node",
        "1",
        "-m",
        "0",
        "position",
        "--rate",
        "20",
        "--count",
        "20",
        "--",
        "cdios-goto",
        "-d",
        "gripper",
        "3000",
    ]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let pos = |l: &str| serde_json::from_str::<Value>(l).unwrap()["devices"][0]["values"]["position"]["value"].clone();
    let lines: Vec<&str> = r.stdout.lines().collect();
    assert_eq!(lines.len(), 20, "{}", r.stdout);
    assert!(pos(lines[19]).as_i64() > pos(lines[0]).as_i64(), "module 0 moved: {}", r.stdout);

    // The goto's node, by -d or by a typed --node, is the recording's or
    // nothing goes out (a goto without --node takes the recording's node).
    let log = dir.path().join("frames.log");
    for goto in [&["-d", "gripper"][..], &["--node", "1", "-m", "0"], &["--node=1", "-m", "0"]] {
        let mut args = vec!["--bench", &file, "--log", log.to_str().unwrap(), "record", "--node", "2", "-m", "0"];
        args.extend(["position", "--count", "3", "--", "cdios-goto"]);
        args.extend(goto);
        args.push("3000");
        let r = run(&args);
        assert_eq!(r.code, 2, "{goto:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains("on Cdios node 1 but the recording is of node 2"), "{goto:?}: {}", r.stderr);
    }
    let logged = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(logged.is_empty(), "nothing is sent: {logged}");
}

/// A batch line's goto by name is the motor the batch halts when a later
/// line fails.
#[test]
fn a_batch_halts_the_motor_a_line_named_by_its_device() {
    let dir = tempfile::tempdir().unwrap();
    let file = bench(dir.path());
    let text = "cdios-goto -d gripper 400000\ncdios-status -d cdios:1/9\n";
    let r = run_with_stdin(&["--bench", &file, "--timeout", "50", "--retries", "0", "batch", "-"], text);
    assert_eq!(r.code, 5, "module 9 is refused: {}", r.stderr);
    assert!(
        r.stderr.ends_with("stopped after line 2 failed; halted: `cdios-stop --node 1 -m 0 --option fast`\n"),
        "{}",
        r.stderr
    );
}

/// A named module is reached on the link the bench file puts it on, even
/// when another link carries the Cdios first (a port that does not exist:
/// a command that opened it would exit 3).
#[test]
fn a_module_is_reached_on_its_own_link() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.toml");
    std::fs::write(
        &path,
        "[[link]]\nspec = \"slcan:/dev/axisctl-no-such-tty\"\nfamilies = [\"cdios\"]\n\
         devices = { far = \"cdios:1/0\" }\n\
         [[link]]\nspec = \"sim\"\nfamilies = [\"cdios\"]\ndevices = { near = \"cdios:1/1\" }\n",
    )
    .unwrap();
    let file = path.to_str().unwrap();
    let d = doc(file, &["cdios-status", "-d", "near"]);
    assert_eq!((d["link"].as_str(), d["node"].as_u64(), d["module"].as_u64()), (Some("sim"), Some(1), Some(1)), "{d}");
    let d = doc(file, &["cdios-identify", "-d", "near"]);
    assert_eq!(d["link"], "sim", "{d}");
    // The shorthand takes the family's first link: the missing port.
    let r = run(&["--bench", file, "cdios-status", "-m", "1"]);
    assert_eq!(r.code, 3, "{}{}", r.stdout, r.stderr);
    let r = run(&["--bench", file, "cdios-position", "-d", "near,far"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    assert!(r.stderr.contains("near is on sim and far on slcan:/dev/axisctl-no-such-tty"), "{}", r.stderr);
}

/// Every refusal of `-d` is exit 2 with the reason, and nothing goes out.
#[test]
fn a_device_a_cdios_command_cannot_take_is_refused_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let file = bench(dir.path());
    let log = dir.path().join("frames.log");
    for (args, why) in [
        (
            &["cdios-goto", "-d", "slide", "100"][..],
            "cdios-goto takes Cdios devices (cdios:NODE/MODULE); slide is a PA-CONTROL device",
        ),
        (&["cdios-status", "-d", "gripper,shoulder"], "shoulder is a PowerCube device"),
        (&["cdios-identify", "-d", "pac:2"], "cdios-identify takes Cdios devices"),
        (&["cdios-stop", "-d", "elbow"], "\"elbow\" is not a device of the bench"),
        (&["cdios-goto", "-d", "cdios:0/0", "100"], "node id 1 to 127"),
        (&["cdios-position", "-d", "cdios:1/16"], "module id 0 to 15"),
        (&["cdios-goto", "-d", "gripper", "-m", "0", "100"], "cannot be used with"),
        (&["cdios-status", "--node", "1", "-d", "gripper"], "cannot be used with"),
    ] {
        let mut all = vec!["--bench", &file, "--log", log.to_str().unwrap()];
        all.extend(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(why), "{args:?}: {}", r.stderr);
    }
    let logged = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(logged.is_empty(), "nothing is sent: {logged}");
}
