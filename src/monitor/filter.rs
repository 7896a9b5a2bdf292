//! CAN id filters written as candump writes them: `ID:MASK` passes a frame
//! whose id, masked, equals ID masked; `ID~MASK` passes the others. An ID
//! of eight hex digits is an extended (29-bit) id. The comparison is the
//! kernel's CAN_RAW_FILTER one, on the id with the extended-frame flag, so
//! a mask without that flag (`0E0:7F0`) passes standard and extended
//! frames alike, as candump does.

use crate::proto::CanFrame;

/// The extended-frame flag of a SocketCAN id (`CAN_EFF_FLAG`).
const EFF: u32 = 0x8000_0000;
/// The flags a filter may name: extended frame and the 29 id bits.
const MASKABLE: u32 = EFF | 0x1FFF_FFFF;

/// One `ID:MASK` or `ID~MASK`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdFilter {
    id: u32,
    mask: u32,
    inverted: bool,
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is no CAN filter: write ID:MASK (pass) or ID~MASK (drop), in hex, as candump does (0E0:7F0)")]
pub struct FilterError(pub String);

impl std::str::FromStr for IdFilter {
    type Err = FilterError;

    fn from_str(text: &str) -> Result<Self, FilterError> {
        let bad = || FilterError(text.to_string());
        let (id_text, mask_text, inverted) = match (text.split_once(':'), text.split_once('~')) {
            (Some((i, m)), None) => (i, m, false),
            (None, Some((i, m))) => (i, m, true),
            _ => return Err(bad()),
        };
        let hex = |t: &str| {
            let t = t.trim_start_matches("0x");
            (!t.is_empty() && t.len() <= 8).then(|| u32::from_str_radix(t, 16).ok()).flatten()
        };
        let (Some(id), Some(mask)) = (hex(id_text), hex(mask_text)) else { return Err(bad()) };
        let extended = id_text.trim_start_matches("0x").len() == 8;
        let id = if extended { (id & 0x1FFF_FFFF) | EFF } else { id };
        Ok(Self { id, mask: mask & MASKABLE, inverted })
    }
}

impl IdFilter {
    /// Whether `frame` passes this one filter.
    pub fn passes(&self, frame: &CanFrame) -> bool {
        let received = frame.id() | if frame.is_extended() { EFF } else { 0 };
        ((received & self.mask) == (self.id & self.mask)) != self.inverted
    }
}

/// Whether `frame` passes a list of filters: any of them (none: every frame).
pub fn passes_any(filters: &[IdFilter], frame: &CanFrame) -> bool {
    filters.is_empty() || filters.iter().any(|f| f.passes(frame))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(text: &str) -> CanFrame {
        text.parse().unwrap()
    }

    #[test]
    fn id_and_mask_pass_as_the_kernel_compares_them() {
        let f: IdFilter = "0E0:7F0".parse().unwrap();
        for (text, passes) in [("0E3#01", true), ("0EF#", true), ("0F1#01", false), ("0A3#01", false)] {
            assert_eq!(f.passes(&frame(text)), passes, "{text}");
        }
        // Without the extended flag in the mask, an extended id with the
        // same low bits passes too; with it, only the standard one.
        assert!(f.passes(&frame("000000E3#01")));
        let strict: IdFilter = "0E0:800007F0".parse().unwrap();
        assert!(strict.passes(&frame("0E3#01")) && !strict.passes(&frame("000000E3#01")));
        let ext: IdFilter = "000000E0:800007F0".parse().unwrap();
        assert!(!ext.passes(&frame("0E3#01")) && ext.passes(&frame("000000E3#01")));
    }

    #[test]
    fn an_inverted_filter_passes_the_others_and_a_list_passes_any() {
        let drop: IdFilter = "100~7FF".parse().unwrap();
        assert!(!drop.passes(&frame("100#0700")) && drop.passes(&frame("0E3#01")));
        let list: Vec<IdFilter> = ["0A0:7E0", "100:7FF"].iter().map(|t| t.parse().unwrap()).collect();
        assert!(passes_any(&list, &frame("0B1#01")) && passes_any(&list, &frame("100#0700")));
        assert!(!passes_any(&list, &frame("0E3#01")));
        assert!(passes_any(&[], &frame("0E3#01")), "no filter passes everything");
    }

    #[test]
    fn what_is_no_filter_is_refused() {
        for bad in ["", "0E0", "0E0:", ":7F0", "0E0:7F0~1", "xyz:7F0", "0E0:123456789", "0E0;7F0"] {
            assert!(bad.parse::<IdFilter>().is_err(), "{bad}");
        }
    }
}
