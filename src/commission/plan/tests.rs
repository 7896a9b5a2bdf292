use super::*;

const FULL: &str = r#"
[[device]]
address = "powercube:5"
identity = { kind = "rotary", serial = 12333, firmware = "4.6.01" }
limits = true
home = { timeout_s = 30 }
watchdog = true

[device.settings]
backup = "bench.json"
values = { MaxVel = { value = 1.5, tolerance = 0.01 } }

[device.move]
distance = 0.5
window = [-1.0, 1.0]
vel = 0.75
overshoot_percent = { max = 5.0 }
settling_time_s = { min = 0.1, max = 3.0 }

[device.halt]
distance = 0.5
after_s = 0.2
standstill_s = { max = 0.5 }
"#;

#[test]
fn a_full_plan_reads_and_prints_back_the_same() {
    let plan = Plan::parse(FULL, "p.toml").unwrap();
    let d = &plan.device[0];
    assert_eq!(d.identity.serial, Some(12333));
    assert_eq!(d.moves.as_ref().unwrap().band_percent, 2.0, "the default band");
    assert_eq!(d.settings.as_ref().unwrap().tolerance, 1e-6, "the default tolerance");
    assert!(d.backup, "the final backup runs unless switched off");
    let again = Plan::parse(&plan.to_toml(), "printed").unwrap();
    assert_eq!(again, plan);
}

#[test]
fn unknown_keys_are_refused_with_their_line() {
    let text = FULL.replace("overshoot_percent", "overshot_percent");
    let err = Plan::parse(&text, "p.toml").unwrap_err();
    let PlanError::Toml { line, message, .. } = &err else { panic!("{err}") };
    assert_eq!(*line, 17, "{err}");
    assert!(message.contains("overshot_percent"), "{err}");
    let err = Plan::parse("[[device]]\naddress = \"powercube:3\"\nsnap = 1\n", "p.toml").unwrap_err();
    assert!(err.to_string().contains("line 3"), "{err}");
}

#[test]
fn values_toml_cannot_check_are_refused() {
    let cases = [
        ("distance = 0.5", "distance = -0.5", "move.distance must be a positive"),
        ("window = [-1.0, 1.0]", "window = [1.0, -1.0]", "min < max"),
        ("window = [-1.0, 1.0]", "window = [-0.1, 0.1]", "wider than move.window"),
        ("max = 5.0", "max = nan", "a band needs"),
        ("{ min = 0.1, max = 3.0 }", "{ min = 3.0, max = 0.1 }", "a band needs"),
        ("standstill_s = { max = 0.5 }", "standstill_s = {}", "a band needs"),
        ("timeout_s = 30", "timeout_s = 0", "home.timeout_s"),
    ];
    for (from, to, want) in cases {
        let err = Plan::parse(&FULL.replacen(from, to, 1), "p.toml").unwrap_err();
        assert!(err.to_string().contains(want), "{to}: {err}");
    }
    let twice = format!("{FULL}\n[[device]]\naddress = \"powercube:5\"\n");
    assert!(Plan::parse(&twice, "p").unwrap_err().to_string().contains("planned twice"));
}

#[test]
fn bands_hold_inside_and_say_their_limits() {
    let b = Band { min: Some(0.1), max: Some(0.5) };
    assert!(b.holds(0.1) && b.holds(0.5) && !b.holds(0.6) && !b.holds(0.0) && !b.holds(f64::NAN));
    assert_eq!(b.text(), "0.1 .. 0.5");
    assert_eq!(Band::max(2.0).text(), "<= 2");
}

proptest::proptest! {
    /// Any text is a plan or a typed error, never a panic: cut at any
    /// byte, or a key's value swapped for another.
    #[test]
    fn any_text_parses_or_errs(cut in 0..FULL.len(), junk in "\\PC{0,40}") {
        let text = format!("{}{junk}", &FULL[..FULL.floor_char_boundary(cut)]);
        let _ = Plan::parse(&text, "p.toml");
        for value in ["nan", "inf", "-0.0", "1e308", "\"x\"", "[]", "{}", "-1"] {
            let _ = Plan::parse(&FULL.replacen("0.5", value, 1), "p.toml");
            let _ = Plan::parse(&FULL.replacen("30", value, 1), "p.toml");
        }
    }
}
