//! The PA-CONTROL tables: command codes (manual chapter 5), operating status
//! codes (6.4), command error numbers (6.5), system parameters (0700 list),
//! axis parameters (0800 list) and the axis status values (1910, 1911, 1921).
//!
//! Each row is declared once; the CLI, the simulator, validation and decoded
//! output read from here. Corrections to the manual follow the specs README.

use serde::Serialize;

// ---------------------------------------------------------------------------
// Operating modes

/// A set of operating modes in which a command is valid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(transparent)]
pub struct Modes(u8);

/// One operating mode (manual 3.1 / 2.4 access table).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// Home position ("initial position").
    Home,
    Manual,
    Automatic,
    Online,
}

impl Mode {
    pub const ALL: [Mode; 4] = [Mode::Home, Mode::Manual, Mode::Automatic, Mode::Online];

    const fn bit(self) -> u8 {
        match self {
            Self::Home => 1,
            Self::Manual => 2,
            Self::Automatic => 4,
            Self::Online => 8,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Home => "home position",
            Self::Manual => "manual",
            Self::Automatic => "automatic",
            Self::Online => "online",
        }
    }
}

impl Modes {
    pub const HOME: Modes = Modes(1);
    pub const MANUAL: Modes = Modes(2);
    pub const AUTOMATIC: Modes = Modes(4);
    pub const ONLINE: Modes = Modes(8);
    pub const ALL: Modes = Modes(15);

    pub const fn union(self, other: Modes) -> Modes {
        Modes(self.0 | other.0)
    }

    pub const fn contains(self, mode: Mode) -> bool {
        self.0 & mode.bit() != 0
    }

    pub fn iter(self) -> impl Iterator<Item = Mode> {
        Mode::ALL.into_iter().filter(move |m| self.contains(*m))
    }
}

impl std::fmt::Display for Modes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<_> = self.iter().map(Mode::name).collect();
        f.write_str(&names.join(", "))
    }
}

// ---------------------------------------------------------------------------
// Commands

/// What PAR_1 (the command parameter) addresses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Par1Kind {
    /// Not used; send 0.
    Unused,
    /// An axis, 1..=16.
    Axis,
    /// An axis, or 0 for all axes (0AA2, 0AA3).
    AxisOrAll,
    /// Input number, 1..=1024; for word commands any input of the word.
    Input,
    Output,
    Flag,
    /// Integer register N, 1..=1024.
    IntRegister,
    /// Real number register R, 1..=1024.
    FloatRegister,
    /// System parameter number (see [`SYSTEM_PARAMS`]).
    SystemParam,
    /// axis * 256 + axis parameter number (see [`AXIS_PARAMS`]).
    AxisParam,
    /// System flag SM / system N register SN / system R register SR number;
    /// the range is the controller's (PA-CONTROL programming manual).
    SystemElement,
}

impl Par1Kind {
    /// What PAR_1 means, for help texts.
    pub fn text(self) -> &'static str {
        match self {
            Self::Unused => "not used (0)",
            Self::Axis => "axis number 1 to 16",
            Self::AxisOrAll => "axis number 1 to 16, 0 = all axes",
            Self::Input => "input number 1 to 1024",
            Self::Output => "output number 1 to 1024",
            Self::Flag => "flag number 1 to 1024",
            Self::IntRegister => "integer register number 1 to 1024",
            Self::FloatRegister => "real number register number 1 to 1024",
            Self::SystemParam => "system parameter number",
            Self::AxisParam => "axis * 256 + axis parameter number",
            Self::SystemElement => "system element number",
        }
    }

    /// The valid PAR_1 range that the manual states, if any.
    pub fn range(self) -> Option<(i64, i64)> {
        match self {
            Self::Unused => Some((0, 0)),
            Self::Axis => Some((1, MAX_AXES as i64)),
            Self::AxisOrAll => Some((0, MAX_AXES as i64)),
            Self::Input | Self::Output | Self::Flag | Self::IntRegister | Self::FloatRegister => Some((1, 1024)),
            // Manual 5.2.2: 1..65535, narrowed by the table in validation.
            Self::SystemParam => Some((1, 65535)),
            // Manual 5.2.3: 0101h..10FFh.
            Self::AxisParam => Some((0x0101, 0x10FF)),
            Self::SystemElement => Some((0, 65535)),
        }
    }
}

/// What the command date (PAR_2) carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Par2Kind {
    /// Not used; send 0 with the command's TYP.
    Unused,
    /// 0 or 1.
    Bit,
    /// 0..=65535.
    Word16,
    /// A 32-bit signed integer.
    Int32,
    /// A real number (position, speed, register content, parameter value).
    Float,
    /// A system parameter value; the parameter's range applies.
    SystemParamValue,
    /// An axis parameter value; the parameter's range applies.
    AxisParamValue,
    /// 0AA3: `condition << 24 | element type << 16 | element number`
    /// (see [`Condition`]).
    Condition,
}

impl Par2Kind {
    /// What PAR_2 means, for help texts.
    pub fn text(self) -> &'static str {
        match self {
            Self::Unused => "not used (0)",
            Self::Bit => "state 0 / 1",
            Self::Word16 => "16-bit word 0 to 65535, bit 0 = first element of the word",
            Self::Int32 => "32-bit integer",
            Self::Float => "real number",
            Self::SystemParamValue => "system parameter value (integer)",
            Self::AxisParamValue => "axis parameter value (real number)",
            Self::Condition => "condition << 24 | element type (1 input, 2 output, 3 flag) << 16 | element number",
        }
    }
}

/// TYP of the command date and of the acknowledge date.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DataType {
    /// TYP 0.
    Int,
    /// TYP 1.
    Float,
}

impl DataType {
    pub fn typ(self) -> u8 {
        match self {
            Self::Int => 0,
            Self::Float => 1,
        }
    }
}

/// What the acknowledge date (Q_PAR) means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum AckKind {
    /// No meaning ("XXXX" in the manual).
    None,
    /// The value written, echoed.
    Echo,
    /// The state of one element, 0 or 1.
    Bit,
    /// 16 elements, bit 0 = the first element of the word.
    ElementWord,
    /// An integer value.
    Int,
    /// A real value.
    Float,
    /// The axis position where the move started (0A87, 0A89, 0A90, 0A91,
    /// 0A94, 0A95); on polls of 0A87/0A89 the current position.
    StartPosition,
    /// The current / stop position.
    Position,
    /// A PA-CONTROL error number (1909, 0909).
    ErrorNumber,
    /// 1910: see [`AXIS_STATUS`].
    AxisStatus,
    /// 1911: bit n = axis n+1 moving.
    AllAxesBitmap,
    /// 1921: see [`ExtAxisStatus`].
    ExtAxisStatus,
}

impl AckKind {
    /// What Q_PAR means, for help texts.
    pub fn text(self) -> &'static str {
        match self {
            Self::None => "no meaning",
            Self::Echo => "the value written",
            Self::Bit => "state 0 / 1",
            Self::ElementWord => "16 elements, bit 0 = first element of the word",
            Self::Int => "integer value",
            Self::Float => "real value",
            Self::StartPosition => "position where the move started (on polls: current position)",
            Self::Position => "current position",
            Self::ErrorNumber => "PA-CONTROL error number",
            Self::AxisStatus => "axis status (0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring mode)",
            Self::AllAxesBitmap => "bit n = axis n+1 moving",
            Self::ExtAxisStatus => "power pack, limit switches and axis status bytes",
        }
    }
}

/// How a command finishes, as seen in BE of its acknowledges.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Completion {
    /// Done when acknowledged (BE = 1).
    Immediate,
    /// Starts a move and answers BE = 0 until the move has ended; meanwhile
    /// only polls (lone EOT) may be sent (0A87, 0A89).
    StartAndWait,
    /// Starts a move and answers BE = 1 at once; check the axis status later
    /// (0A94, 0A95, and the manual moves 0A90 / 0A91).
    StartAndReturn,
    /// Moves nothing itself but answers BE = 0 until the axis stands still
    /// (0A93 stop axis).
    UntilStandstill,
}

