//! The Cdios nodes of a link and their modules in a backup, a diff or a
//! restore.

use axisctl::device::cdios::{Node, Slot};
use axisctl::proto::cdios::{ModuleId, NodeId};
use axisctl::session::ErrorKind;

use axisctl::backup::{self, Address, Device, Problem, ValueResult};
use axisctl::bench::BenchLink;

use crate::commands::backup::live::target;
use crate::commands::backup::live::{LiveFamily, Steps, Wanted};
use crate::commands::{classify, usage, Ctx};

/// The nodes, each opened and identified once, with the controller's
/// identify answer.
#[derive(Default)]
pub struct NodesLive(Vec<(Node, Vec<Slot>)>);

pub fn live() -> Box<dyn LiveFamily> {
    Box::new(NodesLive::default())
}

impl NodesLive {
    fn node(&mut self, ctx: &Ctx, link: &BenchLink, id: u8) -> anyhow::Result<(&mut Node, &[Slot])> {
        let i = match self.0.iter().position(|(n, _)| n.id().get() == id) {
            Some(i) => i,
            None => {
                let node_id =
                    NodeId::new(id).ok_or_else(|| usage(format!("node {id}: a Cdios node id is 1 to 127")))?;
                let s = ctx.opener().cdios(&link.spec, &ctx.session_options())?;
                let mut node = Node::new(s, node_id, ctx.retry);
                let slots = node.identify()?;
                self.0.push((node, slots));
                self.0.len() - 1
            }
        };
        let (node, slots) = &mut self.0[i];
        Ok((node, slots))
    }
}

fn module(at: Address) -> anyhow::Result<ModuleId> {
    at.module.and_then(ModuleId::new).ok_or_else(|| usage(format!("{at}: no Cdios module id 0 to 15")))
}

impl LiveFamily for NodesLive {
    fn present(&mut self, ctx: &Ctx, link: &BenchLink, w: &Wanted) -> anyhow::Result<Vec<Address>> {
        let node_of = |id| Address { family: axisctl::family::Family::Cdios, module: None, axis: None, node: Some(id) };
        let mut out = Vec::new();
        for &id in &w.nodes {
            target(node_of(id));
            let found = match self.node(ctx, link, id).and_then(|(node, _)| Ok(node.scan()?)) {
                Ok(found) => found,
                // A node that does not answer is absent, unless asked for; any
                // other failure (a busy port, a refusal) is said.
                Err(e) if !w.named && classify(&e) == ErrorKind::Timeout => continue,
                Err(e) => return Err(e),
            };
            out.extend(found.iter().map(|m| Address { module: Some(m.get()), ..node_of(id) }));
        }
        Ok(out)
    }

    fn capture(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<Device> {
        let m = module(at)?;
        let (node, slots) = self.node(ctx, link, at.node.unwrap_or(NodeId::FACTORY.get()))?;
        let slot = slots.iter().find(|s| s.module == m.get()).copied();
        let (ty, version) = slot.map_or((0, 0), |s| (s.ty, s.version));
        Ok(backup::cdios::capture(node, m, ty, version, &link.text)?)
    }

    fn check_live(&mut self, _: &Ctx, _: &BenchLink, file: &Device, live: &Device) -> anyhow::Result<Vec<Problem>> {
        Ok(backup::cdios::check_live(file, live))
    }

    fn restore(
        &mut self,
        ctx: &Ctx,
        link: &BenchLink,
        file: &Device,
        live: &Device,
        steps: Steps<'_>,
    ) -> anyhow::Result<Vec<ValueResult>> {
        let at = live.address();
        let m = module(at)?;
        let (node, _) = self.node(ctx, link, at.node.unwrap_or(NodeId::FACTORY.get()))?;
        Ok(backup::cdios::restore(node, m, file, live, steps.skip, steps.stop)?)
    }

    fn ensure_at_rest(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<()> {
        let m = module(at)?;
        let (node, _) = self.node(ctx, link, at.node.unwrap_or(NodeId::FACTORY.get()))?;
        Ok(backup::cdios::ensure_at_rest(node, m)?)
    }

    /// The EEPROM store (05h) of one module.
    fn store(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<()> {
        let m = module(at)?;
        let (node, _) = self.node(ctx, link, at.node.unwrap_or(NodeId::FACTORY.get()))?;
        Ok(backup::cdios::store(node, m)?)
    }
}
