//! The servo configuration of one 6168 (20h), kept as the table's field
//! values per set selector, so that set, read, defaults and EEPROM storage
//! all go through the one table in `proto::cdios::table`.

use crate::proto::cdios::table::{self, Kind, SERVO_CONFIGURATION};

/// Field values per set selector (0..4, 10h..17h, 20h..27h), defaults from the table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServoStore {
    parts: Vec<(u8, Vec<(&'static str, i64)>)>,
}

impl ServoStore {
    /// The manual's defaults ("Range Default Units" column); 0 where it gives none.
    pub fn defaults() -> Self {
        let mut parts = Vec::new();
        let rows = table::COMMANDS.iter().filter(|c| c.code == SERVO_CONFIGURATION && !c.fields.is_empty());
        for def in rows {
            for s in def.selectors {
                for sel in s.lo..=s.hi {
                    let values = def
                        .fields
                        .iter()
                        .filter(|f| !matches!(f.kind, Kind::Const(_)))
                        .map(|f| (f.key, f.default.unwrap_or(0)))
                        .collect();
                    parts.push((sel, values));
                }
            }
        }
        parts.sort_by_key(|p| p.0);
        Self { parts }
    }

    /// The values of set selector `sel`.
    pub fn values(&self, sel: u8) -> Option<&[(&'static str, i64)]> {
        self.parts.iter().find(|p| p.0 == sel).map(|p| p.1.as_slice())
    }

    pub fn get(&self, sel: u8, key: &str) -> i64 {
        self.values(sel).and_then(|v| v.iter().find(|(k, _)| *k == key)).map_or(0, |(_, v)| *v)
    }

    /// Replaces the values of `sel` that `values` names.
    pub fn set(&mut self, sel: u8, values: &[(&'static str, i64)]) {
        if let Some(part) = self.parts.iter_mut().find(|p| p.0 == sel) {
            for (k, v) in values {
                if let Some(slot) = part.1.iter_mut().find(|(pk, _)| pk == k) {
                    slot.1 = *v;
                }
            }
        }
    }
}

/// One traject (servo selectors 10h..17h or 20h..27h).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TrajectDef {
    pub end_position: i32,
    pub length: u8,
    pub initial_speed: u16,
    pub change_positions: [i32; 3],
    pub speeds: [u16; 3],
}

/// The configuration in the units the motor model uses, derived from a [`ServoStore`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    pub min_rpm: f64,
    pub max_rpm: f64,
    /// RPM per second: (max - min) over the slope time.
    pub accel: f64,
    pub max_mv: f64,
    pub forward_check: bool,
    pub reverse_check: bool,
    pub ppr: f64,
    pub hold_on_enable: bool,
    pub auto_zero: bool,
    pub sin2: bool,
    pub positioning_error: f64,
    pub ready_check: bool,
    pub error_check: bool,
    pub trajects: [TrajectDef; 2],
}

impl Params {
    pub fn from_store(s: &ServoStore) -> Self {
        let min_rpm = s.get(0, "minimum_speed").max(1) as f64;
        let max_rpm = (s.get(0, "maximum_speed") as f64).max(min_rpm);
        let slope_s = s.get(0, "slope").max(1) as f64 * 0.1;
        let span = (max_rpm - min_rpm).max(1.0);
        let traject = |t: u8| {
            let base = 0x10 * (t + 1);
            TrajectDef {
                end_position: s.get(base, "end_position") as i32,
                length: s.get(base, "length") as u8,
                initial_speed: s.get(base + 1, "initial_speed") as u16,
                change_positions: [1, 2, 3].map(|n| s.get(base + 2 * n, "change_position") as i32),
                speeds: [1, 2, 3].map(|n| s.get(base + 2 * n + 1, "speed") as u16),
            }
        };
        Self {
            min_rpm,
            max_rpm,
            accel: span / slope_s,
            max_mv: s.get(1, "maximum_voltage") as f64,
            forward_check: s.get(1, "forward_end_switch") != 0,
            reverse_check: s.get(1, "reverse_end_switch") != 0,
            ppr: s.get(2, "pulses_per_revolution").max(1) as f64,
            hold_on_enable: s.get(2, "hold_on_enable") != 0,
            auto_zero: s.get(2, "auto_zero") != 0,
            sin2: s.get(2, "slope_profile") != 0,
            positioning_error: s.get(3, "positioning_error") as f64,
            ready_check: s.get(4, "ready_input") != 0,
            error_check: s.get(4, "error_input") != 0,
            trajects: [traject(0), traject(1)],
        }
    }

    /// A speed clamped to the configured minimum / maximum; 0 means the maximum.
    pub fn clamp_speed(&self, rpm: u16) -> f64 {
        if rpm == 0 {
            self.max_rpm
        } else {
            (rpm as f64).clamp(self.min_rpm, self.max_rpm)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    // Manual 20h "Range Default Units": 50 RPM, 8000 RPM, slope 10 (1 s), 10000 mV,
    // end switches on, 500 pulses, positioning error 25, gain 32, D 32, inputs checked.
    #[test]
    fn defaults_are_the_manuals() {
        let s = ServoStore::defaults();
        assert_eq!(s.values(0), Some(&[("minimum_speed", 50), ("maximum_speed", 8000), ("slope", 10)][..]));
        assert_eq!(s.get(1, "maximum_voltage"), 10000);
        assert_eq!(s.get(2, "pulses_per_revolution"), 500);
        assert_eq!(s.get(3, "gain_factor"), 32);
        assert_eq!(s.get(4, "ready_input"), 1);
        assert_eq!(s.get(0x27, "speed"), 0);
        let p = Params::from_store(&s);
        assert_eq!((p.min_rpm, p.max_rpm, p.accel), (50.0, 8000.0, 7950.0));
        assert!(p.forward_check && p.reverse_check && p.ready_check && p.error_check);
        assert_eq!(p.clamp_speed(0), 8000.0);
        assert_eq!(p.clamp_speed(10), 50.0);
        assert_eq!(p.clamp_speed(40000), 8000.0);
    }
}
