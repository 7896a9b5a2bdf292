//! Dynamic shell completion: the shell asks the binary itself
//! (`AXISCTL_COMPLETE=bash axisctl -- WORDS...`), which parses the words
//! with the real parser, so a global option's value (`--link sim`) is never
//! taken for a subcommand, and values are completed from the protocol
//! tables: parameter names, Config flags, decode kinds, record values,
//! link forms.

use std::ffi::{OsStr, OsString};

use clap_complete::engine::{ArgValueCompleter, CompletionCandidate};

use axisctl::family::Family;

/// The variable that asks the binary for completions (in the registration
/// script `axisctl completions SHELL` prints).
pub const VAR: &str = "AXISCTL_COMPLETE";

/// Answers a shell's completion request (the variable [`VAR`] is set) and
/// ends the process; returns at once otherwise.
///
/// clap_complete's engine takes an option's value for a subcommand when it
/// is spelled like one (`axisctl --link sim move-ramp --<Tab>` completed the
/// `sim` subcommand's flags): the words before the cursor are given to it
/// with each value joined to its option (`--link=sim`), one word that is
/// never a subcommand.
pub fn answer_shell(command: impl Fn() -> clap::Command) {
    if std::env::var_os(VAR).is_none_or(|v| v.is_empty() || v == "0") {
        return;
    }
    let cmd = command();
    let mut args: Vec<OsString> = std::env::args_os().collect();
    let index: Option<usize> = std::env::var(INDEX).ok().and_then(|i| i.parse().ok());
    if let Some(words) = args.iter().position(|a| a == "--").map(|i| i + 1) {
        let cursor = index.map_or(args.len() - 1, |i| words + i);
        let joined = join_option_values(&cmd, &mut args, words, cursor);
        if let Some(i) = index {
            // SAFETY (edition 2021: safe): one thread, before anything else runs.
            std::env::set_var(INDEX, (i - joined).to_string());
        }
    }
    let current_dir = std::env::current_dir().ok();
    match clap_complete::CompleteEnv::with_factory(|| cmd.clone()).var(VAR).try_complete(args, current_dir.as_deref()) {
        Ok(true) => std::process::exit(0),
        Ok(false) => {}
        Err(e) => e.exit(),
    }
}

/// Where bash's script says the cursor is, among the words.
const INDEX: &str = "_CLAP_COMPLETE_INDEX";

/// Joins `--opt VALUE` into `--opt=VALUE` in `args[from..cursor]` for the
/// top-level options that take a value; how many words went.
fn join_option_values(cmd: &clap::Command, args: &mut Vec<OsString>, from: usize, mut cursor: usize) -> usize {
    let takes_value: Vec<&str> =
        cmd.get_arguments().filter(|a| a.get_action().takes_values()).filter_map(|a| a.get_long()).collect();
    let mut joined = 0;
    let mut i = from;
    while i + 1 < cursor {
        let long = args[i].to_str().and_then(|a| a.strip_prefix("--")).filter(|l| takes_value.contains(l));
        if long.is_some() {
            let mut word = args[i].clone();
            word.push("=");
            word.push(&args[i + 1]);
            args[i] = word;
            args.remove(i + 1);
            cursor -= 1;
            joined += 1;
        }
        i += 1;
    }
    joined
}

/// The names of `names` that start with what is typed, case-insensitively
/// (parameter names are matched so by the commands too).
pub(super) fn starting_with<'a>(current: &OsStr, names: impl IntoIterator<Item = &'a str>) -> Vec<CompletionCandidate> {
    let typed = current.to_string_lossy().to_ascii_lowercase();
    let mut out: Vec<&str> = names.into_iter().filter(|n| n.to_ascii_lowercase().starts_with(&typed)).collect();
    out.dedup();
    out.into_iter().map(CompletionCandidate::new).collect()
}

