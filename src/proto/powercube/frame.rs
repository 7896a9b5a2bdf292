//! PowerCube command and acknowledge payloads ("net data"), identical on CAN
//! and RS232 (manual 4.4, 4.5).

use super::table::{self, CommandId, MotionArg, ParamType};
use crate::proto::DecodeError;

/// The acknowledge marker of SetExtended and simple motion acks.
pub const ACK_OK: u8 = 0x64;

/// Up to 8 bytes of net data, stored inline (no allocation on the hot path).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Payload {
    len: u8,
    bytes: [u8; 8],
}

impl Payload {
    pub fn new(data: &[u8]) -> Option<Self> {
        let mut p = Self::default();
        p.extend(data).then_some(p)
    }

    /// Appends; false (and unchanged) if it would exceed 8 bytes.
    pub fn extend(&mut self, data: &[u8]) -> bool {
        let start = self.len as usize;
        let Some(end) = start.checked_add(data.len()).filter(|e| *e <= 8) else {
            return false;
        };
        self.bytes[start..end].copy_from_slice(data);
        self.len = end as u8;
        true
    }

    pub fn as_slice(&self) -> &[u8] {
        &self.bytes[..self.len as usize]
    }

    pub fn len(&self) -> usize {
        self.len as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl std::fmt::Debug for Payload {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[")?;
        for (i, b) in self.as_slice().iter().enumerate() {
            if i > 0 {
                write!(f, " ")?;
            }
            write!(f, "{b:02x}")?;
        }
        write!(f, "]")
    }
}

/// A typed parameter value. Floats serialize as the shortest decimal that
/// reads back as the same f32 (0.1, not 0.10000000149011612).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum Value {
    Float(#[serde(serialize_with = "ser_f32")] f32),
    Int32(i32),
    UInt32(u32),
    Int16(i16),
    UInt16(u16),
    UInt8(u8),
    FloatStateDio {
        #[serde(serialize_with = "ser_f32")]
        position: f32,
        short_state: u8,
        dio: u8,
    },
    FloatTime {
        #[serde(serialize_with = "ser_f32")]
        position: f32,
        time_ms: u16,
    },
}

/// The f64 whose shortest decimal form is that of `v`: what the user typed
/// and what the module's float means, without f32-to-f64 widening noise.
pub fn f32_to_f64(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(f64::from(v))
}

fn ser_f32<S: serde::Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(f32_to_f64(*v))
}

impl Value {
    pub fn ty(&self) -> ParamType {
        match self {
            Self::Float(_) => ParamType::Float,
            Self::Int32(_) => ParamType::Int32,
            Self::UInt32(_) => ParamType::UInt32,
            Self::Int16(_) => ParamType::Int16,
            Self::UInt16(_) => ParamType::UInt16,
            Self::UInt8(_) => ParamType::UInt8,
            Self::FloatStateDio { .. } => ParamType::FloatStateDio,
            Self::FloatTime { .. } => ParamType::FloatTime,
        }
    }

    /// Little-endian wire bytes.
    pub fn to_payload(&self) -> Payload {
        let mut p = Payload::default();
        match *self {
            Self::Float(v) => p.extend(&v.to_le_bytes()),
            Self::Int32(v) => p.extend(&v.to_le_bytes()),
            Self::UInt32(v) => p.extend(&v.to_le_bytes()),
            Self::Int16(v) => p.extend(&v.to_le_bytes()),
            Self::UInt16(v) => p.extend(&v.to_le_bytes()),
            Self::UInt8(v) => p.extend(&[v]),
            Self::FloatStateDio { position, short_state, dio } => {
                p.extend(&position.to_le_bytes()) && p.extend(&[short_state, dio])
            }
            Self::FloatTime { position, time_ms } => {
                p.extend(&position.to_le_bytes()) && p.extend(&time_ms.to_le_bytes())
            }
        };
        p
    }

