//! The PA-CONTROL subcommands, as typed (clap derive only). Flattened into
//! [`super::Command`]; `commands::pac` gives them meaning.

mod motion;
pub mod send;

use clap::{Args, Subcommand};

use super::{ids, Switch};
use axisctl::bench::DeviceRef;
use axisctl::family::{Family, IdRange, PAC_AXIS};

/// An axis number (the controller's own count is checked when known).
fn axis_parser() -> impl Fn(&str) -> Result<u8, String> + Clone + Send + Sync + 'static {
    ids::id(PAC_AXIS)
}

/// One axis: `2`, or `-d pac:2` / the name a bench file gives it. clap
/// gives positionals out by place, so a line that names a device is parsed
/// with AXIS out of the positionals ([`device_form`]): `pac-move -d slide
/// 900` reads 900 as the position, and every line without `-d` is parsed as
/// it always was.
#[derive(Debug, Args, Clone)]
pub struct AxisArg {
    /// Axis number, 1 to 16 (or -d DEVICE in its place)
    #[arg(value_name = "AXIS", value_parser = axis_parser(), required = true)]
    pub axis: Option<u8>,
    /// The axis as a device of the bench: pac:AXIS or the name a bench file gives it (instead of AXIS)
    #[arg(short, long, value_name = "DEVICE", conflicts_with = "axis", add = super::complete::bench_devices(Some(Family::Pac)))]
    pub device: Option<DeviceRef>,
}

impl AxisArg {
    /// The axis number, once `-d` is resolved (`commands::pac` resolves
    /// every device before the link opens).
    pub fn number(&self) -> u8 {
        self.axis.expect("clap requires AXIS or -d, and -d is resolved to AXIS before the command runs")
    }
}

/// The axes a read is about: `2`, `1,3` or `all`, or `-d pac:1,pac:3`
/// (bench-file names too; see [`AxisArg`]).
#[derive(Debug, Args, Clone)]
pub struct AxesArg {
    /// Axis number 1..16, a list (1,3 or 1-3: one object per axis) or all (every configured axis); or -d DEVICE[,DEVICE...] in its place
    #[arg(value_name = "AXIS[,AXIS...]|all", value_parser = ids::devices(PAC_AXIS), required = true)]
    pub axis: Option<ids::Devices>,
    /// The axes as devices of the bench: pac:AXIS or bench-file names, comma-separated (one device: one object; several: a list)
    #[arg(
        short,
        long,
        value_name = "DEVICE[,DEVICE...]",
        value_delimiter = ',',
        num_args = 1,
        conflicts_with = "axis",
        add = super::complete::bench_devices(Some(Family::Pac))
    )]
    pub device: Option<Vec<DeviceRef>>,
}

