//! The PowerCube subcommands, as typed (clap derive only). Flattened into
//! [`super::Command`]; `commands::powercube` gives them meaning.

mod motion;
pub(crate) mod values;

use clap::{Args, Subcommand};

use super::ids::{self, IdList};
use super::WaitArgs;
use axisctl::bench::DeviceRef;
use axisctl::family::{Family, POWERCUBE_MODULE};

/// One module: `-m 17`, or `-d powercube:17` / a bench file's name for it.
#[derive(Debug, Args, Clone)]
#[group(required = true, multiple = false)]
pub struct ModuleArg {
    /// PowerCube module address, 1 to 31
    #[arg(short, long, value_name = "ID", value_parser = ids::id(POWERCUBE_MODULE), add = super::complete::bench_modules())]
    pub module: Option<u8>,
    /// The module as a device of the bench: powercube:ID or the name a bench file gives it (instead of -m)
    #[arg(short, long, value_name = "DEVICE", add = super::complete::bench_devices(Some(Family::PowerCube)))]
    pub device: Option<DeviceRef>,
}

/// The modules a read is about: `-m 17`, `-m 3,5,17` or `-m all`, or
/// `-d powercube:3,powercube:5` (bench-file names too).
#[derive(Debug, Args, Clone)]
#[group(required = true, multiple = false)]
pub struct ModulesArg {
    /// PowerCube module address 1..31, a list (3,5,17 or 1-8: one object per module) or all (every module present)
    #[arg(short, long, value_name = "ID[,ID...]|all", value_parser = ids::devices(POWERCUBE_MODULE), add = super::complete::bench_modules())]
    pub module: Option<ids::Devices>,
    /// The modules as devices of the bench: powercube:ID or bench-file names, comma-separated (one device: one object; several: a list)
    #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(Some(Family::PowerCube)))]
    pub device: Option<Vec<DeviceRef>>,
}

/// `-m ID`, `-d DEVICE` or `--all` (broadcast).
#[derive(Debug, Args, Clone)]
#[group(required = true, multiple = false)]
pub struct Target {
    /// PowerCube module address, 1 to 31
    #[arg(short, long, value_name = "ID", value_parser = ids::id(POWERCUBE_MODULE), add = super::complete::bench_modules())]
    pub module: Option<u8>,
    /// Broadcast to every module on the bus (not acknowledged)
    #[arg(long)]
    pub all: bool,
    /// The module as a device of the bench: powercube:ID or the name a bench file gives it (instead of -m)
    #[arg(short, long, value_name = "DEVICE", add = super::complete::bench_devices(Some(Family::PowerCube)))]
    pub device: Option<DeviceRef>,
}

/// What `halt` stops: `-m ID`, `--all` (the broadcast; over a bench every
/// device of every family) or `-d DEVICE,...` (those devices, any family).
#[derive(Debug, Args, Clone)]
#[group(required = true, multiple = false)]
pub struct HaltTarget {
    /// PowerCube module address, 1 to 31
    #[arg(short, long, value_name = "ID", value_parser = ids::id(POWERCUBE_MODULE), add = super::complete::bench_modules())]
    pub module: Option<u8>,
    /// Broadcast to every module on the bus (not acknowledged); over a bench, every device of every family
    #[arg(long)]
    pub all: bool,
    /// Devices of the bench, any family: powercube:3, pac:2, cdios:1/0 or a bench file's name; each is stopped through its family (exit 0 when already at rest)
    #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(None))]
    pub device: Option<Vec<DeviceRef>>,
}

impl HaltTarget {
    /// The PowerCube target of `-m` or `--all`; `None` with `-d`.
    pub fn powercube(&self) -> Option<Target> {
        self.device.is_none().then_some(Target { module: self.module, all: self.all, device: None })
    }
}

/// Module ids in the order typed (`3,5,17`): positions pair with them by
/// place, so the list is neither sorted nor deduplicated here.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModuleList(pub Vec<u8>);

fn module_list(text: &str) -> Result<ModuleList, String> {
    let one = |s: &str| {
        let s = s.trim();
        s.parse::<u8>()
            .ok()
            .filter(|id| POWERCUBE_MODULE.contains(*id))
            .ok_or_else(|| format!("{s:?} is not a valid {POWERCUBE_MODULE}"))
    };
    text.split(',').map(one).collect::<Result<_, _>>().map(ModuleList)
}

