//! The Cdios 6168 table: every command of the manual (05h, 10h, 16h, 20h..27h)
//! plus the controller's 01h identify, with their fields, selectors, replies,
//! command-specific error bits, the four motor status bytes and the general
//! error codes. Each row is declared once; the generic encoder and decoders
//! below, the typed [`super::Command`], the CLI and the docs read from here.
//!
//! Offsets are 0-based indices into the 8 data bytes (manual byte = offset + 1).
//! Every multi-byte value is little-endian.

use super::{Address, ValidationError};
use crate::proto::DecodeError;

/// How a field sits in the 8 data bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    U8,
    U16,
    I16,
    I32,
    /// `width` bits from bit `shift` of one byte; several share a byte.
    Bits {
        shift: u8,
        width: u8,
    },
    /// A byte the manual fixes (the "CDS" key of 05h).
    Const(u8),
}

impl Kind {
    /// Bytes on the wire.
    pub const fn width(self) -> usize {
        match self {
            Self::U8 | Self::Bits { .. } | Self::Const(_) => 1,
            Self::U16 | Self::I16 => 2,
            Self::I32 => 4,
        }
    }

    pub const fn signed(self) -> bool {
        matches!(self, Self::I16 | Self::I32)
    }

    /// What the wire can carry at all.
    pub const fn raw_range(self) -> (i64, i64) {
        match self {
            Self::U8 => (0, u8::MAX as i64),
            Self::U16 => (0, u16::MAX as i64),
            Self::I16 => (i16::MIN as i64, i16::MAX as i64),
            Self::I32 => (i32::MIN as i64, i32::MAX as i64),
            Self::Bits { width, .. } => (0, (1i64 << width) - 1),
            Self::Const(c) => (c as i64, c as i64),
        }
    }

    fn read(self, offset: usize, data: &[u8; 8]) -> i64 {
        let at = |i: usize| data.get(offset + i).copied().unwrap_or(0);
        match self {
            Self::U8 | Self::Const(_) => at(0).into(),
            Self::U16 => u16::from_le_bytes([at(0), at(1)]).into(),
            Self::I16 => i16::from_le_bytes([at(0), at(1)]).into(),
            Self::I32 => i32::from_le_bytes([at(0), at(1), at(2), at(3)]).into(),
            Self::Bits { shift, width } => ((at(0) >> shift) & ((1u16 << width) - 1) as u8).into(),
        }
    }

    /// `v` must already be inside [`Self::raw_range`].
    fn write(self, offset: usize, data: &mut [u8; 8], v: i64) {
        let bytes: &[u8] = match self {
            Self::U8 => &[v as u8],
            Self::Const(c) => &[c],
            Self::U16 | Self::I16 => &(v as u16).to_le_bytes(),
            Self::I32 => &(v as u32).to_le_bytes(),
            Self::Bits { shift, width } => {
                let mask = ((1u16 << width) - 1) as u8;
                if let Some(b) = data.get_mut(offset) {
                    *b = (*b & !(mask << shift)) | ((v as u8 & mask) << shift);
                }
                return;
            }
        };
        for (i, b) in bytes.iter().enumerate() {
            if let Some(slot) = data.get_mut(offset + i) {
                *slot = *b;
            }
        }
    }
}

/// Conversion of a raw value to a physical one: `raw * factor` in `unit`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Scale {
    pub factor: f64,
    pub unit: &'static str,
}

/// One value inside a message.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Field {
    /// JSON / CLI key.
    pub key: &'static str,
    /// The manual's name.
    pub name: &'static str,
    /// 0-based index of the first byte (manual byte = offset + 1).
    pub offset: u8,
    pub kind: Kind,
    /// Unit of the raw value as the manual gives it ("" where it gives none).
    pub unit: &'static str,
    pub scale: Option<Scale>,
    /// Valid range from the manual (inclusive).
    pub min: i64,
    pub max: i64,
    /// The manual's default, where it gives one.
    pub default: Option<i64>,
    pub description: &'static str,
}

impl Field {
    pub fn in_range(&self, v: i64) -> bool {
        (self.min..=self.max).contains(&v)
    }

    pub fn check(&self, v: i64) -> Result<(), ValidationError> {
        if self.in_range(v) {
            Ok(())
        } else {
            Err(ValidationError::OutOfRange { field: self.key, value: v, min: self.min, max: self.max })
        }
    }

    pub fn read(&self, data: &[u8; 8]) -> i64 {
        self.kind.read(self.offset as usize, data)
    }
}

const F: Field = Field {
    key: "",
    name: "",
    offset: 3,
    kind: Kind::U8,
    unit: "",
    scale: None,
    min: 0,
    max: 255,
    default: None,
    description: "",
};
const BOOL: Field = Field { min: 0, max: 1, ..F };
const I32_FULL: Field = Field { kind: Kind::I32, min: i32::MIN as i64, max: i32::MAX as i64, ..F };

/// One selector value (or a run of them) and what it means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct SelectorDef {
    pub lo: u8,
    pub hi: u8,
    pub key: &'static str,
    pub meaning: &'static str,
}

impl SelectorDef {
    pub const fn contains(&self, v: u8) -> bool {
        v >= self.lo && v <= self.hi
    }
}

const fn sel(value: u8, key: &'static str, meaning: &'static str) -> SelectorDef {
    SelectorDef { lo: value, hi: value, key, meaning }
}

/// Rows without a selector: data byte 3 is 0.
const NO_SELECTOR: &[SelectorDef] = &[sel(0, "none", "no selector, byte 3 is 0")];

/// What byte 3 of a reply holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ReplySelector {
    /// 0 (confirmations, and the 11h digital output state).
    Zero,
    /// A copy of the command's selector.
    Echo,
}

/// The normal answer of a command.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ReplyDef {
    pub code: u8,
    pub selector: ReplySelector,
    pub fields: &'static [Field],
}

/// Whether the normal answer can be switched off.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Confirm {
    /// A confirmation, not sent when the controller's 'Confirm' is 0.
    Suppressible,
    /// Always sent (reads, and 05h store configuration).
    Always,
}

/// Whom the command goes to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    Module,
    Controller,
}

/// One command layout: a code and the selectors sharing one set of fields.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CommandDef {
    pub key: &'static str,
    /// The manual's title.
    pub name: &'static str,
    pub code: u8,
    pub target: Target,
    pub selectors: &'static [SelectorDef],
    pub fields: &'static [Field],
    pub reply: ReplyDef,
    pub confirm: Confirm,
    /// Accepted only while the motor is not running (manual remark).
    pub motor_stopped: bool,
    pub description: &'static str,
}

impl CommandDef {
    pub fn selector(&self, v: u8) -> Option<&'static SelectorDef> {
        self.selectors.iter().find(|s| s.contains(v))
    }

    pub fn field(&self, key: &str) -> Option<&'static Field> {
        self.fields.iter().find(|f| f.key == key)
    }

    /// Fields the caller supplies (constants are filled in).
    pub fn value_fields(&self) -> impl Iterator<Item = &'static Field> {
        self.fields.iter().filter(|f| !matches!(f.kind, Kind::Const(_)))
    }
}

const fn ack(code: u8) -> ReplyDef {
    ReplyDef { code, selector: ReplySelector::Zero, fields: &[] }
}

const fn echo(code: u8, fields: &'static [Field]) -> ReplyDef {
    ReplyDef { code, selector: ReplySelector::Echo, fields }
}

