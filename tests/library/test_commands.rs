//! The test command of the README, of scripts/test.sh and of CI runs every
//! test binary even after one fails: a failure in one binary must not hide
//! what the binaries after it would have said.

use std::path::Path;

fn read(path: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Every line of `text` that runs `cargo test` over all targets (a
/// `--no-run` line only builds them).
fn test_runs(text: &str) -> Vec<&str> {
    text.lines().filter(|l| l.contains("cargo test --all-targets") && !l.contains("--no-run")).collect()
}

#[test]
fn every_documented_test_command_runs_every_test_binary() {
    for path in ["README.md", "scripts/test.sh", ".ci/run"] {
        let text = read(path);
        let runs = test_runs(&text);
        assert!(!runs.is_empty(), "{path} runs no `cargo test --all-targets`");
        for line in runs {
            assert!(line.contains("--no-fail-fast"), "{path}: stops at the first failing binary: {line}");
        }
    }
}

#[test]
fn ci_runs_the_readme_test_command() {
    let readme = read("README.md");
    let command =
        test_runs(&readme).into_iter().find(|l| l.contains("scripts/test.sh")).expect("README's test command");
    let ci = read(".ci/run");
    for part in command.trim().split(" && ") {
        assert!(
            ci.lines().any(|l| l.trim() == part.replace("scripts/", "bash scripts/") || l.trim() == part),
            "{part:?} not in .ci/run"
        );
    }
}
