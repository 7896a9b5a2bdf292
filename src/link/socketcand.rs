//! A bus of a socketcand daemon (linux-can/socketcand) as a [`CanLink`]:
//! a TCP connection in raw mode (see [`crate::proto::socketcand`]).
//!
//! Opening connects (a refused connection fails at once, an unanswered one
//! after [`CONNECT`]), waits for `< hi >`, opens the bus and switches to raw
//! mode, each answer awaited for at most [`HANDSHAKE`]; then it measures the
//! round trip with `< echo >` unless the link gives it (`?rtt=MS`). The
//! sessions add [`CanLink::round_trip`] to their answer timeouts, so a slow
//! network is not taken for a silent device.
//!
//! TCP has no line noise: bytes that are no socketcand message mean the far
//! end is something else (or broken), and fail the link at once rather
//! than being skipped. A closed connection is [`LinkError::Remote`].

use std::io::{self, Write};
use std::net::{Shutdown, SocketAddr, TcpStream, ToSocketAddrs};
use std::os::fd::AsRawFd;
use std::time::{Duration, Instant};

use super::serial::read_fd;
use super::{CanLink, LinkError};
use crate::proto::socketcand::{Decoder, Message, Stamp};
use crate::proto::CanFrame;

/// How long a connection may take to be accepted.
pub const CONNECT: Duration = Duration::from_secs(3);
/// How long the daemon may take to answer each step of the open.
pub const HANDSHAKE: Duration = Duration::from_secs(2);
/// Echo round trips measured at the open; the slowest counts.
const ECHOES: u32 = 4;
/// The measured round trip is doubled for the timeouts (a network's
/// round trip varies), and is at least this.
const MIN_ALLOWANCE: Duration = Duration::from_millis(1);

/// An open raw-mode connection to one bus of a daemon.
pub struct SocketcandLink {
    stream: TcpStream,
    decoder: Decoder,
    /// `HOST:PORT/BUS` as given, for messages.
    name: String,
    round_trip: Duration,
    /// The daemon's stamp of the last frame received.
    last_stamp: Option<Stamp>,
    /// Messages received that carry no frame (error frames, statistics).
    skipped: u64,
    out: Vec<u8>,
}

impl std::fmt::Debug for SocketcandLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SocketcandLink").field("name", &self.name).field("round_trip", &self.round_trip).finish()
    }
}

/// Connects to `host:port`, opens `bus` in raw mode and settles the round
/// trip: `rtt` as given, or measured.
pub fn open(host: &str, port: u16, bus: &str, rtt: Option<Duration>) -> Result<SocketcandLink, LinkError> {
    let addr = if host.contains(':') { format!("[{host}]:{port}") } else { format!("{host}:{port}") };
    let stream = connect(&addr)?;
    let mut link = SocketcandLink {
        stream,
        decoder: Decoder::new(),
        name: format!("socketcand at {addr}/{bus}"),
        round_trip: Duration::ZERO,
        last_stamp: None,
        skipped: 0,
        out: Vec::new(),
    };
    link.handshake(bus)?;
    link.round_trip = match rtt {
        Some(r) => r,
        None => link.measure()?,
    };
    Ok(link)
}

fn connect(addr: &str) -> Result<TcpStream, LinkError> {
    let open_err = |source| LinkError::Open { path: addr.to_string(), source };
    let addrs: Vec<SocketAddr> = addr.to_socket_addrs().map_err(open_err)?.collect();
    let mut last = io::Error::new(io::ErrorKind::NotFound, "the host name has no address");
    for a in &addrs {
        match TcpStream::connect_timeout(a, CONNECT) {
            Ok(s) => {
                // One small message per frame: sent at once, not gathered.
                s.set_nodelay(true).map_err(open_err)?;
                return Ok(s);
            }
            Err(e) => last = e,
        }
    }
    let why = match last.kind() {
        io::ErrorKind::ConnectionRefused => "connection refused: is socketcand running there, on that port?",
        io::ErrorKind::TimedOut => "no answer to the connection: host down or port filtered?",
        _ => return Err(open_err(last)),
    };
    Err(open_err(io::Error::new(last.kind(), format!("{why} ({last})"))))
}

