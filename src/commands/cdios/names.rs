//! The Cdios names: its configuration fields and status flags as `params`
//! and `flags` list them, and the did-you-mean of a misspelled item.

use axisctl::device::cdios::config as servo;
use axisctl::family::Family;
use axisctl::proto::cdios::table as cdios_table;
use serde_json::{json, Value};

use crate::commands::names::{did_you_mean, range, FlagRow, Names};
use crate::commands::usage;

pub struct CdiosNames;

impl Names for CdiosNames {
    fn param_rows(&self, f: Family) -> Vec<Value> {
        servo::fields()
            .into_iter()
            .map(|(_, field, name)| {
                json!({"family": f, "kind": "config-field", "name": name, "id": null, "type": "int",
                       "unit": field.unit, "access": "read-write",
                       "range": range(Some(field.min), Some(field.max)), "description": field.description})
            })
            .collect()
    }

    fn record_values(&self) -> Vec<&'static str> {
        axisctl::record::cdios::CdiosValue::ALL.into_iter().map(axisctl::record::cdios::CdiosValue::name).collect()
    }

    fn flag_rows(&self) -> Vec<FlagRow> {
        cdios_table::STATUS_FLAGS
            .iter()
            .map(|d| FlagRow {
                family: Family::Cdios,
                word: "cdios-status",
                name: d.name,
                short: None,
                class: d.class.name(),
                description: d.meaning,
            })
            .collect()
    }
}

/// A Cdios configuration item (`PART` or `FIELD=VALUE`) that names no part
/// or field.
pub fn check_config_item(item: &str) -> anyhow::Result<()> {
    let norm = |s: &str| s.trim().to_ascii_lowercase().replace('-', "_");
    let fields = servo::fields();
    let full: Vec<String> = fields.iter().map(|(.., n)| n.clone()).collect();
    // Fields outside the trajects may be named without their group.
    let short: Vec<String> = full
        .iter()
        .filter(|n| !n.starts_with("traject"))
        .filter_map(|n| n.split_once('.').map(|(_, k)| k.to_string()))
        .collect();
    match item.split_once('=') {
        Some((name, _)) => {
            let n = norm(name);
            if full.contains(&n) || short.contains(&n) {
                return Ok(());
            }
            let hint = did_you_mean(&n, full.iter().chain(&short).map(String::as_str));
            Err(usage(format!("unknown configuration field {name:?}{hint}; `axisctl params cdios` lists them")))
        }
        None => {
            let groups: Vec<String> =
                full.iter().filter_map(|n| n.split_once('.')).map(|(g, _)| g.to_string()).collect();
            if groups.contains(&norm(item)) {
                return Ok(());
            }
            let hint = did_you_mean(&norm(item), groups.iter().map(String::as_str));
            Err(usage(format!("unknown part {item:?}{hint}; parts: {}", dedup(groups).join(", "))))
        }
    }
}

fn dedup(mut v: Vec<String>) -> Vec<String> {
    v.dedup();
    v
}
