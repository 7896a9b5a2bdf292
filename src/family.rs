//! The device families, declared once: names, link kind, serial default,
//! decode kinds, id ranges and dashboard actions. The CLI, `monitor`,
//! `decode`, `sim`, the dashboard and the docs read this table instead of
//! spelling family facts out again.

use std::fmt;

use crate::link::SerialFormat;
use crate::proto::bus::BusFrame;
use crate::proto::{cdios, pac, powercube, CanFrame};

/// A family of motion hardware axisctl talks to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
pub enum Family {
    #[serde(rename = "powercube")]
    PowerCube,
    #[serde(rename = "pac")]
    Pac,
    #[serde(rename = "cdios")]
    Cdios,
}

/// Which links a family is reached over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkKind {
    Can,
    Rs232,
    /// Either: the PowerCube has a CAN and an RS232 port.
    CanOrRs232,
}

impl LinkKind {
    pub fn can(self) -> bool {
        matches!(self, Self::Can | Self::CanOrRs232)
    }
    pub fn rs232(self) -> bool {
        matches!(self, Self::Rs232 | Self::CanOrRs232)
    }
}

/// The character format and speed a family's RS232 port starts with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialDefault {
    pub baud: u32,
    pub format: SerialFormat,
}

/// One kind of address a family uses, with the range its proto newtype accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdRange {
    /// How the CLI and errors name it: "module id", "axis", "node id".
    pub what: &'static str,
    pub min: u8,
    pub max: u8,
}

impl IdRange {
    pub fn contains(self, id: u8) -> bool {
        (self.min..=self.max).contains(&id)
    }
}

impl fmt::Display for IdRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} to {}", self.what, self.min, self.max)
    }
}

/// PowerCube module address (the range of [`powercube::ModuleId`]).
pub const POWERCUBE_MODULE: IdRange =
    IdRange { what: "module id", min: powercube::ModuleId::MIN, max: powercube::ModuleId::MAX };
/// PA-CONTROL axis number.
pub const PAC_AXIS: IdRange = IdRange { what: "axis", min: 1, max: pac::table::MAX_AXES };
/// Cdios CANopen node id (the range of [`cdios::NodeId`]).
pub const CDIOS_NODE: IdRange = IdRange { what: "node id", min: cdios::NodeId::MIN, max: cdios::NodeId::MAX };
/// The Cdios node id a controller ships with: the node every Cdios command
/// talks to unless told another (`--node`), and the one a bench-wide scan
/// always probes.
pub const CDIOS_FACTORY_NODE: u8 = cdios::NodeId::FACTORY.get();
/// Cdios 6168 module id on a node (the range of [`cdios::ModuleId`]).
pub const CDIOS_MODULE: IdRange = IdRange { what: "module id", min: 0, max: cdios::ModuleId::MAX };

/// What the dashboard can ask of a device, family by family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Capability {
    Halt,
    Reset,
    Home,
    EnableDisable,
    Jog,
    GoTo,
    OnlineOffline,
}

/// The `decode` kinds of the Cdios (its other tables decode whole replies).
pub const CDIOS_DECODE_KINDS: &[&str] = &["cdios-status", "cdios-error"];
/// The PowerCube's Profibus input image, beside its flag words.
pub const POWERCUBE_PROFIBUS_IMAGE: &str = "profibus-image";

struct Info {
    name: &'static str,
    display: &'static str,
    aliases: &'static [&'static str],
    link: LinkKind,
    serial: Option<SerialDefault>,
    ids: &'static [IdRange],
    capabilities: &'static [Capability],
    /// How the family's CAN frames are told apart and read (`None`: not on CAN).
    can: Option<CanFrames>,
    /// Its RS232 answers as another of its devices sends them (`None`: a
    /// serial protocol without addresses, or none).
    serial_readdress: Option<ReaddressBytes>,
}

/// A CAN family's frames, as the bus sees them.
struct CanFrames {
    /// Whether a frame is one of its answers, by its id: what a shared bus routes by.
    answer: fn(&CanFrame) -> bool,
    /// A frame of its in words (`monitor`, `send`); `None` when not its.
    describe: fn(&CanFrame) -> Option<BusFrame>,
    /// Why a frame of its may start a motion, if it may.
    motion: fn(&CanFrame) -> Option<String>,
    /// One of its answers as another of its devices sends it, the device
    /// picked by `other(current, lowest, highest)` (the simulator's
    /// `wrong-module` fault); `None` when not one of its answers.
    readdress: Readdress<CanFrame>,
}

/// How an answer is made to name another device: `other(current, lowest,
/// highest)` picks the device.
type Readdress<T> = fn(&T, &mut dyn FnMut(u8, u8, u8) -> u8) -> Option<T>;
/// The same for a serial line's answers (bytes that do not frame are dropped).
type ReaddressBytes = fn(&[u8], &mut dyn FnMut(u8, u8, u8) -> u8) -> Vec<u8>;

