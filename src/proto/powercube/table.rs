//! The PowerCube tables: commands (manual 4.4), motion ids (4.5) and
//! parameters (4.6). Each row is declared once; the CLI, JSON, decoded output
//! and docs read from here.

/// Command ids (manual 4.4, plus the watchdog 0x07 of section 13 and the
/// broadcast-only ids of 4.1.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum CommandId {
    Reset = 0x00,
    Home = 0x01,
    Halt = 0x02,
    Watchdog = 0x07,
    SetExtended = 0x08,
    /// RecalcPIDParam on a module; "change baud rate" as a broadcast.
    RecalcPidParam = 0x09,
    GetExtended = 0x0a,
    SetMotion = 0x0b,
    SetIStep = 0x0d,
    /// Broadcast only: store the actual position.
    SavePos = 0x0e,
    /// Broadcast only: release the last motion command (SYNC_MOTION).
    StartMotion = 0x0f,
    ResetTime = 0x12,
}

pub struct CommandDef {
    pub id: CommandId,
    pub name: &'static str,
    pub description: &'static str,
}

pub const COMMANDS: &[CommandDef] = &[
    CommandDef { id: CommandId::Reset, name: "Reset", description: "Clear error state" },
    CommandDef { id: CommandId::Home, name: "Home", description: "Start homing procedure" },
    CommandDef { id: CommandId::Halt, name: "Halt", description: "Stop immediately" },
    CommandDef {
        id: CommandId::Watchdog,
        name: "Watchdog",
        description: "Toggle watchdog online/offline; as broadcast: refresh",
    },
    CommandDef { id: CommandId::SetExtended, name: "SetExtended", description: "Set parameter" },
    CommandDef {
        id: CommandId::RecalcPidParam,
        name: "RecalcPIDParam",
        description: "Recalculate the PID loop parameters (broadcast: change baud rate)",
    },
    CommandDef { id: CommandId::GetExtended, name: "GetExtended", description: "Fetch parameter" },
    CommandDef { id: CommandId::SetMotion, name: "SetMotion", description: "Set motion command" },
    CommandDef { id: CommandId::SetIStep, name: "SetIStep", description: "Motion command in step mode" },
    CommandDef { id: CommandId::SavePos, name: "SavePos", description: "Broadcast: store the actual position" },
    CommandDef {
        id: CommandId::StartMotion,
        name: "StartMotion",
        description: "Broadcast: release the last motion command",
    },
    CommandDef { id: CommandId::ResetTime, name: "ResetTime", description: "Reset internal clock to zero" },
];

impl CommandId {
    pub fn from_u8(v: u8) -> Option<Self> {
        COMMANDS.iter().map(|c| c.id).find(|c| *c as u8 == v)
    }

    pub fn def(self) -> &'static CommandDef {
        COMMANDS.iter().find(|c| c.id == self).expect("every CommandId has a row")
    }

    pub fn name(self) -> &'static str {
        self.def().name
    }
}

/// How a motion command's target is encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionArg {
    /// float, in rad / m, rad/s / m/s or A
    Float,
    /// Int32, encoder ticks or ticks/s
    Int32,
    /// Int16, current in digits
    Int16,
}

/// What a motion command does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionKind {
    Ramp,
    Step,
    Velocity,
    Current,
    CosLoop,
    RampLoop,
}

pub struct MotionDef {
    pub id: u8,
    pub name: &'static str,
    pub kind: MotionKind,
    pub arg: MotionArg,
    /// A UInt16 time in ms follows the target.
    pub timed: bool,
    /// Extended acknowledge: position, short state and DIO.
    pub extended_ack: bool,
    pub unit: &'static str,
}

const fn m(
    id: u8,
    name: &'static str,
    kind: MotionKind,
    arg: MotionArg,
    timed: bool,
    extended_ack: bool,
    unit: &'static str,
) -> MotionDef {
    MotionDef { id, name, kind, arg, timed, extended_ack, unit }
}

use MotionArg::{Float, Int16, Int32};
use MotionKind::{CosLoop, Current, Ramp, RampLoop, Step, Velocity};

/// Motion ids, manual 4.5.
pub const MOTIONS: &[MotionDef] = &[
    m(4, "FRAMP_MODE", Ramp, Float, false, false, "rad|m"),
    m(6, "FSTEP_MODE", Step, Float, true, false, "rad|m"),
    m(7, "FVEL_MODE", Velocity, Float, false, false, "rad/s|m/s"),
    m(8, "FCUR_MODE", Current, Float, false, false, "A"),
    m(9, "IRAMP_MODE", Ramp, Int32, false, false, "ticks"),
    m(11, "ISTEP_MODE", Step, Int32, true, false, "ticks"),
    m(12, "IVEL_MODE", Velocity, Int32, false, false, "ticks/s"),
    m(13, "ICUR_MODE", Current, Int16, false, false, "digits"),
    m(14, "FRAMP_ACK", Ramp, Float, false, true, "rad|m"),
    m(16, "FSTEP_ACK", Step, Float, true, true, "rad|m"),
    m(17, "FVEL_ACK", Velocity, Float, false, true, "rad/s|m/s"),
    m(18, "FCUR_ACK", Current, Float, false, true, "A"),
    m(19, "IRAMP_ACK", Ramp, Int32, false, true, "ticks"),
    m(21, "ISTEP_ACK", Step, Int32, true, true, "ticks"),
    m(22, "IVEL_ACK", Velocity, Int32, false, true, "ticks/s"),
    m(23, "ICUR_ACK", Current, Int16, false, true, "digits"),
    m(24, "FCOSLOOP", CosLoop, Float, true, false, "rad|m"),
    m(25, "FRAMPLOOP", RampLoop, Float, false, false, "rad|m"),
];

pub fn motion(id: u8) -> Option<&'static MotionDef> {
    MOTIONS.iter().find(|d| d.id == id)
}

pub fn motion_by_name(name: &str) -> Option<&'static MotionDef> {
    MOTIONS.iter().find(|d| d.name.eq_ignore_ascii_case(name))
}

// PARAMETERS: see the parameter table below (section 4.6).

