//! `record DEVICE.VALUE...`: values of devices anywhere on the bench, each
//! named with its device (`powercube:3.ActPos`, `pac:2.position`,
//! `cdios:1/0.speed`, or a bench file's name: `shoulder.ActPos`), read over
//! the link that carries its family, in one recording with one time base.
//! Every name is checked before a link opens.

use axisctl::bench::{Address, Bench, BenchLink, DeviceRef};
use axisctl::device::cdios::Node;
use axisctl::device::pac::Controller;
use axisctl::device::powercube::{self as cube_dev, Cubes};
use axisctl::device::supervisor;
use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
use axisctl::proto::powercube::table::ParamDef;
use axisctl::proto::powercube::ModuleId;
use axisctl::record::cdios::{CdiosSampler, CdiosValue};
use axisctl::record::pac::{PacSampler, PacValue};
use axisctl::record::powercube::CubeSampler;
use axisctl::record::{self, Sampler, Several};

use super::super::{usage, Ctx};
use super::{device_error, names, pace, Writer};
use crate::cli::record::RecordArgs;
use crate::output;

/// Whether the values name their devices (`DEVICE.VALUE`): the bench form.
pub(super) fn addressed(values: &[String]) -> bool {
    values.iter().any(|v| v.contains('.'))
}

/// The values of one device, checked, and the link it is read on.
struct Device<'b> {
    address: Address,
    link: &'b BenchLink,
    values: Values,
}

enum Values {
    PowerCube(Vec<&'static ParamDef>),
    Pac(Vec<PacValue>),
    Cdios(Vec<CdiosValue>),
}

/// The bench link a device is read on: the one the bench file names it
/// on, else the one carrying its family.
fn link_of(bench: &Bench, at: Address) -> anyhow::Result<&BenchLink> {
    let named = bench.links().iter().find(|l| l.carries(at.family()) && l.devices.values().any(|a| *a == at));
    Ok(match named {
        Some(l) => l,
        None => bench.link_for(at.family())?,
    })
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
            let values = match address {
                Address::PowerCube { .. } => {
                    given.iter().try_for_each(|n| super::super::names::check_powercube_param(n))?;
                    Values::PowerCube(cube_dev::readable_params(&given, false)?)
                }
                Address::Pac { axis: None } => {
                    return Err(usage("pac is the controller: record one of its axes, pac:AXIS.position"))
                }
                Address::Pac { .. } => {
                    Values::Pac(names(&given, PacValue::parse, PacValue::ALL.map(PacValue::name).as_slice())?)
                }
                Address::Cdios { .. } => {
                    Values::Cdios(names(&given, CdiosValue::parse, CdiosValue::ALL.map(CdiosValue::name).as_slice())?)
                }
            };
            Ok(Device { address, link: link_of(bench, address)?, values })
        })
        .collect()
}

/// The sampler of one device, on its link (kept open for the other
/// devices of the recording on the same port).
fn sampler(ctx: &Ctx, d: &Device) -> anyhow::Result<Box<dyn Sampler>> {
    let opts = ctx.session_options();
    let spec = &d.link.spec;
    Ok(match (&d.values, d.address) {
        (Values::PowerCube(params), Address::PowerCube { module }) => {
            let m = ModuleId::new(module).ok_or_else(|| usage(format!("module {module} out of range")))?;
            let cubes = Cubes::new(ctx.opener().powercube(spec, &opts)?);
            Box::new(CubeSampler::new(cubes, &[m], params).map_err(device_error)?)
        }
        (Values::Pac(values), Address::Pac { axis: Some(axis) }) => {
            let mut ctl = Controller::new(ctx.opener().pac(spec, &opts)?);
            ctl.set_axes(vec![axis]);
            Box::new(PacSampler::new(ctl, &[axis], values))
        }
        (Values::Cdios(values), Address::Cdios { node, module }) => {
            let node = NodeId::new(node).ok_or_else(|| usage(format!("node {node} out of range")))?;
            let module = CdiosModule::new(module).ok_or_else(|| usage(format!("module {module} out of range")))?;
            let mut session = ctx.opener().cdios(spec, &opts)?;
            session.set_nmt(true);
            Box::new(CdiosSampler::new(Node::new(session, node, ctx.retry), &[module], values).map_err(device_error)?)
        }
        _ => unreachable!("the values were checked for the device's family"),
    })
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
    let (period, until, format) = pace(ctx, args)?;
    // From here on a signal ends the recording between two samples.
    super::super::arm_interrupt()?;
    ctx.opener().keep_links_open();
    let mut parts = Vec::new();
    let mut links = Vec::new();
    for d in &devices {
        let part = sampler(ctx, d)?;
        links.extend(part.channels().iter().map(|_| d.link.text.clone()));
        parts.push(part);
    }
    let mut s = Several::new(parts);
    let mut writer = Writer::new(format);
    writer.header(record::Sampler::channels(&s), &links);
    let ended =
        record::record(&mut s, ctx.clock.as_ref(), period, until, &|| supervisor::stop_requested(), &mut |smp, _| {
            writer.sample(smp);
            Ok(())
        });
    output::flush();
    ended.map(|_| ()).map_err(device_error)
}
