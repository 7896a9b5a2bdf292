//! The command line, as typed: clap derive only, no meaning. `commands`
//! resolves it.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "axisctl", version, about = "Commission PowerCube, PA-CONTROL and Cdios motion hardware")]
#[command(
    after_help = "Links: socketcan:IFACE, slcan:TTY[?bitrate=N], serial:TTY[?baud=N&format=8N1|7N1|7E1|7O1], sim\n\
Exit codes: 0 ok, 1 other failure, 2 usage / out of range (nothing sent), 3 link, 4 timeout, 5 device fault or refusal, 6 malformed answer, 130 interrupted"
)]
pub struct Cli {
    #[command(flatten)]
    pub global: Global,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Args)]
pub struct Global {
    /// The link: socketcan:IFACE, slcan:TTY[?bitrate=N], serial:TTY[?baud=N&format=F] or sim
    #[arg(long, global = true, env = "AXISCTL_LINK", value_name = "URI")]
    pub link: Option<String>,
    /// Machine output: one JSON document on stdout (JSON Lines for streams)
    #[arg(long, global = true)]
    pub json: bool,
    /// How long to wait for each answer, in ms (default 100 on CAN, 30 plus wire time on RS232)
    #[arg(long, global = true, env = "AXISCTL_TIMEOUT", value_name = "MS")]
    pub timeout: Option<u64>,
    /// Print every frame sent and received, decoded, on stderr
    #[arg(long, global = true)]
    pub trace: bool,
    /// Append every CAN frame in candump -l format (serial traffic as hex lines) to FILE
    #[arg(long, global = true, value_name = "FILE")]
    pub log: Option<PathBuf>,
    /// How often a read is retried after a timeout (motion is never retried)
    #[arg(long, global = true, value_name = "N", default_value_t = 2)]
    pub retries: u32,
    /// PA-CONTROL: send CHECK as the XOR including ETX (default: strictly between STX and ETX)
    #[arg(long, global = true)]
    pub pac_check_etx: bool,
}

#[derive(Debug, Args, Clone, Copy)]
pub struct ModuleArg {
    /// PowerCube module address, 1..31
    #[arg(short, long, value_name = "ID", value_parser = clap::value_parser!(u8).range(1..=31))]
    pub module: u8,
}

/// `-m ID` or `--all` (broadcast).
#[derive(Debug, Args, Clone, Copy)]
#[group(required = true, multiple = false)]
pub struct Target {
    /// PowerCube module address, 1..31
    #[arg(short, long, value_name = "ID", value_parser = clap::value_parser!(u8).range(1..=31))]
    pub module: Option<u8>,
    /// Broadcast to every module on the bus (not acknowledged)
    #[arg(long)]
    pub all: bool,
}

