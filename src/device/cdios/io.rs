//! Outputs, analog outputs, event masks and the EEPROM store: values
//! range-checked with the table before anything is sent, written, then read
//! back.

use std::time::Duration;

use super::{check, field_value, Error, Node};
use crate::proto::cdios::table::STATUS_FLAGS;
use crate::proto::cdios::{Address, AnalogOutput, Command, ModuleId, Timers};
use crate::proto::parse_int;

/// A digital outputs mask for `set_digital_outputs`.
pub fn outputs_value(text: &str) -> Result<u8, Error> {
    let v = parse_int(text).ok_or_else(|| Error::Refused(format!("--set {text:?} is not a number")))?;
    field_value("set_digital_outputs", "outputs", v)
}

/// The analog outputs a request reads (one, or both) and the write it
/// makes first, if any.
pub fn analog_request(
    output: Option<i64>,
    set: Option<i64>,
    latched: bool,
) -> Result<(Vec<AnalogOutput>, Option<Command>), Error> {
    let which = |n: i64| match n {
        1 => Ok(AnalogOutput::One),
        2 => Ok(AnalogOutput::Two),
        _ => Err(Error::Refused(format!("--output {n}: the 6168 has analog outputs 1 and 2; nothing was sent"))),
    };
    let outs = match output {
        Some(n) => vec![which(n)?],
        None => vec![AnalogOutput::One, AnalogOutput::Two],
    };
    let set = match set {
        Some(v) => Some(Command::SetAnalogOutput {
            output: outs[0],
            latched,
            millivolts: field_value::<i16>("set_analog_output", "value", v)?,
        }),
        None => None,
    };
    Ok((outs, set))
}

/// One analog output as read back.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AnalogReading {
    pub output: u8,
    pub millivolts: i64,
}

/// Event masks and timers, as set or read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EventSetup {
    pub masks: [u8; 4],
    pub timers: Timers,
}

/// The changes an `events` request makes; `None` keeps what the module has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EventChange {
    pub masks: Option<[u8; 4]>,
    pub position_interval: Option<u8>,
    pub position_on_change: Option<bool>,
    pub speed_interval: Option<u8>,
    pub speed_on_change: Option<bool>,
}

impl EventChange {
    /// Flag names (`none` clears) or four raw mask bytes, and the timer
    /// codes, each checked with the table.
    pub fn parse(
        mask: Option<&str>,
        raw_masks: Option<&str>,
        position_interval: Option<i64>,
        position_on_change: Option<bool>,
        speed_interval: Option<i64>,
        speed_on_change: Option<bool>,
    ) -> Result<Self, Error> {
        let masks = match (mask, raw_masks) {
            (Some(n), _) => Some(masks_from_names(n)?),
            (_, Some(r)) => Some(masks_from_raw(r)?),
            _ => None,
        };
        let interval = |v: i64, key| field_value::<u8>("set_event_mask", key, v);
        Ok(Self {
            masks,
            position_interval: position_interval.map(|v| interval(v, "position_interval")).transpose()?,
            position_on_change,
            speed_interval: speed_interval.map(|v| interval(v, "speed_interval")).transpose()?,
            speed_on_change,
        })
    }

    pub fn any(&self) -> bool {
        *self != Self::default()
    }

    fn apply(&self, old: EventSetup) -> EventSetup {
        let t = old.timers;
        EventSetup {
            masks: self.masks.unwrap_or(old.masks),
            timers: Timers {
                position_interval: self.position_interval.unwrap_or(t.position_interval),
                position_on_change: self.position_on_change.unwrap_or(t.position_on_change),
                speed_interval: self.speed_interval.unwrap_or(t.speed_interval),
                speed_on_change: self.speed_on_change.unwrap_or(t.speed_on_change),
            },
        }
    }
}

