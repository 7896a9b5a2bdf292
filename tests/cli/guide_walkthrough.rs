//! docs/guide.md "Commissioning a replacement module" works as written: its
//! two blocks of commands run against a served bench, the second against a
//! fresh one (the replacement module, with factory settings), and each
//! step says what the text claims.

use crate::common;

use std::path::Path;

use common::Sim;

/// The command lines of each indented block of the walk-through section.
fn blocks() -> Vec<Vec<String>> {
    let guide = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/guide.md")).unwrap();
    let section = guide.split("\n## Commissioning a replacement module\n").nth(1).expect("the section");
    let section = section.split("\n## ").next().unwrap();
    let mut blocks: Vec<Vec<String>> = Vec::new();
    let mut in_block = false;
    for line in section.lines() {
        match line.strip_prefix("    axisctl ") {
            Some(cmd) => {
                if !in_block {
                    blocks.push(Vec::new());
                }
                in_block = true;
                blocks.last_mut().unwrap().push(cmd.split("  #").next().unwrap().trim().to_string());
            }
            None => in_block = false,
        }
    }
    blocks
}

/// The words of a command line as a shell splits them (double quotes),
/// `$L` replaced, and the file its stdout is redirected to.
fn words(line: &str, link: &str) -> (Vec<String>, Option<String>) {
    let (cmd, out) = match line.split_once(" > ") {
        Some((c, f)) => (c, Some(f.trim().to_string())),
        None => (line, None),
    };
    let mut words = Vec::new();
    for (i, part) in cmd.split('"').enumerate() {
        if i % 2 == 1 {
            words.push(part.to_string());
        } else {
            words.extend(part.split_whitespace().map(|w| w.replace("$L", link)));
        }
    }
    (words, out)
}

/// Runs one line in `dir`; returns its stdout.
fn run_line(dir: &Path, line: &str, link: &str) -> String {
    let (args, out) = words(line, link);
    let r = common::bin().current_dir(dir).args(&args).output().unwrap();
    let stdout = String::from_utf8_lossy(&r.stdout).into_owned();
    assert!(r.status.success(), "`axisctl {line}`: {}", String::from_utf8_lossy(&r.stderr));
    if let Some(file) = out {
        std::fs::write(dir.join(file), &stdout).unwrap();
    }
    stdout
}

#[test]
fn the_replacement_walk_through_runs_as_written() {
    let blocks = blocks();
    assert_eq!(blocks.len(), 2, "{blocks:?}");
    let dir = tempfile::tempdir().unwrap();
    let mut outputs = Vec::new();
    {
        let old = Sim::start(&[], 3);
        for line in &blocks[0] {
            run_line(dir.path(), line, old.link("powercube"));
        }
    }
    let new = Sim::start(&[], 3);
    for line in &blocks[1] {
        outputs.push((line.clone(), run_line(dir.path(), line, new.link("powercube"))));
    }
    let said = |start: &str| -> Vec<&str> {
        outputs.iter().filter(|(l, _)| l.starts_with(start)).map(|(_, out)| out.as_str()).collect()
    };
    let diffs = said("--link $L diff arm.json");
    assert!(diffs[0].contains("MaxVel") && diffs[0].contains("ActC0"), "the new module differs: {}", diffs[0]);
    assert!(diffs[1].starts_with("no differences"), "nothing is left: {}", diffs[1]);
    let restores = said("--link $L restore m17.json --to 17");
    assert!(restores[0].contains("dry run: nothing was written"), "{}", restores[0]);
    assert!(restores[1].contains("restore: 2 written"), "{}", restores[1]);
    for name in ["before", "after"] {
        let svg = std::fs::read_to_string(dir.path().join(format!("{name}.svg"))).unwrap();
        assert!(svg.contains(&format!("module 17 {name}")), "the title");
        for label in ["[m]", "[m/s]", "[A]"] {
            assert!(svg.contains(label), "{name}.svg has no axis {label}");
        }
    }
}
