//! axisctl: commissioning PowerCube, PA-CONTROL and Cdios motion hardware.
//!
//! Layers, from the wire up:
//! - [`proto`]: sans-IO codecs and the protocol tables. No I/O, no clock.
//! - [`link`]: transports (SocketCAN, slcan, serial, in-memory) behind small traits.
//! - [`session`]: request/answer matching with timeouts and the retry policy.
//! - [`sim`]: clock-driven simulators of the devices.
//! - [`family`]: the families, declared once (names, links, serial defaults, id ranges,
//!   decode kinds, dashboard capabilities).
//! - [`open`]: from a `--link` and a family to a ready link or session, `sim` and `--log` included.
//! - [`monitor`]: passive decoding of any frame on a CAN bus.
//! - [`tui`]: the dashboard.
//! - `cli` and `commands` (binary side): the command line as typed, and the subcommands.

pub mod clock;
pub mod device;
pub mod family;
pub mod link;
pub mod monitor;
pub mod open;
pub mod proto;
pub mod session;
pub mod sim;
pub mod tui;
