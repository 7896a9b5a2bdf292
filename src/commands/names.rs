//! `axisctl params [FAMILY]` and `axisctl flags [WORD]`: the names the
//! commands accept, listed offline from the protocol tables; and the
//! did-you-mean of a misspelled one, checked before anything opens.

use axisctl::family::Family;
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
        rows.extend(super::names_of(f).param_rows(f));
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
pub struct FlagRow {
    pub family: Family,
    pub word: &'static str,
    pub name: &'static str,
    pub short: Option<&'static str>,
    pub class: &'static str,
    pub description: &'static str,
}

fn every_flag() -> Vec<FlagRow> {
    Family::ALL.into_iter().flat_map(|f| super::names_of(f).flag_rows()).collect()
}

/// A family's names as `params` and `flags` list them, said in its folder
/// (`commands/<family>/names.rs`); `super::names_of` picks the family's.
pub trait Names {
    /// The parameters (or configuration fields) of `family`, one row each:
    /// `family`, `kind`, `name`, `id`, `type`, `unit`, `access`, `range`,
    /// `description`.
    fn param_rows(&self, family: Family) -> Vec<Value>;
    /// Every flag and bit field of the family's status words.
    fn flag_rows(&self) -> Vec<FlagRow>;
    /// The values `record` samples of one of its devices (completion).
    fn record_values(&self) -> Vec<&'static str>;
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
            match r.class {
                "error" => ctx.style.error(r.name),
                "warning" => ctx.style.warn(r.name),
                _ => r.name.into(),
            },
            r.short.unwrap_or("-").into(),
            r.class.into(),
            r.description.into(),
        ]);
    }
    output::table(&table, ctx.style);
    Ok(())
}
