//! `--wait`: the plumbing every family's waiting commands share (Ctrl-C
//! armed, the spinner, the poll and give-up timing); what is waited for and
//! how a failed wait stops the device is the device layer's.

use std::time::Duration;

use super::Ctx;
use crate::cli::WaitArgs;

/// How a `--wait` polls, gives up, and how often it sends the stop that
/// ends a failed wait.
pub(super) struct Timing {
    pub poll: Duration,
    pub timeout: Duration,
    pub stop_attempts: u32,
}

/// Runs a device wait with Ctrl-C armed and the spinner shown (not with
/// --json); `run` gets the timing and the function that sets the spinner's
/// message.
pub(super) fn waiting<T>(
    ctx: &Ctx,
    wait: &WaitArgs,
    run: impl FnOnce(Timing, &dyn Fn(String)) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    super::arm_interrupt()?;
    let timing = Timing {
        poll: Duration::from_millis(wait.poll),
        timeout: wait.wait_timeout,
        stop_attempts: 1 + ctx.retry.read_retries,
    };
    let bar = crate::output::spinner(ctx.json);
    let show = |msg: String| {
        if let Some(bar) = &bar {
            bar.set_message(msg);
            bar.tick();
        }
    };
    let out = run(timing, &show);
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    out
}
