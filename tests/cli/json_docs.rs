//! docs/json*.md stays true: every documented command is run against the
//! simulated bench and its output must have the documented shape and
//! validate against the published schema (schema/axisctl.schema.json).

use crate::common;

use serde_json::Value;

use common::{schema, schema_errors};

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

/// Same keys recursively and the same JSON types; each real element of an
/// array has the shape of one of the documented elements (a list of
/// devices of several families documents one element of each kind).
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
            (Some(d0), Some(_)) => r.iter().enumerate().try_for_each(|(i, v)| {
                let at = format!("{path}[{i}]");
                match d.iter().any(|de| same_shape(de, v, &at).is_ok()) {
                    true => Ok(()),
                    false => same_shape(d0, v, &at),
                }
            }),
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
    let _busy = common::heavy::slot();
    let (document, stream) = (schema("document"), schema("stream_line"));
    // A stream's example is one line of it.
    let streams = ["cdios-watch", "record"];
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
            let r = if sim.is_some() { common::run_served(&args) } else { common::run(&args) };
            assert_eq!(r.code, 0, "{name}: `axisctl {cmd}` failed: {}", r.stderr);
            let doc: Value = serde_json::from_str(&doc).unwrap_or_else(|e| panic!("{name}: bad JSON for {cmd}: {e}"));
            if let Err(e) = same_shape(&doc, &r.json(), "$") {
                panic!("{name}: `axisctl {cmd}`: {e}");
            }
            let schema = if args.iter().any(|a| streams.contains(a)) { &stream } else { &document };
            for (what, v) in [("real output", r.json()), ("documented example", doc)] {
                if let Some(e) = schema_errors(schema, &v) {
                    panic!("{name}: `axisctl {cmd}`: the {what} breaks the schema:\n{e}");
                }
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "only {checked} examples found");
}

/// Commands whose --json output is no single document: the dashboard is a
/// terminal UI, `monitor` and `sim` stream JSON Lines (docs/guide.md).
/// Commands that print no JSON document: the dashboard, streams, and the
/// shell scripts and man pages generated from the parser. `batch` and
/// `shell` print one `$defs/batch_line` object per line of other commands
/// (docs/json.md, checked by tests/cli/batch_cli.rs).
const NOT_DOCUMENTS: [&str; 8] = ["dashboard", "help", "monitor", "sim", "completions", "man", "batch", "shell"];

// Every command's JSON is documented, so every command's output is checked
// against the schema by the test above.
#[test]
fn every_command_has_a_documented_example() {
    let help = common::run(&["--help"]).stdout;
    let commands: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(commands.len() > 40, "{help}");
    let mut documented = std::collections::BTreeSet::new();
    for entry in std::fs::read_dir(concat!(env!("CARGO_MANIFEST_DIR"), "/docs")).unwrap() {
        let path = entry.unwrap().path();
        if !path.file_name().unwrap().to_string_lossy().starts_with("json") {
            continue;
        }
        for (cmd, _) in examples(&std::fs::read_to_string(&path).unwrap()) {
            let words: Vec<&str> = cmd.split_whitespace().collect();
            // The first word that is neither an option nor an option's value.
            let mut i = 0;
            while i < words.len() && words[i].starts_with('-') {
                i += if matches!(words[i], "--link" | "--timeout" | "--retries" | "--log") { 2 } else { 1 };
            }
            documented.extend(words.get(i).map(|w| w.to_string()));
        }
    }
    let missing: Vec<&&str> =
        commands.iter().filter(|c| !NOT_DOCUMENTS.contains(c) && !documented.contains(**c)).collect();
    assert!(missing.is_empty(), "no documented --json example for {missing:?}");
}

#[test]
fn shape_comparison_notices_differences() {
    let a: Value = serde_json::json!({"module": 17, "flags": ["X"]});
    assert!(same_shape(&a, &serde_json::json!({"module": 3, "flags": []}), "$").is_ok());
    assert!(same_shape(&a, &serde_json::json!({"module": "17", "flags": []}), "$").is_err());
    assert!(same_shape(&a, &serde_json::json!({"module": 17}), "$").is_err());
    assert!(same_shape(&a, &serde_json::json!({"module": 17, "flags": [1]}), "$").is_err());
    // An array's real elements each take the shape of one documented element.
    let kinds = serde_json::json!({"d": [{"a": 1}, {"b": "x"}]});
    assert!(same_shape(&kinds, &serde_json::json!({"d": [{"b": "y"}, {"a": 2}, {"a": 3}]}), "$").is_ok());
    assert!(same_shape(&kinds, &serde_json::json!({"d": [{"a": 2}, {"c": 1}]}), "$").is_err());
}