impl Completion {
    /// Whether the first acknowledge normally has BE = 0.
    pub fn waits(self) -> bool {
        matches!(self, Self::StartAndWait | Self::UntilStandstill)
    }
}

/// One command code of chapter 5.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CommandDef {
    pub code: u16,
    /// CLI name: the manual name without `cmd_`, in kebab case.
    pub name: &'static str,
    /// The manual's name (section 5.2 heading).
    pub manual_name: &'static str,
    /// Manual section describing the command.
    pub section: &'static str,
    pub modes: Modes,
    pub par1: Par1Kind,
    pub par2: Par2Kind,
    /// TYP the command is sent with and of its acknowledge date.
    pub data_type: DataType,
    pub ack: AckKind,
    /// Starts an axis move.
    pub motion: bool,
    pub completion: Completion,
    pub description: &'static str,
}

impl CommandDef {
    /// "start and wait": BE = 0 until the move ends; only polls meanwhile.
    pub fn is_start_and_wait(&self) -> bool {
        self.completion == Completion::StartAndWait
    }

    pub fn code_hex(&self) -> String {
        format!("{:04X}", self.code)
    }
}

#[allow(clippy::too_many_arguments)]
const fn c(
    code: u16,
    name: &'static str,
    manual_name: &'static str,
    section: &'static str,
    modes: Modes,
    par1: Par1Kind,
    par2: Par2Kind,
    data_type: DataType,
    ack: AckKind,
    description: &'static str,
) -> CommandDef {
    CommandDef {
        code,
        name,
        manual_name,
        section,
        modes,
        par1,
        par2,
        data_type,
        ack,
        motion: false,
        completion: Completion::Immediate,
        description,
    }
}

const fn moving(def: CommandDef, completion: Completion) -> CommandDef {
    CommandDef { motion: true, completion, ..def }
}

const fn waiting(def: CommandDef, completion: Completion) -> CommandDef {
    CommandDef { completion, ..def }
}

/// The highest axis number the protocol can address.
pub const MAX_AXES: u8 = 16;

/// The manual's user units (AE) of an axis position, and of its speed.
pub const POSITION_UNIT: &str = "AE";
pub const SPEED_UNIT: &str = "AE/s";

const HOME: Modes = Modes::HOME;
const ALL: Modes = Modes::ALL;
const AUTO: Modes = Modes::AUTOMATIC;
const ONLINE: Modes = Modes::ONLINE;
const AUTO_ONLINE: Modes = Modes::AUTOMATIC.union(Modes::ONLINE);

use AckKind as A;
use DataType::{Float as F, Int as I};
use Par1Kind as P1;
use Par2Kind as P2;

