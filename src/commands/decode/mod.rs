//! `axisctl decode KIND VALUE`: take a raw word apart offline. Each
//! family's words are decoded in its own file, in the shapes its commands
//! give them; this file only finds the family of a kind.

mod cdios_words;
mod pac_words;
mod powercube_words;

use axisctl::family::Family;

use super::{usage, Ctx};

pub(super) use pac_words::ext_axis_state;

pub fn run(ctx: &Ctx, kind: &str, value: &str) -> anyhow::Result<()> {
    let unknown = || {
        let kinds = Family::all_decode_kinds();
        let hint = super::names::did_you_mean(kind, kinds.iter().copied());
        usage(format!("unknown kind {kind:?}{hint}; kinds: {}", kinds.join(", ")))
    };
    let decoded = match Family::of_decode_kind(kind).ok_or_else(unknown)? {
        Family::Cdios => cdios_words::decode_kind(ctx, kind, value),
        Family::Pac => pac_words::decode_kind(ctx, kind, value),
        Family::PowerCube => powercube_words::decode_kind(ctx, kind, value),
    };
    decoded.unwrap_or_else(|| Err(unknown()))
}

/// Hex bytes as the manuals print them (`a3 01 00`, `a3:01`, `a30100`).
fn hex_bytes(text: &str) -> anyhow::Result<Vec<u8>> {
    crate::output::parse_hex_bytes(text).ok_or_else(|| usage(format!("{text:?} is not a sequence of hex bytes")))
}
