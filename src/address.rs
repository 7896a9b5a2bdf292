//! One device address for every family: `powercube:3` (a module), `pac` (the
//! controller) and `pac:2` (one of its axes), `cdios:1/0` (node 1, module 0),
//! or a name the bench file gives a device. The id ranges are the family
//! registry's, so an address that parses names a device that can exist.

use std::fmt;
use std::str::FromStr;

use crate::family::{self, Family, IdRange};

/// A device, said the same way for every family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Address {
    PowerCube {
        module: u8,
    },
    /// `axis: None` is the controller itself (`pac`): a PA-CONTROL answers
    /// for its axes, and some commands (a halt-all, the mode) are its own.
    Pac {
        axis: Option<u8>,
    },
    Cdios {
        node: u8,
        module: u8,
    },
}

/// What the user may write where a device is asked for: an address, or a
/// name from the bench file (resolved by [`crate::bench::Bench::resolve`]).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum DeviceRef {
    Address(Address),
    Name(String),
}

/// Why a text is not a device address.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AddressError {
    #[error("empty device address (expected {FORMS})")]
    Empty,
    #[error("device address {text:?}: unknown family {family:?} (expected {FORMS})")]
    UnknownFamily { text: String, family: String },
    #[error("device address {text:?}: {range}, not {value:?}")]
    OutOfRange { text: String, range: IdRange, value: String },
    #[error("device address {text:?}: the {family} is addressed as {form}")]
    Form { text: String, family: Family, form: &'static str },
    #[error(
        "{text:?} is not a device address or name (expected {FORMS}; a name is letters, digits, '_' and '-', \
         starting with a letter)"
    )]
    BadName { text: String },
}

const FORMS: &str = "powercube:MODULE, pac, pac:AXIS, cdios:NODE/MODULE";

impl Address {
    /// How a device of `family` is written: `powercube:MODULE`, `pac:AXIS`
    /// (or `pac`, the controller), `cdios:NODE/MODULE`.
    pub fn form(family: Family) -> &'static str {
        match family {
            Family::PowerCube => "powercube:MODULE",
            Family::Pac => "pac:AXIS",
            Family::Cdios => "cdios:NODE/MODULE",
        }
    }

    pub fn family(self) -> Family {
        match self {
            Self::PowerCube { .. } => Family::PowerCube,
            Self::Pac { .. } => Family::Pac,
            Self::Cdios { .. } => Family::Cdios,
        }
    }

    /// The device a decoded frame names by its raw ids (module; axis, `None`
    /// the controller; node and module), checked against the registry's
    /// ranges; `None` when they name no one device.
    pub fn of_ids(family: Family, first: Option<u8>, second: Option<u8>) -> Option<Self> {
        match (family, first, second) {
            (Family::PowerCube, Some(m), _) => Self::powercube(m),
            (Family::Pac, axis, _) => Self::pac(axis),
            (Family::Cdios, Some(n), Some(m)) => Self::cdios(n, m),
            (Family::PowerCube | Family::Cdios, ..) => None,
        }
    }

    /// A PowerCube module, checked against the registry's range.
    pub fn powercube(module: u8) -> Option<Self> {
        family::POWERCUBE_MODULE.contains(module).then_some(Self::PowerCube { module })
    }

    /// A PA-CONTROL axis (`Some`) or the controller (`None`).
    pub fn pac(axis: Option<u8>) -> Option<Self> {
        axis.is_none_or(|a| family::PAC_AXIS.contains(a)).then_some(Self::Pac { axis })
    }

    /// A Cdios module on a node.
    pub fn cdios(node: u8, module: u8) -> Option<Self> {
        (family::CDIOS_NODE.contains(node) && family::CDIOS_MODULE.contains(module))
            .then_some(Self::Cdios { node, module })
    }
}

impl Address {
    /// `PowerCube 17`, `PA-CONTROL`, `PA axis 2`, `Cdios 1/0`: how the
    /// dashboard's events and panes name the device.
    pub fn label(self) -> String {
        match self {
            Self::PowerCube { module } => format!("PowerCube {module}"),
            Self::Pac { axis: None } => "PA-CONTROL".into(),
            Self::Pac { axis: Some(a) } => format!("PA axis {a}"),
            Self::Cdios { node, module } => format!("Cdios {node}/{module}"),
        }
    }

    /// `module 17`, `axis 2`, `node 1 module 0`: the device part of a
    /// recording's CSV column and chart legend (the family is the link's).
    pub fn column(self) -> String {
        match self {
            Self::PowerCube { module } => format!("module {module}"),
            Self::Pac { axis: None } => "controller".into(),
            Self::Pac { axis: Some(a) } => format!("axis {a}"),
            Self::Cdios { node, module } => format!("node {node} module {module}"),
        }
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = self.family().name();
        match self {
            Self::PowerCube { module } => write!(f, "{name}:{module}"),
            Self::Pac { axis: None } => f.write_str(name),
            Self::Pac { axis: Some(a) } => write!(f, "{name}:{a}"),
            Self::Cdios { node, module } => write!(f, "{name}:{node}/{module}"),
        }
    }
}