const ROW: CommandDef = CommandDef {
    key: "",
    name: "",
    code: 0,
    target: Target::Module,
    selectors: NO_SELECTOR,
    fields: &[],
    reply: ack(0),
    confirm: Confirm::Suppressible,
    motor_stopped: false,
    description: "",
};

/// The unit of motor speeds and RPM errors (26h); positions are motor
/// counts, which the manual gives no unit.
pub const SPEED_UNIT: &str = "rpm";
/// The unit of positions: motor counts (the manual names none).
pub const POSITION_UNIT: &str = "counts";

// ---- Command codes ----

pub const IDENTIFY: u8 = 0x01;
pub const STORE_CONFIGURATION: u8 = 0x05;
pub const DIGITAL_OUTPUTS: u8 = 0x10;
/// Reply code of "Get digital outputs" (10h with selector 80h).
pub const DIGITAL_OUTPUTS_STATE: u8 = 0x11;
pub const ANALOG_OUTPUTS: u8 = 0x16;
/// The error code the manual prints for 16h (by the general rule an event).
pub const ANALOG_OUTPUTS_ERROR_AS_PRINTED: u8 = 0x56;
pub const SERVO_CONFIGURATION: u8 = 0x20;
pub const READ_POSITION: u8 = 0x21;
pub const SET_POSITION: u8 = 0x22;
pub const GOTO: u8 = 0x23;
pub const START: u8 = 0x24;
pub const STOP: u8 = 0x25;
pub const MOTOR_STATUS: u8 = 0x26;
pub const EVENT_MASK: u8 = 0x27;

/// `data` zero-padded to 8 bytes; `None` if empty or longer than 8.
pub fn padded(data: &[u8]) -> Option<[u8; 8]> {
    if data.is_empty() || data.len() > 8 {
        return None;
    }
    let mut out = [0u8; 8];
    out[..data.len()].copy_from_slice(data);
    Some(out)
}

/// What an answer from a node is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum AnswerKind {
    /// The command code repeated (11h for reading digital outputs).
    Reply,
    /// Code | 0x40, unsolicited.
    Event,
    /// Code | 0x80 (and 56h for 16h, as the manual prints it).
    Error,
}

/// Classifies an answer's code byte; returns the kind and the command code
/// it belongs to. Total: every byte has an answer.
pub const fn classify_code(code: u8) -> (AnswerKind, u8) {
    if code == ANALOG_OUTPUTS_ERROR_AS_PRINTED {
        (AnswerKind::Error, ANALOG_OUTPUTS)
    } else if code & 0x80 != 0 {
        (AnswerKind::Error, code & 0x7F)
    } else if code & 0x40 != 0 {
        (AnswerKind::Event, code & 0x3F)
    } else if code == DIGITAL_OUTPUTS_STATE {
        (AnswerKind::Reply, DIGITAL_OUTPUTS)
    } else {
        (AnswerKind::Reply, code)
    }
}

// ---- Fields ----

/// 05h: bytes 4..6 must be 43h 44h 53h ("CDS").
const STORE_KEY: &[Field] = &[
    Field { key: "key_c", name: "43h", offset: 3, kind: Kind::Const(0x43), min: 0x43, max: 0x43, ..F },
    Field { key: "key_d", name: "44h", offset: 4, kind: Kind::Const(0x44), min: 0x44, max: 0x44, ..F },
    Field { key: "key_s", name: "53h", offset: 5, kind: Kind::Const(0x53), min: 0x53, max: 0x53, ..F },
];

const OUTPUTS: &[Field] = &[Field {
    key: "outputs",
    name: "Data",
    max: 15,
    description: "bit 0 = output 1 .. bit 3 = output 4; 1 is on",
    ..F
}];

const OUTPUT_STATE: &[Field] =
    &[Field { key: "state", name: "State", max: 15, description: "bit 0 = output 1 .. bit 3 = output 4", ..F }];

// The manual maps -10000..10000 to -10.00..+10.00 V: one count is 1 mV.
const ANALOG_VALUE: &[Field] = &[Field {
    key: "value",
    name: "Data",
    kind: Kind::I16,
    unit: "mV",
    scale: Some(Scale { factor: 0.001, unit: "V" }),
    min: -10000,
    max: 10000,
    description: "analog output, -10.00 .. +10.00 V",
    ..F
}];

const SERVO_SPEEDS: &[Field] = &[
    Field {
        key: "minimum_speed",
        name: "Minimum Speed",
        kind: Kind::U16,
        unit: SPEED_UNIT,
        min: 1,
        max: 2500,
        default: Some(50),
        description: "RPM from encoder pulses and 'Pulses per revolution'",
        ..F
    },
    Field {
        key: "maximum_speed",
        name: "Maximum Speed",
        offset: 5,
        kind: Kind::U16,
        unit: SPEED_UNIT,
        min: 50,
        max: 32000,
        default: Some(8000),
        ..F
    },
    Field {
        key: "slope",
        name: "Slope",
        offset: 7,
        unit: "0.1 s",
        scale: Some(Scale { factor: 0.1, unit: "s" }),
        min: 1,
        max: 255,
        default: Some(10),
        description: "time from minimum to maximum speed (and back), 0.1 .. 25.5 s",
        ..F
    },
];

const SERVO_VOLTAGE: &[Field] = &[
    Field {
        key: "maximum_voltage",
        name: "Maximum Voltage",
        kind: Kind::U16,
        unit: "mV",
        scale: Some(Scale { factor: 0.001, unit: "V" }),
        min: 1000,
        max: 10000,
        default: Some(10000),
        description: "maximum absolute voltage of the motor regulating analog output",
        ..F
    },
    Field {
        key: "forward_end_switch",
        name: "Forward End Switch",
        offset: 5,
        default: Some(1),
        description: "1 = forward end switch checking enabled",
        ..BOOL
    },
    Field {
        key: "reverse_end_switch",
        name: "Reverse End Switch",
        offset: 6,
        default: Some(1),
        description: "1 = reverse end switch checking enabled",
        ..BOOL
    },
];

const SERVO_ENCODER: &[Field] = &[
    Field {
        key: "pulses_per_revolution",
        name: "Pulses Per Revolution",
        kind: Kind::U16,
        min: 1,
        max: 10000,
        default: Some(500),
        description: "encoder pulses per revolution, for the RPM",
        ..F
    },
    Field {
        key: "hold_on_enable",
        name: "Hold On Enable",
        offset: 5,
        default: Some(0),
        description: "1 = hold the motor at the setpoint after ENABLE or STOP",
        ..BOOL
    },
    Field {
        key: "auto_zero",
        name: "Auto Zero",
        offset: 6,
        default: Some(0),
        description: "1 = zero the position once when Zero and Index inputs are active",
        ..BOOL
    },
    Field {
        key: "slope_profile",
        name: "Slope Profile",
        offset: 7,
        default: Some(0),
        description: "0 = linear slope, 1 = sin2 slope",
        ..BOOL
    },
];

const SERVO_CONTROL: &[Field] = &[
    Field {
        key: "positioning_error",
        name: "Positioning Error",
        kind: Kind::U16,
        max: 10000,
        default: Some(25),
        description: "allowed positioning error around the setpoint",
        ..F
    },
    Field {
        key: "gain_factor",
        name: "Gain Factor",
        offset: 5,
        min: 1,
        default: Some(32),
        description: "RPM control loop gain",
        ..F
    },
    Field {
        key: "d_factor",
        name: "D Factor",
        offset: 6,
        default: Some(32),
        description: "RPM control loop derivative",
        ..F
    },
    Field {
        key: "failsafe",
        name: "Failsafe",
        offset: 7,
        max: 63,
        default: Some(0),
        description: "active-low inputs: bit 0 forward end switch, 1 reverse end switch, 2 emergency, 3 zero, \
                      4 ready, 5 error",
        ..F
    },
];