const POWERCUBE: Info = Info {
    name: "powercube",
    display: "PowerCube",
    aliases: &["pc"],
    link: LinkKind::CanOrRs232,
    serial: Some(SerialDefault { baud: 9600, format: SerialFormat::F8N1 }),
    ids: &[POWERCUBE_MODULE],
    capabilities: &[Capability::Halt, Capability::Reset, Capability::Home, Capability::Jog, Capability::GoTo],
    can: Some(CanFrames {
        answer: |f| powercube::session::ack_module(f).is_some(),
        describe: powercube::bus::describe,
        motion: powercube::bus::motion_of,
        readdress: powercube::bus::readdressed,
    }),
    serial_readdress: Some(powercube::bus::readdressed_rs232),
};

const PAC: Info = Info {
    name: "pac",
    display: "PA-CONTROL",
    aliases: &["pa-control"],
    link: LinkKind::Rs232,
    serial: Some(SerialDefault { baud: 9600, format: SerialFormat::F7N1 }),
    ids: &[PAC_AXIS],
    capabilities: &[
        Capability::Halt,
        Capability::Reset,
        Capability::Home,
        Capability::EnableDisable,
        Capability::Jog,
        Capability::GoTo,
        Capability::OnlineOffline,
    ],
    can: None,
    serial_readdress: None,
};

const CDIOS: Info = Info {
    name: "cdios",
    display: "Cdios",
    aliases: &[],
    link: LinkKind::Can,
    serial: None,
    ids: &[CDIOS_NODE, CDIOS_MODULE],
    capabilities: &[Capability::Halt, Capability::Reset, Capability::EnableDisable, Capability::Jog, Capability::GoTo],
    can: Some(CanFrames {
        answer: |f| cdios::transport::answer_node(f).is_some(),
        describe: cdios::bus::describe,
        motion: cdios::bus::motion_of,
        readdress: cdios::bus::readdressed,
    }),
    serial_readdress: None,
};

impl Family {
    pub const ALL: [Family; 3] = [Family::PowerCube, Family::Pac, Family::Cdios];

    fn info(self) -> &'static Info {
        match self {
            Self::PowerCube => &POWERCUBE,
            Self::Pac => &PAC,
            Self::Cdios => &CDIOS,
        }
    }

    /// The CLI and JSON name: `powercube`, `pac`, `cdios`.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// How people write it: `PowerCube`, `PA-CONTROL`, `Cdios`.
    pub fn display_name(self) -> &'static str {
        self.info().display
    }

    pub fn aliases(self) -> &'static [&'static str] {
        self.info().aliases
    }

    pub fn link_kind(self) -> LinkKind {
        self.info().link
    }

    /// The RS232 default, `None` for a CAN-only family.
    pub fn serial_default(self) -> Option<SerialDefault> {
        self.info().serial
    }

    pub fn id_ranges(self) -> &'static [IdRange] {
        self.info().ids
    }

    pub fn capabilities(self) -> &'static [Capability] {
        self.info().capabilities
    }

    pub fn can(self, c: Capability) -> bool {
        self.capabilities().contains(&c)
    }

    /// The family whose answer a CAN frame is, by its id; `None` for a
    /// frame that answers nobody (a request of another master, NMT).
    pub fn of_can_answer(frame: &CanFrame) -> Option<Family> {
        Self::ALL.into_iter().find(|f| f.info().can.as_ref().is_some_and(|c| (c.answer)(frame)))
    }

    /// `frame` in the family's words, if it is one of the family's CAN frames.
    pub fn describe_can(self, frame: &CanFrame) -> Option<BusFrame> {
        (self.info().can.as_ref()?.describe)(frame)
    }

    /// One of the family's CAN answers as another of its devices sends it
    /// (`other(current, lowest, highest)` picks it); `None` when `frame` is
    /// not one of its answers.
    pub fn readdress_can(self, frame: &CanFrame, other: &mut dyn FnMut(u8, u8, u8) -> u8) -> Option<CanFrame> {
        (self.info().can.as_ref()?.readdress)(frame, other)
    }

    /// The family's RS232 answers as another of its devices sends them;
    /// `None` when its serial protocol names no device.
    pub fn readdress_serial(self, bytes: &[u8], other: &mut dyn FnMut(u8, u8, u8) -> u8) -> Option<Vec<u8>> {
        Some((self.info().serial_readdress?)(bytes, other))
    }

    /// Why sending `frame` may start a motion of the family's devices, if it may.
    pub fn can_motion(self, frame: &CanFrame) -> Option<String> {
        (self.info().can.as_ref()?.motion)(frame)
    }

    /// The `decode` kinds the family owns, read from its proto tables.
    pub fn decode_kinds(self) -> Vec<&'static str> {
        match self {
            Self::PowerCube => {
                powercube::flags::WORDS.iter().map(|w| w.kind).chain([POWERCUBE_PROFIBUS_IMAGE]).collect()
            }
            Self::Pac => pac::profibus::WORDS.iter().map(|w| w.kind).collect(),
            Self::Cdios => CDIOS_DECODE_KINDS.to_vec(),
        }
    }

    /// The family owning a `decode` kind (any case).
    pub fn of_decode_kind(kind: &str) -> Option<Family> {
        Self::ALL.into_iter().find(|f| f.decode_kinds().iter().any(|k| k.eq_ignore_ascii_case(kind)))
    }

    /// Every `decode` kind, family by family.
    pub fn all_decode_kinds() -> Vec<&'static str> {
        Self::ALL.into_iter().flat_map(Self::decode_kinds).collect()
    }

    /// The CLI names of the families that have `filter`, joined for help and errors.
    pub fn names_where(filter: impl Fn(Family) -> bool) -> String {
        join_or(&Self::ALL.into_iter().filter(|f| filter(*f)).map(Self::name).collect::<Vec<_>>())
    }
}

