//! Session + codec overhead per transaction on the in-process links
//! (`cargo bench --bench session`; goal < 5 µs).
//!
//! The far end is a trivial responder that hands back a prepared answer, so
//! the figure is what a session costs (encode, send, match, decode, deadline
//! bookkeeping), not what a simulator costs. Real clock, no tracer, as the
//! binary runs.

use std::sync::Arc;
use std::time::Instant;

use axisctl::clock::{Clock, SystemClock};
use axisctl::link::mem::{ByteDevice, CanDevice, MemBus, MemByteLink};
use axisctl::link::SerialFormat;
use axisctl::proto::cdios::{self, NodeId, PositionSource};
use axisctl::proto::pac::{Ack, CheckRule, Command as PacCommand, Par2};
use axisctl::proto::powercube::rs232;
use axisctl::proto::powercube::table::{self, ids};
use axisctl::proto::powercube::{can as pc_can, ModuleId, Response};
use axisctl::proto::CanFrame;
use axisctl::session::cdios::Cdios;
use axisctl::session::pac::Pac;
use axisctl::session::powercube::PowerCube;
use criterion::{criterion_group, criterion_main, Criterion};

/// Answers every frame with the same frame.
struct CanResponder(CanFrame);

impl CanDevice for CanResponder {
    fn on_frame(&mut self, _now: Instant, _frame: &CanFrame, out: &mut Vec<CanFrame>) {
        out.push(self.0);
    }
}

/// Answers every write with the same bytes.
struct ByteResponder(Vec<u8>);

impl ByteDevice for ByteResponder {
    fn on_bytes(&mut self, _now: Instant, _bytes: &[u8], out: &mut Vec<u8>) {
        out.extend_from_slice(&self.0);
    }
}

fn clock() -> Arc<dyn Clock> {
    Arc::new(SystemClock)
}

/// ActPos of module 3 reads 0.75.
fn act_pos_answer() -> Response {
    Response::decode(&[0x0A, ids::ACT_POS, 0x00, 0x00, 0x40, 0x3F]).unwrap()
}

fn powercube(c: &mut Criterion) {
    let m = ModuleId::new(3).unwrap();
    let act_pos = table::param(ids::ACT_POS).unwrap();

    let bus = MemBus::new(clock());
    bus.attach(Box::new(CanResponder(pc_can::ack_frame(m, &act_pos_answer()))));
    let mut pc = PowerCube::over_can(Box::new(bus.open()));
    c.bench_function("session/powercube_can_get", |b| b.iter(|| pc.get(m, act_pos).unwrap()));

    let mut wire = Vec::new();
    rs232::encode_response(3, &act_pos_answer(), &mut wire);
    let link = MemByteLink::new(Box::new(ByteResponder(wire)), clock());
    let mut pc = PowerCube::over_rs232(Box::new(link), 9600);
    c.bench_function("session/powercube_rs232_get", |b| b.iter(|| pc.get(m, act_pos).unwrap()));
}

fn pac(c: &mut Criterion) {
    let ack =
        Ack { quit: 0, be: true, status: 31, error: 0, q_par: Par2::Float(2000.5), check_rule: CheckRule::default() }
            .encode()
            .unwrap();
    let link = MemByteLink::new(Box::new(ByteResponder(ack)), clock());
    let mut pac = Pac::new(Box::new(link), 9600, SerialFormat::F7N1);
    let cmd = PacCommand::new(0x190C, 3, Par2::Float(0.0));
    c.bench_function("session/pac_get", |b| b.iter(|| pac.transact(&cmd).unwrap()));
}

fn cdios(c: &mut Criterion) {
    let node = NodeId::new(1).unwrap();
    let module = cdios::ModuleId::new(0).unwrap();
    let bus = MemBus::new(clock());
    bus.attach(Box::new(CanResponder(CanFrame::new(0x181, &[0x21, 0, 0, 0x50, 0xFB, 0xFF, 0xFF, 0]).unwrap())));
    let mut cd = Cdios::new(Box::new(bus.open()));
    cd.set_nmt(false);
    c.bench_function("session/cdios_read_position", |b| {
        b.iter(|| cd.read_position(node, module, PositionSource::Current).unwrap())
    });
}

criterion_group!(session, powercube, pac, cdios);
criterion_main!(session);
