//! Backup, diff and restore of a bench: one JSON document
//! (`axisctl-backup/1`) holding each device's identity and every setting
//! that can be written back, a diff engine over two such documents (a file
//! and the live bench read into the same shape, or two files), and per
//! family the checks and the write order of a restore.
//!
//! Every read and write goes through the device layer (`device::powercube`,
//! ...): its access, type and limit checks decide what may be sent. This
//! module only decides which settings a backup holds, the order in which a
//! restore writes them, and how a read-back value is reported.

pub mod cdios;
mod diff;
mod keys;
pub mod pac;
pub mod powercube;

#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};

use serde::{Deserialize, Serialize};

use crate::family::Family;
use crate::session::ErrorKind;

pub use diff::{diff, same_value, DeviceDiff, Difference};

/// The schema name and version this axisctl writes and reads.
pub const SCHEMA: &str = "axisctl-backup/1";
const SCHEMA_PREFIX: &str = "axisctl-backup/";
const SCHEMA_VERSION: u32 = 1;

/// A backup of a bench: what `axisctl backup` writes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Document {
    /// `axisctl-backup/1`: a reader refuses a newer version.
    pub schema: String,
    /// The axisctl that wrote it, for the reader's information.
    #[serde(default)]
    pub created_by: String,
    /// The link the devices were read on, as given.
    #[serde(default)]
    pub link: String,
    pub devices: Vec<Device>,
}

/// One device: the contract's envelope (family, link, address), its
/// identity and its settings by name.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Device {
    #[serde(with = "family_name")]
    pub family: Family,
    #[serde(default)]
    pub link: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub module: Option<u8>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axis: Option<u8>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub node: Option<u8>,
    /// What tells this device from another of its family: serial number,
    /// firmware version, type. Compared by a restore, never written.
    #[serde(default)]
    pub identity: BTreeMap<String, serde_json::Value>,
    #[serde(default)]
    pub settings: BTreeMap<String, Setting>,
}

/// One setting: a value with its unit. `restore` is false for a value kept
/// for information only (read-only, or a mirror of another setting): a
/// restore never writes it and a diff does not compare it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Setting {
    /// The protocol table's id, where the family numbers its parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub id: Option<u32>,
    /// The wire type, where the family's table gives one.
    #[serde(rename = "type", default, skip_serializing_if = "Option::is_none")]
    pub ty: Option<String>,
    #[serde(default)]
    pub unit: String,
    pub value: serde_json::Value,
    pub restore: bool,
}

impl Setting {
    pub fn new(value: serde_json::Value, unit: &str, restore: bool) -> Self {
        Self { id: None, ty: None, unit: unit.into(), value, restore }
    }
}

mod family_name {
    use crate::family::Family;

    pub fn serialize<S: serde::Serializer>(f: &Family, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(f.name())
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Family, D::Error> {
        let text = <String as serde::Deserialize>::deserialize(d)?;
        text.parse().map_err(|_| serde::de::Error::custom(format!("unknown family {text:?}")))
    }
}

/// Where a device is, in its family's one form (the envelope's address).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Address {
    pub family: Family,
    pub module: Option<u8>,
    pub axis: Option<u8>,
    pub node: Option<u8>,
}

/// The one device address in the backup's envelope form. The backup's
/// own form stays while a file may hold ids no device has (a module 40, no
/// module at all): a restore or diff names them as written.
impl From<crate::address::Address> for Address {
    fn from(a: crate::address::Address) -> Self {
        use crate::address::Address as One;
        let none = Self { family: a.family(), module: None, axis: None, node: None };
        match a {
            One::PowerCube { module } => Self { module: Some(module), ..none },
            One::Pac { axis } => Self { axis, ..none },
            One::Cdios { node, module } => Self { module: Some(module), node: Some(node), ..none },
        }
    }
}

impl std::fmt::Display for Address {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.family.name())?;
        if let Some(n) = self.node {
            write!(f, " node {n}")?;
        }
        if let Some(m) = self.module {
            write!(f, " module {m}")?;
        }
        if let Some(a) = self.axis {
            write!(f, " axis {a}")?;
        }
        Ok(())
    }
}

impl Device {
    pub fn new(family: Family, link: &str) -> Self {
        Self {
            family,
            link: link.into(),
            module: None,
            axis: None,
            node: None,
            identity: BTreeMap::new(),
            settings: BTreeMap::new(),
        }
    }

    pub fn address(&self) -> Address {
        Address { family: self.family, module: self.module, axis: self.axis, node: self.node }
    }

    /// The settings a restore writes.
    pub fn restorable(&self) -> impl Iterator<Item = (&String, &Setting)> {
        self.settings.iter().filter(|(_, s)| s.restore)
    }
}

