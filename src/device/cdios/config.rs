//! The servo configuration (20h / 21h selectors 80h..): fields named
//! `group.key` (e.g. `speeds.maximum_speed`, `traject0.speed2`), each
//! range-checked with the table, each selector written whole.

use std::collections::BTreeMap;

use super::{check, Error, Node};
use crate::proto::cdios::table::{self, DecodedReply, Field};
use crate::proto::cdios::{Address, Command, ModuleId, ServoConfig, ServoPart};
use crate::proto::parse_int;

/// The groups, in the order they are shown.
pub const GROUPS: &[&str] = &["speeds", "voltage", "encoder", "control", "inputs", "traject0", "traject1"];

/// The group of a servo configuration part, e.g. `traject0` / `speeds`.
pub fn group_of(part: ServoPart) -> String {
    match part {
        ServoPart::TrajectEnd(t)
        | ServoPart::TrajectInitialSpeed(t)
        | ServoPart::TrajectChangePosition(t, _)
        | ServoPart::TrajectSpeed(t, _) => format!("traject{}", t.to_u8()),
        ServoPart::Speeds => "speeds".into(),
        ServoPart::Voltage => "voltage".into(),
        ServoPart::Encoder => "encoder".into(),
        ServoPart::Control => "control".into(),
        ServoPart::Inputs => "inputs".into(),
    }
}

/// The key of a field within its group: trajects number their steps.
pub fn key_of(part: ServoPart, field: &Field) -> String {
    match part {
        ServoPart::TrajectChangePosition(_, s) | ServoPart::TrajectSpeed(_, s) => {
            format!("{}{}", field.key, s.to_u8())
        }
        _ => field.key.to_string(),
    }
}

/// The set row of a part: its fields are the configurable ones.
pub fn set_row(part: ServoPart) -> &'static table::CommandDef {
    table::command_for(table::SERVO_CONFIGURATION, part.selector()).expect("every part has a set row")
}

/// Every configurable field: (part, field, `group.key` name).
pub fn fields() -> Vec<(ServoPart, &'static Field, String)> {
    let mut out = Vec::new();
    for part in ServoPart::all() {
        for f in set_row(part).value_fields() {
            out.push((part, f, format!("{}.{}", group_of(part), key_of(part, f))));
        }
    }
    out
}

fn norm(s: &str) -> String {
    s.trim().to_ascii_lowercase().replace('-', "_")
}

/// `maximum_speed` or `speeds.maximum_speed`; trajects need their group.
fn find_field(name: &str) -> Option<(ServoPart, &'static Field)> {
    let n = norm(name);
    fields()
        .into_iter()
        .find(|(part, _, full)| {
            *full == n || (!group_of(*part).starts_with("traject") && full.ends_with(&format!(".{n}")))
        })
        .map(|(p, f, _)| (p, f))
}

/// Field keys and new values of one part.
pub type Assignments = Vec<(&'static str, i64)>;

/// What a `config` request asks: groups to show, or changes by selector.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    Show(Vec<String>),
    Set(BTreeMap<u8, (ServoPart, Assignments)>),
}

impl Request {
    /// Group names, or `FIELD=VALUE` assignments (not both); every name is
    /// resolved and every value range-checked before anything is sent.
    pub fn parse(items: &[String]) -> Result<Self, Error> {
        let sets: Vec<&String> = items.iter().filter(|i| i.contains('=')).collect();
        if !sets.is_empty() && sets.len() != items.len() {
            return Err(Error::Refused("give either parts to show or FIELD=VALUE assignments, not both".into()));
        }
        if sets.is_empty() {
            if items.is_empty() {
                return Ok(Self::Show(GROUPS.iter().map(|g| g.to_string()).collect()));
            }
            let groups = items
                .iter()
                .map(|i| {
                    let g = norm(i);
                    if GROUPS.contains(&g.as_str()) {
                        Ok(g)
                    } else {
                        Err(Error::Refused(format!("unknown part {i:?}; parts: {}", GROUPS.join(", "))))
                    }
                })
                .collect::<Result<_, _>>()?;
            return Ok(Self::Show(groups));
        }
        let mut changes: BTreeMap<u8, (ServoPart, Assignments)> = BTreeMap::new();
        for a in sets {
            let (name, value) = a.split_once('=').expect("filtered on '='");
            let (part, field) = find_field(name).ok_or_else(|| {
                let names: Vec<String> = fields().into_iter().map(|(.., n)| n).collect();
                Error::Refused(format!("unknown configuration field {name:?}; fields: {}", names.join(", ")))
            })?;
            let v = parse_int(value).ok_or_else(|| Error::Refused(format!("{name}: {value:?} is not an integer")))?;
            field.check(v)?;
            changes.entry(part.selector()).or_insert((part, Vec::new())).1.push((field.key, v));
        }
        Ok(Self::Set(changes))
    }
}

impl Node {
    /// Reads the parts of the named groups, in table order.
    pub fn read_config(&mut self, m: ModuleId, groups: &[String]) -> Result<Vec<(ServoPart, DecodedReply)>, Error> {
        self.ready(m)?;
        let mut out = Vec::new();
        for part in ServoPart::all().into_iter().filter(|p| groups.contains(&group_of(*p))) {
            out.push((part, self.s.read(self.node, Address::Module(m), &Command::ReadServoConfig(part))?));
        }
        Ok(out)
    }

    /// Each selector is written whole: read it, change the named fields,
    /// check every write, then send them. Returns the groups changed.
    pub fn write_config(
        &mut self,
        m: ModuleId,
        changes: &BTreeMap<u8, (ServoPart, Assignments)>,
    ) -> Result<Vec<String>, Error> {
        self.ready(m)?;
        let mut writes = Vec::new();
        for (part, new) in changes.values() {
            let r = self.s.read(self.node, Address::Module(m), &Command::ReadServoConfig(*part))?;
            let cfg = ServoConfig::from_values(*part, |k| {
                new.iter().rev().find(|(nk, _)| *nk == k).map(|(_, v)| *v).or_else(|| r.get(k))
            })
            .map_err(|reason| Error::ConfigRejected { group: group_of(*part), reason })?;
            writes.push(Command::SetServoConfig(cfg));
        }
        check(&writes, m)?;
        self.send(m, &writes)?;
        let mut groups: Vec<String> = changes.values().map(|(p, _)| group_of(*p)).collect();
        groups.dedup();
        Ok(groups)
    }
}
