//! The `cdios-*` command line, as typed (clap derive only). Ranges of the
//! manual are checked by `commands::cdios` against the protocol table before
//! anything is sent; clap only checks the addressing.

mod motion;

use clap::{Args, Subcommand, ValueEnum};

use super::ids;
use super::WaitArgs;
use axisctl::bench::DeviceRef;
use axisctl::family::{Family, CDIOS_FACTORY_NODE, CDIOS_MODULE, CDIOS_NODE};

/// Which node, and how it is talked to.
#[derive(Debug, Args, Clone, Copy)]
pub struct NodeArgs {
    /// Cdios node id (CANopen), 1 to 127; 1 is the factory setting
    #[arg(long, value_name = "N", default_value_t = CDIOS_FACTORY_NODE, value_parser = ids::id(CDIOS_NODE))]
    pub node: u8,
    /// Do not send the NMT start (the node is operational already)
    #[arg(long)]
    pub no_nmt: bool,
    /// The controller's 'Confirm' is 0: do not wait for confirmations, only for errors
    #[arg(long)]
    pub no_confirm: bool,
}

/// A 6168 module on a node: `--node N -m ID`, or `-d cdios:N/ID` / a bench
/// file's name for it.
#[derive(Debug, Args, Clone)]
pub struct ModuleTarget {
    #[command(flatten)]
    pub node: NodeArgs,
    /// 6168 module id on the node (DIP switch), 0 to 15
    #[arg(short, long, value_name = "ID", value_parser = ids::id(CDIOS_MODULE), required_unless_present = "device")]
    pub module: Option<u8>,
    /// The module as a device of the bench: cdios:NODE/ID or the name a bench file gives it (instead of --node and -m)
    #[arg(short, long, value_name = "DEVICE", conflicts_with_all = ["node", "module"], add = super::complete::bench_devices(Some(Family::Cdios)))]
    pub device: Option<DeviceRef>,
}

/// The nodes a read is about: `--node 1` or a list, `--node 1,2`.
#[derive(Debug, Args, Clone)]
pub struct NodesArgs {
    /// Cdios node id (CANopen) 1 to 127, or a list (1,2 or 1-3: the modules of each node); 1 is the factory setting
    #[arg(
        long,
        value_name = "N[,N...]",
        default_value_t = ids::Devices::One(CDIOS_FACTORY_NODE),
        value_parser = ids::nodes(CDIOS_NODE)
    )]
    pub node: ids::Devices,
    /// Do not send the NMT start (the node is operational already)
    #[arg(long)]
    pub no_nmt: bool,
    /// The controller's 'Confirm' is 0: do not wait for confirmations, only for errors
    #[arg(long)]
    pub no_confirm: bool,
}

impl NodesArgs {
    /// Each node named, in id order, with the options of this command.
    pub fn each(&self) -> Vec<NodeArgs> {
        let ids = match &self.node {
            ids::Devices::One(n) => vec![*n],
            ids::Devices::List(l) => l.0.clone(),
            ids::Devices::All => unreachable!("ids::nodes refuses all"),
        };
        ids.into_iter().map(|node| NodeArgs { node, no_nmt: self.no_nmt, no_confirm: self.no_confirm }).collect()
    }
}

