//! PowerCube CAN frames (manual 4.1, 4.4, 4.5): classification, command and
//! acknowledge payloads, parameter values. Invariants: no panic; whatever
//! classifies re-encodes to the very same frame; every decoded payload
//! re-encodes to its bytes.
#![no_main]

use axisctl::proto::powercube::can::{self, Broadcast, CanMessage};
use axisctl::proto::powercube::frame::Value;
use axisctl::proto::powercube::table::ParamType;
use axisctl::proto::powercube::{ModuleId, Request, Response};
use axisctl::proto::CanFrame;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const TYPES: [ParamType; 8] = [
    ParamType::Float,
    ParamType::Int32,
    ParamType::UInt32,
    ParamType::Int16,
    ParamType::UInt16,
    ParamType::UInt8,
    ParamType::FloatStateDio,
    ParamType::FloatTime,
];

fuzz_target!(|data: &[u8]| {
    let mut b = common::Bytes(data);
    let raw_id = b.u16();
    let extended = raw_id & 0x8000 != 0;
    let payload = b.take(8);
    let frame = if extended {
        CanFrame::new_extended(u32::from(raw_id & 0x7FF), payload)
    } else {
        CanFrame::new(u32::from(raw_id & 0x7FF), payload)
    }
    .expect("id and length in range");

    match can::classify(&frame) {
        Ok(Some(CanMessage::Request { module, request })) => {
            let encoded = can::request_frame(module, &request);
            assert_eq!(encoded.id(), frame.id());
            assert_round_trip(&request, encoded.data(), frame.data());
        }
        Ok(Some(CanMessage::Ack { module, response })) => {
            assert_eq!(can::ack_frame(module, &response), frame);
            assert_eq!(can::ack_from(module, &frame), Some(Ok(response)));
        }
        Ok(Some(CanMessage::Broadcast(bc))) => {
            assert_eq!(Broadcast::decode(&bc.payload()), Ok(bc));
            assert_eq!(Broadcast::decode(bc.frame().data()), Ok(bc));
        }
        Ok(None) | Err(_) => {}
    }
    if let Some(m) = ModuleId::new((raw_id >> 11) as u8 & 0x1F) {
        let _ = can::ack_from(m, &frame);
    }

    // The payload alone, as either side would read it.
    if let Ok(req) = Request::decode(payload) {
        assert_round_trip(&req, req.to_payload().as_slice(), payload);
        let _ = req.is_motion();
        if let Ok(resp) = Response::decode(payload) {
            let _ = req.matches(&resp);
        }
    }
    if let Ok(resp) = Response::decode(payload) {
        assert_eq!(resp.to_payload().as_slice(), payload);
    }
    for ty in TYPES {
        match Value::decode(ty, payload) {
            Ok(v) => {
                assert_eq!(payload.len(), ty.size());
                assert_eq!(v.ty(), ty);
                assert_eq!(v.to_payload().as_slice(), payload);
                let _ = v.to_string();
                let _ = v.as_f64();
            }
            Err(_) => assert_ne!(payload.len(), ty.size(), "{ty:?} of the right size must decode"),
        }
    }
});

/// A decoded request encodes back to the bytes it came from, except for the
/// zeros the vendor library pads GetExtended with to 8 bytes: the padding is
/// read past, nothing else is.
fn assert_round_trip(req: &Request, encoded: &[u8], got: &[u8]) {
    if matches!(req, Request::GetExtended { .. }) {
        assert!(got.starts_with(encoded), "{got:02x?}");
        assert!(got[encoded.len()..].iter().all(|b| *b == 0), "{got:02x?}");
    } else {
        assert_eq!(encoded, got);
    }
}
