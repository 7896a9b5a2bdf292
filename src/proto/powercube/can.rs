//! PowerCube CAN framing (manual 4.1, with the specs README's corrections):
//! GetExtended to `0x0C0 + M`, every other command to `0x0E0 + M`,
//! acknowledges on `0x0A0 + M`, broadcasts on `0x100`. The length is the
//! DLC, never part of the identifier.

use super::frame::{Request, Response};
use super::table::CommandId;
use super::ModuleId;
use crate::proto::{CanFrame, DecodeError};

pub const ACK_BASE: u32 = 0x0A0;
pub const GET_BASE: u32 = 0x0C0;
pub const PUT_BASE: u32 = 0x0E0;
pub const BROADCAST_ID: u32 = 0x100;

/// The CAN frame carrying `req` to `module`.
pub fn request_frame(module: ModuleId, req: &Request) -> CanFrame {
    let base = if matches!(req, Request::GetExtended { .. }) { GET_BASE } else { PUT_BASE };
    let payload = req.to_payload();
    CanFrame::new(base + u32::from(module.get()), payload.as_slice()).expect("ids <= 0x0FF and payload <= 8 bytes")
}

/// Broadcast commands (manual 4.1.2): never acknowledged.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Broadcast {
    Reset,
    Home,
    Halt,
    WatchdogRefresh,
    /// 1 = 250 kbit/s, 2 = 500 kbit/s, 3 = 1 Mbit/s
    ChangeBaudrate(u8),
    SavePos,
    StartMotion,
}

impl Broadcast {
    pub fn command(self) -> CommandId {
        match self {
            Self::Reset => CommandId::Reset,
            Self::Home => CommandId::Home,
            Self::Halt => CommandId::Halt,
            Self::WatchdogRefresh => CommandId::Watchdog,
            Self::ChangeBaudrate(_) => CommandId::RecalcPidParam,
            Self::SavePos => CommandId::SavePos,
            Self::StartMotion => CommandId::StartMotion,
        }
    }

    /// The two payload bytes `[cmd, param]`, param 0 where unused.
    pub fn payload(self) -> [u8; 2] {
        let param = if let Self::ChangeBaudrate(b) = self { b } else { 0 };
        [self.command() as u8, param]
    }

    pub fn frame(self) -> CanFrame {
        CanFrame::new(BROADCAST_ID, &self.payload()).expect("valid broadcast frame")
    }

    /// The manual's meaning of ChangeBaudrate's parameter, in bit/s.
    pub fn bitrate(param: u8) -> Option<u32> {
        match param {
            1 => Some(250_000),
            2 => Some(500_000),
            3 => Some(1_000_000),
            _ => None,
        }
    }

    pub fn decode(data: &[u8]) -> Result<Self, DecodeError> {
        let (&cmd, rest) = data.split_first().ok_or(DecodeError::TooShort { need: 1, got: 0 })?;
        let param = rest.first().copied().unwrap_or(0);
        Ok(match cmd {
            0x00 => Self::Reset,
            0x01 => Self::Home,
            0x02 => Self::Halt,
            0x07 => Self::WatchdogRefresh,
            0x09 => Self::ChangeBaudrate(param),
            0x0e => Self::SavePos,
            0x0f => Self::StartMotion,
            other => return Err(DecodeError::Unknown { what: "broadcast command", value: other.into() }),
        })
    }
}

/// The manual's names: `Halt`, `WatchdogRefresh`, `ChangeBaudrate 500 kbit/s`.
impl std::fmt::Display for Broadcast {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let name = match self {
            Self::Reset => "Reset",
            Self::Home => "Home",
            Self::Halt => "Halt",
            Self::WatchdogRefresh => "WatchdogRefresh",
            Self::SavePos => "SavePos",
            Self::StartMotion => "StartMotion",
            Self::ChangeBaudrate(p) => {
                return match Self::bitrate(*p) {
                    Some(b) if b >= 1_000_000 => write!(f, "ChangeBaudrate {} Mbit/s", b / 1_000_000),
                    Some(b) => write!(f, "ChangeBaudrate {} kbit/s", b / 1000),
                    None => write!(f, "ChangeBaudrate {p} (not a rate of the manual: 1, 2 or 3)"),
                }
            }
        };
        f.write_str(name)
    }
}

/// What a PowerCube CAN frame is, seen from anywhere on the bus.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CanMessage {
    Request { module: ModuleId, request: Request },
    Ack { module: ModuleId, response: Response },
    Broadcast(Broadcast),
}