/// The 6168 modules a read is about: `-m 0`, `-m 0,1` or `-m all`, on one
/// node or several; or `-d cdios:1/0,cdios:2/1` (bench-file names too), the
/// modules named and no others.
#[derive(Debug, Args, Clone)]
pub struct ModulesTarget {
    #[command(flatten)]
    pub node: NodesArgs,
    /// 6168 module id 0..15, a list (0,1 or 0-3: one object per module) or all (every module the node reports)
    #[arg(
        short,
        long,
        value_name = "ID[,ID...]|all",
        value_parser = ids::devices(CDIOS_MODULE),
        required_unless_present = "device"
    )]
    pub module: Option<ids::Devices>,
    /// The modules as devices of the bench: cdios:NODE/ID or bench-file names, comma-separated, on one node or several (one device: one object; several: a list in the order named) (instead of --node and -m)
    #[arg(
        short,
        long,
        value_name = "DEVICE[,DEVICE...]",
        value_delimiter = ',',
        num_args = 1,
        conflicts_with_all = ["node", "module"],
        add = super::complete::bench_devices(Some(Family::Cdios))
    )]
    pub device: Option<Vec<DeviceRef>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PositionKind {
    /// The current motor position
    Current,
    /// The position latched by the latest SYNC
    Latched,
    /// The setpoint (latest GOTO position / traject end)
    Setpoint,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DirectionArg {
    Forward,
    Reverse,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StartOptionArg {
    /// 0: start and remain at minimum speed
    MinSpeed,
    /// 1: start at minimum speed, accelerate to maximum speed
    Accelerate,
    /// 2: minimum speed until the end switch of the direction
    UntilEndSwitch,
    /// 3: accelerate / decelerate to --speed (0 stops)
    ToSpeed,
    /// 4: minimum speed until the I (index) input; position set to zero
    UntilIndex,
    /// 6: minimum speed until the I and Z inputs; position set to zero
    UntilIndexAndZero,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum StopOptionArg {
    /// 0: decelerate to minimum speed and keep running
    ToMinSpeed,
    /// 1: decelerate to minimum speed, then stop
    Decelerate,
    /// 2: fast stop
    Fast,
    /// 3: release the emergency stop (status 2 bit 5)
    ReleaseEmergency,
    /// 4: clear the hold status
    ClearHold,
}

#[derive(Debug, Subcommand)]
pub enum CdiosCommand {
    /// Cdios: the module types and versions the controller of a node knows (01h)
    #[command(name = "cdios-identify")]
    Identify {
        #[command(flatten)]
        node: NodeArgs,
        /// A module of the node as a device of the bench: cdios:NODE/ID or a bench-file name; its node is identified (instead of --node)
        #[arg(short, long, value_name = "DEVICE", conflicts_with = "node", add = super::complete::bench_devices(Some(Family::Cdios)))]
        device: Option<DeviceRef>,
    },
    /// Cdios: the four motor status bytes decoded, motor speed and RPM error (26h)
    #[command(name = "cdios-status")]
    Status(ModulesTarget),
    /// Cdios: the motor position: current, latched or setpoint (21h)
    #[command(name = "cdios-position")]
    Position {
        #[command(flatten)]
        target: ModulesTarget,
        /// Which position
        #[arg(long, value_enum, default_value_t = PositionKind::Current, conflicts_with = "all")]
        source: PositionKind,
        /// All three
        #[arg(long)]
        all: bool,
    },
    /// Cdios: set the motor position and the setpoint (22h; motor stopped)
    #[command(name = "cdios-set-position")]
    SetPosition {
        #[command(flatten)]
        target: ModuleTarget,
        /// The position the motor takes as its current one and its setpoint, in counts
        #[arg(allow_negative_numbers = true)]
        position: i64,
    },
    /// Cdios: move to a position (23h); absolute unless told otherwise
    #[command(name = "cdios-goto")]
    Goto {
        #[command(flatten)]
        target: ModuleTarget,
        /// Position, or steps with --relative / --setpoint-relative
        #[arg(allow_negative_numbers = true)]
        position: i64,
        /// Steps from the current position
        #[arg(long, conflicts_with = "setpoint_relative")]
        relative: bool,
        /// Steps from the current setpoint (the last GOTO position)
        #[arg(long)]
        setpoint_relative: bool,
        /// Latch the move; the motor moves on the next SYNC
        #[arg(long, conflicts_with = "wait")]
        latched: bool,
        /// Maximum speed of this goto, RPM (sent first as 'Next GOTO Speed'; 0 = configured maximum)
        #[arg(long, value_name = "RPM")]
        speed: Option<i64>,
        /// Skip the check of --speed against the module's configured speeds (the manual's ranges still apply)
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        wait: WaitArgs,
    },
    /// Cdios: run traject 0 or 1 as configured with cdios-config (23h selector 6/7)
    #[command(name = "cdios-traject")]
    Traject {
        #[command(flatten)]
        target: ModuleTarget,
        /// Traject number
        traject: i64,
        /// Start on the next SYNC
        #[arg(long, conflicts_with = "wait")]
        latched: bool,
        #[command(flatten)]
        wait: WaitArgs,
    },
    /// Cdios: manual motion (24h)
    #[command(name = "cdios-start")]
    Start {
        #[command(flatten)]
        target: ModuleTarget,
        /// Which way the motor turns
        #[arg(long, value_enum, default_value_t = DirectionArg::Forward)]
        direction: DirectionArg,
        /// How the motor starts (the manual's start option)
        #[arg(long, value_enum)]
        option: StartOptionArg,
        /// Target speed for --option to-speed, RPM
        #[arg(long, value_name = "RPM")]
        speed: Option<i64>,
        /// Start on the next SYNC
        #[arg(long)]
        latched: bool,
    },
    /// Cdios: stop the motor (25h; by default decelerate and stop)
    #[command(name = "cdios-stop")]
    Stop {
        #[command(flatten)]
        target: ModuleTarget,
        /// How the motor stops (the manual's stop option)
        #[arg(long, value_enum, default_value_t = StopOptionArg::Decelerate)]
        option: StopOptionArg,
        /// Stop on the next SYNC
        #[arg(long)]
        latched: bool,
    },
    /// Cdios: enable the motor (24h option 5): the position becomes the setpoint
    #[command(name = "cdios-enable")]
    Enable {
        #[command(flatten)]
        target: ModuleTarget,
        /// Release an emergency stop first (25h option 3)
        #[arg(long)]
        release_emergency: bool,
    },
    /// Cdios: disable the motor (25h option 5; a running motor fast-stops)
    #[command(name = "cdios-disable")]
    Disable(ModuleTarget),
    /// Cdios: servo configuration (20h): show [PART...], or set FIELD=VALUE... (read, modify, write each selector)
    #[command(name = "cdios-config")]
    Config {
        #[command(flatten)]
        target: ModuleTarget,
        /// Parts to show (speeds, voltage, encoder, control, inputs, traject0, traject1), or FIELD=VALUE to set
        #[arg(value_name = "PART|FIELD=VALUE", allow_negative_numbers = true)]
        items: Vec<String>,
    },
    /// Cdios: the 4 digital outputs (10h): show, or --set MASK
    #[command(name = "cdios-outputs")]
    Outputs {
        #[command(flatten)]
        target: ModuleTarget,
        /// Outputs 1 to 4 as bits 0 to 3 (e.g. 0b0101)
        #[arg(long, value_name = "MASK")]
        set: Option<String>,
        /// Update on the next SYNC
        #[arg(long, requires = "set")]
        latched: bool,
    },
    /// Cdios: the 2 analog outputs (16h): show, or --set MV on --output N
    #[command(name = "cdios-analog")]
    Analog {
        #[command(flatten)]
        target: ModuleTarget,
        /// Output 1 or 2 (both are shown by default)
        #[arg(long, value_name = "N")]
        output: Option<i64>,
        /// New value in mV, -10000 to 10000
        #[arg(long, value_name = "MV", allow_negative_numbers = true, requires = "output")]
        set: Option<i64>,
        /// Update on the next SYNC
        #[arg(long, requires = "set")]
        latched: bool,
    },
    /// Cdios: status change event masks and position / speed timers (27h): show, or change
    #[command(name = "cdios-events")]
    Events {
        #[command(flatten)]
        target: ModuleTarget,
        /// Status flags that raise events, by name (e.g. GOTO_ACTIVE,ENABLED); 'none' clears
        #[arg(long, value_name = "FLAGS", conflicts_with = "raw_masks")]
        mask: Option<String>,
        /// The four mask bytes, e.g. 0x80,0,0x80,0
        #[arg(long, value_name = "M1,M2,M3,M4")]
        raw_masks: Option<String>,
        /// 'Send current position' interval code 0 to 7 (0 never, 1 3.9 ms to 7 250 ms)
        #[arg(long, value_name = "CODE")]
        position_interval: Option<i64>,
        /// Send the position only when it changed
        #[arg(long, value_name = "BOOL")]
        position_on_change: Option<bool>,
        /// 'Send MotorSpeed/RPM Error' interval code 0 to 7
        #[arg(long, value_name = "CODE")]
        speed_interval: Option<i64>,
        /// Send the speed only when it changed
        #[arg(long, value_name = "BOOL")]
        speed_on_change: Option<bool>,
    },
    /// Cdios: store the configuration in EEPROM (05h; 260 to 750 ms; motor disabled)
    #[command(name = "cdios-store")]
    Store {
        #[command(flatten)]
        target: ModuleTarget,
        /// Reset to the defaults first, then store
        #[arg(long)]
        defaults: bool,
    },
    /// Cdios: events and polled status as they come, until Ctrl-C, --count or --for
    #[command(name = "cdios-watch")]
    Watch {
        #[command(flatten)]
        target: ModuleTarget,
        /// Status poll interval, ms
        #[arg(long, value_name = "MS", default_value_t = 100)]
        poll: u64,
        /// Events only, no status polling
        #[arg(long)]
        no_poll: bool,
        /// Stop after this many lines
        #[arg(long, value_name = "N")]
        count: Option<u64>,
        /// Stop after this many seconds
        #[arg(long = "for", value_name = "S")]
        duration: Option<f64>,
    },
}