/// Every command code of chapter 5, in the order of the overview (5.1).
#[rustfmt::skip]
pub const COMMANDS: &[CommandDef] = &[
    // 5.1.1 / 5.2.1 operating modes. The overview marks 0600 valid in
    // automatic only; its description (5.2.1.1) covers online mode too.
    c(0x0600, "stop", "cmd_stop", "5.2.1.1", AUTO_ONLINE, P1::Unused, P2::Unused, I, A::None,
      "STOP automatic or online positioning (like the STOP key): status 15 / 35 once all axes stand still"),
    c(0x0602, "start-auto", "cmd_start_auto", "5.2.1.2", HOME, P1::Unused, P2::Unused, I, A::None,
      "Go from home position to automatic mode and run the START program"),
    c(0x0603, "start-online", "cmd_start_online", "5.2.1.3", HOME, P1::Unused, P2::Unused, I, A::None,
      "Go from home position to online mode (an external stop input must be defined and powered)"),
    // 5.1.2 / 5.2.2 system parameters
    c(0x0700, "set-system-parameter", "cmd_set_system_parameter", "5.2.2.1", HOME, P1::SystemParam,
      P2::SystemParamValue, I, A::Echo, "Write a system parameter"),
    c(0x1700, "get-system-parameter", "cmd_get_system_parameter", "5.2.2.2", HOME, P1::SystemParam, P2::Unused, I,
      A::Int, "Read a system parameter"),
    c(0x1701, "get-system-parameter-max", "cmd_get_system_parameter_max", "5.2.2.3", HOME, P1::SystemParam,
      P2::Unused, I, A::Int, "Read a system parameter's maximum"),
    c(0x1702, "get-system-parameter-min", "cmd_get_system_parameter_min", "5.2.2.4", HOME, P1::SystemParam,
      P2::Unused, I, A::Int, "Read a system parameter's minimum"),
    // 5.1.3 / 5.2.3 axis parameters
    c(0x0800, "set-axis-parameter", "cmd_set_axis_parameter", "5.2.3", HOME, P1::AxisParam, P2::AxisParamValue, F,
      A::Echo, "Write an axis parameter (PAR_1 = axis * 256 + parameter)"),
    c(0x1800, "get-axis-parameter", "cmd_get_axis_parameter", "5.2.3.1", HOME, P1::AxisParam, P2::Unused, F,
      A::Float, "Read an axis parameter (PAR_1 = axis * 256 + parameter)"),
    c(0x1801, "get-axis-parameter-max", "cmd_get_axis_parameter_max", "5.2.3.2", HOME, P1::AxisParam, P2::Unused,
      F, A::Float, "Read an axis parameter's maximum"),
    c(0x1802, "get-axis-parameter-min", "cmd_get_axis_parameter_min", "5.2.3.3", HOME, P1::AxisParam, P2::Unused,
      F, A::Float, "Read an axis parameter's minimum"),
    // 5.1.4 / 5.2.4 elements
    c(0x1900, "get-single-input", "cmd_get_single_input", "5.2.4.1", ALL, P1::Input, P2::Unused, I, A::Bit,
      "Read one input"),
    c(0x1901, "get-input-word", "cmd_get_input_word", "5.2.4.2", ALL, P1::Input, P2::Unused, I, A::ElementWord,
      "Read the 16 inputs of the word holding input PAR_1"),
    c(0x0902, "put-single-output", "cmd_put_single_output", "5.2.4.3", ALL, P1::Output, P2::Bit, I, A::Echo,
      "Set or reset one output"),
    c(0x1902, "get-single-output", "cmd_get_single_output", "5.2.4.4", ALL, P1::Output, P2::Unused, I, A::Bit,
      "Read one output"),
    c(0x0903, "put-output-word", "cmd_put_output_word", "5.2.4.5", ALL, P1::Output, P2::Word16, I, A::Echo,
      "Write the 16 outputs of the word holding output PAR_1"),
    c(0x1903, "get-output-word", "cmd_get_output_word", "5.2.4.6", ALL, P1::Output, P2::Unused, I, A::ElementWord,
      "Read the 16 outputs of the word holding output PAR_1"),
    c(0x0904, "put-single-flag", "cmd_put_single_flag", "5.2.4.7", ALL, P1::Flag, P2::Bit, I, A::Echo,
      "Set or reset one flag"),
    c(0x1904, "get-single-flag", "cmd_get_single_flag", "5.2.4.8", ALL, P1::Flag, P2::Unused, I, A::Bit,
      "Read one flag"),
    c(0x0905, "put-flag-word", "cmd_put_flag_word", "5.2.4.9", ALL, P1::Flag, P2::Word16, I, A::Echo,
      "Write the 16 flags of the word holding flag PAR_1"),
    c(0x1905, "get-flag-word", "cmd_get_flag_word", "5.2.4.10", ALL, P1::Flag, P2::Unused, I, A::ElementWord,
      "Read the 16 flags of the word holding flag PAR_1"),
    c(0x0906, "put-int-reg", "cmd_put_int_reg", "5.2.4.11", ALL, P1::IntRegister, P2::Int32, I, A::Echo,
      "Write integer register N"),
    c(0x1906, "get-int-reg", "cmd_get_int_reg", "5.2.4.12", ALL, P1::IntRegister, P2::Unused, I, A::Int,
      "Read integer register N"),
    c(0x0907, "put-float-reg", "cmd_put_float_reg", "5.2.4.13", ALL, P1::FloatRegister, P2::Float, F, A::Echo,
      "Write real number register R"),
    c(0x1907, "get-float-reg", "cmd_get_float_reg", "5.2.4.14", ALL, P1::FloatRegister, P2::Unused, F, A::Float,
      "Read real number register R"),
    // 5.2.4.15: "can only be carried out in home position", although the
    // overview lists every element command as valid in all modes.
    c(0x0909, "reset-error", "cmd_reset_error", "5.2.4.15", HOME, P1::Unused, P2::Unused, I, A::ErrorNumber,
      "Reset a system error of class 2 (100-499); answers the error number if it cannot be reset"),
    c(0x1909, "get-error", "cmd_get_error", "5.2.4.16", ALL, P1::Unused, P2::Unused, I, A::ErrorNumber,
      "Read the PA-CONTROL error number"),
    c(0x190B, "get-state", "cmd_get_state", "5.2.4.17", ALL, P1::Unused, P2::Unused, I, A::None,
      "Read the operating status (in STATUS; see 6.4)"),
    c(0x190C, "get-actual-pos", "cmd_get_actual_pos", "5.2.4.18", ALL, P1::Axis, P2::Unused, F, A::Position,
      "Read an axis' current position"),
    c(0x190D, "get-actual-speed", "cmd_get_actual_speed", "5.2.4.19", ALL, P1::Axis, P2::Unused, F, A::Float,
      "Read an axis' current traverse speed"),
    // The overview lists this as a second 190D (specs README).
    c(0x190E, "get-actual-rotation-control-pos", "cmd_get_actual_rotation_control_pos", "5.2.4.20", ALL, P1::Axis,
      P2::Unused, F, A::Float, "Read an axis' shaft encoder position (PA-CONTROL EP)"),
    // 5.2.4.21 is missing from the manual; the overview gives the row. Its
    // siblings 1915 / 1920 answer floats.
    c(0x190F, "get-max-towfault", "cmd_get_max_towfault", "5.1.4", ALL, P1::Axis, P2::Unused, F, A::Float,
      "Read the largest following error that occurred (PA-CONTROL EP)"),
    c(0x1910, "get-status-axis", "cmd_get_status_axis", "5.2.4.22", ALL, P1::Axis, P2::Unused, I, A::AxisStatus,
      "Read an axis' status (0 in position, 1 moving, 2 stopped, 4 fault, 8 measuring mode)"),
    c(0x1911, "get-status-all-axis", "cmd_get_status_all_axis", "5.2.4.23", ALL, P1::Unused, P2::Unused, I,
      A::AllAxesBitmap, "Read which axes move (bit n = axis n+1)"),
    c(0x1913, "get-axis-traverse-area-min", "cmd_get_axis_traverse_area_min", "5.2.4.24", ALL, P1::Axis,
      P2::Unused, F, A::Float, "Read an axis' minimum traverse area"),
    c(0x1914, "get-axis-traverse-area-max", "cmd_get_axis_traverse_area_max", "5.2.4.25", ALL, P1::Axis,
      P2::Unused, F, A::Float, "Read an axis' maximum traverse area"),
    // Printed as 0000h-FFFFh, but the example answers 10.00 (4120 0000 IEEE).
    c(0x1915, "get-axis-following-error", "cmd_get_axis_following_error", "5.2.4.26", ALL, P1::Axis, P2::Unused,
      F, A::Float, "Read an axis' current following error (PA-CONTROL EP)"),
    // Same: the example answers 40.03 (4220 0000 IEEE).
    c(0x1920, "get-temperature", "cmd_get_temperature", "5.2.4.27", ALL, P1::Axis, P2::Unused, F, A::Float,
      "Read the cooler temperature of an axis' power stage in degrees C (PA-CONTROL EP)"),
    c(0x1921, "get-extended-status-axis", "cmd_get_extended_status_axis", "5.2.4.28", ALL, P1::Axis, P2::Unused,
      I, A::ExtAxisStatus, "Read an axis' extended status (power pack, limit switches, axis status)"),
    // The overview prints 934 / 935 / 0937 (specs README).
    c(0x1934, "send-system-flag", "cmd_send_system_flag", "5.2.4.29", ALL, P1::SystemElement, P2::Unused, I,
      A::Bit, "Read system flag SM"),
    c(0x1935, "send-system-n-reg", "cmd_send_system_n_reg", "5.2.4.30", ALL, P1::SystemElement, P2::Unused, I,
      A::Int, "Read system N register SN"),
    c(0x1937, "send-system-r-reg", "cmd_send_system_r_reg", "5.2.4.31", ALL, P1::SystemElement, P2::Unused, F,
      A::Float, "Read system R register SR"),
    // 5.1.5 / 5.2.5 automatic
    c(0x0A41, "abort-auto", "cmd_abort_auto", "5.2.5.1", AUTO, P1::Unused, P2::Unused, I, A::None,
      "Abort automatic mode and return to home position"),
    // 5.1.6 / 5.2.6 online
    c(0x0A81, "abort-online", "cmd_abort_online", "5.2.6.1", ONLINE, P1::Unused, P2::Unused, I, A::None,
      "Abort online mode and return to home position"),
    c(0x0A83, "put-no-reference", "cmd_put_no_reference", "5.2.6.2", ONLINE, P1::Axis, P2::Unused, I, A::None,
      "Release an axis for traversing without a reference run (G25.A0); no motion"),
    // 5.2.6.3 says the reference flag is set "once the command has been
    // executed"; like 0A87 its acknowledge is taken to wait for the end of
    // the run (the session polls on BE = 0 either way).
    moving(
        c(0x0A84, "put-start-reference", "cmd_put_start_reference", "5.2.6.3", ONLINE, P1::Axis, P2::Unused, I,
          A::None, "Run an axis' reference drive (G25.Ai)"),
        Completion::StartAndWait,
    ),
    c(0x0A85, "set-position-null", "cmd_set_position_null", "5.2.6.4", ONLINE, P1::Axis, P2::Unused, I, A::None,
      "Set an axis' current position to zero (G26)"),
    c(0x0A86, "set-position", "cmd_set_position", "5.2.6.5", ONLINE, P1::Axis, P2::Float, F, A::Echo,
      "Set an axis' current position to PAR_2 (G29), shifting the software limits"),
    moving(
        c(0x0A87, "pos-axis-absolut", "cmd_pos_axis_absolut", "5.2.6.6", ONLINE, P1::Axis, P2::Float, F,
          A::StartPosition, "Move an axis to an absolute position; BE = 0 until it arrives"),
        Completion::StartAndWait,
    ),
    moving(
        c(0x0A89, "pos-axis-relativ", "cmd_pos_axis_relativ", "5.2.6.7", ONLINE, P1::Axis, P2::Float, F,
          A::StartPosition, "Move an axis by a relative distance; BE = 0 until it arrives"),
        Completion::StartAndWait,
    ),
    c(0x0A8D, "set-speed-axis", "cmd_set_speed_axis", "5.2.6.8", ONLINE, P1::Axis, P2::Float, F, A::Echo,
      "Set an axis' traverse speed for online mode (within the parameter limits)"),
    c(0x0A8E, "set-acceleration-axis", "cmd_set_acceleration_axis", "5.2.6.9", ONLINE, P1::Axis, P2::Float, F,
      A::Echo, "Set an axis' acceleration for online mode (within the parameter limits)"),
    moving(
        c(0x0A90, "start-manuell-axis-absolut", "cmd_start_manuell_axis_absolut", "5.2.6.10", ONLINE, P1::Axis,
          P2::Float, F, A::StartPosition,
          "Manual move to an absolute position; keep it going with 0A92 at least every second"),
        Completion::StartAndReturn,
    ),
    moving(
        c(0x0A91, "start-manuell-axis-relativ", "cmd_start_manuell_axis_relativ", "5.2.6.11", ONLINE, P1::Axis,
          P2::Float, F, A::StartPosition,
          "Manual move by a relative distance; keep it going with 0A92 at least every second"),
        Completion::StartAndReturn,
    ),
    c(0x0A92, "control-move-axis", "cmd_control_move_axis", "5.2.6.12", ONLINE, P1::Axis, P2::Unused, F,
      A::Position, "Keep a manual move (0A90 / 0A91) going; repeat at least every second"),
    // The overview calls it cmd_stop_axis.
    waiting(
        c(0x0A93, "abort-move-axis", "cmd_abort_move_axis", "5.2.6.13", ONLINE, P1::Axis, P2::Unused, F,
          A::Position, "Stop an axis; BE = 0 until it stands still, then the stop position"),
        Completion::UntilStandstill,
    ),
    moving(
        c(0x0A94, "start-axis-absolut", "cmd_start_axis_absolut", "5.2.6.14", ONLINE, P1::Axis, P2::Float, F,
          A::StartPosition, "Start a move to an absolute position and return at once (BE = 1)"),
        Completion::StartAndReturn,
    ),
    moving(
        c(0x0A95, "start-axis-relativ", "cmd_start_axis_relativ", "5.2.6.15", ONLINE, P1::Axis, P2::Float, F,
          A::StartPosition, "Start a move by a relative distance and return at once (BE = 1)"),
        Completion::StartAndReturn,
    ),
    c(0x0A96, "put-axis-reference-on-position", "cmd_put_axis_reference_on_position", "5.2.6.16", ONLINE, P1::Axis,
      P2::Float, F, A::Position, "Reference an axis where it stands, taking PAR_2 as its position"),
    c(0x0A97, "on-axis", "cmd_on_axis", "5.2.6.17", ONLINE, P1::Axis, P2::Unused, I, A::None, "Switch an axis on"),
    c(0x0A98, "off-axis", "cmd_off_axis", "5.2.6.18", ONLINE, P1::Axis, P2::Unused, I, A::None, "Switch an axis off"),
    // Its example shows 0A96 (specs README).
    c(0x0A9A, "stop-axis-multi-cmd", "cmd_stop_axis_multi_cmd", "5.2.6.19", ONLINE, P1::Axis, P2::Unused, F,
      A::Position, "Stop an axis without waiting (BE = 1 at once); query 1910 for standstill"),
    // 5.2.6.20 requires automatic or online mode with the axis standing.
    c(0x0AA0, "set-measuring-mode", "cmd_set_measuring_mode", "5.2.6.20", AUTO_ONLINE, P1::Axis, P2::Unused, I,
      A::None, "Activate an axis' measuring mode (power stage off, axis movable by hand)"),
    c(0x0AA1, "reset-axis-measuring-mode", "cmd_reset_axis_measuring_mode", "5.2.6.21", ONLINE, P1::Axis,
      P2::Unused, I, A::None, "Deactivate an axis' measuring mode"),
    c(0x0AA2, "put-limit-switch-monitoring-on-off", "cmd_put_limit_switch_monitoring_on_off", "5.2.6.22", ONLINE,
      P1::AxisOrAll, P2::Bit, I, A::None, "Limit switch monitoring off (0) or on (1); axis 0 = all axes"),
    c(0x0AA3, "put-condition-move-axis", "cmd_put_condition_move_axis", "5.2.6.23", ONLINE, P1::AxisOrAll,
      P2::Condition, I, A::None, "Make the axis' next move last only while an input / output / flag has a state"),
];