/// `a, b or c`.
pub fn join_or(words: &[&str]) -> String {
    match words {
        [] => String::new(),
        [one] => (*one).to_string(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

impl fmt::Display for Family {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.display_name())
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown family {0:?} (expected {names})", names = Family::names_where(|_| true))]
pub struct UnknownFamily(pub String);

impl std::str::FromStr for Family {
    type Err = UnknownFamily;
    /// The CLI name or an alias, any case.
    fn from_str(s: &str) -> Result<Self, UnknownFamily> {
        let s = s.trim();
        Self::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(s) || f.aliases().iter().any(|a| a.eq_ignore_ascii_case(s)))
            .ok_or_else(|| UnknownFamily(s.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_match_serde() {
        for f in Family::ALL {
            assert_eq!(f.name().parse::<Family>(), Ok(f));
            assert_eq!(f.name().to_uppercase().parse::<Family>(), Ok(f));
            assert_eq!(serde_json::to_value(f).unwrap(), f.name());
            for a in f.aliases() {
                assert_eq!(a.parse::<Family>(), Ok(f));
            }
        }
        assert!("robots".parse::<Family>().is_err());
        assert_eq!(Family::names_where(|_| true), "powercube, pac or cdios");
    }

    #[test]
    fn id_ranges_are_the_newtypes() {
        for id in 0..=255u8 {
            assert_eq!(POWERCUBE_MODULE.contains(id), powercube::ModuleId::new(id).is_some(), "{id}");
            assert_eq!(CDIOS_NODE.contains(id), cdios::NodeId::new(id).is_some(), "{id}");
            assert_eq!(CDIOS_MODULE.contains(id), cdios::ModuleId::new(id).is_some(), "{id}");
        }
        assert_eq!(PAC_AXIS.to_string(), "axis 1 to 16");
    }

    #[test]
    fn decode_kinds_are_owned_once() {
        let all = Family::all_decode_kinds();
        for k in &all {
            assert_eq!(all.iter().filter(|o| o.eq_ignore_ascii_case(k)).count(), 1, "{k} owned twice");
        }
        assert_eq!(Family::of_decode_kind("CUBE-STATE"), Some(Family::PowerCube));
        assert_eq!(Family::of_decode_kind("cdios-error"), Some(Family::Cdios));
        assert_eq!(Family::of_decode_kind("pac-axis-status"), Some(Family::Pac));
    }

    /// docs/links.md's link table says which families each link carries, as the registry does.
    #[test]
    fn the_link_table_of_the_docs_follows_the_registry() {
        let docs = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/links.md")).unwrap();
        let names = |fams: Vec<String>| fams.join(", ");
        let can = names(Family::ALL.into_iter().filter(|f| f.link_kind().can()).map(|f| f.to_string()).collect());
        let serial = names(
            Family::ALL
                .into_iter()
                .filter_map(|f| {
                    let d = f.serial_default()?;
                    let port = if f.link_kind().can() { " RS232" } else { "" };
                    Some(format!("{f}{port} (default {} {})", d.baud, d.format))
                })
                .collect(),
        );
        for (row, fams) in [("`socketcan:IFACE`", &can), ("`slcan:TTY", &can), ("`serial:TTY", &serial)] {
            let line = docs.lines().find(|l| l.starts_with(&format!("| {row}"))).unwrap_or_else(|| panic!("{row}"));
            assert!(line.ends_with(&format!("| {fams} |")), "docs/links.md: {line}\nexpected families: {fams}");
        }
    }

    #[test]
    fn serial_defaults() {
        assert_eq!(Family::PowerCube.serial_default().map(|s| (s.baud, s.format)), Some((9600, SerialFormat::F8N1)));
        assert_eq!(Family::Pac.serial_default().map(|s| (s.baud, s.format)), Some((9600, SerialFormat::F7N1)));
        assert_eq!(Family::Cdios.serial_default(), None);
    }
}
