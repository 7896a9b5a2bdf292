//! PowerCube modules: every chosen parameter of every chosen module in one
//! pipelined burst per sample on CAN (one request after the other on RS232).

use super::{Address, Channel, RecordError, Sampler};
use crate::device::powercube::{is_linear, Cubes, Error};
use crate::proto::powercube::table::{ids, ParamDef};
use crate::proto::powercube::{ModuleId, Request};
use crate::session::powercube::decode_get;

pub struct CubeSampler {
    cubes: Cubes,
    reqs: Vec<(ModuleId, Request)>,
    defs: Vec<&'static ParamDef>,
    channels: Vec<Channel>,
}

impl CubeSampler {
    /// Reads each module's Config once, for the units of its kind (rad or m).
    pub fn new(mut cubes: Cubes, modules: &[ModuleId], params: &[&'static ParamDef]) -> Result<Self, RecordError> {
        let (mut reqs, mut defs, mut channels) = (Vec::new(), Vec::new(), Vec::new());
        for &m in modules {
            let linear = is_linear(cubes.get_u32(m, ids::CONFIG)?);
            for &d in params {
                reqs.push((m, Request::GetExtended { param: d.id }));
                defs.push(d);
                let unit = match d.unit.split_once('|') {
                    Some((rot, lin)) => if linear { lin } else { rot }.to_string(),
                    None => d.unit.to_string(),
                };
                channels.push(Channel { address: Address::Module(m.get()), name: d.name.into(), unit });
            }
        }
        Ok(Self { cubes, reqs, defs, channels })
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
        let mut out = Vec::with_capacity(answers.len());
        for (((m, req), d), a) in self.reqs.iter().zip(&self.defs).zip(answers) {
            let resp = match a {
                Ok(r) => r,
                Err(e) => self.cubes.session().retry_read(*m, req, e).map_err(Error::from)?,
            };
            let v = decode_get(*m, d, &resp).map_err(Error::from)?;
            out.push(v.as_f64().unwrap_or(f64::NAN));
        }
        Ok(out)
    }
}
