//! The passive bus monitor on arbitrary frames. Invariants: no panic; the
//! family follows the id ranges of the module docs; the JSON form always
//! serializes; statistics count every frame.
#![no_main]

use axisctl::family::Family;
use axisctl::monitor::{describe, Stats};
use axisctl::proto::CanFrame;
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let mut b = common::Bytes(data);
    let mut stats = Stats::default();
    let mut frames = 0;
    // A few frames per input keep the rate high; the corpus covers the rest.
    while !b.0.is_empty() && frames < 8 {
        let head = b.u16();
        let extended = head & 0x8000 != 0;
        let len = usize::from(head >> 11 & 0xF).min(8);
        let payload = b.take(len);
        let frame = if extended {
            CanFrame::new_extended((u32::from(head & 0x7FF) << 18) | u32::from(b.u16()), payload)
        } else {
            CanFrame::new(u32::from(head & 0x7FF), payload)
        }
        .expect("ids and lengths in range");
        let info = describe(&frame);
        let id = frame.id();
        // `None`: a frame of no family.
        let expected = if frame.is_extended() {
            None
        } else if id == 0x100 || ((0x0A1..=0x0FF).contains(&id) && id & 0x1F != 0) {
            Some(Family::PowerCube)
        } else if id == 0x000 || (0x181..=0x1FF).contains(&id) || (0x201..=0x27F).contains(&id) {
            Some(Family::Cdios)
        } else {
            None
        };
        // PowerCube ids whose base is not a PowerCube base are not ours.
        if !(expected == Some(Family::PowerCube) && info.family.is_none()) {
            assert_eq!(info.family, expected, "{frame} described as {info:?}");
        }
        if info.family.is_none() {
            assert_eq!(info.kind, "raw");
        }
        serde_json::to_string(&info).expect("FrameInfo serializes");
        stats.add(&frame, &info);
        frames += 1;
    }
    assert_eq!(stats.frames, frames);
    assert!(stats.errors <= stats.frames);
});
