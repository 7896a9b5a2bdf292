//! PowerCube RS232 stream decoder (manual 4.3): arbitrary bytes fed in
//! arbitrary chunks. Invariants: no panic; chunking does not change what is
//! decoded; the input queue is drained; every decoded frame re-encodes to a
//! frame that decodes to itself; a valid frame after any garbage is found.
#![no_main]

use axisctl::proto::powercube::rs232::{self, Decoder, Direction, Rs232Frame};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fn drain(d: &mut Decoder, out: &mut Vec<Result<Rs232Frame, rs232::DecodeError>>) {
    while let Some(r) = d.next_frame() {
        out.push(r);
    }
}

fn decode_all(bytes: &[u8]) -> Vec<Result<Rs232Frame, rs232::DecodeError>> {
    let mut d = Decoder::new();
    d.push(bytes);
    let mut out = Vec::new();
    drain(&mut d, &mut out);
    out
}

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else { return };

    let whole = decode_all(stream);

    let mut d = Decoder::new();
    let mut chunked = Vec::new();
    for c in common::chunks(seed, stream) {
        d.push(c);
        drain(&mut d, &mut chunked);
    }
    assert_eq!(whole, chunked, "chunking changed the decoded frames");

    for frame in whole.iter().flatten() {
        assert!(frame.module <= rs232::MAX_MODULE);
        assert!(frame.payload.len() <= 8);
        // Typed interpretations must not panic either.
        let _ = frame.response();
        let _ = frame.request();
        let mut bytes = Vec::new();
        frame.encode(&mut bytes);
        let again = decode_all(&bytes);
        assert_eq!(again.len(), 1, "{frame:?} re-encoded to {bytes:02x?}");
        let g = again[0].as_ref().expect("re-encoded frame decodes");
        assert_eq!((g.dir, g.module, g.payload), (frame.dir, frame.module, frame.payload));
        assert!(!g.len_mismatch());
    }

    // A well-formed frame built from the input survives any garbage before it.
    let dir = if seed & 1 == 0 { Direction::ToModule } else { Direction::FromModule };
    let module = (seed >> 1) & 0x1f;
    let payload = &stream[stream.len().saturating_sub(usize::from(seed >> 6) * 3)..];
    let payload = &payload[..payload.len().min(8)];
    let mut bytes = stream.to_vec();
    rs232::encode(dir, module, payload, &mut bytes);
    let last = decode_all(&bytes).pop().expect("a frame").expect("valid frame after garbage");
    assert_eq!((last.dir, last.module, last.payload.as_slice()), (dir, module, payload));
});
