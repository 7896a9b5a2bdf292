//! `send CODE;PAR1;TYP;PAR2`: a PA-CONTROL command as typed, the line
//! between STX and ETX.

use axisctl::device::supervisor::MotionTarget;
use axisctl::proto::pac::{table, Command, Par2};

/// The command, or why the text is none.
pub fn parse(text: &str) -> Result<Command, String> {
    let fields: Vec<&str> = text.trim().split(';').collect();
    let [code, par1, typ, par2] = fields[..] else {
        return Err(format!("{text:?} is neither a CAN frame ID#DATA nor a PA-CONTROL command CODE;PAR1;TYP;PAR2"));
    };
    let code = u16::from_str_radix(code, 16)
        .ok()
        .filter(|_| code.len() == 4)
        .ok_or_else(|| format!("PA-CONTROL code {code:?} is not 4 hex digits"))?;
    let par1: i64 = par1.parse().map_err(|_| format!("PAR_1 {par1:?} is not an integer"))?;
    let par2 = match typ {
        "0" => Par2::Int(par2.parse().map_err(|_| format!("PAR_2 {par2:?} is not an integer (TYP 0)"))?),
        "1" => Par2::Float(
            par2.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("PAR_2 {par2:?} is not a number (TYP 1)"))?,
        ),
        _ => return Err(format!("TYP {typ:?} is 0 (integer) or 1 (float)")),
    };
    Ok(Command::new(code, par1, par2))
}

/// A motion command, or one the table does not know (`send` refuses both
/// without --force), may move anything the controller drives.
pub fn moves(text: &str) -> Option<MotionTarget> {
    let c = parse(text).ok()?;
    table::command(c.code).is_none_or(|d| d.motion).then_some(MotionTarget::PacController)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fields_are_read_as_typed() {
        assert_eq!(parse("190C;1;0;0"), Ok(Command::new(0x190C, 1, Par2::Int(0))));
        assert_eq!(parse("0A8D;1;1;100.5"), Ok(Command::new(0x0A8D, 1, Par2::Float(100.5))));
        assert_eq!(moves("0A94;1;1;100.0"), Some(MotionTarget::PacController));
        assert_eq!(moves("190C;1;0;0"), None);
    }
}
