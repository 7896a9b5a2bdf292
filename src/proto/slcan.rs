//! The Lawicel / slcan ASCII protocol, sans-IO, both sides of the serial line.
//!
//! Host → adapter: one command per line, terminated by CR (`S8\r`, `O\r`,
//! `t0F1101\r`, ...), see [`Command`].
//! Adapter → host: CR alone means OK, BEL (0x07) alone means error; received
//! frames come as `tIIIL<data>\r` / `TIIIIIIIIL<data>\r`, optionally followed by
//! a 4-digit timestamp when the adapter's timestamps are on; Lawicel adapters
//! acknowledge a transmit with `z\r` / `Z\r`. [`LineDecoder`] turns that byte
//! stream into [`SlcanEvent`]s.
//!
//! [`Adapter`] is the other end: the state machine of an slcan adapter, used by
//! the simulator to serve a bus on a pseudo-terminal. What real adapters answer
//! differs, so it can imitate the three families in use ([`AckStyle`]):
//! Lawicel CANUSB (`\r`, `z\r`/`Z\r`, BEL; the reference protocol), CANable 2.x
//! firmware (`\r` for every accepted command, BEL for errors) and CANable 1.x
//! firmware (no acknowledges at all). python-can's `slcan` interface and Linux
//! `slcand` ignore every line that is not a frame, so all three work with them.

use std::collections::VecDeque;
use std::fmt;

use super::can_error::ErrorFrame;
use super::{CanFrame, DecodeError};

pub const CR: u8 = b'\r';
pub const BEL: u8 = 0x07;

/// Longest line either side may send: `T` + 8 id + 1 DLC + 16 data + 4
/// timestamp digits is 30; some firmwares answer `V` with a longer banner.
/// Anything longer than this is garbage and is skipped up to the next CR.
pub const MAX_LINE: usize = 96;

/// What a host sends before its first command to re-synchronise with an adapter
/// that may hold half a line from a client that died mid-write: the CRs end that
/// line (the adapter rejects it, BEL, or ignores it), and `V`, which every
/// firmware answers, marks where the stale replies end: everything read before
/// the `V` line belongs to the dead client.
pub const RESYNC: &[u8] = b"\r\r\rV\r";

/// The slcan bitrates S0..S8.
pub const SLCAN_BITRATES: [u32; 9] = [10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000];

/// Lawicel status flags, the `xx` of the `Fxx\r` reply to `F` (CANUSB manual, "F[CR]").
pub mod status {
    pub const RX_FIFO_FULL: u8 = 0x01;
    pub const TX_FIFO_FULL: u8 = 0x02;
    pub const ERROR_WARNING: u8 = 0x04;
    pub const DATA_OVERRUN: u8 = 0x08;
    pub const ERROR_PASSIVE: u8 = 0x20;
    pub const ARBITRATION_LOST: u8 = 0x40;
    pub const BUS_ERROR: u8 = 0x80;

    /// Every flag with its name, for decoding and display.
    pub const FLAGS: [(u8, &str); 7] = [
        (RX_FIFO_FULL, "RX_FIFO_FULL"),
        (TX_FIFO_FULL, "TX_FIFO_FULL"),
        (ERROR_WARNING, "ERROR_WARNING"),
        (DATA_OVERRUN, "DATA_OVERRUN"),
        (ERROR_PASSIVE, "ERROR_PASSIVE"),
        (ARBITRATION_LOST, "ARBITRATION_LOST"),
        (BUS_ERROR, "BUS_ERROR"),
    ];

    /// Names of the flags set in `flags`.
    pub fn names(flags: u8) -> Vec<&'static str> {
        FLAGS.iter().filter(|(bit, _)| flags & bit != 0).map(|&(_, name)| name).collect()
    }
}

/// A remote transmission request: no data, only an id and a DLC.

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RemoteFrame {
    pub id: u32,
    pub extended: bool,
    pub dlc: u8,
}

/// A bitrate that has no `S0`..`S8` code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("bitrate {0} bit/s has no slcan code (S0..S8 are {SLCAN_BITRATES:?})")]
pub struct UnsupportedBitrate(pub u32);

/// A host → adapter command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// `Sn`: bitrate [`SLCAN_BITRATES`]`[n]`, only while the channel is closed.
    SetBitrate(u8),
    /// `O`: open the channel.
    Open,
    /// `L`: open the channel listen-only.
    ListenOnly,
    /// `C`: close the channel.
    Close,
    /// `F`: read (and clear) the status flags.
    ReadStatus,
    /// `V`: hardware and software version.
    Version,
    /// `N`: serial number.
    SerialNumber,
    /// `t` / `T`: transmit a data frame.
    Transmit(CanFrame),
    /// `r` / `R`: transmit a remote frame.
    TransmitRemote(RemoteFrame),
}

