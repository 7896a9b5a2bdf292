//! An in-memory CAN bus: simulated devices and any number of client links
//! on one bus, on real or virtual time.
//!
//! Every frame a client sends is seen by the devices and by the other
//! clients (as on a real bus, where a monitor sees everything); every frame a
//! device sends is seen by all clients.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::{CanLink, LinkError};
use crate::clock::Clock;
use crate::proto::CanFrame;

/// A simulated node on the bus.
pub trait CanDevice: Send {
    /// A frame seen on the bus; answers go to `out`.
    fn on_frame(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>);
    /// Frames the device sends on its own (events, timers) up to `now`.
    fn poll(&mut self, _now: Instant, _out: &mut Vec<CanFrame>) {}
}

/// How the bus treats frames, for fault injection.
pub trait Fault: Send {
    /// Decides what happens to a frame sent by a device; returns the frames to
    /// deliver instead (empty to drop it).
    fn device_frame(&mut self, frame: CanFrame) -> Vec<CanFrame>;
}

struct Inner {
    devices: Vec<Box<dyn CanDevice>>,
    queues: Vec<VecDeque<CanFrame>>,
    fault: Option<Box<dyn Fault>>,
    scratch: Vec<CanFrame>,
}

impl Inner {
    fn deliver_from_devices(&mut self) {
        let mut frames = std::mem::take(&mut self.scratch);
        if let Some(fault) = self.fault.as_mut() {
            frames = frames.into_iter().flat_map(|f| fault.device_frame(f)).collect();
        }
        for q in &mut self.queues {
            q.extend(frames.iter().copied());
        }
        frames.clear();
        self.scratch = frames;
    }

    fn poll_devices(&mut self, now: Instant) {
        let mut out = std::mem::take(&mut self.scratch);
        for d in &mut self.devices {
            d.poll(now, &mut out);
        }
        self.scratch = out;
        self.deliver_from_devices();
    }
}

/// The bus. Cheap to clone; clones share the bus.
#[derive(Clone)]
pub struct MemBus {
    inner: Arc<Mutex<Inner>>,
    clock: Arc<dyn Clock>,
}

impl MemBus {
    pub fn new(clock: Arc<dyn Clock>) -> Self {
        let inner = Inner { devices: Vec::new(), queues: Vec::new(), fault: None, scratch: Vec::new() };
        Self { inner: Arc::new(Mutex::new(inner)), clock }
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn attach(&self, device: Box<dyn CanDevice>) {
        self.lock().devices.push(device);
    }

    pub fn set_fault(&self, fault: Option<Box<dyn Fault>>) {
        self.lock().fault = fault;
    }

    /// A new client link on this bus.
    pub fn open(&self) -> MemCanLink {
        let mut inner = self.lock();
        inner.queues.push(VecDeque::new());
        MemCanLink { bus: self.clone(), index: inner.queues.len() - 1 }
    }

    pub fn clock(&self) -> &Arc<dyn Clock> {
        &self.clock
    }

    /// Runs `f` on the attached devices (tests inspect simulator state this way).
    pub fn with_devices<R>(&self, f: impl FnOnce(&mut [Box<dyn CanDevice>]) -> R) -> R {
        f(&mut self.lock().devices)
    }
}

/// A client's view of a [`MemBus`].
pub struct MemCanLink {
    bus: MemBus,
    index: usize,
}

/// Granularity of waiting on real time; frames from other threads' clients
/// are picked up at most this late.
const WAIT_SLICE: Duration = Duration::from_millis(1);

impl CanLink for MemCanLink {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let now = self.bus.clock.now();
        let mut guard = self.bus.lock();
        let inner = &mut *guard;
        for (i, q) in inner.queues.iter_mut().enumerate() {
            if i != self.index {
                q.push_back(*frame);
            }
        }
        let mut out = std::mem::take(&mut inner.scratch);
        for d in &mut inner.devices {
            d.on_frame(now, frame, &mut out);
        }
        inner.scratch = out;
        inner.deliver_from_devices();
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let deadline = self.bus.clock.now() + timeout;
        loop {
            let now = self.bus.clock.now();
            {
                let mut inner = self.bus.lock();
                inner.poll_devices(now);
                if let Some(f) = inner.queues[self.index].pop_front() {
                    return Ok(Some(f));
                }
            }
            if now >= deadline {
                return Ok(None);
            }
            self.bus.clock.sleep(WAIT_SLICE.min(deadline - now));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::VirtualClock;

    struct Echo;
    impl CanDevice for Echo {
        fn on_frame(&mut self, _now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>) {
            if frame.id() == 0x10 {
                out.push(CanFrame::new(0x11, frame.data()).unwrap());
            }
        }
    }

    #[test]
    fn devices_answer_and_clients_see_each_other() {
        let clock = Arc::new(VirtualClock::new());
        let bus = MemBus::new(clock.clone());
        bus.attach(Box::new(Echo));
        let mut a = bus.open();
        let mut b = bus.open();
        a.send(&CanFrame::new(0x10, &[1]).unwrap()).unwrap();
        assert_eq!(a.recv(Duration::ZERO).unwrap().unwrap().id(), 0x11);
        assert_eq!(b.recv(Duration::ZERO).unwrap().unwrap().id(), 0x10, "b sees a's request");
        assert_eq!(b.recv(Duration::ZERO).unwrap().unwrap().id(), 0x11);
        let t0 = clock.now();
        assert_eq!(a.recv(Duration::from_millis(100)).unwrap(), None);
        assert_eq!(clock.now() - t0, Duration::from_millis(100), "a timeout takes exactly the timeout, virtually");
    }
}
