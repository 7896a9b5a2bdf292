//! A simulated device shared between the bus that serves it and whoever
//! inspects it (tests, RS232 serving, fault injection).

use std::sync::{Arc, Mutex, MutexGuard};

pub type Shared<T> = Arc<Mutex<T>>;

/// Locks `m`; a panic elsewhere while it was held does not make the
/// simulated device unusable (its state stays consistent per call).
pub fn lock<T: ?Sized>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}
