//! `backup`, `diff` and `restore`: the arguments.

use std::path::PathBuf;

use axisctl::bench::DeviceRef;
use axisctl::family::{Family, CDIOS_FACTORY_NODE, CDIOS_NODE, POWERCUBE_MODULE};
use clap::{Args, Subcommand};

use super::ids;

/// Which devices of the bench: the families and the PowerCube modules, or
/// the devices themselves (`-d`).
#[derive(Debug, Args)]
pub struct Selection {
    /// Only these families (powercube, pac, cdios; repeat or comma-separate); default: every family of every link of the bench
    #[arg(long, value_name = "FAMILY", value_delimiter = ',', value_parser = super::dashboard::parse_family)]
    pub family: Vec<Family>,
    /// PowerCube modules: a list (3,5 or 1-8) or all (every module that answers; the default)
    #[arg(short, long, value_name = "ID[,ID...]|all", value_parser = ids::devices(POWERCUBE_MODULE))]
    pub module: Option<ids::Devices>,
    /// Cdios node id (CANopen), 1 to 127
    #[arg(long, value_name = "N", default_value_t = CDIOS_FACTORY_NODE, value_parser = ids::id(CDIOS_NODE))]
    pub node: u8,
    /// Every device of the bench (the default; says so in a script)
    #[arg(long, conflicts_with = "module")]
    pub all: bool,
    /// Only these devices, of any family on any link of the bench: powercube:ID, pac, pac:AXIS, cdios:NODE/MODULE or bench-file names, comma-separated (one that does not answer: exit 4, nothing written)
    #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(None),
          conflicts_with_all = ["family", "module", "node", "all"])]
    pub device: Vec<DeviceRef>,
}

#[derive(Debug, Subcommand)]
pub enum BackupCommand {
    /// Save every device's identity and settings to one JSON document (axisctl-backup/1)
    Backup {
        #[command(flatten)]
        select: Selection,
        /// Write the document to FILE (default, or `-`: stdout)
        #[arg(long, short, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Compare a backup with the live bench, or two backups, per device and setting
    Diff {
        /// The backup (`-` for stdin)
        file: PathBuf,
        /// A second backup to compare with instead of the live bench
        file2: Option<PathBuf>,
        /// Compare only these devices of the file: addresses (powercube:ID, pac, pac:AXIS, cdios:NODE/MODULE) or bench-file names, comma-separated
        #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(None))]
        device: Vec<DeviceRef>,
    },
    /// Write a backup's settings back: shows the diff, checks every value, then writes and reads back
    Restore {
        /// The backup (`-` for stdin)
        file: PathBuf,
        /// Show the diff and the checks, write nothing
        #[arg(long)]
        dry_run: bool,
        /// Write the valid values when some are invalid (the invalid ones are skipped)
        #[arg(long)]
        skip_invalid: bool,
        /// Write the file's one device to this address (PowerCube module, Cdios module) although its identity differs
        #[arg(long, value_name = "ADDRESS", value_parser = ids::number(0u8, 31, ""))]
        to: Option<u8>,
        /// Cdios: store the configuration in the module's EEPROM (05h) after the restore
        #[arg(long)]
        store: bool,
        /// Restore only these devices of the file: addresses (powercube:ID, pac, pac:AXIS, cdios:NODE/MODULE) or bench-file names, comma-separated
        #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(None))]
        device: Vec<DeviceRef>,
    },
}
