//! What the device tests share: a link that records what was sent, so a
//! test can say that a refused operation sent nothing.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::link::{CanLink, LinkError};
use crate::proto::CanFrame;

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