// The schema is no formality: each convention it states rejects output
// that breaks it.
#[test]
fn schema_rejects_broken_conventions() {
    let document = schema("document");
    let detail = serde_json::json!({"name": "SHORT_NOT_OK", "mask": 1, "class": "warning", "description": "not ok"});
    let good = serde_json::json!({"family": "powercube", "module": 17, "link": "sim",
        "short_state": {"raw": 1, "flags": ["SHORT_NOT_OK"], "errors": [], "warnings": ["SHORT_NOT_OK"],
                        "details": [detail], "unknown_bits": 0},
        "state": {"raw": 0, "flags": [], "errors": [], "warnings": [], "details": [], "unknown_bits": 0}});
    assert_eq!(schema_errors(&document, &good), None);
    let broken = |path: &str, v: Value| {
        let mut doc = good.clone();
        *doc.pointer_mut(path).unwrap() = v;
        doc
    };
    for bad in [
        broken("/module", Value::from(0)),
        broken("/family", Value::from("pa-control")),
        broken("/state/unknown_bits", serde_json::json!([])),
        broken("/short_state/details/0/class", Value::from("fatal")),
        broken("/state", Value::from(1)),
        // The short state's old shape, a bare integer.
        broken("/short_state", Value::from(1)),
        serde_json::json!({"foo": 1}),
        serde_json::json!({}),
        serde_json::json!({"family": "cdios", "link": "sim", "module": 0}),
        serde_json::json!({"module": 3, "error": 0}),
        serde_json::json!({"devices": [{"module": 3}]}),
        serde_json::json!({"family": "pac", "link": "sim", "axis": 2, "position": 200.5}),
        serde_json::json!({"family": "cdios", "link": "sim", "node": 1, "module": 0, "motor_speed": 300}),
        // A broadcast names no module; a module's command is no broadcast.
        serde_json::json!({"family": "powercube", "link": "sim", "module": 17, "command": "home",
                           "acknowledged": false, "broadcast": true}),
        serde_json::json!({"family": "powercube", "link": "sim", "module": null, "command": "home", "acknowledged": true}),
        // A PA-CONTROL move always says where it goes.
        serde_json::json!({"family": "pac", "link": "sim", "axis": 2, "command": "pac-move", "manual_command": "move-absolute",
                           "command_code": "0A94", "acknowledged": true, "done": false}),
        // A PowerCube move's old bare target.
        serde_json::json!({"family": "powercube", "link": "sim", "module": 17, "command": "move-ramp",
                           "acknowledged": true, "target": 0.1}),
    ] {
        assert!(document.iter_errors(&bad).next().is_some(), "accepted {bad}");
    }
    let error = schema("error_document");
    assert_eq!(
        schema_errors(&error, &serde_json::json!({"error": {"kind": "usage", "exit_code": 2, "message": "x"}})),
        None
    );
    for bad in [
        serde_json::json!({"error": {"kind": "usage", "exit_code": 5, "message": "x"}}),
        serde_json::json!({"error": {"kind": "usage", "message": "x"}}),
        serde_json::json!({"error": {"kind": "timeout", "exit_code": 4, "message": "x", "device": {}}}),
    ] {
        assert!(schema_errors(&error, &bad).is_some(), "accepted {bad}");
    }
}