/// One id of an address: decimal digits within the registry's range.
fn id(text: &str, value: &str, range: IdRange) -> Result<u8, AddressError> {
    let out = || AddressError::OutOfRange { text: text.into(), range, value: value.into() };
    if value.is_empty() || !value.bytes().all(|b| b.is_ascii_digit()) {
        return Err(out());
    }
    // Digits only, so a failure is a value past u8: out of range too.
    let n: u8 = value.parse().map_err(|_| out())?;
    if range.contains(n) {
        Ok(n)
    } else {
        Err(out())
    }
}

impl FromStr for Address {
    type Err = AddressError;

    /// `family` or `family:ids`; the family by its name or an alias, any case.
    fn from_str(s: &str) -> Result<Self, AddressError> {
        let text = s.trim();
        if text.is_empty() {
            return Err(AddressError::Empty);
        }
        let (fam, rest) = match text.split_once(':') {
            Some((f, r)) => (f, Some(r)),
            None => (text, None),
        };
        let family: Family =
            fam.parse().map_err(|_| AddressError::UnknownFamily { text: text.into(), family: fam.trim().into() })?;
        let form = |form| AddressError::Form { text: text.into(), family, form };
        match (family, rest) {
            (Family::PowerCube, Some(m)) => Ok(Self::PowerCube { module: id(text, m, family::POWERCUBE_MODULE)? }),
            (Family::PowerCube, None) => Err(form("powercube:MODULE")),
            (Family::Pac, None) => Ok(Self::Pac { axis: None }),
            (Family::Pac, Some(a)) => Ok(Self::Pac { axis: Some(id(text, a, family::PAC_AXIS)?) }),
            (Family::Cdios, Some(nm)) => {
                let (n, m) = nm.split_once('/').ok_or_else(|| form("cdios:NODE/MODULE"))?;
                Ok(Self::Cdios { node: id(text, n, family::CDIOS_NODE)?, module: id(text, m, family::CDIOS_MODULE)? })
            }
            (Family::Cdios, None) => Err(form("cdios:NODE/MODULE")),
        }
    }
}

/// Whether `s` may name a device in a bench file: a letter, then letters,
/// digits, `_` and `-`, and not a family's name (so `pac` stays the
/// controller).
pub fn is_name(s: &str) -> bool {
    let mut chars = s.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        && s.parse::<Family>().is_err()
}

impl fmt::Display for DeviceRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Address(a) => a.fmt(f),
            Self::Name(n) => f.write_str(n),
        }
    }
}

impl FromStr for DeviceRef {
    type Err = AddressError;

