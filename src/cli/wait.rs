//! `--wait` and its options, shared by the families' motion commands.

use std::time::Duration;

use clap::Args;

#[derive(Debug, Args, Clone, Copy)]
pub struct WaitArgs {
    /// Wait until the motion ends (exit 5 if an error flag appears; Ctrl-C halts the module)
    #[arg(long)]
    pub wait: bool,
    /// Give up waiting after this many seconds, 0.001 to 86400 (the device is halted, exit 7)
    #[arg(long, value_name = "S", default_value = DEFAULT_WAIT_TIMEOUT, value_parser = wait_timeout, requires = "wait")]
    pub wait_timeout: Duration,
    /// Poll interval while waiting, in ms
    #[arg(long, value_name = "MS", default_value_t = 20, value_parser = poll_ms(), requires = "wait")]
    pub poll: u64,
}

/// `--wait-timeout` of every family's waits, in seconds: a stuck wait is
/// given up (and the device stopped) after two minutes unless told otherwise.
pub const DEFAULT_WAIT_TIMEOUT: &str = "120";

/// The longest wait a command accepts: a day. Checked before anything is
/// sent, so that no value makes a wait that cannot end or a timer that
/// cannot be built once the device moves.
pub const MAX_WAIT: Duration = Duration::from_secs(24 * 3600);

/// The slowest poll: a wait must notice the end of a move (and Ctrl-C)
/// within a minute.
pub const MAX_POLL_MS: u64 = 60_000;

/// The shortest wait: a millisecond. A wait of 0 would send the move only
/// to halt it at once, which no one asks for on purpose.
pub const MIN_WAIT: Duration = Duration::from_millis(1);

/// `--wait-timeout`: seconds, finite, [`MIN_WAIT`]..=[`MAX_WAIT`].
pub fn wait_timeout(text: &str) -> Result<Duration, String> {
    let s: f64 = text.trim().parse().map_err(|_| format!("{text:?} is not a number of seconds"))?;
    if !(MIN_WAIT.as_secs_f64()..=MAX_WAIT.as_secs_f64()).contains(&s) {
        return Err(format!("{text} s is outside {} to {} s", MIN_WAIT.as_secs_f64(), MAX_WAIT.as_secs()));
    }
    Ok(Duration::from_secs_f64(s))
}

/// `--poll`: 1..=[`MAX_POLL_MS`] ms.
pub fn poll_ms() -> impl Fn(&str) -> Result<u64, String> + Clone + Send + Sync + 'static {
    super::ids::number(1, MAX_POLL_MS, "ms")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wait_timeouts_that_cannot_be_waited_are_refused() {
        for bad in ["inf", "-inf", "nan", "NaN", "1e300", "-1", "86401", "x", "", "0", "-0", "0.0009", "1e-12"] {
            assert!(wait_timeout(bad).is_err(), "{bad:?} accepted");
        }
        assert_eq!(wait_timeout("0"), Err("0 s is outside 0.001 to 86400 s".into()));
        assert_eq!(wait_timeout("0.001"), Ok(MIN_WAIT));
        assert_eq!(wait_timeout("2.5"), Ok(Duration::from_millis(2500)));
        assert_eq!(wait_timeout("86400"), Ok(MAX_WAIT));
    }
}
