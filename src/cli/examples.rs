//! The EXAMPLES section of every subcommand's help, kept apart from the
//! flags so they read as a list. `tests` parses each example with the real
//! parser, so none can go stale.

/// (subcommand path, example command lines after `axisctl`).
pub const EXAMPLES: &[(&str, &[&str])] = &[
    (
        "scan",
        &[
            "--link socketcan:can0 scan",
            "--link sim --json scan -m 3,5,17",
            "--link sim --json scan -d powercube:3,pac:2,cdios:1/0",
        ],
    ),
    ("info", &["--link sim info -m 17"]),
    (
        "state",
        &["--link sim state -m 17", "--link sim --json state -m 17", "--link sim state -d powercube:3,powercube:5"],
    ),
    ("home", &["--link sim home -m 17 --wait", "--link sim home --all"]),
    ("reset", &["--link sim reset -m 17", "--link sim reset --all"]),
    ("halt", &["--link sim halt -m 17", "--link sim halt --all", "--link sim halt -d powercube:3,pac:2,cdios:1/0"]),
    (
        "move-ramp",
        &[
            "--link sim move-ramp -m 17 0.1 --vel 0.05 --wait",
            "--link sim move-ramp -m 3 -0.5 --relative --wait",
            "--link socketcan:can0 move-ramp -m 3,5 --sync 0.5 -0.5",
        ],
    ),
    (
        "move-step",
        &["--link sim move-step -m 17 0.05 --time 2000", "--link sim move-step -m 3 -0.1 --relative --time 500"],
    ),
    ("move-vel", &["--link sim move-vel -m 3 -0.05", "--link sim move-vel -d powercube:3 0"]),
    ("move-cur", &["--link sim move-cur -m 3 0.5"]),
    (
        "get-param",
        &[
            "--link sim get-param -m 17 ActPos CubeState",
            "--link sim --json get-param -m 17 0x3c",
            "--link sim get-param -m 17 --all",
        ],
    ),
    ("set-param", &["--link sim set-param -m 17 MaxVel 0.1", "--link sim set-param -m 3 MinPos -0.25"]),
    ("get-config", &["--link sim get-config -m 17"]),
    (
        "set-config",
        &["--link sim set-config -m 17 +brake-present -sync-motion", "--link sim set-config -m 17 -brake-present"],
    ),
    ("dio", &["--link sim dio -m 17", "--link sim dio -m 17 --out 0b0101"]),
    (
        "watchdog",
        &[
            "--link sim watchdog on -m 17",
            "--link sim watchdog keepalive --interval 20 --for 2",
            "--link sim watchdog off -m 17",
        ],
    ),
    ("watchdog on", &["--link sim watchdog on -m 17"]),
    ("watchdog off", &["--link sim watchdog off -m 17"]),
    ("watchdog keepalive", &["--link sim watchdog keepalive --interval 20 --for 2"]),
    (
        "decode",
        &["decode cube-state 0x0800000b", "--json decode config 0x00000001", "decode pac-ext-axis-status 0x0003"],
    ),
    (
        "sim",
        &[
            "sim",
            "sim --pac pty-serial",
            "sim --powercube pty-slcan -m 3,5 --linear 5",
            "sim --fault drop=0.2 --fault-seed 7",
        ],
    ),
    (
        "send",
        &["--link sim send 0C3#0A3C", "--link sim --json send 0C3#0A3C --listen 200", "--link sim send '190C;1;0;0'"],
    ),
    (
        "monitor",
        &[
            "--link slcan:/dev/ttyACM0 monitor -m 3,5",
            "monitor --from-log bus.log --family powercube --stats",
            "--link slcan:/dev/ttyACM0 --link serial:/dev/ttyUSB0 monitor -d powercube:3,cdios:1/0",
        ],
    ),
    ("cdios-identify", &["--link sim cdios-identify", "--link sim --json cdios-identify --node 1"]),
    (
        "cdios-status",
        &[
            "--link sim cdios-status -m 0",
            "--link sim --json cdios-status -m all --node 1",
            "--link sim cdios-status -d cdios:1/1,cdios:1/0   # the modules named, in that order (or a bench file's names)",
        ],
    ),
    (
        "cdios-position",
        &[
            "--link sim cdios-position -m 0",
            "--link sim cdios-position -m 0 --all",
            "--link slcan:/dev/ttyACM0 cdios-position --node 1,2 -m 0,1",
        ],
    ),
    ("cdios-set-position", &["--link sim cdios-set-position -m 0 -1200"]),
    (
        "cdios-goto",
        &[
            "--link 'sim?cdios=enabled' cdios-goto -m 0 5000 --wait",
            "--link 'sim?cdios=enabled' cdios-goto -m 0 -1500 --relative --speed 800",
        ],
    ),
    (
        "cdios-traject",
        &["--link slcan:/dev/ttyACM0 cdios-traject -m 0 0 --wait   # a traject configured with cdios-config"],
    ),
    (
        "cdios-start",
        &[
            "--link 'sim?cdios=enabled' cdios-start -m 0 --option to-speed --speed 1200",
            "--link 'sim?cdios=enabled' cdios-start -m 0 --direction reverse --option min-speed",
        ],
    ),
    ("cdios-stop", &["--link sim cdios-stop -m 0", "--link sim cdios-stop -m 0 --option fast"]),
    ("cdios-enable", &["--link sim cdios-enable -m 0", "--link sim cdios-enable -m 0 --release-emergency"]),
    ("cdios-disable", &["--link sim cdios-disable -m 0"]),
    ("cdios-config", &["--link sim cdios-config -m 0", "--link sim cdios-config -m 0 speeds encoder"]),
    ("cdios-outputs", &["--link sim cdios-outputs -m 0", "--link sim cdios-outputs -m 0 --set 0b0101"]),
    ("cdios-analog", &["--link sim cdios-analog -m 0", "--link sim cdios-analog -m 0 --output 1 --set -2500"]),
    ("cdios-events", &["--link sim cdios-events -m 0", "--link sim cdios-events -m 0 --mask GOTO_ACTIVE,ENABLED"]),
    ("cdios-store", &["--link sim cdios-store -m 0"]),
    ("cdios-watch", &["--link sim cdios-watch -m 0 --for 5", "--link sim --json cdios-watch -m 0 --for 2"]),
    (
        "batch",
        &[
            "--link sim batch docs/examples/commands.txt",
            "--link sim --json batch -",
            "--link slcan:/dev/ttyACM0 batch --keep-going commands.txt",
        ],
    ),
    ("shell", &["--link sim shell", "--link socketcan:can0 shell --history /tmp/axisctl-history"]),
    (
        "dashboard",
        &[
            "--link sim dashboard",
            "--link socketcan:can0 dashboard -m 3,5,17 --without pac",
            "--link sim dashboard -d powercube:17,pac:2,cdios:1/1",
        ],
    ),
    ("pac-online", &["--link sim pac-online"]),
    ("pac-offline", &["--link 'sim?pac=online' pac-offline"]),
    ("pac-stop", &["--link 'sim?pac=online' pac-stop"]),
    ("pac-auto-start", &["--link sim pac-auto-start"]),
    ("pac-auto-abort", &["--link 'sim?pac=automatic' pac-auto-abort"]),
    ("pac-state", &["--link sim pac-state", "--link sim --json pac-state"]),
    ("pac-error", &["--link sim pac-error"]),
    ("pac-reset-error", &["--link sim pac-reset-error"]),
    (
        "pac-move",
        &[
            "--link 'sim?pac=online' pac-move 2 150 --wait",
            "--link 'sim?pac=online' pac-move 2 -10 --relative --wait --wait-timeout 30",
            "--link 'sim?pac=online' pac-move -d pac:2 150 --wait     # the axis as a device (or a bench-file name)",
        ],
    ),
    ("pac-ref", &["--link 'sim?pac=online' pac-ref 2 --wait"]),
    ("pac-no-ref", &["--link 'sim?pac=online' pac-no-ref 2"]),
    ("pac-zero", &["--link 'sim?pac=online' pac-zero 2"]),
    ("pac-set-pos", &["--link 'sim?pac=online' pac-set-pos 2 -12.5"]),
    ("pac-speed", &["--link 'sim?pac=online' pac-speed 2 50", "--link 'sim?pac=online' pac-speed 1 500"]),
    ("pac-accel", &["--link 'sim?pac=online' pac-accel 2 100"]),
    ("pac-stop-axis", &["--link 'sim?pac=online' pac-stop-axis 2", "--link 'sim?pac=online' pac-stop-axis 2 --wait"]),
    ("pac-axis", &["--link sim pac-axis 2", "--link sim --json pac-axis 2"]),
    ("pac-axes", &["--link sim pac-axes"]),
    (
        "pac-axis-power",
        &["--link 'sim?pac=online' pac-axis-power 2 on", "--link 'sim?pac=online' pac-axis-power 2 off"],
    ),
    ("pac-measure", &["--link 'sim?pac=online' pac-measure 2 on", "--link 'sim?pac=online' pac-measure 2 off"]),
    (
        "pac-limit-switch",
        &["--link 'sim?pac=online' pac-limit-switch 2 off", "--link 'sim?pac=online' pac-limit-switch 0 on"],
    ),
    ("pac-in", &["--link sim pac-in 1", "--link sim pac-in 1 --word"]),
    ("pac-out", &["--link sim pac-out 3", "--link sim pac-out 3 1", "--link sim pac-out 1 0x00ff --word"]),
    ("pac-flag", &["--link sim pac-flag 10", "--link sim pac-flag 10 1", "--link sim pac-flag 5 --system"]),
    ("pac-reg", &["--link sim pac-reg N5", "--link sim pac-reg N5 12345", "--link sim pac-reg R3 -1.5"]),
    ("pac-sys-param", &["--link sim pac-sys-param number-of-axes", "--link sim pac-sys-param number-of-axes --max"]),
    ("pac-axis-param", &["--link sim pac-axis-param 2 acceleration", "--link sim pac-axis-param 2 acceleration --min"]),
    ("pac-raw", &["--link sim pac-raw 190C 2", "--link sim pac-raw get-actual-pos 2"]),
    (
        "completions",
        &[
            "completions bash > ~/.local/share/bash-completion/completions/axisctl",
            "completions zsh > ~/.zfunc/_axisctl",
        ],
    ),
    ("man", &["man | man -l -", "man --dir ~/.local/share/man/man1"]),
    ("params", &["params", "params powercube", "--json params pac"]),
    ("flags", &["flags", "flags config", "flags brake", "flags cdios-status"]),
    (
        "backup",
        &[
            "--link sim backup --out bench.json",
            "--link sim backup --family cdios --out cdios.json",
            "--link socketcan:can0 backup -m 3,5 --out arm.json",
            "--link serial:/dev/ttyUSB0 backup --family pac --out pac.json",
            "--link slcan:/dev/ttyACM0 --link serial:/dev/ttyUSB0 backup --out bench.json",
            "--link sim backup --out - | axisctl --link sim diff -",
            "--link sim backup -d powercube:3,pac:2,cdios:1/0 --out three.json",
        ],
    ),
    (
        "diff",
        &[
            "--link sim diff bench.json",
            "--json diff before.json after.json",
            "--link sim diff bench.json -d powercube:3,pac:2",
        ],
    ),
    (
        "restore",
        &[
            "--link sim restore bench.json --dry-run",
            "--link sim restore bench.json --skip-invalid",
            "--link socketcan:can0 restore module17.json --to 12",
            "--link sim restore cdios.json --store",
            "--link sim restore bench.json -d cdios:1/0,pac --dry-run",
        ],
    ),
    (
        "record",
        &[
            "--link sim record -m 17 ActPos ActVel Cur --count 20",
            "--link sim --json record -m 17 ActPos ActVel Cur --for 3s -- move-ramp -m 17 0.1 > step.jsonl",
            "--link sim record --format csv -m 3,5 ActPos --rate 100 --for 10s > run.csv",
            "--link 'sim?pac=online' record --axis 2 position speed --for 5s -- pac-move 2 150",
            "--link 'sim?cdios=enabled' record --node 1 -m 0 position speed --count 50 -- cdios-goto -m 0 5000",
            "--link sim record powercube:17.ActPos pac:2.position cdios:1/0.speed --count 20",
            "--link sim record -d pac:2,cdios:1/0 position --count 20",
            "--bench docs/sim-bench.toml --json record shoulder.ActPos slide.position gripper.position --count 5",
        ],
    ),
    (
        "commission",
        &[
            "--link sim commission --print-plan > plan.toml",
            "--link sim commission --plan plan.toml --out handover --yes",
            "--link sim commission --out check --dry-run",
            "--link sim commission -d powercube:3 --out m3 --yes",
        ],
    ),
    (
        "plot",
        &[
            "plot step.jsonl --svg step.svg",
            "plot step.jsonl --png step.png",
            "plot run.csv --svg run.svg --png run.png --title run --width 1600",
        ],
    ),
];

