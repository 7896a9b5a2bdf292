//! The socketcand protocol (linux-can/socketcand, `doc/protocol.md`): the
//! ASCII messages a raw-mode client and the daemon exchange over TCP.
//!
//! Every message is `< WORDS >`. The part used here: the daemon greets with
//! `< hi >`; the client selects a bus (`< open can0 >`, answered `< ok >` or
//! `< error could not open bus >` and a closed connection) and raw mode
//! (`< rawmode >`, `< ok >`); then `< send ID LEN B0 B1 .. >` transmits and
//! `< frame ID SECS.USECS DATA >` reports each frame on the bus, stamped by
//! the daemon. `< echo >` is answered with itself (used to measure the round
//! trip). An 8-digit id is extended, as the daemon decides it.
//!
//! The daemon writes a frame's data as one run of hex digits (`0A3C`), its
//! protocol document as bytes apart (`0A 3C`): both are read. Messages a
//! raw client does not use (`< error 004 .. >` error frames, `< stat .. >`,
//! `< fdframe .. >`, `< rtr .. >`) are well formed and come out as
//! [`Message::Error`] or [`Message::Other`]; only bytes that are no message
//! at all are a [`DecodeError`]. Nothing here panics, whatever the input.

use std::fmt::Write as _;

use super::{CanFrame, DecodeError};

/// Longest message the decoder holds before deciding it is garbage: a
/// CAN FD frame of 64 bytes is about 150 characters.
pub const MAX_MESSAGE: usize = 512;

/// One message of either side.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Message {
    Hi,
    Ok,
    Echo,
    Open(String),
    RawMode,
    /// A frame to transmit (client to daemon).
    Send(CanFrame),
    /// A frame seen on the bus (daemon to client), with the daemon's stamp.
    Frame {
        frame: CanFrame,
        stamp: Stamp,
    },
    /// `< error WORDS >`: a refusal (`could not open bus`) or an error frame.
    Error(String),
    /// Any other well-formed message, its words as sent.
    Other(String),
}

/// The daemon's receive time of a frame: seconds and microseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Stamp {
    pub secs: u64,
    pub micros: u32,
}

impl Message {
    /// The message as sent on the wire, no separator after it (the daemon
    /// sends none).
    pub fn encode(&self, out: &mut Vec<u8>) {
        let mut s = String::from("< ");
        match self {
            Self::Hi => s.push_str("hi"),
            Self::Ok => s.push_str("ok"),
            Self::Echo => s.push_str("echo"),
            Self::RawMode => s.push_str("rawmode"),
            Self::Open(bus) => {
                let _ = write!(s, "open {bus}");
            }
            Self::Send(f) => {
                let _ = write!(s, "send {} {}", id_text(f), f.data().len());
                for b in f.data() {
                    let _ = write!(s, " {b:02X}");
                }
            }
            Self::Frame { frame, stamp } => {
                let _ = write!(s, "frame {} {}.{:06} ", id_text(frame), stamp.secs, stamp.micros);
                for b in frame.data() {
                    let _ = write!(s, "{b:02X}");
                }
            }
            Self::Error(text) => {
                let _ = write!(s, "error {text}");
            }
            Self::Other(text) => s.push_str(text),
        }
        s.push_str(" >");
        out.extend_from_slice(s.as_bytes());
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut v = Vec::new();
        self.encode(&mut v);
        v
    }
}

fn id_text(f: &CanFrame) -> String {
    if f.is_extended() {
        format!("{:08X}", f.id())
    } else {
        format!("{:03X}", f.id())
    }
}

/// Cuts a byte stream into messages; bytes may arrive in any chunks.
#[derive(Debug, Default)]
pub struct Decoder {
    buf: Vec<u8>,
    /// Where the unread part of `buf` starts.
    at: usize,
}

impl Decoder {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn push(&mut self, bytes: &[u8]) {
        if self.at > 0 && self.at == self.buf.len() {
            self.buf.clear();
            self.at = 0;
        }
        self.buf.extend_from_slice(bytes);
    }

    /// Bytes pushed and not decoded yet.
    pub fn pending(&self) -> usize {
        self.buf.len() - self.at
    }

