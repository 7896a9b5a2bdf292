//! The one error object of `--json` (docs/json.md, schema/axisctl.schema.json
//! `#/$defs/error_document`): every failure, argument errors included.

use axisctl::proto::powercube::flags::CUBE_STATE;
use axisctl::proto::refusal::Refusal;
use serde_json::{json, Map, Value};

use crate::output;

/// `{"error": {...}}` for a failed command: its class and exit code, the
/// message, the device it was addressing and, for a refusal, what the
/// device said.
pub fn failure(kind: &str, exit_code: u8, message: String, refusal: Option<&Refusal>) -> Value {
    let mut error = Map::new();
    error.insert("kind".into(), kind.into());
    error.insert("exit_code".into(), exit_code.into());
    error.insert("message".into(), message.into());
    if let Some(target) = output::current_target() {
        error.extend(target);
    }
    if let Some(link) = output::current_link() {
        error.insert("link".into(), link.into());
    }
    if let Some(r) = refusal {
        error.insert("device".into(), device(r));
    }
    if let Some(report) = output::take_error_report() {
        error.insert("report".into(), report);
    }
    json!({ "error": error })
}

/// `{"error": {...}}` for a command line clap rejected (nothing was sent).
pub fn usage(e: &clap::Error, exit_code: u8) -> Value {
    let text = e.render().to_string();
    // clap's first paragraph is the error (a missing argument is named on
    // the lines after it); usage and a tip for a terminal follow.
    let first: Vec<&str> =
        text.lines().take_while(|l| !l.trim().is_empty() && !l.starts_with("Usage:")).map(str::trim).collect();
    let first = first.join(" ");
    let message = first.strip_prefix("error: ").unwrap_or(&first).to_string();
    let mut error = json!({"kind": "usage", "exit_code": exit_code, "message": message});
    if let Some(clap::error::ContextValue::String(arg)) = e.get(clap::error::ContextKind::InvalidArg) {
        error["argument"] = json!(arg);
    }
    json!({ "error": error })
}

/// What the device answered, one shape for every family: the refused
/// command's wire code, the device's code and the manual's text for it, and
/// the set error bits in the `state` detail shape.
pub(super) fn device(r: &Refusal) -> Value {
    match r {
        Refusal::PaControl(p) => json!({"family": "pac", "command_code": format!("{:04X}", p.command),
            "code": p.quit, "name": null, "text": p.text, "details": [], "unknown_bits": 0}),
        Refusal::Cdios(c) => {
            // Error status byte 1 is the low byte of the mask, byte 2 the next.
            let mask = |status: u8, bit: u8| 1u64 << (8 * u32::from(status.saturating_sub(1)) + u32::from(bit));
            let details: Vec<_> = c
                .errors
                .iter()
                .map(|b| json!({"name": b.name, "mask": mask(b.status, b.bit), "class": "error", "description": b.meaning}))
                .collect();
            let unknown = c.unknown_bits.iter().fold(0, |m, b| m | mask(b.status, b.bit));
            json!({"family": "cdios", "command_code": format!("{:02X}", c.command), "code": c.general,
                   "name": c.general_name, "text": c.general_text.unwrap_or("not in the manual's table"),
                   "details": details, "unknown_bits": unknown})
        }
        Refusal::PowerCube(p) => {
            let state = output::flag_word(&CUBE_STATE, p.cube_state);
            let errors: Vec<&str> = p.errors.clone();
            let details: Vec<Value> = state["details"]
                .as_array()
                .map(|d| d.iter().filter(|d| d["class"] == "error").cloned().collect())
                .unwrap_or_default();
            json!({"family": "powercube", "command_code": null, "code": p.cube_state, "name": null,
                   "text": errors.join(", "), "details": details, "unknown_bits": state["unknown_bits"]})
        }
    }
}

/// The error and its causes joined with ": ", leaving out a cause whose text
/// the message already carries (typed errors quote their source), and the
/// command line's advice.
pub fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !out.contains(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
    }
    out.push_str(&super::hint(e).unwrap_or_default());
    out
}