/// The help text of one subcommand's examples, or `None` when it has none.
pub fn after_help(path: &str) -> Option<String> {
    let (_, lines) = EXAMPLES.iter().find(|(p, _)| *p == path)?;
    let body: Vec<String> = lines.iter().map(|l| format!("  axisctl {l}")).collect();
    Some(format!("Examples:\n{}", body.join("\n")))
}

/// An example as the words the shell would pass (the redirections and
/// pipes of an example are the shell's, not axisctl's).
#[cfg(test)]
fn words(line: &str) -> Vec<&str> {
    line.split_whitespace()
        .take_while(|w| !matches!(*w, ">" | "|") && !w.starts_with('#'))
        .map(|w| w.trim_matches('\''))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every visible subcommand, by path (`watchdog on`), with its command.
    fn all(cmd: &clap::Command, path: &str, out: &mut Vec<(String, clap::Command)>) {
        for sub in cmd.get_subcommands().filter(|s| !s.is_hide_set() && s.get_name() != "help") {
            let p = if path.is_empty() { sub.get_name().to_string() } else { format!("{path} {}", sub.get_name()) };
            out.push((p.clone(), sub.clone()));
            all(sub, &p, out);
        }
    }

    fn subcommands() -> Vec<(String, clap::Command)> {
        let mut cmd = crate::cli::command("");
        cmd.build();
        let mut out = Vec::new();
        all(&cmd, "", &mut out);
        out
    }

    #[test]
    fn every_subcommand_has_examples_in_its_help() {
        for (path, mut sub) in subcommands() {
            let help = sub.render_long_help().to_string();
            assert!(help.contains("Examples:\n  axisctl "), "{path} has no examples:\n{help}");
        }
    }

    #[test]
    fn every_example_parses_as_its_own_command() {
        let names: Vec<String> = subcommands().into_iter().map(|(p, _)| p).collect();
        let mut bad = Vec::new();
        for (path, lines) in EXAMPLES {
            assert!(names.iter().any(|n| n == path), "examples for {path:?}, which is no subcommand");
            for line in *lines {
                let mut argv = vec!["axisctl"];
                argv.extend(words(line));
                let m = match crate::cli::for_words(crate::cli::command(""), &argv).try_get_matches_from(&argv) {
                    Ok(m) => m,
                    Err(e) => {
                        bad.push(format!("{line:?}: {}", e.render().to_string().lines().next().unwrap_or("")));
                        continue;
                    }
                };
                let mut got = Vec::new();
                let mut at = &m;
                while let Some((name, sub)) = at.subcommand() {
                    got.push(name);
                    at = sub;
                }
                let got = got.join(" ");
                assert!(got == *path || got.starts_with(&format!("{path} ")), "{line:?} is filed under {path}");
            }
        }
        assert!(bad.is_empty(), "examples that do not parse:\n{}", bad.join("\n"));
    }

    #[test]
    fn the_top_level_examples_parse() {
        let mut cmd = crate::cli::command("");
        let help = cmd.render_long_help().to_string();
        let examples = help.split("Examples:\n").nth(1).expect("top-level examples");
        for line in examples.lines().filter_map(|l| l.trim().strip_prefix("axisctl ")) {
            let line = line.split('#').next().unwrap_or_default();
            let mut argv = vec!["axisctl"];
            argv.extend(words(line));
            let parsed = crate::cli::command("").try_get_matches_from(&argv);
            // `pac-move --help` ends in clap's DisplayHelp, which is what it asks for.
            if let Err(e) = parsed {
                assert_eq!(e.kind(), clap::error::ErrorKind::DisplayHelp, "{line:?}: {e}");
            }
        }
    }

    #[test]
    fn every_argument_says_what_it_is() {
        let mut bad = Vec::new();
        for (path, sub) in subcommands() {
            for arg in sub.get_arguments().filter(|a| !a.is_hide_set()) {
                let id = arg.get_id().as_str();
                if matches!(id, "help" | "version") {
                    continue;
                }
                if arg.get_help().is_none() {
                    bad.push(format!("{path}: {id}"));
                }
            }
        }
        assert!(bad.is_empty(), "arguments without a description:\n{}", bad.join("\n"));
    }
}
