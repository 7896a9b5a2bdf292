//! One set of flags across the families: device lists with `-m`, on/off
//! said one way, waits opt-in, `--relative` on every move, negative numbers
//! as values, global options in their own help section, suggestions that
//! name the command meant.

use crate::common;

use common::{run, Sim};

fn ok(args: &[&str]) -> common::Run {
    let r = run(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    r
}

#[test]
fn negative_numbers_are_values_not_flags() {
    // Accepted as values, so the device layer's own check answers, not clap.
    let r = run(&["--link", "sim", "move-ramp", "-m", "17", "0.01", "--vel", "-0.05"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(
        r.stderr.contains("velocity must be positive") && !r.stderr.contains("unexpected argument"),
        "{}",
        r.stderr
    );
    let r = run(&["--link", "sim", "pac-speed", "1", "-5"]);
    assert!(!r.stderr.contains("unexpected argument") && r.stderr.contains("-5"), "{}", r.stderr);
    ok(&["--link", "sim", "move-vel", "-m", "3", "-0.05"]);
    ok(&["--link", "sim", "cdios-analog", "-m", "0", "--output", "1", "--set", "-2500"]);
}

#[test]
fn global_options_have_their_own_help_section() {
    let help = ok(&["pac-move", "--help"]).stdout;
    let (own, global) = help.split_once("Global options:").expect("a Global options section");
    assert!(own.contains("--relative") && !own.contains("--link"), "{help}");
    let global = global.split("Examples:").next().unwrap();
    for opt in ["--link", "--json", "--timeout", "--trace", "--log", "--retries"] {
        assert!(global.contains(opt), "{opt} not under Global options:\n{help}");
    }
    assert!(!global.contains("--relative"), "{help}");
}

#[test]
fn help_ranges_are_said_in_words() {
    let help = ok(&["--help"]).stdout;
    assert!(help.contains("1 to 60000") && !help.contains("..="), "{help}");
}

#[test]
fn scan_dashboard_and_sim_take_modules_with_m() {
    let r = ok(&["--link", "sim", "--json", "scan", "-m", "3,17"]);
    let found: Vec<u64> =
        r.json()["devices"].as_array().unwrap().iter().map(|m| m["module"].as_u64().unwrap()).collect();
    assert_eq!(found, [3, 17], "{}", r.stdout);
    // The former spelling still works, hidden from the help.
    ok(&["--link", "sim", "scan", "--ids", "3"]);
    assert!(!ok(&["scan", "--help"]).stdout.contains("--ids"));
    let sim = Sim::start(&["--powercube", "pty-slcan", "-m", "5"], 1);
    let r = ok(&["--link", sim.link("powercube"), "--json", "scan", "-m", "1-31"]);
    assert_eq!(r.json()["devices"].as_array().unwrap().len(), 1, "{}", r.stdout);
    let help = ok(&["dashboard", "--help"]).stdout;
    assert!(
        help.contains("-m, --module <LIST>") && help.contains("--axis <LIST>") && !help.contains("--modules"),
        "{help}"
    );
}

#[test]
fn pac_switches_are_on_or_off_and_stop_axis_waits_only_when_told() {
    let sim = Sim::start(&["--pac", "pty-serial"], 1);
    let link = sim.link("pac");
    let cmd = |args: &[&str]| {
        let mut all = vec!["--link", link, "--timeout", "1000", "--json"];
        all.extend_from_slice(args);
        ok(&all).json()["command_code"].as_str().unwrap().to_string()
    };
    cmd(&["pac-online"]);
    assert_eq!(cmd(&["pac-axis-power", "3", "off"]), "0A98");
    assert_eq!(cmd(&["pac-axis-power", "3", "on"]), "0A97");
    assert_eq!(cmd(&["pac-measure", "3", "on"]), "0AA0");
    assert_eq!(cmd(&["pac-measure", "3", "off"]), "0AA1");
    assert_eq!(cmd(&["pac-stop-axis", "1"]), "0A9A", "returns at once by default");
    assert_eq!(cmd(&["pac-stop-axis", "1", "--wait"]), "0A93", "waits for standstill when told");
    let r = run(&["--link", link, "pac-limit-switch", "2", "maybe"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("[possible values: on, off]"), "{}", r.stderr);
}

#[test]
fn every_wait_has_the_same_default_timeout() {
    for cmd in ["home", "move-ramp", "pac-move", "pac-ref", "cdios-goto", "cdios-traject"] {
        let help = ok(&[cmd, "--help"]).stdout;
        assert!(help.contains("--wait-timeout <S>") && help.contains("[default: 120]"), "{cmd}:\n{help}");
    }
}

#[test]
fn powercube_moves_take_relative_distances_from_the_current_position() {
    let sim = Sim::start(&["--powercube", "pty-slcan"], 1);
    let link = sim.link("powercube");
    let pos = || {
        let r = ok(&["--link", link, "--json", "get-param", "-m", "3", "ActPos"]);
        r.json()["params"]["ActPos"]["value"].as_f64().unwrap()
    };
    ok(&["--link", link, "home", "-m", "3", "--wait"]);
    ok(&["--link", link, "move-ramp", "-m", "3", "0.2", "--wait"]);
    assert!((pos() - 0.2).abs() < 1e-3, "{}", pos());
    ok(&["--link", link, "move-ramp", "-m", "3", "-0.05", "--relative", "--wait"]);
    assert!((pos() - 0.15).abs() < 1e-3, "{}", pos());
    let r = ok(&["--link", link, "--json", "move-step", "-m", "3", "0.1", "--relative", "--time", "200"]);
    assert!((r.json()["target"]["value"].as_f64().unwrap() - 0.25).abs() < 1e-3, "{}", r.stdout);
    assert_eq!(r.json()["target"]["unit"], "rad", "{}", r.stdout);
    let r = run(&["--link", link, "move-ramp", "-m", "3,5", "--sync", "0.1", "0.1", "--relative"]);
    assert_eq!(r.code, 2, "--relative with --sync is refused: {}", r.stderr);
}

#[test]
fn a_mistyped_command_gets_the_one_it_is_near() {
    let r = run(&["pac-axsi"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("'pac-axis'"), "{}", r.stderr);
    assert!(!r.stderr.contains("pac-online") && !r.stderr.contains("pac-axes"), "{}", r.stderr);
}

#[test]
fn keepalive_interval_says_what_it_accepts() {
    let r = run(&["--link", "sim", "watchdog", "keepalive", "--interval", "50"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("1 to 49 ms"), "{}", r.stderr);
    let help = ok(&["watchdog", "keepalive", "--help"]).stdout;
    assert!(help.contains("1 to 49 ms"), "{help}");
}

/// `cdios-goto --speed` above the module's configured maximum (8000 RPM on
/// the bench) is refused after reading the speeds: no goto leaves. `--force`
/// sends it (the motor is not enabled, so the controller refuses: exit 5).
#[test]
fn cdios_goto_checks_speed_against_the_configured_speeds_unless_forced() {
    let r = run(&["--link", "sim", "--trace", "cdios-goto", "-m", "0", "1000", "--speed", "9000"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
    assert!(r.stderr.contains("configured maximum speed 8000 rpm") && r.stderr.contains("--force"), "{}", r.stderr);
    assert!(r.stderr.contains("read_servo_speeds"), "the speeds were read: {}", r.stderr);
    assert!(!r.stderr.lines().any(|l| l.starts_with("-> 201#23")), "a goto was sent: {}", r.stderr);
    let r = run(&["--link", "sim", "--trace", "cdios-goto", "-m", "0", "1000", "--speed", "9000", "--force"]);
    assert!(r.stderr.lines().any(|l| l.starts_with("-> 201#23")), "no goto sent: {}", r.stderr);
    assert!(!r.stderr.contains("read_servo_speeds"), "{}", r.stderr);
}