    /// Decodes `data` as `ty`. Extra trailing bytes are an error; modules
    /// answer exactly the type's size.
    pub fn decode(ty: ParamType, data: &[u8]) -> Result<Self, DecodeError> {
        let need = ty.size();
        if data.len() < need {
            return Err(DecodeError::TooShort { need, got: data.len() });
        }
        if data.len() > need {
            return Err(DecodeError::TooLong { len: data.len() });
        }
        let b4 = || [data[0], data[1], data[2], data[3]];
        let b2 = || [data[0], data[1]];
        Ok(match ty {
            ParamType::Float => Self::Float(f32::from_le_bytes(b4())),
            ParamType::Int32 => Self::Int32(i32::from_le_bytes(b4())),
            ParamType::UInt32 => Self::UInt32(u32::from_le_bytes(b4())),
            ParamType::Int16 => Self::Int16(i16::from_le_bytes(b2())),
            ParamType::UInt16 => Self::UInt16(u16::from_le_bytes(b2())),
            ParamType::UInt8 => Self::UInt8(data[0]),
            ParamType::FloatStateDio => {
                Self::FloatStateDio { position: f32::from_le_bytes(b4()), short_state: data[4], dio: data[5] }
            }
            ParamType::FloatTime => {
                Self::FloatTime { position: f32::from_le_bytes(b4()), time_ms: u16::from_le_bytes([data[4], data[5]]) }
            }
        })
    }

    /// Parses user text as `ty`: decimal or `0x` hex for integers; range
    /// checked against the type.
    pub fn parse(ty: ParamType, text: &str) -> Result<Self, ValueError> {
        let t = text.trim();
        let int = |min: i64, max: i64| -> Result<i64, ValueError> {
            let v = parse_int(t).ok_or_else(|| ValueError::NotANumber { text: text.into(), ty })?;
            if v < min || v > max {
                return Err(ValueError::OutOfRange { text: text.into(), ty, min, max });
            }
            Ok(v)
        };
        Ok(match ty {
            ParamType::Float => {
                let v: f32 = t.parse().map_err(|_| ValueError::NotANumber { text: text.into(), ty })?;
                if !v.is_finite() {
                    return Err(ValueError::NotANumber { text: text.into(), ty });
                }
                Self::Float(v)
            }
            ParamType::Int32 => Self::Int32(int(i32::MIN.into(), i32::MAX.into())? as i32),
            ParamType::UInt32 => Self::UInt32(int(0, u32::MAX.into())? as u32),
            ParamType::Int16 => Self::Int16(int(i16::MIN.into(), i16::MAX.into())? as i16),
            ParamType::UInt16 => Self::UInt16(int(0, u16::MAX.into())? as u16),
            ParamType::UInt8 => Self::UInt8(int(0, u8::MAX.into())? as u8),
            ParamType::FloatStateDio | ParamType::FloatTime => return Err(ValueError::NotWritable { ty }),
        })
    }

    /// The value as f64 where it is a single number.
    pub fn as_f64(&self) -> Option<f64> {
        Some(match *self {
            Self::Float(v) => f32_to_f64(v),
            Self::Int32(v) => v.into(),
            Self::UInt32(v) => v.into(),
            Self::Int16(v) => v.into(),
            Self::UInt16(v) => v.into(),
            Self::UInt8(v) => v.into(),
            Self::FloatStateDio { .. } | Self::FloatTime { .. } => return None,
        })
    }
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Float(v) => write!(f, "{v}"),
            Self::Int32(v) => write!(f, "{v}"),
            Self::UInt32(v) => write!(f, "{v}"),
            Self::Int16(v) => write!(f, "{v}"),
            Self::UInt16(v) => write!(f, "{v}"),
            Self::UInt8(v) => write!(f, "{v}"),
            Self::FloatStateDio { position, short_state, dio } => {
                write!(f, "{position} state={short_state:#04x} dio={dio:#04x}")
            }
            Self::FloatTime { position, time_ms } => write!(f, "{position} t={time_ms}ms"),
        }
    }
}

