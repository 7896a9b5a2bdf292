//! `-d/--device` on the PA-CONTROL commands: an axis command takes `pac:N`
//! or a bench-file name of an axis in place of AXIS, a controller command
//! `pac` or a bench-file name of the controller, which picks its serial
//! link. The same documents as the axis numbers give; a device the command
//! cannot take is a usage error (exit 2) before any link opens.

use crate::common;

use std::path::Path;

use common::bench::{bench_file, SIM_BENCH};
use common::{run, run_with_stdin, Run, Sim};

/// The simulated bench with names (docs/sim-bench.toml): `slide = pac:2`.
/// The simulated bench in online mode, its controller and two axes named.
fn online_bench(dir: &Path) -> String {
    bench_file(
        dir,
        "[[link]]\nspec = \"sim?pac=online\"\ndevices = { panel = \"pac\", slide = \"pac:2\", lift = \"pac:1\" }\n",
    )
}

fn with(lead: &[&str], args: &[&str]) -> Run {
    let mut all = lead.to_vec();
    all.extend(args);
    run(&all)
}

/// `args` ran to exit 0; its document.
fn doc(lead: &[&str], args: &[&str]) -> serde_json::Value {
    let r = with(lead, args);
    assert_eq!(r.code, 0, "{lead:?} {args:?}: {}{}", r.stdout, r.stderr);
    r.json()
}

#[test]
fn pac_reads_take_a_device_as_they_take_an_axis() {
    let lead = ["--bench", SIM_BENCH, "--json"];
    for (by_number, by_device) in [
        (&["pac-axis", "2"][..], &["pac-axis", "-d", "slide"][..]),
        (&["pac-axis", "2"], &["pac-axis", "--device", "pac:2"]),
        (&["pac-axis", "1,2"], &["pac-axis", "-d", "pac:1,slide"]),
        (&["pac-axis-param", "2", "acceleration"], &["pac-axis-param", "-d", "slide", "acceleration"]),
        (
            &["pac-axis-param", "2", "acceleration", "--max"],
            &["pac-axis-param", "-d", "slide", "acceleration", "--max"],
        ),
        (&["pac-raw", "190C", "2"], &["pac-raw", "-d", "pac", "190C", "2"]),
        (&["pac-state"], &["pac-state", "-d", "pac"]),
        (&["pac-axes"], &["pac-axes", "-d", "pac"]),
        (&["pac-sys-param", "number-of-axes"], &["pac-sys-param", "-d", "pac", "number-of-axes"]),
    ] {
        assert_eq!(doc(&lead, by_number), doc(&lead, by_device), "{by_device:?}");
    }
    let list = doc(&lead, &["pac-axis", "-d", "slide,pac:1,pac:2"]);
    let axes: Vec<_> = list["devices"].as_array().unwrap().iter().map(|d| d["axis"].clone()).collect();
    assert_eq!(axes, [2, 1], "each device once, in the order named: {list}");
}

/// A controller named in the bench file is the controller.
#[test]
fn a_controller_command_takes_the_controllers_name() {
    let dir = tempfile::tempdir().unwrap();
    let file = online_bench(dir.path());
    let lead = ["--bench", file.as_str(), "--json"];
    assert_eq!(doc(&lead, &["pac-state"]), doc(&lead, &["pac-state", "-d", "panel"]));
    assert_eq!(doc(&lead, &["pac-error", "-d", "panel"])["controller_error"], 0);
}

