//! `candump -l` log lines and the candump frame form `ID#DATA`.
//! Invariants: no panic; an accepted line formats back to a line that parses
//! to the same interface and frame, and the same time to the microsecond.
#![no_main]

use axisctl::proto::candump::{format_candump_line, parse_candump_line};
use axisctl::proto::CanFrame;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok((t, iface, frame)) = parse_candump_line(&text) {
        assert!(t.is_finite() && t >= 0.0);
        assert!(!iface.is_empty());
        // Whole seconds and microseconds from the stamp as written.
        let stamp = text.trim_start().strip_prefix('(').and_then(|s| s.split_once(')')).map(|(s, _)| s);
        let (secs, frac) = stamp.and_then(|s| s.split_once('.')).expect("accepted stamps are secs.frac");
        if let Ok(secs) = secs.parse::<u64>() {
            let micros: u32 = format!("{frac:0<6}")[..6].parse().expect("digits");
            let line = format_candump_line(secs, micros, &iface, &frame);
            let (t2, iface2, frame2) = parse_candump_line(&line).expect("formatted line parses");
            assert_eq!((iface2, frame2), (iface, frame));
            assert!((t2 - t).abs() <= 1e-6 * t.max(1.0), "{t} vs {t2}");
        }
    }
    if let Ok(frame) = text.parse::<CanFrame>() {
        assert!(frame.dlc() <= 8);
        assert_eq!(frame.to_string().parse::<CanFrame>(), Ok(frame));
    }
});