/// Why a file is no backup this axisctl can read. Nothing was sent.
#[derive(Debug, thiserror::Error)]
pub enum ParseError {
    #[error("{0} is not JSON: {1}")]
    NotJson(String, String),
    #[error("{0} is no axisctl backup: {1}")]
    NotBackup(String, String),
    #[error("{0} is ambiguous: {1}; nothing was sent")]
    DuplicateKey(String, String),
    #[error("{0} was written by a newer axisctl (schema {1:?}; this one reads {SCHEMA}); nothing was sent")]
    Newer(String, String),
}

impl ParseError {
    pub fn kind(&self) -> ErrorKind {
        ErrorKind::Usage
    }
}

/// Reads a backup document; `name` names it in messages. The schema field
/// is checked before the rest, so that a newer document is reported as
/// such rather than as a shape error.
pub fn parse(name: &str, text: &str) -> Result<Document, ParseError> {
    let value: serde_json::Value =
        serde_json::from_str(text).map_err(|e| ParseError::NotJson(name.into(), e.to_string()))?;
    serde_json::from_str::<keys::UniqueKeys>(text).map_err(|e| ParseError::DuplicateKey(name.into(), e.to_string()))?;
    let schema = value
        .get("schema")
        .and_then(serde_json::Value::as_str)
        .ok_or_else(|| ParseError::NotBackup(name.into(), format!("no \"schema\": {SCHEMA:?} field")))?;
    let version = schema
        .strip_prefix(SCHEMA_PREFIX)
        .and_then(|v| v.parse::<u32>().ok())
        .ok_or_else(|| ParseError::NotBackup(name.into(), format!("schema {schema:?} is not {SCHEMA:?}")))?;
    if version > SCHEMA_VERSION {
        return Err(ParseError::Newer(name.into(), schema.into()));
    }
    let doc: Document = serde_json::from_value(value).map_err(|e| ParseError::NotBackup(name.into(), e.to_string()))?;
    // A device is its address on its link: two links of a bench may each have a module 3.
    let mut seen = std::collections::BTreeSet::new();
    if let Some(d) = doc.devices.iter().find(|d| !seen.insert((d.link.as_str(), d.address()))) {
        let on = if d.link.is_empty() { String::new() } else { format!(" on {}", d.link) };
        return Err(ParseError::NotBackup(name.into(), format!("{}{on} is in it twice", d.address())));
    }
    Ok(doc)
}

/// A value of the file that must not be written: listed before anything
/// is sent.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Problem {
    #[serde(skip)]
    pub device: Address,
    pub name: String,
    pub message: String,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}: {}", self.device, self.name, self.message)
    }
}

/// What happened to one value of a restore.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Outcome {
    /// Written, and read back as written.
    Written,
    /// The device holds the file's value already: nothing sent.
    Unchanged,
    /// Not written: invalid and `--skip-invalid`.
    Skipped,
    /// Written, but the device holds another value (it limited it).
    Clamped,
    /// The write or its read-back failed.
    Failed,
    /// Not written: the restore stopped before it (a signal, a lost link,
    /// a device that refused), so the device holds what it held.
    NotWritten,
}

impl Outcome {
    pub const ALL: [Self; 6] =
        [Self::Written, Self::Unchanged, Self::Skipped, Self::Clamped, Self::Failed, Self::NotWritten];

    pub fn name(self) -> &'static str {
        match self {
            Self::Written => "written",
            Self::Unchanged => "unchanged",
            Self::Skipped => "skipped",
            Self::Clamped => "clamped",
            Self::Failed => "failed",
            Self::NotWritten => "not_written",
        }
    }
}

/// One value of a restore: what the file wants, what the device held
/// before and holds after, and the outcome.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ValueResult {
    pub name: String,
    pub unit: String,
    pub wanted: serde_json::Value,
    pub before: serde_json::Value,
    pub after: serde_json::Value,
    pub outcome: Outcome,
    /// Why it was skipped or failed.
    pub message: Option<String>,
    /// The exit-code class of a failure.
    #[serde(skip)]
    pub kind: Option<ErrorKind>,
}

impl ValueResult {
    fn new(name: &str, unit: &str, wanted: &serde_json::Value, before: &serde_json::Value) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            wanted: wanted.clone(),
            before: before.clone(),
            after: before.clone(),
            outcome: Outcome::Unchanged,
            message: None,
            kind: None,
        }
    }

    /// The file's setting against the live device's value, before any write.
    fn against(name: &str, s: &Setting, live: &Device) -> Self {
        let before = live.settings.get(name).map_or(serde_json::Value::Null, |l| l.value.clone());
        Self::new(name, &s.unit, &s.value, &before)
    }

    fn skipped(mut self, why: &str) -> Self {
        self.outcome = Outcome::Skipped;
        self.message = Some(why.into());
        self
    }

    fn failed(mut self, e: &dyn std::fmt::Display, kind: ErrorKind) -> Self {
        self.outcome = Outcome::Failed;
        self.message = Some(e.to_string());
        self.kind = Some(kind);
        self
    }

    pub(crate) fn not_written(mut self, why: &str) -> Self {
        self.outcome = Outcome::NotWritten;
        self.message = Some(why.into());
        self
    }

    /// Written and read back as `after`: clamped when the device holds
    /// another value than the file's.
    fn read_back(mut self, after: serde_json::Value) -> Self {
        self.outcome = if same_value(&self.wanted, &after) { Outcome::Written } else { Outcome::Clamped };
        self.after = after;
        self
    }
}

