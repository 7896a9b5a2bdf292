//! `record pac:AXIS.VALUE`: an axis' values, checked by name before the
//! link opens.

use axisctl::device::pac::Controller;
use axisctl::record::pac::{PacSampler, PacValue};

use axisctl::bench::Address;
use axisctl::link::LinkSpec;
use axisctl::record::Sampler;

use crate::commands::record::names;
use crate::commands::record::several::Plan;
use crate::commands::{usage, Ctx};

struct PacPlan {
    axis: u8,
    values: Vec<PacValue>,
}

pub fn plan(address: Address, given: &[String]) -> anyhow::Result<Box<dyn Plan>> {
    let Address::Pac { axis } = address else { unreachable!("picked by the address's family") };
    let Some(axis) = axis else {
        return Err(usage("pac is the controller: record one of its axes, pac:AXIS.position"));
    };
    let values = names(given, PacValue::parse, PacValue::ALL.map(PacValue::name).as_slice())?;
    Ok(Box::new(PacPlan { axis, values }))
}

impl Plan for PacPlan {
    fn sampler(&self, ctx: &Ctx, spec: &LinkSpec) -> anyhow::Result<Box<dyn Sampler>> {
        let mut ctl = Controller::new(ctx.opener().pac(spec, &ctx.session_options())?);
        ctl.set_axes(vec![self.axis]);
        Ok(Box::new(PacSampler::new(ctl, &[self.axis], &self.values)))
    }
}