#[derive(Debug, Args, Clone, Copy)]
pub struct WaitArgs {
    /// Wait until the motion ends (exit 5 if an error flag appears; Ctrl-C halts the module)
    #[arg(long)]
    pub wait: bool,
    /// Give up waiting after this many seconds (the module is halted)
    #[arg(long, value_name = "S", default_value_t = 120.0, requires = "wait")]
    pub wait_timeout: f64,
    /// Poll interval while waiting, in ms
    #[arg(long, value_name = "MS", default_value_t = 20, requires = "wait")]
    pub poll: u64,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// List the PowerCube modules present on the link
    Scan {
        /// Ids to probe, e.g. 1-31 or 3,5,17
        #[arg(long, value_name = "LIST", default_value = "1-31")]
        ids: String,
    },
    /// Identity, kind, limits, position and state of one module
    Info(ModuleArg),
    /// CubeState, decoded flag by flag
    State(ModuleArg),
    /// Start the homing procedure
    Home {
        #[command(flatten)]
        target: Target,
        #[command(flatten)]
        wait: WaitArgs,
    },
    /// Clear the error state
    Reset {
        #[command(flatten)]
        target: Target,
    },
    /// Stop immediately
    Halt {
        #[command(flatten)]
        target: Target,
    },
    /// Ramp (trapezoidal) motion to a position
    MoveRamp {
        #[command(flatten)]
        module: ModuleArg,
        /// Target position (rad or m; encoder ticks with --ticks)
        #[arg(allow_negative_numbers = true)]
        pos: f64,
        /// Ramp velocity (TargetVel; units/s or ticks/s)
        #[arg(long)]
        vel: Option<f64>,
        /// Ramp acceleration (TargetAcc; units/s² or ticks/s²)
        #[arg(long)]
        acc: Option<f64>,
        /// Values are encoder ticks (IRAMP_MODE)
        #[arg(long)]
        ticks: bool,
        /// Skip the check against the module's own limits
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        wait: WaitArgs,
    },
    /// Step motion: reach a position in a given time
    MoveStep {
        #[command(flatten)]
        module: ModuleArg,
        #[arg(allow_negative_numbers = true)]
        pos: f64,
        /// Time to reach the position, ms
        #[arg(long, value_name = "MS")]
        time: u16,
        #[arg(long)]
        ticks: bool,
        #[arg(long)]
        force: bool,
    },
    /// Velocity motion
    MoveVel {
        #[command(flatten)]
        module: ModuleArg,
        #[arg(allow_negative_numbers = true)]
        vel: f64,
        #[arg(long)]
        ticks: bool,
        #[arg(long)]
        force: bool,
    },
    /// Current (torque) motion
    MoveCur {
        #[command(flatten)]
        module: ModuleArg,
        #[arg(allow_negative_numbers = true)]
        amps: f64,
        #[arg(long)]
        force: bool,
    },
    /// Read parameters by manual name (case-insensitive) or id (decimal or 0x hex)
    GetParam {
        #[command(flatten)]
        module: ModuleArg,
        #[arg(value_name = "NAME|ID", required_unless_present = "all")]
        params: Vec<String>,
        /// Every readable parameter
        #[arg(long, conflicts_with = "params")]
        all: bool,
    },
    /// Write a parameter
    SetParam {
        #[command(flatten)]
        module: ModuleArg,
        #[arg(value_name = "NAME|ID")]
        param: String,
        #[arg(allow_negative_numbers = true)]
        value: String,
    },
    /// The Config word, decoded
    GetConfig(ModuleArg),
    /// Change Config flags: +FLAG sets, -FLAG clears (manual or short names)
    SetConfig {
        #[command(flatten)]
        module: ModuleArg,
        #[arg(value_name = "+FLAG|-FLAG", allow_hyphen_values = true, required_unless_present = "raw")]
        changes: Vec<String>,
        /// Write the whole word
        #[arg(long, value_name = "0xHEX", conflicts_with = "changes")]
        raw: Option<String>,
    },
    /// Digital I/O (DioSetup): show, or set the outputs
    Dio {
        #[command(flatten)]
        module: ModuleArg,
        /// Set outputs 0..3 to this 4-bit mask (e.g. 0b0101)
        #[arg(long, value_name = "MASK")]
        out: Option<String>,
    },
    /// The module watchdog: switch it online / offline, or keep it alive
    Watchdog {
        #[command(subcommand)]
        action: WatchdogAction,
    },
    /// Decode a raw word offline: cube-state, config, dio, ..., cdios-status, pac-axis-status, ... (an unknown KIND lists them all)
    Decode {
        /// What the value is
        kind: String,
        /// The raw value (decimal, 0x hex or 0b binary; hex bytes for profibus-image)
        value: String,
    },
    /// Serve the simulated bench on pseudo-terminals until stopped
    Sim(SimArgs),
    /// Passive, decoded bus monitor on any CAN link, or replay of a candump log
    Monitor(MonitorArgs),
    #[command(flatten)]
    Cdios(crate::cli_cdios::CdiosCommand),
    /// Live dashboard of every device on the links (try: --link sim dashboard)
    Dashboard(crate::cli_dashboard::DashboardArgs),
    #[command(flatten)]
    Pac(crate::cli_pac::PacCommand),
}

