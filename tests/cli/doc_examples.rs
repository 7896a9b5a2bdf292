//! Every example command of README.md and docs/ (outside docs/json*.md,
//! which tests/cli/json_docs.rs runs and compares) that runs on the
//! simulated bench runs as written: in code blocks and in running text,
//! one file's lines in one scratch directory (a line that reads a file an
//! earlier line wrote runs after it), each exiting 0. Lines that need a
//! terminal or real hardware are listed with the test that covers them.

use crate::common;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// Example lines not run here, and why (each must still be in the docs).
const ELSEWHERE: &[(&str, Covered)] = &[
    ("axisctl --link sim dashboard", Covered::Test("tests/cli/dashboard_tmux.rs")),
    ("axisctl --bench docs/sim-bench.toml dashboard", Covered::Test("tests/cli/dashboard_tmux.rs")),
    ("axisctl --link sim shell", Covered::Test("tests/cli/shell_tmux.rs")),
    ("axisctl --link sim move-ramp --<Tab>", Covered::Test("tests/cli/completions_man.rs")),
    (
        "axisctl --link sim commission --print-plan > plan.toml     # the default plan, to edit",
        Covered::Help("commission"),
    ),
    ("axisctl --link sim commission --plan plan.toml --out handover --yes", Covered::Help("commission")),
    (
        "axisctl --link sim commission --out check --dry-run        # no motion: reads, lists the motions",
        Covered::Help("commission"),
    ),
];

/// Where a line not run here is run or checked.
#[derive(Debug)]
enum Covered {
    /// By a test of this file (a terminal UI, an interactive shell, a
    /// completion: what a line of shell cannot drive).
    Test(&'static str),
    /// It is an example of this subcommand's `--help` (comments aside),
    /// which tests/cli/json_docs.rs runs as written (those that commission
    /// the whole bench, tests/cli/commission.rs).
    Help(&'static str),
}

/// Whether a command runs on the simulated bench: its link is `sim`.
fn on_sim(cmd: &str) -> bool {
    ["axisctl --link sim ", "axisctl --link 'sim?", "axisctl --bench docs/sim-bench.toml "]
        .iter()
        .any(|p| cmd.starts_with(p))
}

/// The example commands of one Markdown text: indented code lines and
/// inline code spans that start with `axisctl`.
fn commands(md: &str) -> Vec<String> {
    let mut out = Vec::new();
    for line in md.lines() {
        if let Some(code) = line.strip_prefix("    ") {
            out.push(code.trim().to_string());
        }
        out.extend(line.split('`').skip(1).step_by(2).map(|s| s.trim().to_string()));
    }
    out.retain(|c| c.starts_with("axisctl "));
    out
}

fn docs() -> Vec<(String, String)> {
    let mut files = vec![format!("{ROOT}/README.md")];
    for e in std::fs::read_dir(format!("{ROOT}/docs")).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        if name.ends_with(".md") && !name.starts_with("json") {
            files.push(p.to_string_lossy().to_string());
        }
    }
    files.sort();
    files.into_iter().map(|f| (f.clone(), std::fs::read_to_string(&f).unwrap())).collect()
}

#[test]
fn every_sim_example_of_the_docs_runs_as_written() {
    let _busy = common::heavy::slot();
    let mut lines = Vec::new();
    let mut skipped = Vec::new();
    for (_, text) in docs() {
        let mut found: Vec<String> = commands(&text).into_iter().filter(|c| on_sim(c)).collect();
        found.dedup();
        for l in found {
            match ELSEWHERE.iter().any(|(e, _)| l == *e) {
                true => skipped.push(l),
                false => lines.push(l),
            }
        }
    }
    assert!(lines.len() > 15, "only {} examples found", lines.len());
    for (line, covered) in ELSEWHERE {
        assert!(skipped.iter().any(|s| s == line), "{line} ({covered:?}) is no longer in the docs");
        match covered {
            Covered::Help(sub) => {
                let help = common::run(&[sub, "--help"]).stdout;
                let bare = line.split(" #").next().unwrap().trim();
                assert!(help.lines().any(|l| l.trim() == bare), "{bare} is not an example of `{sub} --help`");
            }
            Covered::Test(file) => assert!(std::path::Path::new(ROOT).join(file).is_file(), "{file} for {line}"),
        }
    }
    // One scratch directory: the files one line writes and a later one
    // reads order them (in the files' order: README.md, then docs/ by name).
    let cwd = tempfile::tempdir().unwrap();
    std::os::unix::fs::symlink(format!("{ROOT}/docs"), cwd.path().join("docs")).unwrap();
    let failed = common::pool::failing_lines(&lines, cwd.path(), 120);
    assert!(failed.is_empty(), "doc examples that fail as written:\n{}", failed.join("\n"));
}

#[test]
fn examples_are_found_in_code_blocks_and_running_text() {
    let md = "Text `axisctl --link sim state -m 3` and `x`.\n\n    axisctl --link sim scan   # a comment\n    other\n";
    assert_eq!(commands(md), ["axisctl --link sim state -m 3", "axisctl --link sim scan   # a comment"]);
    assert!(on_sim("axisctl --link 'sim?pac=online' pac-move 2 150") && !on_sim("axisctl --link slcan:/dev/x scan"));
}
