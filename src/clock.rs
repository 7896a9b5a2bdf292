//! Time as a dependency: the real clock for the binary, a virtual one for tests.
//!
//! Simulators and polling loops take a [`Clock`] so that tests of homing,
//! ramps and watchdogs run on virtual time and finish instantly.

pub mod stop;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub trait Clock: Send + Sync {
    fn now(&self) -> Instant;
    /// Waits (really or virtually) for `d`.
    fn sleep(&self, d: Duration);
    /// Waits like [`sleep`](Clock::sleep) but wakes early when the motion
    /// supervisor caught a signal: the poll interval of a wait never delays
    /// the halt.
    fn sleep_or_wake(&self, d: Duration) {
        self.sleep(d);
    }
}

/// The operating system's monotonic clock.
#[derive(Debug, Default, Clone, Copy)]
pub struct SystemClock;

impl Clock for SystemClock {
    fn now(&self) -> Instant {
        Instant::now()
    }
    fn sleep(&self, d: Duration) {
        std::thread::sleep(d);
    }
    fn sleep_or_wake(&self, d: Duration) {
        stop::sleep(d);
    }
}

/// A clock that only moves when told to; `sleep` advances it at once.
#[derive(Debug, Clone)]
pub struct VirtualClock {
    now: Arc<Mutex<Instant>>,
}

impl Default for VirtualClock {
    fn default() -> Self {
        Self::new()
    }
}

impl VirtualClock {
    pub fn new() -> Self {
        Self { now: Arc::new(Mutex::new(Instant::now())) }
    }

    pub fn advance(&self, d: Duration) {
        *self.now.lock().unwrap_or_else(|e| e.into_inner()) += d;
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> Instant {
        *self.now.lock().unwrap_or_else(|e| e.into_inner())
    }
    fn sleep(&self, d: Duration) {
        self.advance(d);
    }
}
