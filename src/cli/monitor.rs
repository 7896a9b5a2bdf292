//! `axisctl monitor` options, as typed.

use std::path::PathBuf;

use clap::Args;

use super::ids::{self, IdList};
use axisctl::bench::DeviceRef;
use axisctl::family::{IdRange, CDIOS_MODULE, POWERCUBE_MODULE};
use axisctl::monitor::{FamilyFilter, IdFilter};

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
    /// Only frames of these devices (instead of -m): powercube:ID, cdios:NODE/MODULE or bench-file names, comma-separated; live, the link they are on is listened to
    #[arg(
        short,
        long,
        value_name = "DEVICE[,DEVICE...]",
        value_delimiter = ',',
        num_args = 1,
        conflicts_with = "module",
        add = super::complete::bench_devices(None)
    )]
    pub device: Vec<DeviceRef>,
    /// Only these CAN ids, hex (e.g. 0F1; repeatable)
    #[arg(long, value_name = "HEX")]
    pub id: Vec<String>,
    /// Only frames passing ID:MASK (or not ID~MASK), hex, as candump's filters; several: any passes
    #[arg(long, value_name = "ID:MASK", value_delimiter = ',', value_parser = clap::value_parser!(IdFilter))]
    pub filter: Vec<IdFilter>,
    /// Time column: absolute (seconds since 1970), delta (since the frame before) or zero (since the first), as candump -t a|d|z
    #[arg(long, value_name = "WHEN", default_value = "absolute")]
    pub timestamps: Timestamps,
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
    /// A live table, one row per CAN id: count, period, rate, last data and its decoding (printed once at the end when not on a terminal)
    #[arg(long)]
    pub table: bool,
    /// Decode a candump log file instead of listening on a link (- reads standard input)
    #[arg(long, value_name = "FILE")]
    pub from_log: Option<PathBuf>,
}

/// How the human time column counts (JSON keeps `timestamp` absolute and
/// adds nothing: a script subtracts).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Timestamps {
    Absolute,
    Delta,
    Zero,
}