const SERVO_INPUTS: &[Field] = &[
    Field {
        key: "ready_input",
        name: "Ready Input",
        offset: 5,
        default: Some(1),
        description: "1 = the motor may not run while Ready is not active",
        ..BOOL
    },
    Field {
        key: "error_input",
        name: "Error Input",
        offset: 6,
        default: Some(1),
        description: "1 = the motor may not run while Error is active",
        ..BOOL
    },
];

const TRAJECT_END: &[Field] = &[
    Field {
        key: "end_position",
        name: "Relative end position",
        default: Some(0),
        description: "end position relative to the setpoint when GOTO TRAJECT is given",
        ..I32_FULL
    },
    Field {
        key: "length",
        name: "Length",
        offset: 7,
        max: 4,
        default: Some(0),
        description: "0 = not defined, 1 = end position and speed only, 2..4 = 1..3 speed changes",
        ..F
    },
];

const SPEED_32767: Field = Field { kind: Kind::U16, unit: SPEED_UNIT, max: 32767, default: Some(0), ..F };

const TRAJECT_INITIAL_SPEED: &[Field] = &[Field {
    key: "initial_speed",
    name: "Initial speed",
    description: "speed of the first part of the traject",
    ..SPEED_32767
}];

const TRAJECT_CHANGE_POSITION: &[Field] = &[Field {
    key: "change_position",
    name: "Relative speed change position",
    default: Some(0),
    description: "setpoint-relative position where the speed changes",
    ..I32_FULL
}];

const TRAJECT_SPEED: &[Field] =
    &[Field { key: "speed", name: "Speed", description: "speed of the next part of the traject", ..SPEED_32767 }];

const POSITION: &[Field] =
    &[Field { key: "position", name: "Motor position", description: "32-bit signed motor position", ..I32_FULL }];

const GOTO_POSITION: &[Field] = &[Field {
    key: "position",
    name: "Motor position or amount of steps",
    description: "absolute position, or relative steps (positive = forward)",
    ..I32_FULL
}];

const GOTO_TRAJECT: &[Field] = &[Field { key: "traject", name: "Traject", max: 1, description: "traject number", ..F }];

const GOTO_NEXT_SPEED: &[Field] = &[Field {
    key: "speed",
    name: "Next GOTO Speed",
    default: None,
    description: "maximum speed of the next GOTO, clamped to the configured speeds; 0 = maximum speed",
    ..SPEED_32767
}];

const GOTO_CHANGE_POSITION: &[Field] = &[Field {
    key: "position",
    name: "Next speed change absolute motor position",
    description: "absolute position where the running GOTO takes the next speed",
    ..I32_FULL
}];

const GOTO_CHANGE_SPEED: &[Field] = &[Field {
    key: "speed",
    name: "Change GOTO Speed",
    default: None,
    description: "new speed of the running GOTO, immediately",
    ..SPEED_32767
}];

const START_FIELDS: &[Field] = &[
    Field { key: "direction", name: "Direction", description: "0 = forward, 1 = reverse", ..BOOL },
    Field {
        key: "option",
        name: "Option",
        offset: 4,
        max: 6,
        description: "0 min speed, 1 accelerate to max, 2 until end switch, 3 to MotorSpeed, 4 until index, \
                      5 enable, 6 until index and zero",
        ..F
    },
    Field {
        key: "motor_speed",
        name: "MotorSpeed",
        offset: 5,
        kind: Kind::U16,
        unit: SPEED_UNIT,
        max: 30000,
        description: "target speed, used with option 3",
        ..F
    },
];

const STOP_FIELDS: &[Field] = &[Field {
    key: "option",
    name: "Option",
    max: 5,
    description: "0 decelerate to min speed, 1 decelerate and stop, 2 fast stop, 3 release emergency, \
                  4 clear hold, 5 disable",
    ..F
}];

const STATUS_BYTES: &[Field] = &[
    Field { key: "status1", name: "Status 1", description: "motion", ..F },
    Field { key: "status2", name: "Status 2", offset: 4, description: "end switches, emergency, stop causes", ..F },
    Field { key: "status3", name: "Status 3", offset: 5, description: "drive faults, enable", ..F },
    Field { key: "status4", name: "Status 4", offset: 6, description: "inputs, hold, traject", ..F },
];

const MOTOR_SPEED: Field = Field {
    key: "motor_speed",
    name: "MotorSpeed",
    kind: Kind::U16,
    unit: SPEED_UNIT,
    max: 30000,
    description: "actual motor speed (depends on Pulses Per Revolution)",
    ..F
};

const SPEED_ONLY: &[Field] = &[MOTOR_SPEED];

const SPEED_AND_ERROR: &[Field] = &[
    MOTOR_SPEED,
    Field {
        key: "rpm_error",
        name: "RPM_Error",
        offset: 5,
        kind: Kind::I16,
        unit: SPEED_UNIT,
        min: -30000,
        max: 30000,
        description: "actual minus desired speed; < 0 runs too slow",
        ..F
    },
];

const TIMER: Field = Field { kind: Kind::Bits { shift: 0, width: 3 }, offset: 7, max: 7, default: Some(0), ..F };

const EVENT_MASK_FIELDS: &[Field] = &[
    Field { key: "mask1", name: "Mask 1", default: Some(0), description: "status 1 bits that raise events", ..F },
    Field { key: "mask2", name: "Mask 2", offset: 4, default: Some(0), ..F },
    Field { key: "mask3", name: "Mask 3", offset: 5, default: Some(0), ..F },
    Field { key: "mask4", name: "Mask 4", offset: 6, default: Some(0), ..F },
    Field {
        key: "position_interval",
        name: "Timers bits 0-2",
        description: "'send current position' interval, see TIMER_INTERVALS_MS",
        ..TIMER
    },
    Field {
        key: "position_on_change",
        name: "Timers bit 3",
        kind: Kind::Bits { shift: 3, width: 1 },
        max: 1,
        description: "1 = send the position only when it changed",
        ..TIMER
    },
    Field {
        key: "speed_interval",
        name: "Timers bits 4-6",
        kind: Kind::Bits { shift: 4, width: 3 },
        description: "'send MotorSpeed/RPM Error' interval, see TIMER_INTERVALS_MS",
        ..TIMER
    },
    Field {
        key: "speed_on_change",
        name: "Timers bit 7",
        kind: Kind::Bits { shift: 7, width: 1 },
        max: 1,
        description: "1 = send MotorSpeed/RPM Error only when changed",
        ..TIMER
    },
];

/// The timer interval codes 0..7 of 27h; 0 = never sent.
pub const TIMER_INTERVALS_MS: [f64; 8] = [0.0, 3.9, 7.8, 15.6, 31.25, 62.5, 125.0, 250.0];

// The controller page shows selectors 0..7 as type / version pairs of modules
// 2s and 2s+1; the layout of selectors 8..24 (serial numbers) is not in our
// specs, so those bytes stay raw.
const IDENTIFY_TYPES: &[Field] = &[
    Field { key: "first_type", name: "type 2s", description: "module type of module 2 * selector", ..F },
    Field { key: "first_version", name: "version 2s", offset: 4, ..F },
    Field {
        key: "second_type",
        name: "type 2s+1",
        offset: 5,
        description: "module type of module 2 * selector + 1",
        ..F
    },
    Field { key: "second_version", name: "version 2s+1", offset: 6, ..F },
];

