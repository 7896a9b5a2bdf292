//! Which commands may start a motion, and which device they send moving:
//! a `batch` or `shell` that a signal ends halts each such device, also one
//! a line left moving without `--wait`. Each family's command enum answers
//! in one exhaustive match (no catch-all arm) in its own folder
//! (`cli/<family>/motion.rs`), so a new command does not compile until
//! someone says whether it moves; a test walks the parser's tree and
//! checks every subcommand against the list below.

use axisctl::bench::{Address, DeviceRef};
use axisctl::device::supervisor::MotionTarget;

use super::backup::BackupCommand;
use super::Command;

/// How a `-d` device is found while deciding what a line moves: through
/// the bench (its file's names), `None` when it names no device. A `-d`
/// that does not resolve, or names a device of another family, fails the
/// line before anything is sent, so it moves nothing.
pub type Names<'a> = &'a dyn Fn(&DeviceRef) -> Option<Address>;

/// [`Names`] without a bench: addresses only.
#[cfg(test)]
pub fn addresses_only(r: &DeviceRef) -> Option<Address> {
    match r {
        DeviceRef::Address(a) => Some(*a),
        DeviceRef::Name(_) => None,
    }
}

impl Command {
    /// The device this command may set moving, `None` for a command that
    /// moves nothing.
    pub fn starts_motion(&self, names: Names) -> Option<MotionTarget> {
        match self {
            Self::PowerCube(c) => c.starts_motion(names),
            Self::Pac(c) => c.starts_motion(names),
            Self::Cdios(c) => c.starts_motion(names),
            Self::Backup(c) => c.starts_motion(),
            // A recording halts its own motion on every way out; the run
            // that holds it halts it once more, which is harmless.
            Self::Record(args) => match args.motion.is_empty() {
                true => None,
                false => super::parse_words(&args.motion).ok().and_then(|cli| cli.command.starts_motion(names)),
            },
            // Every PowerCube module of the plan may move (it halts them
            // itself on every way out); with one device named (`-d`), that
            // device, whatever its family.
            Self::Commission(a) if !a.dry_run && !a.print_plan => match &a.device[..] {
                [one] => names(one).and_then(|at| MotionTarget::try_from(at).ok()),
                _ => Some(MotionTarget::CubeBus),
            },
            Self::Send(args) => args.starts_motion(),
            Self::Commission(_)
            | Self::Decode { .. }
            | Self::Sim(_)
            | Self::Monitor(_)
            | Self::Dashboard(_)
            | Self::Params { .. }
            | Self::Flags { .. }
            | Self::Batch(_)
            | Self::Shell(_)
            | Self::Plot(_)
            | Self::Completions { .. }
            | Self::Man { .. } => None,
        }
    }
}

