//! `candump -l` log lines: `(1700000000.123456) can0 0F1#01`, as written by
//! can-utils and by axisctl's `--log`. Newer can-utils may append a direction
//! flag (` R` / ` T`); it is accepted and ignored. Remote (`123#R`) and CAN FD
//! (`123##1...`) frames are rejected: axisctl's devices use neither.

use super::can_error::{CanEvent, ErrorFrame};
use super::{CanFrame, DecodeError};

/// Formats one log line (no newline) the way `candump -l` does.
pub fn format_candump_line(secs: u64, micros: u32, iface: &str, frame: &CanFrame) -> String {
    format!("({secs}.{micros:06}) {iface} {frame}")
}

/// Parses one log line into (timestamp in seconds, interface, frame).
pub fn parse_candump_line(line: &str) -> Result<(f64, String, CanFrame), DecodeError> {
    let bad = |why: &str| DecodeError::Malformed(format!("candump line {line:?}: {why}"));
    let line = line.trim_end_matches(['\r', '\n']);
    let mut fields = line.split_ascii_whitespace();
    let stamp = fields.next().ok_or_else(|| bad("empty"))?;
    let stamp = stamp.strip_prefix('(').and_then(|s| s.strip_suffix(')')).ok_or_else(|| bad("no (timestamp)"))?;
    let (secs, frac) = stamp.split_once('.').ok_or_else(|| bad("timestamp without fraction"))?;
    let digits = |s: &str| !s.is_empty() && s.len() <= 18 && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(secs) || !digits(frac) {
        return Err(bad("timestamp is not seconds.fraction"));
    }
    let timestamp: f64 = stamp.parse().map_err(|_| bad("timestamp is not a number"))?;
    let iface = fields.next().ok_or_else(|| bad("no interface"))?;
    let frame_text = fields.next().ok_or_else(|| bad("no frame"))?;
    match fields.next() {
        None | Some("R" | "T") => {}
        Some(_) => return Err(bad("trailing text")),
    }
    if fields.next().is_some() {
        return Err(bad("trailing text"));
    }
    let frame = frame_text.parse::<CanFrame>()?;
    Ok((timestamp, iface.to_string(), frame))
}

/// [`parse_candump_line`], and error frames too (`candump -e -L` writes
/// them as an extended id with the error flag, `20000004#0004...`).
pub fn parse_candump_event(line: &str) -> Result<(f64, String, CanEvent), DecodeError> {
    let frame_text = line.split_ascii_whitespace().nth(2).unwrap_or("");
    match ErrorFrame::parse_candump(frame_text) {
        None => parse_candump_line(line).map(|(t, i, f)| (t, i, CanEvent::Frame(f))),
        Some(error) => {
            let error = error?;
            // The rest of the line as a data frame's, so both are checked alike.
            let (t, i, _) = parse_candump_line(&line.replacen(frame_text, "000#", 1))?;
            Ok((t, i, CanEvent::Error(error)))
        }
    }
}

/// An error frame's log line, the way `candump -l -e` writes it.
pub fn format_candump_error(secs: u64, micros: u32, iface: &str, frame: &ErrorFrame) -> String {
    format!("({secs}.{micros:06}) {iface} {frame}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn parses_the_contract_example() {
        // cli-contract.md, --log: `(1700000000.123456) can0 0F1#01`
        let (t, iface, f) = parse_candump_line("(1700000000.123456) can0 0F1#01").unwrap();
        assert!((t - 1_700_000_000.123456).abs() < 1e-6);
        assert_eq!(iface, "can0");
        assert_eq!(f, CanFrame::new(0x0F1, &[1]).unwrap());
        assert_eq!(format_candump_line(1_700_000_000, 123_456, "can0", &f), "(1700000000.123456) can0 0F1#01");
        assert_eq!(format_candump_line(5, 7, "slcan0", &f), "(5.000007) slcan0 0F1#01");
    }

    #[test]
    fn accepts_extended_empty_and_direction() {
        let (_, _, f) = parse_candump_line("(0.000001) vcan0 12345678#DEADBEEF R\n").unwrap();
        assert_eq!(f, CanFrame::new_extended(0x1234_5678, &[0xde, 0xad, 0xbe, 0xef]).unwrap());
        let (_, _, f) = parse_candump_line("(1.5) can1 100#").unwrap();
        assert_eq!(f.dlc(), 0);
    }

    #[test]
    fn error_frames_are_read_from_a_log() {
        let (t, iface, e) = parse_candump_event("(1.500000) can0 20000040#0000000000000000").unwrap();
        assert_eq!((t, iface.as_str()), (1.5, "can0"));
        let CanEvent::Error(e) = e else { panic!("an error frame: {e:?}") };
        assert_eq!(e.problems(), ["bus off"]);
        assert_eq!(format_candump_error(1, 500_000, "can0", &e), "(1.500000) can0 20000040#0000000000000000");
        assert!(matches!(parse_candump_event("(1.5) can0 0F1#01").unwrap().2, CanEvent::Frame(_)));
        assert!(parse_candump_event("(1.5) can0 20000040#000").is_err());
        assert!(parse_candump_event("(x) can0 20000040#00").is_err());
        assert!(parse_candump_event("").is_err());
    }

    #[test]
    fn rejects_bad_lines() {
        for bad in [
            "",
            "can0 0F1#01",
            "(1700000000.123456)",
            "(1700000000.123456) can0",
            "(abc.def) can0 0F1#01",
            "(1700000000) can0 0F1#01",
            "(1.2) can0 123#R",
            "(1.2) can0 123##1DEAD",
            "(1.2) can0 0F1#01 X",
            "(1.2) can0 0F1#01 R extra",
            "(-1.2) can0 0F1#01",
        ] {
            assert!(parse_candump_line(bad).is_err(), "{bad:?}");
        }
    }

    proptest! {
        #[test]
        fn never_panics(s in "\\PC{0,60}") {
            let _ = parse_candump_line(&s);
        }

        #[test]
        fn round_trip(secs in 0u64..4_000_000_000, micros in 0u32..1_000_000, ext in any::<bool>(),
                      id in any::<u32>(), data in proptest::collection::vec(any::<u8>(), 0..=8)) {
            let f = if ext { CanFrame::new_extended(id & 0x1FFF_FFFF, &data) } else { CanFrame::new(id & 0x7FF, &data) }
                .unwrap();
            let line = format_candump_line(secs, micros, "can0", &f);
            let (t, iface, g) = parse_candump_line(&line).unwrap();
            prop_assert_eq!(g, f);
            prop_assert_eq!(iface, "can0");
            prop_assert!((t - (secs as f64 + f64::from(micros) / 1e6)).abs() < 1e-5);
        }
    }
}
