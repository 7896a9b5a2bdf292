//! The PowerCube protocol (Amtec/SCHUNK "Data exchange with PowerCube").
//!
//! The same command payload travels over CAN and RS232; only the framing
//! differs. [`frame`] holds the payloads, [`can`] and [`rs232`] the framings,
//! [`table`] the command, motion and parameter tables and [`flags`] the state,
//! config, setup and DIO words.

pub mod bus;
pub mod can;
mod display;
pub mod flags;
pub mod frame;
pub mod limits;
pub mod refusal;
pub mod rs232;
pub mod session;
pub mod table;

pub use frame::{Motion, MotionValue, Request, Response};

/// A module address, 1..=31.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(transparent)]
pub struct ModuleId(u8);

impl ModuleId {
    pub const MIN: u8 = 1;
    pub const MAX: u8 = 31;

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

    /// Every valid address, 1..=31.
    pub fn all() -> impl Iterator<Item = Self> {
        (Self::MIN..=Self::MAX).map(Self)
    }
}

impl std::fmt::Display for ModuleId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}
