//! PowerCube modules: every chosen parameter of every chosen module in one
//! pipelined burst per sample on CAN (one request after the other on RS232).
//! Back to back on CAN, the next sample's burst goes out before the current
//! one is collected: the bus carries it while the current answers cross the
//! link to the host and the host turns around, instead of falling idle.

use std::time::{Duration, Instant};

use super::{Channel, HaltMotion, RecordError, Sampler};
use crate::address::Address;
use crate::clock::Clock;
use crate::device::face::{Face, FaceError};
use crate::device::powercube::{is_linear, Cubes, Error};
use crate::proto::powercube::table::{self, ids, ParamDef};
use crate::proto::powercube::{ModuleId, Request};
use crate::session::powercube::{decode_get, Burst};

pub struct CubeSampler {
    cubes: Cubes,
    reqs: Vec<(ModuleId, Request)>,
    defs: Vec<&'static ParamDef>,
    channels: Vec<Channel>,
    /// Per channel, its request; `None` for a parameter the module's
    /// firmware lacks (never asked: the module would not answer it).
    slots: Vec<Option<usize>>,
    /// Send each burst one sample ahead (CAN, back to back).
    ahead: bool,
    /// The next sample's burst, sent and not collected yet.
    next: Option<Burst>,
    /// When the modules answered the last sample.
    read_at: Option<Instant>,
}

impl CubeSampler {
    /// Reads each module's Config once, for the units of its kind (rad or m),
    /// and its version when a parameter needs a newer firmware.
    pub fn new(mut cubes: Cubes, modules: &[ModuleId], params: &[&'static ParamDef]) -> Result<Self, RecordError> {
        let (mut reqs, mut defs, mut channels, mut slots) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let needs_version = params.iter().any(|d| !table::firmware_has(0, d.id));
        for &m in modules {
            let linear = is_linear(cubes.get_u32(m, ids::CONFIG)?);
            let version = if needs_version { Some(cubes.version(m)?) } else { None };
            for &d in params {
                if version.is_none_or(|v| table::firmware_has(v, d.id)) {
                    slots.push(Some(reqs.len()));
                    reqs.push((m, Request::GetExtended { param: d.id }));
                    defs.push(d);
                } else {
                    slots.push(None);
                }
                let unit = d.unit_for(linear).to_string();
                channels.push(Channel { address: Address::PowerCube { module: m.get() }, name: d.name.into(), unit });
            }
        }
        Ok(Self { cubes, reqs, defs, channels, slots, ahead: false, next: None, read_at: None })
    }

    /// The device handle, for a motion on the same link.
    pub fn cubes(&mut self) -> &mut Cubes {
        &mut self.cubes
    }

    /// The device handle back, once the recording is over (a run that
    /// records one module after the other keeps one link).
    pub fn into_cubes(mut self) -> Cubes {
        self.finish();
        self.cubes
    }
}

impl Sampler for CubeSampler {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// A read the burst did not answer is retried on its own (the session's
    /// `--retries`), so one lost frame does not end a recording. Retries go
    /// out while the next sample's burst is in flight: the session gives
    /// each answer to the oldest request it answers.
    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        let pc = self.cubes.session();
        let burst = match self.next.take() {
            Some(b) => b,
            None => pc.send_burst(&self.reqs).map_err(Error::from)?,
        };
        if self.ahead {
            match pc.send_burst(&self.reqs) {
                Ok(next) => self.next = Some(next),
                Err(e) => {
                    pc.abandon(burst);
                    return Err(Error::from(e).into());
                }
            }
        }
        let collected = pc.collect(burst).map_err(Error::from)?;
        self.read_at = collected.first_answer;
        let mut read = Vec::with_capacity(collected.answers.len());
        for (((m, req), d), a) in self.reqs.iter().zip(&self.defs).zip(collected.answers) {
            let resp = match a {
                Ok(r) => r,
                Err(e) => self.cubes.session().retry_read(*m, req, e).map_err(Error::from)?,
            };
            let v = decode_get(*m, d, &resp).map_err(Error::from)?;
            read.push(v.as_f64().unwrap_or(f64::NAN));
        }
        Ok(self.slots.iter().map(|s| s.map_or(f64::NAN, |i| read[i])).collect())
    }

    /// Only on CAN: on RS232's half-duplex line a burst is one request
    /// after the other, answered before the next goes out.
    fn back_to_back(&mut self) {
        self.ahead = self.cubes.session().is_can();
    }

    fn read_at(&self) -> Option<Instant> {
        if self.ahead {
            self.read_at
        } else {
            None
        }
    }

    /// A motion's watchdog refresh goes on while the recording waits.
    fn pause(&mut self, clock: &dyn Clock, d: Duration) {
        if self.cubes.deadman_refreshing() {
            // A link that fails here fails the next sample, which halts.
            let _ = self.cubes.session().pause(d);
        } else {
            clock.sleep_or_wake(d);
        }
    }

    fn finish(&mut self) {
        if let Some(b) = self.next.take() {
            self.cubes.session().abandon(b);
        }
    }
}

impl From<Error> for RecordError {
    fn from(e: Error) -> Self {
        FaceError::from(e).into()
    }
}

impl HaltMotion for CubeSampler {
    fn face(&mut self) -> &mut dyn Face {
        self.cubes()
    }

    fn release(&mut self) -> Result<(), String> {
        self.cubes().release_deadman().map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests;
