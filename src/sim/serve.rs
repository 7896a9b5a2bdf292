//! Serving the bench on real links: a pty speaking PowerCube RS232 or the
//! PA-CONTROL protocol, a pty behaving as an slcan adapter with the bus
//! behind it, or a SocketCAN interface. These loops are the only I/O of the
//! simulators.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

pub mod socketcand;

use super::fault::{ByteFaults, Trip};
use crate::clock::Clock;
use crate::link::mem::{ByteDevice, MemCanLink};
use crate::link::{ByteLink, CanLink, LinkError, SerialFormat};
use crate::proto::slcan::{AckStyle, Adapter};
use crate::proto::CanFrame;

/// How long a serving loop blocks before it looks at the bus again.
const TICK: Duration = Duration::from_millis(1);

/// Character timing of an emulated serial line.
#[derive(Debug, Clone, Copy)]
pub struct Pace {
    pub char_time: Duration,
}

impl Pace {
    pub fn serial(baud: u32, format: SerialFormat) -> Self {
        Self { char_time: Duration::from_secs(format.bits_per_char().into()) / baud.max(1) }
    }
}

/// Which way traffic went on a served link, named as its client sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Way {
    /// Sent by the client: a request.
    FromClient,
    /// Sent to the client: an answer, an event, an adapter's reply.
    ToClient,
}

