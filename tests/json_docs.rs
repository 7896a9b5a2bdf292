//! docs/json*.md stays true: every documented command is run against the
//! simulated bench and its output must have the documented shape.

mod common;

use serde_json::Value;

/// (command line, documented JSON) pairs of one markdown file.
fn examples(md: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut cmd: Option<String> = None;
    let mut lines = md.lines();
    while let Some(line) = lines.next() {
        if let Some(c) = line.strip_prefix("$ axisctl ") {
            cmd = Some(c.to_string());
        } else if line.trim() == "```json" {
            let body: Vec<&str> = lines.by_ref().take_while(|l| l.trim() != "```").collect();
            if let Some(c) = cmd.take() {
                out.push((c, body.join("\n")));
            }
        }
    }
    out
}

/// Same keys recursively and the same JSON types; arrays compare their
/// elements with the first real element's shape.
fn same_shape(doc: &Value, real: &Value, path: &str) -> Result<(), String> {
    match (doc, real) {
        (Value::Object(d), Value::Object(r)) => {
            let (dk, rk): (Vec<_>, Vec<_>) = (d.keys().collect(), r.keys().collect());
            if dk != rk {
                return Err(format!("{path}: documented keys {dk:?}, real keys {rk:?}"));
            }
            d.iter().try_for_each(|(k, v)| same_shape(v, &r[k], &format!("{path}.{k}")))
        }
        (Value::Array(d), Value::Array(r)) => match (d.first(), r.first()) {
            (Some(d0), Some(_)) => {
                r.iter().enumerate().try_for_each(|(i, v)| same_shape(d0, v, &format!("{path}[{i}]")))
            }
            _ => Ok(()),
        },
        (Value::Number(_), Value::Number(_))
        | (Value::String(_), Value::String(_))
        | (Value::Bool(_), Value::Bool(_))
        | (Value::Null, Value::Null) => Ok(()),
        _ => Err(format!("{path}: documented {doc}, real {real}")),
    }
}

/// A file with this line runs its examples in order on one served
/// simulator, so that state carries over (online mode, a referenced axis);
/// otherwise each example runs on a fresh in-process bench.
const SERVED: &str = "<!-- examples run in order on one served simulator -->";

/// The served link of the family a command belongs to.
fn family_link<'a>(sim: &'a common::Sim, args: &[&str]) -> &'a str {
    match args.iter().find(|a| !a.starts_with('-') && **a != "sim") {
        Some(c) if c.starts_with("pac-") => sim.link("pac"),
        Some(c) if c.starts_with("cdios-") => sim.link("cdios"),
        _ => sim.link("powercube"),
    }
}

#[test]
fn every_documented_example_matches_real_output() {
    let mut checked = 0;
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/docs")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if !(name.starts_with("json") && name.ends_with(".md")) {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let sim = text.contains(SERVED).then(|| common::Sim::start(&[], 3));
        for (cmd, doc) in examples(&text) {
            let mut args: Vec<&str> = cmd.split_whitespace().collect();
            assert!(args.contains(&"--json"), "{name}: example without --json: {cmd}");
            if let Some(sim) = &sim {
                let link = family_link(sim, &args);
                args.iter_mut().filter(|a| **a == "sim").for_each(|a| *a = link);
            }
            let r = common::run(&args);
            assert_eq!(r.code, 0, "{name}: `axisctl {cmd}` failed: {}", r.stderr);
            let doc: Value = serde_json::from_str(&doc).unwrap_or_else(|e| panic!("{name}: bad JSON for {cmd}: {e}"));
            if let Err(e) = same_shape(&doc, &r.json(), "$") {
                panic!("{name}: `axisctl {cmd}`: {e}");
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} examples found");
}

#[test]
fn shape_comparison_notices_differences() {
    let a: Value = serde_json::json!({"module": 17, "flags": ["X"]});
    assert!(same_shape(&a, &serde_json::json!({"module": 3, "flags": []}), "$").is_ok());
    assert!(same_shape(&a, &serde_json::json!({"module": "17", "flags": []}), "$").is_err());
    assert!(same_shape(&a, &serde_json::json!({"module": 17}), "$").is_err());
    assert!(same_shape(&a, &serde_json::json!({"module": 17, "flags": [1]}), "$").is_err());
}
