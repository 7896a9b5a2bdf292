//! Simulators.

pub mod powercube;
