//! axisctl: commissioning PowerCube, PA-CONTROL and Cdios motion hardware.
//!
//! Layers, from the wire up (docs/architecture.md draws them and says what
//! each may import; tests/library/architecture.rs checks it):
//! - [`proto`]: sans-IO codecs, the protocol tables and the answer matchers. No I/O, no clock.
//! - [`clock`]: real and virtual time.
//! - [`link`]: transports (SocketCAN, slcan, serial, in-memory) behind small traits.
//! - [`family`]: the families, declared once (names, links, serial defaults, id ranges,
//!   decode kinds, dashboard capabilities, and for a CAN family its answer ids and how its
//!   frames read).
//! - [`address`]: the one device address (`powercube:3`, `pac:2`, `cdios:1/0`), parsed and
//!   printed against the family registry's id ranges, and the labels each output gives it.
//! - [`session`]: one core (timeouts, retries, tracing, the pipelined CAN burst) and a thin
//!   session per family; [`session::bus`] shares one CAN link between families.
//! - [`sim`]: clock-driven simulators of the devices.
//! - [`device`]: every operation on a device, written once per family, with its safety rules.
//! - [`backup`]: backup, diff and restore of a bench: the document, the diff engine, per family the checks and the write order.
//! - [`open`]: from a `--link` and a family to a ready link or session, `sim` and `--log` included.
//! - [`record`]: sampling chosen values with time stamps, pipelined as the dashboard polls.
//! - [`monitor`]: passive decoding of any frame on a CAN bus.
//! - [`tui`]: the dashboard, adapters over [`device`].
//! - [`commission`]: a plan run over the bench, its checks, step-response figures and the report.
//! - [`plot`]: charts of sampled values as SVG (recordings, dashboard snapshots); pure.
//! - `cli` and `commands` (binary side): the command line as typed, and thin subcommands.

pub mod address;
pub mod backup;
pub mod bench;
pub mod clock;
pub mod commission;
pub mod device;
pub mod family;
pub mod link;
pub mod monitor;
pub mod open;
pub mod plot;
pub mod proto;
pub mod record;
pub mod session;
pub mod sim;
pub mod tui;

pub use address::Address;