const IDENTIFY_RAW: &[Field] = &[
    Field { key: "byte4", name: "byte 4", ..F },
    Field { key: "byte5", name: "byte 5", offset: 4, ..F },
    Field { key: "byte6", name: "byte 6", offset: 5, ..F },
    Field { key: "byte7", name: "byte 7", offset: 6, ..F },
    Field { key: "byte8", name: "byte 8", offset: 7, ..F },
];

// ---- Selectors ----

const DIRECT_OR_SYNC: &[SelectorDef] = &[
    sel(0, "direct", "executed directly"),
    sel(1, "sync", "latched, executed after a SYNC (CAN SYNC or the controller's SYNC command)"),
];

const SERVO_TRAJECT_END: &[SelectorDef] =
    &[sel(0x10, "traject0_end", "traject 0 end position"), sel(0x20, "traject1_end", "traject 1 end position")];
const SERVO_TRAJECT_INITIAL: &[SelectorDef] = &[
    sel(0x11, "traject0_initial_speed", "traject 0 initial speed"),
    sel(0x21, "traject1_initial_speed", "traject 1 initial speed"),
];
const SERVO_TRAJECT_CHANGE: &[SelectorDef] = &[
    sel(0x12, "traject0_change_position1", "traject 0 speed change position 1"),
    sel(0x14, "traject0_change_position2", "traject 0 speed change position 2"),
    sel(0x16, "traject0_change_position3", "traject 0 speed change position 3"),
    sel(0x22, "traject1_change_position1", "traject 1 speed change position 1"),
    sel(0x24, "traject1_change_position2", "traject 1 speed change position 2"),
    sel(0x26, "traject1_change_position3", "traject 1 speed change position 3"),
];
const SERVO_TRAJECT_SPEED: &[SelectorDef] = &[
    sel(0x13, "traject0_speed1", "traject 0 speed 1"),
    sel(0x15, "traject0_speed2", "traject 0 speed 2"),
    sel(0x17, "traject0_speed3", "traject 0 speed 3"),
    sel(0x23, "traject1_speed1", "traject 1 speed 1"),
    sel(0x25, "traject1_speed2", "traject 1 speed 2"),
    sel(0x27, "traject1_speed3", "traject 1 speed 3"),
];
const READ_TRAJECT_END: &[SelectorDef] =
    &[sel(0x90, "traject0_end", "traject 0 end position"), sel(0xA0, "traject1_end", "traject 1 end position")];
const READ_TRAJECT_INITIAL: &[SelectorDef] = &[
    sel(0x91, "traject0_initial_speed", "traject 0 initial speed"),
    sel(0xA1, "traject1_initial_speed", "traject 1 initial speed"),
];
const READ_TRAJECT_CHANGE: &[SelectorDef] = &[
    sel(0x92, "traject0_change_position1", "traject 0 speed change position 1"),
    sel(0x94, "traject0_change_position2", "traject 0 speed change position 2"),
    sel(0x96, "traject0_change_position3", "traject 0 speed change position 3"),
    sel(0xA2, "traject1_change_position1", "traject 1 speed change position 1"),
    sel(0xA4, "traject1_change_position2", "traject 1 speed change position 2"),
    sel(0xA6, "traject1_change_position3", "traject 1 speed change position 3"),
];
const READ_TRAJECT_SPEED: &[SelectorDef] = &[
    sel(0x93, "traject0_speed1", "traject 0 speed 1"),
    sel(0x95, "traject0_speed2", "traject 0 speed 2"),
    sel(0x97, "traject0_speed3", "traject 0 speed 3"),
    sel(0xA3, "traject1_speed1", "traject 1 speed 1"),
    sel(0xA5, "traject1_speed2", "traject 1 speed 2"),
    sel(0xA7, "traject1_speed3", "traject 1 speed 3"),
];

const SET_SERVO: CommandDef = CommandDef {
    name: "Set Analog Servo motor configuration",
    code: SERVO_CONFIGURATION,
    motor_stopped: true,
    reply: ack(SERVO_CONFIGURATION),
    ..ROW
};
const READ_SERVO: CommandDef = CommandDef {
    name: "Read Analog Servo motor configuration",
    code: SERVO_CONFIGURATION,
    confirm: Confirm::Always,
    ..ROW
};