pub use crate::proto::parse_int;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ValueError {
    #[error("{text:?} is not a valid {} value", ty.name())]
    NotANumber { text: String, ty: ParamType },
    #[error("{text:?} is outside the {} range {min} to {max}", ty.name())]
    OutOfRange { text: String, ty: ParamType, min: i64, max: i64 },
    #[error("values of type {} cannot be written", ty.name())]
    NotWritable { ty: ParamType },
}

/// A motion command's target value, encoded per the motion id's argument type.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MotionValue {
    Float(f32),
    Int32(i32),
    Int16(i16),
}

/// A SetMotion command (manual 4.5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    pub id: u8,
    pub value: MotionValue,
    /// Step modes carry a time in ms.
    pub time_ms: Option<u16>,
}

/// A command to one module or a broadcast payload.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Request {
    Reset,
    Home,
    Halt,
    RecalcPidParam,
    ResetTime,
    /// 0x07 to one module toggles its watchdog online / offline.
    Watchdog,
    GetExtended {
        param: u8,
    },
    SetExtended {
        param: u8,
        data: Payload,
    },
    SetMotion(Motion),
    SetIStep {
        target: i32,
        time_ms: u16,
    },
}

impl Request {
    pub fn command(&self) -> CommandId {
        match self {
            Self::Reset => CommandId::Reset,
            Self::Home => CommandId::Home,
            Self::Halt => CommandId::Halt,
            Self::RecalcPidParam => CommandId::RecalcPidParam,
            Self::ResetTime => CommandId::ResetTime,
            Self::Watchdog => CommandId::Watchdog,
            Self::GetExtended { .. } => CommandId::GetExtended,
            Self::SetExtended { .. } => CommandId::SetExtended,
            Self::SetMotion(_) => CommandId::SetMotion,
            Self::SetIStep { .. } => CommandId::SetIStep,
        }
    }

    /// A typed SetExtended.
    pub fn set(param: u8, value: Value) -> Self {
        Self::SetExtended { param, data: value.to_payload() }
    }

    /// Motion commands start the drive; they are never retried.
    pub fn is_motion(&self) -> bool {
        matches!(self, Self::Home | Self::SetMotion(_) | Self::SetIStep { .. })
    }

    /// Reads change nothing on the module and may be retried.
    pub fn is_read(&self) -> bool {
        matches!(self, Self::GetExtended { .. })
    }

    pub fn to_payload(&self) -> Payload {
        let mut p = Payload::default();
        p.extend(&[self.command() as u8]);
        match *self {
            Self::GetExtended { param } => {
                p.extend(&[param]);
            }
            Self::SetExtended { param, data } => {
                p.extend(&[param]);
                p.extend(data.as_slice());
            }
            Self::SetMotion(m) => {
                p.extend(&[m.id]);
                match m.value {
                    MotionValue::Float(v) => p.extend(&v.to_le_bytes()),
                    MotionValue::Int32(v) => p.extend(&v.to_le_bytes()),
                    MotionValue::Int16(v) => p.extend(&v.to_le_bytes()),
                };
                if let Some(t) = m.time_ms {
                    p.extend(&t.to_le_bytes());
                }
            }
            Self::SetIStep { target, time_ms } => {
                p.extend(&target.to_le_bytes());
                p.extend(&time_ms.to_le_bytes());
            }
            _ => {}
        }
        p
    }

