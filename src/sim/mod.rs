//! Simulators of the devices, faithful to the manuals and driven by an
//! injected clock: every entry point takes `now`, so tests run on virtual
//! time. [`bench`] puts them on one bus; `axisctl sim` serves it on ptys.

pub mod bench;
pub mod cdios;
pub mod fault;
pub mod pac;
pub mod powercube;
pub mod serve;
pub mod shared;
