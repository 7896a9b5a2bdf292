//! Shell completions, the man page and `--version`, as a user meets them:
//! the bash script sourced in a real bash, the page rendered by `man -l`.
//! bash and man are required (scripts/test.sh installs man-db): a missing
//! one fails the test rather than skipping it.

use crate::common;

use std::process::Command;

fn axisctl(args: &[&str]) -> common::Run {
    let r = common::run(args);
    assert_eq!(r.code, 0, "{args:?}: {}", r.stderr);
    r
}

fn tool(name: &str, args: &[&str]) -> std::process::Output {
    Command::new(name)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("{name} is needed by this test ({e}); scripts/test.sh installs it"))
}

/// Candidates that bash's completion function offers for `axisctl WORDS...`.
fn complete_bash(words: &[&str]) -> Vec<String> {
    common::bash_completion(words, &[])
}

#[test]
fn bash_completes_pac_a_to_the_pac_a_commands() {
    let got = complete_bash(&["pac-a"]);
    for want in ["pac-axis", "pac-axes", "pac-accel", "pac-auto-start", "pac-axis-param"] {
        assert!(got.iter().any(|c| c == want), "{want} missing from {got:?}");
    }
    assert!(got.iter().all(|c| c.starts_with("pac-a")), "{got:?}");
}

#[test]
fn bash_completes_the_options_of_a_subcommand() {
    let got = complete_bash(&["pac-move", "--w"]);
    assert!(got.iter().any(|c| c == "--wait"), "{got:?}");
}

/// The main usage: a global option's value before the subcommand is no
/// subcommand (`sim` is one too), and values come from the tables.
#[test]
fn bash_completes_after_the_link_with_options_parameters_and_commands() {
    let got = complete_bash(&["--link", "sim", "move-ramp", "--"]);
    assert!(got.iter().any(|c| c == "--vel"), "{got:?}");
    assert!(!got.iter().any(|c| c == "--wire-speed"), "the sim subcommand's flags: {got:?}");
    let got = complete_bash(&["--link", "sim", "get-param", "-m", "3", "Act"]);
    assert!(got.iter().any(|c| c == "ActPos") && got.iter().all(|c| c.starts_with("Act")), "{got:?}");
    let got = complete_bash(&["--link", "sim", ""]);
    assert!(got.iter().any(|c| c == "move-ramp") && got.iter().any(|c| c == "pac-move"), "{got:?}");
    let got = complete_bash(&["decode", "cube-"]);
    assert_eq!(got, ["cube-state"]);
    let got = complete_bash(&["--link", "si"]);
    assert_eq!(got, ["sim"]);
    let got = complete_bash(&["--link", "sim", "set-config", "-m", "3", "+brake-p"]);
    assert_eq!(got, ["+brake-present"]);
    let got = complete_bash(&["--link", "sim", "record", "-m", "17", "ActP"]);
    assert!(got.iter().any(|c| c == "ActPos"), "{got:?}");
}

#[test]
fn every_shell_gets_a_script_that_asks_this_binary() {
    let exe = env!("CARGO_BIN_EXE_axisctl");
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let r = axisctl(&["completions", shell]);
        assert!(r.stdout.contains(exe) && r.stdout.contains("AXISCTL_COMPLETE"), "{shell}: {}", r.stdout);
    }
    // fish and powershell complete the last word: asked as their scripts ask.
    for shell in ["fish", "powershell"] {
        let out = common::bin()
            .env("AXISCTL_COMPLETE", shell)
            .args(["--", "axisctl", "--link", "sim", "pac-a"])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success() && text.lines().any(|l| l.starts_with("pac-axis\t")), "{shell}: {text}");
    }
    let r = common::run(&["completions", "tcsh"]);
    assert_eq!(r.code, 2, "{}", r.stderr);
}

fn render(page: &std::path::Path) -> String {
    let out = Command::new("man")
        .args(["-P", "cat", "-l"])
        .arg(page)
        .env("MANWIDTH", "100")
        .output()
        .unwrap_or_else(|e| panic!("man is needed by this test ({e}); scripts/test.sh installs man-db"));
    assert!(out.status.success(), "man -l {}: {}", page.display(), String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

#[test]
fn the_man_page_renders_with_man_l() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("axisctl.1");
    std::fs::write(&page, axisctl(&["man"]).stdout).unwrap();
    let text = render(&page);
    for want in ["NAME", "SYNOPSIS", "OPTIONS", "axisctl", "pac-move", "cdios-goto", "--json"] {
        assert!(text.contains(want), "{want} missing from the rendered page:\n{text}");
    }
    assert!(!text.contains(".TH") && !text.contains("\\fB"), "roff left unrendered:\n{text}");
}

#[test]
fn man_dir_writes_one_page_per_subcommand() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("man1");
    axisctl(&["man", "--dir", target.to_str().unwrap()]);
    for name in ["axisctl.1", "axisctl-pac-move.1", "axisctl-move-ramp.1", "axisctl-cdios-goto.1"] {
        assert!(target.join(name).is_file(), "{name} not written");
    }
    let text = render(&target.join("axisctl-pac-move.1"));
    assert!(text.contains("--wait"), "{text}");
}

#[test]
fn version_names_the_git_commit_of_the_checkout() {
    let shown = axisctl(&["--version"]).stdout;
    let head = tool("git", &["-C", env!("CARGO_MANIFEST_DIR"), "rev-parse", "--short=12", "HEAD"]);
    let head = String::from_utf8_lossy(&head.stdout).trim().to_string();
    assert!(head.len() == 12, "the tests run in a git checkout");
    assert_eq!(shown.trim(), format!("axisctl {} (git {head})", env!("CARGO_PKG_VERSION")));
}