impl BackupCommand {
    /// A restore writes settings, never a motion command.
    pub fn starts_motion(&self) -> Option<MotionTarget> {
        match self {
            Self::Backup { .. } | Self::Diff { .. } | Self::Restore { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeSet;

    use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
    use axisctl::proto::powercube::ModuleId;
    use clap::FromArgMatches;

    use super::*;

    /// Every subcommand that may start a motion. A new subcommand must be
    /// put here or in [`STILL`], and its examples are classified below.
    const MOVING: &[&str] = &[
        "home",
        "move-ramp",
        "move-step",
        "move-vel",
        "move-cur",
        "pac-move",
        "pac-ref",
        "pac-online",
        "pac-auto-start",
        "pac-raw",
        "cdios-goto",
        "cdios-traject",
        "cdios-start",
    ];

    /// Every subcommand that moves nothing (`record` moves what follows
    /// its `--`, `commission` what its plan says unless `--dry-run` or
    /// `--print-plan`: each classified on its own).
    const STILL: &[&str] = &[
        // Moves only with --force and a motion frame: classified per frame (cli::send's tests).
        "send",
        "scan",
        "info",
        "state",
        "reset",
        "halt",
        "get-param",
        "set-param",
        "get-config",
        "set-config",
        "dio",
        "watchdog",
        "decode",
        "sim",
        "monitor",
        "cdios-identify",
        "cdios-status",
        "cdios-position",
        "cdios-set-position",
        "cdios-stop",
        "cdios-enable",
        "cdios-disable",
        "cdios-config",
        "cdios-outputs",
        "cdios-analog",
        "cdios-events",
        "cdios-store",
        "cdios-watch",
        "dashboard",
        "pac-offline",
        "pac-stop",
        "pac-auto-abort",
        "pac-state",
        "pac-error",
        "pac-reset-error",
        "pac-no-ref",
        "pac-zero",
        "pac-set-pos",
        "pac-speed",
        "pac-accel",
        "pac-stop-axis",
        "pac-axis",
        "pac-axes",
        "pac-axis-power",
        "pac-axis-on",
        "pac-axis-off",
        "pac-measure",
        "pac-limit-switch",
        "pac-in",
        "pac-out",
        "pac-flag",
        "pac-reg",
        "pac-sys-param",
        "pac-axis-param",
        "backup",
        "diff",
        "restore",
        "params",
        "flags",
        "batch",
        "shell",
        "record",
        "commission",
        "plot",
        "completions",
        "man",
    ];

    fn parse(line: &str) -> Command {
        // An example may go on into the shell: `> file`, `| man -l -`.
        let words = shlex::split(line).expect("an example splits");
        let words = words.into_iter().take_while(|w| !w.starts_with(['>', '<', '|', '&', ';']));
        let words: Vec<String> = std::iter::once("axisctl".to_string()).chain(words).collect();
        let parser = crate::cli::for_words(crate::cli::command(""), &words);
        let matches = parser.try_get_matches_from(words).unwrap_or_else(|e| panic!("{line}: {e}"));
        crate::cli::Cli::from_arg_matches(&matches).unwrap().command
    }

    #[test]
    fn every_subcommand_of_the_parser_is_said_to_move_or_not() {
        let tree: BTreeSet<String> =
            crate::cli::command("").get_subcommands().map(|c| c.get_name().to_string()).collect();
        let listed: BTreeSet<String> = MOVING.iter().chain(STILL).map(|s| s.to_string()).collect();
        assert_eq!(MOVING.len() + STILL.len(), listed.len(), "a subcommand is listed twice");
        assert_eq!(tree, listed, "each subcommand goes into MOVING or STILL");
    }

    /// Every example of every subcommand's help, parsed by the real parser
    /// and classified: the motion commands name a device, the others none.
    #[test]
    fn every_example_is_classified_as_its_subcommand_is_listed() {
        let mut seen = BTreeSet::new();
        for (path, lines) in crate::cli::examples::EXAMPLES {
            let name = path.split(' ').next().unwrap();
            for line in *lines {
                let moves = parse(line).starts_motion(&addresses_only);
                let plan_moves = !line.contains("--dry-run") && !line.contains("--print-plan");
                let listed = MOVING.contains(&name)
                    || (name == "record" && line.contains(" -- "))
                    || (name == "commission" && plan_moves);
                assert_eq!(moves.is_some(), listed, "{line}: {moves:?}");
                seen.insert(name);
            }
        }
        for name in MOVING {
            assert!(seen.contains(name), "{name} has an example");
        }
    }

    #[test]
    fn each_motion_names_the_device_it_sends_moving() {
        let cube = |m| MotionTarget::Cube(ModuleId::new(m).unwrap());
        let cdios = |n, m| MotionTarget::Cdios { node: NodeId::new(n).unwrap(), module: CdiosModule::new(m).unwrap() };
        for (line, target) in [
            ("home -m 17", cube(17)),
            ("home --all --wait", MotionTarget::CubeBus),
            ("move-ramp -m 3 0.5", cube(3)),
            ("move-ramp -m 3,5 --sync 0.5 -0.5", MotionTarget::CubeBus),
            ("move-ramp -m 5 --sync 0.5", MotionTarget::CubeBus),
            ("move-step -m 5 0.1 --time 100", cube(5)),
            ("move-vel -m 9 0.1", cube(9)),
            ("move-cur -m 31 0.5", cube(31)),
            ("pac-move 2 900", MotionTarget::PacAxis(2)),
            ("pac-ref 3 --wait", MotionTarget::PacAxis(3)),
            ("pac-online", MotionTarget::PacController),
            ("pac-auto-start", MotionTarget::PacController),
            ("pac-raw 0A94 2 900.0", MotionTarget::PacController),
            ("cdios-goto -m 1 3000", cdios(1, 1)),
            ("cdios-goto --node 7 -m 2 3000", cdios(7, 2)),
            ("cdios-traject --node 3 -m 0 1", cdios(3, 0)),
            ("cdios-start -m 4 --option to-speed --speed 100", cdios(1, 4)),
            ("record -m 17 ActPos -- move-ramp -m 17 0.1", cube(17)),
            ("record --axis 2 position -- pac-move 2 250", MotionTarget::PacAxis(2)),
        ] {
            assert_eq!(parse(line).starts_motion(&addresses_only), Some(target), "{line}");
        }
        for line in ["record -m 17 ActPos --count 3", "record -m 17 ActPos -- no-such-command"] {
            assert_eq!(parse(line).starts_motion(&addresses_only), None, "{line}");
        }
    }

    /// `-d` names the same device as the shorthand, through the bench's
    /// names; one that names no device of the command's family moves
    /// nothing (the line fails before sending).
    #[test]
    fn a_device_named_with_d_is_the_device_that_moves() {
        let cube = |m| MotionTarget::Cube(ModuleId::new(m).unwrap());
        let names = |r: &DeviceRef| match r {
            DeviceRef::Name(n) if n == "wrist" => Address::powercube(9),
            DeviceRef::Name(n) if n == "slide" => Address::pac(Some(2)),
            r => addresses_only(r),
        };
        for (line, target) in [
            ("move-vel -d powercube:9 0.1", Some(cube(9))),
            ("move-vel -d wrist 0.1", Some(cube(9))),
            ("home -d wrist", Some(cube(9))),
            ("move-ramp -d wrist 0.1", Some(cube(9))),
            ("move-ramp -d wrist,powercube:3 --sync 0.1 0.2", Some(MotionTarget::CubeBus)),
            ("move-cur --device powercube:4 0.5", Some(cube(4))),
            ("move-vel -d slide 0.1", None),
            ("move-step -d nobody 0.1 --time 100", None),
            ("record -m 17 ActPos -- move-vel -d wrist 0.1", Some(cube(9))),
            ("commission --out o --yes", Some(MotionTarget::CubeBus)),
            ("commission -d slide --out o --yes", Some(MotionTarget::PacAxis(2))),
            ("commission -d wrist --out o --yes", Some(cube(9))),
            ("commission -d wrist,slide --out o --yes", Some(MotionTarget::CubeBus)),
            ("commission -d slide --out o --dry-run", None),
        ] {
            assert_eq!(parse(line).starts_motion(&names), target, "{line}");
        }
    }
}