/// A real document turns invalid with an unknown key at the top level and
/// in every nested object (a `{value, unit}`, the `state`, a detail), and
/// the check that every test's schema validation makes
/// (`common::schema_errors`) notices a schema that leaves one object open:
/// the published schema with `additionalProperties: false` taken off
/// `{value, unit}` accepts `position.axisctl_unknown_key`.
#[test]
fn an_unknown_key_in_any_object_of_a_real_document_makes_it_invalid() {
    let r = common::run(&["--link", "sim", "--json", "pac-axis", "2"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let doc = r.json();
    let document = schema("document");
    assert_eq!(schema_errors(&document, &doc), None, "{doc}");
    let variants = common::with_an_unknown_key(&doc);
    let at: Vec<&str> = variants.iter().map(|(p, _)| p.as_str()).collect();
    for p in ["", "/position", "/speed", "/state", "/state/details/0"] {
        assert!(at.contains(&p), "no copy with a key added at {p:?}: {at:?}");
    }
    for (p, d) in &variants {
        assert!(document.iter_errors(d).next().is_some(), "an unknown key at {p:?} is accepted");
    }

    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/schema/axisctl.schema.json")).unwrap();
    let mut open: Value = serde_json::from_str(&text).unwrap();
    let value = open.pointer_mut("/$defs/value").and_then(Value::as_object_mut).unwrap();
    assert_eq!(value.remove("additionalProperties"), Some(Value::Bool(false)));
    open.as_object_mut().unwrap().remove("anyOf");
    open["$ref"] = Value::from("#/$defs/document");
    let loose = jsonschema::validator_for(&open).unwrap();
    let said = schema_errors(&loose, &doc).expect("the open {value, unit} is noticed");
    assert!(said.contains("\"/position\""), "{said}");
    assert!(!said.contains("\"\" "), "{said}");
}

/// Beyond the documented examples: every `--link sim` example of every
/// subcommand's own help, run with `--json`, prints one document that the
/// schema accepts (JSON Lines of stream lines for a stream), or on failure
/// one error object on stderr carrying the exit code.
#[test]
fn every_help_example_under_json_follows_the_schema() {
    let _busy = common::heavy::slot();
    let (document, stream, error) = (schema("document"), schema("stream_line"), schema("error_document"));
    let mut subs = Vec::new();
    common::subcommands_and_sim_examples(&[], &mut subs);
    // Text, a terminal UI, or streams that run until stopped (tests/cli/json_streams.rs).
    let text_only = ["completions", "man", "sim", "dashboard", "watchdog keepalive", "cdios-watch", "monitor"];
    let mut runs: Vec<Vec<String>> = Vec::new();
    for (path, examples) in subs {
        if text_only.iter().any(|t| path == *t || path.starts_with(&format!("{t} "))) {
            continue;
        }
        for words in examples {
            let command: Vec<&str> =
                words.iter().map(String::as_str).skip(2).skip_while(|w| w.starts_with("--")).collect();
            if text_only.iter().any(|t| command.join(" ").starts_with(t)) {
                continue;
            }
            // `--link LINK` first, then `--json`.
            let mut args: Vec<String> = words.into_iter().filter(|w| w != "--json").collect();
            args.insert(2, "--json".into());
            runs.push(args);
        }
    }
    // Examples write files (`backup --out bench.json`): never into the checkout.
    let cwd = concat!(env!("CARGO_TARGET_TMPDIR"), "/json-docs-cwd");
    std::fs::create_dir_all(cwd).unwrap();
    // A few at a time; one that names a file an earlier one wrote runs after it.
    let lines: Vec<String> = runs.iter().map(|a| a.join(" ")).collect();
    let (documents, errors) = (std::sync::atomic::AtomicUsize::new(0), std::sync::atomic::AtomicUsize::new(0));
    common::pool::each_after(&runs, &common::pool::after_their_files(&lines), |args| {
        let out = common::bin().current_dir(cwd).args(args).output().unwrap();
        let r = common::Run {
            code: out.status.code().unwrap_or(-1),
            stdout: String::from_utf8_lossy(&out.stdout).into(),
            stderr: String::from_utf8_lossy(&out.stderr).into(),
        };
        if r.code == 0 {
            let docs: Vec<(Value, &jsonschema::Validator)> = match serde_json::from_str::<Value>(&r.stdout) {
                Ok(v) => vec![(v, &document)],
                Err(_) => r.stdout.lines().map(|l| (serde_json::from_str(l).unwrap(), &stream)).collect(),
            };
            for (v, schema) in docs {
                if let Some(e) = schema_errors(schema, &v) {
                    panic!("`axisctl {}`: {v} breaks the schema:\n{e}", args.join(" "));
                }
            }
            documents.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        } else {
            let line = r.stderr.lines().last().unwrap_or_default();
            let v: Value = serde_json::from_str(line).unwrap_or_else(|e| panic!("{args:?}: {e}: {}", r.stderr));
            if let Some(e) = schema_errors(&error, &v) {
                panic!("`axisctl {}`: {v} breaks the schema:\n{e}", args.join(" "));
            }
            assert_eq!(v["error"]["exit_code"], r.code, "{args:?}");
            errors.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        }
    });
    let (documents, errors) = (documents.into_inner(), errors.into_inner());
    assert!(documents > 60, "only {documents} examples printed a document ({errors} errors)");
}

/// Every `--link sim` example of every `--help` page, run as written by bash
/// (redirections, `&&` and comments included) on the binary under test, in
/// the order the pages come: all exit 0 and end. An example that needs a
/// state gets it from its link (`sim?pac=online`, `sim?cdios=enabled`,
/// `sim?pac=automatic`) or from an earlier example (`backup --out bench.json`
/// before `restore bench.json`); files of the checkout are reached as
/// `docs/...`. The dashboard needs a terminal (tests/cli/dashboard_tmux.rs).
#[test]
fn every_sim_example_of_every_help_runs_as_written_and_ends() {
    let _busy = common::heavy::slot();
    fn pages(path: &[String], out: &mut Vec<String>) {
        let mut args: Vec<&str> = path.iter().map(String::as_str).collect();
        args.push("--help");
        let help = common::run(&args).stdout;
        let section = |name: &str| -> Vec<String> {
            help.split(&format!("\n{name}:\n"))
                .nth(1)
                .map(|s| s.lines().take_while(|l| l.starts_with("  ") || l.is_empty()).map(str::to_string).collect())
                .unwrap_or_default()
        };
        for line in section("Examples") {
            let line = line.trim();
            if ["axisctl --link sim ", "axisctl --link 'sim?", "axisctl --bench docs/sim-bench.toml "]
                .iter()
                .any(|p| line.starts_with(p))
            {
                out.push(line.to_string());
            }
        }
        for line in section("Commands") {
            let Some(name) = line.split_whitespace().next().filter(|n| *n != "help") else { continue };
            let mut sub = path.to_vec();
            sub.push(name.to_string());
            pages(&sub, out);
        }
    }
    let mut examples = Vec::new();
    pages(&[], &mut examples);
    examples.dedup();
    assert!(examples.len() > 100, "only {} examples found", examples.len());
    let cwd = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(concat!(env!("CARGO_MANIFEST_DIR"), "/docs"), cwd.path().join("docs")).unwrap();
    // A few at a time; a line that names a file an earlier line wrote runs after it.
    // The dashboard needs a terminal (tests/cli/dashboard_tmux.rs); the
    // whole bench's commissioning runs in its own test.
    let elsewhere = crate::commission::WHOLE_BENCH_EXAMPLES;
    let examples: Vec<String> =
        examples.into_iter().filter(|l| !l.contains(" dashboard") && !elsewhere.contains(&l.as_str())).collect();
    let failed = common::pool::failing_lines(&examples, cwd.path(), 120);
    assert!(failed.is_empty(), "help examples that fail as written:\n{}", failed.join("\n"));
}

#[test]
fn the_example_pool_orders_by_files_and_runs_everything() {
    let lines: Vec<String> = [
        "axisctl --link sim backup --out bench.json",
        "axisctl --link sim state -m 3",
        "axisctl --link sim diff bench.json",
        "axisctl --link sim commission --print-plan > plan.toml",
        "axisctl --link sim commission --plan plan.toml --out handover --yes",
        "axisctl --link sim backup --out - | axisctl --link sim diff -",
    ]
    .map(String::from)
    .to_vec();
    let after = common::pool::after_their_files(&lines);
    assert_eq!(after, [vec![], vec![], vec![0], vec![], vec![3], vec![]]);
    let order = std::sync::Mutex::new(Vec::new());
    common::pool::each_after(&lines, &after, |l| {
        std::thread::sleep(std::time::Duration::from_millis(if l.contains("backup --out bench") { 50 } else { 1 }));
        order.lock().unwrap().push(l.clone());
    });
    let order = order.into_inner().unwrap();
    assert_eq!(order.len(), lines.len());
    let at = |s: &str| order.iter().position(|l| l == s).unwrap();
    assert!(at(&lines[0]) < at(&lines[2]), "{order:?}");
    assert!(at(&lines[3]) < at(&lines[4]), "{order:?}");
    // A panic is raised after every item ran, not lost and not a deadlock.
    let ran = std::sync::Mutex::new(0);
    let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        common::pool::each_after(&lines, &after, |l| {
            *ran.lock().unwrap() += 1;
            assert!(!l.contains("bench.json --out"), "never");
            assert!(!l.starts_with("axisctl --link sim backup --out bench"), "the first fails");
        })
    }));
    assert!(caught.is_err());
    assert_eq!(*ran.lock().unwrap(), lines.len());
}