/// What `record` samples: PowerCube parameters, PA-CONTROL and Cdios values,
/// and `DEVICE.VALUE` with the devices of the bench file (their names and
/// addresses), a device's values after its dot.
pub fn record_values() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| record_values_on(&bench_file(), current))
}

fn record_values_on(bench: &std::path::Path, current: &OsStr) -> Vec<CompletionCandidate> {
    use axisctl::bench::{Address, Bench};
    let devices: Vec<(String, Address)> = Bench::from_file(bench)
        .map(|b| b.links().iter().flat_map(|l| l.devices.iter().map(|(n, a)| (n.clone(), *a))).collect())
        .unwrap_or_default();
    let typed = current.to_string_lossy();
    if let Some((device, _)) = typed.split_once('.') {
        let address = device.parse::<Address>().ok().or_else(|| devices.iter().find(|(n, _)| n == device).map(|d| d.1));
        let Some(family) = address.map(Address::family) else { return Vec::new() };
        let names: Vec<String> = values_of(family).map(|v| format!("{device}.{v}")).collect();
        return starting_with(current, names.iter().map(String::as_str));
    }
    let mut names: Vec<String> = Family::ALL.into_iter().flat_map(values_of).map(str::to_string).collect();
    names.extend(devices.iter().flat_map(|(n, a)| [format!("{n}."), format!("{a}.")]));
    starting_with(current, names.iter().map(String::as_str))
}

/// The values `record` samples of a family's device.
fn values_of(family: Family) -> impl Iterator<Item = &'static str> {
    crate::commands::names_of(family).record_values().into_iter()
}

/// The bench file completion reads: `AXISCTL_BENCH`, else `./axisctl.toml`.
fn bench_file() -> std::path::PathBuf {
    std::env::var_os("AXISCTL_BENCH")
        .filter(|v| !v.is_empty())
        .map_or_else(|| std::path::PathBuf::from(crate::commands::BENCH_FILE), std::path::PathBuf::from)
}

/// The kinds `decode` takes.
pub fn decode_kinds() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| starting_with(current, Family::all_decode_kinds()))
}

/// `-m` of the PowerCube commands: the modules the bench file names
/// (`AXISCTL_BENCH`, else `./axisctl.toml`), each with its name; nothing
/// without a bench file (any id of the range is valid, none is likelier).
pub fn bench_modules() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| modules_in(&bench_file(), Family::PowerCube, current))
}

/// The module ids of `family`'s devices in the bench file at `path`, those
/// that start with what is typed after the list's last comma.
fn modules_in(path: &std::path::Path, family: Family, current: &OsStr) -> Vec<CompletionCandidate> {
    use axisctl::bench::{Address, Bench};
    let Ok(bench) = Bench::from_file(path) else { return Vec::new() };
    let typed = current.to_string_lossy();
    let (done, last) = typed.rsplit_once(',').map_or(("", typed.as_ref()), |(d, l)| (d, l));
    let mut out: Vec<(u8, String)> = bench
        .links()
        .iter()
        .flat_map(|l| l.devices.iter())
        .filter_map(|(name, a)| match (family, a) {
            (Family::PowerCube, Address::PowerCube { module }) => Some((*module, name.clone())),
            _ => None,
        })
        .filter(|(m, _)| m.to_string().starts_with(last))
        .collect();
    out.sort();
    out.into_iter()
        .map(|(m, name)| {
            let value = if done.is_empty() { m.to_string() } else { format!("{done},{m}") };
            CompletionCandidate::new(value).help(Some(format!("powercube:{m} {name}").into()))
        })
        .collect()
}

/// `-d` of a family's commands (`None`: of any family, `halt -d` and the
/// whole-bench commands): the devices the bench file names, by name and by
/// address, the name's address as its help; after a comma, the list's next.
pub fn bench_devices(family: Option<Family>) -> ArgValueCompleter {
    ArgValueCompleter::new(move |current: &OsStr| devices_in(&bench_file(), family, current))
}

