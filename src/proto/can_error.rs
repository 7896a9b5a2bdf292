//! CAN error frames as SocketCAN delivers them (`linux/can/error.h`): an id
//! with the error flag (0x20000000) whose low bits are the error classes, and
//! 8 data bytes with the details. candump logs them the same way
//! (`20000004#0004000000000000`). An slcan adapter's error report (`e1a`,
//! `sb256256`, as the Linux slcan driver reads them) is turned into the same
//! form, so one decoder names them all.

use std::fmt;

use super::DecodeError;

/// The error flag of a SocketCAN id (`CAN_ERR_FLAG`).
pub const ERR_FLAG: u32 = 0x2000_0000;
/// The class bits below it (`CAN_ERR_MASK`).
pub const ERR_MASK: u32 = 0x1FFF_FFFF;

// Classes (`can_id` bits).
const TX_TIMEOUT: u32 = 0x001;
const LOSTARB: u32 = 0x002;
const CRTL: u32 = 0x004;
const PROT: u32 = 0x008;
const TRX: u32 = 0x010;
const ACK: u32 = 0x020;
const BUSOFF: u32 = 0x040;
const BUSERROR: u32 = 0x080;
const RESTARTED: u32 = 0x100;
const CNT: u32 = 0x200;

/// `data[1]`: controller problems.
const CRTL_FLAGS: [(u8, &str); 7] = [
    (0x01, "rx overflow"),
    (0x02, "tx overflow"),
    (0x04, "rx warning"),
    (0x08, "tx warning"),
    (0x10, "rx passive"),
    (0x20, "tx passive"),
    (0x40, "back to error active"),
];
/// `data[2]`: protocol violation types.
const PROT_FLAGS: [(u8, &str); 8] = [
    (0x01, "bit error"),
    (0x02, "form error"),
    (0x04, "stuff error"),
    (0x08, "bit0 error (cannot send dominant)"),
    (0x10, "bit1 error (cannot send recessive)"),
    (0x20, "bus overload"),
    (0x40, "active error announcement"),
    (0x80, "while transmitting"),
];
/// `data[3]`: where in the frame a protocol violation was seen.
const PROT_LOCATIONS: [(u8, &str); 20] = [
    (0x03, "start of frame"),
    (0x02, "id bits 28-21"),
    (0x06, "id bits 20-18"),
    (0x04, "SRTR bit"),
    (0x05, "IDE bit"),
    (0x07, "id bits 17-13"),
    (0x0F, "id bits 12-5"),
    (0x0E, "id bits 4-0"),
    (0x0C, "RTR bit"),
    (0x0D, "reserved bit 1"),
    (0x09, "reserved bit 0"),
    (0x0B, "DLC"),
    (0x0A, "data"),
    (0x08, "CRC sequence"),
    (0x18, "CRC delimiter"),
    (0x19, "ACK slot"),
    (0x1B, "ACK delimiter"),
    (0x1A, "end of frame"),
    (0x12, "intermission"),
    (0x00, "unspecified location"),
];

/// One error frame: its classes and details, as SocketCAN has them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ErrorFrame {
    /// The class bits (the id without the error flag).
    pub class: u32,
    pub data: [u8; 8],
}

impl ErrorFrame {
    /// From a SocketCAN id (with or without the flag) and up to 8 data bytes.
    pub fn new(id: u32, data: &[u8]) -> Self {
        let mut d = [0u8; 8];
        let n = data.len().min(8);
        d[..n].copy_from_slice(&data[..n]);
        Self { class: id & ERR_MASK, data: d }
    }

    /// The SocketCAN id: the flag and the classes.
    pub fn id(&self) -> u32 {
        ERR_FLAG | self.class
    }

    /// A candump log frame `20000004#0004000000000000`, if it is an error frame.
    pub fn parse_candump(text: &str) -> Option<Result<Self, DecodeError>> {
        let (id, data) = text.split_once('#')?;
        let id_val = u32::from_str_radix(id, 16).ok().filter(|_| id.len() == 8)?;
        if id_val & ERR_FLAG == 0 {
            return None;
        }
        let bad = || DecodeError::Malformed(format!("not a candump error frame: {text:?}"));
        if id_val > ERR_FLAG | ERR_MASK || data.len() % 2 != 0 || data.len() > 16 {
            return Some(Err(bad()));
        }
        let bytes: Option<Vec<u8>> = (0..data.len() / 2)
            .map(|i| data.get(2 * i..2 * i + 2).and_then(|h| u8::from_str_radix(h, 16).ok()))
            .collect();
        Some(bytes.map(|b| Self::new(id_val, &b)).ok_or_else(bad))
    }

