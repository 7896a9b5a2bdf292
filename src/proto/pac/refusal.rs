//! The PA-CONTROL's refusal (QUIT != 0 in the acknowledge, manual 6.5), as
//! data for [`Refusal`]: the refused command, the code and the manual's text.

use std::fmt;

use serde::Serialize;

use super::session::DeviceError;
use crate::proto::Refusal;

#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PacRefusal {
    /// The refused command's code, as the manual writes it (`0A94`).
    #[serde(serialize_with = "hex4")]
    pub command: u16,
    pub quit: u16,
    /// Manual 6.5's text for `quit`.
    pub text: &'static str,
}

fn hex4<S: serde::Serializer>(code: &u16, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&format!("{code:04X}"))
}

impl From<&DeviceError> for Refusal {
    fn from(d: &DeviceError) -> Self {
        Self::PaControl(PacRefusal { command: d.code, quit: d.quit, text: d.text })
    }
}

impl fmt::Display for PacRefusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "command error 0x{:02X} ({}): {}", self.quit, self.quit, self.text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proto::pac::{Ack, CheckRule, Par2};

    // Manual 6.5: QUIT 41h is "position outside range".
    #[test]
    fn pa_control_refusal_keeps_code_quit_and_text() {
        let ack =
            Ack { quit: 0x41, be: true, status: 31, error: 0, q_par: Par2::Int(0), check_rule: CheckRule::Strict };
        let d = DeviceError { code: 0x0A94, quit: 0x41, text: "position outside range", ack };
        let r = Refusal::from(&d);
        assert_eq!(r.to_string(), "command error 0x41 (65): position outside range");
        assert_eq!(
            serde_json::to_value(&r).unwrap(),
            serde_json::json!({"family": "pa-control", "command": "0A94", "quit": 65, "text": "position outside range"})
        );
    }
}
