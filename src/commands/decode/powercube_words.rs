//! `decode` of the PowerCube words: flag words, and the Profibus input image.

use axisctl::family;
use axisctl::proto::powercube::bus::describe_ack;
use axisctl::proto::powercube::flags::{self, ProfibusInput};
use serde_json::json;

use super::hex_bytes;
use crate::commands::{usage, Ctx};
use crate::output;
use crate::output::say;

const PROFIBUS_IMAGE: &str = family::POWERCUBE_PROFIBUS_IMAGE;

/// `decode KIND VALUE` for a PowerCube kind; `None` for a kind it does not know.
pub(super) fn decode_kind(ctx: &Ctx, kind: &str, value: &str) -> Option<anyhow::Result<()>> {
    if kind.eq_ignore_ascii_case(PROFIBUS_IMAGE) {
        return Some(profibus_image(ctx, value));
    }
    flags::word(kind).map(|word| flag_word(ctx, word, value))
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

fn profibus_image(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let bytes = hex_bytes(value)?;
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
