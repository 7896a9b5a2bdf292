//! The device layer: every operation a person or a script performs on a
//! device (read its state, move it with its limit checks, stop it, home it,
//! change its mode, find its axes, halt everything), written once per family
//! with typed errors. The CLI commands and the dashboard are thin adapters
//! over it: nothing that decides what is safe to send lives above this layer.

pub mod cdios;
pub mod face;
pub mod pac;
pub mod powercube;
pub mod registry;
pub mod supervisor;

#[cfg(test)]
mod tests;
