//! The controller's own limits for the online speed and acceleration
//! (0A8D / 0A8E): the min / max of axis parameters 1 and 6. The manual lets
//! them be read (1802 / 1801) only in home position, and 0A8D / 0A8E are
//! valid only online, so they are read on the way online and kept: by the
//! [`Controller`](super::Controller) that went online, and by whoever stores
//! the text form ([`OnlineLimits::to_text`]) for the next process.

use std::collections::BTreeMap;

use crate::proto::pac::table;

/// Axis parameter limiting 0A8D (traverse speed).
const SPEED_PARAM: u8 = 1;
/// Axis parameter limiting 0A8E (acceleration).
const ACCEL_PARAM: u8 = 6;
/// First line of the text form: text without it is not ours.
const MAGIC: &str = "axisctl-pac-limits 1";
/// Axes times two limits, a line each: anything longer is not ours.
const MAX_LINES: usize = 2 * table::MAX_AXES as usize + 1;

/// (min, max) by axis parameter PAR_1 (axis * 256 + 1 or 6).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OnlineLimits(pub(super) BTreeMap<i64, (f64, f64)>);

/// The axis parameter that limits `code` (0A8D, 0A8E), with its word for messages.
pub(super) fn limiting_param(code: u16) -> Option<(u8, &'static str)> {
    match code {
        0x0A8D => Some((SPEED_PARAM, "speed")),
        0x0A8E => Some((ACCEL_PARAM, "acceleration")),
        _ => None,
    }
}

/// The parameters to read for an axis on the way online.
pub(super) const PARAMS: [u8; 2] = [SPEED_PARAM, ACCEL_PARAM];

impl OnlineLimits {
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// (min, max) of `code`'s value for `axis`, if read.
    pub fn of(&self, code: u16, axis: u8) -> Option<(f64, f64)> {
        let (param, _) = limiting_param(code)?;
        self.0.get(&table::axis_param_par1(axis, param)).copied()
    }

    /// The axes with a limit known.
    pub fn axes(&self) -> Vec<u8> {
        let mut axes: Vec<u8> =
            self.0.keys().filter_map(|p| table::split_axis_param_par1(*p)).map(|(a, _)| a).collect();
        axes.dedup();
        axes
    }

    pub(super) fn insert(&mut self, axis: u8, param: u8, min: f64, max: f64) {
        self.0.insert(table::axis_param_par1(axis, param), (min, max));
    }

    /// One line per limit: `PAR_1 min max`.
    pub fn to_text(&self) -> String {
        let mut s = format!("{MAGIC}\n");
        for (par1, (min, max)) in &self.0 {
            s.push_str(&format!("{par1} {min} {max}\n"));
        }
        s
    }

    /// Reads the text form back. `None` for anything that is not exactly
    /// what [`to_text`](Self::to_text) writes (a limit wrongly read would
    /// refuse good values or pass bad ones); never panics.
    pub fn parse(text: &str) -> Option<Self> {
        let mut lines = text.lines();
        if lines.next()? != MAGIC || text.lines().count() > MAX_LINES {
            return None;
        }
        let mut limits = Self::default();
        for line in lines {
            let mut words = line.split(' ');
            let par1: i64 = words.next()?.parse().ok()?;
            let min: f64 = words.next()?.parse().ok()?;
            let max: f64 = words.next()?.parse().ok()?;
            let (axis, param) = table::split_axis_param_par1(par1)?;
            let sane = words.next().is_none() && min.is_finite() && max.is_finite() && min <= max;
            if !sane || !PARAMS.contains(&param) || !(1..=table::MAX_AXES).contains(&axis) {
                return None;
            }
            limits.insert(axis, param, min, max);
        }
        Some(limits)
    }
}

