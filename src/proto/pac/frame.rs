//! PA-CONTROL RS232 "online command" frames (manual 3.3, 3.3.1; specs README).
//!
//! ```text
//! command      SOH STX CMD ; PAR_1 ; TYP ; PAR_2 ETX CHECK EOT
//! acknowledge  SOH STX QUIT ; BE ; STATUS ; ERROR ; TYP ; Q_PAR ETX CHECK EOT
//! poll         EOT
//! ```
//!
//! CMD is four hex digits, every other field decimal; TYP is `0` (integer) or
//! `1` (float, `.` as decimal point). CHECK is the XOR of characters written as
//! 1-3 decimal digits. The manual's own examples disagree on which characters
//! count (specs README), hence [`CheckRule`]: encoders write one rule, decoders
//! accept either and report which one matched.
//!
//! The controller's default format is 7N1, but a pty (the simulator) delivers
//! whatever 8-bit bytes were written, so the stream decoders mask every byte
//! to 7 bits before looking at it.

use serde::Serialize;

pub const SOH: u8 = 0x01;
pub const STX: u8 = 0x02;
pub const ETX: u8 = 0x03;
pub const EOT: u8 = 0x04;

/// The poll command: a lone EOT asks for a fresh acknowledge (manual 3.3.1).
pub const POLL: [u8; 1] = [EOT];

/// Frames longer than this (SOH to EOT) are dropped. Large enough for any
/// finite f64 written without exponent (about 330 characters), so every frame
/// the encoder can produce fits.
pub const MAX_FRAME: usize = 1024;

/// The command date / acknowledge date (PAR_2 / Q_PAR) with its TYP.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "type", content = "value", rename_all = "lowercase")]
pub enum Par2 {
    /// TYP `0`.
    Int(i64),
    /// TYP `1`.
    Float(f64),
}

impl Par2 {
    /// The TYP digit.
    pub fn typ(&self) -> u8 {
        match self {
            Self::Int(_) => 0,
            Self::Float(_) => 1,
        }
    }

    pub fn as_f64(&self) -> f64 {
        match *self {
            Self::Int(v) => v as f64,
            Self::Float(v) => v,
        }
    }

    /// The integer value; a float only if it is integral and in range.
    pub fn as_i64(&self) -> Option<i64> {
        match *self {
            Self::Int(v) => Some(v),
            Self::Float(v) if v.fract() == 0.0 && v.abs() < 9.0e15 => Some(v as i64),
            Self::Float(_) => None,
        }
    }
}

impl std::fmt::Display for Par2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::Int(v) => write!(f, "{v}"),
            Self::Float(v) => f.write_str(&format_float(v, FloatFormat::Shortest)),
        }
    }
}

/// Which characters the CHECK digits are the XOR of.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum CheckRule {
    /// The characters strictly between STX and ETX: the command examples of
    /// manual 3.4 (`1900;5;0;0` -> 6).
    #[default]
    Strict,
    /// Those characters and ETX: most acknowledge examples of manual 3.4
    /// (`0;1;1;0;0;12345` -> 57).
    WithEtx,
    /// CHECK written as `0` without computing it, which manual 3.1 allows
    /// ("It can be replaced by the value 0"). Decoders accept it only when
    /// told to (the command decoder, standing in for the controller, does by
    /// default) and only when neither real rule matches.
    Omitted,
}

impl CheckRule {
    /// The CHECK value of a frame body (the bytes between STX and ETX).
    pub fn compute(self, body: &[u8]) -> u8 {
        let x = body.iter().fold(0u8, |acc, b| acc ^ b);
        match self {
            Self::Strict => x,
            Self::WithEtx => x ^ ETX,
            Self::Omitted => 0,
        }
    }
}

/// How float dates are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FloatFormat {
    /// The shortest decimal that reads back as the same f64, with at least one
    /// digit after the point: `5552.0` as in manual 3.4.3. Round-trips.
    #[default]
    Shortest,
    /// A fixed number of decimals, as the controller writes its answers
    /// (`640.0000` for R registers, `1255.000` for positions, manual 3.4).
    /// Does not round-trip in general.
    Fixed(u8),
}

/// Encoder settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EncodeOptions {
    pub check_rule: CheckRule,
    pub float_format: FloatFormat,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    #[error("{field} is not a finite number and cannot be written")]
    NonFinite { field: &'static str },
}