#[derive(Debug, Subcommand)]
pub enum PowerCubeCommand {
    /// List the PowerCube modules on the link; over a bench, every device of every family
    Scan {
        /// Module addresses to probe, e.g. 1-31 or 3,5,17
        #[arg(short = 'm', long = "module", alias = "ids", value_name = "LIST", default_value = "1-31",
              value_parser = ids::list(POWERCUBE_MODULE))]
        ids: IdList,
        /// Probe only these devices, of any family on any link of the bench (instead of -m): powercube:ID, pac, pac:AXIS, cdios:NODE/MODULE or bench-file names, comma-separated; one that does not answer is listed as missing (exit 4)
        #[arg(
            short,
            long,
            value_name = "DEVICE[,DEVICE...]",
            value_delimiter = ',',
            num_args = 1,
            conflicts_with = "ids",
            add = super::complete::bench_devices(None)
        )]
        device: Vec<DeviceRef>,
    },
    /// Identity, kind, limits, position and state of modules
    Info(ModulesArg),
    /// CubeState, decoded flag by flag
    State(ModulesArg),
    /// Start the homing procedure
    Home {
        #[command(flatten)]
        target: Target,
        #[command(flatten)]
        wait: WaitArgs,
        /// With --wait (CAN): switch the watchdog on for this motion if it is off, refresh it while waiting, switch it off afterwards; if this process dies, the module halts within 50 ms
        #[arg(long, requires = "wait")]
        deadman: bool,
    },
    /// Clear the error state
    Reset {
        #[command(flatten)]
        target: Target,
    },
    /// Stop immediately; --all over a bench stops every device of every family, -d the devices named
    Halt {
        #[command(flatten)]
        target: HaltTarget,
    },
    /// Ramp (trapezoidal) motion to a position; with --sync several modules started together
    MoveRamp {
        /// PowerCube module address, 1 to 31; with --sync a list such as 3,5,17 (one position each, in order)
        #[arg(short, long = "module", value_name = "ID[,ID...]", value_parser = module_list, required_unless_present = "device")]
        modules: Option<ModuleList>,
        /// The modules as devices of the bench (instead of -m): powercube:ID or bench-file names; with --sync several, in order
        #[arg(
            short,
            long,
            value_name = "DEVICE[,DEVICE...]",
            value_delimiter = ',',
            num_args = 1,
            conflicts_with = "modules",
            add = super::complete::bench_devices(Some(Family::PowerCube))
        )]
        device: Option<Vec<DeviceRef>>,
        /// Target position (rad or m; encoder ticks with --ticks); with --sync one per module
        #[arg(allow_negative_numbers = true, required = true, num_args = 1..)]
        pos: Vec<f64>,
        /// Ramp velocity (TargetVel; units/s or ticks/s)
        #[arg(long)]
        vel: Option<f64>,
        /// Ramp acceleration (TargetAcc; units/s² or ticks/s²)
        #[arg(long)]
        acc: Option<f64>,
        /// Values are encoder ticks (IRAMP_MODE)
        #[arg(long)]
        ticks: bool,
        /// POS is a distance from the current position (ActPos, or ActIPos with --ticks)
        #[arg(long, conflicts_with = "sync")]
        relative: bool,
        /// Skip the check against the module's own limits
        #[arg(long)]
        force: bool,
        /// Synchronized: each module (in sync mode, CAN only) takes its target, then one StartMotion broadcast starts them all
        #[arg(long)]
        sync: bool,
        #[command(flatten)]
        wait: WaitArgs,
        /// With --wait (CAN): switch the watchdog on for this motion if it is off, refresh it while waiting, switch it off afterwards; if this process dies, the module halts within 50 ms
        #[arg(long, requires = "wait")]
        deadman: bool,
    },
    /// Step motion: reach a position in a given time
    MoveStep {
        #[command(flatten)]
        module: ModuleArg,
        /// Target position (rad or m; encoder ticks with --ticks)
        #[arg(allow_negative_numbers = true)]
        pos: f64,
        /// Time to reach the position, 1 to 65535 ms (the step's UInt16)
        #[arg(long, value_name = "MS", value_parser = ids::number(1u16, u16::MAX, "ms"))]
        time: u16,
        /// Values are encoder ticks
        #[arg(long)]
        ticks: bool,
        /// POS is a distance from the current position (ActPos, or ActIPos with --ticks)
        #[arg(long)]
        relative: bool,
        /// Skip the check against the module's own limits
        #[arg(long)]
        force: bool,
    },
    /// Velocity motion
    MoveVel {
        #[command(flatten)]
        module: ModuleArg,
        /// Velocity (rad/s or m/s; ticks/s with --ticks); 0 stops
        #[arg(allow_negative_numbers = true)]
        vel: f64,
        /// Values are encoder ticks
        #[arg(long)]
        ticks: bool,
        /// Skip the check against the module's own limits
        #[arg(long)]
        force: bool,
    },
    /// Current (torque) motion
    MoveCur {
        #[command(flatten)]
        module: ModuleArg,
        /// Motor current, A
        #[arg(allow_negative_numbers = true)]
        amps: f64,
        /// Skip the check against the module's own limits
        #[arg(long)]
        force: bool,
    },
    /// Read parameters by manual name (case-insensitive) or id (decimal or 0x hex)
    GetParam {
        #[command(flatten)]
        module: ModulesArg,
        /// Parameters by manual name (ActPos, case-insensitive) or id (60, 0x3c); `axisctl params` lists them
        #[arg(value_name = "NAME|ID", required_unless_present = "all", add = values::params())]
        params: Vec<String>,
        /// Every readable parameter
        #[arg(long, conflicts_with = "params")]
        all: bool,
    },
    /// Write a parameter
    SetParam {
        #[command(flatten)]
        module: ModuleArg,
        /// The parameter by manual name (case-insensitive) or id; `axisctl params` lists them
        #[arg(value_name = "NAME|ID", add = values::params())]
        param: String,
        /// The new value, in the parameter's unit
        #[arg(allow_negative_numbers = true)]
        value: String,
        /// Skip the check against the module's limits (never the manual's range or the wire type)
        #[arg(long)]
        force: bool,
    },
    /// The Config word, decoded
    GetConfig(ModuleArg),
    /// Change Config flags: +FLAG sets, -FLAG clears (manual or short names)
    SetConfig {
        #[command(flatten)]
        module: ModuleArg,
        /// Flags to set (+) or clear (-), by manual name or short form; `axisctl flags config` lists them
        #[arg(value_name = "+FLAG|-FLAG", allow_hyphen_values = true, required_unless_present = "raw",
              add = values::config_changes())]
        changes: Vec<String>,
        /// Write the whole word (needs --force: it may clear any safety flag)
        #[arg(long, value_name = "0xHEX", conflicts_with = "changes")]
        raw: Option<String>,
        /// Allow changes that remove a safety: +disable-ack, -sw1-enabled, -sw2-enabled, the watchdog flag, --raw
        #[arg(long)]
        force: bool,
    },
    /// Digital I/O (DioSetup): show, or set the outputs
    Dio {
        #[command(flatten)]
        module: ModuleArg,
        /// Set outputs 0 to 3 to this 4-bit mask (e.g. 0b0101)
        #[arg(long, value_name = "MASK")]
        out: Option<String>,
    },
    /// The module watchdog: switch it online / offline, or keep it alive
    Watchdog {
        #[command(subcommand)]
        action: WatchdogAction,
    },
}

