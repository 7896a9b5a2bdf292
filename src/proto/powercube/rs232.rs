//! PowerCube RS232 framing (manual 4.3, with the specs README's corrections).
//!
//! A frame is `STX TELID(2, high byte first) data BCC ETX`. TELID is
//! `0x0400 | M<<5 | L` towards the module and `0x0800 | M<<5 | L` from it,
//! M the module address (0 = broadcast on RS232), L the number of net data
//! bytes. BCC is the low byte of `s + (s >> 8)`, `s` the 16-bit sum of both
//! TELID bytes and all data bytes. STX, ETX and DLE inside TELID, data and BCC
//! are sent as DLE followed by the byte + 0x80.
//!
//! [`encode`] appends one frame to a buffer. [`Decoder`] is streaming: feed it
//! whatever the link delivered with [`Decoder::push`], then call
//! [`Decoder::next_frame`] until it returns `None`.

use std::collections::VecDeque;

use super::frame::{Payload, Request, Response};
pub use crate::proto::DecodeError;

/// Start of text.
pub const STX: u8 = 0x02;
/// End of text.
pub const ETX: u8 = 0x03;
/// Data link escape: the next byte is the escaped byte + 0x80.
pub const DLE: u8 = 0x10;
/// TELID bits of a frame to a module (TELID_SENDDAT).
pub const TELID_SEND: u16 = 0x0400;
/// TELID bits of a frame from a module (TELID_RECVDAT).
pub const TELID_RECV: u16 = 0x0800;
/// The module address that reaches every module on RS232.
pub const BROADCAST: u8 = 0;
/// Largest module address.
pub const MAX_MODULE: u8 = 31;

/// TELID (2) + at most 15 data bytes (the 4-bit L) + BCC, unescaped. A frame
/// growing beyond this without ETX is garbage and is dropped.
const MAX_CONTENT: usize = 2 + 15 + 1;

/// Which way a frame travels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// TELID_SENDDAT: host to module.
    ToModule,
    /// TELID_RECVDAT: module to host.
    FromModule,
}

impl Direction {
    const fn bits(self) -> u16 {
        match self {
            Self::ToModule => TELID_SEND,
            Self::FromModule => TELID_RECV,
        }
    }
}

/// The 16-bit TELID. `module` above 31 and `len` above 15 do not fit and are
/// truncated to their field.
pub const fn telid(dir: Direction, module: u8, len: u8) -> u16 {
    dir.bits() | ((module as u16 & 0x1f) << 5) | (len as u16 & 0x0f)
}

/// The block check character over TELID and data bytes, unescaped.
pub fn bcc(bytes: &[u8]) -> u8 {
    fold(bytes.iter().fold(0u16, |s, &b| s.wrapping_add(b.into())))
}

/// `BCC = BCC + (BCC >> 8)`, low byte.
const fn fold(sum: u16) -> u8 {
    sum.wrapping_add(sum >> 8) as u8
}

fn push_escaped(out: &mut Vec<u8>, b: u8) {
    if matches!(b, STX | ETX | DLE) {
        out.extend_from_slice(&[DLE, b + 0x80]);
    } else {
        out.push(b);
    }
}

/// Appends the frame carrying `payload` to `out`.
///
/// `module` is 0..=31 (0 = broadcast) and `payload` at most 15 bytes (8 in
/// practice); larger values are a caller bug and are truncated to the TELID
/// fields (checked in debug builds).
pub fn encode(dir: Direction, module: u8, payload: &[u8], out: &mut Vec<u8>) {
    debug_assert!(module <= MAX_MODULE, "module address {module} > 31");
    debug_assert!(payload.len() <= 15, "RS232 payload of {} bytes", payload.len());
    let t = telid(dir, module, payload.len() as u8).to_be_bytes();
    let mut sum = 0u16;
    out.push(STX);
    for &b in t.iter().chain(payload) {
        sum = sum.wrapping_add(b.into());
        push_escaped(out, b);
    }
    push_escaped(out, fold(sum));
    out.push(ETX);
}

