//! Completion of the PowerCube's names: parameters and Config flags.

use std::ffi::OsStr;

use axisctl::proto::powercube::{flags as cube_flags, table as cube_table};
use clap_complete::engine::ArgValueCompleter;

use crate::cli::complete::starting_with;

/// PowerCube parameter names (`get-param`, `set-param`).
pub fn params() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| starting_with(current, cube_table::PARAMS.iter().map(|p| p.name)))
}

/// `+FLAG` / `-FLAG` of `set-config`, manual and short names.
pub fn config_changes() -> ArgValueCompleter {
    ArgValueCompleter::new(|current: &OsStr| {
        let typed = current.to_string_lossy();
        let sign = if typed.starts_with('-') { "-" } else { "+" };
        let names = cube_flags::CONFIG.flags.iter().flat_map(|f| f.short.into_iter().chain(std::iter::once(f.name)));
        let signed: Vec<String> = names.map(|n| format!("{sign}{n}")).collect();
        starting_with(current, signed.iter().map(String::as_str))
    })
}
