//! A classic CAN 2.0 data frame, independent of any platform socket type.

use std::fmt;

/// Largest standard (11-bit) identifier.
pub const MAX_STANDARD_ID: u32 = 0x7FF;
/// Largest extended (29-bit) identifier.
pub const MAX_EXTENDED_ID: u32 = 0x1FFF_FFFF;

/// A CAN data frame with up to 8 data bytes.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanFrame {
    id: u32,
    extended: bool,
    len: u8,
    data: [u8; 8],
}

impl CanFrame {
    /// A standard-id frame; `None` if the id exceeds 11 bits or data exceeds 8 bytes.
    pub fn new(id: u32, data: &[u8]) -> Option<Self> {
        (id <= MAX_STANDARD_ID).then_some(())?;
        Self::build(id, false, data)
    }

    /// An extended-id frame; `None` if the id exceeds 29 bits or data exceeds 8 bytes.
    pub fn new_extended(id: u32, data: &[u8]) -> Option<Self> {
        (id <= MAX_EXTENDED_ID).then_some(())?;
        Self::build(id, true, data)
    }

    fn build(id: u32, extended: bool, data: &[u8]) -> Option<Self> {
        if data.len() > 8 {
            return None;
        }
        let mut buf = [0u8; 8];
        buf[..data.len()].copy_from_slice(data);
        Some(Self { id, extended, len: data.len() as u8, data: buf })
    }

    pub fn id(&self) -> u32 {
        self.id
    }

    pub fn is_extended(&self) -> bool {
        self.extended
    }

    pub fn data(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    pub fn dlc(&self) -> usize {
        self.len as usize
    }
}

/// candump form: `0F1#01`, `12345678#DEADBEEF`, `100#` for no data.
impl fmt::Display for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.extended {
            write!(f, "{:08X}#", self.id)?;
        } else {
            write!(f, "{:03X}#", self.id)?;
        }
        for b in self.data() {
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "CanFrame({self})")
    }
}

impl std::str::FromStr for CanFrame {
    type Err = super::DecodeError;

    /// Parses candump form `ID#HEX` (3 hex digits standard, 8 extended).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || super::DecodeError::Malformed(format!("not a candump frame: {s:?}"));
        let (id, data) = s.split_once('#').ok_or_else(bad)?;
        if data.len() % 2 != 0 || data.len() > 16 || id.is_empty() {
            return Err(bad());
        }
        let id_val = u32::from_str_radix(id, 16).map_err(|_| bad())?;
        let mut bytes = [0u8; 8];
        let n = data.len() / 2;
        for (i, slot) in bytes.iter_mut().enumerate().take(n) {
            *slot = u8::from_str_radix(data.get(2 * i..2 * i + 2).ok_or_else(bad)?, 16).map_err(|_| bad())?;
        }
        let frame = if id.len() > 3 { Self::new_extended(id_val, &bytes[..n]) } else { Self::new(id_val, &bytes[..n]) };
        frame.ok_or_else(bad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candump_round_trip() {
        let f = CanFrame::new(0x0F1, &[0x01]).unwrap();
        assert_eq!(f.to_string(), "0F1#01");
        assert_eq!("0F1#01".parse::<CanFrame>().unwrap(), f);
        let e = CanFrame::new_extended(0x1234_5678, &[0xde, 0xad]).unwrap();
        assert_eq!(e.to_string(), "12345678#DEAD");
        assert_eq!("12345678#DEAD".parse::<CanFrame>().unwrap(), e);
        assert_eq!("100#".parse::<CanFrame>().unwrap().dlc(), 0);
    }

    #[test]
    fn rejects_bad_frames() {
        assert!(CanFrame::new(0x800, &[]).is_none());
        assert!(CanFrame::new(1, &[0; 9]).is_none());
        for s in ["", "0F1", "0F1#1", "XYZ#00", "0F1#001122334455667788", "é#00"] {
            assert!(s.parse::<CanFrame>().is_err(), "{s}");
        }
    }
}