/// The wire type of a parameter's value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ParamType {
    Float,
    Int32,
    UInt32,
    Int16,
    UInt16,
    UInt8,
    /// ActFPosStateDio: float position, short state byte, DIO byte.
    FloatStateDio,
    /// ActFPosTime: float position, UInt16 time stamp in ms.
    FloatTime,
}

impl ParamType {
    /// Bytes on the wire.
    pub const fn size(self) -> usize {
        match self {
            Self::Float | Self::Int32 | Self::UInt32 => 4,
            Self::Int16 | Self::UInt16 => 2,
            Self::UInt8 => 1,
            Self::FloatStateDio | Self::FloatTime => 6,
        }
    }

    pub const fn name(self) -> &'static str {
        match self {
            Self::Float => "float",
            Self::Int32 => "int32",
            Self::UInt32 => "uint32",
            Self::Int16 => "int16",
            Self::UInt16 => "uint16",
            Self::UInt8 => "uint8",
            Self::FloatStateDio => "float_state_dio",
            Self::FloatTime => "float_time",
        }
    }
}

/// Read / write access as the manual's table marks it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Access {
    Read,
    Write,
    ReadWrite,
    /// Marked neither readable nor writable (DefA0).
    None,
}

impl Access {
    /// A row marked neither way (DefA0) reads like the ROM value it is: the
    /// vendor's library reads it from real modules.
    pub const fn readable(self) -> bool {
        matches!(self, Self::Read | Self::ReadWrite | Self::None)
    }
    pub const fn writable(self) -> bool {
        matches!(self, Self::Write | Self::ReadWrite)
    }
}

/// The manual's classes: default (ROM), limit, target and actual values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ParamClass {
    Default,
    Limit,
    Target,
    Actual,
}

/// One row of the parameter table (manual 4.6).
#[derive(Debug)]
pub struct ParamDef {
    pub id: u8,
    /// The manual's name, e.g. `ActPos`.
    pub name: &'static str,
    pub ty: ParamType,
    /// Unit as text; `unit` of the module kind where it reads "rad|m".
    pub unit: &'static str,
    pub access: Access,
    pub class: ParamClass,
    pub description: &'static str,
}

impl ParamDef {
    /// The unit for a module of this kind: the table's "rad|m" reads "rad"
    /// on a rotary module and "m" on a linear one.
    pub fn unit_for(&self, linear: bool) -> &'static str {
        match self.unit.split_once('|') {
            Some((rotary, lin)) => {
                if linear {
                    lin
                } else {
                    rotary
                }
            }
            None => self.unit,
        }
    }
}

use Access as Acc;
use ParamClass as Cls;
use ParamType as Ty;

const fn p(
    id: u8,
    name: &'static str,
    ty: ParamType,
    unit: &'static str,
    access: Access,
    class: ParamClass,
    description: &'static str,
) -> ParamDef {
    ParamDef { id, name, ty, unit, access, class, description }
}