/// Appends the frame carrying `req` to `module` (0 = broadcast).
pub fn encode_request(module: u8, req: &Request, out: &mut Vec<u8>) {
    encode(Direction::ToModule, module, req.to_payload().as_slice(), out);
}

/// Appends the frame a module at `module` answers `resp` with.
pub fn encode_response(module: u8, resp: &Response, out: &mut Vec<u8>) {
    encode(Direction::FromModule, module, resp.to_payload().as_slice(), out);
}

/// One decoded frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rs232Frame {
    pub dir: Direction,
    /// 0..=31; 0 is the broadcast address.
    pub module: u8,
    /// The data bytes actually framed between TELID and BCC.
    pub payload: Payload,
    /// L from the TELID, which need not match `payload.len()`: the manual's
    /// own example acknowledges declare 6 for 3 bytes.
    pub declared_len: u8,
}

impl Rs232Frame {
    /// The TELID length disagrees with the bytes framed.
    pub fn len_mismatch(&self) -> bool {
        usize::from(self.declared_len) != self.payload.len()
    }

    /// Sent to the broadcast address.
    pub fn is_broadcast(&self) -> bool {
        self.module == BROADCAST
    }

    /// The payload as a module's acknowledge.
    pub fn response(&self) -> Result<Response, DecodeError> {
        Response::decode(self.payload.as_slice())
    }

    /// The payload as a command to a module.
    pub fn request(&self) -> Result<Request, DecodeError> {
        Request::decode(self.payload.as_slice())
    }

    /// Appends the frame's bytes, with the length of the payload (a
    /// mismatching `declared_len` is not reproduced).
    pub fn encode(&self, out: &mut Vec<u8>) {
        encode(self.dir, self.module, self.payload.as_slice(), out);
    }
}

/// Parses the unescaped bytes between STX and ETX.
fn parse_content(content: &[u8]) -> Result<Rs232Frame, DecodeError> {
    let [hi, lo, data @ .., check] = content else {
        return Err(DecodeError::TooShort { need: 3, got: content.len() });
    };
    let computed = bcc(&content[..content.len() - 1]);
    if computed != *check {
        return Err(DecodeError::Checksum { computed, received: *check });
    }
    let t = u16::from_be_bytes([*hi, *lo]);
    // Bit 4 of the low byte is always 0; the top four bits are unused.
    let dir = match t & 0xfc10 {
        TELID_SEND => Direction::ToModule,
        TELID_RECV => Direction::FromModule,
        _ => return Err(DecodeError::Unknown { what: "RS232 TELID", value: t.into() }),
    };
    let payload = Payload::new(data).ok_or(DecodeError::TooLong { len: data.len() })?;
    Ok(Rs232Frame { dir, module: ((t >> 5) & 0x1f) as u8, payload, declared_len: (t & 0x0f) as u8 })
}

/// Streaming RS232 decoder that resynchronises on garbage.
///
/// Bytes outside STX..ETX are skipped and counted; an STX inside a frame
/// starts a new frame (the partial one counts as skipped); a frame that grows
/// beyond the longest valid one is dropped. A complete frame yields
/// `Ok(frame)` or a typed error (bad BCC, bad escape, bad TELID, too long),
/// after which decoding continues with the next frame.
#[derive(Debug, Default)]
pub struct Decoder {
    input: VecDeque<u8>,
    /// Unescaped bytes since STX; `None` while hunting for STX.
    content: Option<Vec<u8>>,
    /// Raw bytes of the current frame, including STX.
    raw_len: usize,
    escape: bool,
    bad_escape: Option<u8>,
    skipped: u64,
    bad_frames: u64,
}

