//! The command line, as typed: clap derive only, no meaning. `commands`
//! resolves it.

pub mod backup;
pub mod batch;
pub mod cdios;
pub mod commission;
pub mod complete;
pub mod dashboard;
pub mod examples;
pub mod ids;
pub mod monitor;
pub mod motion;
pub mod pac;
pub mod powercube;
pub mod record;
pub mod send;
pub mod sim;
pub mod suggest;
pub mod wait;

use std::path::PathBuf;

use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand};

pub use monitor::MonitorArgs;
pub use powercube::{PowerCubeCommand, Target, WatchdogAction};
pub use sim::SimArgs;
pub use wait::WaitArgs;

#[derive(Debug, Parser)]
#[command(name = "axisctl", version = env!("AXISCTL_VERSION"), about = "Commission PowerCube, PA-CONTROL and Cdios motion hardware")]
pub struct Cli {
    #[command(flatten)]
    pub global: Global,
    #[command(subcommand)]
    pub command: Command,
    /// The subcommand's name as typed (`pac-online`): the `command` of
    /// its JSON documents.
    #[arg(skip)]
    pub name: String,
}

/// The longest answer timeout: an answer later than a minute is no answer,
/// and a longer one would leave a stop waiting behind it.
pub const MAX_TIMEOUT_MS: u64 = 60_000;
/// The most read retries: each costs a timeout per absent device.
pub const MAX_RETRIES: u32 = 10;

