//! The one error object of `--json` (docs/json.md, schema/axisctl.schema.json
//! `#/$defs/error_document`): every failure, argument errors included.

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
/// the set error bits in the `state` detail shape. Each family's refusal
/// says it in its folder (`commands/<family>.rs`).
pub(super) fn device(r: &Refusal) -> Value {
    match r {
        Refusal::PaControl(p) => p.device_doc(),
        Refusal::Cdios(c) => c.device_doc(),
        Refusal::PowerCube(p) => p.device_doc(),
    }
}

/// A family's refusal as the `device` object of an error document
/// (docs/json.md): `family`, `command_code`, `code`, `name`, `text`,
/// `details`, `unknown_bits`.
pub trait DeviceDoc {
    fn device_doc(&self) -> Value;
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
