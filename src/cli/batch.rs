//! `axisctl batch` and `axisctl shell` options, as typed.

use std::path::PathBuf;

use clap::Args;

#[derive(Debug, Args)]
pub struct BatchArgs {
    /// The commands, one per line, as after `axisctl` (`-` or none: standard input)
    #[arg(value_name = "FILE|-")]
    pub file: Option<PathBuf>,
    /// Run every line even after a failure, halting nothing (the exit code is still the first failure's; the last message names what may still move). Without it a failure stops the batch and halts what its lines moved
    #[arg(long)]
    pub keep_going: bool,
}

#[derive(Debug, Args)]
pub struct ShellArgs {
    /// The history file (default: $XDG_STATE_HOME/axisctl/history or ~/.local/state/axisctl/history)
    #[arg(long, value_name = "FILE")]
    pub history: Option<PathBuf>,
}
