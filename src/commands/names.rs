//! `axisctl params [FAMILY]` and `axisctl flags [WORD]`: the names the
//! commands accept, listed offline from the protocol tables; and the
//! did-you-mean of a misspelled one, checked before anything opens.

use axisctl::device::cdios::config as servo;
use axisctl::family::Family;
use axisctl::proto::cdios::table as cdios_table;
use axisctl::proto::pac::{profibus, table as pac_table};
use axisctl::proto::powercube::{flags as cube_flags, table as cube_table};
use serde_json::{json, Value};

use super::{usage, Ctx};
use crate::cli::suggest::closest;
use crate::output;

/// " (did you mean X?)" for the names nearest `typed`, or "".
pub fn did_you_mean<'a>(typed: &str, names: impl IntoIterator<Item = &'a str>) -> String {
    match closest(typed, names)[..] {
        [] => String::new(),
        [one] => format!(" (did you mean {one}?)"),
        ref many => format!(" (did you mean one of {}?)", many.join(", ")),
    }
}

/// A range as said to people: "0 to 10000"; `None` when the table has none.
pub fn range<T: std::fmt::Display>(min: Option<T>, max: Option<T>) -> Option<String> {
    match (min, max) {
        (Some(lo), Some(hi)) => Some(format!("{lo} to {hi}")),
        (Some(lo), None) => Some(format!("from {lo}")),
        (None, Some(hi)) => Some(format!("up to {hi}")),
        (None, None) => None,
    }
}