#[derive(Debug, Args)]
#[command(next_help_heading = "Global options")]
pub struct Global {
    /// The link: socketcan:IFACE, slcan:TTY[?bitrate=N], socketcand:HOST[:PORT]/BUS[?rtt=MS], serial:TTY[?baud=N&format=F] or sim; once per link of a bench (AXISCTL_LINK: separated by commas or spaces)
    #[arg(long, global = true, env = "AXISCTL_LINK", value_name = "URI", action = clap::ArgAction::Append,
          add = complete::links())]
    pub link: Vec<String>,
    /// The link came from `AXISCTL_LINK`, not `--link`: an error about it names the variable.
    #[arg(skip)]
    pub link_from_env: bool,
    /// A bench file naming the links, their families and devices (TOML); else ./axisctl.toml if there is one. --link wins over it
    #[arg(long, global = true, env = "AXISCTL_BENCH", value_name = "FILE")]
    pub bench: Option<PathBuf>,
    /// The bench file came from `AXISCTL_BENCH`, not `--bench`.
    #[arg(skip)]
    pub bench_from_env: bool,
    /// Machine output: one JSON document on stdout (JSON Lines for streams)
    #[arg(long, global = true)]
    pub json: bool,
    /// How long to wait for each answer, in ms, 1 to 60000 (default 100 on CAN, 30 plus wire time on RS232; a socketcand: link adds its round trip)
    #[arg(long, global = true, env = "AXISCTL_TIMEOUT", value_name = "MS",
          value_parser = ids::number(1, MAX_TIMEOUT_MS, "ms"))]
    pub timeout: Option<u64>,
    /// Print every frame sent and received, decoded, on stderr
    #[arg(long, short = 'v', visible_alias = "verbose", global = true)]
    pub trace: bool,
    /// Print no results, only errors and warnings (on stderr); the exit status says how it went
    #[arg(long, short = 'q', global = true, conflicts_with = "json")]
    pub quiet: bool,
    /// Append every CAN frame in candump -l format (serial traffic as hex lines) to FILE (- for standard output)
    #[arg(long, global = true, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// How often a read is retried after a timeout, 0 to 10 (motion is never retried)
    #[arg(long, global = true, value_name = "N", default_value_t = 2,
          value_parser = ids::number(0, MAX_RETRIES, ""))]
    pub retries: u32,
    /// PA-CONTROL: send CHECK as the XOR including ETX (default: strictly between STX and ETX)
    #[arg(long, global = true)]
    pub pac_check_etx: bool,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    #[command(flatten)]
    PowerCube(PowerCubeCommand),
    /// Decode a raw word offline (decode --help lists the kinds)
    Decode {
        /// What the value is (the kinds are listed below)
        #[arg(add = complete::decode_kinds())]
        kind: String,
        /// The raw value (decimal, 0x hex or 0b binary; hex bytes for profibus-image)
        value: String,
    },
    /// Serve the simulated bench on pseudo-terminals until stopped
    Sim(SimArgs),
    /// Passive, decoded bus monitor on any CAN link, or replay of a candump log
    Monitor(MonitorArgs),
    /// Send one raw frame, decoded first, and print the answers decoded (motion only with --force)
    Send(send::SendArgs),
    #[command(flatten)]
    Cdios(cdios::CdiosCommand),
    /// Live dashboard of every device on the links (try: --link sim dashboard)
    Dashboard(dashboard::DashboardArgs),
    #[command(flatten)]
    Pac(pac::PacCommand),
    #[command(flatten)]
    Backup(backup::BackupCommand),
    /// List parameter and configuration names offline: PowerCube parameters, PA-CONTROL system and axis parameters, Cdios config fields
    Params {
        /// Only this family: powercube, pac or cdios
        #[arg(value_name = "FAMILY", value_parser = dashboard::parse_family)]
        family: Option<axisctl::family::Family>,
    },
    /// List status and Config flags offline: every word's flags, or those of WORD (a decode kind) or matching WORD
    Flags {
        /// A decode kind (config, cube-state, cdios-status, ...) or part of a flag name (brake)
        #[arg(value_name = "WORD")]
        word: Option<String>,
    },
    /// Run commands from FILE or standard input, one per line as after `axisctl`, on one open link
    Batch(batch::BatchArgs),
    /// An interactive shell: the same commands, on one open link, with history and completion
    Shell(batch::ShellArgs),
    /// Record chosen values with a time stamp per sample (JSON Lines, CSV), optionally while a motion runs
    Record(record::RecordArgs),
    /// Draw a recording of `record` as an SVG chart with units
    Plot(record::PlotArgs),
    /// Run a commissioning plan over the bench (identity, settings, limits, homing, test moves, halt, backup) and write the report
    Commission(commission::CommissionArgs),
    /// Print a shell completion script: bash, zsh, fish, elvish or powershell
    #[command(after_help = "Examples:\n  \
                            axisctl completions bash > ~/.local/share/bash-completion/completions/axisctl   # mkdir -p the directory first\n  \
                            axisctl completions zsh > ~/.zfunc/_axisctl\n  \
                            axisctl completions fish > ~/.config/fish/completions/axisctl.fish")]
    Completions {
        /// The shell the script is for
        shell: clap_complete::Shell,
    },
    /// Print the man page (roff), or with --dir write one page per subcommand
    #[command(after_help = "Examples:\n  axisctl man | man -l -\n  \
                            axisctl man --dir ~/.local/share/man/man1   # then: man -l ~/.local/share/man/man1/axisctl-pac-move.1")]
    Man {
        /// Write axisctl.1 and axisctl-COMMAND.1 for every subcommand into this directory
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
    },
}

/// `on` or `off`: how every switch is said (`watchdog on`, `pac-axis-power 2 off`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Switch {
    On,
    Off,
}

impl Switch {
    pub fn is_on(self) -> bool {
        self == Self::On
    }
}

const TOP_EXAMPLES: &str = "Examples:
  axisctl --link sim dashboard                   # every simulated device, live
  axisctl --link socketcan:can0 scan             # the PowerCube modules on a bus
  axisctl --link sim move-ramp -m 17 0.1 --wait
  axisctl --link sim --json pac-axis 2
  axisctl params powercube                       # the names the commands take
  axisctl pac-move --help                        # every command's help ends with examples";

const LINKS: &str = "Links: socketcan:IFACE, slcan:TTY[?bitrate=N], socketcand:HOST[:PORT]/BUS[?rtt=MS], serial:TTY[?baud=N&format=8N1|7N1|7E1|7O1], sim";

