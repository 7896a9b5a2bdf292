//! The PowerCube's frames as they read on a shared CAN bus, for `monitor`,
//! `send` and the served bench's trace: requests, acknowledges and
//! broadcasts in words, and which of them start a motion. The family
//! registry hands them to the bus decoder (`family::Family::describe_can`).

use serde_json::json;

use super::can::{self, Broadcast, CanMessage};
use super::flags;
use super::frame::Value;
use super::rs232;
use super::{table, Response};
use crate::proto::bus::BusFrame;
use crate::proto::CanFrame;

/// Why sending `frame` by hand may set something moving, if it is a
/// PowerCube frame that may: a motion request (Home, SetMotion, SetIStep),
/// the Home / StartMotion broadcast, or a frame on its ids that does not
/// decode (nothing can say it does not move).
pub fn motion_of(frame: &CanFrame) -> Option<String> {
    match can::classify(frame) {
        Ok(Some(CanMessage::Request { module, request })) if request.is_motion() => {
            Some(format!("{request} starts a motion of PowerCube module {module}"))
        }
        Ok(Some(CanMessage::Broadcast(b @ (Broadcast::Home | Broadcast::StartMotion)))) => {
            Some(format!("the {b} broadcast starts every PowerCube module on the bus"))
        }
        Ok(_) => None,
        Err(e) => Some(format!("a PowerCube frame that does not decode ({e}): it may move a module")),
    }
}

/// A frame on the PowerCube's ids (0x0A1..0x0FF, the broadcast 0x100)
/// taken apart; `None` for any other frame.
pub fn describe(frame: &CanFrame) -> Option<BusFrame> {
    let id = frame.id();
    let ours = !frame.is_extended() && (id == can::BROADCAST_ID || (0x0A1..=0x0FF).contains(&id) && id & 0x1F != 0);
    if !ours {
        return None;
    }
    Some(match can::classify(frame) {
        Ok(Some(CanMessage::Request { module, request })) => {
            let mut i = BusFrame::new("request", request.to_string());
            i.module = Some(module.get());
            i
        }
        Ok(Some(CanMessage::Ack { module, response })) => {
            let (summary, details) = describe_ack(&response);
            let mut i = BusFrame::new("ack", summary);
            i.module = Some(module.get());
            i.details = details;
            i
        }
        Ok(Some(CanMessage::Broadcast(b))) => {
            let mut i = BusFrame::new("broadcast", format!("{b} to all"));
            i.details = json!({"command": b.command().name()});
            if let can::Broadcast::ChangeBaudrate(p) = b {
                i.details["bitrate"] = json!(can::Broadcast::bitrate(p));
            }
            i
        }
        Ok(None) => return None,
        Err(e) => {
            let mut i = BusFrame::new("raw", String::new());
            i.module = Some((id & 0x1F) as u8).filter(|m| *m != 0);
            i.error = Some(e.to_string());
            i
        }
    })
}

/// An acknowledge for humans and as JSON details: the parameter's value by
/// its table type (flag words with their flags), the motion by name.
pub fn describe_ack(resp: &Response) -> (String, serde_json::Value) {
    match resp {
        Response::Get { param, data } => {
            let Some(def) = table::param(*param) else {
                return (format!("GetExtended {param:#04x} = {data:?}"), serde_json::Value::Null);
            };
            match Value::decode(def.ty, data.as_slice()) {
                Ok(v) => {
                    let mut details = json!({"param": def.name, "id": def.id, "value": v});
                    let mut text = format!("{} = {v}", def.name);
                    if let (Some(word), Some(raw)) = (flags::word_for_param(*param), v.as_f64()) {
                        let d = word.decode(raw as u32);
                        text.push_str(&format!(" [{}]", d.flags.join(" ")));
                        details["flags"] = json!(d.flags);
                        details["errors"] = json!(d.errors);
                    }
                    (text, details)
                }
                Err(e) => (format!("{} = {data:?} ({e})", def.name), serde_json::Value::Null),
            }
        }
        Response::SetAck { param } => {
            (format!("SetExtended {} ok", table::param(*param).map_or("?", |d| d.name)), serde_json::Value::Null)
        }
        Response::MotionAck { motion } => {
            (format!("SetMotion {} ok", table::motion(*motion).map_or("?", |d| d.name)), serde_json::Value::Null)
        }
        Response::MotionAckExt { motion, pos, short_state, dio } => {
            let def = table::motion(*motion);
            let float = def.is_some_and(|d| d.name.starts_with('F'));
            let pos = if float { f64::from(f32::from_le_bytes(*pos)) } else { f64::from(i32::from_le_bytes(*pos)) };
            let st = flags::SHORT_STATE.decode(u32::from(*short_state));
            let io = flags::DIO.decode(u32::from(*dio));
            (
                format!(
                    "SetMotion {} ok, pos {pos} [{}] dio [{}]",
                    def.map_or("?", |d| d.name),
                    st.flags.join(" "),
                    io.flags.join(" ")
                ),
                // The one state shape, as `state` gives its short state.
                json!({"position": pos, "short_state": flags::SHORT_STATE.state_json(u32::from(*short_state)),
                       "dio": flags::DIO.state_json(u32::from(*dio))}),
            )
        }
        Response::Simple(cmd) => (format!("{} ok", cmd.name()), serde_json::Value::Null),
    }
}

/// An acknowledge on CAN as another module sends it, its module picked by
/// `other(current, lowest, highest)`; `None` for a frame that is no
/// module's acknowledge. What the simulator's `wrong-module` fault sends.
pub fn readdressed(f: &CanFrame, other: &mut dyn FnMut(u8, u8, u8) -> u8) -> Option<CanFrame> {
    let id = f.id();
    if f.is_extended() || !(can::ACK_BASE + 1..can::ACK_BASE + 32).contains(&id) {
        return None;
    }
    let m = other((id - can::ACK_BASE) as u8, 1, 31);
    CanFrame::new(can::ACK_BASE + u32::from(m), f.data())
}

/// RS232 answers re-framed as if another module had sent them (module
/// picked by `other(current, lowest, highest)`); broadcasts stay as they
/// are, bytes that do not frame are dropped.
pub fn readdressed_rs232(bytes: &[u8], other: &mut dyn FnMut(u8, u8, u8) -> u8) -> Vec<u8> {
    let mut d = rs232::Decoder::new();
    d.push(bytes);
    let mut out = Vec::with_capacity(bytes.len() + 4);
    while let Some(item) = d.next_frame() {
        match item {
            Ok(mut f) if !f.is_broadcast() => {
                f.module = other(f.module, 1, 31);
                rs232::encode(f.dir, f.module, f.payload.as_slice(), &mut out);
            }
            Ok(f) => f.encode(&mut out),
            Err(_) => {}
        }
    }
    out
}
