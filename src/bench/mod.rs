//! The bench: every link a command may use and the families on each, from
//! `--link` (given once or several times) or a bench file (`--bench FILE`,
//! `AXISCTL_BENCH`, `axisctl.toml`). A per-family command asks the bench
//! which link carries its family; a whole-bench command (`scan`,
//! `halt --all`) goes over every link and every family on it.
//!
//! It only says where things are: opening is [`crate::open`]'s, which opens
//! each port once and shares a CAN port among the families on it.

mod file;

/// The one device address, here too because a bench names its devices by it.
pub use crate::address;

use std::collections::BTreeMap;
use std::path::Path;

pub use crate::address::{Address, AddressError, DeviceRef};
pub use file::FileError;

use crate::family::Family;
use crate::link::{LinkSpec, SpecError};

/// One link of the bench.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BenchLink {
    pub spec: LinkSpec,
    /// The spec as written, for messages and the JSON envelope.
    pub text: String,
    /// The families on it, in the registry's order.
    pub families: Vec<Family>,
    /// The devices the bench file expects on it, by name.
    pub devices: BTreeMap<String, Address>,
}

impl BenchLink {
    /// A link with the families its kind carries by default.
    pub fn new(text: &str, spec: LinkSpec) -> Self {
        let families = default_families(&spec);
        Self { spec, text: text.to_string(), families, devices: BTreeMap::new() }
    }

    pub fn carries(&self, family: Family) -> bool {
        self.families.contains(&family)
    }

    /// `slcan:/dev/ttyACM0 (powercube, cdios)`.
    pub fn describe(&self) -> String {
        let names: Vec<_> = self.families.iter().map(|f| f.name()).collect();
        format!("{} ({})", self.text, names.join(", "))
    }
}

/// The families a link carries unless the bench file says: `sim` is the
/// whole simulated bench, a CAN link the CAN families, a serial line the
/// families whose own port is RS232 only (a PowerCube on RS232 is said with
/// `families = ["powercube"]`).
pub fn default_families(spec: &LinkSpec) -> Vec<Family> {
    Family::ALL
        .into_iter()
        .filter(|f| match spec {
            LinkSpec::Sim(_) => true,
            _ if spec.is_can() => f.link_kind().can(),
            _ => f.link_kind().rs232() && !f.link_kind().can(),
        })
        .collect()
}

/// The physical port behind a spec: a tty whatever is spoken over it
/// (`slcan:` or `serial:`, any options, through a symlink), a CAN interface,
/// or the in-process bench. Two links of a bench never share one.
pub fn port(spec: &LinkSpec) -> String {
    match spec {
        LinkSpec::SocketCan { iface } => format!("socketcan:{iface}"),
        // One bus of one daemon, whatever round trip each link allows for.
        LinkSpec::Socketcand { host, port, bus, .. } => format!("socketcand:{host}:{port}/{bus}"),
        LinkSpec::Slcan { path, .. } | LinkSpec::Serial { path, .. } => crate::link::lock::canonical(path),
        LinkSpec::Sim(_) => "sim".into(),
    }
}

/// Whether `family` can be reached over `spec` at all.
pub fn fits(spec: &LinkSpec, family: Family) -> bool {
    match spec {
        LinkSpec::Sim(_) => true,
        _ if spec.is_can() => family.link_kind().can(),
        _ => family.link_kind().rs232(),
    }
}

/// The links of a command.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Bench {
    links: Vec<BenchLink>,
    /// One `--link` (no bench file): every command takes that link, as it
    /// always did, and the opener says when it does not fit the family.
    single: bool,
    /// Where the links came from, for messages: `--link`, `AXISCTL_LINK`,
    /// or the bench file's path.
    source: String,
}

