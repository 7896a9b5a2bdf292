//! Cdios 6168 messages on CAN: bus classification, answers (reply / event /
//! error), commands as a module receives them, motor status. Invariants: no
//! panic; a command that decodes and validates re-encodes (typed and through
//! the table) to bytes that decode to the same command; error replies
//! round-trip.
#![no_main]

use axisctl::proto::cdios::table::{self, Kind};
use axisctl::proto::cdios::transport::{self, Answer, ErrorReply};
use axisctl::proto::cdios::{decode_status, Command, NodeId};
use axisctl::proto::CanFrame;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let mut b = common::Bytes(data);
    let raw_id = b.u16();
    let payload = b.take(8);
    let frame = CanFrame::new(u32::from(raw_id & 0x7FF), payload).expect("standard id, <= 8 bytes");
    let _ = transport::classify(&frame);
    if let Ok(Some(a)) = Answer::from_frame(&frame) {
        assert_eq!(a.dlc as usize, payload.len());
        match (a.reply(), a.error()) {
            (Some(_), None) => {}
            (None, Some(e)) => {
                let _ = e.describe();
                assert_eq!(ErrorReply::decode(&e.to_data()).map(|x| x.to_data()), Ok(e.to_data()));
            }
            other => panic!("an answer is a reply or an error, not {other:?}"),
        }
    }
    if let Some(node) = NodeId::new((raw_id >> 11) as u8 | 1) {
        let _ = Answer::from_data(node, payload);
    }

    if let Ok(e) = ErrorReply::decode(payload) {
        let _ = (e.flags(), e.unknown_bits(), e.general_error(), e.describe());
        assert_eq!(ErrorReply::decode(&e.to_data()), Ok(e));
    }
    if let Ok(r) = table::decode_reply(payload) {
        if let Some(def) = r.def {
            let values: Vec<(&str, i64)> = r
                .fields
                .iter()
                .zip(def.reply.fields)
                .filter(|(_, f)| !matches!(f.kind, Kind::Const(_)))
                .map(|(v, _)| (v.key, v.raw))
                .collect();
            if let Ok(bytes) = table::encode_reply(def, r.module, r.selector, &values) {
                let again = table::decode_reply(&bytes).expect("encoded reply decodes");
                if again.def.map(|d| d.key) == Some(def.key) {
                    assert_eq!(again.fields, r.fields);
                }
            }
        }
    }
    if payload.len() >= 4 {
        let st = decode_status([payload[0], payload[1], payload[2], payload[3]]);
        assert!(st.errors.iter().all(|e| st.flags.contains(e)));
    }

    // A command as the module reads it.
    if let Ok(d) = table::decode_command(payload) {
        if d.validate().is_ok() {
            let values: Vec<(&str, i64)> = d
                .fields
                .iter()
                .zip(d.def.fields)
                .filter(|(_, f)| !matches!(f.kind, Kind::Const(_)))
                .map(|(v, _)| (v.key, v.raw))
                .collect();
            let bytes = table::encode(d.def, d.address, d.selector, &values).expect("valid command re-encodes");
            let again = table::decode_command(&bytes).expect("encoded command decodes");
            assert_eq!((again.def.key, again.address, again.selector), (d.def.key, d.address, d.selector));
            assert_eq!(again.fields, d.fields);
        }
    }
    if let Ok((address, cmd)) = Command::decode(payload) {
        let bytes = cmd.encode(address).expect("a decoded command encodes");
        assert_eq!(Command::decode(&bytes), Ok((address, cmd)));
        let _ = (cmd.def(), cmd.selector(), cmd.reply_code());
    }
});
