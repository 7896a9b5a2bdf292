//! `record powercube:M.PARAM`: a module's parameters, checked by name
//! before the link opens.

use axisctl::device::powercube::{self as cube_dev, Cubes};
use axisctl::proto::powercube::table::ParamDef;
use axisctl::proto::powercube::ModuleId;
use axisctl::record::powercube::CubeSampler;

use axisctl::bench::Address;
use axisctl::link::LinkSpec;
use axisctl::record::Sampler;

use crate::commands::record::device_error;
use crate::commands::record::several::Plan;
use crate::commands::{usage, Ctx};

struct CubePlan {
    module: u8,
    params: Vec<&'static ParamDef>,
}

pub fn plan(address: Address, given: &[String]) -> anyhow::Result<Box<dyn Plan>> {
    let Address::PowerCube { module } = address else { unreachable!("picked by the address's family") };
    given.iter().try_for_each(|n| super::names::check_param(n))?;
    Ok(Box::new(CubePlan { module, params: cube_dev::readable_params(given, false)? }))
}

impl Plan for CubePlan {
    fn sampler(&self, ctx: &Ctx, spec: &LinkSpec) -> anyhow::Result<Box<dyn Sampler>> {
        let module = self.module;
        let m = ModuleId::new(module).ok_or_else(|| usage(format!("module {module} out of range")))?;
        let cubes = Cubes::new(ctx.opener().powercube(spec, &ctx.session_options())?);
        Ok(Box::new(CubeSampler::new(cubes, &[m], &self.params).map_err(device_error)?))
    }
}
