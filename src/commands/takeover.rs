//! The emergency halt from another terminal: `halt`, `pac-stop`,
//! `pac-stop-axis` and `cdios-stop` open their link with
//! [`Opener::take_over`], so a device held by another axisctl process (a
//! `--wait`, the dashboard) is released by its holder, which halts what it
//! drives, before this command sends its own halt. Here: opening that way,
//! and saying what became of the holder.

use std::time::Duration;

use axisctl::link::LinkSpec;
use axisctl::open::{OpenError, Opener, SessionOptions, Takeover};
use serde_json::{json, Value};

use super::Ctx;

/// How long the report waits for the holder's process to be gone, once our
/// own halt is sent: it closes the port a moment before it exits.
const EXIT_GRACE: Duration = Duration::from_secs(2);

/// Opens with `open`, taking the device over from an axisctl holder.
pub fn open<T>(
    ctx: &Ctx,
    open: impl Fn(&Opener, &LinkSpec, &SessionOptions) -> Result<T, OpenError>,
) -> anyhow::Result<(T, Option<Takeover>)> {
    let spec = ctx.link()?;
    let opts = ctx.session_options();
    Ok(ctx.opener().take_over(|o| open(o, spec, &opts))?)
}

/// What became of the holder, reported after our own halt went out.
pub struct HolderReport {
    pid: u32,
    what: String,
    path: String,
    signalled: bool,
    exited: bool,
}

impl HolderReport {
    /// `None` when nobody held the device. Waits up to [`EXIT_GRACE`] for the
    /// holder to exit: call it only once the halt is sent.
    pub fn after_halt(takeover: Option<&Takeover>) -> Option<Self> {
        takeover.map(|t| Self {
            pid: t.holder.pid,
            what: t.holder.what.clone(),
            path: t.path.clone(),
            signalled: t.signalled,
            exited: t.exited(EXIT_GRACE),
        })
    }

    /// The `holder` member of the command's JSON.
    pub fn json(&self) -> Value {
        json!({"pid": self.pid, "what": self.what, "signalled": self.signalled, "exited": self.exited})
    }

    /// One line, printed before the command's own.
    pub fn line(&self) -> String {
        let end = if self.exited { "it exited" } else { "it had not exited yet" };
        let asked = if self.signalled {
            "asked it with SIGTERM to halt what it drives and let go"
        } else {
            "it ended by itself before it was signalled"
        };
        format!("{} was held by axisctl PID {} ({}): {asked}; {end}", self.path, self.pid, self.what)
    }
}

/// An error after the holder was signalled says so: it may have halted,
/// but our own halt did not go through.
pub fn failed(err: impl Into<anyhow::Error>, takeover: Option<&Takeover>) -> anyhow::Error {
    let err = err.into();
    match takeover {
        Some(t) => err.context(format!(
            "{} was held by axisctl PID {}, which was asked with SIGTERM to halt and let go; then our own halt failed",
            t.path, t.holder.pid
        )),
        None => err,
    }
}