impl Command {
    /// `S<n>` for a bitrate of [`SLCAN_BITRATES`].
    pub fn set_bitrate(bitrate: u32) -> Result<Self, UnsupportedBitrate> {
        SLCAN_BITRATES
            .iter()
            .position(|&b| b == bitrate)
            .map(|i| Self::SetBitrate(i as u8))
            .ok_or(UnsupportedBitrate(bitrate))
    }

    /// Appends the command line, CR included.
    pub fn encode(&self, out: &mut Vec<u8>) {
        match self {
            Self::SetBitrate(n) => {
                out.push(b'S');
                out.push(hex_digit(*n));
            }
            Self::Open => out.push(b'O'),
            Self::ListenOnly => out.push(b'L'),
            Self::Close => out.push(b'C'),
            Self::ReadStatus => out.push(b'F'),
            Self::Version => out.push(b'V'),
            Self::SerialNumber => out.push(b'N'),
            Self::Transmit(f) => {
                encode_frame(f, out);
                return;
            }
            Self::TransmitRemote(r) => {
                encode_head(if r.extended { b'R' } else { b'r' }, r.id, r.extended, r.dlc, out);
            }
        }
        out.push(CR);
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut v = Vec::new();
        self.encode(&mut v);
        v
    }

    /// Parses one command line, without its CR.
    pub fn parse(line: &[u8]) -> Result<Self, DecodeError> {
        let (&kind, rest) = line.split_first().ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        let single = |cmd: Self| if rest.is_empty() { Ok(cmd) } else { Err(malformed("command", line)) };
        match kind {
            b'S' => match rest {
                [d @ b'0'..=b'8'] => Ok(Self::SetBitrate(d - b'0')),
                _ => Err(malformed("bitrate command", line)),
            },
            b'O' => single(Self::Open),
            b'L' => single(Self::ListenOnly),
            b'C' => single(Self::Close),
            b'F' => single(Self::ReadStatus),
            b'V' => single(Self::Version),
            b'N' => single(Self::SerialNumber),
            b't' | b'T' => Ok(Self::Transmit(parse_data_frame(line, false)?)),
            b'r' | b'R' => Ok(Self::TransmitRemote(parse_remote_frame(line, false)?)),
            other => Err(DecodeError::Unknown { what: "slcan command", value: other.into() }),
        }
    }
}

/// Appends `tIIILDD..\r` (standard id) or `TIIIIIIIILDD..\r` (extended id).
pub fn encode_frame(f: &CanFrame, out: &mut Vec<u8>) {
    let kind = if f.is_extended() { b'T' } else { b't' };
    encode_head(kind, f.id(), f.is_extended(), f.dlc() as u8, out);
    for &b in f.data() {
        out.push(hex_digit(b >> 4));
        out.push(hex_digit(b & 0xF));
    }
    out.push(CR);
}

fn encode_head(kind: u8, id: u32, extended: bool, dlc: u8, out: &mut Vec<u8>) {
    out.push(kind);
    let digits = if extended { 8 } else { 3 };
    for i in (0..digits).rev() {
        out.push(hex_digit(((id >> (4 * i)) & 0xF) as u8));
    }
    out.push(hex_digit(dlc));
}

fn hex_digit(n: u8) -> u8 {
    b"0123456789ABCDEF"[usize::from(n & 0xF)]
}

fn hex_value(c: u8) -> Option<u8> {
    (c as char).to_digit(16).map(|d| d as u8)
}

fn hex_number(digits: &[u8]) -> Option<u32> {
    digits.iter().try_fold(0u32, |acc, &c| Some(acc << 4 | u32::from(hex_value(c)?)))
}

fn malformed(what: &str, line: &[u8]) -> DecodeError {
    DecodeError::Malformed(format!("slcan {what} {:?}", String::from_utf8_lossy(line)))
}

/// Splits `line` (kind letter first) into id, extended flag, DLC and the rest.
fn parse_head(line: &[u8]) -> Result<(u32, bool, u8, &[u8]), DecodeError> {
    let extended = line[0].is_ascii_uppercase();
    let id_len = if extended { 8 } else { 3 };
    let need = 1 + id_len + 1;
    if line.len() < need {
        return Err(DecodeError::TooShort { need, got: line.len() });
    }
    let id = hex_number(&line[1..1 + id_len]).ok_or_else(|| malformed("frame id", line))?;
    let max = if extended { super::can::MAX_EXTENDED_ID } else { super::can::MAX_STANDARD_ID };
    if id > max {
        return Err(malformed("frame id out of range", line));
    }
    let dlc = match line[1 + id_len] {
        d @ b'0'..=b'8' => d - b'0',
        _ => return Err(malformed("frame length", line)),
    };
    Ok((id, extended, dlc, &line[need..]))
}

