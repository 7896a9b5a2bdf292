//! An in-memory CAN bus: simulated devices and any number of client links
//! on one bus, on real or virtual time.
//!
//! Every frame a client sends is seen by the devices and by the other
//! clients (as on a real bus, where a monitor sees everything); every frame a
//! device sends is seen by all clients.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::{ByteLink, CanLink, LinkError};
use crate::clock::Clock;
use crate::proto::CanFrame;

/// A simulated node on the bus.
pub trait CanDevice: Send {
    /// A frame seen on the bus; answers go to `out`.
    fn on_frame(&mut self, now: Instant, frame: &CanFrame, out: &mut Vec<CanFrame>);
    /// Frames the device sends on its own (events, timers) up to `now`.
    fn poll(&mut self, _now: Instant, _out: &mut Vec<CanFrame>) {}
}

/// How the bus treats frames, for fault injection (see `sim::fault`).
pub trait Fault: Send {
    /// Decides what happens to a frame sent by a device: pushes the frames to
    /// deliver instead, each after a delay (nothing pushed drops it).
    fn device_frame(&mut self, frame: CanFrame, out: &mut Vec<Delivery>);
}

/// A frame a [`Fault`] lets through, `after` this long.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Delivery {
    pub after: Duration,
    pub frame: CanFrame,
}

/// A frame on its way: it occupies the bus until `done`, then every other
/// node sees it.
struct InFlight {
    done: Instant,
    frame: CanFrame,
    /// The client that sent it (it does not receive its own frame), or `None`
    /// for a device.
    from: Option<usize>,
}

struct Inner {
    devices: Vec<Box<dyn CanDevice>>,
    queues: Vec<VecDeque<CanFrame>>,
    fault: Option<Box<dyn Fault>>,
    scratch: Vec<CanFrame>,
    /// Bit time when the wire speed is emulated; frames then take their real
    /// length on the bus, one after the other.
    bit_time: Option<Duration>,
    busy_until: Option<Instant>,
    /// Ends are non-decreasing: the bus carries one frame at a time.
    in_flight: VecDeque<InFlight>,
    /// Device frames a fault holds back, with the time they go on the bus.
    delayed: Vec<(Instant, CanFrame)>,
    deliveries: Vec<Delivery>,
}

impl Inner {
    fn schedule(&mut self, now: Instant, frame: CanFrame, from: Option<usize>) {
        let start = self.busy_until.map_or(now, |b| b.max(now));
        let done = start + self.bit_time.map_or(Duration::ZERO, |t| t * frame.wire_bits());
        self.busy_until = Some(done);
        self.in_flight.push_back(InFlight { done, frame, from });
    }

    /// Frames devices produced at `at` go on the bus after fault injection.
    fn schedule_device_frames(&mut self, at: Instant) {
        let mut frames = std::mem::take(&mut self.scratch);
        if let Some(fault) = self.fault.as_mut() {
            let mut deliveries = std::mem::take(&mut self.deliveries);
            for f in frames.drain(..) {
                fault.device_frame(f, &mut deliveries);
            }
            for d in deliveries.drain(..) {
                if d.after.is_zero() {
                    frames.push(d.frame);
                } else {
                    self.delayed.push((at + d.after, d.frame));
                }
            }
            self.deliveries = deliveries;
        }
        for f in frames.drain(..) {
            self.schedule(at, f, None);
        }
        self.scratch = frames;
    }

    /// Puts held-back frames that are due by `now` on the bus, in time order.
    fn release_delayed(&mut self, now: Instant) {
        if self.delayed.iter().all(|(t, _)| *t > now) {
            return;
        }
        self.delayed.sort_by_key(|(t, _)| *t);
        let due = self.delayed.iter().take_while(|(t, _)| *t <= now).count();
        let frames: Vec<_> = self.delayed.drain(..due).collect();
        for (t, f) in frames {
            self.schedule(t, f, None);
        }
    }

