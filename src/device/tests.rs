//! What the device tests share: the contract bench on virtual time behind
//! a link that records what was sent, so a test can say that a refused
//! operation sent nothing.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::clock::{Clock, VirtualClock};
use crate::link::{CanLink, LinkError};
use crate::proto::CanFrame;
use crate::sim::bench::Bench;

/// The contract bench, its clock, and a recording link onto its CAN bus.
pub struct Recorded {
    pub clock: VirtualClock,
    pub shared: Arc<dyn Clock>,
    pub bench: Bench,
    pub link: Recording,
    pub sent: Arc<Mutex<Vec<CanFrame>>>,
}

pub fn recorded_bench() -> Recorded {
    let clock = VirtualClock::new();
    let shared: Arc<dyn Clock> = Arc::new(clock.clone());
    let bench = Bench::contract(Arc::clone(&shared));
    let sent = Arc::new(Mutex::new(Vec::new()));
    let link = Recording { inner: Box::new(bench.bus.open()), sent: Arc::clone(&sent) };
    Recorded { clock, shared, bench, link, sent }
}

/// A link that keeps a copy of every frame sent through it.
pub struct Recording {
    pub inner: Box<dyn CanLink>,
    pub sent: Arc<Mutex<Vec<CanFrame>>>,
}

impl CanLink for Recording {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.sent.lock().unwrap().push(*frame);
        self.inner.send(frame)
    }
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.sent.lock().unwrap().extend_from_slice(frames);
        self.inner.send_many(frames)
    }
    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        self.inner.recv(timeout)
    }
}