/// A PowerCube parameter name or id that the table does not know: refused
/// with the nearest names, before the link opens.
pub fn check_powercube_param(text: &str) -> anyhow::Result<()> {
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

/// A Cdios configuration item (`PART` or `FIELD=VALUE`) that names no part
/// or field.
pub fn check_cdios_config_item(item: &str) -> anyhow::Result<()> {
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

/// `axisctl params [FAMILY]`.
/// Table rows grouped by family (`{"powercube": [...], ...}`): the key
/// `family` belongs to the envelope of a device document, and a row of a
/// table is not one.
fn by_family(rows: &[Value]) -> Value {
    let mut out = serde_json::Map::new();
    for row in rows {
        let mut row = row.clone();
        let Some(obj) = row.as_object_mut() else { continue };
        let family = obj.remove("family").and_then(|f| f.as_str().map(str::to_string)).unwrap_or_default();
        if let Some(list) = out.entry(family).or_insert_with(|| Value::Array(Vec::new())).as_array_mut() {
            list.push(row);
        }
    }
    Value::Object(out)
}

pub fn params(ctx: &Ctx, family: Option<Family>) -> anyhow::Result<()> {
    let families = family.map_or_else(|| Family::ALL.to_vec(), |f| vec![f]);
    let mut rows: Vec<Value> = Vec::new();
    for f in families {
        match f {
            Family::PowerCube => rows.extend(cube_table::PARAMS.iter().map(|p| {
                let access = match (p.access.readable(), p.access.writable()) {
                    (true, true) => "read-write",
                    (true, false) => "read",
                    (false, true) => "write",
                    (false, false) => "-",
                };
                json!({"family": f, "kind": "parameter", "name": p.name, "id": p.id, "type": p.ty.name(),
                       "unit": p.unit, "access": access, "range": null, "description": p.description})
            })),
            Family::Pac => {
                rows.extend(pac_table::SYSTEM_PARAMS.iter().filter(|p| !p.unused).map(|p| {
                    json!({"family": f, "kind": "system-parameter", "name": p.name, "id": p.number,
                           "type": "int", "unit": "", "access": "read-write",
                           "range": range(p.min, p.max), "description": p.meaning})
                }));
                rows.extend(pac_table::AXIS_PARAMS.iter().filter(|p| !p.unused).map(|p| {
                    json!({"family": f, "kind": "axis-parameter", "name": p.name, "id": p.number,
                           "type": "float", "unit": p.unit, "access": "read-write",
                           "range": range(p.min, p.max), "description": p.manual_name})
                }));
            }
            Family::Cdios => rows.extend(servo::fields().into_iter().map(|(_, field, name)| {
                json!({"family": f, "kind": "config-field", "name": name, "id": null, "type": "int",
                       "unit": field.unit, "access": "read-write",
                       "range": range(Some(field.min), Some(field.max)), "description": field.description})
            })),
        }
    }
    if ctx.json {
        output::json(&json!({ "parameters": by_family(&rows) }));
        return Ok(());
    }
    let text = |v: &Value| match v {
        Value::String(s) => s.clone(),
        Value::Null => "-".into(),
        other => other.to_string(),
    };
    let mut table = vec![["family", "kind", "name", "id", "unit", "range", "description"].map(String::from).to_vec()];
    for r in &rows {
        let family = Family::ALL.into_iter().find(|f| json!(f) == r["family"]).map_or("?", |f| f.name());
        let unit = if r["unit"] == "" { "-".into() } else { text(&r["unit"]) };
        table.push(vec![
            family.into(),
            text(&r["kind"]),
            text(&r["name"]),
            text(&r["id"]),
            unit,
            text(&r["range"]),
            text(&r["description"]),
        ]);
    }
    output::table(&table, ctx.style);
    Ok(())
}

/// One flag or bit field of a status word, whatever the family.
struct FlagRow {
    family: Family,
    word: &'static str,
    name: &'static str,
    short: Option<&'static str>,
    class: &'static str,
    description: &'static str,
}

fn every_flag() -> Vec<FlagRow> {
    let mut out = Vec::new();
    for w in cube_flags::WORDS {
        out.extend(w.flags.iter().map(|d| FlagRow {
            family: Family::PowerCube,
            word: w.kind,
            name: d.name,
            short: d.short,
            class: d.class.name(),
            description: d.description,
        }));
    }
    for w in profibus::WORDS {
        out.extend(w.fields.iter().map(|d| FlagRow {
            family: Family::Pac,
            word: w.kind,
            name: d.name,
            short: None,
            class: "field",
            description: d.description,
        }));
    }
    out.extend(cdios_table::STATUS_FLAGS.iter().map(|d| FlagRow {
        family: Family::Cdios,
        word: "cdios-status",
        name: d.name,
        short: None,
        class: d.class.name(),
        description: d.meaning,
    }));
    out
}

/// `axisctl flags [WORD]`: WORD is a `decode` kind (every flag of that
/// word) or part of a flag name (`brake`).
pub fn flags(ctx: &Ctx, word: Option<&str>) -> anyhow::Result<()> {
    let all = every_flag();
    let rows: Vec<&FlagRow> = match word {
        None => all.iter().collect(),
        Some(w) if all.iter().any(|r| r.word.eq_ignore_ascii_case(w)) => {
            all.iter().filter(|r| r.word.eq_ignore_ascii_case(w)).collect()
        }
        Some(w) => {
            let w = w.to_ascii_lowercase().replace('_', "-");
            let hit = |s: &str| s.to_ascii_lowercase().replace('_', "-").contains(&w);
            all.iter().filter(|r| hit(r.name) || r.short.is_some_and(hit)).collect()
        }
    };
    if rows.is_empty() {
        let typed = word.unwrap_or_default();
        let words = all.iter().map(|r| r.word).chain(all.iter().map(|r| r.name));
        let hint = did_you_mean(typed, words);
        return Err(usage(format!("no word or flag matches {typed:?}{hint}; `axisctl flags` lists them all")));
    }
    if ctx.json {
        let list: Vec<Value> = rows
            .iter()
            .map(|r| {
                json!({"family": r.family, "word": r.word, "name": r.name, "short": r.short, "class": r.class,
                             "description": r.description})
            })
            .collect();
        output::json(&json!({ "flags": by_family(&list) }));
        return Ok(());
    }
    let mut table = vec![["word", "name", "short", "class", "description"].map(String::from).to_vec()];
    for r in rows {
        table.push(vec![
            r.word.into(),
            ctx.style.flag(r.name, class_of(r.class)),
            r.short.unwrap_or("-").into(),
            r.class.into(),
            r.description.into(),
        ]);
    }
    output::table(&table, ctx.style);
    Ok(())
}

fn class_of(name: &str) -> cube_flags::FlagClass {
    match name {
        "error" => cube_flags::FlagClass::Error,
        "warning" => cube_flags::FlagClass::Warning,
        _ => cube_flags::FlagClass::Info,
    }
}