    /// When something next happens on the bus by itself.
    fn next_wake(&self) -> Option<Instant> {
        let flight = self.in_flight.front().map(|f| f.done);
        let delayed = self.delayed.iter().map(|(t, _)| *t).min();
        match (flight, delayed) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Delivers every frame whose transmission has ended by `now`, lets the
    /// devices answer, and polls them for frames of their own.
    fn pump(&mut self, now: Instant) {
        let mut out = std::mem::take(&mut self.scratch);
        for d in &mut self.devices {
            d.poll(now, &mut out);
        }
        self.scratch = out;
        self.schedule_device_frames(now);
        self.release_delayed(now);
        while self.in_flight.front().is_some_and(|f| f.done <= now) {
            let InFlight { done, frame, from } = self.in_flight.pop_front().expect("checked");
            for (i, q) in self.queues.iter_mut().enumerate() {
                if Some(i) != from {
                    q.push_back(frame);
                }
            }
            if from.is_some() {
                let mut out = std::mem::take(&mut self.scratch);
                for d in &mut self.devices {
                    d.on_frame(done, &frame, &mut out);
                }
                self.scratch = out;
                self.schedule_device_frames(done);
            }
        }
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
        let inner = Inner {
            devices: Vec::new(),
            queues: Vec::new(),
            fault: None,
            scratch: Vec::new(),
            bit_time: None,
            busy_until: None,
            in_flight: VecDeque::new(),
            delayed: Vec::new(),
            deliveries: Vec::new(),
        };
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

    /// Emulates a bus at `bitrate`: every frame takes its length in bits,
    /// stuff bits included ([`CanFrame::wire_bits`]), and frames queue for
    /// the bus. `None` delivers at once.
    pub fn set_bitrate(&self, bitrate: Option<u32>) {
        self.lock().bit_time = bitrate.map(|b| Duration::from_secs(1) / b.max(1));
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

impl MemCanLink {
    /// How long until the frame now on the bus ends, at most `max`: a
    /// serving loop that waits on something else wakes for it in time.
    pub fn until_next_due(&self, max: Duration) -> Duration {
        let next = self.bus.lock().in_flight.front().map(|f| f.done);
        next.map_or(max, |n| n.saturating_duration_since(self.bus.clock.now()).min(max))
    }
}

/// Granularity of waiting on real time; frames from other threads' clients
/// are picked up at most this late.
const WAIT_SLICE: Duration = Duration::from_millis(1);

impl CanLink for MemCanLink {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        let now = self.bus.clock.now();
        let mut inner = self.bus.lock();
        inner.schedule(now, *frame, Some(self.index));
        inner.pump(now);
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let deadline = self.bus.clock.now() + timeout;
        loop {
            let now = self.bus.clock.now();
            let next = {
                let mut inner = self.bus.lock();
                inner.pump(now);
                if let Some(f) = inner.queues[self.index].pop_front() {
                    return Ok(Some(f));
                }
                inner.next_wake()
            };
            if now >= deadline {
                return Ok(None);
            }
            let wake = next.map_or(deadline, |n| n.clamp(now, deadline));
            self.bus.clock.sleep((wake - now).clamp(Duration::from_micros(1), WAIT_SLICE));
        }
    }
}

/// A simulated device at the far end of a byte link (a serial port).
pub trait ByteDevice: Send {
    /// Bytes from the host, split anywhere; answers go to `out`.
    fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>);
    /// Bytes the device sends on its own (or lets time pass) up to `now`.
    fn poll(&mut self, _now: Instant, _out: &mut Vec<u8>) {}
}

/// A device shared with whoever inspects it (tests, the bench, a dashboard).
impl<T: ByteDevice> ByteDevice for Arc<Mutex<T>> {
    fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
        self.lock().unwrap_or_else(|e| e.into_inner()).on_bytes(now, bytes, out);
    }
    fn poll(&mut self, now: Instant, out: &mut Vec<u8>) {
        self.lock().unwrap_or_else(|e| e.into_inner()).poll(now, out);
    }
}

/// An in-memory serial line to one [`ByteDevice`], on real or virtual time:
/// what is written reaches the device at once, its answers queue until read.
/// With [`MemByteLink::set_char_time`] the line runs at a baud rate instead:
/// the device sees a write once its last character has arrived, and each
/// answer character becomes readable one character time after the previous.
pub struct MemByteLink {
    device: Box<dyn ByteDevice>,
    clock: Arc<dyn Clock>,
    /// Answer bytes and when each has arrived.
    rx: VecDeque<(Instant, u8)>,
    /// Writes on their way to the device, with when their last character arrives.
    tx: VecDeque<(Instant, Vec<u8>)>,
    char_time: Duration,
    tx_free: Instant,
    rx_free: Instant,
    scratch: Vec<u8>,
}

impl MemByteLink {
    pub fn new(device: Box<dyn ByteDevice>, clock: Arc<dyn Clock>) -> Self {
        let now = clock.now();
        Self {
            device,
            clock,
            rx: VecDeque::new(),
            tx: VecDeque::new(),
            char_time: Duration::ZERO,
            tx_free: now,
            rx_free: now,
            scratch: Vec::new(),
        }
    }