/// The row of a command code.
pub fn command(code: u16) -> Option<&'static CommandDef> {
    COMMANDS.iter().find(|d| d.code == code)
}

fn name_eq(a: &str, b: &str) -> bool {
    a.len() == b.len()
        && a.bytes().zip(b.bytes()).all(|(x, y)| {
            let norm = |c: u8| if c == b'_' { b'-' } else { c.to_ascii_lowercase() };
            norm(x) == norm(y)
        })
}

/// The row by CLI name, manual name (with or without `cmd_`) or hex code,
/// case-insensitive, `_` and `-` alike.
pub fn command_by_name(name: &str) -> Option<&'static CommandDef> {
    let bare = name.strip_prefix("cmd_").or_else(|| name.strip_prefix("cmd-")).unwrap_or(name);
    COMMANDS.iter().find(|d| name_eq(d.name, bare) || name_eq(d.manual_name, name)).or_else(|| {
        let hex = name.trim_start_matches("0x").trim_start_matches("0X");
        (hex.len() == 4).then(|| u16::from_str_radix(hex, 16).ok().and_then(command)).flatten()
    })
}

// ---------------------------------------------------------------------------
// Operating status (6.4)

/// One operating status code (manual 6.4, decimal; STATUS in RS232
/// acknowledges, byte 5 of the Profibus reply).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct OperatingStatusDef {
    pub code: u8,
    pub mode: Mode,
    pub text: &'static str,
}

const fn st(code: u8, mode: Mode, text: &'static str) -> OperatingStatusDef {
    OperatingStatusDef { code, mode, text }
}

/// Manual 6.4 (codes 04-08 are elided there as "..."; 14 is blank). The
/// cmd_get_state table labels the same numbers "hex": a misprint (specs
/// README). Code 0 comes from the Profibus table of 2.4.2.
pub const OPERATING_STATUS: &[OperatingStatusDef] = &[
    st(0, Mode::Home, "no communication possible (not initialised correctly)"),
    st(1, Mode::Home, "home position"),
    st(2, Mode::Manual, "manual operation via the PA-CONTROL front panel"),
    st(3, Mode::Manual, "manual operation via the PA-CONTROL front panel and axis movement"),
    st(9, Mode::Home, "home position with system error"),
    st(10, Mode::Automatic, "AUTOMATIC started"),
    st(11, Mode::Automatic, "AUTOMATIC"),
    st(12, Mode::Automatic, "AUTOMATIC and STOP recognized"),
    st(13, Mode::Automatic, "AUTOMATIC process STOP program"),
    st(15, Mode::Automatic, "AUTOMATIC and STOPPED"),
    st(16, Mode::Automatic, "AUTOMATIC process START-AFTER-STOP program"),
    st(17, Mode::Automatic, "AUTOMATIC malfunction recognized"),
    st(18, Mode::Automatic, "AUTOMATIC process MALFUNCTION program"),
    st(19, Mode::Automatic, "AUTOMATIC STOPPED with MALFUNCTION"),
    st(20, Mode::Manual, "manual operation (movement of axes) via WINPAC / serial"),
    st(30, Mode::Online, "ONLINE started"),
    st(31, Mode::Online, "ONLINE"),
    st(32, Mode::Online, "ONLINE STOP recognized"),
    st(35, Mode::Online, "ONLINE and STOPPED"),
    st(37, Mode::Online, "ONLINE and MALFUNCTION recognized"),
    st(39, Mode::Online, "ONLINE STOPPED with MALFUNCTION"),
];

pub fn operating_status(code: u16) -> Option<&'static OperatingStatusDef> {
    OPERATING_STATUS.iter().find(|s| u16::from(s.code) == code)
}

/// The operating mode of a status code; for codes the table lacks, the
/// decade (0x home/manual, 1x automatic, 3x online).
pub fn mode_of_status(code: u16) -> Option<Mode> {
    operating_status(code).map(|s| s.mode).or(match code {
        4..=8 => Some(Mode::Manual),
        10..=19 => Some(Mode::Automatic),
        30..=39 => Some(Mode::Online),
        _ => None,
    })
}

pub fn operating_status_text(code: u16) -> &'static str {
    operating_status(code).map_or("unknown operating status", |s| s.text)
}

// ---------------------------------------------------------------------------
// Command errors (6.5)

/// One command error number (QUIT in RS232, word 3 bits 0-12 over Profibus).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct CommandErrorDef {
    pub code: u16,
    pub message: &'static str,
    pub explanation: &'static str,
}

impl CommandErrorDef {
    /// "0x2A (42)": the manual lists both columns.
    pub fn label(&self) -> String {
        format!("0x{:02X} ({})", self.code, self.code)
    }
}