impl SocketcandLink {
    /// `< hi >`, then `< open BUS >` and `< rawmode >`, each answered `< ok >`.
    fn handshake(&mut self, bus: &str) -> Result<(), LinkError> {
        match self.expect("the greeting")? {
            Message::Hi => {}
            other => return Err(self.remote(format!("greeted with {other:?} instead of < hi >: not socketcand?"))),
        }
        self.write(&Message::Open(bus.to_string()))?;
        match self.expect("the bus open")? {
            Message::Ok => {}
            Message::Error(why) => {
                return Err(self.remote(format!(
                    "refused to open bus {bus}: {why} (is {bus} in the daemon's -i list? socketcand -i {bus})"
                )))
            }
            other => return Err(self.remote(format!("answered the bus open with {other:?}"))),
        }
        self.write(&Message::RawMode)?;
        match self.expect("raw mode")? {
            Message::Ok => Ok(()),
            other => Err(self.remote(format!("answered < rawmode > with {other:?}"))),
        }
    }

    /// The next message within [`HANDSHAKE`]; frames that arrive in
    /// between (raw mode is on from the `< ok >`) are stale, dropped.
    fn expect(&mut self, what: &str) -> Result<Message, LinkError> {
        let deadline = Instant::now() + HANDSHAKE;
        loop {
            match self.next_message(deadline)? {
                Some(Message::Frame { .. }) => {}
                Some(m) => return Ok(m),
                None => return Err(self.remote(format!("did not answer {what} within {} s", HANDSHAKE.as_secs()))),
            }
        }
    }

    /// The slowest of [`ECHOES`] echo round trips, doubled. Any answer to
    /// the echo counts: an old daemon's `< error unknown command >` as well.
    fn measure(&mut self) -> Result<Duration, LinkError> {
        let mut slowest = Duration::ZERO;
        for _ in 0..ECHOES {
            let t0 = Instant::now();
            self.write(&Message::Echo)?;
            self.expect("< echo >")?;
            slowest = slowest.max(t0.elapsed());
        }
        Ok((slowest * 2).max(MIN_ALLOWANCE))
    }

    /// The daemon's stamp of the last frame received.
    pub fn last_stamp(&self) -> Option<Stamp> {
        self.last_stamp
    }

    /// Well-formed messages received that carry no data frame.
    pub fn skipped(&self) -> u64 {
        self.skipped
    }

    fn remote(&self, what: String) -> LinkError {
        LinkError::Remote(format!("{}: {what}", self.name))
    }

    fn write(&mut self, m: &Message) -> Result<(), LinkError> {
        self.out.clear();
        m.encode(&mut self.out);
        self.flush_out()
    }

    fn flush_out(&mut self) -> Result<(), LinkError> {
        match self.stream.write_all(&self.out) {
            Ok(()) => Ok(()),
            Err(e) => Err(self.io_error(e)),
        }
    }

    fn io_error(&self, e: io::Error) -> LinkError {
        match e.kind() {
            io::ErrorKind::BrokenPipe
            | io::ErrorKind::ConnectionReset
            | io::ErrorKind::ConnectionAborted
            | io::ErrorKind::UnexpectedEof => self.remote(format!("connection lost ({e})")),
            _ => LinkError::Io(e),
        }
    }

