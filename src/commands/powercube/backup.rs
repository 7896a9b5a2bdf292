//! The PowerCube modules of a link in a backup, a diff or a restore.

use axisctl::device::powercube::{Cubes, Error as CubeError};
use axisctl::family::POWERCUBE_MODULE;
use axisctl::proto::powercube::ModuleId;

use axisctl::backup::{self, Address, Device, Problem, ValueResult};
use axisctl::bench::BenchLink;

use crate::commands::backup::live::{LiveFamily, Steps, Wanted};
use crate::commands::{usage, Ctx};

/// The bus's modules, through one session opened when first needed.
#[derive(Default)]
pub struct CubesLive(Option<Cubes>);

pub fn live() -> Box<dyn LiveFamily> {
    Box::new(CubesLive::default())
}

impl CubesLive {
    fn cubes(&mut self, ctx: &Ctx, link: &BenchLink) -> anyhow::Result<&mut Cubes> {
        if self.0.is_none() {
            self.0 = Some(Cubes::new(ctx.opener().powercube(&link.spec, &ctx.session_options())?));
        }
        Ok(self.0.as_mut().expect("opened above"))
    }
}

fn module(at: Address) -> anyhow::Result<ModuleId> {
    at.module.and_then(ModuleId::new).ok_or_else(|| usage(format!("{at}: no PowerCube module id 1 to 31")))
}

impl LiveFamily for CubesLive {
    fn present(&mut self, ctx: &Ctx, link: &BenchLink, w: &Wanted) -> anyhow::Result<Vec<Address>> {
        let ids: Vec<u8> = match &w.modules {
            Some(ids) => ids.clone(),
            None => {
                let found: Vec<u8> = self.cubes(ctx, link)?.present()?.iter().map(|m| m.get()).collect();
                if found.is_empty() && w.named {
                    let ids = format!("{}-{}", POWERCUBE_MODULE.min, POWERCUBE_MODULE.max);
                    return Err(CubeError::NoneAnswered { ids }.into());
                }
                found
            }
        };
        let family = axisctl::family::Family::PowerCube;
        Ok(ids.into_iter().map(|id| Address { family, module: Some(id), axis: None, node: None }).collect())
    }

    fn capture(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<Device> {
        Ok(backup::powercube::capture(self.cubes(ctx, link)?, module(at)?, &link.text)?)
    }

    fn check_live(&mut self, _: &Ctx, _: &BenchLink, file: &Device, live: &Device) -> anyhow::Result<Vec<Problem>> {
        Ok(backup::powercube::check_live(file, live))
    }

    fn restore(
        &mut self,
        ctx: &Ctx,
        link: &BenchLink,
        file: &Device,
        live: &Device,
        steps: Steps<'_>,
    ) -> anyhow::Result<Vec<ValueResult>> {
        let m = module(live.address())?;
        Ok(backup::powercube::restore(self.cubes(ctx, link)?, m, file, live, steps.skip, steps.stop)?)
    }

    fn ensure_at_rest(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<()> {
        let m = module(at)?;
        Ok(backup::powercube::ensure_at_rest(self.cubes(ctx, link)?, m)?)
    }
}
