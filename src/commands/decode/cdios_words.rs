//! `decode cdios-status` and `decode cdios-error`: the 4 status bytes and an
//! error reply, in the shapes the commands give them.

use axisctl::proto::cdios::table::{self, STATUS_FLAGS};
use axisctl::proto::cdios::{decode_status, ErrorReply};
use axisctl::proto::refusal::Refusal;
use serde_json::json;

use super::hex_bytes;
use crate::commands::cdios::{merge, status_json, status_line};
use crate::commands::{error_json, usage, Ctx};
use crate::output;
use crate::output::say;

/// `axisctl decode cdios-status|cdios-error VALUE`; `None` for other kinds.
pub(super) fn decode_kind(ctx: &Ctx, kind: &str, value: &str) -> Option<anyhow::Result<()>> {
    match kind.to_ascii_lowercase().as_str() {
        "cdios-status" => Some(decode_status_bytes(ctx, value)),
        "cdios-error" => Some(decode_error(ctx, value)),
        _ => None,
    }
}

fn decode_status_bytes(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let b = hex_bytes(value)?;
    let status: [u8; 4] = b.as_slice().try_into().map_err(|_| {
        usage(format!(
            "cdios-status takes the 4 status bytes in wire order (status 1 first), e.g. 81008010; got {} bytes",
            b.len()
        ))
    })?;
    let r = decode_status(status);
    if ctx.json {
        let mut doc = json!({"kind": "cdios-status"});
        merge(&mut doc, status_json(&r));
        output::json(&doc);
        return Ok(());
    }
    say!("Cdios 6168 status {}", status_line(ctx, &r));
    let mut rows = vec![["BIT", "FLAG", "CLASS", "MEANING"].map(String::from).to_vec()];
    for f in STATUS_FLAGS.iter().filter(|f| f.is_set(&status)) {
        let name = if f.class == table::Class::Error { ctx.style.error(f.name) } else { f.name.to_string() };
        rows.push(vec![format!("status {}.{}", f.byte, f.bit), name, f.class.name().into(), f.meaning.into()]);
    }
    if rows.len() > 1 {
        output::table(&rows, ctx.style);
    }
    for (b, bit) in &r.reserved {
        say!("{}", ctx.style.warn(&format!("status {b} bit {bit} is set (reserved)")));
    }
    Ok(())
}

fn decode_error(ctx: &Ctx, value: &str) -> anyhow::Result<()> {
    let b = hex_bytes(value)?;
    let e = ErrorReply::decode(&b).map_err(|err| {
        usage(format!(
            "cdios-error takes the data bytes of an error reply (code | 0x80 first, e.g. a3 01 00 00 80): {err}"
        ))
    })?;
    let general = e.general_error();
    if ctx.json {
        // The shape of an error document's `device`: what a refused command
        // reports, so the decoder and the commands say the same of one reply.
        let mut doc = json!({"kind": "cdios-error", "module": e.module,
            "manual_command": table::COMMANDS.iter().find(|c| c.code == e.command).map_or("unknown", |c| c.name)});
        merge(&mut doc, error_json::device(&Refusal::from(&e)));
        output::json(&doc);
        return Ok(());
    }
    say!("{}", e.describe());
    if let Some((name, text)) = general {
        say!("general error {} {name}: {text}", e.general);
    }
    for f in e.flags() {
        say!("  error status {} bit {}: {} ({})", f.byte, f.bit, ctx.style.error(f.name), f.meaning);
    }
    Ok(())
}