/// Classifies a frame; `Ok(None)` for ids that are not PowerCube's.
pub fn classify(frame: &CanFrame) -> Result<Option<CanMessage>, DecodeError> {
    if frame.is_extended() {
        return Ok(None);
    }
    let id = frame.id();
    if id == BROADCAST_ID {
        return Broadcast::decode(frame.data()).map(|b| Some(CanMessage::Broadcast(b)));
    }
    let (base, low) = (id & !0x1F, (id & 0x1F) as u8);
    let Some(module) = ModuleId::new(low) else { return Ok(None) };
    match base {
        ACK_BASE => Response::decode(frame.data()).map(|response| Some(CanMessage::Ack { module, response })),
        GET_BASE | PUT_BASE => {
            let request = Request::decode(frame.data())?;
            let on_get = matches!(request, Request::GetExtended { .. });
            if on_get != (base == GET_BASE) {
                return Err(DecodeError::Malformed(format!("{} sent on id {id:#05x}", request.command().name())));
            }
            Ok(Some(CanMessage::Request { module, request }))
        }
        _ => Ok(None),
    }
}

/// The acknowledge frame a module sends.
pub fn ack_frame(module: ModuleId, resp: &Response) -> CanFrame {
    CanFrame::new(ACK_BASE + u32::from(module.get()), resp.to_payload().as_slice()).expect("valid ack frame")
}

/// If `frame` is an acknowledge from `module`, its decoded response.
pub fn ack_from(module: ModuleId, frame: &CanFrame) -> Option<Result<Response, DecodeError>> {
    (!frame.is_extended() && frame.id() == ACK_BASE + u32::from(module.get())).then(|| Response::decode(frame.data()))
}

#[cfg(test)]
mod tests {
    use super::super::frame::{Motion, MotionValue, Value};
    use super::*;

    fn m17() -> ModuleId {
        ModuleId::new(17).unwrap()
    }

    // Manual section 8, module 17.
    #[test]
    fn section_8_home_and_reset() {
        assert_eq!(request_frame(m17(), &Request::Home).to_string(), "0F1#01");
        assert_eq!(ack_from(m17(), &"0B1#01".parse().unwrap()), Some(Ok(Response::Simple(CommandId::Home))));
        assert_eq!(request_frame(m17(), &Request::Reset).to_string(), "0F1#00");
        assert_eq!(ack_from(m17(), &"0B1#00".parse().unwrap()), Some(Ok(Response::Simple(CommandId::Reset))));
    }

    #[test]
    fn section_8_set_acc_vel_and_ramp() {
        let acc = request_frame(m17(), &Request::set(0x50, Value::Float(0.5)));
        assert_eq!(acc.to_string(), "0F1#08500000003F");
        assert_eq!(ack_from(m17(), &"0B1#085064".parse().unwrap()), Some(Ok(Response::SetAck { param: 0x50 })));
        let vel = request_frame(m17(), &Request::set(0x4f, Value::Float(0.08)));
        assert_eq!(vel.to_string(), "0F1#084F0AD7A33D");
        let ramp =
            request_frame(m17(), &Request::SetMotion(Motion { id: 4, value: MotionValue::Float(0.75), time_ms: None }));
        assert_eq!(ramp.to_string(), "0F1#0B040000403F");
        assert_eq!(ack_from(m17(), &"0B1#0B0464".parse().unwrap()), Some(Ok(Response::MotionAck { motion: 4 })));
    }

    #[test]
    fn section_8_reads_and_extended_ack() {
        assert_eq!(request_frame(m17(), &Request::GetExtended { param: 0x27 }).to_string(), "0D1#0A27");
        assert_eq!(request_frame(m17(), &Request::GetExtended { param: 0x3c }).to_string(), "0D1#0A3C");
        let ack: CanFrame = "0B1#0A2702000000".parse().unwrap();
        assert!(matches!(ack_from(m17(), &ack), Some(Ok(Response::Get { param: 0x27, .. }))));
        // Extended acknowledge: [0b 0e pos(4) state dio], answered on 0x0B1.
        let ext: CanFrame = "0B1#0B0E0000403F2011".parse().unwrap();
        assert_eq!(
            ack_from(m17(), &ext),
            Some(Ok(Response::MotionAckExt { motion: 14, pos: 0.75f32.to_le_bytes(), short_state: 0x20, dio: 0x11 }))
        );
    }

