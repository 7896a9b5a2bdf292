//! The PA-CONTROL of a line and its axes in a backup, a diff or a restore.

use axisctl::device::pac::Controller;

use axisctl::backup::{self, Address, Device, Problem, ValueResult};
use axisctl::bench::BenchLink;

use crate::commands::backup::live::{LiveFamily, Steps, Wanted};
use crate::commands::Ctx;

/// The controller, through one session opened when first needed.
#[derive(Default)]
pub struct PacLive(Option<Controller>);

pub fn live() -> Box<dyn LiveFamily> {
    Box::new(PacLive::default())
}

impl PacLive {
    fn pac(&mut self, ctx: &Ctx, link: &BenchLink) -> anyhow::Result<&mut Controller> {
        if self.0.is_none() {
            self.0 = Some(Controller::new(ctx.opener().pac(&link.spec, &ctx.session_options())?));
        }
        Ok(self.0.as_mut().expect("opened above"))
    }
}

impl LiveFamily for PacLive {
    /// The controller and each configured axis, read in home position.
    fn present(&mut self, ctx: &Ctx, link: &BenchLink, _: &Wanted) -> anyhow::Result<Vec<Address>> {
        let c = self.pac(ctx, link)?;
        backup::pac::ensure_home(c)?;
        let n = c.configured_axes()?;
        let controller = Address { family: axisctl::family::Family::Pac, module: None, axis: None, node: None };
        let axes = (1..=n).map(|a| Address { axis: Some(a), ..controller });
        Ok(std::iter::once(controller).chain(axes).collect())
    }

    fn capture(&mut self, ctx: &Ctx, link: &BenchLink, at: Address) -> anyhow::Result<Device> {
        let c = self.pac(ctx, link)?;
        Ok(match at.axis {
            None => backup::pac::capture_controller(c, &link.text)?,
            Some(a) => backup::pac::capture_axis(c, a, &link.text)?,
        })
    }

    fn check_live(
        &mut self,
        ctx: &Ctx,
        link: &BenchLink,
        file: &Device,
        live: &Device,
    ) -> anyhow::Result<Vec<Problem>> {
        Ok(backup::pac::check_live(self.pac(ctx, link)?, file, live)?)
    }

    fn restore(
        &mut self,
        ctx: &Ctx,
        link: &BenchLink,
        file: &Device,
        live: &Device,
        steps: Steps<'_>,
    ) -> anyhow::Result<Vec<ValueResult>> {
        Ok(backup::pac::restore(self.pac(ctx, link)?, file, live, steps.skip, steps.stop)?)
    }

    /// Writes need home position.
    fn ensure_at_rest(&mut self, ctx: &Ctx, link: &BenchLink, _: Address) -> anyhow::Result<()> {
        Ok(backup::pac::ensure_home(self.pac(ctx, link)?)?)
    }
}
