//! The live bench of a backup, a diff or a restore: the sessions of every
//! (link, family) pair, each opened when first needed and kept for the
//! command (the opener shares one CAN port among the families on it, so a
//! PowerCube and a Cdios node on one adapter never open it twice).

use std::collections::BTreeSet;

use axisctl::backup::{self, Address, Device, Problem, ValueResult};
use axisctl::bench::{self, Bench, BenchError, BenchLink};
use axisctl::device::cdios::{Node, Slot};
use axisctl::device::pac::Controller;
use axisctl::device::powercube::{Cubes, Error as CubeError};
use axisctl::family::{Family, POWERCUBE_MODULE};
use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
use axisctl::proto::powercube::ModuleId;
use axisctl::session::ErrorKind;

use super::super::{classify, usage, Ctx};
use crate::cli::backup::Selection;
use crate::cli::ids::Devices;
use crate::output;

/// The sessions of the command, by the text of the bench link they are on.
pub(super) struct Live<'a> {
    ctx: &'a Ctx,
    cubes: Vec<(&'a str, Cubes)>,
    pacs: Vec<(&'a str, Controller)>,
    /// Cdios nodes, with the controller's identify answer.
    nodes: Vec<(&'a str, Node, Vec<Slot>)>,
}

/// Which devices of a family on a link a backup reads.
pub(super) struct Wanted<'s> {
    pub select: &'s Selection,
    /// The Cdios nodes probed on the link.
    pub nodes: Vec<u8>,
    /// The family was asked for (`--family`, `-m`, a node the bench file
    /// expects): a family with no device there is an error, not an empty list.
    pub named: bool,
}

impl<'a> Live<'a> {
    pub fn new(ctx: &'a Ctx) -> Self {
        ctx.opener().keep_links_open();
        Self { ctx, cubes: Vec::new(), pacs: Vec::new(), nodes: Vec::new() }
    }

    fn cubes(&mut self, link: &'a BenchLink) -> anyhow::Result<&mut Cubes> {
        let i = match self.cubes.iter().position(|(l, _)| *l == link.text) {
            Some(i) => i,
            None => {
                let pc = self.ctx.opener().powercube(&link.spec, &self.ctx.session_options())?;
                self.cubes.push((&link.text, Cubes::new(pc)));
                self.cubes.len() - 1
            }
        };
        Ok(&mut self.cubes[i].1)
    }

    fn pac(&mut self, link: &'a BenchLink) -> anyhow::Result<&mut Controller> {
        let i = match self.pacs.iter().position(|(l, _)| *l == link.text) {
            Some(i) => i,
            None => {
                let pac = self.ctx.opener().pac(&link.spec, &self.ctx.session_options())?;
                self.pacs.push((&link.text, Controller::new(pac)));
                self.pacs.len() - 1
            }
        };
        Ok(&mut self.pacs[i].1)
    }

    /// The node and its slots, opened and identified once.
    fn node(&mut self, link: &'a BenchLink, id: u8) -> anyhow::Result<(&mut Node, &[Slot])> {
        let i = match self.nodes.iter().position(|(l, n, _)| *l == link.text && n.id().get() == id) {
            Some(i) => i,
            None => {
                let node_id =
                    NodeId::new(id).ok_or_else(|| usage(format!("node {id}: a Cdios node id is 1 to 127")))?;
                let s = self.ctx.opener().cdios(&link.spec, &self.ctx.session_options())?;
                let mut node = Node::new(s, node_id, self.ctx.retry);
                let slots = node.identify()?;
                self.nodes.push((&link.text, node, slots));
                self.nodes.len() - 1
            }
        };
        let (_, node, slots) = &mut self.nodes[i];
        Ok((node, slots))
    }

    /// The devices of `family` on `link` the selection names, or those present.
    pub fn present(&mut self, link: &'a BenchLink, family: Family, w: &Wanted) -> anyhow::Result<Vec<Address>> {
        let addr = |module| Address { family, module, axis: None, node: None };
        match family {
            Family::PowerCube => {
                let ids: Vec<u8> = match &w.select.module {
                    Some(Devices::One(id)) => vec![*id],
                    Some(Devices::List(list)) => list.0.clone(),
                    Some(Devices::All) | None => {
                        let found: Vec<u8> = self.cubes(link)?.present()?.iter().map(|m| m.get()).collect();
                        if found.is_empty() && w.named {
                            let ids = format!("{}-{}", POWERCUBE_MODULE.min, POWERCUBE_MODULE.max);
                            return Err(CubeError::NoneAnswered { ids }.into());
                        }
                        found
                    }
                };
                Ok(ids.into_iter().map(|id| addr(Some(id))).collect())
            }
            Family::Pac => {
                let c = self.pac(link)?;
                backup::pac::ensure_home(c)?;
                let n = c.configured_axes()?;
                let axes = (1..=n).map(|a| Address { axis: Some(a), ..addr(None) });
                Ok(std::iter::once(addr(None)).chain(axes).collect())
            }
            Family::Cdios => {
                let mut out = Vec::new();
                for &id in &w.nodes {
                    target(Address { family, module: None, axis: None, node: Some(id) });
                    let found = match self.node(link, id).and_then(|(node, _)| Ok(node.scan()?)) {
                        Ok(found) => found,
                        // A node that does not answer is absent, unless asked for; any
                        // other failure (a busy port, a refusal) is said.
                        Err(e) if !w.named && classify(&e) == ErrorKind::Timeout => continue,
                        Err(e) => return Err(e),
                    };
                    out.extend(found.iter().map(|m| Address { module: Some(m.get()), node: Some(id), ..addr(None) }));
                }
                Ok(out)
            }
        }
    }

    /// The live device at `at` on `link`, read into the backup's shape.
    pub fn capture(&mut self, link: &'a BenchLink, at: Address) -> anyhow::Result<Device> {
        target(at);
        let text = link.text.clone();
        match at.family {
            Family::PowerCube => Ok(backup::powercube::capture(self.cubes(link)?, module(at)?, &text)?),
            Family::Pac => Ok(match at.axis {
                None => backup::pac::capture_controller(self.pac(link)?, &text)?,
                Some(a) => backup::pac::capture_axis(self.pac(link)?, a, &text)?,
            }),
            Family::Cdios => {
                let m = cdios_module(at)?;
                let (node, slots) = self.node(link, at.node.unwrap_or(1))?;
                let slot = slots.iter().find(|s| s.module == m.get()).copied();
                let (ty, version) = slot.map_or((0, 0), |s| (s.ty, s.version));
                Ok(backup::cdios::capture(node, m, ty, version, &text)?)
            }
        }
    }

    pub fn check_live(&mut self, link: &'a BenchLink, file: &Device, live: &Device) -> anyhow::Result<Vec<Problem>> {
        target(file.address());
        Ok(match file.family {
            Family::PowerCube => backup::powercube::check_live(file, live),
            Family::Pac => backup::pac::check_live(self.pac(link)?, file, live)?,
            Family::Cdios => backup::cdios::check_live(file, live),
        })
    }

    pub fn restore(
        &mut self,
        link: &'a BenchLink,
        file: &Device,
        live: &Device,
        skip: &BTreeSet<String>,
        stop: backup::Stop<'_>,
    ) -> anyhow::Result<Vec<ValueResult>> {
        let at = live.address();
        target(at);
        match at.family {
            Family::PowerCube => {
                let m = module(at)?;
                Ok(backup::powercube::restore(self.cubes(link)?, m, file, live, skip, stop)?)
            }
            Family::Pac => Ok(backup::pac::restore(self.pac(link)?, file, live, skip, stop)?),
            Family::Cdios => {
                let m = cdios_module(at)?;
                let (node, _) = self.node(link, at.node.unwrap_or(1))?;
                Ok(backup::cdios::restore(node, m, file, live, skip, stop)?)
            }
        }
    }

    /// Refuses a device that moves (or a PA-CONTROL out of home position):
    /// asked of every device before the first write.
    pub fn ensure_at_rest(&mut self, link: &'a BenchLink, at: Address) -> anyhow::Result<()> {
        target(at);
        match at.family {
            Family::PowerCube => {
                let m = module(at)?;
                Ok(backup::powercube::ensure_at_rest(self.cubes(link)?, m)?)
            }
            Family::Pac => Ok(backup::pac::ensure_home(self.pac(link)?)?),
            Family::Cdios => {
                let m = cdios_module(at)?;
                let (node, _) = self.node(link, at.node.unwrap_or(1))?;
                Ok(backup::cdios::ensure_at_rest(node, m)?)
            }
        }
    }

    /// The Cdios EEPROM store (05h) of one module.
    pub fn store(&mut self, link: &'a BenchLink, at: Address) -> anyhow::Result<()> {
        target(at);
        let m = cdios_module(at)?;
        let (node, _) = self.node(link, at.node.unwrap_or(1))?;
        Ok(backup::cdios::store(node, m)?)
    }
}

/// The bench link a device of a file is read on: the link of the same text
/// when the bench has one carrying its family (a bench of several CAN
/// adapters), else the bench's link for the family (the ptys of a served
/// simulator change from run to run). With the one `--link` of old, that
/// link if the family can be reached over it at all.
pub(super) fn link_of<'b>(bench: &'b Bench, dev: &Device) -> Result<&'b BenchLink, BenchError> {
    if bench.is_single() {
        let one = &bench.links()[0];
        return if bench::fits(&one.spec, dev.family) {
            Ok(one)
        } else {
            Err(BenchError::NoLink { family: dev.family, links: bench.describe() })
        };
    }
    match bench.links().iter().find(|l| l.text == dev.link && l.carries(dev.family)) {
        Some(l) => Ok(l),
        None => bench.link_for(dev.family),
    }
}

/// Whether a failure to read a device of a file means it is not on the
/// bench (no link reaches its family, or it does not answer), as opposed
/// to a failure of the bench itself (a link that cannot be opened, a
/// refusal, a garbled answer), which ends the command.
pub(super) fn is_missing(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.is::<BenchError>()) || classify(e) == ErrorKind::Timeout
}

fn cdios_module(at: Address) -> anyhow::Result<CdiosModule> {
    at.module.and_then(CdiosModule::new).ok_or_else(|| usage(format!("{at}: no Cdios module id 0 to 15")))
}

fn module(at: Address) -> anyhow::Result<ModuleId> {
    at.module.and_then(ModuleId::new).ok_or_else(|| usage(format!("{at}: no PowerCube module id 1 to 31")))
}

/// Records the device being addressed, for the error object.
pub(super) fn target(at: Address) {
    let mut addr: Vec<(&'static str, u64)> = Vec::new();
    addr.extend(at.node.map(|n| ("node", n.into())));
    addr.extend(at.module.map(|m| ("module", m.into())));
    addr.extend(at.axis.map(|a| ("axis", a.into())));
    output::target(at.family, &addr);
}

/// Forgets the device addressed last: the command is past its devices.
pub(super) fn done() {
    output::forget_target();
}