    /// The next message, `None` until one is complete. Whitespace between
    /// messages is skipped; anything else outside `< >`, and a message
    /// longer than [`MAX_MESSAGE`], is an error once, and is dropped.
    pub fn next_message(&mut self) -> Option<Result<Message, DecodeError>> {
        let rest = &self.buf[self.at..];
        let Some(start) = rest.iter().position(|b| !b.is_ascii_whitespace()) else {
            self.at = self.buf.len();
            return None;
        };
        let garbage = |bytes: &[u8]| {
            let shown = String::from_utf8_lossy(&bytes[..bytes.len().min(40)]).into_owned();
            Some(Err(DecodeError::Malformed(format!("bytes outside a message: {shown:?}"))))
        };
        let message = &rest[start..];
        if message[0] != b'<' {
            let next = message.iter().position(|&b| b == b'<').unwrap_or(message.len());
            self.at += start + next;
            return garbage(&message[..next]);
        }
        let end = message.iter().position(|&b| b == b'>');
        // A `<` later than the first one (before any `>`) starts the real
        // message: what lies before it is garbage, however it arrived.
        let head = &message[..end.unwrap_or(message.len())];
        if let Some(restart) = head.iter().rposition(|&b| b == b'<').filter(|&i| i > 0) {
            self.at += start + restart;
            return garbage(&message[..restart]);
        }
        let Some(len) = end else {
            if message.len() > MAX_MESSAGE {
                self.at = self.buf.len();
                return Some(Err(DecodeError::TooLong { len: message.len() }));
            }
            return None;
        };
        let body = &message[1..len];
        self.at += start + len + 1;
        if len > MAX_MESSAGE {
            return Some(Err(DecodeError::TooLong { len }));
        }
        Some(parse(body))
    }
}

/// The words between `<` and `>`.
fn parse(body: &[u8]) -> Result<Message, DecodeError> {
    let text = std::str::from_utf8(body).map_err(|_| bad("not ASCII", body))?;
    let mut words = text.split_ascii_whitespace();
    let verb = words.next().ok_or_else(|| bad("empty message", body))?;
    let rest: Vec<&str> = words.collect();
    let only = |m: Message| if rest.is_empty() { Ok(m) } else { Err(bad("unexpected words", body)) };
    match verb {
        "hi" => only(Message::Hi),
        "ok" => only(Message::Ok),
        "echo" => only(Message::Echo),
        "rawmode" => only(Message::RawMode),
        "open" => match rest.as_slice() {
            [bus] => Ok(Message::Open((*bus).to_string())),
            _ => Err(bad("open takes one bus name", body)),
        },
        "send" => parse_send(&rest).ok_or_else(|| bad("bad send", body)),
        "frame" => parse_frame(&rest).ok_or_else(|| bad("bad frame", body)),
        "error" => Ok(Message::Error(rest.join(" "))),
        _ => Ok(Message::Other(text.split_ascii_whitespace().collect::<Vec<_>>().join(" "))),
    }
}

fn bad(why: &str, body: &[u8]) -> DecodeError {
    let shown = String::from_utf8_lossy(&body[..body.len().min(60)]).into_owned();
    DecodeError::Malformed(format!("{why}: \"<{shown}>\""))
}

/// An id as the daemon reads it: 8 hex digits are extended.
fn parse_id(text: &str, data: &[u8]) -> Option<CanFrame> {
    if text.is_empty() || text.len() > 8 || !text.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let id = u32::from_str_radix(text, 16).ok()?;
    if text.len() == 8 {
        CanFrame::new_extended(id, data)
    } else {
        CanFrame::new(id, data)
    }
}

/// `ID LEN B0 B1 ..`: LEN in decimal (python-can writes it in hex, the
/// same for 0..8), each byte one or two hex digits.
fn parse_send(words: &[&str]) -> Option<Message> {
    let (id, len, bytes) = match words {
        [id, len, bytes @ ..] => (*id, *len, bytes),
        _ => return None,
    };
    let len: usize = len.parse().ok()?;
    if len != bytes.len() || len > 8 {
        return None;
    }
    let mut data = Vec::with_capacity(len);
    for b in bytes {
        if b.is_empty() || b.len() > 2 || !b.bytes().all(|c| c.is_ascii_hexdigit()) {
            return None;
        }
        data.push(u8::from_str_radix(b, 16).ok()?);
    }
    parse_id(id, &data).map(Message::Send)
}