/// What may follow the frame body: nothing, or (adapter side only) a 4-digit timestamp.
fn check_tail(tail: &[u8], allow_timestamp: bool, line: &[u8]) -> Result<(), DecodeError> {
    match tail.len() {
        0 => Ok(()),
        4 if allow_timestamp && hex_number(tail).is_some() => Ok(()),
        _ => Err(malformed("frame", line)),
    }
}

fn parse_data_frame(line: &[u8], allow_timestamp: bool) -> Result<CanFrame, DecodeError> {
    let (id, extended, dlc, rest) = parse_head(line)?;
    let n = usize::from(dlc);
    if rest.len() < 2 * n {
        return Err(malformed("frame data", line));
    }
    let mut data = [0u8; 8];
    for (i, slot) in data.iter_mut().take(n).enumerate() {
        *slot = hex_number(&rest[2 * i..2 * i + 2]).ok_or_else(|| malformed("frame data", line))? as u8;
    }
    check_tail(&rest[2 * n..], allow_timestamp, line)?;
    let frame = if extended { CanFrame::new_extended(id, &data[..n]) } else { CanFrame::new(id, &data[..n]) };
    frame.ok_or_else(|| malformed("frame", line))
}

fn parse_remote_frame(line: &[u8], allow_timestamp: bool) -> Result<RemoteFrame, DecodeError> {
    let (id, extended, dlc, rest) = parse_head(line)?;
    check_tail(rest, allow_timestamp, line)?;
    Ok(RemoteFrame { id, extended, dlc })
}

/// What an adapter sent, one line at a time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SlcanEvent {
    /// A data frame received from the bus (`t` / `T`).
    Frame(CanFrame),
    /// A remote frame received from the bus (`r` / `R`); axisctl's devices never send one.
    Remote(RemoteFrame),
    /// A bare CR: the last command succeeded.
    Ack,
    /// `z` / `Z`: Lawicel's acknowledge of a `t` / `T` transmit.
    TransmitAck { extended: bool },
    /// BEL: the last command failed.
    Error,
    /// `Fxx`: status flags, see [`status`].
    Status(u8),
    /// An error report (`e1a`) or bus state change (`sb256256`) of adapters
    /// that report them, as the Linux slcan driver reads them.
    BusError(ErrorFrame),
    /// Any other printable line, e.g. a `V1013` version or `NA123` serial number reply.
    Other(String),
}

impl fmt::Display for SlcanEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Frame(fr) => write!(f, "frame {fr}"),
            Self::Remote(r) => write!(f, "remote frame id {:#x} dlc {}", r.id, r.dlc),
            Self::Ack => f.write_str("OK"),
            Self::TransmitAck { extended } => {
                f.write_str(if *extended { "Z (transmitted)" } else { "z (transmitted)" })
            }
            Self::Error => f.write_str("BEL (error)"),
            Self::Status(s) => write!(f, "status {s:#04x} {:?}", status::names(*s)),
            Self::BusError(e) => write!(f, "bus error {}", e.problems().join(", ")),
            Self::Other(s) => write!(f, "{s:?}"),
        }
    }
}

/// One line cut out of a byte stream by [`LineBuffer`].
#[derive(Debug, PartialEq, Eq)]
enum Line {
    /// Bytes up to a CR (CR not included).
    Cr(Vec<u8>),
    /// A BEL; the bytes before it on the same line come as a separate `Partial` first.
    Bel,
    /// Bytes cut short by a BEL.
    Partial(Vec<u8>),
    /// A line longer than [`MAX_LINE`]; its bytes up to the next CR are dropped.
    Overlong(usize),
}

/// Splits a byte stream at CR and BEL with a bounded buffer. A LF right after a
/// line end is dropped, so `\r\n` endings from some firmwares do not turn into
/// empty lines (which would read as an OK).
#[derive(Debug, Default)]
struct LineBuffer {
    buf: Vec<u8>,
    /// Dropping an overlong line until its CR.
    skipping: bool,
}

impl LineBuffer {
    fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    fn next_line(&mut self) -> Option<Line> {
        if self.skipping {
            let i = self.buf.iter().position(|&b| b == CR || b == BEL);
            let Some(i) = i else {
                self.buf.clear();
                return None;
            };
            // Keep a BEL: it is a reply of its own.
            let end = if self.buf[i] == CR { i + 1 } else { i };
            self.buf.drain(..end);
            self.skipping = false;
        }
        let lf = self.buf.iter().take_while(|&&b| b == b'\n').count();
        self.buf.drain(..lf);
        match self.buf.iter().position(|&b| b == CR || b == BEL) {
            Some(0) if self.buf[0] == BEL => {
                self.buf.drain(..1);
                Some(Line::Bel)
            }
            // Length first, whatever ends the line: a line that arrived in
            // one read must read as it does when it trickles in (overlong
            // before its end is seen). Keep a BEL: it is a reply of its own.
            Some(i) if i > MAX_LINE => {
                let end = if self.buf[i] == CR { i + 1 } else { i };
                self.buf.drain(..end);
                Some(Line::Overlong(i))
            }
            Some(i) if self.buf[i] == BEL => Some(Line::Partial(self.buf.drain(..i).collect())),
            Some(i) => {
                let mut line: Vec<u8> = self.buf.drain(..=i).collect();
                line.pop();
                Some(Line::Cr(line))
            }
            None if self.buf.len() > MAX_LINE => {
                let n = self.buf.len();
                self.buf.clear();
                self.skipping = true;
                Some(Line::Overlong(n))
            }
            None => None,
        }
    }
}

