//! The tests that keep the CPU busy: commissioning runs (an in-process
//! bench computes every motion of every family) and the pools that run
//! many examples at once. The cli binary runs more tests at a time than the
//! machine has cores (`.cargo/config.toml`), because most of them wait on
//! simulated devices; of these busy ones at most [`SLOTS`] run at once, as
//! when the binary ran two tests at a time, so the tests that measure
//! timing keep the CPU they had then.

use std::sync::{Condvar, Mutex, MutexGuard};

/// How many busy tests run at once.
pub const SLOTS: usize = 2;

static BUSY: Slots = Slots::new(SLOTS);

/// Waits for one of the [`SLOTS`], held for the whole of a busy test.
pub fn slot() -> Slot<'static> {
    BUSY.take()
}

/// A counting semaphore.
pub struct Slots {
    max: usize,
    taken: Mutex<usize>,
    freed: Condvar,
}

/// One slot of a [`Slots`], given back on drop (also when its test panics).
#[must_use = "the slot is given back when this is dropped"]
pub struct Slot<'a>(&'a Slots);

impl Slots {
    pub const fn new(max: usize) -> Self {
        Slots { max, taken: Mutex::new(0), freed: Condvar::new() }
    }

    /// A failed test that held a slot must not lock the others out.
    fn count(&self) -> MutexGuard<'_, usize> {
        self.taken.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits until a slot is free and takes it.
    pub fn take(&self) -> Slot<'_> {
        let mut n = self.count();
        while *n >= self.max {
            n = self.freed.wait(n).unwrap_or_else(|e| e.into_inner());
        }
        *n += 1;
        Slot(self)
    }

    /// How many are taken now.
    pub fn taken(&self) -> usize {
        *self.count()
    }
}

impl Drop for Slot<'_> {
    fn drop(&mut self) {
        *self.0.count() -= 1;
        self.0.freed.notify_one();
    }
}