fn devices_in(path: &std::path::Path, family: Option<Family>, current: &OsStr) -> Vec<CompletionCandidate> {
    use axisctl::bench::Bench;
    let Ok(bench) = Bench::from_file(path) else { return Vec::new() };
    let typed = current.to_string_lossy();
    let (done, last) = typed.rsplit_once(',').map_or(("", typed.as_ref()), |(d, l)| (d, l));
    let devices = bench.links().iter().flat_map(|l| l.devices.iter());
    let mut out: Vec<(String, String)> = devices
        .filter(|(_, a)| family.is_none_or(|f| a.family() == f))
        .flat_map(|(name, a)| [(name.clone(), a.to_string()), (a.to_string(), name.clone())])
        .filter(|(value, _)| value.starts_with(last))
        .collect();
    out.sort();
    out.into_iter()
        .map(|(value, help)| {
            let value = if done.is_empty() { value } else { format!("{done},{value}") };
            CompletionCandidate::new(value).help(Some(help.into()))
        })
        .collect()
}

/// `--link`: `sim`, the forms with the serial ports and CAN interfaces of
/// this machine.
pub fn links() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| {
        let mut forms = vec!["sim".to_string()];
        for tty in ttys() {
            forms.push(format!("slcan:{tty}"));
            forms.push(format!("serial:{tty}"));
        }
        forms.extend(can_interfaces().into_iter().map(|i| format!("socketcan:{i}")));
        starting_with(current, forms.iter().map(String::as_str))
    })
}

/// USB serial adapters and the serial ports that exist.
fn ttys() -> Vec<String> {
    let mut out: Vec<String> = std::fs::read_dir("/dev")
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("ttyUSB") || n.starts_with("ttyACM"))
        .map(|n| format!("/dev/{n}"))
        .collect();
    out.sort();
    out
}

