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

/// Bits after the CRC sequence: CRC delimiter, ACK slot and delimiter, end of
/// frame (7) and intermission (3). None of them is stuffed.
const TRAILER_BITS: u32 = 13;

impl CanFrame {
    /// The frame's length on the wire in bits, stuff bits included, with
    /// the 3-bit intermission: what the bus is busy for (ISO 11898-1).
    pub fn wire_bits(&self) -> u32 {
        fn push(bits: &mut Vec<bool>, v: u32, n: u32) {
            bits.extend((0..n).rev().map(|i| v >> i & 1 == 1));
        }
        let mut bits: Vec<bool> = Vec::with_capacity(64 + 8 * self.dlc());
        let b = &mut bits;
        push(b, 0, 1); // SOF
        if self.extended {
            push(b, self.id >> 18, 11);
            push(b, 0b11, 2); // SRR, IDE
            push(b, self.id & 0x3_FFFF, 18);
            push(b, 0b000, 3); // RTR, r1, r0
        } else {
            push(b, self.id, 11);
            push(b, 0b000, 3); // RTR, IDE, r0
        }
        push(b, self.len.into(), 4);
        for byte in self.data() {
            push(b, (*byte).into(), 8);
        }
        let crc = bits.iter().fold(0u16, |crc, &bit| {
            let top = (crc >> 14) & 1 == 1;
            let crc = (crc << 1) & 0x7FFF;
            if top != bit {
                crc ^ 0x4599
            } else {
                crc
            }
        });
        push(&mut bits, crc.into(), 15);
        let mut stuffed = 0;
        let mut run = 0;
        let mut last = None;
        for &b in &bits {
            if Some(b) == last {
                run += 1;
            } else {
                run = 1;
                last = Some(b);
            }
            if run == 5 {
                stuffed += 1;
                // The stuff bit is the complement and starts a new run.
                last = Some(!b);
                run = 1;
            }
        }
        bits.len() as u32 + stuffed + TRAILER_BITS
    }
}

#[cfg(test)]
mod wire_tests {
    use super::*;

    #[test]
    fn wire_bits_match_the_standard_frame_layout() {
        // 44 + 8n unstuffed bits up to the CRC delimiter... plus trailer: 47 + 8n
        // without stuffing. An all-zero frame stuffs heavily.
        let f = CanFrame::new(0x555, &[0x55; 8]).unwrap();
        assert!(f.wire_bits() >= 47 + 64, "{}", f.wire_bits());
        assert!(f.wire_bits() <= 47 + 64 + 24, "{}", f.wire_bits());
        let zeros = CanFrame::new(0, &[0; 8]).unwrap();
        assert!(zeros.wire_bits() > f.wire_bits(), "zeros need stuff bits");
        // The longest classic frame is 135 bits with intermission (worst-case stuffing + IFS).
        for id in [0u32, 0x7FF, 0x0F1, 0x100] {
            for d in [[0u8; 8], [0xFF; 8], [0x0F; 8]] {
                let b = CanFrame::new(id, &d).unwrap().wire_bits();
                assert!((111..=135).contains(&b), "{id:#x} {d:?}: {b}");
            }
        }
        let e = CanFrame::new_extended(0x1234_5678, &[1, 2]).unwrap();
        assert!(e.wire_bits() >= 67 + 16, "{}", e.wire_bits());
    }
}