    /// The next message, reading until `deadline`; `None` when none came.
    fn next_message(&mut self, deadline: Instant) -> Result<Option<Message>, LinkError> {
        loop {
            match self.decoder.next_message() {
                Some(Ok(m)) => return Ok(Some(m)),
                Some(Err(e)) => return Err(self.remote(format!("sent what is no socketcand message ({e})"))),
                None => {}
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if !self.fill(left)? {
                return Ok(None);
            }
        }
    }

    /// Reads what has come within `timeout`; false when nothing did. The
    /// wait is a ppoll to the microsecond: a socket's own receive timeout
    /// counts in scheduler ticks (1 to 4 ms), longer than a whole burst of
    /// answers at 1 Mbit/s.
    fn fill(&mut self, timeout: Duration) -> Result<bool, LinkError> {
        let mut buf = [0u8; 4096];
        match read_fd(self.stream.as_raw_fd(), &mut buf, timeout) {
            Ok(0) => Ok(false),
            Ok(n) => {
                self.decoder.push(&buf[..n]);
                Ok(true)
            }
            Err(LinkError::Closed) => Err(self.remote("closed the connection".into())),
            Err(LinkError::Io(e)) => Err(self.io_error(e)),
            Err(e) => Err(e),
        }
    }
}

impl CanLink for SocketcandLink {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.send_many(std::slice::from_ref(frame))
    }

    /// One write for the burst: it leaves in as few TCP segments as fit.
    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.out.clear();
        for f in frames {
            Message::Send(*f).encode(&mut self.out);
        }
        self.flush_out()
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let deadline = Instant::now() + timeout;
        while let Some(m) = self.next_message(deadline)? {
            match m {
                Message::Frame { frame, stamp } => {
                    self.last_stamp = Some(stamp);
                    return Ok(Some(frame));
                }
                // Error frames, statistics, a late echo: nothing a command waits for.
                _ => self.skipped += 1,
            }
        }
        Ok(None)
    }

    fn round_trip(&self) -> Duration {
        self.round_trip
    }

    fn stamp(&self) -> Option<Duration> {
        self.last_stamp.map(|s| Duration::new(s.secs, s.micros.min(999_999) * 1000))
    }
}

