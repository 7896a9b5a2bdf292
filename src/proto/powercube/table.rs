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
    pub const fn readable(self) -> bool {
        matches!(self, Self::Read | Self::ReadWrite)
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