    /// An slcan adapter's error report, as the Linux slcan driver reads it:
    /// `e` + count + that many letters (`e1a`: ACK error; `e3bcO`), or a state
    /// change `s` + a / w / p / b + rx and tx error counters (`sb256256`).
    /// `None` for any other line.
    pub fn from_slcan(line: &[u8]) -> Option<Self> {
        let (&kind, rest) = line.split_first()?;
        match kind {
            b'e' => {
                let (&n, letters) = rest.split_first()?;
                let n = (n as char).to_digit(10)? as usize;
                if n == 0 || letters.len() != n {
                    return None;
                }
                let mut f = Self::new(PROT | BUSERROR, &[]);
                for &c in letters {
                    match c {
                        b'a' => f.class |= ACK,
                        b'b' => f.data[2] |= 0x08,
                        b'B' => f.data[2] |= 0x10,
                        b'c' => {
                            f.data[2] |= 0x01;
                            f.data[3] = 0x08;
                        }
                        b'f' => f.data[2] |= 0x02,
                        b'o' => {
                            f.class |= CRTL;
                            f.data[1] |= 0x01;
                        }
                        b'O' => {
                            f.class |= CRTL;
                            f.data[1] |= 0x02;
                        }
                        b's' => f.data[2] |= 0x04,
                        _ => return None,
                    }
                }
                // The driver sets the protocol class for every report; one
                // without a protocol letter (`e1a`) has nothing to say there.
                if f.data[2] == 0 {
                    f.class &= !PROT;
                }
                Some(f)
            }
            b's' if rest.len() == 7 => {
                let counter = |d: &[u8]| -> Option<u16> { std::str::from_utf8(d).ok()?.parse().ok() };
                let (rx, tx) = (counter(&rest[1..4])?, counter(&rest[4..7])?);
                let mut f = Self::new(CNT, &[]);
                f.data[6] = tx.min(255) as u8;
                f.data[7] = rx.min(255) as u8;
                match rest[0] {
                    b'a' => {
                        f.class |= CRTL;
                        f.data[1] = 0x40;
                    }
                    b'w' => {
                        f.class |= CRTL;
                        f.data[1] = if tx >= rx { 0x08 } else { 0x04 };
                    }
                    b'p' => {
                        f.class |= CRTL;
                        f.data[1] = if tx >= rx { 0x20 } else { 0x10 };
                    }
                    b'b' => f.class |= BUSOFF,
                    _ => return None,
                }
                Some(f)
            }
            _ => None,
        }
    }

    /// What happened, one phrase per class, in `linux/can/error.h` order.
    pub fn problems(&self) -> Vec<String> {
        let d = &self.data;
        let flags = |table: &[(u8, &str)], byte: u8| -> String {
            let named: Vec<&str> = table.iter().filter(|(b, _)| byte & b != 0).map(|(_, n)| *n).collect();
            if named.is_empty() {
                "unspecified".into()
            } else {
                named.join(", ")
            }
        };
        let mut out = Vec::new();
        if self.class & TX_TIMEOUT != 0 {
            out.push("transmit timeout".into());
        }
        if self.class & LOSTARB != 0 {
            out.push(match d[0] {
                0 => "lost arbitration".into(),
                bit => format!("lost arbitration at bit {bit}"),
            });
        }
        if self.class & CRTL != 0 {
            out.push(format!("controller: {}", flags(&CRTL_FLAGS, d[1])));
        }
        if self.class & PROT != 0 {
            let at = PROT_LOCATIONS.iter().find(|(l, _)| *l == d[3]).map_or("unknown location", |(_, n)| n);
            let at = if d[3] == 0 { String::new() } else { format!(" at {at}") };
            out.push(format!("protocol violation: {}{at}", flags(&PROT_FLAGS, d[2])));
        }
        if self.class & TRX != 0 {
            out.push(format!("transceiver status {:#04x}", d[4]));
        }
        if self.class & ACK != 0 {
            out.push("no acknowledge (no other node on the bus, or a wrong bitrate?)".into());
        }
        if self.class & BUSOFF != 0 {
            out.push("bus off".into());
        }
        if self.class & BUSERROR != 0 && out.is_empty() {
            out.push("bus error".into());
        }
        if self.class & RESTARTED != 0 {
            out.push("controller restarted".into());
        }
        if self.class & CNT != 0 {
            out.push(format!("error counters tx {} rx {}", d[6], d[7]));
        }
        let unknown = self.class & !(0x3FF);
        if unknown != 0 {
            out.push(format!("unknown error class {unknown:#x}"));
        }
        if out.is_empty() {
            out.push("error frame without a class".into());
        }
        out
    }
}