    /// Parses a command payload (what a module receives).
    pub fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let (&cmd, rest) = data.split_first().ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        let cmd = CommandId::from_u8(cmd).ok_or(DecodeError::Unknown { what: "command id", value: cmd.into() })?;
        let exact = |n: usize| {
            if rest.len() < n {
                Err(DecodeError::TooShort { need: n + 1, got: data.len() })
            } else if rest.len() > n {
                Err(DecodeError::TooLong { len: data.len() })
            } else {
                Ok(())
            }
        };
        Ok(match cmd {
            CommandId::Reset => exact(0).map(|_| Self::Reset)?,
            CommandId::Home => exact(0).map(|_| Self::Home)?,
            CommandId::Halt => exact(0).map(|_| Self::Halt)?,
            CommandId::RecalcPidParam => exact(0).map(|_| Self::RecalcPidParam)?,
            CommandId::ResetTime => exact(0).map(|_| Self::ResetTime)?,
            CommandId::Watchdog => exact(0).map(|_| Self::Watchdog)?,
            // The vendor's library pads GetExtended with zeros to 8 bytes;
            // anything else after the parameter is not a GetExtended.
            CommandId::GetExtended if rest.len() > 1 && rest[1..].iter().all(|b| *b == 0) => {
                Self::GetExtended { param: rest[0] }
            }
            CommandId::GetExtended => exact(1).map(|_| Self::GetExtended { param: rest[0] })?,
            CommandId::SetExtended => {
                if !(2..=7).contains(&rest.len()) {
                    return Err(DecodeError::Malformed(format!(
                        "SetExtended with {} data bytes",
                        rest.len().saturating_sub(1)
                    )));
                }
                Self::SetExtended { param: rest[0], data: Payload::new(&rest[1..]).unwrap_or_default() }
            }
            CommandId::SetMotion => {
                let (&id, args) = rest.split_first().ok_or(DecodeError::TooShort { need: 2, got: data.len() })?;
                let def = table::motion(id).ok_or(DecodeError::Unknown { what: "motion id", value: id.into() })?;
                // The manual's current in digits is an Int16; the vendor's
                // library sends it as an Int32, which modules evidently take.
                let wide_digits = def.arg == MotionArg::Int16 && !def.timed && args.len() == 4;
                let vlen = match def.arg {
                    MotionArg::Float | MotionArg::Int32 => 4,
                    MotionArg::Int16 if wide_digits => 4,
                    MotionArg::Int16 => 2,
                };
                let need = vlen + if def.timed { 2 } else { 0 };
                if args.len() < need {
                    return Err(DecodeError::TooShort { need: need + 2, got: data.len() });
                }
                if args.len() > need {
                    return Err(DecodeError::TooLong { len: data.len() });
                }
                let value = match def.arg {
                    MotionArg::Float => MotionValue::Float(f32::from_le_bytes([args[0], args[1], args[2], args[3]])),
                    MotionArg::Int32 => MotionValue::Int32(i32::from_le_bytes([args[0], args[1], args[2], args[3]])),
                    MotionArg::Int16 if wide_digits => {
                        MotionValue::Int32(i32::from_le_bytes([args[0], args[1], args[2], args[3]]))
                    }
                    MotionArg::Int16 => MotionValue::Int16(i16::from_le_bytes([args[0], args[1]])),
                };
                let time_ms = def.timed.then(|| u16::from_le_bytes([args[vlen], args[vlen + 1]]));
                Self::SetMotion(Motion { id, value, time_ms })
            }
            CommandId::SetIStep => {
                exact(6)?;
                Self::SetIStep {
                    target: i32::from_le_bytes([rest[0], rest[1], rest[2], rest[3]]),
                    time_ms: u16::from_le_bytes([rest[4], rest[5]]),
                }
            }
            CommandId::SavePos | CommandId::StartMotion => {
                return Err(DecodeError::Malformed(format!("{} is a broadcast-only command", cmd.name())))
            }
        })
    }

    /// Whether `resp` acknowledges this request (the vendor library's rule:
    /// same command id, and same parameter / motion id where there is one).
    pub fn matches(&self, resp: &Response) -> bool {
        match (self, resp) {
            (Self::GetExtended { param }, Response::Get { param: p, .. }) => param == p,
            (Self::SetExtended { param, .. }, Response::SetAck { param: p }) => param == p,
            (Self::SetMotion(m), Response::MotionAck { motion }) => m.id == *motion,
            (Self::SetMotion(m), Response::MotionAckExt { motion, .. }) => m.id == *motion,
            (_, Response::Simple(cmd)) => self.command() == *cmd,
            _ => false,
        }
    }
}