/// At most two busy tests at once, and a busy test that panics gives its
/// slot back.
#[test]
fn the_busy_slots_hold_two_at_a_time_and_come_back_after_a_panic() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let slots = common::heavy::Slots::new(2);
    let (now, most) = (AtomicUsize::new(0), AtomicUsize::new(0));
    std::thread::scope(|s| {
        for i in 0..6 {
            let (slots, now, most) = (&slots, &now, &most);
            s.spawn(move || {
                let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    let _slot = slots.take();
                    let n = now.fetch_add(1, Ordering::SeqCst) + 1;
                    most.fetch_max(n, Ordering::SeqCst);
                    // Holds its slot until a second holder came (or 2 s
                    // passed), then a moment more for a wrongful third.
                    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(2);
                    while now.load(Ordering::SeqCst) < 2 && std::time::Instant::now() < deadline {
                        std::thread::sleep(std::time::Duration::from_millis(1));
                    }
                    most.fetch_max(now.load(Ordering::SeqCst), Ordering::SeqCst);
                    std::thread::sleep(std::time::Duration::from_millis(20));
                    now.fetch_sub(1, Ordering::SeqCst);
                    assert!(i % 2 == 0, "a busy test that fails");
                }));
            });
        }
    });
    assert_eq!(most.into_inner(), 2);
    assert_eq!(slots.taken(), 0);
}