/// Why received bytes did not make a frame. The stream decoders report the
/// error, drop what they could not use and carry on with the next bytes.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("{len} byte(s) outside any frame skipped")]
    Garbage { len: usize },
    #[error("SOH not followed by STX")]
    MissingStx,
    #[error("frame cut off after {len} byte(s) by a new control character")]
    Truncated { len: usize },
    #[error("frame longer than {max} bytes dropped", max = MAX_FRAME)]
    TooLong,
    #[error("bad CHECK {received}: expected {strict} (without ETX) or {with_etx} (with ETX)")]
    BadCheck { received: u16, strict: u8, with_etx: u8 },
    #[error("missing field {field}")]
    MissingField { field: &'static str },
    #[error("{count} field(s) more than expected")]
    ExtraField { count: usize },
    #[error("bad field {field}: {text:?}")]
    BadField { field: &'static str, text: String },
    #[error("expected one complete frame, got {0}")]
    NotOneFrame(&'static str),
}

fn non_finite(field: &'static str, v: &Par2) -> Result<(), EncodeError> {
    match v {
        Par2::Float(f) if !f.is_finite() => Err(EncodeError::NonFinite { field }),
        _ => Ok(()),
    }
}

/// Writes a finite float per `fmt`.
pub fn format_float(v: f64, fmt: FloatFormat) -> String {
    match fmt {
        FloatFormat::Shortest => {
            // f64's Display is the shortest round-tripping decimal and never
            // uses an exponent; it drops ".0" on integral values, which the
            // TYP 1 examples always carry.
            let mut s = format!("{v}");
            if !s.contains('.') {
                s.push_str(".0");
            }
            s
        }
        FloatFormat::Fixed(n) => format!("{v:.*}", n as usize),
    }
}

fn write_par2(out: &mut Vec<u8>, v: &Par2, fmt: FloatFormat) {
    match *v {
        Par2::Int(i) => out.extend_from_slice(i.to_string().as_bytes()),
        Par2::Float(f) => out.extend_from_slice(format_float(f, fmt).as_bytes()),
    }
}

fn finish_frame(body: &[u8], rule: CheckRule, buf: &mut Vec<u8>) {
    buf.push(SOH);
    buf.push(STX);
    buf.extend_from_slice(body);
    buf.push(ETX);
    buf.extend_from_slice(rule.compute(body).to_string().as_bytes());
    buf.push(EOT);
}

/// A command from the master (manual 3.3).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Command {
    /// CMD, e.g. 0x0A87; written as four uppercase hex digits.
    pub code: u16,
    /// PAR_1: axis, element or parameter number.
    pub par1: i64,
    /// TYP and PAR_2.
    pub par2: Par2,
}

impl Command {
    pub fn new(code: u16, par1: i64, par2: Par2) -> Self {
        Self { code, par1, par2 }
    }

    /// The characters between STX and ETX.
    pub fn body(&self, float_format: FloatFormat) -> Result<Vec<u8>, EncodeError> {
        non_finite("PAR_2", &self.par2)?;
        let mut b = format!("{:04X};{};{};", self.code, self.par1, self.par2.typ()).into_bytes();
        write_par2(&mut b, &self.par2, float_format);
        Ok(b)
    }

    /// The frame with the default options (CHECK without ETX, shortest floats).
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        let mut buf = Vec::new();
        self.encode_with(&EncodeOptions::default(), &mut buf)?;
        Ok(buf)
    }

    /// Appends the frame to `buf`.
    pub fn encode_with(&self, opts: &EncodeOptions, buf: &mut Vec<u8>) -> Result<(), EncodeError> {
        let body = self.body(opts.float_format)?;
        finish_frame(&body, opts.check_rule, buf);
        Ok(())
    }

    /// Decodes exactly one complete command frame. CHECK `0` is accepted as
    /// [`CheckRule::Omitted`], as the controller would.
    pub fn decode(bytes: &[u8]) -> Result<(Self, CheckRule), FrameError> {
        let mut d = CommandDecoder::new();
        d.push(bytes);
        match d.next() {
            Some(Ok(Request::Command { command, check_rule })) if d.buffered() == 0 => Ok((command, check_rule)),
            Some(Ok(_)) => Err(FrameError::NotOneFrame("a poll or trailing bytes")),
            Some(Err(e)) => Err(e),
            None => Err(FrameError::NotOneFrame("an incomplete frame")),
        }
    }
}

/// An acknowledge from the controller (manual 3.3.1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ack {
    /// Command error number (manual 6.5); 0 = no error.
    pub quit: u16,
    /// End of processing flag: true (1) = finished; false (0) = still running,
    /// poll with EOT for a fresh acknowledge.
    pub be: bool,
    /// Operating status (manual 6.4).
    pub status: u16,
    /// PA-CONTROL error number (Exxx).
    pub error: u16,
    /// TYP_QUIT and the acknowledge date.
    pub q_par: Par2,
    /// The rule the received CHECK matched; the rule used when encoding.
    pub check_rule: CheckRule,
}

impl Ack {
    pub fn body(&self, float_format: FloatFormat) -> Result<Vec<u8>, EncodeError> {
        non_finite("Q_PAR", &self.q_par)?;
        let mut b = format!("{};{};{};{};{};", self.quit, u8::from(self.be), self.status, self.error, self.q_par.typ())
            .into_bytes();
        write_par2(&mut b, &self.q_par, float_format);
        Ok(b)
    }

    /// The frame, CHECK per `self.check_rule`, floats shortest.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        let mut buf = Vec::new();
        self.encode_with(FloatFormat::Shortest, &mut buf)?;
        Ok(buf)
    }

    /// Appends the frame to `buf`, CHECK per `self.check_rule`.
    pub fn encode_with(&self, float_format: FloatFormat, buf: &mut Vec<u8>) -> Result<(), EncodeError> {
        let body = self.body(float_format)?;
        finish_frame(&body, self.check_rule, buf);
        Ok(())
    }

    /// Decodes exactly one complete acknowledge frame.
    pub fn decode(bytes: &[u8]) -> Result<Self, FrameError> {
        let mut d = AckDecoder::new();
        d.push(bytes);
        match d.next() {
            Some(Ok(ack)) if d.buffered() == 0 => Ok(ack),
            Some(Ok(_)) => Err(FrameError::NotOneFrame("trailing bytes")),
            Some(Err(e)) => Err(e),
            None => Err(FrameError::NotOneFrame("an incomplete frame")),
        }
    }
}

// ---------------------------------------------------------------------------
// Field parsing

fn field_err(field: &'static str, text: &[u8]) -> FrameError {
    FrameError::BadField { field, text: String::from_utf8_lossy(text).into_owned() }
}

fn parse_uint<T: std::str::FromStr>(field: &'static str, text: &[u8]) -> Result<T, FrameError> {
    if text.is_empty() {
        return Err(FrameError::MissingField { field });
    }
    if !text.iter().all(u8::is_ascii_digit) {
        return Err(field_err(field, text));
    }
    std::str::from_utf8(text).ok().and_then(|s| s.parse().ok()).ok_or_else(|| field_err(field, text))
}

