//! slcan (Lawicel) both ways: the host's line decoder fed adapter output in
//! random chunks, and the simulated adapter fed host bytes. Invariants: no
//! panic; chunking changes nothing; at most one line is buffered; frames and
//! commands round-trip; what the adapter writes always decodes cleanly.
#![no_main]

use axisctl::proto::slcan::{self, AckStyle, Adapter, Command, LineDecoder, SlcanEvent, ADAPTER_TX_QUEUE, MAX_LINE};
use axisctl::proto::{CanFrame, DecodeError};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fn events(d: &mut LineDecoder, out: &mut Vec<Result<SlcanEvent, DecodeError>>) {
    while let Some(e) = d.next_event() {
        out.push(e);
    }
    assert!(d.buffered() <= MAX_LINE, "line decoder holds {} bytes", d.buffered());
}

/// An overlong line reports how much of it was buffered when it was given
/// up, which depends on how the bytes arrived: compare without the length.
fn normalized(v: Vec<Result<SlcanEvent, DecodeError>>) -> Vec<Result<SlcanEvent, DecodeError>> {
    v.into_iter()
        .map(|r| r.map_err(|e| if let DecodeError::TooLong { .. } = e { DecodeError::TooLong { len: 0 } } else { e }))
        .collect()
}

fn decode_all(bytes: &[u8]) -> Vec<Result<SlcanEvent, DecodeError>> {
    let mut d = LineDecoder::new();
    d.push(bytes);
    let mut out = Vec::new();
    events(&mut d, &mut out);
    out
}

/// Runs an adapter over `chunks` of host bytes, with bus traffic between
/// them; returns everything it wrote to the host and put on the bus.
fn run_adapter(style: AckStyle, chunks: &[&[u8]], bus: &[CanFrame]) -> (Vec<u8>, Vec<CanFrame>) {
    let mut a = Adapter::new(style);
    let (mut out, mut tx) = (Vec::new(), Vec::new());
    for (i, c) in chunks.iter().enumerate() {
        a.handle_host_bytes(c);
        if let Some(f) = bus.get(i) {
            a.bus_frame(f);
        }
        if let Some(o) = a.poll_output() {
            out.extend(o);
        }
    }
    while let Some(f) = a.poll_transmit() {
        tx.push(f);
    }
    assert!(tx.len() <= ADAPTER_TX_QUEUE);
    let _ = (a.is_open(), a.is_listen_only(), a.bitrate(), a.remote_transmits());
    (out, tx)
}

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else { return };

    // Host side: what an adapter sends.
    let whole = decode_all(stream);
    let mut d = LineDecoder::new();
    let mut chunked = Vec::new();
    for c in common::chunks(seed, stream) {
        d.push(c);
        events(&mut d, &mut chunked);
    }
    assert_eq!(normalized(whole.clone()), normalized(chunked));
    for ev in whole.iter().flatten() {
        let _ = ev.to_string();
        if let SlcanEvent::Frame(f) = ev {
            let mut bytes = Vec::new();
            slcan::encode_frame(f, &mut bytes);
            assert_eq!(decode_all(&bytes), vec![Ok(SlcanEvent::Frame(*f))]);
        }
    }

    // Each line as a host command.
    for line in stream.split(|&b| b == slcan::CR) {
        if let Ok(cmd) = Command::parse(line) {
            let bytes = cmd.to_bytes();
            assert_eq!(bytes.last(), Some(&slcan::CR));
            assert_eq!(Command::parse(&bytes[..bytes.len() - 1]), Ok(cmd));
        }
    }

    // Adapter side: what a host sends, chunking must not matter, and the
    // adapter's output must read back without a single decode error.
    let style = match seed % 3 {
        0 => AckStyle::Lawicel,
        1 => AckStyle::CrOnly,
        _ => AckStyle::Silent,
    };
    let bus: Vec<CanFrame> =
        stream.chunks(9).take(4).filter_map(|c| CanFrame::new(u32::from(c[0]) << 3, &c[1..])).collect();
    let (out, tx) = run_adapter(style, &[stream], &[]);
    let chunks = common::chunks(seed.wrapping_add(1), stream);
    let (out2, tx2) = run_adapter(style, &chunks, &[]);
    assert_eq!(tx, tx2, "chunking changed what the adapter transmitted");
    assert_eq!(out, out2, "chunking changed what the adapter answered");
    // With bus traffic between the reads, the answers interleave with frames.
    let (out3, tx3) = run_adapter(style, &chunks, &bus);
    assert_eq!(tx3, tx);
    for ev in decode_all(&out3) {
        assert!(ev.is_ok(), "adapter wrote {out3:02x?}, decoded as {ev:?}");
    }
});