/// What a restore does with one setting before any write: nothing for a
/// setting kept for information, a finished result for one skipped as
/// invalid or already holding the file's value, else the setting to write
/// with its result so far. Every family decides it the same way.
pub(crate) enum Step<'a> {
    Done(ValueResult),
    Write(&'a Setting, ValueResult),
}

pub(crate) fn step<'a>(file: &'a Device, live: &Device, name: &str, skip: &BTreeSet<String>) -> Option<Step<'a>> {
    let s = file.settings.get(name).filter(|s| s.restore)?;
    let r = ValueResult::against(name, s, live);
    Some(if skip.contains(name) {
        Step::Done(r.skipped("invalid (see the problems); not written"))
    } else if same_value(&s.value, &r.before) {
        Step::Done(r)
    } else {
        Step::Write(s, r)
    })
}

/// Asked before each write of a restore: why it must stop now (a signal),
/// or `None` to go on. The values it did not reach are reported as
/// [`Outcome::NotWritten`] with the reason.
pub type Stop<'a> = &'a dyn Fn() -> Option<String>;

/// The result of a value that a stopped restore did not reach: unchanged
/// when the device held the file's value already, skipped when invalid,
/// else not written, for `why`.
pub(crate) fn not_reached(
    file: &Device,
    live: &Device,
    name: &str,
    skip: &BTreeSet<String>,
    why: &str,
) -> Option<ValueResult> {
    step(file, live, name, skip).map(|s| match s {
        Step::Done(r) => r,
        Step::Write(_, r) => r.not_written(why),
    })
}

/// The reason to stop, once `stop` gave one: kept, so that every later
/// value is not written for the same reason.
pub(crate) fn stopping(stopped: &mut Option<String>, stop: Stop<'_>) -> Option<String> {
    if stopped.is_none() {
        *stopped = stop();
    }
    stopped.clone()
}

/// The results of a device that a restore did not write at all (it stopped
/// before this device, or the device refused it), in the file's order of
/// names: each value unchanged, skipped or not written.
pub fn not_written(file: &Device, live: &Device, skip: &BTreeSet<String>, why: &str) -> Vec<ValueResult> {
    file.restorable().filter_map(|(name, _)| not_reached(file, live, name, skip, why)).collect()
}

/// What the file alone shows wrong with a device's settings, by its
/// family's rules; a restore refuses them before the link opens.
pub fn check_file(dev: &Device) -> Vec<Problem> {
    match dev.family {
        Family::PowerCube => powercube::check_file(dev),
        Family::Pac => pac::check_file(dev),
        Family::Cdios => cdios::check_file(dev),
    }
}

/// The identity keys a restore compares.
pub fn identity_keys(f: Family) -> &'static [&'static str] {
    match f {
        Family::PowerCube => &powercube::IDENTITY,
        Family::Pac => &pac::IDENTITY,
        Family::Cdios => &cdios::IDENTITY,
    }
}

/// The file's device's identity against the live device's: the keys that
/// differ (a restore refuses them unless told which device to write to).
pub fn identity_mismatch(file: &Device, live: &Device, keys: &[&str]) -> Vec<String> {
    keys.iter()
        .filter(|k| file.identity.get(**k).is_some_and(|v| live.identity.get(**k).is_none_or(|l| !same_value(v, l))))
        .map(|k| {
            format!(
                "{k} {} in the file, {} on the device",
                file.identity[*k],
                live.identity.get(*k).map_or("none".to_string(), ToString::to_string)
            )
        })
        .collect()
}

/// A restore that could not write every value (or refused to start): the
/// exit-code class of the first failure, and what failed.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct Failed {
    pub kind: ErrorKind,
    pub message: String,
}

/// The counts of a restore's outcomes, in [`Outcome::ALL`] order.
pub fn summary<'a>(results: impl IntoIterator<Item = &'a ValueResult>) -> [(Outcome, usize); 6] {
    let mut out = Outcome::ALL.map(|o| (o, 0));
    for r in results {
        if let Some(slot) = out.iter_mut().find(|(o, _)| *o == r.outcome) {
            slot.1 += 1;
        }
    }
    out
}
