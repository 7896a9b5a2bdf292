//! The module watchdog's refresh, kept going by the session itself while a
//! supervised motion lasts (the dead-man backstop, docs/safety.md).
//!
//! The refresh is the broadcast `[0x07, 0]`, due at least every 50 ms
//! (manual 13). It is sent from wherever the session spends time: before
//! each frame it sends, and from inside every wait for an answer, which is
//! cut into slices that end when the next refresh is due. A slow or missing
//! answer therefore never holds a refresh back; a wait between polls goes
//! through [`super::PowerCube::pause`] for the same reason. One thread, no
//! lock: the refresh cannot interleave with a frame half written.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::clock::Clock;
use crate::link::{CanLink, LinkError};
use crate::proto::powercube::can::Broadcast;
use crate::proto::CanFrame;

/// How many refreshes went out and the longest time between two of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RefreshStats {
    pub refreshes: u64,
    pub max_gap: Duration,
}

/// The refresh schedule of one session.
pub(super) struct Refresh {
    clock: Arc<dyn Clock>,
    every: Duration,
    frame: CanFrame,
    /// When the next refresh is due.
    next: Instant,
    last: Option<Instant>,
    stats: RefreshStats,
}

impl Refresh {
    /// Due at once: the first refresh goes out with the next frame or wait.
    pub(super) fn new(clock: Arc<dyn Clock>, every: Duration) -> Self {
        let next = clock.now();
        Self {
            clock,
            every,
            frame: Broadcast::WatchdogRefresh.frame(),
            next,
            last: None,
            stats: RefreshStats::default(),
        }
    }

    pub(super) fn next(&self) -> Instant {
        self.next
    }

    pub(super) fn stats(&self) -> RefreshStats {
        self.stats
    }

    /// Sends the refresh if it is due. The next one is due `every` after
    /// this one went out, not on a fixed grid: a late refresh is followed by
    /// a full interval, never by a catch-up burst.
    pub(super) fn tick(&mut self, link: &mut dyn CanLink) -> Result<(), LinkError> {
        if self.clock.now() < self.next {
            return Ok(());
        }
        link.send(&self.frame)?;
        let now = self.clock.now();
        if let Some(last) = self.last {
            self.stats.max_gap = self.stats.max_gap.max(now - last);
        }
        self.last = Some(now);
        self.stats.refreshes += 1;
        self.next = now + self.every;
        Ok(())
    }
}

/// A CAN link that refreshes the watchdog while it is used: every send
/// and every receive sends the refresh first when it is due, and a receive
/// waits no longer than until the next one.
pub(super) struct Refreshing<'a> {
    link: &'a mut dyn CanLink,
    refresh: Option<&'a mut Refresh>,
}

impl<'a> Refreshing<'a> {
    pub(super) fn new(link: &'a mut dyn CanLink, refresh: Option<&'a mut Refresh>) -> Self {
        Self { link, refresh }
    }

    fn tick(&mut self) -> Result<(), LinkError> {
        match self.refresh.as_deref_mut() {
            Some(r) => r.tick(self.link),
            None => Ok(()),
        }
    }
}

impl CanLink for Refreshing<'_> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.tick()?;
        self.link.send(frame)
    }

    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.tick()?;
        self.link.send_many(frames)
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let Some(r) = self.refresh.as_deref_mut() else { return self.link.recv(timeout) };
        let deadline = r.clock.now() + timeout;
        loop {
            r.tick(self.link)?;
            let now = r.clock.now();
            let slice = deadline.min(r.next()).saturating_duration_since(now);
            if let Some(frame) = self.link.recv(slice)? {
                return Ok(Some(frame));
            }
            if r.clock.now() >= deadline {
                return Ok(None);
            }
        }
    }
}
