//! Sans-IO protocol core: frame types, codecs and the protocol tables.
//!
//! Nothing in here performs I/O or reads a clock. Links feed bytes or CAN
//! frames in; typed frames come out, and typed frames encode to bytes.

pub mod bus;
pub mod can;
pub mod can_error;
pub mod candump;
pub mod cdios;
pub mod flag_word;
pub mod pac;
pub mod powercube;
pub mod refusal;
pub mod slcan;
pub mod socketcand;

pub use can::CanFrame;
pub use refusal::Refusal;

/// Why a sequence of bytes or a frame could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    #[error("frame too short: need {need} bytes, got {got}")]
    TooShort { need: usize, got: usize },
    #[error("frame too long: {len} bytes")]
    TooLong { len: usize },
    #[error("bad checksum: computed {computed:#04x}, received {received:#04x}")]
    Checksum { computed: u8, received: u8 },
    #[error("unknown {what} {value:#04x}")]
    Unknown { what: &'static str, value: u32 },
    #[error("malformed frame: {0}")]
    Malformed(String),
}

/// A number as a user types it: decimal, `0x` hex or `0b` binary (either
/// case), surrounding blanks ignored.
fn split_radix(t: &str) -> (&str, u32) {
    if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        (h, 16)
    } else if let Some(b) = t.strip_prefix("0b").or_else(|| t.strip_prefix("0B")) {
        (b, 2)
    } else {
        (t, 10)
    }
}

/// A signed integer as a user types it: decimal, `0x` hex or `0b` binary,
/// with an optional sign. `None` for anything else, never a panic.
pub fn parse_int(text: &str) -> Option<i64> {
    let t = text.trim();
    let (neg, body) = match t.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, t.strip_prefix('+').unwrap_or(t)),
    };
    let (digits, radix) = split_radix(body);
    let v = i64::from_str_radix(digits, radix).ok()?;
    // The digits may carry a sign of their own ("--5", "-0x-8000000000000000"):
    // negating i64::MIN must be a parse error, not an overflow.
    if neg {
        v.checked_neg()
    } else {
        Some(v)
    }
}

/// An unsigned integer as a user types it: decimal, `0x` hex or `0b` binary.
pub fn parse_uint(text: &str) -> Option<u64> {
    let (digits, radix) = split_radix(text.trim());
    // from_str_radix takes a leading '+'; a second sign is not a number here.
    if digits.starts_with(['+', '-']) {
        return None;
    }
    u64::from_str_radix(digits, radix).ok()
}

#[cfg(test)]
mod parse_tests {
    use super::*;

    #[test]
    fn user_numbers() {
        assert_eq!(parse_int(" -0x10 "), Some(-16));
        assert_eq!(parse_int("0B101"), Some(5));
        assert_eq!(parse_int("+7"), Some(7));
        assert_eq!(parse_int("--9223372036854775808"), None);
        assert_eq!(parse_int("x"), None);
        assert_eq!(parse_uint("0x3E11"), Some(15889));
        assert_eq!(parse_uint("18446744073709551615"), Some(u64::MAX));
        assert_eq!(parse_uint("-1"), None);
        assert_eq!(parse_uint("0x-1"), None);
    }
}