/// Every command layout of the manual, plus the controller's 01h.
pub const COMMANDS: &[CommandDef] = &[
    CommandDef {
        key: "identify",
        name: "Identify I/O modules",
        code: IDENTIFY,
        target: Target::Controller,
        selectors: &[SelectorDef {
            lo: 0,
            hi: 7,
            key: "types",
            meaning: "module types and versions of modules 2s and 2s+1",
        }],
        reply: echo(IDENTIFY, IDENTIFY_TYPES),
        confirm: Confirm::Always,
        description: "controller table of module types, versions and serial numbers",
        ..ROW
    },
    CommandDef {
        key: "identify_table",
        name: "Identify I/O modules",
        code: IDENTIFY,
        target: Target::Controller,
        selectors: &[SelectorDef { lo: 8, hi: 24, key: "table", meaning: "rest of the table (serial numbers)" }],
        reply: echo(IDENTIFY, IDENTIFY_RAW),
        confirm: Confirm::Always,
        description: "controller table of module types, versions and serial numbers",
        ..ROW
    },
    CommandDef {
        key: "store_configuration",
        name: "Store configuration",
        code: STORE_CONFIGURATION,
        selectors: &[
            sel(0, "current", "store the current configuration"),
            sel(1, "default", "change the configuration into the default and store it"),
        ],
        fields: STORE_KEY,
        reply: ack(STORE_CONFIGURATION),
        confirm: Confirm::Always,
        description: "store the configuration in EEPROM (260..750 ms; the motor must be disabled)",
        ..ROW
    },
    CommandDef {
        key: "set_digital_outputs",
        name: "Set digital outputs",
        code: DIGITAL_OUTPUTS,
        selectors: &[
            sel(0, "direct", "write outputs direct"),
            sel(1, "latched", "write outputs latched, updated after SYNC"),
        ],
        fields: OUTPUTS,
        reply: ack(DIGITAL_OUTPUTS),
        description: "set the 4 digital outputs",
        ..ROW
    },
    CommandDef {
        key: "get_digital_outputs",
        name: "Get digital outputs",
        code: DIGITAL_OUTPUTS,
        selectors: &[sel(0x80, "read", "read the output state")],
        reply: ReplyDef { code: DIGITAL_OUTPUTS_STATE, selector: ReplySelector::Zero, fields: OUTPUT_STATE },
        confirm: Confirm::Always,
        description: "read the current output state (answered with code 11h)",
        ..ROW
    },
    CommandDef {
        key: "set_analog_output",
        name: "Set analog outputs",
        code: ANALOG_OUTPUTS,
        selectors: &[
            sel(0x00, "output1", "write analog output #1 direct"),
            sel(0x01, "output1_latched", "write analog output #1 latched, updated after SYNC"),
            sel(0x10, "output2", "write analog output #2 direct"),
            sel(0x11, "output2_latched", "write analog output #2 latched, updated after SYNC"),
        ],
        fields: ANALOG_VALUE,
        reply: ack(ANALOG_OUTPUTS),
        description: "set an analog output (#1 only while the motor is not enabled)",
        ..ROW
    },
    CommandDef {
        key: "read_analog_output",
        name: "Read analog outputs",
        code: ANALOG_OUTPUTS,
        selectors: &[sel(0x80, "output1", "read output #1"), sel(0x90, "output2", "read output #2")],
        reply: echo(ANALOG_OUTPUTS, ANALOG_VALUE),
        confirm: Confirm::Always,
        description: "read the value of one of the 2 analog outputs",
        ..ROW
    },
    CommandDef {
        key: "set_servo_speeds",
        selectors: &[sel(0, "speeds", "minimum / maximum speed, slope")],
        fields: SERVO_SPEEDS,
        ..SET_SERVO
    },
    CommandDef {
        key: "set_servo_voltage",
        selectors: &[sel(1, "voltage", "maximum voltage, end switch checking")],
        fields: SERVO_VOLTAGE,
        ..SET_SERVO
    },
    CommandDef {
        key: "set_servo_encoder",
        selectors: &[sel(2, "encoder", "pulses per revolution, hold on enable, auto zero, slope profile")],
        fields: SERVO_ENCODER,
        ..SET_SERVO
    },
    CommandDef {
        key: "set_servo_control",
        selectors: &[sel(3, "control", "positioning error, gain, D factor, failsafe")],
        fields: SERVO_CONTROL,
        ..SET_SERVO
    },
    CommandDef {
        key: "set_servo_inputs",
        selectors: &[sel(4, "inputs", "ready / error input checking")],
        fields: SERVO_INPUTS,
        ..SET_SERVO
    },
    CommandDef { key: "set_traject_end", selectors: SERVO_TRAJECT_END, fields: TRAJECT_END, ..SET_SERVO },
    CommandDef {
        key: "set_traject_initial_speed",
        selectors: SERVO_TRAJECT_INITIAL,
        fields: TRAJECT_INITIAL_SPEED,
        ..SET_SERVO
    },
    CommandDef {
        key: "set_traject_change_position",
        selectors: SERVO_TRAJECT_CHANGE,
        fields: TRAJECT_CHANGE_POSITION,
        ..SET_SERVO
    },
    CommandDef { key: "set_traject_speed", selectors: SERVO_TRAJECT_SPEED, fields: TRAJECT_SPEED, ..SET_SERVO },
    CommandDef {
        key: "read_servo_speeds",
        selectors: &[sel(0x80, "speeds", "minimum / maximum speed, slope")],
        reply: echo(SERVO_CONFIGURATION, SERVO_SPEEDS),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_servo_voltage",
        selectors: &[sel(0x81, "voltage", "maximum voltage, end switch checking")],
        reply: echo(SERVO_CONFIGURATION, SERVO_VOLTAGE),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_servo_encoder",
        selectors: &[sel(0x82, "encoder", "pulses per revolution, hold on enable, auto zero, slope profile")],
        reply: echo(SERVO_CONFIGURATION, SERVO_ENCODER),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_servo_control",
        selectors: &[sel(0x83, "control", "positioning error, gain, D factor, failsafe")],
        reply: echo(SERVO_CONFIGURATION, SERVO_CONTROL),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_servo_inputs",
        selectors: &[sel(0x84, "inputs", "ready / error input checking")],
        reply: echo(SERVO_CONFIGURATION, SERVO_INPUTS),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_traject_end",
        selectors: READ_TRAJECT_END,
        reply: echo(SERVO_CONFIGURATION, TRAJECT_END),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_traject_initial_speed",
        selectors: READ_TRAJECT_INITIAL,
        reply: echo(SERVO_CONFIGURATION, TRAJECT_INITIAL_SPEED),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_traject_change_position",
        selectors: READ_TRAJECT_CHANGE,
        reply: echo(SERVO_CONFIGURATION, TRAJECT_CHANGE_POSITION),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_traject_speed",
        selectors: READ_TRAJECT_SPEED,
        reply: echo(SERVO_CONFIGURATION, TRAJECT_SPEED),
        ..READ_SERVO
    },
    CommandDef {
        key: "read_position",
        name: "Read current position",
        code: READ_POSITION,
        selectors: &[
            sel(0, "current", "current motor position"),
            sel(1, "latched", "motor position latched by the latest SYNC"),
            sel(2, "setpoint", "current setpoint (latest GOTO position / traject end)"),
        ],
        reply: echo(READ_POSITION, POSITION),
        confirm: Confirm::Always,
        description: "read the 32-bit motor position",
        ..ROW
    },
    CommandDef {
        key: "set_position",
        name: "Set position",
        code: SET_POSITION,
        fields: POSITION,
        reply: ack(SET_POSITION),
        motor_stopped: true,
        description: "set the motor position and the setpoint",
        ..ROW
    },
    CommandDef {
        key: "goto",
        name: "Goto position",
        code: GOTO,
        selectors: &[
            sel(0, "absolute", "move absolute to the position"),
            sel(1, "absolute_sync", "latch the absolute position, move after SYNC"),
            sel(2, "relative", "move relative to the current position"),
            sel(3, "relative_sync", "latch the relative position, move after SYNC"),
            sel(4, "setpoint_relative", "move relative to the current setpoint"),
            sel(5, "setpoint_relative_sync", "latch the setpoint relative position, move after SYNC"),
        ],
        fields: GOTO_POSITION,
        reply: ack(GOTO),
        motor_stopped: true,
        description: "move to a position",
        ..ROW
    },
    CommandDef {
        key: "goto_traject",
        name: "Goto position",
        code: GOTO,
        selectors: &[sel(6, "traject", "start traject 0/1"), sel(7, "traject_sync", "start traject 0/1 after SYNC")],
        fields: GOTO_TRAJECT,
        reply: ack(GOTO),
        motor_stopped: true,
        description: "start a traject",
        ..ROW
    },
    CommandDef {
        key: "goto_next_speed",
        name: "Goto position",
        code: GOTO,
        selectors: &[sel(8, "next_speed", "maximum speed of the next GOTO")],
        fields: GOTO_NEXT_SPEED,
        reply: ack(GOTO),
        description: "set the speed of the next GOTO",
        ..ROW
    },
    CommandDef {
        key: "goto_speed_change_position",
        name: "Goto position",
        code: GOTO,
        selectors: &[sel(9, "speed_change_position", "absolute position to change the speed of the running GOTO")],
        fields: GOTO_CHANGE_POSITION,
        reply: ack(GOTO),
        description: "only while an interruptable GOTO runs and no traject",
        ..ROW
    },
    CommandDef {
        key: "goto_change_speed",
        name: "Goto position",
        code: GOTO,
        selectors: &[sel(10, "change_speed", "change the speed of the running GOTO now")],
        fields: GOTO_CHANGE_SPEED,
        reply: ack(GOTO),
        description: "only while an interruptable GOTO runs and no traject",
        ..ROW
    },
    CommandDef {
        key: "start",
        name: "Start",
        code: START,
        selectors: DIRECT_OR_SYNC,
        fields: START_FIELDS,
        reply: ack(START),
        motor_stopped: true,
        description: "manual motion: run, enable, search end switch or index",
        ..ROW
    },
    CommandDef {
        key: "stop",
        name: "Stop",
        code: STOP,
        selectors: DIRECT_OR_SYNC,
        fields: STOP_FIELDS,
        reply: ack(STOP),
        description: "manual motion: decelerate, stop, release emergency, clear hold, disable",
        ..ROW
    },
    CommandDef {
        key: "read_status",
        name: "Read motor status",
        code: MOTOR_STATUS,
        selectors: &[sel(0, "status", "status bytes 1..4")],
        reply: echo(MOTOR_STATUS, STATUS_BYTES),
        confirm: Confirm::Always,
        description: "read the four motor status bytes",
        ..ROW
    },
    CommandDef {
        key: "read_speed",
        name: "Read motor status",
        code: MOTOR_STATUS,
        selectors: &[sel(1, "speed", "motor speed")],
        reply: echo(MOTOR_STATUS, SPEED_ONLY),
        confirm: Confirm::Always,
        description: "read the actual motor speed",
        ..ROW
    },
    CommandDef {
        key: "read_speed_error",
        name: "Read motor status",
        code: MOTOR_STATUS,
        selectors: &[sel(2, "speed_error", "motor speed and RPM error")],
        reply: echo(MOTOR_STATUS, SPEED_AND_ERROR),
        confirm: Confirm::Always,
        description: "read the actual motor speed and the speed error",
        ..ROW
    },
    CommandDef {
        key: "set_event_mask",
        name: "Set event on motor status change mask",
        code: EVENT_MASK,
        fields: EVENT_MASK_FIELDS,
        reply: ack(EVENT_MASK),
        description: "status bits that raise events; position and speed timers",
        ..ROW
    },
    CommandDef {
        key: "read_event_mask",
        name: "Read event on motor status change mask",
        code: EVENT_MASK,
        selectors: &[sel(0x80, "read", "read the masks and timers")],
        reply: echo(EVENT_MASK, EVENT_MASK_FIELDS),
        confirm: Confirm::Always,
        description: "read back the event masks and timers",
        ..ROW
    },
];

