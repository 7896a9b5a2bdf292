//! The PA-CONTROL's names: its system and axis parameters and the fields of
//! its PROFIBUS words as `params` and `flags` list them.

use axisctl::family::Family;
use axisctl::proto::pac::{profibus, table as pac_table};
use serde_json::{json, Value};

use crate::commands::names::{range, FlagRow, Names};

pub struct PacNames;

impl Names for PacNames {
    fn param_rows(&self, f: Family) -> Vec<Value> {
        let system = pac_table::SYSTEM_PARAMS.iter().filter(|p| !p.unused).map(|p| {
            json!({"family": f, "kind": "system-parameter", "name": p.name, "id": p.number,
                   "type": "int", "unit": "", "access": "read-write",
                   "range": range(p.min, p.max), "description": p.meaning})
        });
        let axis = pac_table::AXIS_PARAMS.iter().filter(|p| !p.unused).map(|p| {
            json!({"family": f, "kind": "axis-parameter", "name": p.name, "id": p.number,
                   "type": "float", "unit": p.unit, "access": "read-write",
                   "range": range(p.min, p.max), "description": p.manual_name})
        });
        system.chain(axis).collect()
    }

    fn record_values(&self) -> Vec<&'static str> {
        axisctl::record::pac::PacValue::ALL.into_iter().map(axisctl::record::pac::PacValue::name).collect()
    }

    fn flag_rows(&self) -> Vec<FlagRow> {
        profibus::WORDS
            .iter()
            .flat_map(|w| {
                w.fields.iter().map(|d| FlagRow {
                    family: Family::Pac,
                    word: w.kind,
                    name: d.name,
                    short: None,
                    class: "field",
                    description: d.description,
                })
            })
            .collect()
    }
}
