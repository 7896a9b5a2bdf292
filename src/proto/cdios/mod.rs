//! The Cdios 6168 motor driver controller module, behind a Cdios controller
//! (type 6152) on CAN ("Cdios 6168 Command / Reply / Event messages V2.0",
//! with the transport of the specs README).
//!
//! - [`transport`]: CAN ids (NMT start, commands to `0x200 + node`, answers
//!   from `0x180 + node`), zero padding of short frames and the
//!   reply / event / error classification of answers.
//! - [`table`]: every command, field, selector, status flag and error bit of
//!   the manual, declared once; the generic field encoder / decoder.
//! - [`command`]: the typed [`Command`] front end; its bytes come from the
//!   table.
//!
//! Data bytes are indexed from 0 here; the manual numbers them 1..8
//! (manual byte N is index N - 1).
//!
//! Where the manual is read rather than copied:
//! - 23h: an absolute goto is selector 0 (`cdios-goto -m 1 --node 1 5000` is
//!   `201#2301008813000000`); relative moves are selector 2 (from the
//!   current position) or 4 (from the setpoint).
//! - 25h option 3 is printed "Reserved", but status 2 bit 5 says a stop with
//!   option 3 releases the emergency stop: it is accepted as that.
//! - 26h: the command table says selector 0..1, the reply table shows 0..2.
//! - 16h analog values: -10000..10000 for -10.00..+10.00 V is 1 mV per count.
//! - Events carry the reply layout of their command (the controller page:
//!   "an event code is similar to a reply code, with bit 6 set").
//! - 01h: selectors 0..7 are type / version pairs; the layout of selectors
//!   8..24 (serial numbers) is not in our specs and decodes as raw bytes.

pub mod bus;
pub mod command;
mod display;
pub mod refusal;
pub mod session;
pub mod table;
pub mod transport;

#[cfg(test)]
mod tests;

pub use command::{
    AnalogOutput, Command, Direction, GotoMode, PositionSource, ServoConfig, ServoPart, StartOption, StatusSelector,
    Step, StopOption, Timers, Traject,
};
pub use table::{decode_status, StatusReport};
pub use transport::{Answer, AnswerKind, ErrorReply};

/// An I/O module id on a node, 0..=15 (DIP switch).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(transparent)]
pub struct ModuleId(u8);

impl ModuleId {
    pub const MAX: u8 = 15;

    pub const fn new(id: u8) -> Option<Self> {
        if id <= Self::MAX {
            Some(Self(id))
        } else {
            None
        }
    }

    pub const fn get(self) -> u8 {
        self.0
    }

    pub fn all() -> impl Iterator<Item = Self> {
        (0..=Self::MAX).map(Self)
    }
}

impl TryFrom<u8> for ModuleId {
    type Error = ValidationError;
    fn try_from(v: u8) -> Result<Self, Self::Error> {
        Self::new(v).ok_or(ValidationError::Module(v))
    }
}

impl std::fmt::Display for ModuleId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// A CANopen node id, 1..=127 (factory setting 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(transparent)]
pub struct NodeId(u8);

impl NodeId {
    pub const MIN: u8 = 1;
    pub const MAX: u8 = 127;
    pub const FACTORY: Self = Self(1);

    pub const fn new(id: u8) -> Option<Self> {
        if id >= Self::MIN && id <= Self::MAX {
            Some(Self(id))
        } else {
            None
        }
    }

    pub const fn get(self) -> u8 {
        self.0
    }
}

impl TryFrom<u8> for NodeId {
    type Error = ValidationError;
    fn try_from(v: u8) -> Result<Self, Self::Error> {
        Self::new(v).ok_or(ValidationError::Node(v))
    }
}

impl std::fmt::Display for NodeId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

/// Who data byte 2 addresses: an I/O module, or the Cdios controller itself
/// (any id above 15; 0xFF is the preferred one and what we send).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Address {
    Module(ModuleId),
    Controller,
}

impl Address {
    pub const CONTROLLER_BYTE: u8 = 0xFF;

    pub const fn to_byte(self) -> u8 {
        match self {
            Self::Module(m) => m.get(),
            Self::Controller => Self::CONTROLLER_BYTE,
        }
    }

    pub const fn from_byte(b: u8) -> Self {
        match ModuleId::new(b) {
            Some(m) => Self::Module(m),
            None => Self::Controller,
        }
    }
}

/// Why a command was not encoded (nothing is sent): the manual's ranges.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ValidationError {
    #[error("module id {0} out of range 0 to 15")]
    Module(u8),
    #[error("node id {0} out of range 1 to 127")]
    Node(u8),
    #[error("{command}: selector {selector:#04x} is not valid")]
    Selector { command: &'static str, selector: u8 },
    #[error("unknown command code {0:#04x}")]
    UnknownCode(u8),
    #[error("empty command")]
    Empty,
    #[error("{field} = {value} is out of range {min} to {max}")]
    OutOfRange { field: &'static str, value: i64, min: i64, max: i64 },
    #[error("{command}: missing value for {field}")]
    MissingField { command: &'static str, field: &'static str },
    #[error("{command}: no field named {field:?}")]
    UnknownField { command: &'static str, field: String },
    #[error("{command} must be addressed to {expected}")]
    Address { command: &'static str, expected: &'static str },
}