    /// Emulates the line's speed: `bits_per_char / baud` per character
    /// ([`crate::link::SerialFormat::bits_per_char`]); zero delivers at once.
    pub fn set_char_time(&mut self, char_time: Duration) {
        self.char_time = char_time;
    }

    /// Answer bytes received and not read yet.
    pub fn pending(&self) -> usize {
        let now = self.clock.now();
        self.rx.iter().take_while(|(at, _)| *at <= now).count()
    }

    /// Hands the device what has arrived by `now` and lets it run; its answer
    /// characters leave one after the other from the end of the request.
    fn pump(&mut self, now: Instant) {
        while self.tx.front().is_some_and(|(due, _)| *due <= now) {
            let (due, bytes) = self.tx.pop_front().expect("checked");
            self.device.on_bytes(now, &bytes, &mut self.scratch);
            self.queue_answer(due);
        }
        self.device.poll(now, &mut self.scratch);
        self.queue_answer(now);
    }

    fn queue_answer(&mut self, from: Instant) {
        let mut at = self.rx_free.max(from);
        for b in self.scratch.drain(..) {
            at += self.char_time;
            self.rx.push_back((at, b));
        }
        self.rx_free = at;
    }

    /// When the next thing on the line happens, if anything is on its way.
    fn next_due(&self) -> Option<Instant> {
        let tx = self.tx.front().map(|(t, _)| *t);
        let rx = self.rx.front().map(|(t, _)| *t);
        tx.into_iter().chain(rx).min()
    }
}

impl ByteLink for MemByteLink {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let now = self.clock.now();
        let due = self.tx_free.max(now) + self.char_time * bytes.len() as u32;
        self.tx_free = due;
        self.tx.push_back((due, bytes.to_vec()));
        self.pump(now);
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let deadline = self.clock.now() + timeout;
        loop {
            let now = self.clock.now();
            self.pump(now);
            let mut n = 0;
            while n < buf.len() && self.rx.front().is_some_and(|(at, _)| *at <= now) {
                buf[n] = self.rx.pop_front().expect("checked").1;
                n += 1;
            }
            if n > 0 {
                return Ok(n);
            }
            if now >= deadline {
                return Ok(0);
            }
            let wake = self.next_due().map_or(deadline, |t| t.clamp(now, deadline));
            self.clock.sleep((wake - now).clamp(Duration::from_micros(1), WAIT_SLICE));
        }
    }

