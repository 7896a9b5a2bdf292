//! The PA-CONTROL subcommands, as typed (clap derive only). Flattened into
//! [`super::Command`]; `commands::pac` gives them meaning.

mod motion;
pub mod send;

use clap::{Args, Subcommand};

use super::{ids, Switch};
use axisctl::family::{IdRange, PAC_AXIS};

/// An axis number (the controller's own count is checked when known).
fn axis_parser() -> impl Fn(&str) -> Result<u8, String> + Clone + Send + Sync + 'static {
    ids::id(PAC_AXIS)
}

#[derive(Debug, Args, Clone, Copy)]
pub struct AxisArg {
    /// Axis number, 1 to 16
    #[arg(value_name = "AXIS", value_parser = axis_parser())]
    pub axis: u8,
}

/// The axes a read is about: `2`, `1,3` or `all`.
#[derive(Debug, Args, Clone)]
pub struct AxesArg {
    /// Axis number 1..16, a list (1,3 or 1-3: one object per axis) or all (every configured axis)
    #[arg(value_name = "AXIS[,AXIS...]|all", value_parser = ids::devices(PAC_AXIS))]
    pub axis: ids::Devices,
}

#[derive(Debug, Args, Clone, Copy)]
pub struct PacWait {
    /// Wait until the axis stands still, showing the position live (Ctrl-C stops the axis)
    #[arg(long)]
    pub wait: bool,
    /// Give up waiting after this many seconds, 0.001 to 86400 (the axis is stopped, exit 7)
    #[arg(long, value_name = "S", default_value = super::wait::DEFAULT_WAIT_TIMEOUT, value_parser = super::wait::wait_timeout,
          requires = "wait")]
    pub wait_timeout: std::time::Duration,
    /// Poll interval while waiting, in ms
    #[arg(long, value_name = "MS", default_value_t = 50, value_parser = super::wait::poll_ms(), requires = "wait")]
    pub poll: u64,
    /// Stream one JSON line per poll on stderr: {"progress": {"axis", "position", "status", ...}}
    #[arg(long, requires = "wait")]
    pub progress_json: bool,
}

/// Read one parameter, its limits, or write it.
#[derive(Debug, Args, Clone)]
pub struct ParamAccess {
    /// The new value (checked against the controller's min / max first)
    #[arg(allow_negative_numbers = true, conflicts_with_all = ["min", "max"])]
    pub value: Option<String>,
    /// Read the parameter's minimum instead
    #[arg(long, conflicts_with = "max")]
    pub min: bool,
    /// Read the parameter's maximum instead
    #[arg(long)]
    pub max: bool,
}