fn parse_int(field: &'static str, text: &[u8]) -> Result<i64, FrameError> {
    let digits = text.strip_prefix(b"-").unwrap_or(text);
    if text.is_empty() {
        return Err(FrameError::MissingField { field });
    }
    if digits.is_empty() || !digits.iter().all(u8::is_ascii_digit) {
        return Err(field_err(field, text));
    }
    std::str::from_utf8(text).ok().and_then(|s| s.parse().ok()).ok_or_else(|| field_err(field, text))
}

fn parse_float(field: &'static str, text: &[u8]) -> Result<f64, FrameError> {
    if text.is_empty() {
        return Err(FrameError::MissingField { field });
    }
    // Digits, sign, point and an exponent (in case a firmware's ftoa writes
    // one); letters other than e/E would let "inf" and "nan" through.
    let ok_chars = text.iter().all(|c| c.is_ascii_digit() || b"+-.eE".contains(c));
    let has_digit = text.iter().any(u8::is_ascii_digit);
    if !ok_chars || !has_digit {
        return Err(field_err(field, text));
    }
    std::str::from_utf8(text)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|v| v.is_finite())
        .ok_or_else(|| field_err(field, text))
}

fn parse_par2(typ_field: &'static str, typ: &[u8], field: &'static str, text: &[u8]) -> Result<Par2, FrameError> {
    match typ {
        b"0" => parse_int(field, text).map(Par2::Int),
        b"1" => parse_float(field, text).map(Par2::Float),
        b"" => Err(FrameError::MissingField { field: typ_field }),
        _ => Err(field_err(typ_field, typ)),
    }
}

/// Splits a body into exactly `names.len()` fields.
fn split_fields<'a>(body: &'a [u8], names: &[&'static str]) -> Result<Vec<&'a [u8]>, FrameError> {
    let fields: Vec<&[u8]> = body.split(|c| *c == b';').collect();
    if fields.len() < names.len() {
        return Err(FrameError::MissingField { field: names[fields.len()] });
    }
    if fields.len() > names.len() {
        return Err(FrameError::ExtraField { count: fields.len() - names.len() });
    }
    Ok(fields)
}

fn parse_command_body(body: &[u8]) -> Result<Command, FrameError> {
    let f = split_fields(body, &["CMD", "PAR_1", "TYP", "PAR_2"])?;
    if f[0].is_empty() {
        return Err(FrameError::MissingField { field: "CMD" });
    }
    if f[0].len() != 4 || !f[0].iter().all(u8::is_ascii_hexdigit) {
        return Err(field_err("CMD", f[0]));
    }
    let code = std::str::from_utf8(f[0])
        .ok()
        .and_then(|s| u16::from_str_radix(s, 16).ok())
        .ok_or_else(|| field_err("CMD", f[0]))?;
    let par1 = parse_int("PAR_1", f[1])?;
    let par2 = parse_par2("TYP", f[2], "PAR_2", f[3])?;
    Ok(Command { code, par1, par2 })
}

fn parse_ack_body(body: &[u8], check_rule: CheckRule) -> Result<Ack, FrameError> {
    let f = split_fields(body, &["QUIT", "BE", "STATUS", "ERROR", "TYP_QUIT", "Q_PAR"])?;
    let quit = parse_uint("QUIT", f[0])?;
    let be = match f[1] {
        b"0" => false,
        b"1" => true,
        b"" => return Err(FrameError::MissingField { field: "BE" }),
        other => return Err(field_err("BE", other)),
    };
    let status = parse_uint("STATUS", f[2])?;
    let error = parse_uint("ERROR", f[3])?;
    let q_par = parse_par2("TYP_QUIT", f[4], "Q_PAR", f[5])?;
    Ok(Ack { quit, be, status, error, q_par, check_rule })
}

fn verify_check(body: &[u8], check: &[u8], accept_omitted: bool) -> Result<CheckRule, FrameError> {
    if check.is_empty() {
        return Err(FrameError::MissingField { field: "CHECK" });
    }
    if check.len() > 3 || !check.iter().all(u8::is_ascii_digit) {
        return Err(field_err("CHECK", check));
    }
    let received: u16 = check.iter().fold(0u16, |acc, d| acc * 10 + u16::from(d - b'0'));
    let strict = CheckRule::Strict.compute(body);
    let with_etx = CheckRule::WithEtx.compute(body);
    if received == u16::from(strict) {
        Ok(CheckRule::Strict)
    } else if received == u16::from(with_etx) {
        Ok(CheckRule::WithEtx)
    } else if received == 0 && accept_omitted {
        Ok(CheckRule::Omitted)
    } else {
        Err(FrameError::BadCheck { received, strict, with_etx })
    }
}

// ---------------------------------------------------------------------------
// Stream decoding

enum Raw {
    Frame { body: Vec<u8>, check: Vec<u8> },
    Poll,
}

/// Byte-level framing shared by both decoders: finds `SOH STX .. ETX .. EOT`
/// (and, for the controller side, lone EOTs), skipping everything else.
#[derive(Debug, Clone, Default)]
struct Framer {
    buf: Vec<u8>,
    polls: bool,
}

impl Framer {
    fn push(&mut self, bytes: &[u8]) {
        self.buf.extend(bytes.iter().map(|b| b & 0x7f));
    }

    fn drop_front(&mut self, n: usize) {
        self.buf.drain(..n);
    }

    fn next(&mut self) -> Option<Result<Raw, FrameError>> {
        if self.buf.is_empty() {
            return None;
        }
        let polls = self.polls;
        let start = self.buf.iter().position(|b| *b == SOH || (polls && *b == EOT));
        match start {
            None => {
                let len = self.buf.len();
                self.buf.clear();
                return Some(Err(FrameError::Garbage { len }));
            }
            Some(0) => {}
            Some(len) => {
                self.drop_front(len);
                return Some(Err(FrameError::Garbage { len }));
            }
        }
        if self.buf[0] == EOT {
            self.drop_front(1);
            return Some(Ok(Raw::Poll));
        }
        if self.buf.len() < 2 {
            return None;
        }
        if self.buf[1] != STX {
            self.drop_front(1);
            return Some(Err(FrameError::MissingStx));
        }
        // Body: up to ETX. Any other control character means the frame was
        // cut off; resume at an SOH, swallow an EOT (it ended the broken
        // frame, it is not a poll). The length limit is checked by position
        // before each byte, so the verdict on a long frame does not depend on
        // how the bytes were split into reads: ETX at MAX_FRAME - 1 or later
        // leaves no room for EOT inside MAX_FRAME bytes.
        let mut i = 2;
        while i < self.buf.len() {
            if i >= MAX_FRAME - 1 {
                self.drop_front(1);
                return Some(Err(FrameError::TooLong));
            }
            match self.buf[i] {
                ETX => break,
                SOH | STX => {
                    self.drop_front(i);
                    return Some(Err(FrameError::Truncated { len: i }));
                }
                EOT => {
                    self.drop_front(i + 1);
                    return Some(Err(FrameError::Truncated { len: i + 1 }));
                }
                _ => i += 1,
            }
        }
        if i >= self.buf.len() {
            return None;
        }
        let etx = i;
        let mut j = etx + 1;
        while j < self.buf.len() {
            if j >= MAX_FRAME {
                self.drop_front(1);
                return Some(Err(FrameError::TooLong));
            }
            match self.buf[j] {
                EOT => break,
                SOH => {
                    self.drop_front(j);
                    return Some(Err(FrameError::Truncated { len: j }));
                }
                _ => j += 1,
            }
        }
        if j >= self.buf.len() {
            return None;
        }
        let body = self.buf[2..etx].to_vec();
        let check = self.buf[etx + 1..j].to_vec();
        self.drop_front(j + 1);
        Some(Ok(Raw::Frame { body, check }))
    }
}

/// Streaming decoder for acknowledges (the master's side).
///
/// Call [`push`](Self::push) with received bytes, then [`next`](Self::next)
/// until it returns `None` (more bytes needed). Errors are reported one by
/// one and decoding continues after them; the buffer never holds more than
/// one partial frame of at most [`MAX_FRAME`] bytes once drained.
#[derive(Debug, Clone, Default)]
pub struct AckDecoder {
    framer: Framer,
    accept_omitted: bool,
}

impl AckDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Also accept CHECK `0` when it matches neither rule (off by default:
    /// the controller always computes its CHECK).
    pub fn accept_omitted_check(mut self, yes: bool) -> Self {
        self.accept_omitted = yes;
        self
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.framer.push(bytes);
    }

    /// Bytes held back waiting for the rest of a frame.
    pub fn buffered(&self) -> usize {
        self.framer.buf.len()
    }

    /// Drops buffered bytes, e.g. before sending a new command on a
    /// half-duplex line.
    pub fn clear(&mut self) {
        self.framer.buf.clear();
    }

    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Option<Result<Ack, FrameError>> {
        Some(match self.framer.next()? {
            Err(e) => Err(e),
            // A lone EOT is never recognised here (polls is false).
            Ok(Raw::Poll) => Err(FrameError::Garbage { len: 1 }),
            Ok(Raw::Frame { body, check }) => {
                verify_check(&body, &check, self.accept_omitted).and_then(|rule| parse_ack_body(&body, rule))
            }
        })
    }
}

/// What the controller receives.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum Request {
    Command {
        command: Command,
        check_rule: CheckRule,
    },
    /// A lone EOT.
    Poll,
}