/// The controller a controller-level command talks to: the bench's
/// PA-CONTROL, or with `-d` the one named, which picks its serial link when
/// a bench file has several.
#[derive(Debug, Args, Clone, Default)]
pub struct ControllerArg {
    /// The controller as a device of the bench: pac or the name a bench file gives it (picks its link)
    #[arg(short, long, value_name = "DEVICE", add = super::complete::bench_devices(Some(Family::Pac)))]
    pub device: Option<DeviceRef>,
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
    PacOnline(ControllerArg),
    /// PA-CONTROL: abort online mode, back to home position (0A81)
    PacOffline(ControllerArg),
    /// PA-CONTROL: STOP automatic or online positioning (0600)
    PacStop(ControllerArg),
    /// PA-CONTROL: start automatic mode from home position (0602)
    PacAutoStart(ControllerArg),
    /// PA-CONTROL: abort automatic mode, back to home position (0A41)
    PacAutoAbort(ControllerArg),
    /// PA-CONTROL: operating status and error number (190B)
    PacState(ControllerArg),
    /// PA-CONTROL: the PA-CONTROL error number (1909)
    PacError(ControllerArg),
    /// PA-CONTROL: reset a class 2 system error, home position only (0909)
    PacResetError(ControllerArg),
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
    PacAxes(ControllerArg),
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
        /// Axis number, or 0 for all axes (or -d DEVICE in its place)
        #[arg(value_parser = ids::id(IdRange { min: 0, ..PAC_AXIS }), required = true)]
        axis: Option<u8>,
        /// The axis as a device of the bench, pac:AXIS or a bench-file name; pac (the controller) for all axes (instead of AXIS)
        #[arg(short, long, value_name = "DEVICE", conflicts_with = "axis", add = super::complete::bench_devices(Some(Family::Pac)))]
        device: Option<DeviceRef>,
        /// on or off
        #[arg(value_enum)]
        state: Switch,
    },
    /// PA-CONTROL: read an input (1900), or with --word the 16 inputs of its word (1901)
    PacIn {
        #[command(flatten)]
        controller: ControllerArg,
        /// Input number, 1 to 1024
        number: u16,
        /// Read the 16 inputs of the word that holds NUMBER
        #[arg(long)]
        word: bool,
    },
    /// PA-CONTROL: read an output (1902 / 1903), or set it (0902 / 0903 with --word)
    PacOut {
        #[command(flatten)]
        controller: ControllerArg,
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
        #[command(flatten)]
        controller: ControllerArg,
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
        #[command(flatten)]
        controller: ControllerArg,
        /// N<number>, R<number>, SN<number> or SR<number>
        register: String,
        /// New content
        #[arg(allow_negative_numbers = true)]
        value: Option<String>,
    },
    /// PA-CONTROL: read, write or show the limits of a system parameter (home position only)
    PacSysParam {
        #[command(flatten)]
        controller: ControllerArg,
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
        #[command(flatten)]
        controller: ControllerArg,
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

/// The parser of a line that names a device: in every PA-CONTROL command
/// with both, AXIS stops being a positional (a hidden `--axis` nobody
/// types, which `-d` conflicts with) and `-d` is required. The words after
/// `-d DEVICE` then fall to the positionals after AXIS, in order, whatever
/// flags stand between them: `pac-move -d slide 900 --wait`,
/// `pac-axis-param -d slide acceleration 500`.
pub fn device_form(mut cmd: clap::Command) -> clap::Command {
    let has = |c: &clap::Command, id: &str| c.get_arguments().any(|a| a.get_id() == id);
    let names: Vec<String> = cmd
        .get_subcommands()
        .filter(|c| c.get_name().starts_with("pac-") && has(c, "axis") && has(c, "device"))
        .map(|c| c.get_name().to_string())
        .collect();
    for name in names {
        cmd = cmd.mut_subcommand(name, |c| {
            c.mut_arg("axis", |a| a.long("axis").hide(true).required(false)).mut_arg("device", |a| a.required(true))
        });
    }
    cmd
}

#[cfg(test)]
mod tests {
    use clap::FromArgMatches;

    use super::super::{Cli, Command};
    use super::*;

    /// A line as the binary parses it (`cli::command`, with its settings
    /// applied to every subcommand), or clap's error.
    fn parse(line: &str) -> Result<PacCommand, String> {
        let argv = std::iter::once("axisctl").chain(line.split_whitespace());
        let argv: Vec<&str> = argv.collect();
        let cmd = crate::cli::for_words(crate::cli::command(""), &argv);
        let matches = cmd.try_get_matches_from(argv).map_err(|e| e.to_string())?;
        match Cli::from_arg_matches(&matches).map_err(|e| e.to_string())?.command {
            Command::Pac(c) => Ok(c),
            other => panic!("{line}: not a PA-CONTROL command: {other:?}"),
        }
    }

    fn axis(c: &PacCommand) -> (Option<u8>, Option<String>) {
        let a = match c {
            PacCommand::PacMove { axis, .. }
            | PacCommand::PacMeasure { axis, .. }
            | PacCommand::PacSpeed { axis, .. }
            | PacCommand::PacAxisParam { axis, .. }
            | PacCommand::PacAxisPower { axis, .. } => axis,
            other => panic!("no single axis: {other:?}"),
        };
        (a.axis, a.device.as_ref().map(ToString::to_string))
    }

    /// Lines without `-d` are parsed as they always were, flags between the
    /// axis and its value and `--` included; with `-d` the words after it
    /// are the values after AXIS, wherever the flags stand.
    #[test]
    fn a_device_stands_in_for_the_axis_and_the_values_keep_their_places() {
        let pos = |c: &PacCommand| match c {
            PacCommand::PacMove { pos, relative, wait, .. } => (*pos, *relative, wait.wait),
            other => panic!("{other:?}"),
        };
        let by_number = (Some(2), None);
        let by_device = (None, Some("slide".to_string()));
        for (line, who, moved) in [
            ("pac-move 2 900", &by_number, (900.0, false, false)),
            ("pac-move 2 -5", &by_number, (-5.0, false, false)),
            ("pac-move 2 --relative 900", &by_number, (900.0, true, false)),
            ("pac-move --relative 2 900", &by_number, (900.0, true, false)),
            ("pac-move 2 --wait -- -5", &by_number, (-5.0, false, true)),
            ("pac-move -- 2 -5", &by_number, (-5.0, false, false)),
            ("pac-move -d slide 900", &by_device, (900.0, false, false)),
            ("pac-move -d slide 900 --wait", &by_device, (900.0, false, true)),
            ("pac-move --device slide --relative -5 --wait", &by_device, (-5.0, true, true)),
            ("pac-move 900 -d slide", &by_device, (900.0, false, false)),
            ("pac-move -dslide -- -5", &by_device, (-5.0, false, false)),
            ("pac-move -vqd slide 900", &by_device, (900.0, false, false)),
            ("pac-move -v 2 -5", &by_number, (-5.0, false, false)),
        ] {
            let c = parse(line).unwrap_or_else(|e| panic!("{line}: {e}"));
            assert_eq!((&axis(&c), pos(&c)), (who, moved), "{line}");
        }
        let measure = parse("pac-measure 2 --off").unwrap();
        assert!(matches!(measure, PacCommand::PacMeasure { state: None, off: true, .. }), "{measure:?}");
        assert_eq!(axis(&measure), by_number);
        let measure = parse("pac-measure -d slide on").unwrap();
        assert!(matches!(measure, PacCommand::PacMeasure { state: Some(Switch::On), .. }), "{measure:?}");
        let param = parse("pac-axis-param -d slide acceleration 500").unwrap();
        assert_eq!(axis(&param), by_device);
        assert!(
            matches!(&param, PacCommand::PacAxisParam { param, access, .. }
            if param == "acceleration" && access.value.as_deref() == Some("500")),
            "{param:?}"
        );
        let param = parse("pac-axis-param 2 acceleration 500").unwrap();
        assert_eq!(axis(&param), by_number);
        assert_eq!(axis(&parse("pac-axis-power -d pac:3 on").unwrap()), (None, Some("pac:3".into())));
        assert_eq!(axis(&parse("pac-speed --device=slide -5").unwrap()), by_device);
        let axes = parse("pac-axis -d slide,pac:1").unwrap();
        assert!(
            matches!(&axes, PacCommand::PacAxis(a) if a.axis.is_none() && a.device.as_ref().map(Vec::len) == Some(2))
        );
        let state = parse("pac-state -d pac").unwrap();
        assert!(matches!(&state, PacCommand::PacState(c) if c.device.is_some()), "{state:?}");
        // Old lines with no controller named still parse.
        assert!(matches!(parse("pac-state").unwrap(), PacCommand::PacState(ControllerArg { device: None })));
    }

    /// Both forms at once, neither, or the hidden `--axis` without `-d`,
    /// are clap's usage errors.
    #[test]
    fn a_device_and_an_axis_number_are_one_or_the_other() {
        for line in [
            "pac-move -d slide 2 900",
            "pac-move -d slide",
            "pac-move 900",
            "pac-move --axis 2 900",
            "pac-move -d slide --axis 2 900",
            "pac-axis",
            "pac-axis 2 -d slide",
            "pac-limit-switch on",
        ] {
            assert!(parse(line).is_err(), "{line} was accepted: {:?}", parse(line));
        }
    }

    /// Each PA-CONTROL command that takes an axis takes `-d` in its place,
    /// and each of the controller takes `-d` for the controller: a new
    /// command must say which.
    #[test]
    fn every_pac_command_takes_a_device() {
        let cmd = crate::cli::command("");
        let device_form = device_form(cmd.clone());
        for c in cmd.get_subcommands().filter(|c| c.get_name().starts_with("pac-")) {
            let has = |id: &str| c.get_arguments().any(|a| a.get_id() == id);
            assert!(has("device"), "{} takes no -d", c.get_name());
            if has("axis") {
                let d = device_form.find_subcommand(c.get_name()).unwrap();
                assert!(d.get_positionals().all(|a| a.get_id() != "axis"), "{}", c.get_name());
            }
        }
    }
}
