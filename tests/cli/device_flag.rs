//! `-d/--device` on the per-family commands: the same device as the
//! family's shorthand (`-m`, axis numbers, `--node`), by address or by the
//! name a bench file gives it, on the link the bench puts it on. A device of
//! another family, an unknown name or devices on two links are usage errors
//! (exit 2) before any link opens.

use crate::common;

use common::bench::{two_cube_links, SIM_BENCH};
use common::run;

#[test]
fn powercube_reads_take_a_device_as_they_take_a_module() {
    for (by_id, by_device) in [
        (&["state", "-m", "3"][..], &["state", "-d", "powercube:3"][..]),
        (&["state", "-m", "3"], &["state", "-d", "shoulder"]),
        (&["info", "-m", "3,5"], &["info", "-d", "shoulder,elbow"]),
        (&["get-param", "-m", "5", "ActPos"], &["get-param", "--device", "elbow", "ActPos"]),
        (&["get-config", "-m", "3"], &["get-config", "-d", "shoulder"]),
        (&["dio", "-m", "5"], &["dio", "-d", "powercube:5"]),
    ] {
        let with = |args: &[&str]| {
            let mut all = vec!["--bench", SIM_BENCH, "--json"];
            all.extend(args);
            let r = run(&all);
            assert_eq!(r.code, 0, "{args:?}: {}{}", r.stdout, r.stderr);
            r.json()
        };
        assert_eq!(with(by_id), with(by_device), "{by_device:?}");
    }
}

#[test]
fn one_device_is_one_object_and_several_a_list() {
    let r = run(&["--bench", SIM_BENCH, "--json", "state", "-d", "shoulder"]);
    assert_eq!(r.json()["module"], 3, "{}", r.stdout);
    let r = run(&["--bench", SIM_BENCH, "--json", "state", "-d", "shoulder,powercube:3,elbow"]);
    let modules: Vec<_> = r.json()["devices"].as_array().unwrap().iter().map(|d| d["module"].clone()).collect();
    assert_eq!(modules, [3, 5], "each device once, in the order named: {}", r.stdout);
}

#[test]
fn powercube_motions_take_a_device() {
    let r = run(&["--bench", SIM_BENCH, "--json", "move-ramp", "-d", "elbow", "0.2", "--wait"]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
    assert_eq!(r.json()["module"], 5);
    assert_eq!(r.json()["command"], "move-ramp");
    let r = run(&["--bench", SIM_BENCH, "--json", "home", "-d", "shoulder", "--wait"]);
    assert_eq!((r.code, r.json()["module"].clone()), (0, 3.into()), "{}{}", r.stdout, r.stderr);
}

/// A named device is reached on the link the bench file puts it on, even
/// when another link carries its family first.
#[test]
fn a_device_is_read_on_its_own_link() {
    let dir = tempfile::tempdir().unwrap();
    let file = two_cube_links(dir.path());
    let r = run(&["--bench", &file, "--json", "state", "-d", "arm"]);
    assert_eq!(r.code, 0, "{}{}", r.stdout, r.stderr);
    assert_eq!((r.json()["link"].as_str(), r.json()["module"].as_u64()), (Some("sim"), Some(3)));
    // The shorthand takes the family's first link: the missing port.
    let r = run(&["--bench", &file, "--json", "state", "-m", "3"]);
    assert_eq!(r.code, 3, "{}{}", r.stdout, r.stderr);
}

/// Every refusal of `-d` is exit 2 with the reason, and nothing goes out:
/// the log stays empty.
#[test]
fn a_device_the_command_cannot_take_is_refused_before_sending() {
    let dir = tempfile::tempdir().unwrap();
    let file = two_cube_links(dir.path());
    let log = dir.path().join("frames.log");
    for (args, why) in [
        (
            &["move-vel", "-d", "slide", "0.1"][..],
            "move-vel takes PowerCube devices (powercube:MODULE); slide is a PA-CONTROL device",
        ),
        (&["home", "-d", "cdios:1/0"], "home takes PowerCube devices (powercube:MODULE); cdios:1/0 is a Cdios device"),
        (&["state", "-d", "wrist"], "\"wrist\" is not a device of the bench"),
        (&["state", "-d", "powercube:32"], "module id 1 to 31"),
    ] {
        let mut all = vec!["--bench", SIM_BENCH, "--log", log.to_str().unwrap()];
        all.extend(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}{}", r.stdout, r.stderr);
        assert!(r.stderr.contains(why), "{args:?}: {}", r.stderr);
    }
    let r =
        run(&["--bench", &file, "--log", log.to_str().unwrap(), "move-ramp", "-d", "arm,far", "--sync", "0.1", "0.2"]);
    assert_eq!(r.code, 2, "{}{}", r.stdout, r.stderr);
    assert!(r.stderr.contains("arm is on sim and far on slcan:/dev/axisctl-no-such-tty"), "{}", r.stderr);
    let logged = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(logged.is_empty(), "nothing is sent: {logged}");
}

/// `record -d`: each value of each device. One family's devices are the
/// `-m` form (a motion after `--` included); several families are
/// `DEVICE.VALUE` for each, one stream.
#[test]
fn record_takes_devices_of_one_family_or_several() {
    let devices = |args: &[&str]| -> Vec<(String, Vec<String>)> {
        let mut all = vec!["--bench", SIM_BENCH, "--json", "record"];
        all.extend(args);
        let r = run(&all);
        assert_eq!(r.code, 0, "{args:?}: {}{}", r.stdout, r.stderr);
        let first: serde_json::Value = serde_json::from_str(r.stdout.lines().next().unwrap()).unwrap();
        first["devices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|d| {
                let id = ["module", "axis"].iter().find_map(|k| d[k].as_u64()).unwrap();
                let values = d["values"].as_object().unwrap().keys().cloned().collect();
                (format!("{} {id}", d["family"].as_str().unwrap()), values)
            })
            .collect()
    };
    let cube = |id: &str| (format!("powercube {id}"), vec!["ActPos".to_string()]);
    assert_eq!(devices(&["-d", "shoulder,elbow", "ActPos", "--count", "1"]), [cube("3"), cube("5")]);
    assert_eq!(
        devices(&["-d", "shoulder,elbow", "ActPos", "--count", "1"]),
        devices(&["-m", "3,5", "ActPos", "--count", "1"])
    );
    assert_eq!(
        devices(&["-d", "elbow", "ActPos", "--count", "3", "--", "move-ramp", "-d", "elbow", "0.01"]),
        [cube("5")]
    );
    let position = |d: &str| (d.to_string(), vec!["position".to_string()]);
    assert_eq!(devices(&["-d", "slide,gripper", "position", "--count", "1"]), [position("pac 2"), position("cdios 0")]);
    let r = run(&["--bench", SIM_BENCH, "record", "-d", "shoulder,slide", "ActPos", "--count", "1"]);
    assert_eq!(r.code, 2, "a value the PA-CONTROL axis does not have: {}", r.stderr);
    let r = run(&["--bench", SIM_BENCH, "record", "-d", "shoulder", "shoulder.ActPos", "--count", "1"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("with -d the values are given without a device"), "{}", r.stderr);
}
