//! The PowerCube's names: its parameters and flags as `params` and `flags`
//! list them, and the did-you-mean of a misspelled parameter or Config flag.

use axisctl::family::Family;
use axisctl::proto::powercube::{flags as cube_flags, table as cube_table};
use serde_json::{json, Value};

use crate::commands::names::{did_you_mean, FlagRow, Names};
use crate::commands::usage;

pub struct PowerCubeNames;

impl Names for PowerCubeNames {
    fn param_rows(&self, f: Family) -> Vec<Value> {
        cube_table::PARAMS
            .iter()
            .map(|p| {
                let access = match (p.access.readable(), p.access.writable()) {
                    (true, true) => "read-write",
                    (true, false) => "read",
                    (false, true) => "write",
                    (false, false) => "-",
                };
                json!({"family": f, "kind": "parameter", "name": p.name, "id": p.id, "type": p.ty.name(),
                       "unit": p.unit, "access": access, "range": null, "description": p.description})
            })
            .collect()
    }

    fn record_values(&self) -> Vec<&'static str> {
        cube_table::PARAMS.iter().map(|p| p.name).collect()
    }

    fn flag_rows(&self) -> Vec<FlagRow> {
        cube_flags::WORDS
            .iter()
            .flat_map(|w| {
                w.flags.iter().map(|d| FlagRow {
                    family: Family::PowerCube,
                    word: w.kind,
                    name: d.name,
                    short: d.short,
                    class: d.class.name(),
                    description: d.description,
                })
            })
            .collect()
    }
}

/// A PowerCube parameter name or id that the table does not know: refused
/// with the nearest names, before the link opens.
pub fn check_param(text: &str) -> anyhow::Result<()> {
    if cube_table::resolve_param(text).is_some() {
        return Ok(());
    }
    // "ActCur" for Cur: most measured values start with Act, so the prefix
    // is easily added to one that has none; spelling distance would offer
    // an unrelated Act* name (ActC0) instead.
    let unprefixed = text.get(..3).filter(|p| p.eq_ignore_ascii_case("act")).and_then(|_| text.get(3..));
    let hint = match unprefixed.and_then(cube_table::param_by_name) {
        Some(def) => format!(" (did you mean {}?)", def.name),
        None => did_you_mean(text, cube_table::PARAMS.iter().map(|p| p.name)),
    };
    Err(usage(format!("unknown parameter {text:?}{hint}; `axisctl params powercube` lists them")))
}

/// `+FLAG` / `-FLAG` of set-config whose FLAG the Config word does not know.
pub fn check_config_flag(change: &str) -> anyhow::Result<()> {
    let name = change.trim_start_matches(['+', '-']);
    if change.len() == name.len() || cube_flags::CONFIG.flag(name).is_some() {
        return Ok(()); // a change without a sign is the device layer's to refuse
    }
    let names = cube_flags::CONFIG.flags.iter().flat_map(|f| std::iter::once(f.name).chain(f.short));
    let hint = did_you_mean(name, names);
    Err(usage(format!("unknown Config flag {name:?}{hint}; `axisctl flags config` lists them")))
}