/// Network interfaces of type CAN (280, ARPHRD_CAN).
fn can_interfaces() -> Vec<String> {
    let mut out: Vec<String> = std::fs::read_dir("/sys/class/net")
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| std::fs::read_to_string(e.path().join("type")).is_ok_and(|t| t.trim() == "280"))
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    out.sort();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::powercube::values::{config_changes, params};

    fn names(c: &ArgValueCompleter, typed: &str) -> Vec<String> {
        c.complete(OsStr::new(typed)).iter().map(|c| c.get_value().to_string_lossy().into_owned()).collect()
    }

    #[test]
    fn a_global_options_value_is_joined_to_it_before_the_cursor_only() {
        let cmd = super::super::command("");
        let words = |w: &[&str]| w.iter().map(OsString::from).collect::<Vec<_>>();
        let mut args = words(&["axisctl", "--", "axisctl", "--link", "sim", "--json", "move-ramp", "--"]);
        assert_eq!(join_option_values(&cmd, &mut args, 2, 7), 1);
        assert_eq!(args, words(&["axisctl", "--", "axisctl", "--link=sim", "--json", "move-ramp", "--"]));
        // The value being typed stays a word of its own, to be completed.
        let mut args = words(&["axisctl", "--", "axisctl", "--link", "si"]);
        assert_eq!(join_option_values(&cmd, &mut args, 2, 4), 0);
    }

    #[test]
    fn values_come_from_the_tables() {
        let act = names(&params(), "actp");
        assert!(act.contains(&"ActPos".to_string()) && act.iter().all(|n| n.starts_with("ActP")), "{act:?}");
        assert!(names(&record_values(), "rpm").contains(&"rpm-error".to_string()));
        assert!(names(&decode_kinds(), "cube").contains(&"cube-state".to_string()));
        assert!(names(&config_changes(), "-brake").contains(&"-brake-present".to_string()));
        assert!(names(&config_changes(), "+CONFIGID_MOD_BRAKE").contains(&"+CONFIGID_MOD_BRAKE_PRESENT".to_string()));
        assert_eq!(names(&links(), "si"), ["sim"]);
    }

    #[test]
    fn record_values_complete_the_bench_files_devices_and_each_ones_values() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("axisctl.toml");
        std::fs::write(
            &path,
            "[[link]]\nspec = \"sim\"\ndevices = { wrist = \"powercube:17\", gripper = \"cdios:1/0\" }\n",
        )
        .unwrap();
        let got = |typed: &str| -> Vec<String> {
            record_values_on(&path, OsStr::new(typed))
                .iter()
                .map(|c| c.get_value().to_string_lossy().into_owned())
                .collect()
        };
        assert_eq!(got("wr"), ["wrist."]);
        assert_eq!(got("powercube:1"), ["powercube:17."]);
        assert!(got("wrist.ActP").contains(&"wrist.ActPos".to_string()), "{:?}", got("wrist.ActP"));
        assert!(got("gripper.").iter().all(|v| v.starts_with("gripper.")) && !got("gripper.").is_empty());
        assert!(!got("gripper.").contains(&"gripper.ActPos".to_string()), "a Cdios device has no PowerCube parameters");
        assert!(got("pac:2.").iter().any(|v| v == "pac:2.position"), "{:?}", got("pac:2."));
        assert!(got("nobody.").is_empty());
        assert!(got("ActP").contains(&"ActPos".to_string()));
    }

    #[test]
    fn module_ids_come_from_the_bench_file_with_their_names() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("axisctl.toml");
        std::fs::write(
            &path,
            "[[link]]\nspec = \"sim\"\ndevices = { base = \"powercube:3\", wrist = \"powercube:17\", \
             elbow = \"powercube:5\", gripper = \"cdios:1/0\" }\n",
        )
        .unwrap();
        let got = |typed: &str| -> Vec<(String, String)> {
            modules_in(&path, Family::PowerCube, OsStr::new(typed))
                .iter()
                .map(|c| {
                    (
                        c.get_value().to_string_lossy().into_owned(),
                        c.get_help().map(|h| h.to_string()).unwrap_or_default(),
                    )
                })
                .collect()
        };
        let all = got("");
        assert_eq!(all.iter().map(|(v, _)| v.as_str()).collect::<Vec<_>>(), ["3", "5", "17"], "{all:?}");
        assert_eq!(all[0].1, "powercube:3 base");
        assert_eq!(got("1").iter().map(|(v, _)| v.as_str()).collect::<Vec<_>>(), ["17"]);
        assert_eq!(got("3,1").iter().map(|(v, _)| v.as_str()).collect::<Vec<_>>(), ["3,17"], "after a comma");
        assert!(modules_in(&dir.path().join("none.toml"), Family::PowerCube, OsStr::new("")).is_empty());
    }

    #[test]
    fn devices_come_from_the_bench_file_by_name_and_address() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("axisctl.toml");
        std::fs::write(&path, "[[link]]\nspec = \"sim\"\ndevices = { wrist = \"powercube:17\", slide = \"pac:2\" }\n")
            .unwrap();
        let got = |family, typed: &str| -> Vec<(String, String)> {
            devices_in(&path, family, OsStr::new(typed))
                .iter()
                .map(|c| {
                    let help = c.get_help().map(|h| h.to_string()).unwrap_or_default();
                    (c.get_value().to_string_lossy().into_owned(), help)
                })
                .collect()
        };
        let pair = |v: &str, h: &str| (v.to_string(), h.to_string());
        assert_eq!(got(Some(Family::PowerCube), ""), [pair("powercube:17", "wrist"), pair("wrist", "powercube:17")]);
        assert_eq!(got(None, "s"), [pair("slide", "pac:2")]);
        assert_eq!(got(None, "wrist,p"), [pair("wrist,pac:2", "slide"), pair("wrist,powercube:17", "wrist")]);
        assert!(got(Some(Family::Cdios), "").is_empty(), "no Cdios device in the file");
        assert!(devices_in(&dir.path().join("none.toml"), None, OsStr::new("")).is_empty());
    }
}
