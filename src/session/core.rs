//! What every session shares: the clock deadlines are measured on, the
//! answer timeout, the retry policy and the tracer, and the loops built on
//! them (read retries, receive until a deadline, dropping stale frames, the
//! pipelined CAN burst). The families bring only their matchers (`proto`).

use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::{RetryPolicy, SessionError, TraceEvent, Tracer};
use crate::clock::{Clock, SystemClock};
use crate::link::{ByteLink, CanLink, LinkError};
use crate::proto::CanFrame;

/// Most stale frames dropped before a request: a bus that never falls
/// silent must not starve it.
const MAX_DRAIN: usize = 256;

pub struct Core {
    pub clock: Arc<dyn Clock>,
    pub timeout: Duration,
    pub retry: RetryPolicy,
    tracer: Option<Tracer>,
}

impl Core {
    pub fn new(timeout: Duration) -> Self {
        Self { clock: Arc::new(SystemClock), timeout, retry: RetryPolicy::default(), tracer: None }
    }

    pub fn set_tracer(&mut self, tracer: Tracer) {
        self.tracer = Some(tracer);
    }

    /// Builds the event only when someone listens.
    pub fn trace(&mut self, ev: impl FnOnce() -> TraceEvent) {
        if let Some(t) = self.tracer.as_mut() {
            t(ev());
        }
    }

    pub fn now(&self) -> Instant {
        self.clock.now()
    }

    /// Waits on the session's clock (virtual in tests).
    pub fn sleep(&self, d: Duration) {
        self.clock.sleep(d);
    }

    /// Receives until `on` breaks (`Some`) or `deadline` passes (`None`).
    pub fn recv_until<T>(
        &mut self,
        link: &mut dyn CanLink,
        deadline: Instant,
        mut on: impl FnMut(&mut Self, CanFrame) -> ControlFlow<T>,
    ) -> Result<Option<T>, LinkError> {
        loop {
            let now = self.clock.now();
            if now >= deadline {
                return Ok(None);
            }
            if let Some(frame) = link.recv(deadline - now)? {
                if let ControlFlow::Break(t) = on(self, frame) {
                    return Ok(Some(t));
                }
            }
        }
    }

    /// Reads until `on` breaks (`Some`) or the deadline passes (`None`). `on`
    /// sees an empty chunk first (for what its decoder still holds), then
    /// every chunk read; it may move the deadline.
    pub fn read_until<T>(
        &mut self,
        link: &mut dyn ByteLink,
        mut deadline: Instant,
        mut on: impl FnMut(&mut Self, &[u8], &mut Instant) -> ControlFlow<T>,
    ) -> Result<Option<T>, LinkError> {
        let mut buf = [0u8; 128];
        let mut n = 0;
        loop {
            if let ControlFlow::Break(t) = on(self, &buf[..n], &mut deadline) {
                return Ok(Some(t));
            }
            let now = self.clock.now();
            if now >= deadline {
                return Ok(None);
            }
            n = link.read(&mut buf, deadline - now)?;
        }
    }

    /// Hands `on` every frame already queued, at most [`MAX_DRAIN`]. Frames
    /// queued before a request cannot answer it: a late answer to an exchange
    /// that timed out would otherwise be taken for the answer to the next
    /// request of the same kind, and every later read would be one behind.
    pub fn drain(&mut self, link: &mut dyn CanLink, mut on: impl FnMut(&mut Self, CanFrame)) -> Result<(), LinkError> {
        for _ in 0..MAX_DRAIN {
            let Some(frame) = link.recv(Duration::ZERO)? else { break };
            on(self, frame);
        }
        Ok(())
    }

    /// The pipelined CAN burst, sent: every frame in one go (on an slcan
    /// adapter one write); the deadline of its answers (one timeout from
    /// now). Whatever is sent next goes out behind these frames while their
    /// answers are still on their way, so the bus need not fall idle while
    /// the answers cross the link; [`Self::collect`] waits for them.
    pub fn send_burst(&mut self, link: &mut dyn CanLink, frames: &[CanFrame]) -> Result<Instant, LinkError> {
        link.send_many(frames)?;
        Ok(self.clock.now() + self.timeout)
    }

    /// The answers of a burst: receives until `on` has said `pending` times
    /// that a frame settled a request, or until `deadline`. `on` sees every
    /// frame received, whichever request it answers.
    pub fn collect(
        &mut self,
        link: &mut dyn CanLink,
        deadline: Instant,
        mut pending: usize,
        mut on: impl FnMut(&mut Self, CanFrame) -> bool,
    ) -> Result<(), LinkError> {
        if pending == 0 {
            return Ok(());
        }
        self.recv_until(link, deadline, |core, frame| {
            if on(core, frame) {
                pending -= 1;
            }
            if pending == 0 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })?;
        Ok(())
    }
}

/// Errors after which a read may go out again.
pub trait Retryable {
    /// The session error, if it is a timeout or a malformed answer.
    fn retryable(&self) -> bool;
}

impl Retryable for SessionError {
    fn retryable(&self) -> bool {
        matches!(self, Self::Timeout { .. } | Self::Malformed { .. })
    }
}

/// A session that has a [`Core`].
pub trait HasCore {
    fn core(&mut self) -> &mut Core;
}

