//! `commission`, as typed (clap derive only).

use std::path::PathBuf;

use axisctl::bench::DeviceRef;
use clap::Args;

#[derive(Debug, Args)]
pub struct CommissionArgs {
    /// The plan (TOML); without it, the default plan for every device found
    #[arg(long, value_name = "FILE")]
    pub plan: Option<PathBuf>,
    /// Print the default plan for the bench it sees (TOML) and exit: nothing moves
    #[arg(long, conflicts_with_all = ["out", "yes", "dry_run", "plan"])]
    pub print_plan: bool,
    /// Write report.json, report.md, report.html, the recordings and backup.json here
    #[arg(long, value_name = "DIR", required_unless_present = "print_plan")]
    pub out: Option<PathBuf>,
    /// Make the plan's motions without asking (for scripts)
    #[arg(long)]
    pub yes: bool,
    /// Run only the checks that do not move; list the motions the plan would make
    #[arg(long)]
    pub dry_run: bool,
    /// Only these devices of the plan (or of the default plan; with --print-plan, the plan for them): powercube:ID, pac, pac:AXIS, cdios:NODE/MODULE or bench-file names, comma-separated
    #[arg(short, long, value_name = "DEVICE[,DEVICE...]", value_delimiter = ',', num_args = 1, add = super::complete::bench_devices(None))]
    pub device: Vec<DeviceRef>,
}
