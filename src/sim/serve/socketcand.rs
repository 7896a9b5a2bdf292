//! The bench's CAN bus served as a socketcand daemon serves a SocketCAN
//! interface: any number of TCP clients at once, each greeted with
//! `< hi >`, opening the one bus by name and switching to raw mode (see
//! [`crate::proto::socketcand`]). What one client sends, the devices and
//! every other client see, as on the daemon's host.
//!
//! Like the daemon: a bus that is not served is answered
//! `< error could not open bus >` and the connection closed; an unknown
//! command is answered `< error unknown command >`; frames are stamped
//! with the wall clock; a client's own frames are not sent back to it.

use std::io::{self, Write};
use std::net::{TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use super::{Tap, Traffic, Way, TICK};
use crate::link::mem::{MemBus, MemCanLink};
use crate::link::serial::read_fd;
use crate::link::{CanLink, LinkError};
use crate::proto::socketcand::{Decoder, Message, Stamp};

/// Links of clients that left, reused by the next ones: a bus client can
/// not be closed, and a new one per connection would grow without end.
type Pool = Arc<Mutex<Vec<MemCanLink>>>;

/// Serves `bus` under the name `bus_name` on `listener` until `stop`.
/// The bus keeps running between clients (the modules' watchdogs, events).
pub fn serve(
    listener: TcpListener,
    bus: MemBus,
    bus_name: &str,
    stop: &Arc<AtomicBool>,
    tap: Tap,
) -> Result<(), LinkError> {
    listener.set_nonblocking(true)?;
    let tap = Arc::new(Mutex::new(tap));
    let pool: Pool = Arc::default();
    // The daemon's host: its bus runs with or without clients.
    let mut host = bus.open();
    let mut clients = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                let link = pool.lock().unwrap_or_else(|e| e.into_inner()).pop().unwrap_or_else(|| bus.open());
                let client = Client { stream, link, bus_name: bus_name.to_string(), tap: Arc::clone(&tap) };
                let (pool, stop) = (Arc::clone(&pool), Arc::clone(stop));
                clients.push(std::thread::spawn(move || {
                    let mut c = client;
                    // A client that goes away ends its connection, not the server.
                    let _ = c.run(&stop);
                    c.drain();
                    pool.lock().unwrap_or_else(|e| e.into_inner()).push(c.link);
                }));
            }
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                while host.recv(Duration::ZERO)?.is_some() {}
                std::thread::sleep(TICK);
            }
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(LinkError::Io(e)),
        }
        clients.retain(|c: &std::thread::JoinHandle<()>| !c.is_finished());
    }
    for c in clients {
        let _ = c.join();
    }
    Ok(())
}

/// What a connection has selected so far.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    NoBus,
    Bcm,
    Raw,
}

struct Client {
    stream: TcpStream,
    link: MemCanLink,
    bus_name: String,
    tap: Arc<Mutex<Tap>>,
}

impl Client {
    fn hear(&self, way: Way, t: Traffic<'_>) {
        self.tap.lock().unwrap_or_else(|e| e.into_inner()).hear(way, t);
    }

    /// Frames queued for this link while it waited in the pool are not this client's.
    fn drain(&mut self) {
        while let Ok(Some(_)) = self.link.recv(Duration::ZERO) {}
    }

    fn run(&mut self, stop: &AtomicBool) -> Result<(), LinkError> {
        self.drain();
        self.stream.set_nodelay(true)?;
        self.stream.write_all(&Message::Hi.to_bytes())?;
        let mut decoder = Decoder::new();
        let mut mode = Mode::NoBus;
        let mut buf = [0u8; 4096];
        let mut out = Vec::new();
        while !stop.load(Ordering::Relaxed) {
            // Woken when the frame on the bus ends (ppoll, to the microsecond), not a tick later.
            match read_fd(self.stream.as_raw_fd(), &mut buf, self.link.until_next_due(TICK)) {
                Ok(n) => decoder.push(&buf[..n]),
                Err(LinkError::Closed) => return Ok(()),
                Err(e) => return Err(e),
            }
            out.clear();
            while let Some(m) = decoder.next_message() {
                // The daemon reports a syntax error only in its own log and reads on.
                let Ok(m) = m else { continue };
                match self.command(m, &mut mode, &mut out)? {
                    Next::Go => {}
                    Next::Close => {
                        self.stream.write_all(&out)?;
                        return Ok(());
                    }
                }
            }
            // One write for everything due: the client wakes once per burst.
            while let Some(frame) = self.link.recv(Duration::ZERO)? {
                if mode == Mode::Raw {
                    self.hear(Way::ToClient, Traffic::Can(&frame));
                    Message::Frame { frame, stamp: now_stamp() }.encode(&mut out);
                }
            }
            if !out.is_empty() {
                self.stream.write_all(&out)?;
            }
        }
        Ok(())
    }

    fn command(&mut self, m: Message, mode: &mut Mode, out: &mut Vec<u8>) -> Result<Next, LinkError> {
        match (m, *mode) {
            (Message::Open(bus), Mode::NoBus) => {
                if bus != self.bus_name {
                    Message::Error("could not open bus".into()).encode(out);
                    return Ok(Next::Close);
                }
                *mode = Mode::Bcm;
                Message::Ok.encode(out);
            }
            (Message::RawMode, Mode::Bcm | Mode::Raw) => {
                *mode = Mode::Raw;
                Message::Ok.encode(out);
            }
            (Message::Other(w), Mode::Raw) if w == "bcmmode" => {
                *mode = Mode::Bcm;
                Message::Ok.encode(out);
            }
            (Message::Echo, Mode::Bcm | Mode::Raw) => Message::Echo.encode(out),
            (Message::Send(frame), Mode::Bcm | Mode::Raw) => {
                self.hear(Way::FromClient, Traffic::Can(&frame));
                self.link.send(&frame)?;
            }
            _ => Message::Error("unknown command".into()).encode(out),
        }
        Ok(Next::Go)
    }
}

enum Next {
    Go,
    Close,
}

/// The wall clock, as the daemon stamps frames (SO_TIMESTAMP).
fn now_stamp() -> Stamp {
    let t = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default();
    Stamp { secs: t.as_secs(), micros: t.subsec_micros() }
}