const fn e(code: u16, message: &'static str, explanation: &'static str) -> CommandErrorDef {
    CommandErrorDef { code, message, explanation }
}

const UPDATE: &str = "Only in connection with an update of the operating system (1A-1F hex)";
const PROGRAM: &str = "Only when transmitting programs to the PA-CONTROL (50-53 hex)";
const PARAM_CHECK: &str = "Starting AUTOMATIC or ONLINE: the converted parameters are not feasible (60-6B hex)";
const ASI_COMM: &str = "Communication error between the PA-CONTROL CPU and the AS-i bus master CPU";
const ASI_ADDR: &str = "An AS-i slave should be set to an address";

/// Manual 6.5. Where the hex and decimal columns disagree the hex column is
/// kept, since the rows are in hex order: 1D/30 is 1E, 25/36 is 37, 2D/46 is
/// 2E, 2F/7 is 47; 31 (49) is printed twice.
pub const COMMAND_ERRORS: &[CommandErrorDef] = &[
    e(0x00, "no error", ""),
    e(0x10, "sum of digits error", "Wrong CHECK in a command received via RS232"),
    e(0x11, "wrong sequence set-up", "The control symbols of an RS232 command were in the wrong order"),
    e(0x12, "wrong sequence beginning", "The control symbols of an RS232 command were in the wrong order"),
    e(0x13, "unknown command", "The command is not in the valid command list"),
    e(0x14, "inadmissible command", "This command may not be used in this situation"),
    e(0x15, "command not executable", "This command is not possible in this situation"),
    e(0x1A, "EPROM programming defective", UPDATE),
    e(0x1B, "number of data bytes defective", UPDATE),
    e(0x1C, "inadmissible data record", UPDATE),
    e(0x1D, "sum of digits data record defective", UPDATE),
    e(0x1E, "delete EPROM defective", UPDATE),
    e(0x1F, "inadmissible EPROM address", UPDATE),
    e(0x20, "axis number unknown", "The axis is not configured in the system parameters"),
    e(0x21, "axis parameter unknown", "The command parameter names no valid axis parameter"),
    e(0x22, "system parameter unknown", "The command parameter names no valid system parameter"),
    e(0x23, "inadmissible input", "Invalid input number"),
    e(0x24, "inadmissible output", "Invalid output number"),
    e(0x25, "inadmissible flag", "Invalid flag number"),
    e(0x26, "inadmissible N register", "Invalid N register number"),
    e(0x27, "inadmissible R register", "Invalid R register number"),
    e(0x28, "inadmissible task number", "An inadmissible TASK was accessed during parallel processing"),
    e(0x29, "value outside range", "The command date is outside the values saved in the parameters"),
    e(0x2A, "axis still moves", "An axis already moving was started again"),
    e(0x2B, "no reference point", "No reference flag is set for the axis"),
    e(0x2C, "external stop not defined", "Online mode needs an external stop input, and it must have power"),
    e(0x2D, "inadmissible AD converter", "The AD converter number is unknown"),
    e(0x2E, "axis not ready", "The axis is not ready"),
    e(0x2F, "axis is no servoTEC axis", "The function is not possible with this type of axis"),
    e(0x30, "no connection to servoTEC axis", "The command cannot be processed via the CAN bus for this axis"),
    e(0x31, "not all axes initialized", "An axis could not be addressed during initialisation via the CAN bus"),
    e(0x32, "error during initialization", "The initialisation of the axis was aborted because of an error"),
    e(0x33, "errors in axis parameters", "An axis parameter of this axis is out of the permissible range"),
    e(0x34, "not initialized", "Axis not initialised correctly"),
    e(0x35, "access to SLAVE axis", "Not all commands are allowed with a PA-CONTROL MP as CAN bus slave axis"),
    e(0x36, "axis path too long", "servoTEC traverse distance is limited by the increments per revolution"),
    e(0x37, "axis not switched on", "The axis is in IDLE or SAFE state"),
    e(0x38, "axis displaced too much", "The axis was displaced too much in the IDLE state"),
    e(0x39, "Profibus-DP address cannot be taken over", "The Profibus-DP address is set by the rotary switches"),
    e(0x3A, "parameter inconsistent", "WINPAC and PA-CONTROL use different servoTEC S2 drive parameter lists"),
    e(0x3B, "Gantry-SLAVE axis cannot be traversed", "This axis is a slave axis of a Gantry drive"),
    e(0x40, "limit switch actuated", "A limit switch was reached, or a limit switch cable broke"),
    e(0x41, "position outside range", "The target position is outside the stored parameter values"),
    e(0x50, "program already existing", PROGRAM),
    e(0x51, "syntax error in program", PROGRAM),
    e(0x52, "program not available", PROGRAM),
    e(0x53, "program names already exist", PROGRAM),
    e(0x60, "traverse speed too high", PARAM_CHECK),
    e(0x61, "traverse speed too low", PARAM_CHECK),
    e(0x62, "reference speed too high", PARAM_CHECK),
    e(0x63, "reference speed too low", PARAM_CHECK),
    e(0x64, "manual speed too high", PARAM_CHECK),
    e(0x65, "manual speed too low", PARAM_CHECK),
    e(0x66, "creep speed too high", PARAM_CHECK),
    e(0x67, "creep speed too low", PARAM_CHECK),
    e(0x68, "initial speed too high", PARAM_CHECK),
    e(0x69, "initial speed too low", PARAM_CHECK),
    e(0x6A, "acceleration too high", PARAM_CHECK),
    e(0x6B, "acceleration too low", PARAM_CHECK),
    e(0x6C, "measuring mode option not admissible for this axis", "Only with the online commands 0AA0 and 0AA1"),
    e(0x6D, "number of axis traverse increments greater than 31 bits", PARAM_CHECK),
    e(0xFA, "error during execution of host task", ASI_COMM),
    e(0xFB, "no error in query by host", ASI_COMM),
    e(0xFC, "the slave needed for the address change does not exist", ASI_ADDR),
    e(0xFD, "only one slave has the address 0", "In AUTOMATIC, no AS-i slave may have address 0"),
    e(0xFE, "slave already exists", "The AS-i address to be set is already occupied"),
    e(0xFF, "error in programming with address 0", "An AS-i slave should be set to address 0"),
    e(0x100, "new address was not assigned", ASI_ADDR),
    e(0x101, "new address could not be saved in EEPROM", ASI_ADDR),
    e(0x102, "unknown ASI address", ASI_ADDR),
    e(0x103, "command time-out", ASI_COMM),
    e(0x104, "ASI power supply error", "Error in the AS-i power pack"),
    e(0x105, "ASI slave with address 0 is available", "Wrong programming: only the master may have address 0"),
    e(0x106, "ASI configuration defective", ""),
];

pub fn command_error(code: u16) -> Option<&'static CommandErrorDef> {
    COMMAND_ERRORS.iter().find(|d| d.code == code)
}

pub fn command_error_text(code: u16) -> &'static str {
    command_error(code).map_or("unknown command error", |d| d.message)
}

// ---------------------------------------------------------------------------
// System parameters (0700)

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SystemParamDef {
    pub number: u16,
    pub name: &'static str,
    pub manual_name: &'static str,
    pub meaning: &'static str,
    /// Always integer (TYP 0) over RS232.
    pub data_type: DataType,
    /// Limits the manual states; otherwise ask the controller (1701 / 1702).
    pub min: Option<i64>,
    pub max: Option<i64>,
    /// "currently not used".
    pub unused: bool,
}

const fn sp(number: u16, name: &'static str, manual_name: &'static str, meaning: &'static str) -> SystemParamDef {
    SystemParamDef { number, name, manual_name, meaning, data_type: DataType::Int, min: None, max: None, unused: false }
}

const fn sp_unused(number: u16) -> SystemParamDef {
    SystemParamDef { unused: true, ..sp(number, "unused", "currently not used", "") }
}

