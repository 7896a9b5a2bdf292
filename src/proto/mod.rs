//! Sans-IO protocol core: frame types, codecs and the protocol tables.
//!
//! Nothing in here performs I/O or reads a clock. Links feed bytes or CAN
//! frames in; typed frames come out, and typed frames encode to bytes.

pub mod can;
pub mod candump;
pub mod cdios;
pub mod pac;
pub mod powercube;
pub mod slcan;

pub use can::CanFrame;

/// Why a sequence of bytes or a frame could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("frame too short: need {need} bytes, got {got}")]
    TooShort { need: usize, got: usize },
    #[error("frame too long: {len} bytes")]
    TooLong { len: usize },
    #[error("bad checksum: computed {computed:#04x}, received {received:#04x}")]
    Checksum { computed: u8, received: u8 },
    #[error("unknown {what} {value:#04x}")]
    Unknown { what: &'static str, value: u32 },
    #[error("malformed frame: {0}")]
    Malformed(String),
}
