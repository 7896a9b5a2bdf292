//! The live bench of a backup, a diff or a restore: the sessions of every
//! (link, family) pair, each opened when first needed and kept for the
//! command (the opener shares one CAN port among the families on it, so a
//! PowerCube and a Cdios node on one adapter never open it twice).

use std::collections::BTreeSet;

use axisctl::backup::{self, Address, Device, Problem, ValueResult};
use axisctl::bench::{self, Bench, BenchError, BenchLink};
use axisctl::family::Family;
use axisctl::session::ErrorKind;

use super::super::{classify, usage, Ctx};
use crate::output;

/// The sessions of the command: one [`LiveFamily`] per (link, family)
/// pair, by the text of the bench link, made when first needed.
pub struct Live<'a> {
    ctx: &'a Ctx,
    units: Vec<(&'a str, Family, Box<dyn LiveFamily>)>,
}

/// Which devices of a family on a link a backup reads.
pub struct Wanted {
    /// The PowerCube modules named (`-m 3,5`, `-d powercube:3`); `None`:
    /// every module that answers.
    pub modules: Option<Vec<u8>>,
    /// The Cdios nodes probed on the link.
    pub nodes: Vec<u8>,
    /// The family was asked for (`--family`, `-m`, a node the bench file
    /// expects): a family with no device there is an error, not an empty list.
    pub named: bool,
}

/// One family's devices on one link of the bench, for a backup, a diff or a
/// restore: its sessions, opened when first needed and kept for the
/// command, and the family's reads and writes (`backup::<family>`). Each
/// family says it in its folder (`commands/<family>/backup.rs`).
pub trait LiveFamily {
    /// The devices the selection names, or those present.
    fn present(&mut self, ctx: &Ctx, link: &BenchLink, w: &Wanted) -> anyhow::Result<Vec<Address>>;
    /// The live device at `at`, read into the backup's shape.
    fn capture(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<Device>;
    /// What the live device says against the file before a restore.
    fn check_live(&mut self, ctx: &Ctx, link: &BenchLink, file: &Device, live: &Device)
        -> anyhow::Result<Vec<Problem>>;
    fn restore(
        &mut self,
        ctx: &Ctx,
        link: &BenchLink,
        file: &Device,
        live: &Device,
        steps: Steps<'_>,
    ) -> anyhow::Result<Vec<ValueResult>>;
    /// Refuses a device that moves (or is out of the mode writes need).
    fn ensure_at_rest(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<()>;
    /// The EEPROM store of a device whose family keeps one.
    fn store(&mut self, _ctx: &Ctx, _link: &BenchLink, at: Address) -> anyhow::Result<()> {
        Err(usage(format!("{at}: its family has no store of its settings")))
    }
}

/// What a restore may write and when it must stop.
pub struct Steps<'s> {
    pub skip: &'s BTreeSet<String>,
    pub stop: backup::Stop<'s>,
}

impl<'a> Live<'a> {
    pub fn new(ctx: &'a Ctx) -> Self {
        ctx.opener().keep_links_open();
        Self { ctx, units: Vec::new() }
    }

    fn unit(&mut self, link: &'a BenchLink, family: Family) -> (&'a Ctx, &mut dyn LiveFamily) {
        let i = match self.units.iter().position(|(l, f, _)| *l == link.text && *f == family) {
            Some(i) => i,
            None => {
                self.units.push((&link.text, family, (super::super::family_cli(family).backup_live)()));
                self.units.len() - 1
            }
        };
        (self.ctx, self.units[i].2.as_mut())
    }

    /// The devices of `family` on `link` the selection names, or those present.
    pub fn present(&mut self, link: &'a BenchLink, family: Family, w: &Wanted) -> anyhow::Result<Vec<Address>> {
        let (ctx, unit) = self.unit(link, family);
        unit.present(ctx, link, w)
    }

    /// The live device at `at` on `link`, read into the backup's shape.
    pub fn capture(&mut self, link: &'a BenchLink, at: Address) -> anyhow::Result<Device> {
        target(at);
        let (ctx, unit) = self.unit(link, at.family);
        unit.capture(ctx, link, at)
    }

    pub fn check_live(&mut self, link: &'a BenchLink, file: &Device, live: &Device) -> anyhow::Result<Vec<Problem>> {
        target(file.address());
        let (ctx, unit) = self.unit(link, file.family);
        unit.check_live(ctx, link, file, live)
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
        let (ctx, unit) = self.unit(link, at.family);
        unit.restore(ctx, link, file, live, Steps { skip, stop })
    }

    /// Refuses a device that moves (or a PA-CONTROL out of home position):
    /// asked of every device before the first write.
    pub fn ensure_at_rest(&mut self, link: &'a BenchLink, at: Address) -> anyhow::Result<()> {
        target(at);
        let (ctx, unit) = self.unit(link, at.family);
        unit.ensure_at_rest(ctx, link, at)
    }

    /// The EEPROM store of one module (the Cdios 05h).
    pub fn store(&mut self, link: &'a BenchLink, at: Address) -> anyhow::Result<()> {
        target(at);
        let (ctx, unit) = self.unit(link, at.family);
        unit.store(ctx, link, at)
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

/// Records the device being addressed, for the error object.
pub(in crate::commands) fn target(at: Address) {
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
