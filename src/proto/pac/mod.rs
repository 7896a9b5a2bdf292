//! The PA-CONTROL protocol (IEF Werner "PA-CONTROL interfaces" manual).
//!
//! [`frame`] holds the RS232 online command frames and their stream
//! decoders, [`table`] the command, status, error and parameter tables,
//! [`profibus`] decoders for the Profibus-DP / Interbus-S words, [`session`]
//! the sans-IO state machine of one command / acknowledge transaction and
//! [`validate`] the checks run on a command before it is sent.

mod display;
pub mod frame;
pub mod profibus;
pub mod refusal;
pub mod session;
pub mod table;
pub mod validate;

pub use display::printable;
pub use frame::{Ack, AckDecoder, CheckRule, Command, CommandDecoder, Par2, Request};
