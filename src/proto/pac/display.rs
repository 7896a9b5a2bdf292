//! Commands and acknowledges for humans (traces, error messages).

use std::fmt;

use super::frame::{Ack, CheckRule, Command, EOT, ETX, SOH, STX};
use super::table;

/// `0A87 pos-axis-absolut (2 5552.0)`: code, the manual's name, PAR_1 and PAR_2.
impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = table::command(self.code).map_or("(unknown code)", |d| d.name);
        write!(f, "{:04X} {name} ({} {})", self.code, self.par1, self.par2)
    }
}

/// The frame as it is on the line, its fields decoded and the CHECK rule it
/// matched.
impl fmt::Display for Ack {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let check = match self.check_rule {
            CheckRule::Strict => "CHECK without ETX",
            CheckRule::WithEtx => "CHECK with ETX",
            CheckRule::Omitted => "CHECK omitted (0)",
        };
        let frame = self.encode().map(|b| printable(&b)).unwrap_or_default();
        write!(
            f,
            "{frame}  QUIT {} BE {} STATUS {} ({}) ERROR {} Q_PAR {}  [{check}]",
            self.quit,
            u8::from(self.be),
            self.status,
            table::operating_status_text(self.status),
            self.error,
            self.q_par
        )
    }
}

/// Control characters by name, the rest as text: `<SOH><STX>0603;0;0;0<ETX>14<EOT>`.
pub fn printable(bytes: &[u8]) -> String {
    let mut s = String::new();
    for &b in bytes {
        match b {
            SOH => s.push_str("<SOH>"),
            STX => s.push_str("<STX>"),
            ETX => s.push_str("<ETX>"),
            EOT => s.push_str("<EOT>"),
            0x20..=0x7e => s.push(b as char),
            _ => s.push_str(&format!("<{b:02x}>")),
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::super::frame::Par2;
    use super::*;

    // Manual 3.4.3: start online, then 0A87 axis 2 to 5552.0.
    #[test]
    fn manual_3_4_3_for_humans() {
        let online = Command::new(0x0603, 0, Par2::Int(0));
        assert_eq!(printable(&online.encode().unwrap()), "<SOH><STX>0603;0;0;0<ETX>14<EOT>");
        let mv = Command::new(0x0A87, 2, Par2::Float(5552.0));
        assert_eq!(mv.to_string(), format!("0A87 {} (2 5552.0)", table::command(0x0A87).unwrap().name));
        assert_eq!(Command::new(0x0999, 1, Par2::Int(7)).to_string(), "0999 (unknown code) (1 7)");
        // "0;1;31;0;0;0" XORs to 8 without ETX.
        let ack = Ack::decode(b"\x01\x020;1;31;0;0;0\x038\x04").unwrap();
        assert_eq!(
            ack.to_string(),
            "<SOH><STX>0;1;31;0;0;0<ETX>8<EOT>  QUIT 0 BE 1 STATUS 31 (ONLINE) ERROR 0 Q_PAR 0  [CHECK without ETX]"
        );
        assert_eq!(printable(&[0x7f, b'A']), "<7f>A");
    }
}