// clap derives each subcommand's name from its variant: the prefix is the
// contract's `pac-` and has to be there.
#[allow(clippy::enum_variant_names)]
#[derive(Debug, Subcommand)]
pub enum PacCommand {
    /// PA-CONTROL: start online mode from home position (0603)
    PacOnline,
    /// PA-CONTROL: abort online mode, back to home position (0A81)
    PacOffline,
    /// PA-CONTROL: STOP automatic or online positioning (0600)
    PacStop,
    /// PA-CONTROL: start automatic mode from home position (0602)
    PacAutoStart,
    /// PA-CONTROL: abort automatic mode, back to home position (0A41)
    PacAutoAbort,
    /// PA-CONTROL: operating status and error number (190B)
    PacState,
    /// PA-CONTROL: the PA-CONTROL error number (1909)
    PacError,
    /// PA-CONTROL: reset a class 2 system error, home position only (0909)
    PacResetError,
    /// PA-CONTROL: move an axis (0A94 / 0A95; with --wait until it stands still)
    PacMove {
        #[command(flatten)]
        axis: AxisArg,
        /// Target position (distance with --relative), in the axis' unit
        #[arg(allow_negative_numbers = true)]
        pos: f64,
        /// POS is a distance from the current position
        #[arg(long)]
        relative: bool,
        /// Skip the check against the axis' traverse area read from the controller
        #[arg(long)]
        force: bool,
        #[command(flatten)]
        wait: PacWait,
    },
    /// PA-CONTROL: reference drive of an axis (0A84)
    PacRef {
        #[command(flatten)]
        axis: AxisArg,
        #[command(flatten)]
        wait: PacWait,
    },
    /// PA-CONTROL: release an axis without a reference drive (0A83, no motion)
    PacNoRef(AxisArg),
    /// PA-CONTROL: set an axis' current position to zero (0A85)
    PacZero(AxisArg),
    /// PA-CONTROL: set an axis' current position to POS (0A86)
    PacSetPos {
        #[command(flatten)]
        axis: AxisArg,
        /// The position the axis takes as its current one, in the axis' unit
        #[arg(allow_negative_numbers = true)]
        pos: f64,
    },
    /// PA-CONTROL: set an axis' traverse speed for online mode (0A8D)
    PacSpeed {
        #[command(flatten)]
        axis: AxisArg,
        /// Traverse speed, in the axis' unit per second
        speed: f64,
    },
    /// PA-CONTROL: set an axis' acceleration for online mode (0A8E)
    PacAccel {
        #[command(flatten)]
        axis: AxisArg,
        /// Acceleration, in the axis' unit per second squared
        accel: f64,
    },
    /// PA-CONTROL: stop an axis (0A9A; with --wait 0A93, answered at standstill)
    PacStopAxis {
        #[command(flatten)]
        axis: AxisArg,
        /// Wait for standstill (0A93: the controller answers once the axis stands)
        #[arg(long)]
        wait: bool,
        /// The former default, now without effect: the stop returns at once unless --wait
        #[arg(long, hide = true, conflicts_with = "wait")]
        no_wait: bool,
    },
    /// PA-CONTROL: position, speed, status and extended status of an axis
    PacAxis(AxesArg),
    /// PA-CONTROL: every configured axis with position and status
    PacAxes,
    /// PA-CONTROL: switch an axis on (0A97) or off (0A98)
    PacAxisPower {
        #[command(flatten)]
        axis: AxisArg,
        /// on or off
        #[arg(value_enum)]
        state: Switch,
    },
    /// The former name of `pac-axis-power AXIS on`
    #[command(hide = true)]
    PacAxisOn(AxisArg),
    /// The former name of `pac-axis-power AXIS off`
    #[command(hide = true)]
    PacAxisOff(AxisArg),
    /// PA-CONTROL: measuring mode of an axis on (0AA0) or off (0AA1)
    PacMeasure {
        #[command(flatten)]
        axis: AxisArg,
        /// on or off
        #[arg(value_enum, required_unless_present = "off")]
        state: Option<Switch>,
        /// The former way to say `off`
        #[arg(long, hide = true, conflicts_with = "state")]
        off: bool,
    },
    /// PA-CONTROL: limit switch monitoring of an axis (0 = all axes) on or off (0AA2)
    PacLimitSwitch {
        /// Axis number, or 0 for all axes
        #[arg(value_parser = ids::id(IdRange { min: 0, ..PAC_AXIS }))]
        axis: u8,
        /// on or off
        #[arg(value_enum)]
        state: Switch,
    },
    /// PA-CONTROL: read an input (1900), or with --word the 16 inputs of its word (1901)
    PacIn {
        /// Input number, 1 to 1024
        number: u16,
        /// Read the 16 inputs of the word that holds NUMBER
        #[arg(long)]
        word: bool,
    },
    /// PA-CONTROL: read an output (1902 / 1903), or set it (0902 / 0903 with --word)
    PacOut {
        /// Output number, 1 to 1024
        number: u16,
        /// 0 / 1, or the 16-bit word with --word (decimal, 0x hex or 0b binary)
        value: Option<String>,
        /// The 16 outputs of the word that holds NUMBER
        #[arg(long)]
        word: bool,
    },
    /// PA-CONTROL: read a flag (1904 / 1905), set it (0904 / 0905), or read system flag SM (1934)
    PacFlag {
        /// Flag number, 1 to 1024 (system flag number with --system)
        number: u16,
        /// 0 / 1, or the 16-bit word with --word (decimal, 0x hex or 0b binary)
        value: Option<String>,
        /// The 16 flags of the word that holds NUMBER
        #[arg(long, conflicts_with = "system")]
        word: bool,
        /// System flag SM (read only)
        #[arg(long)]
        system: bool,
    },
    /// PA-CONTROL: read or write a register: N5, R3 (integer / real), SN7 / SR2 (system, read only)
    PacReg {
        /// N<number>, R<number>, SN<number> or SR<number>
        register: String,
        /// New content
        #[arg(allow_negative_numbers = true)]
        value: Option<String>,
    },
    /// PA-CONTROL: read, write or show the limits of a system parameter (home position only)
    PacSysParam {
        /// Table name (e.g. number-of-axes) or number; `axisctl params pac` lists them
        param: String,
        #[command(flatten)]
        access: ParamAccess,
    },
    /// PA-CONTROL: read, write or show the limits of an axis parameter (home position only)
    PacAxisParam {
        #[command(flatten)]
        axis: AxisArg,
        /// Table name (e.g. acceleration) or number; `axisctl params pac` lists them
        param: String,
        #[command(flatten)]
        access: ParamAccess,
    },
    /// PA-CONTROL: send any command code: CODE (hex) PAR_1 [PAR_2]
    PacRaw {
        /// Command code, 4 hex digits (e.g. 190C) or the table name
        code: String,
        /// Command parameter (decimal)
        #[arg(allow_negative_numbers = true)]
        par1: i64,
        /// Command date: integer, or float with a '.'; typed by the table for known codes
        #[arg(allow_negative_numbers = true)]
        par2: Option<String>,
    },
}
