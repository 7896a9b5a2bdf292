//! Passive bus decoding: what any CAN frame on a commissioning bus means.
//! PowerCube ids (0x0A1..0x0FF, 0x100) and Cdios ids (NMT 0x000, 0x181.., 0x201..)
//! do not overlap; everything else is shown raw. Sans-IO: frames in, [`FrameInfo`] out.
//!
//! Above `proto/` only because it names frames by the family registry.

use std::collections::BTreeMap;

mod filter;
mod table;
pub use filter::{passes_any, FilterError, IdFilter};
pub use table::{Row, Table};

use serde::Serialize;
use serde_json::json;

use crate::family::Family;
use crate::proto::can_error::{CanEvent, ErrorFrame};
use crate::proto::cdios::transport::{self as cdios_tp, AnswerKind, BusMessage};
use crate::proto::cdios::{table as cdios_table, Address};
use crate::proto::powercube::can::{self as pc_can, CanMessage};
use crate::proto::powercube::flags;
use crate::proto::powercube::frame::Value;
use crate::proto::powercube::{table as pc_table, Response};
use crate::proto::CanFrame;

const PC: Option<Family> = Some(Family::PowerCube);
const CD: Option<Family> = Some(Family::Cdios);

/// Which frames a `--family` filter keeps: a family on CAN, or the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FamilyFilter {
    Of(Family),
    Other,
}

impl FamilyFilter {
    /// The registry's CAN families by name or alias, and `other` (or `raw`)
    /// for frames of none.
    pub fn parse(s: &str) -> Result<Self, String> {
        let can = || format!("{} or other", Family::names_where(|f| f.link_kind().can()).replace(" or ", ", "));
        if ["other", "raw"].iter().any(|o| o.eq_ignore_ascii_case(s.trim())) {
            return Ok(Self::Other);
        }
        match s.parse::<Family>() {
            Ok(f) if f.link_kind().can() => Ok(Self::Of(f)),
            Ok(f) => Err(format!("{f} is not on CAN; expected {}", can())),
            Err(_) => Err(format!("expected {}", can())),
        }
    }

    pub fn pass(self, info: &FrameInfo) -> bool {
        match self {
            Self::Of(f) => info.family == Some(f),
            Self::Other => info.family.is_none(),
        }
    }
}

/// A frame's family in JSON and text: its registry name, `other` for none.
pub fn family_name(family: Option<Family>) -> &'static str {
    family.map_or("other", Family::name)
}

/// In JSON a frame of no known family has `"family": null`: the key is the
/// contract's envelope, whose family is one of the registry's names.
fn serialize_family<S: serde::Serializer>(f: &Option<Family>, s: S) -> Result<S::Ok, S::Error> {
    match f {
        Some(f) => s.serialize_str(f.name()),
        None => s.serialize_none(),
    }
}

/// One decoded frame.
#[derive(Debug, Clone, Serialize)]
pub struct FrameInfo {
    /// `None` for a frame of no known family (`null` in JSON, `other` in text).
    #[serde(serialize_with = "serialize_family")]
    pub family: Option<Family>,
    /// request, ack, broadcast, nmt, command, reply, event, error or raw.
    pub kind: &'static str,
    /// PowerCube module id, or Cdios module id (0..15; > 15 the controller).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub module: Option<u8>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node: Option<u8>,
    pub summary: String,
    /// Set when the frame belongs to a family but does not decode.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    #[serde(skip_serializing_if = "serde_json::Value::is_null")]
    pub details: serde_json::Value,
}

impl FrameInfo {
    fn new(family: Option<Family>, kind: &'static str, summary: String) -> Self {
        Self { family, kind, module: None, node: None, summary, error: None, details: serde_json::Value::Null }
    }
}

/// Decodes one frame. Never panics; undecodable frames of a known family
/// carry `error`.
pub fn describe(frame: &CanFrame) -> FrameInfo {
    if let Some(info) = powercube(frame) {
        return info;
    }
    if let Some(info) = cdios(frame) {
        return info;
    }
    FrameInfo::new(None, "raw", String::new())
}

/// An error frame of the bus (SocketCAN's, or an slcan adapter's report):
/// kind `error` of no family, what happened in words.
pub fn describe_error(frame: &ErrorFrame) -> FrameInfo {
    let problems = frame.problems();
    let mut i = FrameInfo::new(None, "error", format!("bus error: {}", problems.join("; ")));
    i.details = json!({"error_class": frame.class, "problems": problems});
    i
}

/// [`describe`] or [`describe_error`].
pub fn describe_event(event: &CanEvent) -> FrameInfo {
    match event {
        CanEvent::Frame(f) => describe(f),
        CanEvent::Error(e) => describe_error(e),
    }
}