    #[test]
    fn broadcasts_say_what_they_mean() {
        assert_eq!(Broadcast::ChangeBaudrate(2).to_string(), "ChangeBaudrate 500 kbit/s");
        assert_eq!(Broadcast::ChangeBaudrate(1).to_string(), "ChangeBaudrate 250 kbit/s");
        assert_eq!(Broadcast::ChangeBaudrate(3).to_string(), "ChangeBaudrate 1 Mbit/s");
        assert!(Broadcast::ChangeBaudrate(7).to_string().contains("not a rate"));
        assert_eq!(Broadcast::StartMotion.to_string(), "StartMotion");
    }

    #[test]
    fn broadcasts_carry_two_bytes() {
        assert_eq!(Broadcast::WatchdogRefresh.frame().to_string(), "100#0700");
        assert_eq!(Broadcast::StartMotion.frame().to_string(), "100#0F00");
        assert_eq!(Broadcast::ChangeBaudrate(3).frame().to_string(), "100#0903");
        for b in [Broadcast::Reset, Broadcast::Home, Broadcast::Halt, Broadcast::SavePos, Broadcast::ChangeBaudrate(2)]
        {
            assert_eq!(Broadcast::decode(&b.payload()), Ok(b));
        }
    }

    #[test]
    fn classify_ignores_foreign_ids() {
        assert_eq!(classify(&"201#2301008813000000".parse().unwrap()), Ok(None));
        assert_eq!(classify(&"0A0#00".parse().unwrap()), Ok(None));
        assert!(matches!(
            classify(&"0F1#01".parse().unwrap()),
            Ok(Some(CanMessage::Request { request: Request::Home, .. }))
        ));
        assert!(classify(&"0F1#0A27".parse().unwrap()).is_err(), "GetExtended belongs on 0x0D1");
    }
}

#[cfg(test)]
mod proptests {
    use super::super::frame::{Motion, MotionValue, Payload};
    use super::*;
    use proptest::prelude::*;

    fn any_request() -> impl Strategy<Value = Request> {
        let motion = (
            proptest::sample::select(super::super::table::MOTIONS.iter().map(|m| m.id).collect::<Vec<_>>()),
            any::<i32>(),
            any::<u16>(),
        )
            .prop_map(|(id, raw, t)| {
                let def = super::super::table::motion(id).unwrap();
                let value = match def.arg {
                    super::super::table::MotionArg::Float => {
                        MotionValue::Float(f32::from_bits(raw as u32 & 0x3fff_ffff))
                    }
                    super::super::table::MotionArg::Int32 => MotionValue::Int32(raw),
                    super::super::table::MotionArg::Int16 => MotionValue::Int16(raw as i16),
                };
                Request::SetMotion(Motion { id, value, time_ms: def.timed.then_some(t) })
            });
        prop_oneof![
            Just(Request::Reset),
            Just(Request::Home),
            Just(Request::Halt),
            Just(Request::Watchdog),
            Just(Request::ResetTime),
            any::<u8>().prop_map(|param| Request::GetExtended { param }),
            (any::<u8>(), proptest::collection::vec(any::<u8>(), 1..=4))
                .prop_map(|(param, d)| Request::SetExtended { param, data: Payload::new(&d).unwrap() }),
            motion,
            (any::<i32>(), any::<u16>()).prop_map(|(target, time_ms)| Request::SetIStep { target, time_ms }),
        ]
    }

    proptest! {
        #[test]
        fn requests_round_trip_through_can(m in 1u8..=31, req in any_request()) {
            let module = ModuleId::new(m).unwrap();
            let frame = request_frame(module, &req);
            prop_assert_eq!(classify(&frame), Ok(Some(CanMessage::Request { module, request: req })));
        }

        #[test]
        fn classify_never_panics(id in 0u32..0x800, data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let frame = CanFrame::new(id, &data).unwrap();
            let _ = classify(&frame);
            let _ = Response::decode(&data);
            let _ = Request::decode(&data);
            let _ = Broadcast::decode(&data);
        }

        #[test]
        fn responses_round_trip(resp_bytes in proptest::collection::vec(any::<u8>(), 1..=8)) {
            if let Ok(resp) = Response::decode(&resp_bytes) {
                let again = resp.to_payload();
                prop_assert_eq!(again.as_slice(), &resp_bytes[..]);
            }
        }
    }
}