/// What went over a served link.
#[derive(Debug, Clone, Copy)]
pub enum Traffic<'a> {
    Can(&'a CanFrame),
    /// Serial bytes as one chunk: all a read brought, or a whole answer
    /// (before its character times on a paced line).
    Bytes(&'a [u8]),
}

/// Hears the traffic of one served link (`axisctl sim --trace` / `--log`);
/// the default hears nothing.
#[derive(Default)]
pub struct Tap(Option<Box<Listener>>);

type Listener = dyn FnMut(Way, Traffic<'_>) + Send;

impl Tap {
    pub fn new(f: impl FnMut(Way, Traffic<'_>) + Send + 'static) -> Self {
        Self(Some(Box::new(f)))
    }

    fn hear(&mut self, way: Way, t: Traffic<'_>) {
        if let Some(f) = self.0.as_mut() {
            f(way, t);
        }
    }

    fn bytes(&mut self, way: Way, b: &[u8]) {
        if !b.is_empty() {
            self.hear(way, Traffic::Bytes(b));
        }
    }
}

/// A device at the far end of a serial line: bytes in, answer bytes out.
pub type ByteHandler<'a> = dyn FnMut(Instant, &[u8], &mut Vec<u8>) + 'a;

/// Serves a byte device on `link`. With `pace`, the line runs at its real
/// speed: a request is handled once its last character has arrived, and the
/// answer leaves one character time after another.
pub fn bytes(
    mut link: Box<dyn ByteLink>,
    device: &mut ByteHandler<'_>,
    clock: &dyn Clock,
    stop: &AtomicBool,
    pace: Option<Pace>,
    tap: &mut Tap,
) -> Result<(), LinkError> {
    let mut buf = [0u8; 256];
    let mut out = Vec::new();
    let mut rx_free = clock.now();
    let mut tx_free = clock.now();
    while !stop.load(Ordering::Relaxed) {
        let n = link.read(&mut buf, Duration::from_millis(20))?;
        tap.bytes(Way::FromClient, &buf[..n]);
        // Called on a quiet line too: time passes for whoever inspects the device.
        let mut at = clock.now();
        if let Some(p) = pace.filter(|_| n > 0) {
            at = at.max(rx_free) + p.char_time * n as u32;
            rx_free = at;
            sleep_until(clock, at);
        }
        device(at, &buf[..n], &mut out);
        tap.bytes(Way::ToClient, &out);
        match pace {
            None => link.write_all(&out)?,
            Some(p) => {
                // Character times on absolute instants from the end of the request: a late
                // wake-up delays one character, not every one after it.
                tx_free = tx_free.max(at);
                for b in &out {
                    tx_free += p.char_time;
                    sleep_until(clock, tx_free);
                    link.write_all(std::slice::from_ref(b))?;
                }
            }
        }
        out.clear();
    }
    Ok(())
}

/// Makes this thread's timed waits (and those of the threads it starts) end
/// within microseconds rather than Linux's default 50 µs timer slack: a CAN
/// frame at 1 Mbit/s lasts about 100 µs.
pub fn precise_timers() {
    #[cfg(target_os = "linux")]
    // SAFETY: PR_SET_TIMERSLACK takes the slack in ns and affects only this thread.
    unsafe {
        libc::prctl(libc::PR_SET_TIMERSLACK, 1_000 as libc::c_ulong);
    }
}

fn sleep_until(clock: &dyn Clock, t: Instant) {
    let now = clock.now();
    if t > now {
        clock.sleep(t - now);
    }
}

/// Faults for a served serial line (`axisctl sim --fault`); the default is a clean line.
#[derive(Default)]
pub struct Noise {
    pub faults: Option<ByteFaults>,
    pub trip: Option<Trip>,
}

impl Noise {
    /// Runs after the device at every turn of the serving loop (a quiet line
    /// too): trips devices that are due, then passes the answer through the
    /// faults and adds delayed answers that are due.
    fn apply(&mut self, now: Instant, out: &mut Vec<u8>) {
        if let Some(t) = self.trip.as_mut() {
            t.check(now);
        }
        if let Some(f) = self.faults.as_mut() {
            f.answer(now, out);
            f.due(now, out);
        }
    }
}

/// A serial device on a byte link: the PowerCube modules' RS232 side
/// ([`PowerCubeRs232`](super::bench::PowerCubeRs232)) or the PA-CONTROL's
/// online command port, with the fault noise on what it answers.
pub fn serial(
    link: Box<dyn ByteLink>,
    mut dev: impl ByteDevice,
    clock: Arc<dyn Clock>,
    stop: &AtomicBool,
    pace: Option<Pace>,
    mut noise: Noise,
    mut tap: Tap,
) -> Result<(), LinkError> {
    let mut device = |now, bytes: &[u8], out: &mut Vec<u8>| {
        dev.on_bytes(now, bytes, out);
        noise.apply(now, out);
    };
    self::bytes(link, &mut device, clock.as_ref(), stop, pace, &mut tap)
}

/// An slcan adapter on a byte link, with `client` as its view of the bus.
pub fn slcan(
    mut link: Box<dyn ByteLink>,
    mut client: MemCanLink,
    stop: &AtomicBool,
    mut tap: Tap,
) -> Result<(), LinkError> {
    let mut adapter = Adapter::new(AckStyle::default());
    let mut buf = [0u8; 512];
    let mut out = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        // With an emulated bitrate, wake when the frame on the bus ends, not a tick later.
        let n = link.read(&mut buf, client.until_next_due(TICK))?;
        adapter.handle_host_bytes(&buf[..n]);
        while let Some(frame) = adapter.poll_transmit() {
            tap.hear(Way::FromClient, Traffic::Can(&frame));
            client.send(&frame)?;
        }
        while let Some(frame) = client.recv(Duration::ZERO)? {
            tap.hear(Way::ToClient, Traffic::Can(&frame));
            adapter.bus_frame(&frame);
        }
        // One write for all lines: the host wakes once per burst, not once per line.
        out.clear();
        while let Some(bytes) = adapter.poll_output() {
            out.extend_from_slice(&bytes);
        }
        if !out.is_empty() {
            link.write_all(&out)?;
        }
    }
    Ok(())
}

/// Bridges a real CAN interface and the simulated bus.
pub fn bridge(
    mut ext: Box<dyn CanLink>,
    mut client: MemCanLink,
    stop: &AtomicBool,
    mut tap: Tap,
) -> Result<(), LinkError> {
    while !stop.load(Ordering::Relaxed) {
        if let Some(frame) = ext.recv(client.until_next_due(TICK))? {
            tap.hear(Way::FromClient, Traffic::Can(&frame));
            client.send(&frame)?;
        }
        while let Some(frame) = client.recv(Duration::ZERO)? {
            tap.hear(Way::ToClient, Traffic::Can(&frame));
            ext.send(&frame)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::SystemClock;
    use crate::link::serial::SerialLink;
    use crate::link::{pty, SerialFormat};
    use crate::sim::pac::PacController;
    use crate::sim::shared::lock;
    use std::sync::Mutex;

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
    }

    /// Reads until `n` EOTs (the end of `n` acknowledges) or 2 s pass.
    fn read_frames(link: &mut SerialLink, n: usize) -> Vec<u8> {
        let mut got = Vec::new();
        let deadline = std::time::Instant::now() + Duration::from_secs(2);
        let mut buf = [0u8; 64];
        while got.iter().filter(|b| **b == 0x04).count() < n && std::time::Instant::now() < deadline {
            let k = link.read(&mut buf, Duration::from_millis(50)).unwrap();
            got.extend_from_slice(&buf[..k]);
        }
        got
    }

    // Manual 3.4.3: start online mode over a real pty, as a client opens it
    // (9600 baud 7N1), answered with the printed acknowledge.
    #[test]
    fn pac_over_a_pty() {
        let (master, path) = pty::open_pair().unwrap();
        let clock: Arc<dyn Clock> = Arc::new(SystemClock);
        let controller = Arc::new(Mutex::new(PacController::new(3, clock.now())));
        let stop = Arc::new(AtomicBool::new(false));
        let server = {
            let (c, clock, stop) = (Arc::clone(&controller), Arc::clone(&clock), Arc::clone(&stop));
            std::thread::spawn(move || {
                serial(Box::new(master), c, clock, &stop, None, Noise::default(), Tap::default())
            })
        };
        let mut client = SerialLink::open(&path, 9600, SerialFormat::F7N1).unwrap();
        client.write_all(&hex("01 02 30 36 30 33 3B 30 3B 30 3B 30 03 31 34 04")).unwrap();
        assert_eq!(read_frames(&mut client, 1), hex("01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04"));
        assert_eq!(lock(&controller).status(), 31);
        // A poll repeats it; a register write comes back.
        client.write_all(&[0x04]).unwrap();
        client.write_all(b"\x01\x020906;5;0;12345\x030\x04").unwrap();
        let got = read_frames(&mut client, 2);
        assert_eq!(
            got,
            [&hex("01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04")[..], b"\x01\x020;1;31;0;0;12345\x039\x04"]
                .concat()
        );
        stop.store(true, Ordering::SeqCst);
        server.join().unwrap().unwrap();
        assert_eq!(lock(&controller).int_register(5), Some(12345));
    }
}
