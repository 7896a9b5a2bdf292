//! Names people can find: `params` and `flags` list them offline from the
//! protocol tables, and a misspelled one gets the name it is near.

use crate::common;

use common::run;

fn ok(args: &[&str]) -> common::Run {
    let r = run(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    r
}

#[test]
fn params_lists_every_family_offline() {
    let all = ok(&["params"]).stdout;
    for name in ["ActPos", "TargetVel", "number-of-axes", "acceleration", "speeds.maximum_speed"] {
        assert!(all.contains(name), "{name} missing");
    }
    let pac = ok(&["params", "pac"]).stdout;
    assert!(pac.contains("number-of-axes") && !pac.contains("ActPos"), "{pac}");
    let v: serde_json::Value = serde_json::from_str(&ok(&["--json", "params", "cdios"]).stdout).unwrap();
    let max = v["parameters"]["cdios"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "speeds.maximum_speed")
        .expect("field");
    assert_eq!((max["unit"].as_str(), max["range"].as_str()), (Some("rpm"), Some("50 to 32000")), "{max}");
    assert_eq!(run(&["params", "robots"]).code, 2);
}

#[test]
fn flags_lists_a_word_or_the_flags_matching_a_word() {
    let config = ok(&["flags", "config"]).stdout;
    assert!(config.contains("CONFIGID_MOD_BRAKE_PRESENT") && config.contains("brake-present"), "{config}");
    assert!(!config.contains("STATE_HOME_OK"), "{config}");
    let brake = ok(&["flags", "brake"]).stdout;
    assert!(brake.contains("STATE_BRAKEACTIVE") && brake.contains("CONFIGID_MOD_BRAKE_PRESENT"), "{brake}");
    let cdios = ok(&["--json", "flags", "cdios-status"]).stdout;
    assert!(cdios.contains("\"GOTO_ACTIVE\""), "{cdios}");
    let r = run(&["flags", "cube-stat"]);
    assert_eq!(r.code, 2);
    assert!(r.stderr.contains("did you mean cube-state?"), "{}", r.stderr);
}

/// Refused with the nearest name before the link opens: the link here does
/// not exist, so reaching it would be exit 3.
#[test]
fn misspelled_names_get_did_you_mean_before_anything_opens() {
    let nowhere = "serial:/dev/axisctl-no-such-port";
    for (args, want) in [
        (&["get-param", "-m", "3", "ActPoss", "CubeState"][..], "did you mean one of ActPos, ActPos_?"),
        (&["set-param", "-m", "3", "MaxVell", "0.1"], "did you mean MaxVel?"),
        (&["record", "-m", "3", "ActCur", "--count", "1"], "did you mean Cur?"),
        (&["set-config", "-m", "3", "+brake-presnt"], "did you mean brake-present?"),
        (&["set-config", "-m", "3", "-CONFIGID_MOD_BRAKE_PRESNT"], "did you mean CONFIGID_MOD_BRAKE_PRESENT?"),
        (&["cdios-config", "-m", "0", "speeds.maximum_sped=5000"], "did you mean speeds.maximum_speed?"),
        (&["cdios-config", "-m", "0", "speedz"], "did you mean speeds?"),
        (&["decode", "cube-stat", "1"], "did you mean cube-state?"),
    ] {
        let mut all = vec!["--link", nowhere];
        all.extend_from_slice(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(want), "{args:?}: {}", r.stderr);
    }
    for (args, want) in [
        (&["pac-sys-param", "numbr-of-axes"][..], "did you mean number-of-axes?"),
        (&["pac-axis-param", "2", "acceleraton"], "did you mean acceleration?"),
    ] {
        let mut all = vec!["--link", "sim"];
        all.extend_from_slice(args);
        let r = run(&all);
        assert_eq!(r.code, 2, "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(want), "{args:?}: {}", r.stderr);
    }
    // Names that are right pass, in any case.
    ok(&["--link", "sim", "get-param", "-m", "17", "actpos", "0x3c"]);
}

/// Words that look like PowerCube parameter names (a table prefix such as
/// `Act`, `Def`, `Max` and a capital after it) in every `--help` page, the
/// README and docs/: each is a parameter of the table, or a pattern of
/// them (`ActI*`), or a misspelling shown as such (`"MaxVell" (did you
/// mean`). Issue 25: `record --help` named `ActCur`, which does not exist.
#[test]
fn every_parameter_named_in_help_or_docs_exists() {
    let table: serde_json::Value = run(&["--json", "params", "powercube"]).json();
    let names: std::collections::HashSet<&str> =
        table["parameters"]["powercube"].as_array().unwrap().iter().map(|p| p["name"].as_str().unwrap()).collect();
    let mut texts: Vec<(String, String)> =
        common::help_pages().into_iter().map(|(p, t)| (format!("axisctl {p} --help"), t)).collect();
    let root = env!("CARGO_MANIFEST_DIR");
    for entry in std::fs::read_dir(format!("{root}/docs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "md") {
            texts.push((path.display().to_string(), std::fs::read_to_string(&path).unwrap()));
        }
    }
    texts.push(("README.md".into(), std::fs::read_to_string(format!("{root}/README.md")).unwrap()));
    const PREFIXES: [&str; 8] = ["Act", "Def", "Target", "Max", "Min", "Home", "Cur", "Delta"];
    let mut unknown = Vec::new();
    for (what, text) in &texts {
        let mut words = Vec::new();
        let mut start = None;
        for (i, c) in text.char_indices().chain([(text.len(), ' ')]) {
            match (c.is_ascii_alphanumeric(), start) {
                (true, None) => start = Some(i),
                (false, Some(s)) => {
                    words.push((s, i));
                    start = None;
                }
                _ => {}
            }
        }
        for (start, end) in words {
            let (word, after) = (&text[start..end], &text[end..]);
            let looks_like = PREFIXES.iter().any(|p| {
                word.strip_prefix(p)
                    .is_some_and(|rest| rest.starts_with(|c: char| c.is_ascii_uppercase() || c.is_ascii_digit()))
            });
            let pattern = after.starts_with('*') && names.iter().any(|n| n.starts_with(word));
            let shown_wrong = after.starts_with("\" (did you mean");
            if looks_like && !names.contains(word) && !pattern && !shown_wrong {
                unknown.push(format!("{what}: {word}"));
            }
        }
    }
    assert!(texts.len() > 60, "only {} texts read", texts.len());
    assert!(unknown.is_empty(), "names that are no PowerCube parameter:\n{}", unknown.join("\n"));
}