/// The row by key, e.g. `"goto"`.
pub fn command(key: &str) -> Option<&'static CommandDef> {
    COMMANDS.iter().find(|c| c.key == key)
}

/// The row that a command with `code` and `selector` uses.
pub fn command_for(code: u8, selector: u8) -> Option<&'static CommandDef> {
    COMMANDS.iter().find(|c| c.code == code && c.selector(selector).is_some())
}

// ---- Flags: motor status bytes and command error bits ----

/// Error flags are faults or stop causes; info flags describe state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Class {
    Error,
    Info,
}

impl Class {
    /// The name in JSON and on screen (the serde name).
    pub const fn name(self) -> &'static str {
        match self {
            Self::Error => "error",
            Self::Info => "info",
        }
    }
}

/// One bit of a status or error status byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct Flag {
    /// Which byte: status 1..4, or error status 1..2.
    pub byte: u8,
    pub bit: u8,
    pub name: &'static str,
    pub meaning: &'static str,
    pub class: Class,
}

impl Flag {
    pub const fn is_set(&self, bytes: &[u8]) -> bool {
        let i = self.byte as usize;
        i >= 1 && i <= bytes.len() && bytes[i - 1] & (1 << self.bit) != 0
    }
}

const fn flag(byte: u8, bit: u8, name: &'static str, class: Class, meaning: &'static str) -> Flag {
    Flag { byte, bit, name, meaning, class }
}

use Class::{Error as E, Info as I};

/// The motor status bytes of 26h (selector 0); bits not listed are reserved.
pub const STATUS_FLAGS: &[Flag] = &[
    flag(1, 0, "RUNNING_FORWARD", I, "motor is running forward"),
    flag(1, 1, "RUNNING_REVERSE", I, "motor is running reverse"),
    flag(1, 2, "RUNNING_TO_END_SWITCH", I, "motor is running until end switch found"),
    flag(1, 3, "AT_MINIMUM_SPEED", I, "motor is running at minimum speed"),
    flag(1, 4, "AT_MAXIMUM_SPEED", I, "motor is running at maximum speed"),
    flag(1, 5, "ACCELERATING", I, "motor is accelerating"),
    flag(1, 6, "DECELERATING", I, "motor is decelerating"),
    flag(1, 7, "GOTO_ACTIVE", I, "goto command is being executed"),
    flag(2, 0, "FORWARD_END_SWITCH_ACTIVE", I, "forward end switch active"),
    flag(2, 1, "REVERSE_END_SWITCH_ACTIVE", I, "reverse end switch active"),
    flag(2, 2, "EMERGENCY_INPUT_ACTIVE", E, "emergency stop input is active"),
    flag(2, 3, "STOPPED_BY_FORWARD_END_SWITCH", E, "stopped by an active, enabled forward end switch (start clears)"),
    flag(2, 4, "STOPPED_BY_REVERSE_END_SWITCH", E, "stopped by an active, enabled reverse end switch (start clears)"),
    flag(
        2,
        5,
        "EMERGENCY_STOP",
        E,
        "stopped by emergency stop, power failure or watchdog time-out; motor disabled \
         (clear: stop option 3, then start option 5)",
    ),
    flag(2, 6, "WATCHDOG_TIMEOUT", E, "stopped by the 0.5 s watchdog time-out (sets EMERGENCY_STOP)"),
    flag(2, 7, "STOPPED_BY_ERROR_OR_READY", E, "stopped by active Error or inactive Ready input (sets EMERGENCY_STOP)"),
    flag(3, 0, "POSITION_ZEROED", I, "position set to zero by I input or Z and I inputs (cleared by reading)"),
    flag(3, 2, "MOTOR_DOES_NOT_RUN", E, "motor does not run; emergency stop (clear: start option 5)"),
    flag(3, 4, "WRONG_DIRECTION", E, "motor runs in opposite direction, swap + and -; emergency stop"),
    flag(3, 5, "ENCODER_FREQUENCY_TOO_HIGH", E, "encoder input frequency too high, pulses may be missed"),
    flag(3, 6, "VOLTAGE_LIMITING", I, "motor voltage limiting is active (output = maximum voltage)"),
    flag(3, 7, "ENABLED", I, "motor is enabled"),
    flag(4, 0, "Z_INPUT_ACTIVE", I, "Z input active"),
    flag(4, 2, "HOLD_ACTIVE", I, "controller keeps the motor at the setpoint"),
    flag(4, 3, "TRAJECT_RUNNING", I, "a traject is running"),
    flag(4, 4, "READY_INPUT_ACTIVE", I, "Ready input active"),
    flag(4, 5, "ERROR_INPUT_ACTIVE", E, "Error input active"),
    flag(
        4,
        7,
        "POSITION_NOT_INITIALIZED",
        I,
        "position not initialized since reset (set position, auto zero or start option 2/4/6 clears)",
    ),
];

/// The command-specific error bits of one command code (error status 1 / 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ErrorBits {
    pub code: u8,
    pub bits: &'static [Flag],
}

const SELECTOR_BIT0: Flag = flag(1, 0, "SELECTOR_OUT_OF_RANGE", E, "selector parameter out of range");
const MOTOR_RUNNING: Flag = flag(1, 0, "MOTOR_RUNNING", E, "motor is running");
const EMERGENCY: Flag =
    flag(1, 1, "EMERGENCY", E, "emergency stop, watchdog status active, error input active or ready not active");