/// Streaming decoder of what an adapter sends. Feed bytes with [`push`](Self::push),
/// then call [`next_event`](Self::next_event) until it returns `None`. An invalid line
/// is returned as an error and decoding carries on with the next line.
#[derive(Debug, Default)]
pub struct LineDecoder {
    lines: LineBuffer,
}

impl LineDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.lines.push(bytes);
    }

    /// Bytes held waiting for the end of their line.
    pub fn buffered(&self) -> usize {
        self.lines.buf.len()
    }

    /// Drops everything buffered, e.g. after the link's input was cleared.
    pub fn clear(&mut self) {
        self.lines = LineBuffer::default();
    }

    pub fn next_event(&mut self) -> Option<Result<SlcanEvent, DecodeError>> {
        Some(match self.lines.next_line()? {
            Line::Cr(line) => parse_event(&line),
            Line::Bel => Ok(SlcanEvent::Error),
            Line::Partial(line) => Err(malformed("line cut by BEL", &line)),
            Line::Overlong(len) => Err(DecodeError::TooLong { len }),
        })
    }
}

fn parse_event(line: &[u8]) -> Result<SlcanEvent, DecodeError> {
    let Some((&kind, rest)) = line.split_first() else {
        return Ok(SlcanEvent::Ack);
    };
    match kind {
        b't' | b'T' => parse_data_frame(line, true).map(SlcanEvent::Frame),
        b'r' | b'R' => parse_remote_frame(line, true).map(SlcanEvent::Remote),
        b'z' | b'Z' if rest.is_empty() => Ok(SlcanEvent::TransmitAck { extended: kind == b'Z' }),
        b'e' | b's' if ErrorFrame::from_slcan(line).is_some() => {
            Ok(SlcanEvent::BusError(ErrorFrame::from_slcan(line).expect("checked")))
        }
        b'F' if rest.len() == 2 => {
            hex_number(rest).map(|s| SlcanEvent::Status(s as u8)).ok_or_else(|| malformed("status reply", line))
        }
        _ if line.iter().all(|b| b.is_ascii_graphic() || *b == b' ') => {
            Ok(SlcanEvent::Other(String::from_utf8_lossy(line).into_owned()))
        }
        _ => Err(malformed("line", line)),
    }
}

/// Which acknowledges a simulated [`Adapter`] sends (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AckStyle {
    /// Lawicel CANUSB: `\r` OK, `z\r` / `Z\r` after a transmit, BEL on error.
    #[default]
    Lawicel,
    /// CANable 2.x: `\r` for every accepted command, transmits included; BEL on error.
    CrOnly,
    /// CANable 1.x: no acknowledge and no error reply; only queries (V, N, F) answer.
    Silent,
}

/// Host-transmitted frames an [`Adapter`] holds before it reports its TX FIFO full.
pub const ADAPTER_TX_QUEUE: usize = 64;

/// Version reply of the simulated adapter: hardware 1.0, software 1.3, in Lawicel's `Vhhss` form.
pub const ADAPTER_VERSION: &str = "V1013";
/// Serial number reply of the simulated adapter, Lawicel's `Nxxxx` form.
pub const ADAPTER_SERIAL: &str = "NAX01";

/// Sans-IO state machine of an slcan adapter (the device side).
///
/// Feed what the host wrote with [`handle_host_bytes`](Self::handle_host_bytes) and
/// bus traffic with [`bus_frame`](Self::bus_frame); then write
/// [`poll_output`](Self::poll_output) back to the host and put
/// [`poll_transmit`](Self::poll_transmit) frames on the bus.
#[derive(Debug)]
pub struct Adapter {
    style: AckStyle,
    lines: LineBuffer,
    bitrate: u8,
    open: bool,
    listen_only: bool,
    status: u8,
    output: Vec<u8>,
    transmit: VecDeque<CanFrame>,
    remote_transmits: u64,
}

impl Adapter {
    /// A closed adapter set to S8 (1 Mbit/s) until the host says otherwise.
    pub fn new(style: AckStyle) -> Self {
        Self {
            style,
            lines: LineBuffer::default(),
            bitrate: (SLCAN_BITRATES.len() - 1) as u8,
            open: false,
            listen_only: false,
            status: 0,
            output: Vec::new(),
            transmit: VecDeque::new(),
            remote_transmits: 0,
        }
    }

