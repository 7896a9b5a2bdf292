//! The Cdios's refusal (an error reply: code | 0x80, its general error and
//! status bits), as data for [`Refusal`], with the manual's names and texts.

use std::fmt;

use serde::Serialize;

use super::ErrorReply;
use crate::proto::Refusal;

#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct CdiosRefusal {
    /// The refused command's code (the error code without 0x80).
    pub command: u8,
    /// Data byte 2: the module, or above 15 the controller.
    pub module: u8,
    /// The general error code (0: none).
    pub general: u8,
    /// Its name and text in the manual's table; `None` for a code not in it.
    pub general_name: Option<&'static str>,
    pub general_text: Option<&'static str>,
    /// The command's error status bits that are set.
    pub errors: Vec<CdiosErrorBit>,
    /// Set bits the command's table does not list.
    pub unknown_bits: Vec<BitPosition>,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct CdiosErrorBit {
    pub name: &'static str,
    pub meaning: &'static str,
    /// Error status byte 1 or 2.
    pub status: u8,
    pub bit: u8,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct BitPosition {
    pub status: u8,
    pub bit: u8,
}

impl From<&ErrorReply> for Refusal {
    fn from(e: &ErrorReply) -> Self {
        let general = e.general_error();
        Self::Cdios(CdiosRefusal {
            command: e.command,
            module: e.module,
            general: e.general,
            general_name: general.map(|(name, _)| name),
            general_text: general.map(|(_, text)| text),
            errors: e
                .flags()
                .iter()
                .map(|f| CdiosErrorBit { name: f.name, meaning: f.meaning, status: f.byte, bit: f.bit })
                .collect(),
            unknown_bits: e.unknown_bits().into_iter().map(|(status, bit)| BitPosition { status, bit }).collect(),
        })
    }
}

impl fmt::Display for CdiosRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        match (self.general_name, self.general_text) {
            (Some(name), Some(text)) if self.general != 0 => {
                parts.push(format!("general error {} {name} ({text})", self.general))
            }
            (None, _) => parts.push(format!("general error {} (not in the table)", self.general)),
            _ => {}
        }
        parts.extend(self.errors.iter().map(|e| format!("{} ({})", e.name, e.meaning)));
        parts.extend(self.unknown_bits.iter().map(|b| format!("error status {} bit {}", b.status, b.bit)));
        if parts.is_empty() {
            parts.push("an error reply with no error bits set".into());
        }
        f.write_str(&parts.join(", "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdios_refusal_names_general_error_and_bits() {
        // 26h to module 7 where there is none: general error 1.
        let absent = Refusal::from(&ErrorReply::decode(&[0xA6, 7, 0, 1, 0, 0, 0, 0]).unwrap());
        let Refusal::Cdios(c) = &absent else { panic!("{absent:?}") };
        assert_eq!((c.command, c.module, c.general), (0x26, 7, 1));
        assert!(absent.to_string().starts_with("general error 1 "), "{absent}");
        let json = serde_json::to_value(&absent).unwrap();
        assert_eq!(json["family"], "cdios");
        assert_eq!(json["general"], 1);
        assert_eq!(json["general_name"], c.general_name.unwrap());
        // 23h goto with error status bits, one the table does not list.
        let e = ErrorReply::new(0x23, 1, 0, 0xFF, 0x80);
        let r = Refusal::from(&e);
        let Refusal::Cdios(c) = &r else { panic!() };
        assert_eq!(c.errors.len(), e.flags().len());
        assert!(!c.errors.is_empty());
        assert_eq!(c.unknown_bits.len(), e.unknown_bits().len());
        let text = r.to_string();
        assert!(text.contains(&format!("{} ({})", c.errors[0].name, c.errors[0].meaning)), "{text}");
        assert_eq!(serde_json::to_value(&r).unwrap()["errors"][0]["name"], c.errors[0].name);
        let none = Refusal::from(&ErrorReply::new(0x23, 1, 0, 0, 0));
        assert_eq!(none.to_string(), "an error reply with no error bits set");
        let unknown = Refusal::from(&ErrorReply::new(0x23, 1, 99, 0, 0));
        assert_eq!(unknown.to_string(), "general error 99 (not in the table)");
        assert!(serde_json::to_value(&unknown).unwrap()["general_name"].is_null());
    }
}
