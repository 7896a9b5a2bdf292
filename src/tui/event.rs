//! Everything the dashboard reacts to arrives as one [`Event`]: keys, what
//! the link workers report, and clock ticks. What it asks of the workers
//! goes out as [`ToWorker`].

use crate::address::Address;
use std::time::{Duration, Instant};

use crossterm::event::KeyEvent;

use super::source::{Action, Health, Snapshot};

/// Index of a link (and of its worker) in the order the links were opened.
pub type LinkId = usize;

#[derive(Debug, Clone)]
pub enum Event {
    Key(KeyEvent),
    Link(LinkEvent),
    /// Time passes: ages data, ends highlights. Carries the clock's now.
    Tick(Instant),
    /// SIGTERM or SIGHUP (its number): halt what the dashboard moved, quit.
    Terminate(i32),
    /// Nobody can vouch for the screen or a worker any more (a panic, a
    /// failed draw; the text says which): halt what the dashboard moved, quit.
    Stop(String),
    /// The chart snapshot asked for with `p` was written (its path) or not
    /// (why).
    Saved(Result<String, String>),
}

/// What a link worker reports.
#[derive(Debug, Clone)]
pub enum LinkEvent {
    /// The devices found on the link (or given on the command line).
    Discovered { link: LinkId, devices: Vec<Address>, errors: Vec<String> },
    /// One poll of one device.
    Polled { link: LinkId, device: Address, at: Instant, result: Result<Snapshot, String>, health: Health },
    /// An action carried out (or refused); `device` is `None` for link-wide
    /// parts of a halt-all (the PowerCube broadcast).
    Acted { link: LinkId, device: Option<Address>, what: String, at: Instant, result: Result<String, String> },
    /// One round over every device: how long it took, and the time since the
    /// previous round started (the achieved poll period).
    Cycle { link: LinkId, busy: Duration, period: Duration },
    /// The link stopped answering and was closed; the worker reopens it.
    Down { link: LinkId, why: String },
    /// The lost link is open again; a [`LinkEvent::Discovered`] follows.
    Reopened { link: LinkId },
    /// The worker stopped (its link failed for good, or it panicked).
    Ended { link: LinkId, why: String },
}

/// What the UI asks of a worker.
#[derive(Debug, Clone, PartialEq)]
pub enum ToWorker {
    Act(Address, Action),
    /// Stop everything on the link; goes before anything else queued.
    HaltAll,
    /// Polls per second wanted.
    SetRate(f64),
    /// Discover the devices again (modules that missed the start).
    Rescan,
    Quit,
}
