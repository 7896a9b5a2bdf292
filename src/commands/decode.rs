//! `axisctl decode KIND VALUE`: take a raw word apart offline.

use axisctl::proto::powercube::flags::{self, ProfibusInput};
use axisctl::proto::powercube::Response;
use serde_json::json;

use super::{usage, Ctx};
use crate::output;

/// Kinds beyond the flag words.
const PROFIBUS_IMAGE: &str = "profibus-image";

fn kinds() -> String {
    flags::WORDS
        .iter()
        .map(|w| w.kind)
        .chain([PROFIBUS_IMAGE])
        .chain(super::cdios::DECODE_KINDS.iter().copied())
        .collect::<Vec<_>>()
        .join(", ")
}

pub fn run(ctx: &Ctx, kind: &str, value: &str) -> anyhow::Result<()> {
    if let Some(r) = super::cdios::decode_kind(ctx, kind, value) {
        return r;
    }
    if kind.eq_ignore_ascii_case(PROFIBUS_IMAGE) {
        return profibus_image(ctx, value);
    }
    let word = flags::word(kind).ok_or_else(|| usage(format!("unknown kind {kind:?}; kinds: {}", kinds())))?;
    let raw = word.parse(value).map_err(|e| usage(e.to_string()))?;
    let d = word.decode(raw);
    if ctx.json {
        let details: Vec<_> = word
            .set_flags(raw)
            .map(|f| json!({"name": f.name, "mask": f.mask, "class": format!("{:?}", f.class).to_lowercase(), "description": f.description}))
            .collect();
        output::json(&json!({"kind": word.kind, "raw": raw, "flags": d.flags, "errors": d.errors,
                             "warnings": d.warnings, "unknown_bits": d.unknown_bits, "details": details}));
        return Ok(());
    }
    let width = (word.bits / 4) as usize;
    println!("{} {:#0w$x}", word.name, raw, w = width + 2);
    let mut rows = Vec::new();
    for f in word.set_flags(raw) {
        rows.push(vec![
            format!("{:#0w$x}", f.mask, w = width + 2),
            ctx.style.flag(f.name, f.class),
            format!("{:?}", f.class).to_lowercase(),
            f.description.to_string(),
        ]);
    }
    if rows.is_empty() {
        println!("(no flags set)");
    } else {
        let mut t = vec![["BIT", "FLAG", "CLASS", "MEANING"].map(String::from).to_vec()];
        t.extend(rows);
        output::table(&t, ctx.style);
    }
    if d.unknown_bits != 0 {
        println!("{}", ctx.style.warn(&format!("unknown bits {:#x}", d.unknown_bits)));
    }
    Ok(())
}

fn parse_hex_bytes(text: &str) -> anyhow::Result<Vec<u8>> {
    let digits: String = text.chars().filter(|c| !c.is_whitespace() && *c != ':' && *c != ',').collect();
    let digits = digits.strip_prefix("0x").unwrap_or(&digits);
    if !digits.len().is_multiple_of(2) || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
        return Err(usage(format!("{text:?} is not a sequence of hex bytes")));
    }
    Ok((0..digits.len()).step_by(2).map(|i| u8::from_str_radix(&digits[i..i + 2], 16).unwrap_or(0)).collect())
}

fn profibus_image(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let bytes = parse_hex_bytes(value)?;
    let img = ProfibusInput::decode(&bytes).map_err(|e| usage(format!("profibus image: {e}")))?;
    let state = img.state();
    let answer = img.answer_len().ok().and_then(|n| Response::decode(&img.answer[..n]).ok());
    if ctx.json {
        output::json(&json!({
            "kind": PROFIBUS_IMAGE, "answer": img.answer, "answer_decoded": answer.map(|a| format!("{a:?}")),
            "position_ticks": img.position_ticks, "short_state": img.short_state,
            "flags": state.flags, "errors": state.errors, "ms": img.ms,
        }));
        return Ok(());
    }
    println!("answer      {:02x?}  {}", img.answer, answer.map(|a| format!("{a:?}")).unwrap_or_default());
    println!("position    {} ticks", img.position_ticks);
    println!("short state {:#06x} {}", img.short_state, state.flags.join(" "));
    println!("ms          {}", img.ms);
    Ok(())
}