/// Every parameter of manual section 4.6, in id order.
///
/// Class follows the row's "(Default value)" / "(Actual value)" / "(Limit)" /
/// "(Target value)" remark. Rows without one are classed here:
/// - `DioSetup`: actual (it reflects the live I/O).
/// - `Config` "(Vorgabe)": limit, because like the limits it can be written
///   after power on and is reset from `DefConfig` at the next power on.
/// - writable `ActI*` / `ActMin*` / `ActMax*` / `Act*Time` rows: limit (they
///   bound the operation and are lost at power off, the manual's definition).
/// - the other `Act*` rows, including writable `ActSyncTime`: actual.
///
/// Types follow the table except the `*Inc` targets and `StepInc`, which the
/// specs README gives as signed Int32. `TargetPos`' remark "in units/s" is a
/// misprint for units. The two `ActFScanPos*` remarks name the opposite edge to
/// the parameter name; they are kept as printed.
pub const PARAMS: &[ParamDef] = &[
    p(0x00, "DefHomeOffset", Ty::Float, "rad|m", Acc::Read, Cls::Default, "Offset to the Home position. By means of this parameter the user can adjust an offset to the physical zero position (home) of the drive."),
    p(0x01, "DefGearRatio", Ty::Float, "", Acc::Read, Cls::Default, "Gear ratio"),
    p(0x02, "DefLinRatio", Ty::Float, "", Acc::Read, Cls::Default, "Transmission factor for transforming rotary in linear motion"),
    p(0x03, "DefMinPos", Ty::Float, "rad|m", Acc::Read, Cls::Default, "Minimum drive position"),
    p(0x04, "DefMaxPos", Ty::Float, "rad|m", Acc::Read, Cls::Default, "Maximum drive position"),
    p(0x05, "DefMaxDeltaPos", Ty::Float, "rad|m", Acc::Read, Cls::Default, "Maximum following error (tow) for the digital servo filter"),
    p(0x06, "DefMaxDeltaVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Default, "Maximum following error for velocity control"),
    p(0x07, "DefTorqueRatio", Ty::Float, "", Acc::Read, Cls::Default, "Transmission factor for transforming current to torque"),
    p(0x08, "DefCurRatio", Ty::Float, "", Acc::Read, Cls::Default, "Transmission factor for current measurement"),
    p(0x09, "DefMinVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Default, "Minimum velocity"),
    p(0x0a, "DefMaxVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Default, "Maximum velocity"),
    p(0x0b, "DefMinAcc", Ty::Float, "rad/s²|m/s²", Acc::Read, Cls::Default, "Minimum acceleration"),
    p(0x0c, "DefMaxAcc", Ty::Float, "rad/s²|m/s²", Acc::Read, Cls::Default, "Maximum acceleration"),
    p(0x0d, "DefMinCur", Ty::Float, "A", Acc::Read, Cls::Default, "Minimum current"),
    p(0x0e, "DefMaxCur", Ty::Float, "A", Acc::Read, Cls::Default, "Maximum current"),
    p(0x0f, "DefHomeVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Default, "Homing velocity. This value is signed and thereby specifies the homing direction."),
    p(0x10, "DefHomeAcc", Ty::Float, "rad/s²|m/s²", Acc::Read, Cls::Default, "Homing acceleration"),
    p(0x1a, "DefCubeSerial", Ty::UInt32, "", Acc::Read, Cls::Default, "Serial number of the PowerCube"),
    p(0x1b, "DefConfig", Ty::UInt32, "", Acc::Read, Cls::Default, "Config word"),
    p(0x1c, "DefPulsesPerTurn", Ty::UInt32, "ticks", Acc::Read, Cls::Default, "Number of Encoder ticks per revolution"),
    p(0x1d, "DefCubeVersion", Ty::UInt16, "", Acc::Read, Cls::Default, "Version information"),
    p(0x1e, "DefServiceInterval", Ty::UInt16, "", Acc::Read, Cls::Default, "Service interval"),
    p(0x1f, "DefBrakeTimeOut", Ty::UInt16, "ms", Acc::Read, Cls::Default, "Delay for releasing the brake in ms"),
    p(0x20, "DefAddress", Ty::UInt8, "", Acc::Read, Cls::Default, "Module bus address [1...31]"),
    p(0x22, "DefPrimBaud", Ty::UInt8, "", Acc::Read, Cls::Default, "Primary Baud rate setting"),
    p(0x23, "DefScndBaud", Ty::UInt8, "", Acc::Read, Cls::Default, "Secondary Baud rate setting"),
    p(0x24, "PosCount", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Absolute Counter value"),
    p(0x25, "RefPosCount", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Absolute Counter value at Homing position"),
    p(0x26, "DioSetup", Ty::UInt32, "", Acc::ReadWrite, Cls::Actual, "Digital IO word"),
    p(0x27, "CubeState", Ty::UInt32, "", Acc::Read, Cls::Actual, "Module State word"),
    p(0x28, "TargetPosInc", Ty::Int32, "ticks", Acc::ReadWrite, Cls::Target, "Target position in Encoder ticks"),
    p(0x29, "TargetVelInc", Ty::Int32, "ticks/s", Acc::ReadWrite, Cls::Target, "Target velocity in Encoder ticks/s"),
    p(0x2a, "TargetAccInc", Ty::Int32, "ticks/s²", Acc::ReadWrite, Cls::Target, "Target acceleration in Encoder ticks/s²"),
    p(0x2b, "StepInc", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Step mode target position in Encoder ticks"),
    p(0x2c, "HomeOffsetInc", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Home offset in Encoder ticks"),
    p(0x35, "RawCur", Ty::Int16, "digits", Acc::ReadWrite, Cls::Actual, "Commanded Current in Digits [-500...+500]"),
    p(0x36, "HomeToZeroInc", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Number of Encoder ticks between home switch and Encoder index"),
    p(0x39, "Config", Ty::UInt32, "", Acc::ReadWrite, Cls::Limit, "Config word"),
    p(0x3a, "MoveMode", Ty::UInt8, "", Acc::Read, Cls::Actual, "Motion mode"),
    p(0x3b, "IncRatio", Ty::Float, "ticks/rad|ticks/m", Acc::Read, Cls::Actual, "Ratio of Encoder ticks and unit, rad resp. m"),
    p(0x3c, "ActPos", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Actual position in rad resp. m"),
    p(0x3d, "ActPos_", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Previous position in rad resp. m"),
    p(0x3e, "IPolPos", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Actual interpolated position"),
    p(0x3f, "DeltaPos", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Actual following error"),
    p(0x40, "MaxDeltaPos", Ty::Float, "rad|m", Acc::ReadWrite, Cls::Limit, "Maximum following error"),
    p(0x41, "ActVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Actual, "Actual velocity in units/s"),
    p(0x42, "IPolVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Actual, "Actual interpolated velocity in units/s"),
    p(0x45, "MinPos", Ty::Float, "rad|m", Acc::ReadWrite, Cls::Limit, "Minimum position"),
    p(0x46, "MaxPos", Ty::Float, "rad|m", Acc::ReadWrite, Cls::Limit, "Maximum position"),
    p(0x48, "MaxVel", Ty::Float, "rad/s|m/s", Acc::ReadWrite, Cls::Limit, "Maximum velocity in units/s"),
    p(0x4a, "MaxAcc", Ty::Float, "rad/s²|m/s²", Acc::ReadWrite, Cls::Limit, "Maximum acceleration in units/s²"),
    p(0x4c, "MaxCur", Ty::Float, "A", Acc::ReadWrite, Cls::Limit, "Maximum Current"),
    p(0x4d, "Cur", Ty::Float, "A", Acc::ReadWrite, Cls::Actual, "Actual current"),
    p(0x4e, "TargetPos", Ty::Float, "rad|m", Acc::Write, Cls::Target, "Target position in units"),
    p(0x4f, "TargetVel", Ty::Float, "rad/s|m/s", Acc::Write, Cls::Target, "Target velocity in units/s"),
    p(0x50, "TargetAcc", Ty::Float, "rad/s²|m/s²", Acc::Write, Cls::Target, "Target acceleration in units/s²"),
    p(0x51, "DefC0", Ty::Int16, "", Acc::Read, Cls::Default, "Servo loop gain C0"),
    p(0x52, "DefDamp", Ty::Int16, "", Acc::Read, Cls::Default, "Servo loop damping"),
    p(0x53, "DefA0", Ty::Int16, "", Acc::None, Cls::Default, "Servo loop parameter A0"),
    p(0x54, "ActC0", Ty::Int16, "", Acc::ReadWrite, Cls::Actual, "Servo loop gain C0"),
    p(0x55, "ActDamp", Ty::Int16, "", Acc::ReadWrite, Cls::Actual, "Servo loop damping"),
    p(0x56, "ActA0", Ty::Int16, "", Acc::ReadWrite, Cls::Actual, "Servo loop parameter A0"),
    p(0x57, "DefBurnCount", Ty::UInt8, "", Acc::Read, Cls::Default, "Number of flash downloads"),
    p(0x58, "Setup", Ty::UInt32, "", Acc::Read, Cls::Default, "Setup word"),
    p(0x59, "HomeOffset", Ty::Float, "rad|m", Acc::ReadWrite, Cls::Actual, "Home offset"),
    p(0x5a, "ActIPos", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Actual position in encoder ticks"),
    p(0x5b, "ActIMaxDeltaPos", Ty::Int32, "ticks", Acc::ReadWrite, Cls::Limit, "Maximum allowed difference between commanded and actual position, in encoder ticks = tow distance"),
    p(0x5c, "ActIMinPos", Ty::Int32, "ticks", Acc::ReadWrite, Cls::Limit, "Minimum allowed Position in encoder ticks"),
    p(0x5d, "ActIMaxPos", Ty::Int32, "ticks", Acc::ReadWrite, Cls::Limit, "Maximum allowed Position in encoder ticks"),
    p(0x5e, "ActIMaxVel", Ty::Int32, "ticks/s", Acc::ReadWrite, Cls::Limit, "Maximum allowed speed in encoder ticks/s"),
    p(0x5f, "ActIMaxAcc", Ty::Int32, "ticks/s²", Acc::ReadWrite, Cls::Limit, "Maximum allowed acceleration in encoder ticks/s²"),
    p(0x60, "ActIVel", Ty::Int32, "ticks/s", Acc::Read, Cls::Actual, "Actual speed in encoder ticks/s"),
    p(0x61, "ActIDeltaPos", Ty::Int32, "ticks", Acc::Read, Cls::Actual, "Actual tow distance in encoder ticks"),
    p(0x62, "ActFPosStateDio", Ty::FloatStateDio, "rad|m", Acc::Read, Cls::Actual, "Returns 3 Values: Actual Position, Short state, I/O-State"),
    p(0x63, "ActFSavedPos", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Last upon broadcast saved position"),
    p(0x64, "ActFHomeVel", Ty::Float, "rad/s|m/s", Acc::Read, Cls::Actual, "Actual homing speed"),
    p(0x65, "ActIHomeVel", Ty::Int32, "ticks/s", Acc::Read, Cls::Actual, "Actual homing speed in encoder ticks/s"),
    p(0x66, "ActSyncTime", Ty::UInt16, "", Acc::ReadWrite, Cls::Actual, "Actual SYNC time"),
    p(0x6a, "ActIIPolVel", Ty::Int32, "ticks/s", Acc::Read, Cls::Actual, "Actual calculated speed in encoder ticks/s"),
    p(0x6c, "ActRawMotorCurrent", Ty::UInt16, "digits", Acc::Read, Cls::Actual, "Actual DC Bus Current in Digits"),
    p(0x6d, "ActRawMotorSupply", Ty::UInt16, "digits", Acc::Read, Cls::Actual, "Actual DC Bus Voltage in Digits"),
    p(0x6e, "ActRawTemp", Ty::Int16, "digits", Acc::Read, Cls::Actual, "Actual temperature inside housing in Digits"),
    p(0x6f, "ActRawLogicSupply", Ty::UInt16, "digits", Acc::Read, Cls::Actual, "Actual Logic voltage in Digits"),
    p(0x70, "ActFMotorCurrent", Ty::Float, "A", Acc::Read, Cls::Actual, "Actual DC Bus Current in A"),
    p(0x71, "ActFMotorSupply", Ty::Float, "V", Acc::Read, Cls::Actual, "Actual DC Bus Voltage in V"),
    p(0x72, "ActFTemp", Ty::Float, "°C", Acc::Read, Cls::Actual, "Actual temperature in housing in °C"),
    p(0x73, "ActFLogicSupply", Ty::Float, "V", Acc::Read, Cls::Actual, "Actual logic supply voltage in V"),
    p(0x74, "ActMinLogicSupply", Ty::Float, "V", Acc::ReadWrite, Cls::Limit, "Minimum allowed logic voltage in V"),
    p(0x75, "ActMaxLogicSupply", Ty::Float, "V", Acc::ReadWrite, Cls::Limit, "Maximum allowed logic voltage in V"),
    p(0x76, "ActMinMotorSupply", Ty::Float, "V", Acc::ReadWrite, Cls::Limit, "Minimum allowed motor voltage in V"),
    p(0x77, "ActMaxMotorSupply", Ty::Float, "V", Acc::ReadWrite, Cls::Limit, "Maximum allowed motor voltage in V"),
    p(0x7a, "ActLogicUndershootTime", Ty::UInt32, "ms", Acc::ReadWrite, Cls::Limit, "Maximum allowed undershoot time for logic voltage in ms"),
    p(0x7b, "ActLogicOvershootTime", Ty::UInt32, "ms", Acc::ReadWrite, Cls::Limit, "Maximum allowed overshoot time for logic voltage in ms"),
    p(0x7c, "ActMotorUndershootTime", Ty::UInt32, "ms", Acc::ReadWrite, Cls::Limit, "Maximum allowed undershoot time for motor voltage in ms"),
    p(0x7d, "ActMotorOvershootTime", Ty::UInt32, "ms", Acc::ReadWrite, Cls::Limit, "Maximum allowed overshoot time for motor voltage in ms"),
    p(0x84, "ActMaxTemp", Ty::Float, "°C", Acc::ReadWrite, Cls::Limit, "Maximum allowed temperature inside housing"),
    p(0x85, "ActMinTemp", Ty::Float, "°C", Acc::ReadWrite, Cls::Limit, "Minimum allowed temperature inside housing"),
    p(0xa1, "ActFPosTime", Ty::FloatTime, "rad|m", Acc::Read, Cls::Actual, "Returns 2 Values: Actual position and time stamp [ms]"),
    p(0xa2, "ActFScanPosFallEdge", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Last upon rising edge on input SW3 saved Position"),
    p(0xa3, "ActFScanPosRisgEdge", Ty::Float, "rad|m", Acc::Read, Cls::Actual, "Last upon falling edge on input SW3 saved Position"),
];

/// The parameter with id `id`.
pub fn param(id: u8) -> Option<&'static ParamDef> {
    PARAMS.iter().find(|d| d.id == id)
}

/// The unit of a position (ActPos) on a module of this kind, for the code
/// that shows a position or a target without naming a parameter.
pub fn position_unit(linear: bool) -> &'static str {
    param(ids::ACT_POS).map_or("", |d| d.unit_for(linear))
}

/// The parameter named `name` (the manual's name, any case).
pub fn param_by_name(name: &str) -> Option<&'static ParamDef> {
    PARAMS.iter().find(|d| d.name.eq_ignore_ascii_case(name))
}

/// A parameter given as a name, a decimal id or a `0x` hex id.
pub fn resolve_param(text: &str) -> Option<&'static ParamDef> {
    let t = text.trim();
    if let Some(d) = param_by_name(t) {
        return Some(d);
    }
    let id = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u8::from_str_radix(h, 16).ok()?
    } else {
        t.parse::<u8>().ok()?
    };
    param(id)
}

/// Parameter ids other code names directly. Each is checked against
/// [`PARAMS`] by name in the tests, so a typo cannot drift from the table.
/// The first firmware (4.6.01) that has the measured temperature and supply
/// voltages: the vendor's library reads them only from this version on.
pub const MEASUREMENTS_SINCE: u16 = 0x4601;

/// `3.5.18` from DefCubeVersion 0x3518.
pub fn version_text(v: u16) -> String {
    format!("{:x}.{:x}.{:02x}", v >> 12, (v >> 8) & 0xf, v & 0xff)
}

/// Whether firmware `version` has parameter `id`: older firmware lacks
/// ActFTemp, ActFMotorSupply and ActFLogicSupply and does not answer them.
pub fn firmware_has(version: u16, id: u8) -> bool {
    version >= MEASUREMENTS_SINCE || !matches!(id, ids::ACT_F_TEMP | ids::ACT_F_MOTOR_SUPPLY | ids::ACT_F_LOGIC_SUPPLY)
}

pub mod ids {
    /// `DefHomeOffset`
    pub const DEF_HOME_OFFSET: u8 = 0x00;
    /// `DefGearRatio`
    pub const DEF_GEAR_RATIO: u8 = 0x01;
    /// `DefLinRatio`
    pub const DEF_LIN_RATIO: u8 = 0x02;
    /// `DefMinPos`
    pub const DEF_MIN_POS: u8 = 0x03;
    /// `DefMaxPos`
    pub const DEF_MAX_POS: u8 = 0x04;
    /// `DefMaxDeltaPos`
    pub const DEF_MAX_DELTA_POS: u8 = 0x05;
    /// `DefMaxDeltaVel`
    pub const DEF_MAX_DELTA_VEL: u8 = 0x06;
    /// `DefTorqueRatio`
    pub const DEF_TORQUE_RATIO: u8 = 0x07;
    /// `DefCurRatio`
    pub const DEF_CUR_RATIO: u8 = 0x08;
    /// `DefMinVel`
    pub const DEF_MIN_VEL: u8 = 0x09;
    /// `DefMaxVel`
    pub const DEF_MAX_VEL: u8 = 0x0a;
    /// `DefMinAcc`
    pub const DEF_MIN_ACC: u8 = 0x0b;
    /// `DefMaxAcc`
    pub const DEF_MAX_ACC: u8 = 0x0c;
    /// `DefMinCur`
    pub const DEF_MIN_CUR: u8 = 0x0d;
    /// `DefMaxCur`
    pub const DEF_MAX_CUR: u8 = 0x0e;
    /// `DefHomeVel`
    pub const DEF_HOME_VEL: u8 = 0x0f;
    /// `DefHomeAcc`
    pub const DEF_HOME_ACC: u8 = 0x10;
    /// `DefCubeSerial`
    pub const DEF_CUBE_SERIAL: u8 = 0x1a;
    /// `DefConfig`
    pub const DEF_CONFIG: u8 = 0x1b;
    /// `DefPulsesPerTurn`
    pub const DEF_PULSES_PER_TURN: u8 = 0x1c;
    /// `DefCubeVersion`
    pub const DEF_CUBE_VERSION: u8 = 0x1d;
    /// `DefServiceInterval`
    pub const DEF_SERVICE_INTERVAL: u8 = 0x1e;
    /// `DefBrakeTimeOut`
    pub const DEF_BRAKE_TIME_OUT: u8 = 0x1f;
    /// `DefAddress`
    pub const DEF_ADDRESS: u8 = 0x20;
    /// `DefPrimBaud`
    pub const DEF_PRIM_BAUD: u8 = 0x22;
    /// `DefScndBaud`
    pub const DEF_SCND_BAUD: u8 = 0x23;
    /// `PosCount`
    pub const POS_COUNT: u8 = 0x24;
    /// `RefPosCount`
    pub const REF_POS_COUNT: u8 = 0x25;
    /// `DioSetup`
    pub const DIO_SETUP: u8 = 0x26;
    /// `CubeState`
    pub const CUBE_STATE: u8 = 0x27;
    /// `TargetPosInc`
    pub const TARGET_POS_INC: u8 = 0x28;
    /// `TargetVelInc`
    pub const TARGET_VEL_INC: u8 = 0x29;
    /// `TargetAccInc`
    pub const TARGET_ACC_INC: u8 = 0x2a;
    /// `StepInc`
    pub const STEP_INC: u8 = 0x2b;
    /// `HomeOffsetInc`
    pub const HOME_OFFSET_INC: u8 = 0x2c;
    /// `RawCur`
    pub const RAW_CUR: u8 = 0x35;
    /// `HomeToZeroInc`
    pub const HOME_TO_ZERO_INC: u8 = 0x36;
    /// `Config`
    pub const CONFIG: u8 = 0x39;
    /// `MoveMode`
    pub const MOVE_MODE: u8 = 0x3a;
    /// `IncRatio`
    pub const INC_RATIO: u8 = 0x3b;
    /// `ActPos`
    pub const ACT_POS: u8 = 0x3c;
    /// `ActPos_`
    pub const ACT_POS_PREV: u8 = 0x3d;
    /// `IPolPos`
    pub const I_POL_POS: u8 = 0x3e;
    /// `DeltaPos`
    pub const DELTA_POS: u8 = 0x3f;
    /// `MaxDeltaPos`
    pub const MAX_DELTA_POS: u8 = 0x40;
    /// `ActVel`
    pub const ACT_VEL: u8 = 0x41;
    /// `IPolVel`
    pub const I_POL_VEL: u8 = 0x42;
    /// `MinPos`
    pub const MIN_POS: u8 = 0x45;
    /// `MaxPos`
    pub const MAX_POS: u8 = 0x46;
    /// `MaxVel`
    pub const MAX_VEL: u8 = 0x48;
    /// `MaxAcc`
    pub const MAX_ACC: u8 = 0x4a;
    /// `MaxCur`
    pub const MAX_CUR: u8 = 0x4c;
    /// `Cur`
    pub const CUR: u8 = 0x4d;
    /// `TargetPos`
    pub const TARGET_POS: u8 = 0x4e;
    /// `TargetVel`
    pub const TARGET_VEL: u8 = 0x4f;
    /// `TargetAcc`
    pub const TARGET_ACC: u8 = 0x50;
    /// `DefC0`
    pub const DEF_C0: u8 = 0x51;
    /// `DefDamp`
    pub const DEF_DAMP: u8 = 0x52;
    /// `DefA0`
    pub const DEF_A0: u8 = 0x53;
    /// `ActC0`
    pub const ACT_C0: u8 = 0x54;
    /// `ActDamp`
    pub const ACT_DAMP: u8 = 0x55;
    /// `ActA0`
    pub const ACT_A0: u8 = 0x56;
    /// `DefBurnCount`
    pub const DEF_BURN_COUNT: u8 = 0x57;
    /// `Setup`
    pub const SETUP: u8 = 0x58;
    /// `HomeOffset`
    pub const HOME_OFFSET: u8 = 0x59;
    /// `ActIPos`
    pub const ACT_I_POS: u8 = 0x5a;
    /// `ActIMaxDeltaPos`
    pub const ACT_I_MAX_DELTA_POS: u8 = 0x5b;
    /// `ActIMinPos`
    pub const ACT_I_MIN_POS: u8 = 0x5c;
    /// `ActIMaxPos`
    pub const ACT_I_MAX_POS: u8 = 0x5d;
    /// `ActIMaxVel`
    pub const ACT_I_MAX_VEL: u8 = 0x5e;
    /// `ActIMaxAcc`
    pub const ACT_I_MAX_ACC: u8 = 0x5f;
    /// `ActIVel`
    pub const ACT_I_VEL: u8 = 0x60;
    /// `ActIDeltaPos`
    pub const ACT_I_DELTA_POS: u8 = 0x61;
    /// `ActFPosStateDio`
    pub const ACT_F_POS_STATE_DIO: u8 = 0x62;
    /// `ActFSavedPos`
    pub const ACT_F_SAVED_POS: u8 = 0x63;
    /// `ActFHomeVel`
    pub const ACT_F_HOME_VEL: u8 = 0x64;
    /// `ActIHomeVel`
    pub const ACT_I_HOME_VEL: u8 = 0x65;
    /// `ActSyncTime`
    pub const ACT_SYNC_TIME: u8 = 0x66;
    /// `ActIIPolVel`
    pub const ACT_II_POL_VEL: u8 = 0x6a;
    /// `ActRawMotorCurrent`
    pub const ACT_RAW_MOTOR_CURRENT: u8 = 0x6c;
    /// `ActRawMotorSupply`
    pub const ACT_RAW_MOTOR_SUPPLY: u8 = 0x6d;
    /// `ActRawTemp`
    pub const ACT_RAW_TEMP: u8 = 0x6e;
    /// `ActRawLogicSupply`
    pub const ACT_RAW_LOGIC_SUPPLY: u8 = 0x6f;
    /// `ActFMotorCurrent`
    pub const ACT_F_MOTOR_CURRENT: u8 = 0x70;
    /// `ActFMotorSupply`
    pub const ACT_F_MOTOR_SUPPLY: u8 = 0x71;
    /// `ActFTemp`
    pub const ACT_F_TEMP: u8 = 0x72;
    /// `ActFLogicSupply`
    pub const ACT_F_LOGIC_SUPPLY: u8 = 0x73;
    /// `ActMinLogicSupply`
    pub const ACT_MIN_LOGIC_SUPPLY: u8 = 0x74;
    /// `ActMaxLogicSupply`
    pub const ACT_MAX_LOGIC_SUPPLY: u8 = 0x75;
    /// `ActMinMotorSupply`
    pub const ACT_MIN_MOTOR_SUPPLY: u8 = 0x76;
    /// `ActMaxMotorSupply`
    pub const ACT_MAX_MOTOR_SUPPLY: u8 = 0x77;
    /// `ActLogicUndershootTime`
    pub const ACT_LOGIC_UNDERSHOOT_TIME: u8 = 0x7a;
    /// `ActLogicOvershootTime`
    pub const ACT_LOGIC_OVERSHOOT_TIME: u8 = 0x7b;
    /// `ActMotorUndershootTime`
    pub const ACT_MOTOR_UNDERSHOOT_TIME: u8 = 0x7c;
    /// `ActMotorOvershootTime`
    pub const ACT_MOTOR_OVERSHOOT_TIME: u8 = 0x7d;
    /// `ActMaxTemp`
    pub const ACT_MAX_TEMP: u8 = 0x84;
    /// `ActMinTemp`
    pub const ACT_MIN_TEMP: u8 = 0x85;
    /// `ActFPosTime`
    pub const ACT_F_POS_TIME: u8 = 0xa1;
    /// `ActFScanPosFallEdge`
    pub const ACT_F_SCAN_POS_FALL_EDGE: u8 = 0xa2;
    /// `ActFScanPosRisgEdge`
    pub const ACT_F_SCAN_POS_RISG_EDGE: u8 = 0xa3;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_unit_follows_the_module_kind_where_the_table_gives_two() {
        let unit = |id, linear| PARAMS.iter().find(|p| p.id == id).unwrap().unit_for(linear);
        assert_eq!((unit(ids::ACT_POS, false), unit(ids::ACT_POS, true)), ("rad", "m"));
        assert_eq!((unit(ids::ACT_VEL, false), unit(ids::ACT_VEL, true)), ("rad/s", "m/s"));
        assert_eq!((unit(ids::CUR, false), unit(ids::CUR, true)), ("A", "A"));
        assert_eq!((position_unit(false), position_unit(true)), ("rad", "m"));
    }

    #[test]
    fn measurements_come_with_firmware_4_6_01() {
        assert_eq!(version_text(0x3518), "3.5.18");
        assert_eq!(version_text(MEASUREMENTS_SINCE), "4.6.01");
        for id in [ids::ACT_F_TEMP, ids::ACT_F_MOTOR_SUPPLY, ids::ACT_F_LOGIC_SUPPLY] {
            assert!(!firmware_has(0x3518, id) && !firmware_has(0x4600, id) && firmware_has(0x4601, id));
        }
        assert!(firmware_has(0x3518, ids::ACT_POS) && firmware_has(0, ids::DEF_A0));
    }

    #[test]
    fn params_match_the_manual_table() {
        // Manual 4.6 lists 100 rows, DefHomeOffset 0x00 .. ActFScanPosRisgEdge 0xA3.
        assert_eq!(PARAMS.len(), 100);
        assert_eq!(PARAMS.first().map(|d| d.name), Some("DefHomeOffset"));
        assert_eq!(PARAMS.last().map(|d| (d.id, d.name)), Some((0xa3, "ActFScanPosRisgEdge")));
        assert!(PARAMS.windows(2).all(|w| w[0].id < w[1].id), "ids strictly ascending, hence unique");
        let mut names: Vec<String> = PARAMS.iter().map(|d| d.name.to_ascii_lowercase()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), PARAMS.len(), "names unique ignoring case");
    }

    #[test]
    fn every_param_resolves_by_id_name_and_text() {
        for d in PARAMS {
            assert_eq!(param(d.id).map(|p| p.name), Some(d.name));
            assert_eq!(param_by_name(&d.name.to_ascii_uppercase()).map(|p| p.id), Some(d.id));
            assert_eq!(resolve_param(d.name).map(|p| p.id), Some(d.id));
            assert_eq!(resolve_param(&d.id.to_string()).map(|p| p.id), Some(d.id));
            assert_eq!(resolve_param(&format!("{:#04x}", d.id)).map(|p| p.id), Some(d.id));
            assert_eq!(resolve_param(&format!("0X{:02X}", d.id)).map(|p| p.id), Some(d.id));
        }
        // 0x11..0x19 are not in the table.
        assert!(param(0x11).is_none());
        assert!(resolve_param("0x11").is_none());
        assert!(resolve_param("256").is_none());
        assert!(resolve_param("NoSuchParam").is_none());
    }

    #[test]
    fn row_types_access_and_classes() {
        let row = |id| param(id).unwrap();
        assert_eq!(row(ids::ACT_POS).ty, ParamType::Float);
        assert_eq!(row(ids::ACT_POS).unit, "rad|m");
        assert_eq!(row(ids::CUBE_STATE).ty, ParamType::UInt32);
        assert_eq!(row(ids::DEF_CUBE_VERSION).ty, ParamType::UInt16);
        assert_eq!(row(ids::RAW_CUR).ty, ParamType::Int16);
        assert_eq!(row(ids::DIO_SETUP).access, Access::ReadWrite);
        // specs README: the *Inc targets are signed.
        for id in [ids::TARGET_POS_INC, ids::TARGET_VEL_INC, ids::TARGET_ACC_INC, ids::STEP_INC] {
            assert_eq!(row(id).ty, ParamType::Int32, "{}", row(id).name);
        }
        assert_eq!(row(ids::ACT_F_POS_STATE_DIO).ty, ParamType::FloatStateDio);
        assert_eq!(row(ids::ACT_F_POS_TIME).ty, ParamType::FloatTime);
        assert_eq!(row(ids::DEF_A0).access, Access::None);
        assert!(row(ids::DEF_A0).access.readable() && !row(ids::DEF_A0).access.writable());
        for id in [ids::TARGET_POS, ids::TARGET_VEL, ids::TARGET_ACC] {
            assert_eq!(row(id).access, Access::Write);
            assert_eq!(row(id).class, ParamClass::Target);
        }
        assert_eq!(row(ids::MAX_VEL).class, ParamClass::Limit);
        assert_eq!(row(ids::DEF_MAX_VEL).class, ParamClass::Default);
        assert_eq!(row(ids::CUR).class, ParamClass::Actual);
        assert_eq!(row(ids::ACT_F_TEMP).unit, "°C");
        assert_eq!(row(ids::TARGET_ACC).unit, "rad/s²|m/s²");
    }

    #[test]
    fn ids_name_the_right_rows() {
        let pairs = [
            (ids::DEF_HOME_OFFSET, "DefHomeOffset"),
            (ids::DEF_GEAR_RATIO, "DefGearRatio"),
            (ids::DEF_LIN_RATIO, "DefLinRatio"),
            (ids::DEF_MIN_POS, "DefMinPos"),
            (ids::DEF_MAX_POS, "DefMaxPos"),
            (ids::DEF_MAX_DELTA_POS, "DefMaxDeltaPos"),
            (ids::DEF_MAX_DELTA_VEL, "DefMaxDeltaVel"),
            (ids::DEF_TORQUE_RATIO, "DefTorqueRatio"),
            (ids::DEF_CUR_RATIO, "DefCurRatio"),
            (ids::DEF_MIN_VEL, "DefMinVel"),
            (ids::DEF_MAX_VEL, "DefMaxVel"),
            (ids::DEF_MIN_ACC, "DefMinAcc"),
            (ids::DEF_MAX_ACC, "DefMaxAcc"),
            (ids::DEF_MIN_CUR, "DefMinCur"),
            (ids::DEF_MAX_CUR, "DefMaxCur"),
            (ids::DEF_HOME_VEL, "DefHomeVel"),
            (ids::DEF_HOME_ACC, "DefHomeAcc"),
            (ids::DEF_CUBE_SERIAL, "DefCubeSerial"),
            (ids::DEF_CONFIG, "DefConfig"),
            (ids::DEF_PULSES_PER_TURN, "DefPulsesPerTurn"),
            (ids::DEF_CUBE_VERSION, "DefCubeVersion"),
            (ids::DEF_SERVICE_INTERVAL, "DefServiceInterval"),
            (ids::DEF_BRAKE_TIME_OUT, "DefBrakeTimeOut"),
            (ids::DEF_ADDRESS, "DefAddress"),
            (ids::DEF_PRIM_BAUD, "DefPrimBaud"),
            (ids::DEF_SCND_BAUD, "DefScndBaud"),
            (ids::POS_COUNT, "PosCount"),
            (ids::REF_POS_COUNT, "RefPosCount"),
            (ids::DIO_SETUP, "DioSetup"),
            (ids::CUBE_STATE, "CubeState"),
            (ids::TARGET_POS_INC, "TargetPosInc"),
            (ids::TARGET_VEL_INC, "TargetVelInc"),
            (ids::TARGET_ACC_INC, "TargetAccInc"),
            (ids::STEP_INC, "StepInc"),
            (ids::HOME_OFFSET_INC, "HomeOffsetInc"),
            (ids::RAW_CUR, "RawCur"),
            (ids::HOME_TO_ZERO_INC, "HomeToZeroInc"),
            (ids::CONFIG, "Config"),
            (ids::MOVE_MODE, "MoveMode"),
            (ids::INC_RATIO, "IncRatio"),
            (ids::ACT_POS, "ActPos"),
            (ids::ACT_POS_PREV, "ActPos_"),
            (ids::I_POL_POS, "IPolPos"),
            (ids::DELTA_POS, "DeltaPos"),
            (ids::MAX_DELTA_POS, "MaxDeltaPos"),
            (ids::ACT_VEL, "ActVel"),
            (ids::I_POL_VEL, "IPolVel"),
            (ids::MIN_POS, "MinPos"),
            (ids::MAX_POS, "MaxPos"),
            (ids::MAX_VEL, "MaxVel"),
            (ids::MAX_ACC, "MaxAcc"),
            (ids::MAX_CUR, "MaxCur"),
            (ids::CUR, "Cur"),
            (ids::TARGET_POS, "TargetPos"),
            (ids::TARGET_VEL, "TargetVel"),
            (ids::TARGET_ACC, "TargetAcc"),
            (ids::DEF_C0, "DefC0"),
            (ids::DEF_DAMP, "DefDamp"),
            (ids::DEF_A0, "DefA0"),
            (ids::ACT_C0, "ActC0"),
            (ids::ACT_DAMP, "ActDamp"),
            (ids::ACT_A0, "ActA0"),
            (ids::DEF_BURN_COUNT, "DefBurnCount"),
            (ids::SETUP, "Setup"),
            (ids::HOME_OFFSET, "HomeOffset"),
            (ids::ACT_I_POS, "ActIPos"),
            (ids::ACT_I_MAX_DELTA_POS, "ActIMaxDeltaPos"),
            (ids::ACT_I_MIN_POS, "ActIMinPos"),
            (ids::ACT_I_MAX_POS, "ActIMaxPos"),
            (ids::ACT_I_MAX_VEL, "ActIMaxVel"),
            (ids::ACT_I_MAX_ACC, "ActIMaxAcc"),
            (ids::ACT_I_VEL, "ActIVel"),
            (ids::ACT_I_DELTA_POS, "ActIDeltaPos"),
            (ids::ACT_F_POS_STATE_DIO, "ActFPosStateDio"),
            (ids::ACT_F_SAVED_POS, "ActFSavedPos"),
            (ids::ACT_F_HOME_VEL, "ActFHomeVel"),
            (ids::ACT_I_HOME_VEL, "ActIHomeVel"),
            (ids::ACT_SYNC_TIME, "ActSyncTime"),
            (ids::ACT_II_POL_VEL, "ActIIPolVel"),
            (ids::ACT_RAW_MOTOR_CURRENT, "ActRawMotorCurrent"),
            (ids::ACT_RAW_MOTOR_SUPPLY, "ActRawMotorSupply"),
            (ids::ACT_RAW_TEMP, "ActRawTemp"),
            (ids::ACT_RAW_LOGIC_SUPPLY, "ActRawLogicSupply"),
            (ids::ACT_F_MOTOR_CURRENT, "ActFMotorCurrent"),
            (ids::ACT_F_MOTOR_SUPPLY, "ActFMotorSupply"),
            (ids::ACT_F_TEMP, "ActFTemp"),
            (ids::ACT_F_LOGIC_SUPPLY, "ActFLogicSupply"),
            (ids::ACT_MIN_LOGIC_SUPPLY, "ActMinLogicSupply"),
            (ids::ACT_MAX_LOGIC_SUPPLY, "ActMaxLogicSupply"),
            (ids::ACT_MIN_MOTOR_SUPPLY, "ActMinMotorSupply"),
            (ids::ACT_MAX_MOTOR_SUPPLY, "ActMaxMotorSupply"),
            (ids::ACT_LOGIC_UNDERSHOOT_TIME, "ActLogicUndershootTime"),
            (ids::ACT_LOGIC_OVERSHOOT_TIME, "ActLogicOvershootTime"),
            (ids::ACT_MOTOR_UNDERSHOOT_TIME, "ActMotorUndershootTime"),
            (ids::ACT_MOTOR_OVERSHOOT_TIME, "ActMotorOvershootTime"),
            (ids::ACT_MAX_TEMP, "ActMaxTemp"),
            (ids::ACT_MIN_TEMP, "ActMinTemp"),
            (ids::ACT_F_POS_TIME, "ActFPosTime"),
            (ids::ACT_F_SCAN_POS_FALL_EDGE, "ActFScanPosFallEdge"),
            (ids::ACT_F_SCAN_POS_RISG_EDGE, "ActFScanPosRisgEdge"),
        ];
        assert_eq!(pairs.len(), PARAMS.len());
        for (id, name) in pairs {
            assert_eq!(param(id).map(|d| d.name), Some(name));
        }
    }
}