/// What a CAN link hands a listener: a data frame or an error frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CanEvent {
    Frame(super::CanFrame),
    Error(ErrorFrame),
}

/// candump form: `20000004#0004000000000000`.
impl fmt::Display for ErrorFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:08X}#", self.id())?;
        self.data.iter().try_for_each(|b| write!(f, "{b:02X}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candump_error_frames_decode_as_candump_names_them() {
        // candump -e names these "controller-problem{rx-error-warning}" and
        // "bus-off" / "protocol-violation{{tx-dominant-bit-error}{}}"
        let f = ErrorFrame::parse_candump("20000004#0004000000000000").unwrap().unwrap();
        assert_eq!(f.problems(), ["controller: rx warning"]);
        assert_eq!(f.to_string(), "20000004#0004000000000000");
        let f = ErrorFrame::parse_candump("20000040#0000000000000000").unwrap().unwrap();
        assert_eq!(f.problems(), ["bus off"]);
        let f = ErrorFrame::parse_candump("20000088#0000880800000000").unwrap().unwrap();
        assert_eq!(
            f.problems(),
            ["protocol violation: bit0 error (cannot send dominant), while transmitting at CRC sequence"]
        );
        let f = ErrorFrame::parse_candump("20000202#0500000000000A0B").unwrap().unwrap();
        assert_eq!(f.problems(), ["lost arbitration at bit 5", "error counters tx 10 rx 11"]);
        assert!(ErrorFrame::parse_candump("0F1#01").is_none(), "a data frame");
        assert!(ErrorFrame::parse_candump("12345678#01").is_none(), "an extended data frame");
        assert!(ErrorFrame::parse_candump("20000004#0").unwrap().is_err());
        assert!(ErrorFrame::parse_candump("60000004#00").unwrap().is_err(), "beyond the flag");
    }

    #[test]
    fn slcan_reports_become_the_kernels_error_frames() {
        let f = ErrorFrame::from_slcan(b"e1a").unwrap();
        assert_eq!(f.id(), ERR_FLAG | BUSERROR | ACK);
        assert_eq!(f.problems(), ["no acknowledge (no other node on the bus, or a wrong bitrate?)"]);
        let f = ErrorFrame::from_slcan(b"e3bcO").unwrap();
        assert_eq!((f.data[1], f.data[2], f.data[3]), (0x02, 0x09, 0x08));
        let f = ErrorFrame::from_slcan(b"sb256256").unwrap();
        assert_eq!(f.problems(), ["bus off", "error counters tx 255 rx 255"]);
        let f = ErrorFrame::from_slcan(b"sp130020").unwrap();
        assert_eq!(f.problems(), ["controller: rx passive", "error counters tx 20 rx 130"]);
        for other in [&b"e0"[..], b"e2a", b"e1x", b"sx000000", b"sa0000", b"sa00000a", b"V1013", b"", b"e"] {
            assert_eq!(ErrorFrame::from_slcan(other), None, "{:?}", String::from_utf8_lossy(other));
        }
    }

    #[test]
    fn decoding_never_panics() {
        use proptest::prelude::*;
        proptest!(|(id in any::<u32>(), data in proptest::collection::vec(any::<u8>(), 0..12), line in proptest::collection::vec(any::<u8>(), 0..12))| {
            let f = ErrorFrame::new(id, &data);
            prop_assert!(!f.problems().is_empty());
            prop_assert_eq!(ErrorFrame::parse_candump(&f.to_string()).unwrap().unwrap(), f);
            let _ = ErrorFrame::from_slcan(&line).map(|f| f.problems());
            let _ = ErrorFrame::parse_candump(&String::from_utf8_lossy(&line));
        });
    }
}