/// A waited move and a reference drive by name are the moves of the axis
/// number (the time taken aside); a stop of an axis at rest is exit 0.
#[test]
fn pac_motions_and_stops_take_a_device() {
    let dir = tempfile::tempdir().unwrap();
    let file = online_bench(dir.path());
    let lead = ["--bench", file.as_str(), "--json"];
    // How long a wait took, and so how many polls it made, is the host's.
    let moved = |args: &[&str]| {
        let mut d = doc(&lead, args);
        for timed in ["elapsed_ms", "polls"] {
            d.as_object_mut().unwrap().remove(timed);
        }
        d
    };
    let by_device = moved(&["pac-move", "-d", "slide", "150", "--wait"]);
    assert_eq!((by_device["axis"].as_u64(), by_device["done"].as_bool()), (Some(2), Some(true)), "{by_device}");
    assert_eq!(by_device, moved(&["pac-move", "2", "150", "--wait"]));
    let relative = moved(&["pac-move", "--device", "slide", "-10", "--relative", "--wait"]);
    assert_eq!(relative, moved(&["pac-move", "2", "-10", "--relative", "--wait"]));
    assert_eq!(moved(&["pac-ref", "-d", "lift", "--wait"]), moved(&["pac-ref", "1", "--wait"]));

    // Home position: nothing moves, the stop is done already.
    let lead = ["--bench", SIM_BENCH, "--json"];
    let stopped = doc(&lead, &["pac-stop-axis", "-d", "slide"]);
    assert_eq!((stopped["axis"].as_u64(), stopped["already_stopped"].as_bool()), (Some(2), Some(true)), "{stopped}");
    assert_eq!(stopped, doc(&lead, &["pac-stop-axis", "2"]));
    assert_eq!(doc(&lead, &["pac-stop", "-d", "pac"]), doc(&lead, &["pac-stop"]));
}

/// The axis commands that write take `-d` too, and send what AXIS sends.
#[test]
fn pac_settings_take_a_device() {
    let dir = tempfile::tempdir().unwrap();
    let file = online_bench(dir.path());
    let lead = ["--bench", file.as_str(), "--json"];
    for (by_number, by_device) in [
        (&["pac-speed", "2", "50"][..], &["pac-speed", "-d", "slide", "50"][..]),
        (&["pac-set-pos", "2", "-12.5"], &["pac-set-pos", "-d", "slide", "-12.5"]),
        (&["pac-axis-power", "2", "on"], &["pac-axis-power", "-d", "slide", "on"]),
        (&["pac-measure", "2", "off"], &["pac-measure", "-d", "slide", "off"]),
        (&["pac-limit-switch", "2", "on"], &["pac-limit-switch", "-d", "slide", "on"]),
        // The controller: every axis (PAR_1 0).
        (&["pac-limit-switch", "0", "on"], &["pac-limit-switch", "-d", "panel", "on"]),
        (&["pac-zero", "2"], &["pac-zero", "-d", "slide"]),
    ] {
        assert_eq!(doc(&lead, by_number), doc(&lead, by_device), "{by_device:?}");
    }
}

/// `record -- pac-move -d NAME` moves the named axis; a batch line
/// `pac-move -d NAME` arms the halt of that axis, which a failed line after
/// it stops.
#[test]
fn record_and_batch_move_the_named_axis() {
    let dir = tempfile::tempdir().unwrap();
    let file = online_bench(dir.path());
    for (name, axis) in [("slide", 2), ("lift", 1)] {
        let r = run(&[
            "--bench", &file, "record", "--axis", "2", "position", "--count", "3", "--", "pac-move", "-d", name, "150",
        ]);
        assert_eq!(r.code, 0, "{}", r.stderr);
        assert!(
            r.stderr.contains(&format!("axis {axis} at t = ")) && r.stderr.contains("moving to 150"),
            "{}",
            r.stderr
        );
    }
    let r = run(&[
        "--bench", &file, "record", "--axis", "2", "position", "--count", "3", "--", "pac-move", "-d", "pac", "150",
    ]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("pac is the controller itself"), "{}", r.stderr);

    let r = run_with_stdin(&["--bench", &file, "batch", "-"], "pac-move -d slide 900\npac-axis 9\n");
    assert_eq!(r.code, 5, "{}", r.stderr);
    assert!(r.stderr.ends_with("halted: `pac-stop-axis 2`\n"), "{}", r.stderr);
}

/// Two PA-CONTROLs served on two serial lines, the first with 3 axes, the
/// second with 5, and a bench file naming axis 2 of the first `near`, the
/// second controller `right` and its axis 5 `far`.
struct TwoControllers {
    three: Sim,
    five: Sim,
    _dir: tempfile::TempDir,
    file: String,
}