/// Error status bits per command, manual "Possible error message" tables.
/// Set and read variants of a code share one table (the bits agree).
pub const ERROR_BITS: &[ErrorBits] = &[
    ErrorBits {
        code: DIGITAL_OUTPUTS,
        bits: &[SELECTOR_BIT0, flag(1, 1, "DATA_OUT_OF_RANGE", E, "data parameter out of range")],
    },
    ErrorBits {
        code: ANALOG_OUTPUTS,
        bits: &[
            SELECTOR_BIT0,
            flag(1, 1, "VALUE_OUT_OF_RANGE", E, "analog value out of range"),
            flag(1, 7, "MOTOR_ENABLED", E, "motor is enabled, analog output #1 cannot be modified"),
        ],
    },
    ErrorBits {
        code: SERVO_CONFIGURATION,
        bits: &[
            MOTOR_RUNNING,
            flag(1, 1, "SELECTOR_OUT_OF_RANGE", E, "selector parameter out of range"),
            flag(1, 2, "MINIMUM_SPEED_OUT_OF_RANGE", E, "minimum speed parameter out of range"),
            flag(1, 3, "MAXIMUM_SPEED_OUT_OF_RANGE", E, "maximum speed parameter out of range"),
            flag(1, 4, "SLOPE_OUT_OF_RANGE", E, "slope parameter out of range"),
            flag(1, 5, "PULSES_PER_REVOLUTION_OUT_OF_RANGE", E, "pulses per revolution parameter out of range"),
            // The manual prints two meanings per bit: selector 2 or selector 4.
            flag(1, 6, "HOLD_ON_ENABLE_OR_READY_OUT_OF_RANGE", E, "hold on enable (or ready) parameter out of range"),
            flag(1, 7, "AUTOZERO_OR_ERROR_OUT_OF_RANGE", E, "autozero (or error) parameter out of range"),
            flag(2, 0, "MAXIMUM_VOLTAGE_OUT_OF_RANGE", E, "maximum voltage parameter out of range"),
            flag(2, 1, "SLOPE_PROFILE_OUT_OF_RANGE", E, "slope profile parameter out of range"),
            flag(2, 2, "FORWARD_END_SWITCH_OUT_OF_RANGE", E, "forward end switch parameter out of range"),
            flag(2, 3, "REVERSE_END_SWITCH_OUT_OF_RANGE", E, "reverse end switch parameter out of range"),
            flag(2, 4, "POSITIONING_ERROR_OUT_OF_RANGE", E, "positioning error parameter out of range"),
            flag(2, 5, "GAIN_FACTOR_OUT_OF_RANGE", E, "gain factor parameter out of range"),
            flag(2, 6, "FAILSAFE_OUT_OF_RANGE", E, "failsafe parameter out of range"),
            flag(2, 7, "TRAJECT_OUT_OF_RANGE", E, "traject configuration parameter out of range (length or speed)"),
        ],
    },
    ErrorBits { code: READ_POSITION, bits: &[SELECTOR_BIT0] },
    ErrorBits { code: SET_POSITION, bits: &[MOTOR_RUNNING] },
    ErrorBits {
        code: GOTO,
        bits: &[
            MOTOR_RUNNING,
            EMERGENCY,
            flag(1, 2, "SELECTOR_OUT_OF_RANGE", E, "selector parameter out of range"),
            flag(1, 3, "TRAJECT_OUT_OF_RANGE", E, "traject parameter out of range"),
            flag(1, 4, "SPEED_OUT_OF_RANGE", E, "speed parameter out of range"),
            flag(1, 5, "NO_GOTO_RUNNING", E, "no GOTO running"),
            flag(1, 6, "TRAJECT_NEEDS_LINEAR_SLOPE", E, "traject cannot start, slope profile = 1"),
            flag(1, 7, "MOTOR_NOT_ENABLED", E, "motor is not enabled"),
        ],
    },
    ErrorBits {
        code: START,
        bits: &[
            MOTOR_RUNNING,
            EMERGENCY,
            flag(1, 2, "RUNNING_OPPOSITE_DIRECTION", E, "motor is running in opposite direction"),
            flag(1, 3, "SELECTOR_OUT_OF_RANGE", E, "selector parameter out of range"),
            flag(1, 4, "DIRECTION_OUT_OF_RANGE", E, "direction parameter out of range"),
            flag(1, 5, "OPTION_OUT_OF_RANGE", E, "option parameter out of range"),
            flag(1, 6, "END_SWITCH_ACTIVE", E, "end switch active, cannot start"),
            flag(1, 7, "MOTOR_SPEED_OUT_OF_RANGE", E, "MotorSpeed parameter out of range (option 3)"),
            flag(2, 7, "MOTOR_NOT_ENABLED", E, "motor is not enabled"),
        ],
    },
    ErrorBits {
        code: STOP,
        bits: &[
            flag(1, 0, "MOTOR_RUNNING", E, "motor is running (option 4)"),
            flag(1, 1, "EMERGENCY", E, "emergency stop or power failure status active"),
            flag(1, 2, "MOTOR_NOT_RUNNING", E, "motor is not running (option 0, 1 or 2)"),
            flag(1, 3, "SELECTOR_OUT_OF_RANGE", E, "selector parameter out of range"),
            flag(1, 4, "OPTION_OUT_OF_RANGE", E, "option parameter out of range"),
            flag(1, 7, "MOTOR_NOT_ENABLED", E, "motor is not enabled"),
        ],
    },
    ErrorBits { code: EVENT_MASK, bits: &[SELECTOR_BIT0] },
];

/// The error bit table of a command code; empty where the manual gives none.
pub fn error_bits(code: u8) -> &'static [Flag] {
    ERROR_BITS.iter().find(|e| e.code == code).map_or(&[], |e| e.bits)
}

/// General error codes (byte 4 of an error reply), from the controller documentation.
pub const GENERAL_ERRORS: &[(u8, &str, &str)] = &[
    (0, "COMMAND_STATUS", "see the command's error status bits"),
    (1, "NO_MODULE", "no module at that module id"),
    (2, "UNSUPPORTED_MODULE", "module id is connected to an unsupported module"),
    (3, "UNKNOWN_COMMAND", "command is unknown in the addressed module"),
    (4, "INITIALISING", "Cdios system still initialising (500 ms after power-up or reset)"),
    (5, "UNSUPPORTED_VERSION", "addressed module has an unsupported version"),
    (6, "NOT_SUPPORTED", "command not supported by this firmware version of the module"),
    (7, "IO_COMMUNICATION", "I/O module communication error"),
    (8, "EEPROM_BUSY", "controller busy programming EEPROM, cannot evaluate the command"),
];

/// `(name, text)` of a general error code.
pub fn general_error(code: u8) -> Option<(&'static str, &'static str)> {
    GENERAL_ERRORS.iter().find(|(c, ..)| *c == code).map(|(_, n, t)| (*n, *t))
}

/// The four motor status bytes, decoded.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct StatusReport {
    pub status: [u8; 4],
    /// Every set flag, in table order.
    pub flags: Vec<&'static str>,
    /// The set flags of class error.
    pub errors: Vec<&'static str>,
    /// Set bits the manual marks reserved, as `(status byte 1..4, bit)`.
    pub reserved: Vec<(u8, u8)>,
}

pub fn decode_status(status: [u8; 4]) -> StatusReport {
    let set: Vec<&Flag> = STATUS_FLAGS.iter().filter(|f| f.is_set(&status)).collect();
    let mut reserved = Vec::new();
    for (i, b) in status.iter().enumerate() {
        let byte = i as u8 + 1;
        for bit in 0..8u8 {
            let known = STATUS_FLAGS.iter().any(|f| f.byte == byte && f.bit == bit);
            if b & (1 << bit) != 0 && !known {
                reserved.push((byte, bit));
            }
        }
    }
    StatusReport {
        status,
        flags: set.iter().map(|f| f.name).collect(),
        errors: set.iter().filter(|f| f.class == Class::Error).map(|f| f.name).collect(),
        reserved,
    }
}

// ---- Generic encoder / decoder ----