    pub fn is_open(&self) -> bool {
        self.open
    }

    pub fn is_listen_only(&self) -> bool {
        self.open && self.listen_only
    }

    /// The bitrate chosen with `S<n>`, in bit/s.
    pub fn bitrate(&self) -> u32 {
        SLCAN_BITRATES[usize::from(self.bitrate)]
    }

    /// Sets status flags (fault injection); `F` reports and clears them.
    pub fn raise_status(&mut self, flags: u8) {
        self.status |= flags;
    }

    /// Remote frames the host asked to transmit (the simulated bus has no use for them).
    pub fn remote_transmits(&self) -> u64 {
        self.remote_transmits
    }

    pub fn handle_host_bytes(&mut self, bytes: &[u8]) {
        self.lines.push(bytes);
        while let Some(line) = self.lines.next_line() {
            match line {
                // A lone CR is how hosts flush a half-typed command (python-can sends
                // one as an empty data-bitrate command): nothing to answer.
                Line::Cr(l) if l.is_empty() => {}
                Line::Cr(l) => {
                    let ok = Command::parse(&l).ok().and_then(|cmd| self.execute(cmd));
                    match ok {
                        Some(reply) => self.reply(reply),
                        None => self.reply(Reply::Error),
                    }
                }
                Line::Bel | Line::Partial(_) | Line::Overlong(_) => self.reply(Reply::Error),
            }
        }
    }

    /// Runs one command; `None` is an error (BEL).
    fn execute(&mut self, cmd: Command) -> Option<Reply> {
        match cmd {
            Command::SetBitrate(n) if !self.open => {
                self.bitrate = n;
                Some(Reply::Ok)
            }
            Command::Open | Command::ListenOnly if !self.open => {
                self.open = true;
                self.listen_only = cmd == Command::ListenOnly;
                Some(Reply::Ok)
            }
            Command::Close if self.open => {
                // Frames accepted before the close are already on their way:
                // a real adapter transmits them within microseconds.
                self.open = false;
                Some(Reply::Ok)
            }
            Command::ReadStatus if self.open => Some(Reply::Text(format!("F{:02X}", std::mem::take(&mut self.status)))),
            Command::Version => Some(Reply::Text(ADAPTER_VERSION.into())),
            Command::SerialNumber => Some(Reply::Text(ADAPTER_SERIAL.into())),
            Command::Transmit(f) if self.open && !self.listen_only => {
                if self.transmit.len() >= ADAPTER_TX_QUEUE {
                    self.status |= status::TX_FIFO_FULL;
                    return None;
                }
                self.transmit.push_back(f);
                Some(Reply::Transmitted { extended: f.is_extended() })
            }
            Command::TransmitRemote(r) if self.open && !self.listen_only => {
                self.remote_transmits += 1;
                Some(Reply::Transmitted { extended: r.extended })
            }
            _ => None,
        }
    }

    fn reply(&mut self, reply: Reply) {
        let text = match (self.style, reply) {
            (_, Reply::Text(t)) => t,
            (AckStyle::Silent, _) => return,
            (_, Reply::Error) => {
                self.output.push(BEL);
                return;
            }
            (AckStyle::Lawicel, Reply::Transmitted { extended }) => (if extended { "Z" } else { "z" }).into(),
            (_, Reply::Ok | Reply::Transmitted { .. }) => String::new(),
        };
        self.output.extend_from_slice(text.as_bytes());
        self.output.push(CR);
    }

    /// A frame seen on the bus: reported to the host while the channel is open.
    /// Returns whether it was reported.
    pub fn bus_frame(&mut self, f: &CanFrame) -> bool {
        if self.open {
            encode_frame(f, &mut self.output);
        }
        self.open
    }

    /// Bytes to write to the host, in order; `None` when there are none.
    #[must_use]
    pub fn poll_output(&mut self) -> Option<Vec<u8>> {
        (!self.output.is_empty()).then(|| std::mem::take(&mut self.output))
    }

    /// The next frame the host asked to put on the bus.
    #[must_use]
    pub fn poll_transmit(&mut self) -> Option<CanFrame> {
        self.transmit.pop_front()
    }
}

#[derive(Debug)]
enum Reply {
    Ok,
    Transmitted { extended: bool },
    Error,
    Text(String),
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn frame(id: u32, data: &[u8]) -> CanFrame {
        CanFrame::new(id, data).unwrap()
    }

    fn encoded(f: &CanFrame) -> String {
        let mut v = Vec::new();
        encode_frame(f, &mut v);
        String::from_utf8(v).unwrap()
    }

    fn events(bytes: &[u8]) -> Vec<Result<SlcanEvent, DecodeError>> {
        let mut d = LineDecoder::new();
        d.push(bytes);
        std::iter::from_fn(|| d.next_event()).collect()
    }