/// An acknowledge from a module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Response {
    /// One-byte acknowledge: Reset, Home, Halt, RecalcPIDParam, ResetTime,
    /// Watchdog, SetIStep.
    Simple(CommandId),
    /// `[0x08, param, 0x64]`
    SetAck { param: u8 },
    /// `[0x0a, param, data...]`
    Get { param: u8, data: Payload },
    /// `[0x0b, motion, 0x64]`
    MotionAck { motion: u8 },
    /// `[0x0b, motion, pos(4), short state, dio]`; `pos` is float for the F*
    /// ids and int32 for the I* ids.
    MotionAckExt { motion: u8, pos: [u8; 4], short_state: u8, dio: u8 },
}

impl Response {
    pub fn command(&self) -> CommandId {
        match self {
            Self::Simple(c) => *c,
            Self::SetAck { .. } => CommandId::SetExtended,
            Self::Get { .. } => CommandId::GetExtended,
            Self::MotionAck { .. } | Self::MotionAckExt { .. } => CommandId::SetMotion,
        }
    }

    pub fn to_payload(&self) -> Payload {
        let mut p = Payload::default();
        p.extend(&[self.command() as u8]);
        match *self {
            Self::Simple(_) => {}
            Self::SetAck { param } => {
                p.extend(&[param, ACK_OK]);
            }
            Self::Get { param, data } => {
                p.extend(&[param]);
                p.extend(data.as_slice());
            }
            Self::MotionAck { motion } => {
                p.extend(&[motion, ACK_OK]);
            }
            Self::MotionAckExt { motion, pos, short_state, dio } => {
                p.extend(&[motion]);
                p.extend(&pos);
                p.extend(&[short_state, dio]);
            }
        }
        p
    }