/// Why sending `frame` by hand may set something moving, if it may: a
/// PowerCube motion request (Home, SetMotion, SetIStep) or Home / StartMotion
/// broadcast, a Cdios GOTO or START, or a command of either family that does
/// not decode (nothing can say it does not move).
pub fn motion_of(frame: &CanFrame) -> Option<String> {
    match pc_can::classify(frame) {
        Ok(Some(CanMessage::Request { module, request })) if request.is_motion() => {
            return Some(format!("{request} starts a motion of PowerCube module {module}"));
        }
        Ok(Some(CanMessage::Broadcast(b @ (pc_can::Broadcast::Home | pc_can::Broadcast::StartMotion)))) => {
            return Some(format!("the {b} broadcast starts every PowerCube module on the bus"));
        }
        Ok(_) => {}
        Err(e) => return Some(format!("a PowerCube frame that does not decode ({e}): it may move a module")),
    }
    match cdios_tp::classify(frame) {
        Ok(Some(BusMessage::Command { node, data })) => match cdios_table::decode_command(&data) {
            Ok(d) if [cdios_table::GOTO, cdios_table::START].contains(&d.def.code) => {
                Some(format!("Cdios {} starts a motor of node {node}", d.def.key))
            }
            Ok(_) => None,
            Err(e) => Some(format!("a Cdios command that does not decode ({e}): it may start a motor")),
        },
        _ => None,
    }
}