/// `ID SECS.USECS DATA`, DATA one run of hex digits or bytes apart.
fn parse_frame(words: &[&str]) -> Option<Message> {
    let (id, time, data) = match words {
        [id, time, data @ ..] => (*id, *time, data),
        _ => return None,
    };
    let (secs, frac) = time.split_once('.')?;
    if secs.is_empty() || frac.is_empty() || frac.len() > 9 || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let secs: u64 = secs.parse().ok()?;
    // Any number of fraction digits, as microseconds.
    let padded = format!("{frac:0<6}");
    let micros: u32 = padded[..6].parse().ok()?;
    let hex: String = data.concat();
    if !hex.len().is_multiple_of(2) || hex.len() > 16 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let bytes: Vec<u8> =
        (0..hex.len() / 2).map(|i| u8::from_str_radix(&hex[2 * i..2 * i + 2], 16)).collect::<Result<_, _>>().ok()?;
    let frame = parse_id(id, &bytes)?;
    Some(Message::Frame { frame, stamp: Stamp { secs, micros } })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn all(bytes: &[u8]) -> Vec<Result<Message, DecodeError>> {
        let mut d = Decoder::new();
        d.push(bytes);
        std::iter::from_fn(|| d.next_message()).collect()
    }

    fn f(id: u32, data: &[u8]) -> CanFrame {
        CanFrame::new(id, data).unwrap()
    }

    // The daemon's own output (state_raw.c): data as one run of hex digits,
    // two blanks before `>` for a frame without data.
    #[test]
    fn reads_what_the_daemon_writes() {
        let got =
            all(b"< hi >< ok >< frame 0B1 23.424242 0A1D1835 >< frame 123 1.000005  >< frame 1AAAAAAA 0.5 01F1 >");
        assert_eq!(
            got,
            vec![
                Ok(Message::Hi),
                Ok(Message::Ok),
                Ok(Message::Frame {
                    frame: f(0x0B1, &[0x0A, 0x1D, 0x18, 0x35]),
                    stamp: Stamp { secs: 23, micros: 424242 }
                }),
                Ok(Message::Frame { frame: f(0x123, &[]), stamp: Stamp { secs: 1, micros: 5 } }),
                Ok(Message::Frame {
                    frame: CanFrame::new_extended(0x1AAA_AAAA, &[1, 0xF1]).unwrap(),
                    stamp: Stamp { secs: 0, micros: 500_000 }
                }),
            ]
        );
        // The protocol document's form: bytes apart.
        assert_eq!(
            all(b"< frame 123 23.424242 11 22 33 44 >"),
            vec![Ok(Message::Frame {
                frame: f(0x123, &[0x11, 0x22, 0x33, 0x44]),
                stamp: Stamp { secs: 23, micros: 424242 }
            })]
        );
    }

    // python-can's client: `{length:X}` and `{x:x}`, no zero padding.
    #[test]
    fn reads_what_python_can_sends() {
        assert_eq!(all(b"< open can0 >< rawmode >"), vec![Ok(Message::Open("can0".into())), Ok(Message::RawMode)]);
        assert_eq!(all(b"< send 0E3 2 a 3c >"), vec![Ok(Message::Send(f(0x0E3, &[0x0A, 0x3C])))]);
        assert_eq!(all(b"< send 123 0 >"), vec![Ok(Message::Send(f(0x123, &[])))]);
        assert_eq!(
            all(b"< send 1AAAAAAA 2 1 F1 >"),
            vec![Ok(Message::Send(CanFrame::new_extended(0x1AAA_AAAA, &[1, 0xF1]).unwrap()))]
        );
    }

    #[test]
    fn what_we_write_reads_back() {
        let ext = CanFrame::new_extended(0x1234_5678, &[1, 2, 3]).unwrap();
        for m in [
            Message::Hi,
            Message::Ok,
            Message::Echo,
            Message::RawMode,
            Message::Open("vcan1".into()),
            Message::Send(f(0x0E3, &[0x0A, 0x3C])),
            Message::Send(ext),
            Message::Frame { frame: f(0x0A3, &[0x0A, 0x3C, 0, 0, 0x80, 0x3F]), stamp: Stamp { secs: 17, micros: 42 } },
            Message::Error("could not open bus".into()),
        ] {
            assert_eq!(all(&m.to_bytes()), vec![Ok(m.clone())], "{:?}", String::from_utf8_lossy(&m.to_bytes()));
        }
        assert_eq!(Message::Send(f(0x0E3, &[0x0A, 0x3C])).to_bytes(), b"< send 0E3 2 0A 3C >");
        assert_eq!(
            Message::Frame { frame: f(0x0A3, &[0x0A]), stamp: Stamp { secs: 3, micros: 7 } }.to_bytes(),
            b"< frame 0A3 3.000007 0A >"
        );
    }

    #[test]
    fn messages_split_anywhere_come_out_whole() {
        let wire = b"< hi >\n< frame 0B1 1.5 01 >  < error could not open bus >";
        for cut in 0..wire.len() {
            let mut d = Decoder::new();
            d.push(&wire[..cut]);
            let mut got: Vec<_> = std::iter::from_fn(|| d.next_message()).collect();
            d.push(&wire[cut..]);
            got.extend(std::iter::from_fn(|| d.next_message()));
            assert_eq!(got.len(), 3, "cut at {cut}: {got:?}");
            assert!(got.iter().all(Result::is_ok), "cut at {cut}: {got:?}");
            assert_eq!(d.pending(), 0);
        }
    }

    #[test]
    fn garbage_is_an_error_once_and_what_follows_is_read() {
        let got = all(b"HTTP/1.1 400 Bad Request\r\n< hi >");
        assert!(matches!(&got[0], Err(DecodeError::Malformed(m)) if m.contains("HTTP/1.1")), "{got:?}");
        assert_eq!(got[1], Ok(Message::Hi));
        for bad in [
            &b"< >"[..],
            b"< send 123 3 1 2 >",
            b"< send 800 0 >",
            b"< frame 123 x 00 >",
            b"< frame 123 1.0 0 >",
            b"< hi there >",
            b"< \xff >",
        ] {
            let got = all(bad);
            assert!(matches!(got.as_slice(), [Err(_)]), "{:?}: {got:?}", String::from_utf8_lossy(bad));
        }
        // A message cut short by another: the first part is garbage.
        let got = all(b"< frame 0A3 < ok >");
        assert!(matches!(&got[0], Err(DecodeError::Malformed(m)) if m.contains("frame 0A3")), "{got:?}");
        assert_eq!(got[1], Ok(Message::Ok));
        // Words no raw client uses are messages, not garbage.
        assert_eq!(all(b"< stat 1 2 3 4 >"), vec![Ok(Message::Other("stat 1 2 3 4".into()))]);
        assert_eq!(all(b"< error 004 3.000001 >"), vec![Ok(Message::Error("004 3.000001".into()))]);
        // A message that never ends is dropped once it is too long to be one.
        let mut d = Decoder::new();
        d.push(b"< frame ");
        d.push(&[b'1'; MAX_MESSAGE]);
        assert!(matches!(d.next_message(), Some(Err(DecodeError::TooLong { .. }))));
        d.push(b"< ok >");
        assert_eq!(d.next_message(), Some(Ok(Message::Ok)));
    }

    proptest! {
        #[test]
        fn chunking_changes_no_message(seed in any::<u64>(), bytes in proptest::collection::vec(
            prop_oneof![Just(b'<'), Just(b'>'), Just(b' '), Just(b'o'), Just(b'k'), any::<u8>()], 0..700)) {
            let whole: Vec<Message> = all(&bytes).into_iter().flatten().collect();
            let mut d = Decoder::new();
            let mut chunked = Vec::new();
            let mut state = seed | 1;
            let mut rest = &bytes[..];
            while !rest.is_empty() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let (head, tail) = rest.split_at(((state % 40) as usize + 1).min(rest.len()));
                d.push(head);
                chunked.extend(std::iter::from_fn(|| d.next_message()).flatten());
                rest = tail;
            }
            prop_assert_eq!(whole, chunked);
        }

        #[test]
        fn never_panics_and_always_progresses(chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..64), 0..16)) {
            let mut d = Decoder::new();
            for c in &chunks {
                d.push(c);
                let mut n = 0;
                while d.next_message().is_some() {
                    n += 1;
                    prop_assert!(n <= 64 * 16, "no progress");
                }
                prop_assert!(d.pending() <= MAX_MESSAGE + 64);
            }
        }

        #[test]
        fn frames_round_trip(ext in any::<bool>(), id in any::<u32>(), data in proptest::collection::vec(any::<u8>(), 0..=8),
                             secs in any::<u32>(), micros in 0u32..1_000_000) {
            let frame = if ext { CanFrame::new_extended(id & 0x1FFF_FFFF, &data) } else { CanFrame::new(id & 0x7FF, &data) }.unwrap();
            for m in [Message::Send(frame), Message::Frame { frame, stamp: Stamp { secs: secs.into(), micros } }] {
                prop_assert_eq!(all(&m.to_bytes()), vec![Ok(m.clone())]);
            }
        }
    }
}
