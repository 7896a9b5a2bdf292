//! `--log FILE`: every CAN frame in `candump -l` format, serial traffic as
//! timestamped hex lines, appended to one file.
//!
//! ```text
//! (1700000000.123456) can0 0F1#01
//! (1700000000.123789) tx 02 06 21 01 28 03
//! (1700000000.131002) rx 02 08 23 00 2B 03
//! ```
//!
//! CAN lines carry no direction, exactly as `candump -l` writes them, so
//! `canplayer` and `log2asc` read the file as it is. The interface column is the
//! SocketCAN interface for `socketcan:` links, `slcan0` for `slcan:` adapters (the
//! name `slcand` would give the same adapter) and `sim0` for the simulated bench:
//! see [`log_iface`]. Timestamps are wall-clock time, microseconds.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use super::{ByteLink, CanLink, LinkError, LinkSpec};
use crate::proto::can_error::{CanEvent, ErrorFrame};
use crate::proto::candump::{format_candump_error, format_candump_line};
use crate::proto::CanFrame;

/// Which way serial bytes went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    Tx,
    Rx,
}

impl Direction {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Tx => "tx",
            Self::Rx => "rx",
        }
    }
}

/// The interface name written in CAN log lines for a link.
pub fn log_iface(spec: &LinkSpec) -> String {
    match spec {
        LinkSpec::SocketCan { iface } => iface.clone(),
        LinkSpec::Slcan { .. } => "slcan0".into(),
        // The daemon's own name for the bus, as candump on that host shows it.
        LinkSpec::Socketcand { bus, .. } => bus.clone(),
        LinkSpec::Sim(_) => "sim0".into(),
        LinkSpec::Serial { .. } => "serial0".into(),
    }
}

/// An append-only traffic log; clones write to the same file.
#[derive(Clone)]
pub struct TrafficLog {
    out: Arc<Mutex<Box<dyn Write + Send>>>,
    iface: String,
}

impl std::fmt::Debug for TrafficLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TrafficLog").field("iface", &self.iface).finish_non_exhaustive()
    }
}

impl TrafficLog {
    /// Opens `path` for appending (creating it), naming CAN frames' interface `iface`.
    /// `-` is standard output, as for every file argument.
    pub fn append(path: &Path, iface: &str) -> Result<Self, LinkError> {
        if path == Path::new("-") {
            return Ok(Self::from_writer(std::io::stdout(), iface));
        }
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(|source| LinkError::Open { path: path.display().to_string(), source })?;
        Ok(Self::from_writer(file, iface))
    }

    /// Logs to any writer. Each line is one `write_all`, so an unbuffered file in
    /// append mode gets whole lines even if the process dies.
    pub fn from_writer(w: impl Write + Send + 'static, iface: &str) -> Self {
        Self { out: Arc::new(Mutex::new(Box::new(w))), iface: iface.into() }
    }

    pub fn iface(&self) -> &str {
        &self.iface
    }

    /// One `candump -l` line for `frame`, timestamped now.
    pub fn can_frame(&self, frame: &CanFrame) -> Result<(), LinkError> {
        let (secs, micros) = now();
        self.line(format_candump_line(secs, micros, &self.iface, frame))
    }

    /// One candump line for an error frame, as `candump -l -e` writes it.
    pub fn can_error(&self, frame: &ErrorFrame) -> Result<(), LinkError> {
        let (secs, micros) = now();
        self.line(format_candump_error(secs, micros, &self.iface, frame))
    }

    /// One hex line for a chunk of serial bytes, timestamped now. Empty chunks are skipped.
    pub fn bytes(&self, dir: Direction, bytes: &[u8]) -> Result<(), LinkError> {
        if bytes.is_empty() {
            return Ok(());
        }
        let (secs, micros) = now();
        self.line(format_bytes_line(secs, micros, dir, bytes))
    }

    /// [`Self::bytes`] with the interface before the direction, for a log of
    /// several serial lines (`axisctl sim --log`): `(secs.micros) serial1 tx 02 06`.
    pub fn bytes_on_iface(&self, dir: Direction, bytes: &[u8]) -> Result<(), LinkError> {
        if bytes.is_empty() {
            return Ok(());
        }
        let (secs, micros) = now();
        let line = format_bytes_line(secs, micros, dir, bytes);
        let (time, rest) = line.split_once(' ').unwrap_or((&line, ""));
        self.line(format!("{time} {} {rest}", self.iface))
    }

    fn line(&self, mut line: String) -> Result<(), LinkError> {
        line.push('\n');
        // A panic elsewhere while holding the lock leaves the file usable.
        let mut out = self.out.lock().unwrap_or_else(|e| e.into_inner());
        out.write_all(line.as_bytes())?;
        out.flush()?;
        Ok(())
    }