#[derive(Debug, Subcommand)]
pub enum WatchdogAction {
    /// Enable the watchdog in Config if needed and switch it online (then keep it alive!)
    On(ModuleArg),
    /// Switch the watchdog offline
    Off(ModuleArg),
    /// Broadcast the refresh [0x07, 0] until Ctrl-C (or --for S)
    Keepalive {
        /// Refresh interval, ms (the modules trip after 50 ms)
        #[arg(long, value_name = "MS", default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..50))]
        interval: u64,
        /// Stop after this many seconds
        #[arg(long = "for", value_name = "S")]
        duration: Option<f64>,
    },
}

#[derive(Debug, Args)]
pub struct SimArgs {
    /// Serve PowerCube modules: pty-serial, pty-slcan or socketcan:IFACE
    #[arg(long, value_name = "WHERE")]
    pub powercube: Option<String>,
    /// Serve the PA-CONTROL: pty-serial
    #[arg(long, value_name = "WHERE")]
    pub pac: Option<String>,
    /// Serve the Cdios node: pty-slcan or socketcan:IFACE
    #[arg(long, value_name = "WHERE")]
    pub cdios: Option<String>,
    /// PowerCube module ids
    #[arg(long, value_name = "LIST", default_value = "3,5,17")]
    pub modules: String,
    /// Which of them are linear
    #[arg(long, value_name = "LIST", default_value = "17")]
    pub linear: String,
    /// PA-CONTROL axes
    #[arg(long, default_value_t = 3)]
    pub axes: u8,
    /// Cdios node id
    #[arg(long, default_value_t = 1)]
    pub node: u8,
    /// Cdios 6168 module ids
    #[arg(long, value_name = "LIST", default_value = "0,1")]
    pub cdios_modules: String,
    /// Run the simulated lines at their real speed: serial at --baud, CAN at --bitrate
    #[arg(long)]
    pub wire_speed: bool,
    /// Baud rate of the served serial lines (with --wire-speed)
    #[arg(long, default_value_t = 9600)]
    pub baud: u32,
    /// CAN bitrate of the simulated bus (with --wire-speed)
    #[arg(long, default_value_t = 1_000_000)]
    pub bitrate: u32,
    /// Inject faults into the devices' answers, e.g. drop=0.2,delay=150ms,garbage=0.1,truncate=0.05,duplicate=0.1,wrong-module=0.05 (also delay=DUR@P, skip=N, count=N, trip=DUR: fault a device moving that long)
    #[arg(long, value_name = "SPEC")]
    pub fault: Option<String>,
    /// Seed of the fault decisions: the same seed replays the same faults
    #[arg(long, value_name = "N", default_value_t = 1, requires = "fault")]
    pub fault_seed: u64,
}

#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// Only these families: powercube, cdios, other (repeatable)
    #[arg(long, value_name = "FAMILY")]
    pub family: Vec<String>,
    /// Only frames of these module ids (PowerCube 1..31, Cdios 0..15; repeatable)
    #[arg(short, long, value_name = "ID")]
    pub module: Vec<u8>,
    /// Only these CAN ids, hex (e.g. 0F1; repeatable)
    #[arg(long, value_name = "HEX")]
    pub id: Vec<String>,
    /// Stop after this many shown frames
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Stop after this many seconds
    #[arg(long = "for", value_name = "S")]
    pub duration: Option<f64>,
    /// Print frame statistics at the end
    #[arg(long)]
    pub stats: bool,
    /// Print candump -L lines instead of decoded ones
    #[arg(long)]
    pub candump: bool,
    /// Decode a candump log file instead of listening on a link
    #[arg(long, value_name = "FILE")]
    pub from_log: Option<PathBuf>,
}