/// Why `value` is refused for `code` on `axis`, if it is: outside the limits
/// read from the controller. Unknown limits refuse nothing (the controller
/// checks, QUIT 0x29).
pub(super) fn check(limits: &OnlineLimits, code: u16, axis: i64, value: Option<f64>) -> Option<String> {
    let (_, what) = limiting_param(code)?;
    let (axis, v) = (u8::try_from(axis).ok()?, value?);
    let (min, max) = limits.of(code, axis)?;
    (!(min..=max).contains(&v)).then(|| {
        format!(
            "{what} {v} is outside axis {axis}'s limits {min} to {max} (axis parameter {}, read when it went online); nothing was sent",
            limiting_param(code).map_or(0, |p| p.0)
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> OnlineLimits {
        let mut l = OnlineLimits::default();
        l.insert(1, 1, 0.1, 50_000.0);
        l.insert(1, 6, 1.0, 100_000.0);
        l.insert(3, 1, 2.5, 7.0);
        l
    }

    #[test]
    fn text_round_trips() {
        let l = sample();
        assert_eq!(OnlineLimits::parse(&l.to_text()), Some(l.clone()));
        assert_eq!(l.axes(), [1, 3]);
        assert_eq!(OnlineLimits::parse(&OnlineLimits::default().to_text()), Some(OnlineLimits::default()));
        assert!(OnlineLimits::default().is_empty() && !l.is_empty());
    }

    /// The largest file `to_text` writes (both limits of every axis the
    /// controller can have) reads back: the line ceiling refuses only more.
    #[test]
    fn the_limits_of_every_axis_read_back() {
        let mut l = OnlineLimits::default();
        for axis in 1..=table::MAX_AXES {
            for param in PARAMS {
                l.insert(axis, param, f64::from(axis), 1000.0 * f64::from(param));
            }
        }
        assert_eq!(l.to_text().lines().count(), 2 * usize::from(table::MAX_AXES) + 1);
        assert_eq!(OnlineLimits::parse(&l.to_text()), Some(l.clone()));
        assert_eq!(OnlineLimits::parse(&format!("{}257 1 2\n", l.to_text())), None, "one line more");
    }

    #[test]
    fn anything_else_is_refused() {
        for bad in [
            "",
            "axisctl-pac-limits 2\n",
            "axisctl-pac-limits 1\n257 x 3\n",
            "axisctl-pac-limits 1\n257 1\n",
            "axisctl-pac-limits 1\n257 1 2 3\n",
            "axisctl-pac-limits 1\n258 1 2\n",   // parameter 2 limits nothing here
            "axisctl-pac-limits 1\n4353 1 2\n",  // axis 17
            "axisctl-pac-limits 1\n257 5 2\n",   // min above max
            "axisctl-pac-limits 1\n257 NaN 2\n", // not finite
            "axisctl-pac-limits 1\n257 1 inf\n", // not finite
            "axisctl-pac-limits 1\n-1 1 2\n",
        ] {
            assert_eq!(OnlineLimits::parse(bad), None, "{bad:?}");
        }
        let long = format!("{MAGIC}\n{}", "257 1 2\n".repeat(MAX_LINES));
        assert_eq!(OnlineLimits::parse(&long), None, "too long");
    }

    #[test]
    fn parse_never_panics() {
        use proptest::prelude::*;
        proptest!(|(s in "\\PC*", tail in proptest::collection::vec(any::<u8>(), 0..64))| {
            let _ = OnlineLimits::parse(&s);
            let text = format!("{MAGIC}\n{}", String::from_utf8_lossy(&tail));
            if let Some(l) = OnlineLimits::parse(&text) {
                prop_assert_eq!(OnlineLimits::parse(&l.to_text()), Some(l));
            }
        });
    }

    #[test]
    fn values_outside_the_limits_are_refused_inside_pass() {
        let l = sample();
        assert!(check(&l, 0x0A8D, 1, Some(1e9))
            .unwrap()
            .contains("speed 1000000000 is outside axis 1's limits 0.1 to 50000"));
        assert!(check(&l, 0x0A8D, 1, Some(0.05)).is_some());
        assert_eq!(check(&l, 0x0A8D, 1, Some(50_000.0)), None, "the maximum itself is allowed");
        assert_eq!(check(&l, 0x0A8D, 1, Some(0.1)), None, "the minimum itself is allowed");
        assert!(check(&l, 0x0A8E, 1, Some(100_001.0)).unwrap().contains("acceleration"));
        assert!(check(&l, 0x0A8D, 3, Some(8.0)).is_some(), "per axis");
        assert_eq!(check(&l, 0x0A8E, 3, Some(1e9)), None, "unknown limits refuse nothing");
        assert_eq!(check(&l, 0x0A8D, 2, Some(1e9)), None, "unknown axis");
        assert_eq!(check(&l, 0x0A86, 1, Some(1e9)), None, "other commands are not limited here");
    }
}
