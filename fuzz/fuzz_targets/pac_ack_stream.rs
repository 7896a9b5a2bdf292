//! PA-CONTROL RS232 streams (manual 3.3, 3.3.1): the acknowledge decoder (the
//! PC's side) and the command decoder (the controller's side) fed in random
//! chunks. Invariants: no panic; chunking changes nothing; at most one
//! partial frame of MAX_FRAME bytes stays buffered; every decoded frame
//! re-encodes to one that decodes to the same values; frames built from the
//! input round-trip.
#![no_main]

use axisctl::proto::pac::frame::{EncodeOptions, FloatFormat, FrameError, MAX_FRAME};
use axisctl::proto::pac::{Ack, AckDecoder, CheckRule, Command, CommandDecoder, Par2, Request};
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fn acks(d: &mut AckDecoder, out: &mut Vec<Result<Ack, FrameError>>) {
    while let Some(r) = d.next() {
        out.push(r);
    }
    assert!(d.buffered() <= MAX_FRAME, "ack decoder holds {} bytes", d.buffered());
}

fn commands(d: &mut CommandDecoder, out: &mut Vec<Result<Request, FrameError>>) {
    while let Some(r) = d.next() {
        out.push(r);
    }
    assert!(d.buffered() <= MAX_FRAME, "command decoder holds {} bytes", d.buffered());
}

/// Garbage is reported per run of bytes the decoder has seen, so chunking
/// splits one report into several: compare the totals between frames.
fn merge_garbage<T>(v: Vec<Result<T, FrameError>>) -> Vec<Result<T, FrameError>> {
    let mut out: Vec<Result<T, FrameError>> = Vec::new();
    for r in v {
        if let (Err(FrameError::Garbage { len }), Some(Err(FrameError::Garbage { len: prev }))) = (&r, out.last_mut()) {
            *prev += len;
            continue;
        }
        out.push(r);
    }
    out
}

fn rule(b: u8) -> CheckRule {
    match b % 3 {
        0 => CheckRule::Strict,
        1 => CheckRule::WithEtx,
        _ => CheckRule::Omitted,
    }
}

fn par2(b: &mut common::Bytes) -> Par2 {
    if b.bool() {
        Par2::Float(f64::from_bits(b.u64()))
    } else {
        Par2::Int(b.u64() as i64)
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else { return };
    let omitted = seed & 0x80 != 0;

    // Acknowledges.
    let mut whole = Vec::new();
    let mut d = AckDecoder::new().accept_omitted_check(omitted);
    d.push(stream);
    acks(&mut d, &mut whole);
    let mut chunked = Vec::new();
    let mut d = AckDecoder::new().accept_omitted_check(omitted);
    for c in common::chunks(seed, stream) {
        d.push(c);
        acks(&mut d, &mut chunked);
    }
    assert_eq!(merge_garbage(whole.clone()), merge_garbage(chunked));
    for ack in whole.iter().flatten() {
        let bytes = ack.encode().expect("decoded values are finite");
        let again = AckDecoder::new().accept_omitted_check(true).next_after(&bytes);
        let again = again.expect("re-encoded ack decodes");
        assert_eq!((again.quit, again.be, again.status, again.error), (ack.quit, ack.be, ack.status, ack.error));
        assert_eq!(again.q_par, ack.q_par);
        if ack.check_rule != CheckRule::Omitted {
            assert_eq!(again.check_rule, ack.check_rule);
        }
    }

    // Commands and polls.
    let mut whole = Vec::new();
    let mut d = CommandDecoder::new().accept_omitted_check(omitted);
    d.push(stream);
    commands(&mut d, &mut whole);
    let mut chunked = Vec::new();
    let mut d = CommandDecoder::new().accept_omitted_check(omitted);
    for c in common::chunks(seed.rotate_left(3), stream) {
        d.push(c);
        commands(&mut d, &mut chunked);
    }
    assert_eq!(merge_garbage(whole.clone()), merge_garbage(chunked));
    for req in whole.iter().flatten() {
        if let Request::Command { command, check_rule } = req {
            let opts = EncodeOptions { check_rule: *check_rule, float_format: FloatFormat::Shortest };
            let mut bytes = Vec::new();
            command.encode_with(&opts, &mut bytes).expect("decoded values are finite");
            let (again, _) = Command::decode(&bytes).expect("re-encoded command decodes");
            assert_eq!(again, *command);
        }
    }

    // Frames built from the input round-trip exactly (shortest floats).
    let mut b = common::Bytes(stream);
    let ack = Ack {
        quit: b.u16(),
        be: b.bool(),
        status: b.u16(),
        error: b.u16(),
        q_par: par2(&mut b),
        check_rule: rule(b.u8()),
    };
    match ack.encode() {
        Ok(bytes) => {
            assert!(bytes.len() <= MAX_FRAME);
            let again = Ack::decode(&bytes).or_else(|_| {
                let mut d = AckDecoder::new().accept_omitted_check(true);
                d.push(&bytes);
                d.next().expect("a frame")
            });
            let again = again.expect("encoded ack decodes");
            assert_eq!(
                (again.quit, again.be, again.status, again.error, again.q_par),
                (ack.quit, ack.be, ack.status, ack.error, ack.q_par)
            );
        }
        Err(_) => assert!(!ack.q_par.as_f64().is_finite()),
    }
    let command = Command::new(b.u16(), b.u64() as i64, par2(&mut b));
    let opts = EncodeOptions { check_rule: rule(b.u8()), float_format: FloatFormat::Shortest };
    let mut bytes = Vec::new();
    match command.encode_with(&opts, &mut bytes) {
        Ok(()) => {
            assert!(bytes.len() <= MAX_FRAME);
            assert_eq!(Command::decode(&bytes).expect("encoded command decodes").0, command);
        }
        Err(_) => assert!(!command.par2.as_f64().is_finite()),
    }
});

trait NextAfter {
    fn next_after(self, bytes: &[u8]) -> Result<Ack, FrameError>;
}

impl NextAfter for AckDecoder {
    fn next_after(mut self, bytes: &[u8]) -> Result<Ack, FrameError> {
        self.push(bytes);
        let r = self.next().expect("one complete frame");
        assert_eq!(self.buffered(), 0);
        r
    }
}