impl Decoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Queues received bytes.
    pub fn push(&mut self, bytes: &[u8]) {
        self.input.extend(bytes);
    }

    /// Bytes dropped while resynchronising (not counting frames reported as errors).
    pub fn skipped_bytes(&self) -> u64 {
        self.skipped
    }

    /// Complete frames reported as errors so far.
    pub fn bad_frames(&self) -> u64 {
        self.bad_frames
    }

    /// Whether a frame has started but not ended.
    pub fn in_frame(&self) -> bool {
        self.content.is_some()
    }

    /// Drops the queued input and any partial frame, counting them as
    /// skipped (e.g. before a new request on a half-duplex line).
    pub fn clear(&mut self) {
        self.skipped += self.input.len() as u64 + self.raw_len as u64;
        self.input.clear();
        self.abandon_counted();
    }

    fn start(&mut self) {
        self.content = Some(Vec::with_capacity(MAX_CONTENT));
        self.raw_len = 1;
        self.escape = false;
        self.bad_escape = None;
    }

    fn abandon_counted(&mut self) {
        self.content = None;
        self.raw_len = 0;
        self.escape = false;
        self.bad_escape = None;
    }

    fn abandon(&mut self) {
        self.skipped += self.raw_len as u64;
        self.abandon_counted();
    }

    /// The next complete frame, or `None` when more bytes are needed.
    pub fn next_frame(&mut self) -> Option<Result<Rs232Frame, DecodeError>> {
        while let Some(b) = self.input.pop_front() {
            let Some(content) = self.content.as_mut() else {
                if b == STX {
                    self.start();
                } else {
                    self.skipped += 1;
                }
                continue;
            };
            self.raw_len += 1;
            match b {
                STX => {
                    self.raw_len -= 1;
                    self.abandon();
                    self.start();
                }
                ETX => {
                    let result = if self.escape {
                        Err(DecodeError::Malformed("DLE before ETX".into()))
                    } else if let Some(e) = self.bad_escape {
                        Err(DecodeError::Malformed(format!("DLE followed by {e:#04x}")))
                    } else {
                        parse_content(content)
                    };
                    self.abandon_counted();
                    if result.is_err() {
                        self.bad_frames += 1;
                    }
                    return Some(result);
                }
                DLE if !self.escape => self.escape = true,
                _ => {
                    let v = if self.escape {
                        self.escape = false;
                        match b {
                            0x82 | 0x83 | 0x90 => b - 0x80,
                            _ => {
                                self.bad_escape.get_or_insert(b);
                                b
                            }
                        }
                    } else {
                        b
                    };
                    content.push(v);
                    if content.len() > MAX_CONTENT {
                        self.abandon();
                    }
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::super::frame::{Motion, MotionValue, Value};
    use super::super::table::CommandId;
    use super::*;
    use proptest::prelude::*;

    const M17: u8 = 17;

    fn enc_req(req: Request) -> Vec<u8> {
        let mut out = Vec::new();
        encode_request(M17, &req, &mut out);
        out
    }

    fn decode_all(bytes: &[u8]) -> Vec<Result<Rs232Frame, DecodeError>> {
        let mut d = Decoder::new();
        d.push(bytes);
        std::iter::from_fn(|| d.next_frame()).collect()
    }

    fn decode_one(bytes: &[u8]) -> Rs232Frame {
        let all = decode_all(bytes);
        assert_eq!(all.len(), 1, "{all:?}");
        all[0].clone().unwrap()
    }

    fn ack(bytes: &[u8]) -> (Rs232Frame, Response) {
        let f = decode_one(bytes);
        assert_eq!((f.dir, f.module), (Direction::FromModule, M17));
        (f, f.response().unwrap())
    }

    // Manual 9 (module 17), every example byte for byte.
    #[test]
    fn section_9_home_and_reset() {
        assert_eq!(enc_req(Request::Home), [0x02, 0x06, 0x21, 0x01, 0x28, 0x03]);
        assert_eq!(ack(&[0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03]).1, Response::Simple(CommandId::Home));
        assert_eq!(enc_req(Request::Reset), [0x02, 0x06, 0x21, 0x00, 0x27, 0x03]);
        assert_eq!(ack(&[0x02, 0x0a, 0x21, 0x00, 0x2b, 0x03]).1, Response::Simple(CommandId::Reset));
    }

    #[test]
    fn section_9_set_acceleration() {
        let send = [0x02, 0x06, 0x26, 0x08, 0x50, 0x00, 0x00, 0x00, 0x3f, 0xc3, 0x03];
        assert_eq!(enc_req(Request::set(0x50, Value::Float(0.5))), send);
        assert_eq!(decode_one(&send).request(), Ok(Request::set(0x50, Value::Float(0.5))));
        // The manual's acknowledge declares 6 bytes in its TELID but frames 3.
        let (f, r) = ack(&[0x02, 0x0a, 0x26, 0x08, 0x50, 0x64, 0xec, 0x03]);
        assert_eq!(f.payload.as_slice(), [0x08, 0x50, 0x64]);
        assert_eq!(f.declared_len, 6);
        assert!(f.len_mismatch());
        assert_eq!(r, Response::SetAck { param: 0x50 });
    }

    #[test]
    fn section_9_set_velocity() {
        let send = [0x02, 0x06, 0x26, 0x08, 0x4f, 0x0a, 0xd7, 0xa3, 0x3d, 0x46, 0x03];
        assert_eq!(enc_req(Request::set(0x4f, Value::Float(0.08))), send);
        let (f, r) = ack(&[0x02, 0x0a, 0x26, 0x08, 0x4f, 0x64, 0xeb, 0x03]);
        assert!(f.len_mismatch());
        assert_eq!(r, Response::SetAck { param: 0x4f });
    }

    #[test]
    fn section_9_ramp_motion() {
        let ramp = Request::SetMotion(Motion { id: 4, value: MotionValue::Float(0.75), time_ms: None });
        assert_eq!(enc_req(ramp), [0x02, 0x06, 0x26, 0x0b, 0x04, 0x00, 0x00, 0x40, 0x3f, 0xba, 0x03]);
        let (f, r) = ack(&[0x02, 0x0a, 0x26, 0x0b, 0x04, 0x64, 0xa3, 0x03]);
        assert!(f.len_mismatch());
        assert_eq!(r, Response::MotionAck { motion: 4 });
        assert!(ramp.matches(&r));
    }

    #[test]
    fn section_9_halt_with_dle() {
        // Unescaped 02 06 21 02 29 03: the command byte 0x02 becomes 10 82.
        let send = [0x02, 0x06, 0x21, 0x10, 0x82, 0x29, 0x03];
        assert_eq!(enc_req(Request::Halt), send);
        let f = decode_one(&send);
        assert_eq!((f.dir, f.module, f.declared_len, f.len_mismatch()), (Direction::ToModule, 17, 1, false));
        assert_eq!(f.request(), Ok(Request::Halt));
    }

    #[test]
    fn section_9_telid() {
        assert_eq!(telid(Direction::ToModule, 17, 6).to_be_bytes(), [0x06, 0x26]);
        assert_eq!(telid(Direction::FromModule, 17, 6).to_be_bytes(), [0x0a, 0x26]);
    }

    #[test]
    fn broadcasts_are_cmd_and_param_at_address_0() {
        use crate::proto::powercube::can::Broadcast;
        let frame = |b: Broadcast| {
            let mut out = Vec::new();
            encode(Direction::ToModule, BROADCAST, &b.payload(), &mut out);
            out
        };
        // The vendor library's halt-all, and docs/guide.md's reset-all and StartMotion.
        assert_eq!(frame(Broadcast::Halt), [0x02, 0x04, 0x10, 0x82, 0x10, 0x82, 0x00, 0x08, 0x03]);
        assert_eq!(frame(Broadcast::Reset), [0x02, 0x04, 0x10, 0x82, 0x00, 0x00, 0x06, 0x03]);
        assert_eq!(frame(Broadcast::StartMotion), [0x02, 0x04, 0x10, 0x82, 0x0f, 0x00, 0x15, 0x03]);
    }

    #[test]
    fn escapes_telid_and_bcc() {
        // Broadcast (module 0) of 2 bytes: TELID 04 02, its low byte escaped.
        let mut out = Vec::new();
        encode(Direction::ToModule, BROADCAST, &[0x0e, 0x00], &mut out);
        assert_eq!(out, [0x02, 0x04, 0x10, 0x82, 0x0e, 0x00, 0x14, 0x03]);
        assert!(decode_one(&out).is_broadcast());
        // 06 + 21 + db = 0x102, BCC = 0x102 + 0x01 -> 0x03, escaped.
        out.clear();
        encode(Direction::ToModule, M17, &[0xdb], &mut out);
        assert_eq!(out, [0x02, 0x06, 0x21, 0xdb, 0x10, 0x83, 0x03]);
        assert_eq!(decode_one(&out).payload.as_slice(), [0xdb]);
        // DLE itself.
        out.clear();
        encode(Direction::FromModule, M17, &[0x0a, 0x10], &mut out);
        assert_eq!(&out[3..6], [0x0a, 0x10, 0x90]);
        assert_eq!(decode_one(&out).payload.as_slice(), [0x0a, 0x10]);
    }

    #[test]
    fn resyncs_on_garbage() {
        let home_ack = [0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03];
        let reset_ack = [0x02, 0x0a, 0x21, 0x00, 0x2b, 0x03];
        let mut bytes = vec![0xff, 0x03, 0x10, 0x55];
        bytes.extend_from_slice(&home_ack);
        bytes.extend_from_slice(&[0x00, 0x90]);
        // A frame cut short by a new STX.
        bytes.extend_from_slice(&[0x02, 0x0a, 0x21]);
        bytes.extend_from_slice(&reset_ack);
        let mut d = Decoder::new();
        d.push(&bytes);
        assert_eq!(d.next_frame().unwrap().unwrap().response(), Ok(Response::Simple(CommandId::Home)));
        assert_eq!(d.next_frame().unwrap().unwrap().response(), Ok(Response::Simple(CommandId::Reset)));
        assert_eq!(d.next_frame(), None);
        assert_eq!(d.skipped_bytes(), 4 + 2 + 3);
        assert_eq!(d.bad_frames(), 0);
    }

    #[test]
    fn bad_bcc_then_good_frame() {
        let mut bytes = vec![0x02, 0x0a, 0x21, 0x01, 0x2d, 0x03];
        bytes.extend_from_slice(&[0x02, 0x0a, 0x21, 0x00, 0x2b, 0x03]);
        let all = decode_all(&bytes);
        assert_eq!(all[0], Err(DecodeError::Checksum { computed: 0x2c, received: 0x2d }));
        assert_eq!(all[1].as_ref().unwrap().response(), Ok(Response::Simple(CommandId::Reset)));
        assert_eq!(all.len(), 2);
    }

    #[test]
    fn malformed_frames_are_typed_errors() {
        assert_eq!(decode_all(&[0x02, 0x03]), [Err(DecodeError::TooShort { need: 3, got: 0 })]);
        // TELID with neither direction bit: 0x0021, BCC 0x21.
        assert!(matches!(decode_all(&[0x02, 0x00, 0x21, 0x21, 0x03])[..], [Err(DecodeError::Unknown { .. })]));
        // DLE followed by something that is not an escape.
        assert!(matches!(
            decode_all(&[0x02, 0x06, 0x21, 0x10, 0x41, 0x68, 0x03])[..],
            [Err(DecodeError::Malformed(_))]
        ));
        assert!(matches!(decode_all(&[0x02, 0x06, 0x21, 0x01, 0x10, 0x03])[..], [Err(DecodeError::Malformed(_))]));
        // Nine data bytes do not fit a payload.
        let mut out = Vec::new();
        encode(Direction::FromModule, M17, &[0x0a; 9], &mut out);
        assert_eq!(decode_all(&out), [Err(DecodeError::TooLong { len: 9 })]);
    }

    #[test]
    fn overlong_frame_is_dropped() {
        let mut bytes = vec![0x02];
        bytes.extend(std::iter::repeat_n(0x41, 40));
        bytes.extend_from_slice(&[0x02, 0x0a, 0x21, 0x01, 0x2c, 0x03]);
        let mut d = Decoder::new();
        d.push(&bytes);
        assert_eq!(d.next_frame().unwrap().unwrap().response(), Ok(Response::Simple(CommandId::Home)));
        assert_eq!(d.skipped_bytes(), 41);
    }

    #[test]
    fn byte_by_byte_feeding() {
        let bytes = [0x02, 0x0a, 0x26, 0x08, 0x50, 0x64, 0xec, 0x03, 0x02, 0x06, 0x21, 0x10, 0x82, 0x29, 0x03];
        let mut d = Decoder::new();
        let mut got = Vec::new();
        for (i, b) in bytes.iter().enumerate() {
            d.push(&[*b]);
            while let Some(f) = d.next_frame() {
                got.push((i, f.unwrap()));
            }
        }
        assert_eq!(got.len(), 2);
        assert_eq!(got[0].0, 7);
        assert_eq!(got[0].1.response(), Ok(Response::SetAck { param: 0x50 }));
        assert_eq!(got[1].0, 14);
        assert_eq!(got[1].1.request(), Ok(Request::Halt));
        assert!(!d.in_frame());
    }

    #[test]
    fn clear_drops_partial_frame() {
        let mut d = Decoder::new();
        d.push(&[0x02, 0x0a, 0x21]);
        assert_eq!(d.next_frame(), None);
        assert!(d.in_frame());
        d.push(&[0x01]);
        d.clear();
        assert_eq!(d.skipped_bytes(), 4);
        d.push(&[0x2c, 0x03]);
        assert_eq!(d.next_frame(), None);
    }

    fn frame_strategy() -> impl Strategy<Value = (bool, u8, Vec<u8>)> {
        // Bias data towards the bytes that need escaping.
        let byte = prop_oneof![Just(STX), Just(ETX), Just(DLE), any::<u8>()];
        (any::<bool>(), 0..=MAX_MODULE, proptest::collection::vec(byte, 1..=8))
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..64), 0..8)) {
            let mut d = Decoder::new();
            for c in &chunks {
                d.push(c);
                while let Some(r) = d.next_frame() {
                    if let Ok(f) = r {
                        let _ = (f.response(), f.request(), f.len_mismatch());
                    }
                }
            }
        }

        #[test]
        fn round_trip((to_module, module, data) in frame_strategy(), split in any::<prop::sample::Index>()) {
            let dir = if to_module { Direction::ToModule } else { Direction::FromModule };
            let mut out = Vec::new();
            encode(dir, module, &data, &mut out);
            prop_assert_eq!(out.first(), Some(&STX));
            prop_assert_eq!(out.last(), Some(&ETX));
            prop_assert!(!out[1..out.len() - 1].iter().any(|b| matches!(*b, STX | ETX)));
            let at = split.index(out.len());
            let mut d = Decoder::new();
            d.push(&out[..at]);
            let early = d.next_frame();
            prop_assert!(early.is_none());
            d.push(&out[at..]);
            let f = d.next_frame().unwrap().unwrap();
            prop_assert_eq!(f, Rs232Frame { dir, module, payload: Payload::new(&data).unwrap(), declared_len: data.len() as u8 });
            prop_assert!(!f.len_mismatch());
            let mut again = Vec::new();
            f.encode(&mut again);
            prop_assert_eq!(again, out);
        }

        #[test]
        fn garbage_before_frame_is_skipped(
            garbage in proptest::collection::vec(any::<u8>().prop_filter("no STX", |b| *b != STX), 0..32),
            (to_module, module, data) in frame_strategy(),
        ) {
            let dir = if to_module { Direction::ToModule } else { Direction::FromModule };
            let mut bytes = garbage.clone();
            encode(dir, module, &data, &mut bytes);
            let mut d = Decoder::new();
            d.push(&bytes);
            let f = d.next_frame().unwrap().unwrap();
            prop_assert_eq!(f.payload.as_slice(), &data[..]);
            prop_assert_eq!(d.skipped_bytes(), garbage.len() as u64);
        }
    }
}
