//! `record cdios:NODE/MODULE.VALUE`: a module's values, checked by name
//! before the link opens.

use axisctl::device::cdios::Node;
use axisctl::proto::cdios::{ModuleId, NodeId};
use axisctl::record::cdios::{CdiosSampler, CdiosValue};

use axisctl::bench::Address;
use axisctl::link::LinkSpec;
use axisctl::record::Sampler;

use crate::commands::record::several::Plan;
use crate::commands::record::{device_error, names};
use crate::commands::{usage, Ctx};

struct CdiosPlan {
    node: u8,
    module: u8,
    values: Vec<CdiosValue>,
}

pub fn plan(address: Address, given: &[String]) -> anyhow::Result<Box<dyn Plan>> {
    let Address::Cdios { node, module } = address else { unreachable!("picked by the address's family") };
    let values = names(given, CdiosValue::parse, CdiosValue::ALL.map(CdiosValue::name).as_slice())?;
    Ok(Box::new(CdiosPlan { node, module, values }))
}

impl Plan for CdiosPlan {
    fn sampler(&self, ctx: &Ctx, spec: &LinkSpec) -> anyhow::Result<Box<dyn Sampler>> {
        let (node, module) = (self.node, self.module);
        let node = NodeId::new(node).ok_or_else(|| usage(format!("node {node} out of range")))?;
        let module = ModuleId::new(module).ok_or_else(|| usage(format!("module {module} out of range")))?;
        let mut session = ctx.opener().cdios(spec, &ctx.session_options())?;
        session.set_nmt(true);
        let sampler = CdiosSampler::new(Node::new(session, node, ctx.retry), &[module], &self.values);
        Ok(Box::new(sampler.map_err(device_error)?))
    }
}