    #[test]
    fn encodes_frames() {
        // PowerCube manual section 8, "Home" to module 17: id 0x0F1 (0x0E0 + 17 per the
        // specs README), DLC 1, data 0x01.
        assert_eq!(encoded(&frame(0x0F1, &[0x01])), "t0F1101\r");
        // PowerCube manual section 8, GetExtended ActPos (0x3c) of module 17 as printed
        // there on 0x0D1: `0x0a 0x3c`.
        assert_eq!(encoded(&frame(0x0D1, &[0x0a, 0x3c])), "t0D120A3C\r");
        // Cdios goto to node 1 (command 0x23, module 1, position 5000 = 0x1388 LE) on 0x201.
        assert_eq!(
            encoded(&frame(0x201, &[0x23, 0x01, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00])),
            "t20182301008813000000\r"
        );
        assert_eq!(encoded(&frame(0x100, &[])), "t1000\r");
        assert_eq!(encoded(&CanFrame::new_extended(0x1234_5678, &[0xde, 0xad]).unwrap()), "T123456782DEAD\r");
        assert_eq!(encoded(&CanFrame::new_extended(0x1F, &[]).unwrap()), "T0000001F0\r");
    }

    #[test]
    fn encodes_commands() {
        let s = |c: Command| String::from_utf8(c.to_bytes()).unwrap();
        for (i, &rate) in SLCAN_BITRATES.iter().enumerate() {
            assert_eq!(s(Command::set_bitrate(rate).unwrap()), format!("S{i}\r"));
        }
        assert_eq!(Command::set_bitrate(1_000_000), Ok(Command::SetBitrate(8)));
        assert_eq!(Command::set_bitrate(83_333), Err(UnsupportedBitrate(83_333)));
        assert_eq!(s(Command::Open), "O\r");
        assert_eq!(s(Command::Close), "C\r");
        assert_eq!(s(Command::ReadStatus), "F\r");
        assert_eq!(s(Command::ListenOnly), "L\r");
        assert_eq!(s(Command::TransmitRemote(RemoteFrame { id: 0x123, extended: false, dlc: 2 })), "r1232\r");
        assert_eq!(s(Command::TransmitRemote(RemoteFrame { id: 0x123, extended: true, dlc: 8 })), "R000001238\r");
    }

    #[test]
    fn decodes_adapter_lines() {
        let got = events(b"t0F1101\r\r\x07z\rZ\rF0C\rV1013\rT123456782dead\rr1232\rt0B13010203ABCD\r");
        let want = vec![
            Ok(SlcanEvent::Frame(frame(0x0F1, &[0x01]))),
            Ok(SlcanEvent::Ack),
            Ok(SlcanEvent::Error),
            Ok(SlcanEvent::TransmitAck { extended: false }),
            Ok(SlcanEvent::TransmitAck { extended: true }),
            Ok(SlcanEvent::Status(status::ERROR_WARNING | status::DATA_OVERRUN)),
            Ok(SlcanEvent::Other("V1013".into())),
            Ok(SlcanEvent::Frame(CanFrame::new_extended(0x1234_5678, &[0xde, 0xad]).unwrap())),
            Ok(SlcanEvent::Remote(RemoteFrame { id: 0x123, extended: false, dlc: 2 })),
            // Lawicel timestamps (Z1): 4 hex digits after the data, dropped.
            Ok(SlcanEvent::Frame(frame(0x0B1, &[1, 2, 3]))),
        ];
        assert_eq!(got, want);
    }

    #[test]
    fn decodes_across_pushes() {
        let mut d = LineDecoder::new();
        let line = b"t20182301008813000000\r";
        for (i, b) in line.iter().enumerate() {
            assert!(d.next_event().is_none(), "event before the CR, at byte {i}");
            d.push(&[*b]);
        }
        assert_eq!(
            d.next_event(),
            Some(Ok(SlcanEvent::Frame(frame(0x201, &[0x23, 0x01, 0x00, 0x88, 0x13, 0x00, 0x00, 0x00]))))
        );
        assert_eq!(d.next_event(), None);
        assert_eq!(d.buffered(), 0);
    }

    #[test]
    fn rejects_bad_lines_and_resynchronises() {
        let got = events(b"t0F\rt0F19\rt8001FF\rtXYZ0\rt0F1201\rT2000000000\r\xff\xfe\rt0F1101\r");
        assert_eq!(got.len(), 8);
        assert!(got[..7].iter().all(|e| e.is_err()), "{got:?}");
        assert_eq!(got[7], Ok(SlcanEvent::Frame(frame(0x0F1, &[0x01]))));
    }