/// The parser, with what the registries know: `decode`'s kinds and the exit
/// codes; every subcommand's examples; negative numbers as values everywhere.
pub fn command(exit_codes: &str) -> clap::Command {
    let kinds = axisctl::family::Family::ALL
        .into_iter()
        .map(|f| format!("  {}: {}", f.display_name(), f.decode_kinds().join(", ")))
        .collect::<Vec<_>>()
        .join("\n");
    let cmd =
        Cli::command().after_help(format!("{LINKS}\n{exit_codes}\n\n{TOP_EXAMPLES}")).mut_subcommand("decode", |c| {
            let examples = examples::after_help("decode").unwrap_or_default();
            c.after_help(format!("Kinds:\n{kinds}\n\n{examples}"))
        });
    finish(cmd, "")
}

/// Applies to a command and all below it what clap only sets per argument.
fn finish(cmd: clap::Command, path: &str) -> clap::Command {
    // `--vel -0.05` and `pac-speed 1 -5` are values, not flags: clap only
    // takes a leading `-` as a value where the argument allows negative numbers.
    let mut cmd = cmd.mut_args(|a| if a.get_action().takes_values() { a.allow_negative_numbers(true) } else { a });
    if !path.is_empty() && cmd.get_after_help().is_none() {
        if let Some(text) = examples::after_help(path) {
            cmd = cmd.after_help(text);
        }
    }
    cmd.mut_subcommands(|sub| {
        let path = if path.is_empty() { sub.get_name().to_string() } else { format!("{path} {}", sub.get_name()) };
        finish(sub, &path)
    })
}

/// Whether a command line names a device with `-d` / `--device` (before
/// any `--`, after which words are another command's, as `record`'s motion),
/// also after the global flags in one cluster (`-vd slide`).
pub fn names_device<S: AsRef<std::ffi::OsStr>>(words: &[S]) -> bool {
    words.iter().map(|w| w.as_ref().to_string_lossy()).take_while(|w| w != "--").any(|w| {
        let short = w.strip_prefix('-').filter(|s| !s.starts_with('-'));
        w == "--device"
            || w.starts_with("--device=")
            || short.is_some_and(|s| s.trim_start_matches(['v', 'q']).starts_with('d'))
    })
}

/// The parser for `words`: `cmd`, or its form for a line that names a
/// device with `-d`, where a PA-CONTROL command's AXIS is no positional
/// ([`pac::device_form`]).
pub fn for_words<S: AsRef<std::ffi::OsStr>>(cmd: clap::Command, words: &[S]) -> clap::Command {
    if names_device(words) {
        pac::device_form(cmd)
    } else {
        cmd
    }
}

/// `Cli::try_parse_from` for a command given as words (`record`'s motion,
/// a line of its own), `-d` included.
pub fn parse_words(words: &[String]) -> Result<Cli, clap::Error> {
    let argv: Vec<&str> = std::iter::once("axisctl").chain(words.iter().map(String::as_str)).collect();
    let matches = for_words(Cli::command(), &argv).try_get_matches_from(&argv)?;
    Cli::from_arg_matches(&matches)
}

/// Parses the process arguments.
pub fn parse(exit_codes: &str) -> Result<Cli, clap::Error> {
    let args: Vec<_> = std::env::args_os().collect();
    let mut cmd = for_words(command(exit_codes), &args);
    let matches = cmd.try_get_matches_from_mut(args).map_err(|e| suggest::subcommand(e, &cmd))?;
    let mut cli = Cli::from_arg_matches(&matches).map_err(|e| e.with_cmd(&cmd))?;
    let from_env = |id| matches.value_source(id) == Some(clap::parser::ValueSource::EnvVariable);
    cli.global.link_from_env = from_env("link");
    cli.global.bench_from_env = from_env("bench");
    cli.name = matches.subcommand_name().unwrap_or_default().to_string();
    Ok(cli)
}