/// A field with the value found in (or written to) a message.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FieldValue {
    pub key: &'static str,
    pub name: &'static str,
    pub raw: i64,
    #[serde(skip_serializing_if = "str::is_empty")]
    pub unit: &'static str,
    /// `raw * factor` in the scale's unit, where the table has a scale.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub value_unit: Option<&'static str>,
    /// Inside the manual's range.
    pub in_range: bool,
}

impl FieldValue {
    pub fn new(field: &'static Field, raw: i64) -> Self {
        Self {
            key: field.key,
            name: field.name,
            raw,
            unit: field.unit,
            value: field.scale.map(|s| raw as f64 * s.factor),
            value_unit: field.scale.map(|s| s.unit),
            in_range: field.in_range(raw),
        }
    }
}

/// Reads every field of `fields` from `data`; never fails.
pub fn read_fields(fields: &'static [Field], data: &[u8; 8]) -> Vec<FieldValue> {
    fields.iter().map(|f| FieldValue::new(f, f.read(data))).collect()
}

/// Looks a value up by key.
pub fn value_of(values: &[FieldValue], key: &str) -> Option<i64> {
    values.iter().find(|v| v.key == key).map(|v| v.raw)
}

fn write_fields(
    command: &'static str,
    fields: &'static [Field],
    data: &mut [u8; 8],
    values: &[(&str, i64)],
) -> Result<(), ValidationError> {
    for (key, _) in values {
        if !fields.iter().any(|f| f.key == *key && !matches!(f.kind, Kind::Const(_))) {
            return Err(ValidationError::UnknownField { command, field: (*key).to_string() });
        }
    }
    for f in fields {
        let v = match f.kind {
            Kind::Const(c) => c.into(),
            _ => values
                .iter()
                .find(|(k, _)| *k == f.key)
                .map(|(_, v)| *v)
                .ok_or(ValidationError::MissingField { command, field: f.key })?,
        };
        f.check(v)?;
        let (lo, hi) = f.kind.raw_range();
        if !(lo..=hi).contains(&v) {
            return Err(ValidationError::OutOfRange { field: f.key, value: v, min: lo, max: hi });
        }
        f.kind.write(f.offset as usize, data, v);
    }
    Ok(())
}

/// The 8 data bytes of a command: `[code, address, selector, fields...]`,
/// after checking address, selector and every field against the manual.
pub fn encode(
    def: &'static CommandDef,
    address: Address,
    selector: u8,
    values: &[(&str, i64)],
) -> Result<[u8; 8], ValidationError> {
    match (def.target, address) {
        (Target::Module, Address::Module(_)) | (Target::Controller, Address::Controller) => {}
        (Target::Module, Address::Controller) => {
            return Err(ValidationError::Address { command: def.key, expected: "a module 0 to 15" })
        }
        (Target::Controller, Address::Module(_)) => {
            return Err(ValidationError::Address { command: def.key, expected: "the controller (0xFF)" })
        }
    }
    if def.selector(selector).is_none() {
        return Err(ValidationError::Selector { command: def.key, selector });
    }
    let mut data = [def.code, address.to_byte(), selector, 0, 0, 0, 0, 0];
    write_fields(def.key, def.fields, &mut data, values)?;
    Ok(data)
}

/// A command read back from its data bytes (what a module receives).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DecodedCommand {
    pub def: &'static CommandDef,
    pub address: Address,
    pub selector: u8,
    pub fields: Vec<FieldValue>,
}

impl DecodedCommand {
    pub fn get(&self, key: &str) -> Option<i64> {
        value_of(&self.fields, key)
    }

    /// The address and the first field outside the manual's range, as the
    /// module would reject them.
    pub fn validate(&self) -> Result<(), ValidationError> {
        match (self.def.target, self.address) {
            (Target::Module, Address::Controller) => {
                return Err(ValidationError::Address { command: self.def.key, expected: "a module 0 to 15" })
            }
            (Target::Controller, Address::Module(_)) => {
                return Err(ValidationError::Address { command: self.def.key, expected: "the controller (0xFF)" })
            }
            _ => {}
        }
        for (v, f) in self.fields.iter().zip(self.def.fields) {
            f.check(v.raw)?;
        }
        Ok(())
    }
}

/// Finds the row of a command; fields are read but not range-checked
/// ([`DecodedCommand::validate`] does that).
pub fn decode_command(data: &[u8]) -> Result<DecodedCommand, ValidationError> {
    let data = padded(data).ok_or(ValidationError::Empty)?;
    let (code, selector) = (data[0], data[2]);
    if !COMMANDS.iter().any(|c| c.code == code) {
        return Err(ValidationError::UnknownCode(code));
    }
    let def = command_for(code, selector).ok_or_else(|| {
        let any = COMMANDS.iter().find(|c| c.code == code).map_or("command", |c| c.key);
        ValidationError::Selector { command: any, selector }
    })?;
    Ok(DecodedCommand { def, address: Address::from_byte(data[1]), selector, fields: read_fields(def.fields, &data) })
}

/// A reply or event read from its data bytes.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DecodedReply {
    /// The row it answers; `None` when no row matches (the raw bytes still
    /// travel with the answer).
    #[serde(serialize_with = "ser_def_key")]
    pub def: Option<&'static CommandDef>,
    pub code: u8,
    pub module: u8,
    pub selector: u8,
    pub fields: Vec<FieldValue>,
}

fn ser_def_key<S: serde::Serializer>(d: &Option<&'static CommandDef>, s: S) -> Result<S::Ok, S::Error> {
    match d {
        Some(d) => s.serialize_some(d.key),
        None => s.serialize_none(),
    }
}

impl DecodedReply {
    pub fn get(&self, key: &str) -> Option<i64> {
        value_of(&self.fields, key)
    }
}

/// The row whose reply has `reply_code` and matches selector byte `selector`:
/// rows echoing their selector first, then the confirmation of that code.
pub fn reply_row(reply_code: u8, selector: u8) -> Option<&'static CommandDef> {
    let mut rows = COMMANDS.iter().filter(|c| c.reply.code == reply_code);
    let echoed = rows.clone().find(|c| c.reply.selector == ReplySelector::Echo && c.selector(selector).is_some());
    echoed.or_else(|| rows.find(|c| c.reply.selector == ReplySelector::Zero))
}

/// Decodes a reply (or an event, with the reply layout of its command).
/// `data` may be shorter than 8 bytes (variable length messages).
pub fn decode_reply(data: &[u8]) -> Result<DecodedReply, DecodeError> {
    let d = padded(data).ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
    if classify_code(d[0]).0 == AnswerKind::Error {
        return Err(DecodeError::Malformed(format!("{:#04x} is an error reply", d[0])));
    }
    // An event is its reply code with bit 6 set.
    let reply_code = d[0] & !0x40;
    let def = reply_row(reply_code, d[2]);
    let fields = def.map(|c| read_fields(c.reply.fields, &d)).unwrap_or_default();
    Ok(DecodedReply { def, code: d[0], module: d[1], selector: d[2], fields })
}

/// The 8 data bytes of a reply to `def` (what a module sends; for simulators).
pub fn encode_reply(
    def: &'static CommandDef,
    module: u8,
    selector: u8,
    values: &[(&str, i64)],
) -> Result<[u8; 8], ValidationError> {
    let sel_byte = match def.reply.selector {
        ReplySelector::Zero => 0,
        ReplySelector::Echo => selector,
    };
    if def.selector(selector).is_none() {
        return Err(ValidationError::Selector { command: def.key, selector });
    }
    let mut data = [def.reply.code, module, sel_byte, 0, 0, 0, 0, 0];
    write_fields(def.key, def.reply.fields, &mut data, values)?;
    Ok(data)
}