    #[test]
    fn crlf_endings_do_not_read_as_acks() {
        assert_eq!(events(b"\r\nt0F1101\r\n"), vec![Ok(SlcanEvent::Ack), Ok(SlcanEvent::Frame(frame(0x0F1, &[1])))]);
    }

    #[test]
    fn bel_cuts_a_partial_line() {
        let got = events(b"t0F\x07t0F1101\r");
        assert!(got[0].is_err());
        assert_eq!(got[1..], [Ok(SlcanEvent::Error), Ok(SlcanEvent::Frame(frame(0x0F1, &[1])))]);
    }

    #[test]
    fn overlong_garbage_is_bounded_and_skipped() {
        let mut d = LineDecoder::new();
        for _ in 0..100 {
            d.push(&[b'x'; 1000]);
            while let Some(e) = d.next_event() {
                assert!(matches!(e, Err(DecodeError::TooLong { .. })), "{e:?}");
            }
            assert!(d.buffered() <= MAX_LINE + 1000);
        }
        d.push(b"still garbage\x07t0F1101\r");
        assert_eq!(d.next_event(), Some(Ok(SlcanEvent::Error)));
        assert_eq!(d.next_event(), Some(Ok(SlcanEvent::Frame(frame(0x0F1, &[1])))));
        assert_eq!(d.next_event(), None);
    }

    // Found by fuzzing (fuzz/fuzz_targets/slcan_stream.rs): an overlong line
    // ended by BEL read as "line cut by BEL" when it arrived in one read and
    // as overlong when it trickled in.
    #[test]
    fn overlong_line_cut_by_bel_reads_the_same_in_any_reads() {
        let mut stream = vec![b'x'; MAX_LINE + 4];
        stream.extend_from_slice(b"\x07t0F1101\r");
        let whole = events(&stream);
        assert!(matches!(whole[0], Err(DecodeError::TooLong { .. })), "{whole:?}");
        assert_eq!(whole[1..], [Ok(SlcanEvent::Error), Ok(SlcanEvent::Frame(frame(0x0F1, &[1])))]);
        let mut d = LineDecoder::new();
        let mut split = Vec::new();
        for b in &stream {
            d.push(std::slice::from_ref(b));
            split.extend(std::iter::from_fn(|| d.next_event()));
        }
        assert_eq!(split.len(), whole.len());
        assert!(matches!(split[0], Err(DecodeError::TooLong { .. })));
        assert_eq!(split[1..], whole[1..]);
    }

    fn run(adapter: &mut Adapter, host: &[u8]) -> Vec<u8> {
        adapter.handle_host_bytes(host);
        adapter.poll_output().unwrap_or_default()
    }

    #[test]
    fn adapter_open_transmit_close_lawicel() {
        let mut a = Adapter::new(AckStyle::Lawicel);
        // Closing a closed channel and transmitting while closed are errors.
        assert_eq!(run(&mut a, b"C\r"), b"\x07");
        assert_eq!(run(&mut a, b"t0F1101\r"), b"\x07");
        assert_eq!(a.poll_transmit(), None);
        assert_eq!(run(&mut a, b"S6\rO\r"), b"\r\r");
        assert!(a.is_open());
        assert_eq!(a.bitrate(), 500_000);
        assert_eq!(run(&mut a, b"S8\r"), b"\x07", "no bitrate change while open");
        assert_eq!(run(&mut a, b"t0F1101\rT123456782DEAD\r"), b"z\rZ\r");
        assert_eq!(a.poll_transmit(), Some(frame(0x0F1, &[1])));
        assert_eq!(a.poll_transmit(), Some(CanFrame::new_extended(0x1234_5678, &[0xde, 0xad]).unwrap()));
        assert_eq!(a.poll_transmit(), None);
        assert!(a.bus_frame(&frame(0x0B1, &[0x01])));
        assert_eq!(a.poll_output().unwrap(), b"t0B1101\r");
        a.raise_status(status::BUS_ERROR);
        assert_eq!(run(&mut a, b"F\r"), b"F80\r");
        assert_eq!(run(&mut a, b"F\r"), b"F00\r", "F clears the flags");
        assert_eq!(run(&mut a, b"V\rN\r"), b"V1013\rNAX01\r");
        assert_eq!(run(&mut a, b"C\r"), b"\r");
        assert!(!a.bus_frame(&frame(0x0B1, &[0x01])));
        assert_eq!(a.poll_output(), None);
        assert_eq!(run(&mut a, b"F\r"), b"\x07");
    }

    #[test]
    fn adapter_styles() {
        let mut a = Adapter::new(AckStyle::CrOnly);
        assert_eq!(run(&mut a, b"S8\rO\rt0F1101\rX\r"), b"\r\r\r\x07");
        let mut a = Adapter::new(AckStyle::Silent);
        assert_eq!(run(&mut a, b"C\rS8\rO\rt0F1101\rX\r"), b"");
        assert_eq!(a.poll_transmit(), Some(frame(0x0F1, &[1])));
        assert_eq!(run(&mut a, b"V\r"), b"V1013\r");
    }