/// Manual 5.2.2.1. The manual gives no limits; the controller reports them
/// (1701 / 1702) and they depend on its configuration.
pub const SYSTEM_PARAMS: &[SystemParamDef] = &[
    sp(1, "language", "Language", "Display language (the 1700 example reads 3 = French)"),
    sp(2, "number-of-axes", "Number of axes", "Configured axes (0 on a control unit)"),
    sp(3, "start-input", "Start input number", "Input that starts the automatic program"),
    sp(4, "stop-input", "Stop input number", "Input for the external stop"),
    sp(5, "manual-release-input", "Manual release input number", "Input that releases manual operation"),
    sp(6, "readiness-output", "Readiness output number", "Output signalling readiness"),
    sp(7, "malfunction-output", "Malfunction output number", "Output signalling a malfunction"),
    sp(8, "autostart", "Autostart", "Start automatic mode after power-on"),
    sp_unused(9),
    sp_unused(10),
    sp_unused(11),
    sp_unused(12),
    sp_unused(13),
    sp_unused(14),
    sp(15, "teleservice-activate-input", "Teleservice activate input number", "Input that activates teleservice"),
    sp(16, "teleservice-contact-output", "Teleservice contact output number", "Output for the teleservice contact"),
    sp(17, "profibus-address", "Profibus DP address", "Profibus-DP station address"),
    sp_unused(18),
    sp(19, "profibus-diagnosis", "Profibus diagnosis active", "Profibus diagnosis on / off"),
    sp(20, "basic-operating-mode", "Basic operating mode of the PA-CONTROL", "Basic operating mode"),
];

pub fn system_param(number: i64) -> Option<&'static SystemParamDef> {
    SYSTEM_PARAMS.iter().find(|p| i64::from(p.number) == number)
}

/// By CLI name, manual name or number, case-insensitive.
pub fn system_param_by_name(name: &str) -> Option<&'static SystemParamDef> {
    if let Ok(n) = name.parse::<i64>() {
        return system_param(n);
    }
    SYSTEM_PARAMS.iter().find(|p| !p.unused && (name_eq(p.name, name) || p.manual_name.eq_ignore_ascii_case(name)))
}

// ---------------------------------------------------------------------------
// Axis parameters (0800)

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AxisParamDef {
    pub number: u8,
    pub name: &'static str,
    pub manual_name: &'static str,
    /// AE = the axis' user unit ("Anwendereinheit").
    pub unit: &'static str,
    /// Always float (TYP 1) over RS232, IEEE over Profibus.
    pub data_type: DataType,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// "not used at present".
    pub unused: bool,
    /// Documented in the separate "absolute position system" manual.
    pub absolute_system: bool,
}

const fn ap(number: u8, name: &'static str, manual_name: &'static str, unit: &'static str) -> AxisParamDef {
    AxisParamDef {
        number,
        name,
        manual_name,
        unit,
        data_type: DataType::Float,
        min: None,
        max: None,
        unused: false,
        absolute_system: false,
    }
}

/// A yes/no parameter. The manual gives no range; its 1800 example reads
/// parameter 31 as 0.0 = "not inverted", so switches are 0 / 1.
const fn ap_switch(number: u8, name: &'static str, manual_name: &'static str) -> AxisParamDef {
    AxisParamDef { min: Some(0.0), max: Some(1.0), ..ap(number, name, manual_name, "0/1") }
}

const fn ap_unused(number: u8, name: &'static str, manual_name: &'static str, unit: &'static str) -> AxisParamDef {
    AxisParamDef { unused: true, ..ap(number, name, manual_name, unit) }
}

const fn ap_abs(def: AxisParamDef) -> AxisParamDef {
    AxisParamDef { absolute_system: true, ..def }
}

/// Manual 5.2.3. Limits other than the switches' come from the controller
/// (1801 / 1802) and depend on the axis type.
pub const AXIS_PARAMS: &[AxisParamDef] = &[
    ap(1, "traverse-speed", "Traverse speed", "AE/s"),
    ap(2, "reference-speed", "Reference speed", "AE/s"),
    ap(3, "manual-speed", "Manual speed", "AE/s"),
    ap(4, "creep-speed", "Creep speed", "AE/s"),
    ap(5, "start-stop-speed", "Start-Stop speed", "AE/s"),
    ap(6, "acceleration", "Acceleration", "AE/s²"),
    ap(7, "gear-factor", "Gear factor", ""),
    ap(8, "traverse-area-min", "Minimum traverse area", "AE"),
    ap(9, "traverse-area-max", "Maximum traverse area", "AE"),
    ap(10, "motor-phase-current", "Motor phase current", "A"),
    ap(11, "motor-standstill-current", "Motor standstill current", "A"),
    ap_unused(12, "p-share", "P share", ""),
    ap_unused(13, "i-share", "I share", ""),
    ap_unused(14, "d-share", "D share", ""),
    ap(15, "encoder-pulses-per-revolution", "Encoder impulses per revolution", "1/rev"),
    ap_unused(16, "position-window", "Position window", "AE"),
    ap(17, "max-towfault", "Maximum towfault", "AE"),
    ap_unused(18, "distance-limit-switch-zero-pulse", "Distance limit switch / zero impulse", "AE"),
    ap_unused(19, "nominal-speed", "Nominal speed", ""),
    ap_unused(20, "p-current-regulator", "P current regulator", ""),
    ap_unused(21, "i-current-regulator", "I current regulator", ""),
    ap_unused(22, "regulator-type", "Regulator type", ""),
    ap_unused(23, "flow-reference-drive", "Flow reference drive", ""),
    ap_switch(24, "direction-of-rotation", "Direction of rotation"),
    ap_switch(25, "rotation-monitoring", "Rotation monitoring activated"),
    ap(26, "motor-steps-per-revolution", "Motor steps / rotation", "1/rev"),
    ap(27, "full-motor-steps-per-revolution", "Full motor steps / rotation", "1/rev"),
    ap_switch(28, "limit-switches-exchanged", "Axis limit switch exchanged"),
    ap(29, "display-unit", "Display unit", ""),
    ap(30, "ramp-type", "Ramp type", ""),
    ap_switch(31, "invert-encoder-direction", "Invert shaft encoder direction"),
    ap_switch(32, "limit-switch-type-closer", "Limit switch type \"closer\""),
    ap(33, "reference-switch-offset", "Distance zero point to reference switch", "AE"),
    ap_switch(34, "encoder-synchronization", "Synchronization to shaft encoder"),
    ap_switch(35, "encoder-take-over", "Take-over of shaft encoder"),
    ap_switch(36, "brake-in-measuring-mode", "Activate brake in measuring mode"),
    ap_abs(ap_switch(37, "abs-activated", "Absolute pos. system activated")),
    ap_abs(ap(38, "abs-transmission-clock", "Absolute pos. system transmission cycle clock", "")),
    ap_abs(ap(39, "abs-break-clock", "Absolute pos. system break clock", "")),
    ap_abs(ap(40, "abs-analysis-code", "Absolute pos. system analysis code", "")),
    ap_abs(ap(41, "abs-multiturn", "Absolute pos. system multiturn", "")),
    ap_abs(ap(42, "abs-ssi-data-bits", "Absolute pos. system number data bits via SSI", "bits")),
    ap_abs(ap(43, "abs-bit-25-function", "Absolute pos. system bit 25 function", "")),
    ap_abs(ap(44, "abs-feed", "Absolute pos. system feed", "AE/rev")),
    ap_abs(ap(45, "abs-reference-offset", "Absolute pos. system offset to reference point", "AE")),
    ap_abs(ap_switch(46, "abs-invert-direction", "Absolute pos. system invert direction")),
    ap_abs(ap(47, "abs-increments-per-revolution", "Absolute pos. system increments / rotation", "1/rev")),
    ap_abs(ap(48, "abs-max-revolutions", "Absolute pos. system max. number of revolutions", "rev")),
    ap_abs(ap(49, "abs-position-data-bits", "Absolute pos. system number of data bits for position analysis", "bits")),
    ap(50, "enable-mode", "Enable mode for axes", ""),
];