impl Drop for SocketcandLink {
    fn drop(&mut self) {
        // The daemon closes the bus when the client goes; say goodbye at once.
        let _ = self.stream.shutdown(Shutdown::Both);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::net::TcpListener;
    use std::thread;

    /// A scripted daemon: answers each message the client sends with the
    /// next reply of `replies` (after the greeting, sent at connect), and
    /// hands back what it read.
    fn daemon(greeting: &'static [u8], replies: Vec<&'static [u8]>) -> (u16, thread::JoinHandle<Vec<u8>>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let h = thread::spawn(move || {
            let (mut s, _) = listener.accept().unwrap();
            s.write_all(greeting).unwrap();
            let mut got = Vec::new();
            let mut replies = replies.into_iter();
            let mut buf = [0u8; 256];
            s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            loop {
                let n = match s.read(&mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => n,
                };
                got.extend_from_slice(&buf[..n]);
                for _ in buf[..n].iter().filter(|b| **b == b'>') {
                    match replies.next() {
                        Some(r) if r == b"CLOSE" => return got,
                        Some(r) => s.write_all(r).unwrap(),
                        None => {}
                    }
                }
            }
            got
        });
        (port, h)
    }

    const OPEN_OK: [&[u8]; 2] = [b"< ok >", b"< ok >"];

    #[test]
    fn opens_measures_and_exchanges_frames() {
        let mut replies = OPEN_OK.to_vec();
        replies.extend([&b"< echo >"[..], b"< echo >", b"< echo >", b"< error unknown command >"]);
        replies.push(b"< frame 0A3 12.000345 0A3C0000803F >< frame 1AAAAAAA 12.5 >");
        let (port, d) = daemon(b"< hi >", replies);
        let mut link = open("127.0.0.1", port, "can0", None).unwrap();
        assert!(link.round_trip() >= MIN_ALLOWANCE && link.round_trip() < Duration::from_secs(2), "{link:?}");
        link.send(&CanFrame::new(0x0E3, &[0x0A, 0x3C]).unwrap()).unwrap();
        assert_eq!(link.recv(Duration::from_secs(2)).unwrap(), CanFrame::new(0x0A3, &[0x0A, 0x3C, 0, 0, 0x80, 0x3F]));
        assert_eq!(link.last_stamp(), Some(Stamp { secs: 12, micros: 345 }));
        assert_eq!(link.recv(Duration::from_secs(2)).unwrap(), CanFrame::new_extended(0x1AAA_AAAA, &[]));
        drop(link);
        let sent = String::from_utf8(d.join().unwrap()).unwrap();
        assert_eq!(
            sent, "< open can0 >< rawmode >< echo >< echo >< echo >< echo >< send 0E3 2 0A 3C >",
            "what the client sent"
        );
    }

    #[test]
    fn a_given_rtt_is_not_measured() {
        let (port, d) = daemon(b"< hi >", OPEN_OK.to_vec());
        let link = open("127.0.0.1", port, "can0", Some(Duration::from_millis(40))).unwrap();
        assert_eq!(link.round_trip(), Duration::from_millis(40));
        drop(link);
        assert_eq!(d.join().unwrap(), b"< open can0 >< rawmode >");
    }

    #[test]
    fn an_unknown_bus_is_a_clear_error() {
        let (port, _d) = daemon(b"< hi >", vec![b"< error could not open bus >", b"CLOSE"]);
        let err = open("127.0.0.1", port, "can7", None).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, LinkError::Remote(_)), "{err:?}");
        assert!(text.contains("refused to open bus can7: could not open bus") && text.contains("-i can7"), "{text}");
    }

    #[test]
    fn something_else_than_socketcand_is_a_clear_error() {
        let (port, _d) = daemon(b"SSH-2.0-OpenSSH_9.6\r\n", vec![]);
        let err = open("127.0.0.1", port, "can0", None).unwrap_err();
        assert!(err.to_string().contains("no socketcand message"), "{err}");
        let (port, _d) = daemon(b"", vec![b"CLOSE"]);
        let err = open("127.0.0.1", port, "can0", None).unwrap_err();
        assert!(err.to_string().contains("did not answer the greeting"), "{err}");
    }

    #[test]
    fn a_refused_connection_fails_at_once_naming_the_address() {
        let port = TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let t0 = Instant::now();
        let err = open("127.0.0.1", port, "can0", None).unwrap_err();
        assert!(t0.elapsed() < Duration::from_secs(1), "{:?}", t0.elapsed());
        let LinkError::Open { path, source } = &err else { panic!("{err:?}") };
        assert_eq!(path, &format!("127.0.0.1:{port}"));
        assert_eq!(source.kind(), io::ErrorKind::ConnectionRefused);
        assert!(err.to_string().contains("is socketcand running there"), "{err}");
    }

    #[test]
    fn a_closed_connection_and_garbage_fail_the_link() {
        let mut replies = OPEN_OK.to_vec();
        replies.push(b"CLOSE");
        let (port, _d) = daemon(b"< hi >", replies);
        let mut link = open("127.0.0.1", port, "can0", Some(Duration::ZERO)).unwrap();
        link.send(&CanFrame::new(0x0E3, &[]).unwrap()).unwrap();
        let err = link.recv(Duration::from_secs(5)).unwrap_err();
        assert!(err.to_string().contains("closed the connection"), "{err}");

        let mut replies = OPEN_OK.to_vec();
        replies.push(b"< frame 0A3 1.0 >\x00\x01garbage");
        let (port, _d) = daemon(b"< hi >", replies);
        let mut link = open("127.0.0.1", port, "can0", Some(Duration::ZERO)).unwrap();
        link.send(&CanFrame::new(0x0E3, &[]).unwrap()).unwrap();
        assert_eq!(link.recv(Duration::from_secs(2)).unwrap(), CanFrame::new(0x0A3, &[]));
        let err = link.recv(Duration::from_secs(2)).unwrap_err();
        assert!(err.to_string().contains("no socketcand message"), "{err}");
    }
}