    #[test]
    fn adapter_rejects_garbage_and_listen_only_transmits() {
        let mut a = Adapter::new(AckStyle::Lawicel);
        assert_eq!(run(&mut a, b"\r\r"), b"", "lone CRs flush, no reply");
        assert_eq!(run(&mut a, b"S9\rQ\rO1\rt0F19\r"), b"\x07\x07\x07\x07");
        assert_eq!(run(&mut a, b"L\rt0F1101\r"), b"\r\x07");
        assert!(a.is_listen_only());
        assert_eq!(a.poll_transmit(), None);
        let mut long = vec![b'x'; MAX_LINE * 3];
        long.push(CR);
        assert_eq!(run(&mut a, &long), b"\x07");
        assert_eq!(run(&mut a, b"C\rO\rr1232\r"), b"\r\rz\r");
        assert_eq!(a.remote_transmits(), 1);
    }

    #[test]
    fn resync_ends_a_half_line_before_the_setup() {
        // A client died in the middle of a transmit line, channel left open.
        let mut a = Adapter::new(AckStyle::Lawicel);
        run(&mut a, b"O\rt0F1");
        let mut out = run(&mut a, RESYNC);
        assert_eq!(out, b"\x07V1013\r", "the half line is rejected, then V marks the sync point");
        out = run(&mut a, b"C\rS6\rO\r");
        assert_eq!(out, b"\r\r\r", "C, S6 and O all accepted");
        assert_eq!(a.bitrate(), 500_000);
        assert!(a.is_open());
    }

    #[test]
    fn adapter_tx_queue_is_bounded() {
        let mut a = Adapter::new(AckStyle::Lawicel);
        run(&mut a, b"O\r");
        for _ in 0..ADAPTER_TX_QUEUE {
            assert_eq!(run(&mut a, b"t0F1101\r"), b"z\r");
        }
        assert_eq!(run(&mut a, b"t0F1101\r"), b"\x07");
        assert_eq!(run(&mut a, b"F\r"), b"F02\r");
    }

    fn arb_frame() -> impl Strategy<Value = CanFrame> {
        (any::<bool>(), any::<u32>(), proptest::collection::vec(any::<u8>(), 0..=8)).prop_map(|(ext, id, data)| {
            if ext {
                CanFrame::new_extended(id & 0x1FFF_FFFF, &data).unwrap()
            } else {
                CanFrame::new(id & 0x7FF, &data).unwrap()
            }
        })
    }

    fn arb_command() -> impl Strategy<Value = Command> {
        prop_oneof![
            (0u8..9).prop_map(Command::SetBitrate),
            Just(Command::Open),
            Just(Command::ListenOnly),
            Just(Command::Close),
            Just(Command::ReadStatus),
            Just(Command::Version),
            Just(Command::SerialNumber),
            arb_frame().prop_map(Command::Transmit),
            (any::<bool>(), any::<u32>(), 0u8..9).prop_map(|(extended, id, dlc)| Command::TransmitRemote(
                RemoteFrame { id: id & if extended { 0x1FFF_FFFF } else { 0x7FF }, extended, dlc }
            )),
        ]
    }

    proptest! {
        #[test]
        fn frame_round_trip(f in arb_frame()) {
            let mut v = Vec::new();
            encode_frame(&f, &mut v);
            prop_assert_eq!(events(&v), vec![Ok(SlcanEvent::Frame(f))]);
        }

        #[test]
        fn command_round_trip(c in arb_command()) {
            let bytes = c.to_bytes();
            prop_assert_eq!(bytes.last(), Some(&CR));
            prop_assert_eq!(Command::parse(&bytes[..bytes.len() - 1]), Ok(c));
        }

        #[test]
        fn decoder_never_panics_and_recovers(garbage in proptest::collection::vec(any::<u8>(), 0..400)) {
            let mut d = LineDecoder::new();
            d.push(&garbage);
            while d.next_event().is_some() {}
            prop_assert!(d.buffered() <= MAX_LINE);
            // A CR ends whatever garbage was pending; the next frame decodes.
            d.push(b"\rt0F1101\r");
            let mut last = None;
            while let Some(e) = d.next_event() { last = Some(e); }
            prop_assert_eq!(last, Some(Ok(SlcanEvent::Frame(CanFrame::new(0x0F1, &[1]).unwrap()))));
        }

        #[test]
        fn adapter_never_panics(garbage in proptest::collection::vec(any::<u8>(), 0..400)) {
            let mut a = Adapter::new(AckStyle::Lawicel);
            a.handle_host_bytes(&garbage);
            let _ = a.poll_output();
            while a.poll_transmit().is_some() {}
            let _ = Command::parse(&garbage);
        }
    }
}