/// Runs `once` and, for a read (`read`), runs it again after a retryable
/// error, so that a read goes out at most `1 + read_retries` times; anything
/// else goes out once. `failed`: the first attempt went out already (in a
/// burst) and failed so.
pub fn with_read_retries<S: HasCore, T, E: Retryable>(
    s: &mut S,
    read: bool,
    failed: Option<E>,
    mut once: impl FnMut(&mut S) -> Result<T, E>,
) -> Result<T, E> {
    let retries = s.core().retry.read_retries;
    let total = if read { 1 + retries } else { 1 };
    let mut done = u32::from(failed.is_some());
    let mut last = match failed {
        Some(e) if !read || !e.retryable() => return Err(e),
        other => other,
    };
    while done < total {
        if done > 0 {
            s.core().trace(|| TraceEvent::Note(format!("retrying read ({done}/{retries})")));
        }
        done += 1;
        match once(s) {
            Ok(t) => return Ok(t),
            Err(e) if e.retryable() => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.expect("a read goes out at least once"))
}

/// The setters every session offers, on the session's `core` field.
macro_rules! core_setters {
    ($session:ty) => {
        impl $session {
            /// The clock deadlines are measured on; links on virtual time pass theirs.
            pub fn with_clock(mut self, clock: std::sync::Arc<dyn crate::clock::Clock>) -> Self {
                self.core.clock = clock;
                self
            }

            pub fn clock(&self) -> &std::sync::Arc<dyn crate::clock::Clock> {
                &self.core.clock
            }

            pub fn set_retry(&mut self, retry: super::RetryPolicy) {
                self.core.retry = retry;
            }

            pub fn set_tracer(&mut self, tracer: super::Tracer) {
                self.core.set_tracer(tracer);
            }
        }

        impl super::core::HasCore for $session {
            fn core(&mut self) -> &mut super::core::Core {
                &mut self.core
            }
        }
    };
    ($session:ty, timeout) => {
        core_setters!($session);

        impl $session {
            pub fn set_timeout(&mut self, timeout: std::time::Duration) {
                self.core.timeout = timeout;
            }

            pub fn timeout(&self) -> std::time::Duration {
                self.core.timeout
            }
        }
    };
}
pub(crate) use core_setters;

#[cfg(test)]
mod tests {
    use super::*;

    struct Counter {
        core: Core,
        calls: u32,
    }

    impl HasCore for Counter {
        fn core(&mut self) -> &mut Core {
            &mut self.core
        }
    }

    fn timeout() -> SessionError {
        SessionError::Timeout { target: "t".into(), what: "w".into(), timeout: Duration::ZERO }
    }

    fn run(read: bool, failed: Option<SessionError>, retries: u32) -> u32 {
        let mut c = Counter { core: Core::new(Duration::ZERO), calls: 0 };
        c.core.retry = RetryPolicy { read_retries: retries };
        let r: Result<(), _> = with_read_retries(&mut c, read, failed, |c| {
            c.calls += 1;
            Err(timeout())
        });
        assert!(r.is_err());
        c.calls
    }

    #[test]
    fn reads_go_out_one_plus_retries_times_the_rest_once() {
        assert_eq!(run(true, None, 2), 3);
        assert_eq!(run(false, None, 2), 1);
        assert_eq!(run(true, Some(timeout()), 2), 2, "a burst was the first attempt");
        assert_eq!(run(true, Some(timeout()), 0), 0);
        assert_eq!(run(false, Some(timeout()), 2), 0);
        let link = SessionError::Link(LinkError::Closed);
        assert_eq!(run(true, Some(link), 2), 0, "a link error is not retried");
    }

    // Only a timeout or a malformed answer sends a read again: after a link
    // error or a refusal the same request would fail the same way.
    #[test]
    fn a_read_that_fails_otherwise_goes_out_once() {
        let mut c = Counter { core: Core::new(Duration::ZERO), calls: 0 };
        c.core.retry = RetryPolicy { read_retries: 2 };
        let r: Result<(), _> = with_read_retries(&mut c, true, None, |c| {
            c.calls += 1;
            Err(SessionError::Link(LinkError::Closed))
        });
        assert!(matches!(r, Err(SessionError::Link(LinkError::Closed))), "{r:?}");
        assert_eq!(c.calls, 1);
    }

    // --trace says when a read goes out again, and only then: the first
    // attempt is not a retry.
    #[test]
    fn each_retry_is_traced_and_the_first_attempt_is_not() {
        let notes = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
        let mut c = Counter { core: Core::new(Duration::ZERO), calls: 0 };
        c.core.retry = RetryPolicy { read_retries: 2 };
        let seen = std::sync::Arc::clone(&notes);
        c.core.set_tracer(Box::new(move |ev| {
            if let TraceEvent::Note(n) = ev {
                seen.lock().unwrap().push(n);
            }
        }));
        let r: Result<(), _> = with_read_retries(&mut c, true, None, |c| {
            c.calls += 1;
            Err(timeout())
        });
        assert!(r.is_err());
        assert_eq!(c.calls, 3);
        assert_eq!(*notes.lock().unwrap(), ["retrying read (1/2)", "retrying read (2/2)"]);
    }
}