    /// Parses an acknowledge payload.
    pub fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let (&cmd, rest) = data.split_first().ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        let cmd = CommandId::from_u8(cmd).ok_or(DecodeError::Unknown { what: "command id", value: cmd.into() })?;
        let too_short = |need| DecodeError::TooShort { need, got: data.len() };
        match cmd {
            CommandId::SetExtended => match rest {
                [param, ACK_OK] => Ok(Self::SetAck { param: *param }),
                [_, other] => Err(DecodeError::Malformed(format!("SetExtended ack byte {other:#04x}, expected 0x64"))),
                [] | [_] => Err(too_short(3)),
                _ => Err(DecodeError::TooLong { len: data.len() }),
            },
            CommandId::GetExtended => {
                let (&param, value) = rest.split_first().ok_or(too_short(2))?;
                Ok(Self::Get { param, data: Payload::new(value).ok_or(DecodeError::TooLong { len: data.len() })? })
            }
            CommandId::SetMotion => match rest {
                [motion, ACK_OK] => Ok(Self::MotionAck { motion: *motion }),
                [motion, a, b, c, d, short_state, dio] => Ok(Self::MotionAckExt {
                    motion: *motion,
                    pos: [*a, *b, *c, *d],
                    short_state: *short_state,
                    dio: *dio,
                }),
                _ => Err(DecodeError::Malformed(format!("SetMotion ack of {} bytes", data.len()))),
            },
            CommandId::SavePos | CommandId::StartMotion => {
                Err(DecodeError::Malformed(format!("{} is never acknowledged", cmd.name())))
            }
            simple if rest.is_empty() => Ok(Self::Simple(simple)),
            _ => Err(DecodeError::TooLong { len: data.len() }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn request_payloads_round_trip() {
        let reqs = [
            Request::Home,
            Request::GetExtended { param: 0x27 },
            Request::set(0x50, Value::Float(0.5)),
            Request::SetMotion(Motion { id: 4, value: MotionValue::Float(0.75), time_ms: None }),
            Request::SetMotion(Motion { id: 11, value: MotionValue::Int32(-5), time_ms: Some(100) }),
            Request::SetMotion(Motion { id: 13, value: MotionValue::Int16(-300), time_ms: None }),
            Request::SetIStep { target: 1000, time_ms: 20 },
        ];
        for r in reqs {
            assert_eq!(Request::decode(r.to_payload().as_slice()), Ok(r));
        }
    }

    #[test]
    fn get_extended_padded_with_zeros_is_a_get_extended() {
        let padded = [0x0a, 0x27, 0, 0, 0, 0, 0, 0];
        assert_eq!(Request::decode(&padded), Ok(Request::GetExtended { param: 0x27 }));
        assert_eq!(Request::decode(&[0x0a, 0x27, 0, 1]), Err(DecodeError::TooLong { len: 4 }));
        assert!(Request::decode(&[0x0a]).is_err());
    }

    #[test]
    fn current_in_digits_decodes_in_the_manuals_int16_and_the_vendor_librarys_int32() {
        // The vendor library's moveCurInc(-100): [0b 0d 9c ff ff ff].
        let wide = Request::decode(&[0x0b, 0x0d, 0x9c, 0xff, 0xff, 0xff]);
        assert_eq!(wide, Ok(Request::SetMotion(Motion { id: 13, value: MotionValue::Int32(-100), time_ms: None })));
        let narrow = Request::decode(&[0x0b, 0x0d, 0x9c, 0xff]);
        assert_eq!(narrow, Ok(Request::SetMotion(Motion { id: 13, value: MotionValue::Int16(-100), time_ms: None })));
        assert_eq!(Request::decode(&[0x0b, 0x0d, 0x9c, 0xff, 0xff]), Err(DecodeError::TooLong { len: 5 }));
    }

    #[test]
    fn manual_section_8_payloads() {
        // Set ramp acceleration 0.5: [08 50 00 00 00 3f]
        assert_eq!(Request::set(0x50, Value::Float(0.5)).to_payload().as_slice(), &[0x08, 0x50, 0, 0, 0, 0x3f]);
        // Ramp motion to 0.75: [0b 04 00 00 40 3f]
        let ramp = Request::SetMotion(Motion { id: 4, value: MotionValue::Float(0.75), time_ms: None });
        assert_eq!(ramp.to_payload().as_slice(), &[0x0b, 0x04, 0, 0, 0x40, 0x3f]);
        assert_eq!(Response::decode(&[0x0b, 0x04, 0x64]), Ok(Response::MotionAck { motion: 4 }));
        assert!(ramp.matches(&Response::MotionAck { motion: 4 }));
        assert!(!ramp.matches(&Response::MotionAck { motion: 14 }));
        assert!(Request::GetExtended { param: 0x27 }
            .matches(&Response::Get { param: 0x27, data: Payload::new(&[2, 0, 0, 0]).unwrap() }));
        assert!(!Request::GetExtended { param: 0x27 }.matches(&Response::Get { param: 0x3c, data: Payload::default() }));
    }

    // Found by fuzzing (fuzz/fuzz_targets/user_values.rs): negating a body that
    // is itself i64::MIN overflowed (a panic with overflow checks on).
    #[test]
    fn parse_int_rejects_double_negative_minimum() {
        assert_eq!(parse_int("--9223372036854775808"), None);
        assert_eq!(parse_int("-0x-8000000000000000"), None);
        assert_eq!(parse_int("-9223372036854775807"), Some(-i64::MAX));
        assert_eq!(parse_int("--5"), Some(5));
        assert!(matches!(Value::parse(ParamType::Int32, "--9223372036854775808"), Err(ValueError::NotANumber { .. })));
    }

    #[test]
    fn value_parsing_checks_ranges() {
        assert_eq!(Value::parse(ParamType::UInt8, "0x1f"), Ok(Value::UInt8(31)));
        assert!(matches!(Value::parse(ParamType::UInt8, "256"), Err(ValueError::OutOfRange { .. })));
        assert!(matches!(Value::parse(ParamType::Float, "abc"), Err(ValueError::NotANumber { .. })));
        assert!(matches!(Value::parse(ParamType::Float, "inf"), Err(ValueError::NotANumber { .. })));
        assert_eq!(Value::parse(ParamType::Int16, "-500"), Ok(Value::Int16(-500)));
    }
}