    fn clear_input(&mut self) -> Result<(), LinkError> {
        let now = self.clock.now();
        self.pump(now);
        while self.rx.front().is_some_and(|(at, _)| *at <= now) {
            self.rx.pop_front();
        }
        Ok(())
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

    #[test]
    fn emulated_bitrate_serialises_frames() {
        let clock = Arc::new(VirtualClock::new());
        let bus = MemBus::new(clock.clone());
        bus.attach(Box::new(Echo));
        bus.set_bitrate(Some(1_000_000));
        let mut a = bus.open();
        let req = CanFrame::new(0x10, &[1, 2, 3, 4, 5, 6, 7, 8]).unwrap();
        let t0 = clock.now();
        a.send(&req).unwrap();
        a.send(&req).unwrap();
        let first = a.recv(Duration::from_millis(10)).unwrap().unwrap();
        assert_eq!(first.id(), 0x11);
        // Request 1, then request 2 and answer 1 compete: the bus is FIFO here.
        let bits = req.wire_bits() + req.wire_bits() + first.wire_bits();
        let took = clock.now() - t0;
        assert!(took >= Duration::from_micros(bits.into()), "{took:?} < {bits} bit times");
        assert!(took < Duration::from_micros(u64::from(bits) + 5), "{took:?}");
        assert_eq!(a.recv(Duration::from_millis(10)).unwrap().unwrap().id(), 0x11);
    }

    /// Answers each byte `b` with `b + 1` at once, and with `0xEE` once
    /// 50 ms have passed since the first byte.
    struct Plus {
        first: Option<Instant>,
        late_sent: bool,
    }
    impl ByteDevice for Plus {
        fn on_bytes(&mut self, now: Instant, bytes: &[u8], out: &mut Vec<u8>) {
            self.first.get_or_insert(now);
            out.extend(bytes.iter().map(|b| b.wrapping_add(1)));
        }
        fn poll(&mut self, now: Instant, out: &mut Vec<u8>) {
            if let Some(t) = self.first {
                if !self.late_sent && now - t >= Duration::from_millis(50) {
                    self.late_sent = true;
                    out.push(0xEE);
                }
            }
        }
    }

    #[test]
    fn byte_link_feeds_the_device_and_queues_answers() {
        let clock = Arc::new(VirtualClock::new());
        let dev = Arc::new(Mutex::new(Plus { first: None, late_sent: false }));
        let mut link = MemByteLink::new(Box::new(Arc::clone(&dev)), clock.clone());
        let t0 = clock.now();
        let mut buf = [0u8; 2];
        assert_eq!(link.read(&mut buf, Duration::from_millis(10)).unwrap(), 0);
        assert_eq!(clock.now() - t0, Duration::from_millis(10), "an empty read waits the timeout, virtually");
        link.write_all(&[1, 2, 3]).unwrap();
        assert_eq!(link.pending(), 3);
        assert_eq!(link.read(&mut buf, Duration::ZERO).unwrap(), 2, "read stops at the buffer's size");
        assert_eq!(buf, [2, 3]);
        assert_eq!(link.read(&mut buf, Duration::ZERO).unwrap(), 1);
        assert_eq!(buf[0], 4);
        // The device's own output arrives while a read waits for it.
        let t1 = clock.now();
        assert_eq!(link.read(&mut buf, Duration::from_secs(1)).unwrap(), 1);
        assert_eq!(buf[0], 0xEE);
        assert_eq!(clock.now() - t1, Duration::from_millis(50), "the read returns as soon as the byte is due");
        link.write_all(&[9]).unwrap();
        link.clear_input().unwrap();
        assert_eq!(link.read(&mut buf, Duration::ZERO).unwrap(), 0, "clear_input drops unread answers");
        assert!(dev.lock().unwrap().late_sent, "the device stays inspectable through the shared handle");
    }

    #[test]
    fn paced_byte_link_takes_the_wire_time_both_ways() {
        let clock = Arc::new(VirtualClock::new());
        let dev = Arc::new(Mutex::new(Plus { first: None, late_sent: false }));
        let mut link = MemByteLink::new(Box::new(Arc::clone(&dev)), clock.clone());
        link.set_char_time(Duration::from_millis(1));
        let t0 = clock.now();
        link.write_all(&[1, 2, 3]).unwrap();
        assert_eq!(link.pending(), 0, "nothing has arrived yet");
        assert!(dev.lock().unwrap().first.is_none(), "the device has not seen the request yet");
        let mut buf = [0u8; 8];
        let mut got = Vec::new();
        let mut arrivals = Vec::new();
        while got.len() < 3 {
            let n = link.read(&mut buf, Duration::from_millis(100)).unwrap();
            got.extend_from_slice(&buf[..n]);
            arrivals.push(clock.now() - t0);
        }
        assert_eq!(got, [2, 3, 4]);
        // The request's 3 characters take 3 ms; the answer's come 1 ms apart after that.
        let ms = Duration::from_millis;
        assert_eq!(arrivals, [ms(4), ms(5), ms(6)]);
        assert_eq!(dev.lock().unwrap().first, Some(t0 + ms(3)), "the device sees the request once it is in");
        // Back-to-back writes queue on the line.
        link.write_all(&[7]).unwrap();
        link.write_all(&[8]).unwrap();
        let t1 = clock.now();
        let mut got = Vec::new();
        while got.len() < 2 {
            let n = link.read(&mut buf, Duration::from_millis(100)).unwrap();
            got.extend_from_slice(&buf[..n]);
        }
        assert_eq!(got, [8, 9]);
        // Full duplex: the first answer leaves while the second request arrives.
        assert_eq!(clock.now() - t1, ms(3));
    }
}
