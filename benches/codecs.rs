//! Encode and decode time per frame for every protocol (`cargo bench --bench codecs`).
//!
//! Each benchmark handles one frame the way a session does: a request
//! encoded into a reused buffer, an answer decoded from the bytes a link
//! would hand over. Names are read by `scripts/bench.sh`.

use std::hint::black_box;

use axisctl::proto::cdios::{self, Address, Command as CdiosCommand, NodeId, PositionSource};
use axisctl::proto::pac::frame::EncodeOptions;
use axisctl::proto::pac::{Ack, AckDecoder, CheckRule, Command as PacCommand, Par2};
use axisctl::proto::powercube::can as pc_can;
use axisctl::proto::powercube::rs232::{self, Direction};
use axisctl::proto::powercube::table::ids;
use axisctl::proto::powercube::{ModuleId, Request, Response};
use axisctl::proto::slcan::{self, LineDecoder};
use axisctl::proto::CanFrame;
use criterion::{criterion_group, criterion_main, Criterion};

fn powercube(c: &mut Criterion) {
    let m = ModuleId::new(3).unwrap();
    let req = Request::GetExtended { param: ids::ACT_POS };
    // An ActPos answer: GetExtended, ActPos, 0.75 as float.
    let ack = CanFrame::new(0x0A3, &[0x0A, ids::ACT_POS, 0x00, 0x00, 0x40, 0x3F]).unwrap();
    c.bench_function("powercube/can_encode", |b| b.iter(|| pc_can::request_frame(black_box(m), black_box(&req))));
    c.bench_function("powercube/can_decode", |b| {
        b.iter(|| pc_can::ack_from(black_box(m), black_box(&ack)).unwrap().unwrap())
    });

    let mut out = Vec::with_capacity(32);
    c.bench_function("powercube/rs232_encode", |b| {
        b.iter(|| {
            out.clear();
            rs232::encode_request(black_box(3), black_box(&req), &mut out);
            out.len()
        })
    });
    let resp = Response::decode(ack.data()).unwrap();
    let mut wire = Vec::new();
    rs232::encode_response(3, &resp, &mut wire);
    let mut dec = rs232::Decoder::new();
    c.bench_function("powercube/rs232_decode", |b| {
        b.iter(|| {
            dec.push(black_box(&wire));
            let f = dec.next_frame().unwrap().unwrap();
            assert_eq!(f.dir, Direction::FromModule);
            f.response().unwrap()
        })
    });
}

fn pac(c: &mut Criterion) {
    // get-actual-pos of axis 3 (manual 5.2.4.18) and an acknowledge carrying a position.
    let cmd = PacCommand::new(0x190C, 3, Par2::Float(0.0));
    let opts = EncodeOptions::default();
    let mut out = Vec::with_capacity(32);
    c.bench_function("pac/command_encode", |b| {
        b.iter(|| {
            out.clear();
            black_box(&cmd).encode_with(&opts, &mut out).unwrap();
            out.len()
        })
    });
    let ack =
        Ack { quit: 0, be: true, status: 31, error: 0, q_par: Par2::Float(2000.5), check_rule: CheckRule::default() }
            .encode()
            .unwrap();
    let mut dec = AckDecoder::new();
    c.bench_function("pac/ack_decode", |b| {
        b.iter(|| {
            dec.push(black_box(&ack));
            dec.next().unwrap().unwrap()
        })
    });
}

fn cdios(c: &mut Criterion) {
    let node = NodeId::new(1).unwrap();
    let addr = Address::Module(cdios::ModuleId::new(0).unwrap());
    let cmd = CdiosCommand::ReadPosition(PositionSource::Current);
    c.bench_function("cdios/command_encode", |b| b.iter(|| black_box(&cmd).frame(black_box(node), addr).unwrap()));
    // 21h reply from node 1 module 0: position -1200 (the manual's reply layout).
    let answer = CanFrame::new(0x181, &[0x21, 0, 0, 0x50, 0xFB, 0xFF, 0xFF, 0]).unwrap();
    c.bench_function("cdios/answer_decode", |b| {
        b.iter(|| {
            let a = cdios::Answer::from_frame(black_box(&answer)).unwrap().unwrap();
            a.reply().unwrap().unwrap().get("position")
        })
    });
}

fn slcan_lines(c: &mut Criterion) {
    let f = CanFrame::new(0x0E3, &[0x0A, ids::ACT_POS]).unwrap();
    let mut out = Vec::with_capacity(32);
    c.bench_function("slcan/frame_encode", |b| {
        b.iter(|| {
            out.clear();
            slcan::encode_frame(black_box(&f), &mut out);
            out.len()
        })
    });
    let ack = CanFrame::new(0x0A3, &[0x0A, ids::ACT_POS, 0x00, 0x00, 0x40, 0x3F]).unwrap();
    let mut line = Vec::new();
    slcan::encode_frame(&ack, &mut line);
    let mut dec = LineDecoder::new();
    c.bench_function("slcan/frame_decode", |b| {
        b.iter(|| {
            dec.push(black_box(&line));
            dec.next_event().unwrap().unwrap()
        })
    });
}

criterion_group!(codecs, powercube, pac, cdios, slcan_lines);
criterion_main!(codecs);