/// Streaming decoder for commands and polls (the controller's side, used by
/// the simulator). Same contract as [`AckDecoder`].
#[derive(Debug, Clone)]
pub struct CommandDecoder {
    framer: Framer,
    accept_omitted: bool,
}

impl Default for CommandDecoder {
    fn default() -> Self {
        Self { framer: Framer { buf: Vec::new(), polls: true }, accept_omitted: true }
    }
}

impl CommandDecoder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether CHECK `0` is accepted as "not computed" (default: yes, manual 3.1).
    pub fn accept_omitted_check(mut self, yes: bool) -> Self {
        self.accept_omitted = yes;
        self
    }

    pub fn push(&mut self, bytes: &[u8]) {
        self.framer.push(bytes);
    }

    pub fn buffered(&self) -> usize {
        self.framer.buf.len()
    }

    pub fn clear(&mut self) {
        self.framer.buf.clear();
    }

    #[allow(clippy::should_implement_trait)]
    pub fn next(&mut self) -> Option<Result<Request, FrameError>> {
        Some(match self.framer.next()? {
            Err(e) => Err(e),
            Ok(Raw::Poll) => Ok(Request::Poll),
            Ok(Raw::Frame { body, check }) => verify_check(&body, &check, self.accept_omitted).and_then(|check_rule| {
                parse_command_body(&body).map(|command| Request::Command { command, check_rule })
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hex(s: &str) -> Vec<u8> {
        s.split_whitespace().map(|b| u8::from_str_radix(b, 16).unwrap()).collect()
    }

    fn cmd(code: u16, par1: i64, par2: Par2) -> Command {
        Command::new(code, par1, par2)
    }

    fn ack(quit: u16, be: bool, status: u16, error: u16, q_par: Par2, check_rule: CheckRule) -> Ack {
        Ack { quit, be, status, error, q_par, check_rule }
    }

    // Manual 3.4.2 command 1, "Get the status of input 5": 1900;5;0;0, CHECK 6.
    #[test]
    fn manual_3_4_2_get_input_5() {
        let c = cmd(0x1900, 5, Par2::Int(0));
        let bytes = hex("01 02 31 39 30 30 3B 35 3B 30 3B 30 03 36 04");
        assert_eq!(c.encode().unwrap(), bytes);
        assert_eq!(Command::decode(&bytes).unwrap(), (c, CheckRule::Strict));
    }

    // Manual 3.4.2 command 3, "Describe integer register 3 with 333": CHECK 4.
    #[test]
    fn manual_3_4_2_put_int_reg_3() {
        let c = cmd(0x0906, 3, Par2::Int(333));
        let bytes = hex("01 02 30 39 30 36 3B 33 3B 30 3B 33 33 33 03 34 04");
        assert_eq!(c.encode().unwrap(), bytes);
        assert_eq!(Command::decode(&bytes).unwrap(), (c, CheckRule::Strict));
    }

    // Manual 3.4.3 command 1, "Start online mode": the printed bytes spell the
    // code 0A03, but their CHECK 14 is that of 0603 (specs README).
    #[test]
    fn manual_3_4_3_start_online() {
        let c = cmd(0x0603, 0, Par2::Int(0));
        assert_eq!(c.encode().unwrap(), hex("01 02 30 36 30 33 3B 30 3B 30 3B 30 03 31 34 04"));
        let printed = hex("01 02 30 41 30 33 3B 30 3B 30 3B 30 03 31 34 04");
        assert_eq!(Command::decode(&printed), Err(FrameError::BadCheck { received: 14, strict: 121, with_etx: 122 }));
    }

    // The other printed command frames of 3.4 carry CHECKs that match no rule
    // (misprints, specs README): a decoder must reject them, not guess.
    #[test]
    fn manual_3_4_misprinted_command_checks_rejected() {
        // 3.4.1: 0906;5;0;12345 printed with CHECK 7; XOR is 0.
        let b = hex("01 02 30 39 30 36 3B 35 3B 30 3B 31 32 33 34 35 03 37 04");
        assert_eq!(Command::decode(&b), Err(FrameError::BadCheck { received: 7, strict: 0, with_etx: 3 }));
        // 3.4.2 command 2 (bytes say 1960 for 1906) printed with CHECK 6.
        let b = hex("01 02 31 39 36 30 3B 32 3B 30 3B 30 03 36 04");
        assert_eq!(Command::decode(&b), Err(FrameError::BadCheck { received: 6, strict: 7, with_etx: 4 }));
        // 3.4.3 command 2, 0A87;2;1;5552.0 printed with CHECK 14.
        let b = hex("01 02 30 41 38 37 3B 32 3B 31 3B 35 35 35 32 2E 30 03 31 34 04");
        assert_eq!(Command::decode(&b), Err(FrameError::BadCheck { received: 14, strict: 95, with_etx: 92 }));
    }

    // The intended commands of those examples, as our encoder writes them.
    #[test]
    fn manual_3_4_intended_commands_encode() {
        let c = cmd(0x0906, 5, Par2::Int(12345));
        assert_eq!(c.encode().unwrap(), b"\x01\x020906;5;0;12345\x030\x04");
        let c = cmd(0x1906, 2, Par2::Int(0));
        assert_eq!(c.encode().unwrap(), b"\x01\x021906;2;0;0\x037\x04");
        // "Move axis 2 to absolute position 5552.0", written as printed.
        let c = cmd(0x0A87, 2, Par2::Float(5552.0));
        assert_eq!(c.encode().unwrap(), b"\x01\x020A87;2;1;5552.0\x0395\x04");
        let opts = EncodeOptions { check_rule: CheckRule::WithEtx, ..Default::default() };
        let mut buf = Vec::new();
        c.encode_with(&opts, &mut buf).unwrap();
        assert_eq!(buf, b"\x01\x020A87;2;1;5552.0\x0392\x04");
        // 3.4.2 command 4's printed bytes (1971;3;0;0, CHECK 6) are
        // self-consistent garbage: they decode literally.
        let b = hex("01 02 31 39 37 31 3B 33 3B 30 3B 30 03 36 04");
        assert_eq!(Command::decode(&b).unwrap(), (cmd(0x1971, 3, Par2::Int(0)), CheckRule::Strict));
    }

    // Every acknowledge printed in manual 3.4, with the rule its CHECK matches.
    #[test]
    fn manual_3_4_acknowledges() {
        use CheckRule::*;
        let cases: &[(&str, Ack, FloatFormat)] = &[
            // 3.4.1: N5 := 12345
            (
                "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 31 32 33 34 35 03 35 37 04",
                ack(0, true, 1, 0, Par2::Int(12345), WithEtx),
                FloatFormat::Shortest,
            ),
            // 3.4.2: input 5 = 1
            (
                "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 31 03 35 37 04",
                ack(0, true, 1, 0, Par2::Int(1), WithEtx),
                FloatFormat::Shortest,
            ),
            // 3.4.2: N2 = 222
            (
                "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 32 32 32 03 35 38 04",
                ack(0, true, 1, 0, Par2::Int(222), WithEtx),
                FloatFormat::Shortest,
            ),
            // 3.4.2: N3 := 333
            (
                "01 02 30 3B 31 3B 31 3B 30 3B 30 3B 33 33 33 03 35 39 04",
                ack(0, true, 1, 0, Par2::Int(333), WithEtx),
                FloatFormat::Shortest,
            ),
            // 3.4.2: R1 = 640.0000
            (
                "01 02 30 3B 31 3B 31 3B 30 3B 31 3B 36 34 30 2E 30 30 30 30 03 32 31 04",
                ack(0, true, 1, 0, Par2::Float(640.0), WithEtx),
                FloatFormat::Fixed(4),
            ),
            // 3.4.3: online mode started, status 31; this one is Strict.
            (
                "01 02 30 3B 31 3B 33 31 3B 30 3B 30 3B 30 03 38 04",
                ack(0, true, 31, 0, Par2::Int(0), Strict),
                FloatFormat::Shortest,
            ),
            // 3.4.3: 0A87 started at 1255.000, BE = 0
            (
                "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 32 35 35 2E 30 30 30 03 33 38 04",
                ack(0, false, 31, 0, Par2::Float(1255.0), WithEtx),
                FloatFormat::Fixed(3),
            ),
            // 3.4.3: first poll, 1516.950
            (
                "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 31 35 31 36 2E 39 35 30 03 34 32 04",
                ack(0, false, 31, 0, Par2::Float(1516.95), WithEtx),
                FloatFormat::Fixed(3),
            ),
            // 3.4.3: second poll, 2634.750
            (
                "01 02 30 3B 30 3B 33 31 3B 30 3B 31 3B 32 36 33 34 2E 37 35 30 03 33 36 04",
                ack(0, false, 31, 0, Par2::Float(2634.75), WithEtx),
                FloatFormat::Fixed(3),
            ),
            // 3.4.3: third poll, target 5552.000 reached, BE = 1
            (
                "01 02 30 3B 31 3B 33 31 3B 30 3B 31 3B 35 35 35 32 2E 30 30 30 03 33 35 04",
                ack(0, true, 31, 0, Par2::Float(5552.0), WithEtx),
                FloatFormat::Fixed(3),
            ),
        ];
        for (bytes, expected, fmt) in cases {
            let bytes = hex(bytes);
            assert_eq!(Ack::decode(&bytes).as_ref(), Ok(expected), "{bytes:02x?}");
            let mut out = Vec::new();
            expected.encode_with(*fmt, &mut out).unwrap();
            assert_eq!(out, bytes, "encode {expected:?}");
        }
    }

    #[test]
    fn checksum_known_answers() {
        assert_eq!(CheckRule::Strict.compute(b"1900;5;0;0"), 6);
        assert_eq!(CheckRule::Strict.compute(b"0906;3;0;333"), 4);
        assert_eq!(CheckRule::Strict.compute(b"0603;0;0;0"), 14);
        assert_eq!(CheckRule::WithEtx.compute(b"0;1;1;0;0;12345"), 57);
        assert_eq!(CheckRule::WithEtx.compute(b"0;1;1;0;1;640.0000"), 21);
        assert_eq!(CheckRule::Omitted.compute(b"0;1;1;0;1;640.0000"), 0);
    }

    #[test]
    fn float_formats() {
        assert_eq!(format_float(5552.0, FloatFormat::Shortest), "5552.0");
        assert_eq!(format_float(-0.5, FloatFormat::Shortest), "-0.5");
        assert_eq!(format_float(0.1, FloatFormat::Shortest), "0.1");
        assert_eq!(format_float(640.0, FloatFormat::Fixed(4)), "640.0000");
        assert_eq!(format_float(1516.95, FloatFormat::Fixed(3)), "1516.950");
        let c = cmd(0x0A87, 1, Par2::Float(f64::NAN));
        assert_eq!(c.encode(), Err(EncodeError::NonFinite { field: "PAR_2" }));
    }

    #[test]
    fn omitted_check() {
        let c = cmd(0x190B, 0, Par2::Int(0));
        let opts = EncodeOptions { check_rule: CheckRule::Omitted, ..Default::default() };
        let mut buf = Vec::new();
        c.encode_with(&opts, &mut buf).unwrap();
        assert_eq!(buf, b"\x01\x02190B;0;0;0\x030\x04");
        assert_eq!(Command::decode(&buf).unwrap(), (c, CheckRule::Omitted));
        let mut d = CommandDecoder::new().accept_omitted_check(false);
        d.push(&buf);
        assert!(matches!(d.next(), Some(Err(FrameError::BadCheck { received: 0, .. }))));
        // Acks: off by default.
        let a = ack(0, true, 31, 0, Par2::Int(0), CheckRule::Omitted);
        let bytes = a.encode().unwrap();
        assert!(matches!(Ack::decode(&bytes), Err(FrameError::BadCheck { .. })));
        let mut d = AckDecoder::new().accept_omitted_check(true);
        d.push(&bytes);
        assert_eq!(d.next(), Some(Ok(a)));
    }

    #[test]
    fn stream_resync_and_errors() {
        let good = ack(0, true, 1, 0, Par2::Int(12345), CheckRule::WithEtx).encode().unwrap();
        let mut stream = b"garbage\r\n".to_vec();
        stream.extend_from_slice(&good);
        // Half a frame, cut off by the next SOH.
        stream.extend_from_slice(b"\x01\x020;1;1");
        stream.extend_from_slice(&good);
        // SOH without STX.
        stream.extend_from_slice(b"\x01x");
        // Bad check.
        stream.extend_from_slice(b"\x01\x020;1;1;0;0;1\x0399\x04");
        // Missing field.
        stream.extend_from_slice(b"\x01\x020;1;1;0;0\x03");
        stream.extend_from_slice(CheckRule::Strict.compute(b"0;1;1;0;0").to_string().as_bytes());
        stream.push(EOT);
        // Bad field.
        stream.extend_from_slice(b"\x01\x020;2;1;0;0;1\x03");
        stream.extend_from_slice(CheckRule::Strict.compute(b"0;2;1;0;0;1").to_string().as_bytes());
        stream.push(EOT);
        // The 8th bit set everywhere (a pty ignores 7-bit settings).
        stream.extend(good.iter().map(|b| b | 0x80));
        let mut d = AckDecoder::new();
        // Byte by byte, to exercise partial frames.
        let mut out = Vec::new();
        for b in &stream {
            d.push(std::slice::from_ref(b));
            while let Some(r) = d.next() {
                out.push(r);
            }
        }
        let a = Ack::decode(&good).unwrap();
        assert_eq!(
            out,
            vec![
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::Garbage { len: 1 }),
                Ok(a),
                Err(FrameError::Truncated { len: 7 }),
                Ok(a),
                Err(FrameError::MissingStx),
                Err(FrameError::Garbage { len: 1 }),
                Err(FrameError::BadCheck { received: 99, strict: 58, with_etx: 57 }),
                Err(FrameError::MissingField { field: "Q_PAR" }),
                Err(FrameError::BadField { field: "BE", text: "2".into() }),
                Ok(a),
            ]
        );
        assert_eq!(d.buffered(), 0);
        // All at once: garbage coalesces into one report.
        let mut d = AckDecoder::new();
        d.push(&stream);
        let first = d.next();
        assert_eq!(first, Some(Err(FrameError::Garbage { len: 9 })));
        let rest: Vec<_> = std::iter::from_fn(|| d.next()).collect();
        assert_eq!(rest.len(), 9);
    }

    #[test]
    fn too_long_frame_is_dropped() {
        let mut d = AckDecoder::new();
        d.push(b"\x01\x02");
        d.push(&vec![b'1'; MAX_FRAME + 10]);
        assert_eq!(d.next(), Some(Err(FrameError::TooLong)));
        assert!(matches!(d.next(), Some(Err(FrameError::Garbage { .. }))));
        assert_eq!(d.buffered(), 0);
        let good = ack(0, true, 1, 0, Par2::Int(1), CheckRule::Strict).encode().unwrap();
        d.push(&good);
        assert!(matches!(d.next(), Some(Ok(_))));
    }

    // Found by fuzzing (fuzz/fuzz_targets/pac_ack_stream.rs): a frame that
    // reached MAX_FRAME bytes was TooLong when a read ended there but
    // Truncated when the next byte came in the same read, and the EOT after
    // it then read as a poll or not depending on read timing.
    #[test]
    fn long_frame_verdict_does_not_depend_on_read_boundaries() {
        let mut stream = b"\x01\x02".to_vec();
        stream.extend(std::iter::repeat_n(b'1', MAX_FRAME - 3));
        stream.push(EOT);
        stream.extend_from_slice(&POLL);
        let run = |reads: &[&[u8]]| {
            let mut d = CommandDecoder::new();
            let mut out = Vec::new();
            for r in reads {
                d.push(r);
                out.extend(std::iter::from_fn(|| d.next()));
            }
            out
        };
        let whole = run(&[&stream]);
        assert_eq!(whole.first(), Some(&Err(FrameError::TooLong)));
        assert_eq!(whole.iter().filter(|r| **r == Ok(Request::Poll)).count(), 2);
        for cut in [MAX_FRAME - 2, MAX_FRAME - 1, MAX_FRAME] {
            let (a, b) = stream.split_at(cut);
            assert_eq!(run(&[a, b]), whole, "split at {cut}");
        }
    }

    #[test]
    fn command_decoder_sees_polls() {
        let c = cmd(0x0A87, 2, Par2::Float(5552.0));
        let mut d = CommandDecoder::new();
        let mut bytes = c.encode().unwrap();
        bytes.extend_from_slice(&POLL);
        bytes.extend_from_slice(&POLL);
        // An EOT that ends a cut-off frame is not a poll.
        bytes.extend_from_slice(b"\x01\x020A87;2\x04");
        d.push(&bytes);
        let out: Vec<_> = std::iter::from_fn(|| d.next()).collect();
        assert_eq!(
            out,
            vec![
                Ok(Request::Command { command: c, check_rule: CheckRule::Strict }),
                Ok(Request::Poll),
                Ok(Request::Poll),
                Err(FrameError::Truncated { len: 9 }),
            ]
        );
        // Acks never treat a lone EOT as anything but noise.
        let mut d = AckDecoder::new();
        d.push(&POLL);
        assert_eq!(d.next(), Some(Err(FrameError::Garbage { len: 1 })));
    }

    #[test]
    fn command_field_errors() {
        let frame = |body: &str| {
            let mut v = Vec::new();
            finish_frame(body.as_bytes(), CheckRule::Strict, &mut v);
            v
        };
        assert_eq!(
            Command::decode(&frame("0A8;2;0;0")),
            Err(FrameError::BadField { field: "CMD", text: "0A8".into() })
        );
        assert_eq!(Command::decode(&frame("0A87;2;2;0")), Err(FrameError::BadField { field: "TYP", text: "2".into() }));
        assert_eq!(
            Command::decode(&frame("0A87;2;0;1.5")),
            Err(FrameError::BadField { field: "PAR_2", text: "1.5".into() })
        );
        assert_eq!(
            Command::decode(&frame("0A87;2;1;nan")),
            Err(FrameError::BadField { field: "PAR_2", text: "nan".into() })
        );
        assert_eq!(Command::decode(&frame("0A87;2;1")), Err(FrameError::MissingField { field: "PAR_2" }));
        assert_eq!(Command::decode(&frame("0A87;;1;0")), Err(FrameError::MissingField { field: "PAR_1" }));
        assert_eq!(Command::decode(&frame("0A87;2;1;0;7")), Err(FrameError::ExtraField { count: 1 }));
        assert_eq!(
            Command::decode(b"\x01\x021900;5;0;0\x031234\x04"),
            Err(FrameError::BadField { field: "CHECK", text: "1234".into() })
        );
        assert_eq!(Command::decode(b"\x01\x021900;5;0;0\x03\x04"), Err(FrameError::MissingField { field: "CHECK" }));
        // Lowercase hex and negative numbers are accepted.
        assert_eq!(Command::decode(&frame("0a87;-2;1;-1.25")).unwrap().0, cmd(0x0A87, -2, Par2::Float(-1.25)));
    }

    // The RS232 columns of the chapter 5 examples print values with leading
    // zeros and varying decimals; the decoders must read every form.
    #[test]
    fn chapter_5_value_forms() {
        let frame = |body: &str| {
            let mut v = Vec::new();
            finish_frame(body.as_bytes(), CheckRule::WithEtx, &mut v);
            v
        };
        // Commands: 5.2.3.1 (1800 # 0543 # 0), 5.2.3 (0800 # 774 # 200.00),
        // 5.2.4.14 (1907 # 0037), 5.2.6.12 (0A92 # 4 # 0.0).
        let cmds = [
            ("1800;0543;1;0", cmd(0x1800, 543, Par2::Float(0.0))),
            ("0800;774;1;200.00", cmd(0x0800, 774, Par2::Float(200.0))),
            ("1907;0037;1;0", cmd(0x1907, 37, Par2::Float(0.0))),
            ("0A92;4;1;0.0", cmd(0x0A92, 4, Par2::Float(0.0))),
            ("0A96;0004;1;0.0", cmd(0x0A96, 4, Par2::Float(0.0))),
            ("0903;25;0;15889", cmd(0x0903, 25, Par2::Int(15889))),
        ];
        for (body, expected) in cmds {
            assert_eq!(Command::decode(&frame(body)).unwrap(), (expected, CheckRule::WithEtx), "{body}");
        }
        // Acknowledge dates of 5.2.2 - 5.2.6.
        let dates = [
            ("0;00004", Par2::Int(4)),
            ("0;36099", Par2::Int(36099)),
            ("0;88224", Par2::Int(88224)),
            ("0;529", Par2::Int(529)),
            ("0;16777476", Par2::Int(16777476)),
            ("0;00208", Par2::Int(208)),
            ("1;0.00000", Par2::Float(0.0)),
            ("1;50000.00", Par2::Float(50000.0)),
            ("1;7000.000", Par2::Float(7000.0)),
            ("1;10.00000", Par2::Float(10.0)),
            ("1;111.11100", Par2::Float(111.111)),
            ("1;5000.000", Par2::Float(5000.0)),
            ("1;40.03", Par2::Float(40.03)),
            ("1;640.50", Par2::Float(640.5)),
            ("1;20480.0", Par2::Float(20480.0)),
        ];
        for (date, expected) in dates {
            let a = Ack::decode(&frame(&format!("0;1;31;0;{date}"))).unwrap();
            assert_eq!(a.q_par, expected, "{date}");
        }
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        fn par2() -> impl Strategy<Value = Par2> {
            prop_oneof![
                any::<i64>().prop_map(Par2::Int),
                any::<f64>().prop_filter("finite", |f| f.is_finite()).prop_map(Par2::Float),
            ]
        }

        fn rule() -> impl Strategy<Value = CheckRule> {
            prop_oneof![Just(CheckRule::Strict), Just(CheckRule::WithEtx)]
        }

        proptest! {
            #[test]
            fn decoders_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
                let mut a = AckDecoder::new();
                a.push(&bytes);
                while a.next().is_some() {}
                prop_assert!(a.buffered() <= MAX_FRAME + 1);
                let mut c = CommandDecoder::new();
                c.push(&bytes);
                while c.next().is_some() {}
                prop_assert!(c.buffered() <= MAX_FRAME + 1);
                let _ = Ack::decode(&bytes);
                let _ = Command::decode(&bytes);
            }

            #[test]
            fn framed_noise_never_panics(body in "[0-9;.eE+-]{0,40}", check in "[0-9]{0,4}") {
                let mut bytes = vec![SOH, STX];
                bytes.extend_from_slice(body.as_bytes());
                bytes.push(ETX);
                bytes.extend_from_slice(check.as_bytes());
                bytes.push(EOT);
                let _ = Ack::decode(&bytes);
                let _ = Command::decode(&bytes);
            }

            #[test]
            fn command_round_trip(code in any::<u16>(), par1 in any::<i64>(), par2 in par2(), rule in rule()) {
                let c = Command::new(code, par1, par2);
                let mut buf = Vec::new();
                c.encode_with(&EncodeOptions { check_rule: rule, ..Default::default() }, &mut buf).unwrap();
                prop_assert_eq!(Command::decode(&buf).unwrap(), (c, rule));
            }

            #[test]
            fn ack_round_trip(quit in any::<u16>(), be in any::<bool>(), status in any::<u16>(), error in any::<u16>(),
                              q_par in par2(), check_rule in rule()) {
                let a = Ack { quit, be, status, error, q_par, check_rule };
                let bytes = a.encode().unwrap();
                prop_assert_eq!(Ack::decode(&bytes).unwrap(), a);
                // Split anywhere, with noise in front, through the stream decoder.
                let mut d = AckDecoder::new();
                let cut = bytes.len() / 2;
                d.push(b"\xff\x00");
                d.push(&bytes[..cut]);
                let mut got = Vec::new();
                while let Some(r) = d.next() { got.push(r); }
                d.push(&bytes[cut..]);
                while let Some(r) = d.next() { got.push(r); }
                prop_assert_eq!(got.last().cloned(), Some(Ok(a)));
            }
        }
    }
}