    /// An address when it starts with a family (`pc:3`, `pac`), else a name.
    fn from_str(s: &str) -> Result<Self, AddressError> {
        let text = s.trim();
        let head = text.split(':').next().unwrap_or_default();
        if text.contains(':') || head.parse::<Family>().is_ok() {
            return text.parse().map(Self::Address);
        }
        if is_name(text) {
            Ok(Self::Name(text.into()))
        } else if text.is_empty() {
            Err(AddressError::Empty)
        } else {
            Err(AddressError::BadName { text: text.into() })
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    #[test]
    fn each_form_parses_and_prints_back() {
        for (text, addr) in [
            ("powercube:3", Address::PowerCube { module: 3 }),
            ("pac", Address::Pac { axis: None }),
            ("pac:2", Address::Pac { axis: Some(2) }),
            ("cdios:1/0", Address::Cdios { node: 1, module: 0 }),
        ] {
            assert_eq!(text.parse::<Address>(), Ok(addr), "{text}");
            assert_eq!(addr.to_string(), text);
        }
        // Aliases and any case, printed with the family's name.
        assert_eq!("PC:17".parse::<Address>().unwrap().to_string(), "powercube:17");
        assert_eq!("pa-control:16".parse::<Address>().unwrap().to_string(), "pac:16");
        assert_eq!(" cdios:127/15 ".parse::<Address>().unwrap().to_string(), "cdios:127/15");
    }

    #[test]
    fn the_dashboard_labels_and_a_recordings_columns() {
        let labels: Vec<String> = [
            Address::PowerCube { module: 17 },
            Address::Pac { axis: None },
            Address::Pac { axis: Some(2) },
            Address::Cdios { node: 1, module: 0 },
        ]
        .iter()
        .map(|a| a.label())
        .collect();
        assert_eq!(labels, ["PowerCube 17", "PA-CONTROL", "PA axis 2", "Cdios 1/0"]);
        let columns: Vec<String> = [
            Address::PowerCube { module: 17 },
            Address::Pac { axis: None },
            Address::Pac { axis: Some(2) },
            Address::Cdios { node: 1, module: 0 },
        ]
        .iter()
        .map(|a| a.column())
        .collect();
        assert_eq!(columns, ["module 17", "controller", "axis 2", "node 1 module 0"]);
    }

    #[test]
    fn ids_follow_the_registry_ranges() {
        let err = |s: &str| s.parse::<Address>().unwrap_err().to_string();
        assert_eq!(err("powercube:0"), "device address \"powercube:0\": module id 1 to 31, not \"0\"");
        assert_eq!(err("powercube:32"), "device address \"powercube:32\": module id 1 to 31, not \"32\"");
        assert_eq!(err("powercube:256"), "device address \"powercube:256\": module id 1 to 31, not \"256\"");
        assert_eq!(err("pac:0"), "device address \"pac:0\": axis 1 to 16, not \"0\"");
        assert_eq!(err("pac:17"), "device address \"pac:17\": axis 1 to 16, not \"17\"");
        assert_eq!(err("cdios:0/0"), "device address \"cdios:0/0\": node id 1 to 127, not \"0\"");
        assert_eq!(err("cdios:1/16"), "device address \"cdios:1/16\": module id 0 to 15, not \"16\"");
        assert_eq!(err("cdios:1"), "device address \"cdios:1\": the Cdios is addressed as cdios:NODE/MODULE");
        assert_eq!(err("powercube"), "device address \"powercube\": the PowerCube is addressed as powercube:MODULE");
        assert_eq!(err("robot:1"), format!("device address \"robot:1\": unknown family \"robot\" (expected {FORMS})"));
        assert_eq!(err("pac:+2"), "device address \"pac:+2\": axis 1 to 16, not \"+2\"");
        assert_eq!(err(""), format!("empty device address (expected {FORMS})"));
        for id in 0..=255u8 {
            assert_eq!(Address::powercube(id).is_some(), family::POWERCUBE_MODULE.contains(id));
            assert_eq!(format!("powercube:{id}").parse::<Address>().is_ok(), family::POWERCUBE_MODULE.contains(id));
            assert_eq!(format!("pac:{id}").parse::<Address>().is_ok(), family::PAC_AXIS.contains(id));
        }
    }

    #[test]
    fn raw_ids_name_a_device_only_within_the_ranges() {
        assert_eq!(Address::of_ids(Family::PowerCube, Some(3), None), Some(Address::PowerCube { module: 3 }));
        assert_eq!(Address::of_ids(Family::PowerCube, Some(0), None), None);
        assert_eq!(Address::of_ids(Family::PowerCube, None, None), None);
        assert_eq!(Address::of_ids(Family::Pac, None, None), Some(Address::Pac { axis: None }));
        assert_eq!(Address::of_ids(Family::Pac, Some(17), None), None);
        assert_eq!(Address::of_ids(Family::Cdios, Some(1), Some(0)), Some(Address::Cdios { node: 1, module: 0 }));
        assert_eq!(Address::of_ids(Family::Cdios, Some(1), None), None);
        assert_eq!(Address::of_ids(Family::Cdios, Some(1), Some(16)), None);
    }

    #[test]
    fn names_are_not_addresses() {
        assert_eq!("shoulder".parse::<DeviceRef>(), Ok(DeviceRef::Name("shoulder".into())));
        assert_eq!("pac".parse::<DeviceRef>(), Ok(DeviceRef::Address(Address::Pac { axis: None })));
        assert_eq!("pc:3".parse::<DeviceRef>(), Ok(DeviceRef::Address(Address::PowerCube { module: 3 })));
        assert!(matches!("robot:3".parse::<DeviceRef>(), Err(AddressError::UnknownFamily { .. })));
        assert!(matches!("3arm".parse::<DeviceRef>(), Err(AddressError::BadName { .. })));
        assert!(matches!("arm 2".parse::<DeviceRef>(), Err(AddressError::BadName { .. })));
        assert!(!is_name("cdios") && !is_name("PC") && is_name("left-arm_2"));
    }

    fn ids(r: IdRange) -> std::ops::RangeInclusive<u8> {
        r.min..=r.max
    }

    fn address() -> impl Strategy<Value = Address> {
        prop_oneof![
            ids(family::POWERCUBE_MODULE).prop_map(|module| Address::PowerCube { module }),
            proptest::option::of(ids(family::PAC_AXIS)).prop_map(|axis| Address::Pac { axis }),
            (ids(family::CDIOS_NODE), ids(family::CDIOS_MODULE))
                .prop_map(|(node, module)| Address::Cdios { node, module }),
        ]
    }

    proptest! {
        #[test]
        fn display_parses_back(a in address()) {
            prop_assert_eq!(a.to_string().parse::<Address>(), Ok(a));
            prop_assert_eq!(a.to_string().parse::<DeviceRef>(), Ok(DeviceRef::Address(a)));
        }

        #[test]
        fn names_print_back(n in "[a-zA-Z][a-zA-Z0-9_-]{0,12}") {
            prop_assume!(n.parse::<Family>().is_err());
            prop_assert_eq!(n.parse::<DeviceRef>().map(|d| d.to_string()), Ok(n.clone()));
        }

        #[test]
        fn garbage_never_panics(s in "\\PC{0,24}", t in "[a-z:/0-9 -]{0,16}") {
            for text in [&s, &t] {
                if let Ok(a) = text.parse::<Address>() {
                    prop_assert_eq!(a.to_string().parse::<Address>(), Ok(a));
                }
                if let Ok(d) = text.parse::<DeviceRef>() {
                    prop_assert_eq!(d.to_string().parse::<DeviceRef>(), Ok(d));
                }
            }
        }
    }
}