pub fn axis_param(number: u8) -> Option<&'static AxisParamDef> {
    AXIS_PARAMS.iter().find(|p| p.number == number)
}

/// By CLI name, manual name or number, case-insensitive.
pub fn axis_param_by_name(name: &str) -> Option<&'static AxisParamDef> {
    if let Ok(n) = name.parse::<u8>() {
        return axis_param(n);
    }
    AXIS_PARAMS.iter().find(|p| name_eq(p.name, name) || p.manual_name.eq_ignore_ascii_case(name))
}

/// PAR_1 of 0800 / 18xx: axis * 256 + parameter (axis 3, acceleration 6 -> 774).
pub const fn axis_param_par1(axis: u8, param: u8) -> i64 {
    axis as i64 * 256 + param as i64
}

/// (axis, parameter) from an 0800 / 18xx PAR_1.
pub fn split_axis_param_par1(par1: i64) -> Option<(u8, u8)> {
    let v = u16::try_from(par1).ok()?;
    Some(((v >> 8) as u8, (v & 0xff) as u8))
}

// ---------------------------------------------------------------------------
// Axis status (1910, 1911, 1921)

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct AxisStatusDef {
    pub code: u8,
    pub name: &'static str,
    pub text: &'static str,
}

/// 1910 acknowledge date and the low byte of 1921 (manual 5.2.4.22).
pub const AXIS_STATUS: &[AxisStatusDef] = &[
    AxisStatusDef { code: 0, name: "in-position", text: "axis standing, in position" },
    AxisStatusDef { code: 1, name: "moving", text: "axis moving" },
    AxisStatusDef { code: 2, name: "stopped", text: "axis standing still, was stopped" },
    AxisStatusDef { code: 4, name: "fault", text: "axis standing still with malfunction" },
    AxisStatusDef { code: 8, name: "measuring-mode", text: "axis in measuring mode" },
];

pub fn axis_status(code: u64) -> Option<&'static AxisStatusDef> {
    AXIS_STATUS.iter().find(|s| u64::from(s.code) == code)
}

/// 1911: the axes (1-based) whose bit is set, i.e. that are moving.
pub fn moving_axes(bitmap: u64) -> Vec<u8> {
    (0..MAX_AXES).filter(|i| bitmap >> i & 1 == 1).map(|i| i + 1).collect()
}

/// 1921 acknowledge date (manual 5.2.4.28, specs README).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ExtAxisStatus {
    /// Bits 24-31 = 1.
    pub power_pack_ready: bool,
    /// Bits 16-23 = 0: the switch is activated.
    pub positive_limit_activated: bool,
    /// Bits 8-15 = 0: the switch is activated.
    pub negative_limit_activated: bool,
    /// Bits 0-7, as 1910.
    pub axis_status: u8,
    pub axis_status_text: &'static str,
}

impl ExtAxisStatus {
    pub fn decode(raw: u32) -> Self {
        let axis_status = (raw & 0xff) as u8;
        Self {
            power_pack_ready: raw >> 24 != 0,
            positive_limit_activated: (raw >> 16) & 0xff == 0,
            negative_limit_activated: (raw >> 8) & 0xff == 0,
            axis_status,
            axis_status_text: axis_status_text(u64::from(axis_status)),
        }
    }
}

pub fn axis_status_text(code: u64) -> &'static str {
    axis_status(code).map_or("undefined axis status", |s| s.text)
}

/// Members of an element word (1901 / 1903 / 1905 / 0903 / 0905): the word
/// holding element `element` (16 per word, word 1 = elements 1..16) and the
/// element numbers whose bit is set in `word`.
pub fn word_members(element: u16, word: u16) -> Vec<u16> {
    let first = (element.max(1) - 1) / 16 * 16 + 1;
    (0..16).filter(|b| word >> b & 1 == 1).map(|b| first + b).collect()
}

// ---------------------------------------------------------------------------
// 0AA3 condition

/// The 0AA3 command date. The manual's byte numbering is ambiguous; this
/// crate encodes `condition << 24 | element type << 16 | element number`
/// (specs README).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Condition {
    /// Move as long as the element has this state.
    pub while_state: bool,
    pub element: ElementType,
    pub number: u16,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ElementType {
    Input = 1,
    Output = 2,
    Flag = 3,
}

impl Condition {
    /// `condition << 24 | type << 16 | number`.
    pub fn encode(&self) -> i64 {
        (i64::from(self.while_state) << 24) | ((self.element as i64) << 16) | i64::from(self.number)
    }

