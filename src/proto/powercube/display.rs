//! Requests for humans (traces, error messages): the manual's command,
//! parameter and motion names, with the value decoded by the table's type.

use std::fmt;

use super::frame::{MotionValue, Value};
use super::table::{self, ParamType};
use super::Request;

/// A parameter by its table name, or its id when the table has none.
struct ParamName(u8);

impl fmt::Display for ParamName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match table::param(self.0) {
            Some(p) => f.write_str(p.name),
            None => write!(f, "{:#04x}", self.0),
        }
    }
}

/// `GetExtended ActPos`, `SetExtended TargetVel = 0.08`, `SetMotion FRAMP_MODE 0.75`.
impl fmt::Display for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::GetExtended { param } => write!(f, "GetExtended {}", ParamName(*param)),
            Self::SetExtended { param, data } => {
                // The two compound types are wider than a SetExtended carries.
                let value = table::param(*param)
                    .filter(|p| p.ty != ParamType::FloatStateDio && p.ty != ParamType::FloatTime)
                    .and_then(|p| Value::decode(p.ty, data.as_slice()).ok());
                match value {
                    Some(v) => write!(f, "SetExtended {} = {v}", ParamName(*param)),
                    None => write!(f, "SetExtended {} = {data:?}", ParamName(*param)),
                }
            }
            Self::SetMotion(m) => {
                let name = table::motion(m.id).map_or("motion?", |d| d.name);
                write!(f, "SetMotion {name} ")?;
                match m.value {
                    MotionValue::Float(v) => write!(f, "{v}")?,
                    MotionValue::Int32(v) => write!(f, "{v}")?,
                    MotionValue::Int16(v) => write!(f, "{v}")?,
                }
                match m.time_ms {
                    Some(t) => write!(f, " in {t} ms"),
                    None => Ok(()),
                }
            }
            other => f.write_str(other.command().name()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::frame::Motion;
    use super::*;

    // The requests of the manual's section 8 (module 17).
    #[test]
    fn section_8_requests_by_name() {
        assert_eq!(Request::Home.to_string(), "Home");
        assert_eq!(Request::GetExtended { param: 0x27 }.to_string(), "GetExtended CubeState");
        assert_eq!(Request::GetExtended { param: 0xFE }.to_string(), "GetExtended 0xfe");
        assert_eq!(Request::set(0x50, Value::Float(0.5)).to_string(), "SetExtended TargetAcc = 0.5");
        let ramp = Request::SetMotion(Motion { id: 4, value: MotionValue::Float(0.75), time_ms: None });
        assert_eq!(ramp.to_string(), "SetMotion FRAMP_MODE 0.75");
        let timed = Request::SetMotion(Motion { id: 6, value: MotionValue::Float(0.5), time_ms: Some(1500) });
        assert_eq!(timed.to_string(), "SetMotion FSTEP_MODE 0.5 in 1500 ms");
    }
}
