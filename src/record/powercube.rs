//! PowerCube modules: every chosen parameter of every chosen module in one
//! pipelined burst per sample on CAN (one request after the other on RS232).

use super::{Address, Channel, RecordError, Sampler};
use crate::device::powercube::{is_linear, Cubes, Error};
use crate::proto::powercube::table::{self, ids, ParamDef};
use crate::proto::powercube::{ModuleId, Request};
use crate::session::powercube::decode_get;

pub struct CubeSampler {
    cubes: Cubes,
    reqs: Vec<(ModuleId, Request)>,
    defs: Vec<&'static ParamDef>,
    channels: Vec<Channel>,
    /// Per channel, its request; `None` for a parameter the module's
    /// firmware lacks (never asked: the module would not answer it).
    slots: Vec<Option<usize>>,
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
                channels.push(Channel { address: Address::Module(m.get()), name: d.name.into(), unit });
            }
        }
        Ok(Self { cubes, reqs, defs, channels, slots })
    }

    /// The device handle, for a motion on the same link.
    pub fn cubes(&mut self) -> &mut Cubes {
        &mut self.cubes
    }
}

impl Sampler for CubeSampler {
    fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// A read the burst did not answer is retried on its own (the session's
    /// `--retries`), so one lost frame does not end a recording.
    fn sample(&mut self) -> Result<Vec<f64>, RecordError> {
        let answers = self.cubes.session().transact_many(&self.reqs).map_err(Error::from)?;
        let mut read = Vec::with_capacity(answers.len());
        for (((m, req), d), a) in self.reqs.iter().zip(&self.defs).zip(answers) {
            let resp = match a {
                Ok(r) => r,
                Err(e) => self.cubes.session().retry_read(*m, req, e).map_err(Error::from)?,
            };
            let v = decode_get(*m, d, &resp).map_err(Error::from)?;
            read.push(v.as_f64().unwrap_or(f64::NAN));
        }
        Ok(self.slots.iter().map(|s| s.map_or(f64::NAN, |i| read[i])).collect())
    }
}
