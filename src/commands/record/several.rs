//! `record DEVICE.VALUE...`: values of devices anywhere on the bench, each
//! named with its device (`powercube:3.ActPos`, `pac:2.position`,
//! `cdios:1/0.speed`, or a bench file's name: `shoulder.ActPos`), read over
//! the link that carries its family, in one recording with one time base.
//! Every name is checked before a link opens.

use axisctl::bench::{Address, Bench, BenchLink, DeviceRef};
use axisctl::device::supervisor;
use axisctl::link::LinkSpec;
use axisctl::record::{self, Sampler, Several};

use super::super::{usage, Ctx};
use super::{device_error, pace, Writer};
use crate::cli::record::RecordArgs;
use crate::output;

/// Whether the values name their devices (`DEVICE.VALUE`): the bench form.
pub(super) fn addressed(values: &[String]) -> bool {
    values.iter().any(|v| v.contains('.'))
}

/// The values of one device, checked, and the link it is read on.
struct Device<'b> {
    link: &'b BenchLink,
    plan: Box<dyn Plan>,
}

/// The values of one device of a family, checked against its names before
/// any link opens; then its sampler on the device's link. Each family says
/// it in its folder (`commands/<family>/record.rs`).
pub trait Plan {
    fn sampler(&self, ctx: &Ctx, spec: &LinkSpec) -> anyhow::Result<Box<dyn Sampler>>;
}

/// The devices of the values in the order first named, each with its values.
fn devices<'b>(bench: &'b Bench, values: &[String]) -> anyhow::Result<Vec<Device<'b>>> {
    let mut by_device: Vec<(Address, Vec<String>)> = Vec::new();
    for v in values {
        let Some((device, name)) = v.split_once('.') else {
            return Err(usage(format!(
                "{v:?} names no device: once one value is DEVICE.VALUE (powercube:3.ActPos) every one is"
            )));
        };
        let device: DeviceRef = device.parse().map_err(|e| usage(format!("{v:?}: {e}")))?;
        let at = bench.resolve(&device)?;
        match by_device.iter_mut().find(|(a, _)| *a == at) {
            Some((_, names)) => names.push(name.to_string()),
            None => by_device.push((at, vec![name.to_string()])),
        }
    }
    by_device
        .into_iter()
        .map(|(address, given)| {
            let plan = (super::super::family_cli(address.family()).record_plan)(address, &given)?;
            Ok(Device { link: bench.link_of(address)?, plan })
        })
        .collect()
}

pub(super) fn run(ctx: &Ctx, args: &RecordArgs) -> anyhow::Result<()> {
    if args.module.is_some() || args.axis.is_some() || args.node.is_some() {
        return Err(usage(
            "the values name their devices (DEVICE.VALUE): leave out -m, --axis and --node, or give plain values",
        ));
    }
    if !args.motion.is_empty() {
        return Err(usage(
            "record -- MOTION records one family's devices (-m, --axis or --node with plain values), so that the \
             motion goes out on the link it reads; nothing was sent",
        ));
    }
    let bench = ctx.bench()?;
    let devices = devices(bench, &args.values)?;
    let (pace, until, format) = pace(ctx, args)?;
    // From here on a signal ends the recording between two samples.
    super::super::arm_interrupt()?;
    ctx.opener().keep_links_open();
    let mut parts = Vec::new();
    let mut links = Vec::new();
    for d in &devices {
        let part = d.plan.sampler(ctx, &d.link.spec)?;
        links.extend(part.channels().iter().map(|_| d.link.text.clone()));
        parts.push(part);
    }
    let mut s = Several::new(parts);
    let mut writer = Writer::new(format);
    writer.header(record::Sampler::channels(&s), &links);
    let ended =
        record::record(&mut s, ctx.clock.as_ref(), pace, until, &|| supervisor::stop_requested(), &mut |smp, _| {
            writer.sample(smp);
            Ok(())
        });
    output::flush();
    ended.map(|_| ()).map_err(device_error)
}