/// Status flag names to the four mask bytes.
fn masks_from_names(text: &str) -> Result<[u8; 4], Error> {
    let mut masks = [0u8; 4];
    if text.trim().eq_ignore_ascii_case("none") {
        return Ok(masks);
    }
    for name in text.split([',', '|']).map(str::trim).filter(|s| !s.is_empty()) {
        let f =
            STATUS_FLAGS.iter().find(|f| f.name.eq_ignore_ascii_case(&name.replace('-', "_"))).ok_or_else(|| {
                let all: Vec<&str> = STATUS_FLAGS.iter().map(|f| f.name).collect();
                Error::Refused(format!("unknown status flag {name:?}; flags: {}", all.join(", ")))
            })?;
        masks[f.byte as usize - 1] |= 1 << f.bit;
    }
    Ok(masks)
}

fn masks_from_raw(text: &str) -> Result<[u8; 4], Error> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 4 {
        return Err(Error::Refused(format!("--raw-masks {text:?}: give four bytes M1,M2,M3,M4")));
    }
    let mut out = [0u8; 4];
    for (i, p) in parts.iter().enumerate() {
        let v = parse_int(p).ok_or_else(|| Error::Refused(format!("--raw-masks: {p:?} is not a number")))?;
        out[i] = field_value::<u8>("set_event_mask", ["mask1", "mask2", "mask3", "mask4"][i], v)?;
    }
    Ok(out)
}

/// The status flags a mask lets through as events.
pub fn mask_flags(masks: [u8; 4]) -> Vec<&'static str> {
    STATUS_FLAGS.iter().filter(|f| f.is_set(&masks)).map(|f| f.name).collect()
}

impl Node {
    /// Sets the digital outputs when given, then reads them back.
    pub fn outputs(&mut self, m: ModuleId, set: Option<u8>, latched: bool) -> Result<u8, Error> {
        if let Some(o) = set {
            self.send(m, &[Command::SetDigitalOutputs { latched, outputs: o }])?;
        }
        self.ready(m)?;
        let r = self.s.read(self.node, Address::Module(m), &Command::GetDigitalOutputs)?;
        Ok(r.get("state").unwrap_or(0) as u8)
    }

    /// Makes the write of [`analog_request`], then reads the outputs back.
    pub fn analog(
        &mut self,
        m: ModuleId,
        outs: &[AnalogOutput],
        set: Option<Command>,
    ) -> Result<Vec<AnalogReading>, Error> {
        if let Some(c) = set {
            self.send(m, &[c])?;
        }
        self.ready(m)?;
        let mut list = Vec::new();
        for &o in outs {
            let r = self.s.read(self.node, Address::Module(m), &Command::ReadAnalogOutput { output: o })?;
            list.push(AnalogReading { output: o.to_u8(), millivolts: r.get("value").unwrap_or(0) });
        }
        Ok(list)
    }

    fn read_events(&mut self, m: ModuleId) -> Result<EventSetup, Error> {
        self.ready(m)?;
        let r = self.s.read(self.node, Address::Module(m), &Command::ReadEventMask)?;
        let g = |k: &str| r.get(k).unwrap_or(0);
        Ok(EventSetup {
            masks: [g("mask1") as u8, g("mask2") as u8, g("mask3") as u8, g("mask4") as u8],
            timers: Timers {
                position_interval: g("position_interval") as u8,
                position_on_change: g("position_on_change") != 0,
                speed_interval: g("speed_interval") as u8,
                speed_on_change: g("speed_on_change") != 0,
            },
        })
    }

    /// The event setup; with changes, the module's setup is read, changed
    /// where asked, written whole and read back.
    pub fn events(&mut self, m: ModuleId, change: &EventChange) -> Result<EventSetup, Error> {
        let old = self.read_events(m)?;
        if !change.any() {
            return Ok(old);
        }
        let new = change.apply(old);
        let cmd = Command::SetEventMask { masks: new.masks, timers: new.timers };
        check(&[cmd], m)?;
        self.send(m, &[cmd])?;
        self.read_events(m)
    }

    /// Stores the configuration (or the defaults) in EEPROM; returns how
    /// long the module took.
    pub fn store(&mut self, m: ModuleId, defaults: bool) -> Result<Duration, Error> {
        let cmd = Command::StoreConfiguration { defaults };
        check(&[cmd], m)?;
        let t0 = self.s.clock().now();
        self.send(m, &[cmd])?;
        Ok(self.s.clock().now() - t0)
    }
}
