//! `--wait` and its options, shared by the families' motion commands.

use clap::Args;

#[derive(Debug, Args, Clone, Copy)]
pub struct WaitArgs {
    /// Wait until the motion ends (exit 5 if an error flag appears; Ctrl-C halts the module)
    #[arg(long)]
    pub wait: bool,
    /// Give up waiting after this many seconds (the module is halted)
    #[arg(long, value_name = "S", default_value_t = 120.0, requires = "wait")]
    pub wait_timeout: f64,
    /// Poll interval while waiting, in ms
    #[arg(long, value_name = "MS", default_value_t = 20, requires = "wait")]
    pub poll: u64,
}