/// The longest keep-alive interval: the modules trip 50 ms after the last refresh.
pub const MAX_KEEPALIVE_MS: u64 = 49;

/// `--interval`: said and checked as the same range.
fn keepalive_interval(text: &str) -> Result<u64, String> {
    match text.trim().parse::<u64>() {
        Ok(ms @ 1..=MAX_KEEPALIVE_MS) => Ok(ms),
        _ => Err(format!("{text:?} is not an interval of 1 to {MAX_KEEPALIVE_MS} ms (the modules trip after 50 ms)")),
    }
}

#[derive(Debug, Subcommand)]
pub enum WatchdogAction {
    /// Enable the watchdog in Config and switch it online, unless it is on already (then keep it alive!)
    On(ModuleArg),
    /// Take the watchdog out of action (clears CONFIGID_MOD_WATCHDOG_ENABLE; nothing sent when it is off)
    Off(ModuleArg),
    /// Broadcast the refresh [0x07, 0] until Ctrl-C (or --for S)
    Keepalive {
        /// Refresh interval, 1 to 49 ms (the modules trip after 50 ms)
        #[arg(long, value_name = "MS", default_value_t = 20, value_parser = keepalive_interval)]
        interval: u64,
        /// Stop after this many seconds
        #[arg(long = "for", value_name = "S")]
        duration: Option<f64>,
    },
}