fn powercube(frame: &CanFrame) -> Option<FrameInfo> {
    let id = frame.id();
    let ours = !frame.is_extended() && (id == pc_can::BROADCAST_ID || (0x0A1..=0x0FF).contains(&id) && id & 0x1F != 0);
    if !ours {
        return None;
    }
    Some(match pc_can::classify(frame) {
        Ok(Some(CanMessage::Request { module, request })) => {
            let mut i = FrameInfo::new(PC, "request", request.to_string());
            i.module = Some(module.get());
            i
        }
        Ok(Some(CanMessage::Ack { module, response })) => {
            let (summary, details) = describe_ack(&response);
            let mut i = FrameInfo::new(PC, "ack", summary);
            i.module = Some(module.get());
            i.details = details;
            i
        }
        Ok(Some(CanMessage::Broadcast(b))) => {
            let mut i = FrameInfo::new(PC, "broadcast", format!("{b} to all"));
            i.details = json!({"command": b.command().name()});
            if let pc_can::Broadcast::ChangeBaudrate(p) = b {
                i.details["bitrate"] = json!(pc_can::Broadcast::bitrate(p));
            }
            i
        }
        Ok(None) => return None,
        Err(e) => {
            let mut i = FrameInfo::new(PC, "raw", String::new());
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
            let Some(def) = pc_table::param(*param) else {
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
            (format!("SetExtended {} ok", pc_table::param(*param).map_or("?", |d| d.name)), serde_json::Value::Null)
        }
        Response::MotionAck { motion } => {
            (format!("SetMotion {} ok", pc_table::motion(*motion).map_or("?", |d| d.name)), serde_json::Value::Null)
        }
        Response::MotionAckExt { motion, pos, short_state, dio } => {
            let def = pc_table::motion(*motion);
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

fn cdios(frame: &CanFrame) -> Option<FrameInfo> {
    let msg = match cdios_tp::classify(frame) {
        Ok(Some(m)) => m,
        Ok(None) => return None,
        Err(e) => {
            let mut i = FrameInfo::new(CD, "raw", String::new());
            i.error = Some(e.to_string());
            return Some(i);
        }
    };
    Some(match msg {
        BusMessage::Nmt { command, node } => {
            let what = if command == 0x01 { "start".to_string() } else { format!("command {command:#04x}") };
            let target = if node == 0 { "all nodes".to_string() } else { format!("node {node}") };
            FrameInfo::new(CD, "nmt", format!("NMT {what} {target}"))
        }
        BusMessage::Command { node, data } => {
            let mut i = match cdios_table::decode_command(&data) {
                Ok(d) => {
                    let mut i = FrameInfo::new(CD, "command", format!("{} {}", d.def.key, fields_text(&d.fields)));
                    i.module = Some(match d.address {
                        Address::Module(m) => m.get(),
                        Address::Controller => 0xFF,
                    });
                    i.details = json!({"command": d.def.key, "selector": d.selector, "fields": d.fields});
                    i
                }
                Err(e) => {
                    let mut i = FrameInfo::new(CD, "command", format!("{:02x?}", data));
                    i.error = Some(e.to_string());
                    i
                }
            };
            i.node = Some(node.get());
            i
        }
        BusMessage::Answer(a) => {
            let kind = match a.kind {
                AnswerKind::Reply => "reply",
                AnswerKind::Event => "event",
                AnswerKind::Error => "error",
            };
            let mut i = FrameInfo::new(CD, kind, String::new());
            i.node = Some(a.node.get());
            i.module = Some(a.module);
            if let Some(err) = a.error() {
                i.summary = format!("error to {:#04x}: {}", a.command, err.describe());
                i.details = json!({"command": a.command, "general": err.general, "status1": err.status1, "status2": err.status2});
            } else if let Some(r) = a.reply() {
                match r {
                    Ok(r) => {
                        i.summary = format!("{} {}", r.def.map_or("?", |d| d.key), fields_text(&r.fields));
                        i.details = serde_json::to_value(&r).unwrap_or_default();
                    }
                    Err(e) => i.error = Some(e.to_string()),
                }
            }
            i
        }
    })
}

fn fields_text(fields: &[cdios_table::FieldValue]) -> String {
    fields
        .iter()
        .map(|f| match (f.value, f.value_unit) {
            (Some(v), Some(u)) => format!("{}={v}{u}", f.key),
            _ => format!("{}={}", f.key, f.raw),
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// Frame counts by family and kind, plus decode errors.
#[derive(Debug, Default, Clone, Serialize)]
pub struct Stats {
    pub frames: u64,
    pub errors: u64,
    pub by_kind: BTreeMap<String, u64>,
    pub by_id: BTreeMap<String, u64>,
}

impl Stats {
    pub fn add(&mut self, frame: &CanFrame, info: &FrameInfo) {
        self.add_id(format!("{:03X}", frame.id()), info);
    }

    /// [`add`](Self::add) for a data or an error frame (counted under its
    /// candump id, `20000004`).
    pub fn add_event(&mut self, event: &CanEvent, info: &FrameInfo) {
        match event {
            CanEvent::Frame(f) => self.add(f, info),
            CanEvent::Error(e) => self.add_id(format!("{:08X}", e.id()), info),
        }
    }

    fn add_id(&mut self, id: String, info: &FrameInfo) {
        self.frames += 1;
        if info.error.is_some() {
            self.errors += 1;
        }
        *self.by_kind.entry(format!("{}/{}", family_name(info.family), info.kind)).or_default() += 1;
        *self.by_id.entry(id).or_default() += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(s: &str) -> FrameInfo {
        describe(&s.parse().unwrap())
    }

    #[test]
    fn decodes_both_families_and_leaves_others_raw() {
        let home = d("0F1#01");
        assert_eq!((home.family, home.kind, home.module), (PC, "request", Some(17)));
        assert_eq!(home.summary, "Home");
        let st = d("0B1#0A2702000000");
        assert_eq!(st.kind, "ack");
        assert!(st.summary.contains("CubeState") && st.summary.contains("STATE_HOME_OK"), "{}", st.summary);
        assert_eq!(d("100#0700").kind, "broadcast");
        let baud = d("100#0902");
        assert_eq!(baud.summary, "ChangeBaudrate 500 kbit/s to all");
        assert_eq!(baud.details["bitrate"], 500_000);
        assert_eq!(d("100#0200").summary, "Halt to all");
        // The vendor library's SaveParameters is no command of the manual.
        let save = d("0E3#10");
        assert_eq!((save.kind, save.module), ("raw", Some(3)));
        assert!(save.error.as_deref().unwrap_or("").contains("unknown command id"), "{:?}", save.error);
        let goto = d("201#2301008813000000");
        assert_eq!((goto.family, goto.kind, goto.node, goto.module), (CD, "command", Some(1), Some(1)));
        assert_eq!(d("000#0101").kind, "nmt");
        assert_eq!(d("7FF#00").family, None);
        assert_eq!(d("12345678#00").family, None);
        assert_eq!(serde_json::to_value(d("7FF#00")).unwrap()["family"], serde_json::Value::Null);
        let bad = d("0B1#0B");
        assert!(bad.error.is_some(), "a truncated ack is an error of its family");
    }

    #[test]
    fn family_filter_reads_the_registry() {
        assert_eq!(FamilyFilter::parse("PC"), Ok(FamilyFilter::Of(Family::PowerCube)));
        assert_eq!(FamilyFilter::parse("cdios"), Ok(FamilyFilter::Of(Family::Cdios)));
        assert_eq!(FamilyFilter::parse("raw"), Ok(FamilyFilter::Other));
        assert!(FamilyFilter::parse("pac").unwrap_err().contains("not on CAN"));
        assert_eq!(FamilyFilter::parse("bogus").unwrap_err(), "expected powercube, cdios or other");
        assert!(FamilyFilter::Other.pass(&d("7FF#00")) && !FamilyFilter::Other.pass(&d("0F1#01")));
    }

    proptest::proptest! {
        #[test]
        fn never_panics(id in 0u32..0x800, data in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..=8)) {
            let f = CanFrame::new(id, &data).unwrap();
            let info = describe(&f);
            let mut s = Stats::default();
            s.add(&f, &info);
            let _ = serde_json::to_string(&info).unwrap();
        }
    }
}
