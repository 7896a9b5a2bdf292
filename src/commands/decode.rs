//! `axisctl decode KIND VALUE`: take a raw word apart offline.

use axisctl::family::{self, Family};
use axisctl::proto::pac::profibus as pac_profibus;
use axisctl::proto::powercube::bus::describe_ack;
use axisctl::proto::powercube::flags::{self, ProfibusInput};
use serde_json::json;

use super::{usage, Ctx};
use crate::output;
use crate::output::{say, say_part};

const PROFIBUS_IMAGE: &str = family::POWERCUBE_PROFIBUS_IMAGE;

pub fn run(ctx: &Ctx, kind: &str, value: &str) -> anyhow::Result<()> {
    let unknown = || {
        let kinds = Family::all_decode_kinds();
        let hint = super::names::did_you_mean(kind, kinds.iter().copied());
        usage(format!("unknown kind {kind:?}{hint}; kinds: {}", kinds.join(", ")))
    };
    match Family::of_decode_kind(kind).ok_or_else(unknown)? {
        Family::Cdios => super::cdios::decode_kind(ctx, kind, value).unwrap_or_else(|| Err(unknown())),
        Family::Pac => pac_word(ctx, pac_profibus::word(kind).ok_or_else(unknown)?, value),
        Family::PowerCube if kind.eq_ignore_ascii_case(PROFIBUS_IMAGE) => profibus_image(ctx, value),
        Family::PowerCube => flag_word(ctx, flags::word(kind).ok_or_else(unknown)?, value),
    }
}

fn flag_word(ctx: &Ctx, word: &'static flags::FlagWord, value: &str) -> anyhow::Result<()> {
    let raw = word.parse(value).map_err(|e| usage(e.to_string()))?;
    let d = word.decode(raw);
    if ctx.json {
        let details: Vec<_> = word
            .set_flags(raw)
            .map(|f| json!({"name": f.name, "mask": f.mask, "class": f.class, "description": f.description}))
            .collect();
        output::json(&json!({"kind": word.kind, "raw": raw, "flags": d.flags, "errors": d.errors,
                             "warnings": d.warnings, "unknown_bits": d.unknown_bits, "details": details}));
        return Ok(());
    }
    let width = (word.bits / 4) as usize;
    say!("{} {:#0w$x}", word.name, raw, w = width + 2);
    let mut rows = Vec::new();
    for f in word.set_flags(raw) {
        rows.push(vec![
            format!("{:#0w$x}", f.mask, w = width + 2),
            ctx.style.flag(f.name, f.class),
            f.class.name().into(),
            f.description.to_string(),
        ]);
    }
    if rows.is_empty() {
        say!("(no flags set)");
    } else {
        let mut t = vec![["BIT", "FLAG", "CLASS", "MEANING"].map(String::from).to_vec()];
        t.extend(rows);
        output::table(&t, ctx.style);
    }
    if d.unknown_bits != 0 {
        say!("{}", ctx.style.warn(&format!("unknown bits {:#x}", d.unknown_bits)));
    }
    Ok(())
}

fn parse_hex_bytes(text: &str) -> anyhow::Result<Vec<u8>> {
    crate::output::parse_hex_bytes(text).ok_or_else(|| usage(format!("{text:?} is not a sequence of hex bytes")))
}

fn profibus_image(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let bytes = parse_hex_bytes(value)?;
    let img = ProfibusInput::decode(&bytes).map_err(|e| usage(format!("profibus image: {e}")))?;
    let state = img.state();
    // Bytes 0..7 are an acknowledge as on CAN: decoded the way `monitor` does.
    let (decoded, details) = match img.response() {
        Ok(resp) => {
            let (text, details) = describe_ack(&resp);
            (Ok(text), details)
        }
        Err(e) => (Err(e.to_string()), serde_json::Value::Null),
    };
    if ctx.json {
        output::json(&json!({
            "kind": PROFIBUS_IMAGE, "answer": img.answer, "answer_decoded": decoded.as_ref().ok(),
            "answer_details": details, "answer_error": decoded.as_ref().err(),
            "position_ticks": img.position_ticks,
            "short_state": output::flag_word(&flags::PROFIBUS_STATE, img.short_state.into()), "ms": img.ms,
        }));
        return Ok(());
    }
    let hex: Vec<String> = img.answer.iter().map(|b| format!("{b:02x}")).collect();
    let text = decoded.unwrap_or_else(|e| format!("(not an acknowledge: {e})"));
    say!("answer      {}  {text}", hex.join(" "));
    say!("position    {} ticks", img.position_ticks);
    say!("short state {:#06x} {}", img.short_state, state.flags.join(" "));
    say!("ms          {}", img.ms);
    Ok(())
}

/// A PA-CONTROL Profibus-DP / Interbus-S word or status date: a number
/// (decimal, 0x hex, 0b binary) or, for the 8-byte CMD images, hex bytes as
/// the manual prints them (`00 00 00 00 0E 01 00 13`, or the 16 digits run
/// together: sixteen digits without `0x` are always the bytes).
fn pac_word(ctx: &Ctx, def: &'static pac_profibus::WordDef, value: &str) -> anyhow::Result<()> {
    let t = value.trim();
    let run_together = t.len() == 16 && t.chars().all(|c| c.is_ascii_hexdigit());
    let raw = if def.bits == 64 && (t.contains(' ') || t.contains(':') || run_together) {
        let bytes = parse_hex_bytes(t)?;
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
    let mut doc = json!({"kind": d.kind, "title": d.title, "section": d.section});
    if let (Some(o), serde_json::Value::Object(st)) = (doc.as_object_mut(), output::state(d.raw, &set, unknown)) {
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