    pub fn decode(raw: i64) -> Option<Self> {
        let raw = u32::try_from(raw).ok()?;
        let while_state = match raw >> 24 {
            0 => false,
            1 => true,
            _ => return None,
        };
        let element = match (raw >> 16) & 0xff {
            1 => ElementType::Input,
            2 => ElementType::Output,
            3 => ElementType::Flag,
            _ => return None,
        };
        Some(Self { while_state, element, number: (raw & 0xffff) as u16 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn rows_are_unique() {
        let codes: HashSet<_> = COMMANDS.iter().map(|c| c.code).collect();
        assert_eq!(codes.len(), COMMANDS.len());
        let names: HashSet<_> = COMMANDS.iter().map(|c| c.name).collect();
        assert_eq!(names.len(), COMMANDS.len());
        for c in COMMANDS {
            assert_eq!(c.manual_name.strip_prefix("cmd_").unwrap().replace('_', "-"), c.name);
            // A command date's type follows the command's TYP.
            match c.par2 {
                Par2Kind::Float | Par2Kind::AxisParamValue => assert_eq!(c.data_type, DataType::Float, "{}", c.name),
                Par2Kind::Bit | Par2Kind::Word16 | Par2Kind::Int32 | Par2Kind::Condition => {
                    assert_eq!(c.data_type, DataType::Int, "{}", c.name)
                }
                _ => {}
            }
            if c.completion == Completion::StartAndWait || c.completion == Completion::StartAndReturn {
                assert!(c.motion, "{}", c.name);
            }
        }
        let errs: HashSet<_> = COMMAND_ERRORS.iter().map(|e| e.code).collect();
        assert_eq!(errs.len(), COMMAND_ERRORS.len());
        let st: HashSet<_> = OPERATING_STATUS.iter().map(|e| e.code).collect();
        assert_eq!(st.len(), OPERATING_STATUS.len());
        assert_eq!(AXIS_PARAMS.len(), 50);
        for (i, p) in AXIS_PARAMS.iter().enumerate() {
            assert_eq!(usize::from(p.number), i + 1);
        }
        for (i, p) in SYSTEM_PARAMS.iter().enumerate() {
            assert_eq!(usize::from(p.number), i + 1);
        }
    }

    // Every code of the overview 5.1, with the specs README's errata.
    #[test]
    fn chapter_5_codes_present() {
        let expected = [
            0x0600, 0x0602, 0x0603, 0x0700, 0x1700, 0x1701, 0x1702, 0x0800, 0x1800, 0x1801, 0x1802, 0x1900, 0x1901,
            0x0902, 0x1902, 0x0903, 0x1903, 0x0904, 0x1904, 0x0905, 0x1905, 0x0906, 0x1906, 0x0907, 0x1907, 0x0909,
            0x1909, 0x190B, 0x190C, 0x190D, 0x190E, 0x190F, 0x1910, 0x1911, 0x1913, 0x1914, 0x1915, 0x1920, 0x1921,
            0x1934, 0x1935, 0x1937, 0x0A41, 0x0A81, 0x0A83, 0x0A84, 0x0A85, 0x0A86, 0x0A87, 0x0A89, 0x0A8D, 0x0A8E,
            0x0A90, 0x0A91, 0x0A92, 0x0A93, 0x0A94, 0x0A95, 0x0A96, 0x0A97, 0x0A98, 0x0A9A, 0x0AA0, 0x0AA1, 0x0AA2,
            0x0AA3,
        ];
        for code in expected {
            assert!(command(code).is_some(), "{code:04X}");
        }
        assert_eq!(COMMANDS.len(), expected.len());
        assert_eq!(command(0x190E).unwrap().name, "get-actual-rotation-control-pos");
        assert!(command(0x0934).is_none());
        assert_eq!(command(0x0A9A).unwrap().completion, Completion::Immediate);
    }

    #[test]
    fn motion_classes() {
        for code in [0x0A87, 0x0A89] {
            let c = command(code).unwrap();
            assert!(c.motion && c.is_start_and_wait() && c.completion.waits());
        }
        for code in [0x0A94, 0x0A95] {
            let c = command(code).unwrap();
            assert!(c.motion && !c.is_start_and_wait() && !c.completion.waits());
        }
        assert!(!command(0x0A93).unwrap().motion);
        assert!(command(0x0A93).unwrap().completion.waits());
        assert!(!command(0x190C).unwrap().motion);
    }

    #[test]
    fn lookups() {
        assert_eq!(command_by_name("pos-axis-absolut").unwrap().code, 0x0A87);
        assert_eq!(command_by_name("CMD_POS_AXIS_ABSOLUT").unwrap().code, 0x0A87);
        assert_eq!(command_by_name("pos_axis_absolut").unwrap().code, 0x0A87);
        assert_eq!(command_by_name("0a87").unwrap().code, 0x0A87);
        assert_eq!(command_by_name("0x190B").unwrap().name, "get-state");
        assert!(command_by_name("pos-axis").is_none());
        assert_eq!(system_param_by_name("Number-Of-Axes").unwrap().number, 2);
        assert_eq!(system_param_by_name("start input number").unwrap().number, 3);
        assert_eq!(system_param_by_name("17").unwrap().name, "profibus-address");
        assert!(system_param_by_name("unused").is_none());
        assert_eq!(axis_param_by_name("ACCELERATION").unwrap().number, 6);
        assert_eq!(axis_param_by_name("Invert shaft encoder direction").unwrap().number, 31);
        assert_eq!(axis_param_by_name("50").unwrap().name, "enable-mode");
        assert!(axis_param_by_name("51").is_none());
    }

    #[test]
    fn modes() {
        assert!(command(0x0603).unwrap().modes.contains(Mode::Home));
        assert!(!command(0x0603).unwrap().modes.contains(Mode::Online));
        assert!(command(0x0600).unwrap().modes.contains(Mode::Online));
        assert_eq!(command(0x1900).unwrap().modes, Modes::ALL);
        assert_eq!(command(0x0A87).unwrap().modes.to_string(), "online");
        assert_eq!(mode_of_status(31), Some(Mode::Online));
        assert_eq!(mode_of_status(15), Some(Mode::Automatic));
        assert_eq!(mode_of_status(1), Some(Mode::Home));
        assert_eq!(mode_of_status(34), Some(Mode::Online));
        assert_eq!(mode_of_status(99), None);
    }

    // Manual 6.4 and the 5.2.1 examples (0600 -> 15, 0602 -> 11, 0603 -> 31).
    #[test]
    fn operating_status_texts() {
        assert_eq!(operating_status_text(1), "home position");
        assert_eq!(operating_status_text(15), "AUTOMATIC and STOPPED");
        assert_eq!(operating_status_text(11), "AUTOMATIC");
        assert_eq!(operating_status_text(31), "ONLINE");
        assert_eq!(operating_status_text(35), "ONLINE and STOPPED");
        assert_eq!(operating_status_text(14), "unknown operating status");
    }

    // Manual 6.5, both columns.
    #[test]
    fn command_error_texts() {
        assert_eq!(command_error_text(0x10), "sum of digits error");
        assert_eq!(command_error(19).unwrap().message, "unknown command");
        assert_eq!(command_error(0x2A).unwrap().label(), "0x2A (42)");
        assert_eq!(command_error(0x1E).unwrap().message, "delete EPROM defective");
        assert_eq!(command_error(0x2E).unwrap().message, "axis not ready");
        assert_eq!(command_error(47).unwrap().message, "axis is no servoTEC axis");
        assert_eq!(command_error(262).unwrap().label(), "0x106 (262)");
        assert_eq!(command_error_text(0x42), "unknown command error");
    }

    // Manual 5.2.3 examples: 0306h = 774, 021Fh = 0543, 0301h = 769, 0406h = 1030.
    #[test]
    fn axis_param_par1_examples() {
        assert_eq!(axis_param_par1(3, 6), 774);
        assert_eq!(axis_param_par1(2, 31), 543);
        assert_eq!(axis_param_par1(3, 1), 769);
        assert_eq!(axis_param_par1(4, 6), 1030);
        assert_eq!(split_axis_param_par1(774), Some((3, 6)));
        assert_eq!(split_axis_param_par1(-1), None);
        assert_eq!(axis_param(6).unwrap().manual_name, "Acceleration");
        assert_eq!(axis_param(31).unwrap().manual_name, "Invert shaft encoder direction");
    }

    // Manual 5.2.4.22 example: axis 4 answers 2 = stopped.
    #[test]
    fn axis_status_1910() {
        assert_eq!(axis_status(2).unwrap().name, "stopped");
        assert_eq!(axis_status_text(4), "axis standing still with malfunction");
        assert!(axis_status(3).is_none());
    }

    // Manual 5.2.4.23 example: 00D0h = 208 -> axes 5, 7 and 8 running.
    #[test]
    fn all_axes_1911() {
        assert_eq!(moving_axes(208), vec![5, 7, 8]);
        assert_eq!(moving_axes(0), Vec::<u8>::new());
    }

    // Manual 5.2.4.28 example: 0100 0104h = 16777476: power pack ready,
    // positive limit switch reached, negative not, axis 8 with malfunction.
    #[test]
    fn ext_axis_status_1921() {
        let s = ExtAxisStatus::decode(16777476);
        assert!(s.power_pack_ready);
        assert!(s.positive_limit_activated);
        assert!(!s.negative_limit_activated);
        assert_eq!(s.axis_status, 4);
        assert_eq!(s.axis_status_text, "axis standing still with malfunction");
        let s = ExtAxisStatus::decode(0x0001_0100);
        assert!(!s.power_pack_ready && !s.positive_limit_activated && !s.negative_limit_activated);
        assert_eq!(s.axis_status, 0);
    }

    // The element word examples of 5.2.4.2 - 5.2.4.10.
    #[test]
    fn element_words() {
        // 1901, input 10, 8D03h = 36099: inputs 1, 2, 9, 11, 12, 16.
        assert_eq!(word_members(10, 36099), vec![1, 2, 9, 11, 12, 16]);
        // 0903, output 25, 3E11h = 15889: outputs 17, 21, 26..30.
        assert_eq!(word_members(25, 15889), vec![17, 21, 26, 27, 28, 29, 30]);
        // 1903, output 33, 5555h = 21845: outputs 33, 35, ..., 47.
        assert_eq!(word_members(33, 21845), vec![33, 35, 37, 39, 41, 43, 45, 47]);
        // 0905, flag 17, 45F2h = 17906: flags 18, 21-25, 27, 31.
        assert_eq!(word_members(17, 17906), vec![18, 21, 22, 23, 24, 25, 27, 31]);
        // 1905, flag 33, 0F0Fh = 3855: flags 33-36, 41-44.
        assert_eq!(word_members(33, 3855), vec![33, 34, 35, 36, 41, 42, 43, 44]);
    }

    #[test]
    fn condition_encoding() {
        let c = Condition { while_state: true, element: ElementType::Input, number: 5 };
        assert_eq!(c.encode(), 0x0101_0005);
        assert_eq!(Condition::decode(0x0101_0005), Some(c));
        let c = Condition { while_state: false, element: ElementType::Flag, number: 1024 };
        assert_eq!(c.encode(), 0x0003_0400);
        assert_eq!(Condition::decode(c.encode()), Some(c));
        assert_eq!(Condition::decode(0x0204_0001), None);
        assert_eq!(Condition::decode(0x0004_0001), None);
        assert_eq!(Condition::decode(-1), None);
    }
}