    /// Logs without failing the traffic: a log that cannot be written (a
    /// full disk) must never stand between the tool and a halt frame. The
    /// failure goes to the motion supervisor, which halts a supervised
    /// motion on it and has it reported once the device is safe.
    fn record(&self, written: Result<(), LinkError>) {
        if let Err(e) = written {
            let io = match e {
                LinkError::Io(io) => io,
                other => std::io::Error::other(other.to_string()),
            };
            crate::clock::stop::note_log_failure(&io);
        }
    }
}

/// `(secs.micros) tx 02 06 21`
pub fn format_bytes_line(secs: u64, micros: u32, dir: Direction, bytes: &[u8]) -> String {
    let mut s = format!("({secs}.{micros:06}) {}", dir.as_str());
    for b in bytes {
        s.push_str(&format!(" {b:02X}"));
    }
    s
}

fn now() -> (u64, u32) {
    let t = SystemTime::now().duration_since(UNIX_EPOCH).unwrap_or_default();
    (t.as_secs(), t.subsec_micros())
}

/// A [`CanLink`] that logs every frame sent and received.
#[derive(Debug)]
pub struct LoggedCanLink<L> {
    inner: L,
    log: TrafficLog,
}

impl<L> LoggedCanLink<L> {
    pub fn new(inner: L, log: TrafficLog) -> Self {
        Self { inner, log }
    }

    pub fn into_inner(self) -> L {
        self.inner
    }
}

impl<L: CanLink> CanLink for LoggedCanLink<L> {
    fn send(&mut self, frame: &CanFrame) -> Result<(), LinkError> {
        self.inner.send(frame)?;
        self.log.record(self.log.can_frame(frame));
        Ok(())
    }

    fn send_many(&mut self, frames: &[CanFrame]) -> Result<(), LinkError> {
        self.inner.send_many(frames)?;
        self.log.record(frames.iter().try_for_each(|f| self.log.can_frame(f)));
        Ok(())
    }

    fn recv(&mut self, timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
        let got = self.inner.recv(timeout)?;
        if let Some(f) = &got {
            self.log.record(self.log.can_frame(f));
        }
        Ok(got)
    }

    fn report_errors(&mut self) -> bool {
        self.inner.report_errors()
    }

    fn recv_event(&mut self, timeout: Duration) -> Result<Option<CanEvent>, LinkError> {
        let got = self.inner.recv_event(timeout)?;
        match &got {
            Some(CanEvent::Frame(f)) => self.log.record(self.log.can_frame(f)),
            Some(CanEvent::Error(e)) => self.log.record(self.log.can_error(e)),
            None => {}
        }
        Ok(got)
    }

    fn round_trip(&self) -> Duration {
        self.inner.round_trip()
    }

    fn stamp(&self) -> Option<Duration> {
        self.inner.stamp()
    }
}

/// A [`ByteLink`] that logs every chunk written and read.
#[derive(Debug)]
pub struct LoggedByteLink<L> {
    inner: L,
    log: TrafficLog,
}

impl<L> LoggedByteLink<L> {
    pub fn new(inner: L, log: TrafficLog) -> Self {
        Self { inner, log }
    }

    pub fn into_inner(self) -> L {
        self.inner
    }
}

