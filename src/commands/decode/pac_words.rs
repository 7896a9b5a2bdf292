//! `decode` of the PA-CONTROL Profibus-DP / Interbus-S words and status
//! dates; the extended axis status (1921) in the one `state` shape that
//! `pac-axis` gives it.

use axisctl::proto::pac::profibus as pac_profibus;
use axisctl::proto::pac::table::{self, ExtAxisStatus};
use serde_json::json;

use super::hex_bytes;
use crate::commands::{usage, Ctx};
use crate::output;
use crate::output::say_part;

const EXT_AXIS_STATUS: &str = "pac-ext-axis-status";

/// `decode KIND VALUE` for a PA-CONTROL kind; `None` for a kind it does not know.
pub(super) fn decode_kind(ctx: &Ctx, kind: &str, value: &str) -> Option<anyhow::Result<()>> {
    pac_profibus::word(kind).map(|def| pac_word(ctx, def, value))
}

/// A PA-CONTROL Profibus-DP / Interbus-S word or status date: a number
/// (decimal, 0x hex, 0b binary) or, for the 8-byte CMD images, hex bytes as
/// the manual prints them (`00 00 00 00 0E 01 00 13`, or the 16 digits run
/// together: sixteen digits without `0x` are always the bytes).
fn pac_word(ctx: &Ctx, def: &'static pac_profibus::WordDef, value: &str) -> anyhow::Result<()> {
    let t = value.trim();
    let run_together = t.len() == 16 && t.chars().all(|c| c.is_ascii_hexdigit());
    let raw = if def.bits == 64 && (t.contains(' ') || t.contains(':') || run_together) {
        let bytes = hex_bytes(t)?;
        let arr: [u8; 8] =
            bytes.try_into().map_err(|b: Vec<u8>| usage(format!("{} takes 8 bytes, got {}", def.kind, b.len())))?;
        pac_profibus::image(arr)
    } else {
        axisctl::proto::parse_uint(t)
            .ok_or_else(|| usage(format!("{value:?} is not a number (decimal, 0x hex or 0b binary)")))?
    };
    let d = pac_profibus::decode_word(def, raw).map_err(|e| usage(e.to_string()))?;
    if ctx.json {
        output::json(&pac_word_json(&d));
    } else {
        say_part!("{d}");
    }
    Ok(())
}

/// A decoded PA-CONTROL word in the common `state` shape (its one-bit flags
/// that are set, the reserved bits set as `unknown_bits`) with every field,
/// each with its bits as an integer `mask` within `raw`.
fn pac_word_json(d: &pac_profibus::Decoded) -> serde_json::Value {
    // "15" or "0-12", as the table prints them.
    let mask_of = |bits: &str| -> u64 {
        let (lo, hi) = bits.split_once('-').unwrap_or((bits, bits));
        let (lo, hi) = (lo.parse::<u32>().unwrap_or(0), hi.parse::<u32>().unwrap_or(0));
        (lo..=hi.min(63)).fold(0, |m, b| m | 1u64 << b)
    };
    // The manual has no classes for these words; a flag that reports an
    // error says so in its name or text.
    let class = |f: &pac_profibus::DecodedField| {
        let says = |t: &str| t.to_ascii_lowercase().contains("error");
        if says(f.name) || says(f.description) {
            "error"
        } else {
            "info"
        }
    };
    let set: Vec<output::Detail> = d
        .fields
        .iter()
        .filter(|f| f.set == Some(true))
        .map(|f| output::Detail { name: f.name, mask: mask_of(&f.bits), class: class(f), description: f.description })
        .collect();
    let unknown = d.reserved_bits_set.iter().fold(0u64, |m, b| m | 1u64.checked_shl(u32::from(*b)).unwrap_or(0));
    // The extended axis status is a `pac-axis` state too: one decoder for both.
    let state = match u32::try_from(d.raw) {
        Ok(raw) if d.kind == EXT_AXIS_STATUS => ext_axis_state(raw),
        _ => output::state(d.raw, &set, unknown),
    };
    let mut doc = json!({"kind": d.kind, "title": d.title, "section": d.section});
    if let (Some(o), serde_json::Value::Object(st)) = (doc.as_object_mut(), state) {
        o.extend(st);
    }
    doc["fields"] = d
        .fields
        .iter()
        .map(|f| {
            let mut field = json!({"name": f.name, "mask": mask_of(&f.bits), "value": f.value,
                                   "description": f.description});
            if let Some(m) = &f.meaning {
                field["meaning"] = json!(m);
            }
            field
        })
        .collect();
    doc
}

/// The extended axis status (1921, manual 5.2.4.28) in the one `state`
/// shape, for `pac-axis` and `decode pac-ext-axis-status` alike. Its bytes are fields, not bits: the mask of a flag is the byte
/// that says it (a limit switch is activated when its byte is 0); the low
/// byte is the axis status of 1910, whose codes 1, 2, 4, 8 are bits.
pub(crate) fn ext_axis_state(raw: u32) -> serde_json::Value {
    let ext = ExtAxisStatus::decode(raw);
    let mut set = Vec::new();
    let mut flag = |on: bool, name, mask, class, description| {
        if on {
            set.push(output::Detail { name, mask, class, description });
        }
    };
    flag(ext.power_pack_ready, "POWER_PACK_READY", 0xff00_0000, "info", "the power pack is ready (bits 24-31 = 1)");
    let positive = "the positive limit switch is activated (bits 16-23 = 0)";
    flag(ext.positive_limit_activated, "POSITIVE_LIMIT_ACTIVATED", 0x00ff_0000, "warning", positive);
    let negative = "the negative limit switch is activated (bits 8-15 = 0)";
    flag(ext.negative_limit_activated, "NEGATIVE_LIMIT_ACTIVATED", 0x0000_ff00, "warning", negative);
    let names = ["AXIS_MOVING", "AXIS_STOPPED", "AXIS_FAULT", "AXIS_MEASURING_MODE"];
    for (bit, name) in names.into_iter().enumerate() {
        let mask = 1u64 << bit;
        let class = if name == "AXIS_FAULT" { "error" } else { "info" };
        flag(u64::from(ext.axis_status) & mask != 0, name, mask, class, table::axis_status_text(mask));
    }
    output::state(raw.into(), &set, u64::from(ext.axis_status & 0xf0))
}
