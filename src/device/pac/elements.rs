//! Inputs, outputs, flags and registers (manual 5.2.4): which of them the
//! online interface may set, and with which codes.

use std::fmt;
use std::str::FromStr;

use crate::proto::pac::Par2;

use super::{Controller, Error, Result};

/// A binary element of the controller.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Element {
    Input,
    Output,
    Flag,
    /// System flag SM: read only.
    SystemFlag,
}

/// Read single, read word, write single, write word.
struct Codes {
    read: u16,
    read_word: Option<u16>,
    write: Option<u16>,
    write_word: Option<u16>,
}

impl Element {
    /// The name in JSON keys and messages.
    pub fn key(self) -> &'static str {
        match self {
            Self::Input => "input",
            Self::Output => "output",
            Self::Flag => "flag",
            Self::SystemFlag => "system_flag",
        }
    }

    fn codes(self) -> Codes {
        let (read, read_word, write, write_word) = match self {
            Self::Input => (0x1900, Some(0x1901), None, None),
            Self::Output => (0x1902, Some(0x1903), Some(0x0902), Some(0x0903)),
            Self::Flag => (0x1904, Some(0x1905), Some(0x0904), Some(0x0905)),
            Self::SystemFlag => (0x1934, None, None, None),
        };
        Codes { read, read_word, write, write_word }
    }

    /// The code that sets one element or a word of them; refused for
    /// elements the online interface cannot set.
    pub fn write_code(self, word: bool) -> Result<u16> {
        let codes = self.codes();
        if word { codes.write_word } else { codes.write }.ok_or_else(|| {
            Error::Refused(match self {
                Self::SystemFlag => "system flags SM are read only".into(),
                other => format!("{}s cannot be set over the online interface", other.key()),
            })
        })
    }
}

/// A register: N / R (integer / real), SN / SR (system, read only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Register {
    pub kind: RegisterKind,
    pub number: i64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RegisterKind {
    N,
    R,
    SN,
    SR,
}

impl RegisterKind {
    fn prefix(self) -> &'static str {
        match self {
            Self::N => "N",
            Self::R => "R",
            Self::SN => "SN",
            Self::SR => "SR",
        }
    }
}

impl Register {
    pub fn is_float(self) -> bool {
        matches!(self.kind, RegisterKind::R | RegisterKind::SR)
    }

    fn read_code(self) -> u16 {
        match self.kind {
            RegisterKind::N => 0x1906,
            RegisterKind::R => 0x1907,
            RegisterKind::SN => 0x1935,
            RegisterKind::SR => 0x1937,
        }
    }

    /// Refused for the system registers SN / SR.
    pub fn write_code(self) -> Result<u16> {
        match self.kind {
            RegisterKind::N => Ok(0x0906),
            RegisterKind::R => Ok(0x0907),
            RegisterKind::SN | RegisterKind::SR => Err(Error::Refused("system registers SN / SR are read only".into())),
        }
    }
}

impl fmt::Display for Register {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.kind.prefix(), self.number)
    }
}

impl FromStr for Register {
    type Err = Error;

    /// `N5`, `r3`, `SN7`, `SR2`.
    fn from_str(text: &str) -> Result<Self> {
        let upper = text.to_ascii_uppercase();
        let (kind, digits) = [RegisterKind::SN, RegisterKind::SR, RegisterKind::N, RegisterKind::R]
            .into_iter()
            .find_map(|k| upper.strip_prefix(k.prefix()).map(|rest| (k, rest)))
            .ok_or_else(|| {
                Error::Refused(format!("{text:?}: expected N<number>, R<number>, SN<number> or SR<number>"))
            })?;
        let number = digits.parse().map_err(|_| Error::Refused(format!("{text:?}: bad register number")))?;
        Ok(Self { kind, number })
    }
}

impl Controller {
    pub fn read_element(&mut self, el: Element, number: u16) -> Result<i64> {
        self.read_i64(el.codes().read, number.into())
    }

    /// The 16 elements of the word holding `number`.
    pub fn read_element_word(&mut self, el: Element, number: u16) -> Result<u16> {
        let code = el.codes().read_word.ok_or_else(|| Error::Refused(format!("{}s have no word read", el.key())))?;
        Ok(self.read_i64(code, number.into())? as u16)
    }

    /// Sets one element, or the word holding `number`; refused for elements
    /// the online interface cannot set.
    pub fn write_element(&mut self, el: Element, number: u16, value: u64, word: bool) -> Result<()> {
        let code = el.write_code(word)?;
        self.send(code, number.into(), Some(value as f64))?;
        Ok(())
    }

    pub fn read_register(&mut self, reg: Register) -> Result<Par2> {
        Ok(self.send(reg.read_code(), reg.number, None)?.ack.q_par)
    }

    /// Refused for the system registers SN / SR.
    pub fn write_register(&mut self, reg: Register, value: f64) -> Result<()> {
        let code = reg.write_code()?;
        self.send(code, reg.number, Some(value))?;
        Ok(())
    }
}
