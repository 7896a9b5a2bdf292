//! The socketcand stream decoder (a remote bus's TCP stream) fed any bytes
//! in random chunks. Invariants: no panic; the decoder always progresses
//! and holds at most one message; chunking changes no decoded message;
//! every frame and send decoded re-encodes to itself.
#![no_main]

use axisctl::proto::socketcand::{Decoder, Message, MAX_MESSAGE};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fn messages(d: &mut Decoder, out: &mut Vec<Message>, pushed: usize) {
    let mut n = 0;
    while let Some(m) = d.next_message() {
        n += 1;
        assert!(n <= pushed + 1, "no progress: {n} results from {pushed} bytes");
        if let Ok(m) = m {
            out.push(m);
        }
    }
    assert!(d.pending() <= MAX_MESSAGE + 32, "decoder holds {} bytes", d.pending());
}

fn decode_all(bytes: &[u8]) -> Vec<Message> {
    let mut d = Decoder::new();
    d.push(bytes);
    let mut out = Vec::new();
    messages(&mut d, &mut out, bytes.len());
    out
}

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else { return };
    let whole = decode_all(stream);
    let mut d = Decoder::new();
    let mut chunked = Vec::new();
    for c in common::chunks(seed, stream) {
        d.push(c);
        messages(&mut d, &mut chunked, c.len());
    }
    assert_eq!(whole, chunked, "chunking changed the messages");
    for m in &whole {
        if matches!(m, Message::Frame { .. } | Message::Send(_)) {
            assert_eq!(decode_all(&m.to_bytes()), vec![m.clone()]);
        }
    }
});