impl<L: ByteLink> ByteLink for LoggedByteLink<L> {
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.inner.write_all(bytes)?;
        self.log.record(self.log.bytes(Direction::Tx, bytes));
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], timeout: Duration) -> Result<usize, LinkError> {
        let n = self.inner.read(buf, timeout)?;
        self.log.record(self.log.bytes(Direction::Rx, &buf[..n]));
        Ok(n)
    }

    fn clear_input(&mut self) -> Result<(), LinkError> {
        self.inner.clear_input()
    }
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;

    use super::*;
    use crate::proto::candump::parse_candump_line;

    /// A writer whose bytes the test can read back.
    #[derive(Clone, Default)]
    struct Shared(Arc<Mutex<Vec<u8>>>);

    impl Write for Shared {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.lock().unwrap().extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Shared {
        fn lines(&self) -> Vec<String> {
            String::from_utf8(self.0.lock().unwrap().clone()).unwrap().lines().map(str::to_string).collect()
        }
    }

    /// Loops sent frames back, answering each on id - 0x40.
    struct Loop(VecDeque<CanFrame>);

    impl CanLink for Loop {
        fn send(&mut self, f: &CanFrame) -> Result<(), LinkError> {
            self.0.push_back(CanFrame::new(f.id() - 0x40, f.data()).unwrap());
            Ok(())
        }
        fn recv(&mut self, _timeout: Duration) -> Result<Option<CanFrame>, LinkError> {
            Ok(self.0.pop_front())
        }
    }

    struct Bytes(VecDeque<u8>);

    impl ByteLink for Bytes {
        fn write_all(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
            self.0.extend(bytes.iter().map(|b| b ^ 0xff));
            Ok(())
        }
        fn read(&mut self, buf: &mut [u8], _timeout: Duration) -> Result<usize, LinkError> {
            let n = self.0.len().min(buf.len());
            for slot in &mut buf[..n] {
                *slot = self.0.pop_front().unwrap();
            }
            Ok(n)
        }
        fn clear_input(&mut self) -> Result<(), LinkError> {
            self.0.clear();
            Ok(())
        }
    }

    /// A log on a full disk.
    struct Full;

    impl Write for Full {
        fn write(&mut self, _buf: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::from_raw_os_error(libc::ENOSPC))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// A full disk must not stop a frame (the halt above all): the traffic
    /// goes on and the failure is left for the supervisor to report.
    #[test]
    fn a_log_that_cannot_be_written_never_stops_the_traffic() {
        let mut can = LoggedCanLink::new(Loop(VecDeque::new()), TrafficLog::from_writer(Full, "can0"));
        let halt = CanFrame::new(0x0E3, &[0x01]).unwrap();
        can.send(&halt).expect("the frame goes out");
        can.send_many(std::slice::from_ref(&halt)).expect("the frames go out");
        assert!(can.recv(Duration::ZERO).expect("the answer comes in").is_some());
        let mut serial = LoggedByteLink::new(Bytes(VecDeque::new()), TrafficLog::from_writer(Full, "serial0"));
        serial.write_all(b"\x02").expect("the bytes go out");
        let mut buf = [0u8; 4];
        assert_eq!(serial.read(&mut buf, Duration::ZERO).expect("the bytes come in"), 1);
        assert!(crate::clock::stop::log_failure().is_some(), "the failure is kept for the report");
    }

    #[test]
    fn can_frames_are_logged_as_candump_lines_both_ways() {
        let out = Shared::default();
        let mut link = LoggedCanLink::new(Loop(VecDeque::new()), TrafficLog::from_writer(out.clone(), "can0"));
        let home = CanFrame::new(0x0F1, &[0x01]).unwrap();
        link.send(&home).unwrap();
        assert_eq!(link.recv(Duration::ZERO).unwrap(), Some(CanFrame::new(0x0B1, &[0x01]).unwrap()));
        assert_eq!(link.recv(Duration::ZERO).unwrap(), None);
        let lines = out.lines();
        assert_eq!(lines.len(), 2, "{lines:?}");
        let (t0, iface, f0) = parse_candump_line(&lines[0]).unwrap();
        assert_eq!((iface.as_str(), f0), ("can0", home));
        assert!(lines[0].ends_with(") can0 0F1#01"), "{}", lines[0]);
        let (t1, _, f1) = parse_candump_line(&lines[1]).unwrap();
        assert_eq!(f1.to_string(), "0B1#01");
        let wall = SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64();
        assert!(t0 <= t1 && (wall - t1).abs() < 60.0, "{t0} {t1} {wall}");
    }

    #[test]
    fn serial_chunks_are_logged_as_hex_lines() {
        let out = Shared::default();
        let mut link = LoggedByteLink::new(Bytes(VecDeque::new()), TrafficLog::from_writer(out.clone(), "serial0"));
        link.write_all(&[0x02, 0x06, 0x21, 0x01, 0x28, 0x03]).unwrap();
        let mut buf = [0u8; 4];
        assert_eq!(link.read(&mut buf, Duration::ZERO).unwrap(), 4);
        assert_eq!(link.read(&mut buf, Duration::ZERO).unwrap(), 2);
        assert_eq!(link.read(&mut buf, Duration::ZERO).unwrap(), 0);
        let lines = out.lines();
        assert_eq!(lines.len(), 3, "empty reads are not logged: {lines:?}");
        assert!(lines[0].ends_with(") tx 02 06 21 01 28 03"), "{}", lines[0]);
        assert!(lines[1].ends_with(") rx FD F9 DE FE"), "{}", lines[1]);
        assert!(lines[2].ends_with(") rx D7 FC"), "{}", lines[2]);
        assert!(lines[0].starts_with('(') && lines[0].find(") tx").unwrap() > 17);
        assert_eq!(format_bytes_line(1_700_000_000, 123_456, Direction::Tx, &[2, 6]), "(1700000000.123456) tx 02 06");
    }

    #[test]
    fn log_file_is_appended_not_truncated() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("traffic.log");
        let f = CanFrame::new(0x0F1, &[1]).unwrap();
        TrafficLog::append(&path, "slcan0").unwrap().can_frame(&f).unwrap();
        TrafficLog::append(&path, "slcan0").unwrap().can_frame(&f).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 2);
        assert!(text.lines().all(|l| parse_candump_line(l).unwrap().1 == "slcan0"));
        let err = TrafficLog::append(dir.path(), "can0").unwrap_err();
        assert!(matches!(&err, LinkError::Open { path, .. } if path == &dir.path().display().to_string()), "{err:?}");
    }

    #[test]
    fn iface_names() {
        let name = |s: &str| log_iface(&s.parse().unwrap());
        assert_eq!(name("socketcan:vcan3"), "vcan3");
        assert_eq!(name("slcan:/dev/ttyACM0"), "slcan0");
        assert_eq!(name("sim"), "sim0");
    }
}
