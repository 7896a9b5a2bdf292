//! Passive bus decoding: what any CAN frame on a commissioning bus means.
//! Each CAN family of the registry reads its own frames (`proto::<family>::bus`,
//! through `Family::describe_can`); their ids do not overlap, and everything
//! else is shown raw. Sans-IO: frames in, [`FrameInfo`] out.
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
use crate::proto::bus::BusFrame;
use crate::proto::can_error::{CanEvent, ErrorFrame};
use crate::proto::CanFrame;

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

    /// A frame `family` decoded.
    fn of(family: Family, b: BusFrame) -> Self {
        let BusFrame { kind, module, node, summary, error, details } = b;
        Self { family: Some(family), kind, module, node, summary, error, details }
    }
}

/// Decodes one frame. Never panics; undecodable frames of a known family
/// carry `error`.
pub fn describe(frame: &CanFrame) -> FrameInfo {
    Family::ALL
        .into_iter()
        .find_map(|f| f.describe_can(frame).map(|b| FrameInfo::of(f, b)))
        .unwrap_or_else(|| FrameInfo::new(None, "raw", String::new()))
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

/// Why sending `frame` by hand may set something moving, if it may: the
/// registry's CAN families each say it of their own frames (a PowerCube
/// motion request or broadcast, a Cdios GOTO or START, or a frame of
/// either that does not decode: nothing can say it does not move).
pub fn motion_of(frame: &CanFrame) -> Option<String> {
    Family::ALL.into_iter().find_map(|f| f.can_motion(frame))
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

    const PC: Option<Family> = Some(Family::PowerCube);
    const CD: Option<Family> = Some(Family::Cdios);

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