fn two_controllers() -> TwoControllers {
    let three = Sim::start(&["--pac", "pty-serial"], 1);
    let five = Sim::start(&["--pac", "pty-serial", "--axes", "5"], 1);
    let dir = tempfile::tempdir().unwrap();
    let file = bench_file(
        dir.path(),
        &format!(
            "[[link]]\nspec = \"{}\"\ndevices = {{ near = \"pac:2\" }}\n\
             [[link]]\nspec = \"{}\"\ndevices = {{ right = \"pac\", far = \"pac:5\" }}\n",
            three.link("pac"),
            five.link("pac")
        ),
    );
    TwoControllers { three, five, _dir: dir, file }
}

/// With two PA-CONTROLs on two serial lines, `-d` picks the line: the
/// controller by its bench-file name (or `pac`, where the file names it),
/// an axis by its name.
#[test]
fn a_device_picks_its_controllers_serial_link() {
    let TwoControllers { three, five, file, .. } = &two_controllers();
    let lead = ["--bench", file.as_str(), "--json"];
    let count = |args: &[&str]| doc(&lead, args)["devices"].as_array().map(Vec::len);
    assert_eq!(count(&["pac-axes"]), Some(3), "without -d: the first link");
    assert_eq!(count(&["pac-axes", "-d", "right"]), Some(5));
    assert_eq!(count(&["pac-axes", "-d", "pac"]), Some(5), "pac: where the bench file names it");
    let far = doc(&lead, &["pac-axis", "-d", "far"]);
    assert_eq!((far["axis"].as_u64(), far["link"].as_str()), (Some(5), Some(five.link("pac"))), "{far}");
    assert_eq!(with(&lead, &["pac-axis", "5"]).code, 5, "axis 5 of the first controller is unknown");
    assert_eq!(doc(&lead, &["pac-axis", "-d", "near"])["link"].as_str(), Some(three.link("pac")));
    // The stops open their line by taking it over: the named one's too.
    // Only the second controller is online, so only its stop goes out.
    assert_eq!(run(&["--link", five.link("pac"), "pac-online"]).code, 0);
    let stopped = |args: &[&str]| doc(&lead, args)["already_stopped"].as_bool();
    assert_eq!(stopped(&["pac-stop-axis", "-d", "far"]), Some(false));
    assert_eq!(stopped(&["pac-stop-axis", "2"]), Some(true), "the first controller, in home position");
    assert_eq!(stopped(&["pac-stop", "-d", "right"]), Some(false));
    let r = with(&lead, &["pac-axis", "-d", "near,far"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    assert!(r.stderr.contains("a PA-CONTROL command talks to one link"), "{}", r.stderr);
}

/// A batch halts a moved axis on the line it moved on: the link of the
/// line's `-d`, else the family's first, whatever link an earlier line
/// named; a line that would move a second link of a family that moves is
/// refused before sending. A halted axis says "was stopped" (status 2),
/// one that was never moved "in position" (0).
#[test]
fn a_batch_halts_each_axis_on_its_own_line() {
    let two = two_controllers();
    let lead = ["--bench", two.file.as_str()];
    for (link, axis) in [(two.three.link("pac"), "2"), (two.five.link("pac"), "5")] {
        assert_eq!(run(&["--link", link, "pac-online"]).code, 0);
        assert_eq!(run(&["--link", link, "pac-no-ref", axis]).code, 0);
    }
    let status =
        |name: &str| doc(&["--bench", two.file.as_str(), "--json"], &["pac-axis", "-d", name])["axis_status"].clone();
    let batch = |text: &str| run_with_stdin(&[&lead[..], &["batch", "-"]].concat(), text);

    // Moved by name on the second line, halted there.
    let r = batch("pac-move -d far 9000\npac-axis 9\n");
    assert_eq!(r.code, 5, "{}", r.stderr);
    assert!(r.stderr.ends_with("halted: `pac-stop-axis 5`\n"), "{}", r.stderr);
    assert_eq!(status("far"), 2, "axis 5 of the second controller was stopped");

    // Moved by number after a line that named the second controller's
    // axis: the first controller's axis 2 is halted, not the second's.
    let r = batch("pac-axis -d far\npac-move 2 5000\npac-axis 9\n");
    assert_eq!(r.code, 5, "{}", r.stderr);
    assert!(r.stderr.ends_with("halted: `pac-stop-axis 2`\n"), "{}", r.stderr);
    assert_eq!(status("near"), 2, "axis 2 of the first controller was stopped");

    // Two controllers' moves in one run: the second is refused unsent.
    assert_eq!(run(&["--link", two.three.link("pac"), "pac-set-pos", "2", "100"]).code, 0);
    let r = batch("pac-move -d far 100\npac-move -d near 300\n");
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("which a failure could not halt with them"), "{}", r.stderr);
    let near = doc(&["--bench", two.file.as_str(), "--json"], &["pac-axis", "-d", "near"]);
    assert_eq!(near["position"]["value"], 100.0, "nothing went to the first controller: {near}");
}

/// Every refusal of `-d` is exit 2 with the reason, and nothing goes out.
#[test]
fn a_device_a_pac_command_cannot_take_is_refused_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("frames.log");
    for (args, why) in [
        (
            &["pac-move", "-d", "shoulder", "900"][..],
            "pac-move takes PA-CONTROL devices (pac:AXIS); shoulder is a PowerCube device",
        ),
        (&["pac-axis", "-d", "cdios:1/0"], "pac-axis takes PA-CONTROL devices (pac:AXIS); cdios:1/0 is a Cdios device"),
        (&["pac-axis", "-d", "slide,gripper"], "gripper is a Cdios device"),
        (&["pac-ref", "-d", "wrist"], "\"wrist\" is not a device of the bench"),
        (&["pac-move", "-d", "pac:17", "900"], "axis 1 to 16, not \"17\""),
        (&["pac-move", "-d", "pac", "900"], "pac-move takes an axis (pac:AXIS); pac is the controller itself"),
        (&["pac-stop-axis", "-d", "pac"], "pac is the controller itself"),
        (&["pac-state", "-d", "slide"], "pac-state is about the controller, not an axis"),
        (&["pac-online", "-d", "pac:2"], "pac-online is about the controller, not an axis"),
        (&["pac-stop", "-d", "shoulder"], "shoulder is a PowerCube device"),
        (&["pac-move", "-d", "slide", "2", "900"], "unexpected argument '900'"),
    ] {
        let r = with(&["--bench", SIM_BENCH, "--log", log.to_str().unwrap()], args);
        assert_eq!(r.code, 2, "{args:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(why), "{args:?}: {}", r.stderr);
    }
    let logged = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(logged.is_empty(), "nothing is sent: {logged}");
}

/// Completion offers the bench file's PA-CONTROL devices after `-d`, on an
/// axis command and on a controller command alike.
#[test]
fn bash_completes_the_pac_devices_of_the_bench_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("axisctl.toml"),
        "[[link]]\nspec = \"sim\"\ndevices = { panel = \"pac\", slide = \"pac:2\", shoulder = \"powercube:3\" }\n",
    )
    .unwrap();
    let bench = dir.path().join("axisctl.toml");
    let env = [("AXISCTL_BENCH", bench.to_str().unwrap())];
    let complete = |words: &[&str]| -> Vec<String> {
        let got = common::bash_completion(words, &env);
        got.iter().map(|l| l.split_whitespace().next().unwrap_or("").to_string()).collect()
    };
    let got = complete(&["pac-move", "-d", ""]);
    assert_eq!(got, ["pac", "pac:2", "panel", "slide"], "the PA-CONTROL devices, by name and address");
    let got = complete(&["pac-axis", "-d", "slide,p"]);
    assert_eq!(got, ["slide,pac", "slide,pac:2", "slide,panel"], "after the comma");
    let got = complete(&["pac-state", "-d", "s"]);
    assert_eq!(got, ["slide"]);
}
