//! `axisctl monitor` options, as typed.

use std::path::PathBuf;

use clap::Args;

use super::ids::{self, IdList};
use axisctl::family::{IdRange, CDIOS_MODULE, POWERCUBE_MODULE};
use axisctl::monitor::FamilyFilter;

/// A module id of any family on the bus.
const ANY_MODULE: IdRange = IdRange { min: CDIOS_MODULE.min, max: POWERCUBE_MODULE.max, ..POWERCUBE_MODULE };

#[derive(Debug, Args)]
pub struct MonitorArgs {
    /// Only these families: powercube, cdios, other (repeatable)
    #[arg(long, value_name = "FAMILY", value_parser = FamilyFilter::parse)]
    pub family: Vec<FamilyFilter>,
    /// Only frames of these module ids, e.g. 3,5 or 1-8 (PowerCube 1 to 31, Cdios 0 to 15; repeatable)
    #[arg(short, long, value_name = "IDS", value_parser = ids::list(ANY_MODULE))]
    pub module: Vec<IdList>,
    /// Only these CAN ids, hex (e.g. 0F1; repeatable)
    #[arg(long, value_name = "HEX")]
    pub id: Vec<String>,
    /// Stop after this many shown frames
    #[arg(long, value_name = "N")]
    pub count: Option<u64>,
    /// Stop after this many seconds
    #[arg(long = "for", value_name = "S")]
    pub duration: Option<f64>,
    /// Print frame statistics at the end
    #[arg(long)]
    pub stats: bool,
    /// Print candump -L lines instead of decoded ones
    #[arg(long)]
    pub candump: bool,
    /// Decode a candump log file instead of listening on a link (- reads standard input)
    #[arg(long, value_name = "FILE")]
    pub from_log: Option<PathBuf>,
}