/// Why the links of a bench could not be settled.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BenchError {
    #[error("{origin}: {error}")]
    Spec { origin: String, error: SpecError },
    #[error("{origin}: {text} is given twice (each port is opened once)")]
    Duplicate { origin: String, text: String },
    #[error("{origin}: no link given")]
    Empty { origin: String },
    #[error(transparent)]
    File(#[from] FileError),
    #[error("no link of the bench carries the {family}: {links}")]
    NoLink { family: Family, links: String },
    #[error("this command takes one link; the bench has {count}: {links}")]
    NotOne { count: usize, links: String },
    #[error("{name:?} is not a device of the bench (its names: {names})")]
    UnknownName { name: String, names: String },
}

impl BenchError {
    /// Every error here is about what the user wrote: nothing was opened.
    pub fn is_usage(&self) -> bool {
        true
    }
}

impl Bench {
    /// The links given with `--link` (or `AXISCTL_LINK`), each a spec;
    /// `source` names where they came from.
    pub fn from_specs<'a>(texts: impl IntoIterator<Item = &'a str>, source: &str) -> Result<Self, BenchError> {
        let mut links: Vec<BenchLink> = Vec::new();
        for text in texts {
            let spec: LinkSpec =
                text.parse().map_err(|error| BenchError::Spec { origin: source.to_string(), error })?;
            if links.iter().any(|l| port(&l.spec) == port(&spec)) {
                return Err(BenchError::Duplicate { origin: source.to_string(), text: text.to_string() });
            }
            links.push(BenchLink::new(text, spec));
        }
        if links.is_empty() {
            return Err(BenchError::Empty { origin: source.to_string() });
        }
        let single = links.len() == 1;
        Ok(Self { links, single, source: source.to_string() })
    }

    /// The links a bench file names.
    pub fn from_file(path: &Path) -> Result<Self, BenchError> {
        let links = file::read(path)?;
        Ok(Self { links, single: false, source: path.display().to_string() })
    }

    /// A bench file's text, `path` naming it in errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, BenchError> {
        let links = file::parse(text, path)?;
        Ok(Self { links, single: false, source: path.display().to_string() })
    }

    pub fn links(&self) -> &[BenchLink] {
        &self.links
    }

    /// The one `--link` of old: the commands that go over the whole bench
    /// (`scan`, `halt --all`) stay the PowerCube commands they were.
    pub fn is_single(&self) -> bool {
        self.single
    }

    /// `--link`, `AXISCTL_LINK` or the bench file's path.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Every link, described, for messages.
    pub fn describe(&self) -> String {
        self.links.iter().map(BenchLink::describe).collect::<Vec<_>>().join(", ")
    }

    /// The link a command of `family` uses: the first that carries it; with
    /// a single `--link`, that link whatever it is (the opener then says if
    /// the family cannot be reached over it).
    pub fn link_for(&self, family: Family) -> Result<&BenchLink, BenchError> {
        if self.single {
            return Ok(&self.links[0]);
        }
        self.links
            .iter()
            .find(|l| l.carries(family))
            .ok_or_else(|| BenchError::NoLink { family, links: self.describe() })
    }

    /// The one link of a command that works on a link rather than a family
    /// (`monitor`, `sim --tap`).
    pub fn only_link(&self) -> Result<&BenchLink, BenchError> {
        match self.links.as_slice() {
            [one] => Ok(one),
            more => Err(BenchError::NotOne { count: more.len(), links: self.describe() }),
        }
    }

    /// Every (link, family) pair, link by link: what a whole-bench command visits.
    pub fn pairs(&self) -> impl Iterator<Item = (&BenchLink, Family)> {
        self.links.iter().flat_map(|l| l.families.iter().map(move |f| (l, *f)))
    }

    /// The link a device is reached on: the one the bench file names it
    /// on, else the one carrying its family.
    pub fn link_of(&self, at: Address) -> Result<&BenchLink, BenchError> {
        let named = self.links.iter().find(|l| l.carries(at.family()) && l.devices.values().any(|a| *a == at));
        named.map_or_else(|| self.link_for(at.family()), Ok)
    }

    /// The name the bench file gives `address`, if any.
    pub fn name_of(&self, address: Address) -> Option<&str> {
        self.links.iter().flat_map(|l| &l.devices).find(|(_, a)| **a == address).map(|(n, _)| n.as_str())
    }

    /// An address as written, or the device a name stands for.
    pub fn resolve(&self, device: &DeviceRef) -> Result<Address, BenchError> {
        match device {
            DeviceRef::Address(a) => Ok(*a),
            DeviceRef::Name(name) => {
                let mut all = self.links.iter().flat_map(|l| &l.devices);
                all.clone().find(|(n, _)| *n == name).map(|(_, a)| *a).ok_or_else(|| BenchError::UnknownName {
                    name: name.clone(),
                    names: {
                        let names: Vec<_> = all.by_ref().map(|(n, _)| n.as_str()).collect();
                        if names.is_empty() {
                            "none".into()
                        } else {
                            names.join(", ")
                        }
                    },
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn specs(texts: &[&str]) -> Result<Bench, BenchError> {
        Bench::from_specs(texts.iter().copied(), "--link")
    }

    #[test]
    fn each_link_kind_carries_its_families() {
        let fams = |s: &str| default_families(&s.parse().unwrap());
        assert_eq!(fams("sim"), Family::ALL.to_vec());
        assert_eq!(fams("slcan:/dev/ttyACM0"), vec![Family::PowerCube, Family::Cdios]);
        assert_eq!(fams("socketcan:can0"), vec![Family::PowerCube, Family::Cdios]);
        assert_eq!(fams("serial:/dev/ttyUSB0"), vec![Family::Pac]);
    }

    #[test]
    fn a_family_uses_the_link_that_carries_it() {
        let b = specs(&["slcan:/dev/a", "serial:/dev/b"]).unwrap();
        assert_eq!(b.link_for(Family::Pac).unwrap().text, "serial:/dev/b");
        assert_eq!(b.link_for(Family::Cdios).unwrap().text, "slcan:/dev/a");
        assert_eq!(b.link_for(Family::PowerCube).unwrap().text, "slcan:/dev/a");
        assert_eq!(b.pairs().count(), 3);
        let b = specs(&["slcan:/dev/a", "socketcan:can0"]).unwrap();
        assert_eq!(
            b.link_for(Family::Pac).unwrap_err().to_string(),
            "no link of the bench carries the PA-CONTROL: slcan:/dev/a (powercube, cdios), socketcan:can0 (powercube, cdios)"
        );
        assert!(b.only_link().unwrap_err().to_string().starts_with("this command takes one link; the bench has 2: "));
    }

    /// One `--link` is what it always was: every family command takes it.
    #[test]
    fn a_single_link_serves_every_family() {
        let b = specs(&["serial:/dev/ttyUSB0"]).unwrap();
        assert_eq!(b.link_for(Family::PowerCube).unwrap().text, "serial:/dev/ttyUSB0");
        assert_eq!(b.link_for(Family::Cdios).unwrap().text, "serial:/dev/ttyUSB0");
    }

    #[test]
    fn bad_lists_are_refused() {
        assert_eq!(
            specs(&["slcan:/dev/a", "slcan:/dev/a"]).unwrap_err().to_string(),
            "--link: slcan:/dev/a is given twice (each port is opened once)"
        );
        assert_eq!(specs(&[]).unwrap_err().to_string(), "--link: no link given");
        assert!(specs(&["bogus:x"]).unwrap_err().to_string().starts_with("--link: bad link"));
        // One port, whatever is spoken over it or however it is spelt.
        let dir = tempfile::tempdir().unwrap();
        let tty = dir.path().join("ttyACM0");
        std::fs::write(&tty, "").unwrap();
        let alias = dir.path().join("by-id");
        std::os::unix::fs::symlink(&tty, &alias).unwrap();
        let (tty, alias) = (tty.to_str().unwrap(), alias.to_str().unwrap());
        for other in [format!("slcan:{tty}?bitrate=500000"), format!("serial:{tty}"), format!("slcan:{alias}")] {
            let e = specs(&[&format!("slcan:{tty}"), &other]).unwrap_err();
            assert_eq!(e.to_string(), format!("--link: {other} is given twice (each port is opened once)"));
        }
    }
}
