//! `axisctl dashboard`: resolves which family lives on which link, opens
//! each link once, and hands the device sources to the TUI.
//!
//! Families on the same CAN link (PowerCube and Cdios on one bus) share one
//! opened link and one worker. `--link sim` builds one in-process bench:
//! PowerCube and Cdios on its in-memory CAN bus, the PA-CONTROL on its own
//! in-process serial line.

use std::io::IsTerminal;
use std::sync::Arc;

use axisctl::link::log::{log_iface, LoggedCanLink, TrafficLog};
use axisctl::link::{self, CanLink, LinkSpec};
use axisctl::proto::cdios::{ModuleId as CdiosModule, NodeId};
use axisctl::session::bus::{CanBus, Route};
use axisctl::session::cdios::Cdios;
use axisctl::session::pac::Pac;
use axisctl::session::powercube::PowerCube;
use axisctl::tui::cdios::CdiosSource;
use axisctl::tui::pac::PacSource;
use axisctl::tui::powercube::CubeSource;
use axisctl::tui::source::{DeviceSource, Family};
use axisctl::tui::worker::{MAX_RATE, MIN_RATE};
use axisctl::tui::LinkPlan;

use super::{usage, Ctx};
use crate::cli_dashboard::DashboardArgs;

pub fn run(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<()> {
    if !(MIN_RATE..=MAX_RATE).contains(&args.rate) {
        return Err(usage(format!("--rate {} is out of range {MIN_RATE}..={MAX_RATE} polls per second", args.rate)));
    }
    let plans = plan(ctx, args)?;
    if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
        return Err(usage("the dashboard needs a terminal (stdin and stdout); for scripts use the other commands"));
    }
    axisctl::tui::run(plans, args.rate, Arc::clone(&ctx.clock))
}

/// Which link each family is on.
#[derive(Debug, Default)]
struct Assignment {
    cube: Option<LinkSpec>,
    pac: Option<LinkSpec>,
    cdios: Option<LinkSpec>,
}

fn parse_spec(opt: &Option<String>) -> anyhow::Result<Option<LinkSpec>> {
    Ok(opt.as_deref().map(str::parse::<LinkSpec>).transpose()?)
}

fn assign(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<Assignment> {
    for w in &args.without {
        if !["powercube", "pac", "cdios"].contains(&w.as_str()) {
            return Err(usage(format!("--without {w:?}: expected powercube, pac or cdios")));
        }
    }
    let keep = |f: &str| !args.without.iter().any(|w| w == f);
    let global = ctx.link.clone();
    if let (Some(g @ LinkSpec::Serial { .. }), None, None) = (&global, &args.cube_link, &args.pac_link) {
        return Err(usage(format!(
            "{g} is a serial line, which carries one family: pass it as --cube-link (PowerCube RS232) or --pac-link (PA-CONTROL)"
        )));
    }
    let can_global = global.clone().filter(LinkSpec::is_can);
    let a = Assignment {
        cube: parse_spec(&args.cube_link)?.or(can_global.clone()).filter(|_| keep("powercube")),
        pac: parse_spec(&args.pac_link)?.or(global.clone().filter(|g| *g == LinkSpec::Sim)).filter(|_| keep("pac")),
        cdios: parse_spec(&args.cdios_link)?.or(can_global).filter(|_| keep("cdios")),
    };
    if let Some(s) = &a.cdios {
        if !s.is_can() {
            return Err(usage(format!("--cdios-link {s}: the Cdios is on CAN (socketcan:, slcan: or sim)")));
        }
    }
    if let Some(s @ (LinkSpec::SocketCan { .. } | LinkSpec::Slcan { .. })) = &a.pac {
        return Err(usage(format!("--pac-link {s}: the PA-CONTROL talks RS232 (serial:TTY or sim)")));
    }
    if a.cube.is_none() && a.pac.is_none() && a.cdios.is_none() {
        return Err(usage(
            "no link given: pass --link URI (or --cube-link / --pac-link / --cdios-link); try --link sim for the simulated bench",
        ));
    }
    Ok(a)
}

fn parse_cube_modules(args: &DashboardArgs) -> anyhow::Result<Option<Vec<axisctl::proto::powercube::ModuleId>>> {
    args.modules.as_deref().map(super::powercube::parse_ids).transpose()
}

fn parse_cdios_modules(args: &DashboardArgs) -> anyhow::Result<Option<Vec<CdiosModule>>> {
    let Some(text) = args.cdios_modules.as_deref() else { return Ok(None) };
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let m = part
            .parse::<u8>()
            .ok()
            .and_then(CdiosModule::new)
            .ok_or_else(|| usage(format!("{part:?} in --cdios-modules is not a module id 0..15")))?;
        if !out.contains(&m) {
            out.push(m);
        }
    }
    if out.is_empty() {
        return Err(usage("--cdios-modules lists no module"));
    }
    Ok(Some(out))
}

fn parse_axes(args: &DashboardArgs) -> anyhow::Result<Option<Vec<u8>>> {
    let Some(text) = args.axes.as_deref() else { return Ok(None) };
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let a = part
            .parse::<u8>()
            .ok()
            .filter(|a| (1..=axisctl::proto::pac::table::MAX_AXES).contains(a))
            .ok_or_else(|| usage(format!("{part:?} in --axes is not an axis 1..16")))?;
        if !out.contains(&a) {
            out.push(a);
        }
    }
    if out.is_empty() {
        return Err(usage("--axes lists no axis"));
    }
    Ok(Some(out))
}

fn powercube_on(ctx: &Ctx, pc: PowerCube, args: &DashboardArgs) -> anyhow::Result<Box<dyn DeviceSource>> {
    let mut pc = pc.with_clock(Arc::clone(&ctx.clock));
    if let Some(t) = ctx.timeout {
        pc.set_timeout(t);
    }
    pc.set_retry(ctx.retry);
    Ok(Box::new(CubeSource::new(pc, parse_cube_modules(args)?)))
}

/// The sources of the CAN families on one opened link.
fn can_sources(
    ctx: &Ctx,
    args: &DashboardArgs,
    bus: CanBus,
    families: &[Family],
) -> anyhow::Result<Vec<Box<dyn DeviceSource>>> {
    let mut out = Vec::new();
    for f in families {
        match f {
            Family::PowerCube => {
                out.push(powercube_on(ctx, PowerCube::over_can(Box::new(bus.port(Route::PowerCube))), args)?)
            }
            Family::Cdios => {
                let mut s = Cdios::new(Box::new(bus.port(Route::Cdios))).with_clock(Arc::clone(&ctx.clock));
                if let Some(t) = ctx.timeout {
                    s.set_timeout(t);
                }
                s.set_retry(ctx.retry);
                let node = NodeId::new(args.node).expect("clap checks 1..=127");
                out.push(Box::new(CdiosSource::new(s, node, parse_cdios_modules(args)?, ctx.retry)));
            }
            Family::Pac => unreachable!("the PA-CONTROL is not on CAN"),
        }
    }
    Ok(out)
}

fn open_can(ctx: &Ctx, spec: &LinkSpec) -> anyhow::Result<Box<dyn CanLink>> {
    let l = link::open_can(spec)?;
    Ok(match &ctx.log {
        Some(path) => Box::new(LoggedCanLink::new(l, TrafficLog::append(path, &log_iface(spec))?)),
        None => l,
    })
}

fn plan(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<Vec<LinkPlan>> {
    let a = assign(ctx, args)?;
    // Checked before any link opens: a typo sends nothing.
    parse_cube_modules(args)?;
    parse_cdios_modules(args)?;
    parse_axes(args)?;
    let uses_sim = [&a.cube, &a.pac, &a.cdios].iter().any(|s| **s == Some(LinkSpec::Sim));
    let bench = if uses_sim { Some(ctx.sim_bench()?) } else { None };
    let mut plans = Vec::new();
    // CAN families, grouped by link.
    let mut groups: Vec<(LinkSpec, Vec<Family>)> = Vec::new();
    for (f, spec) in [(Family::PowerCube, &a.cube), (Family::Cdios, &a.cdios)] {
        let Some(spec) = spec else { continue };
        if let LinkSpec::Serial { path, baud, format } = spec {
            // PowerCube RS232: a line of its own.
            let baud = baud.unwrap_or(9600);
            let l = link::open_bytes(path, baud, format.unwrap_or(link::SerialFormat::F8N1))?;
            plans.push(LinkPlan {
                name: spec.to_string(),
                sources: vec![powercube_on(ctx, PowerCube::over_rs232(l, baud), args)?],
            });
            continue;
        }
        match groups.iter_mut().find(|(s, _)| s == spec) {
            Some((_, fams)) => fams.push(f),
            None => groups.push((spec.clone(), vec![f])),
        }
    }
    for (spec, fams) in groups {
        let (name, link) = match (&spec, &bench) {
            (LinkSpec::Sim, Some(b)) => ("sim CAN".to_string(), Box::new(b.bus.open()) as Box<dyn CanLink>),
            _ => (spec.to_string(), open_can(ctx, &spec)?),
        };
        let sources = can_sources(ctx, args, CanBus::new(link, Arc::clone(&ctx.clock)), &fams)?;
        if !sources.is_empty() {
            plans.push(LinkPlan { name, sources });
        }
    }
    if let Some(spec) = &a.pac {
        let pac = match (spec, &bench) {
            (LinkSpec::Sim, Some(b)) => {
                let l: Box<dyn link::ByteLink> = Box::new(b.pac_link(Arc::clone(&ctx.clock)));
                Pac::new(l, 9600, link::SerialFormat::F7N1)
            }
            (LinkSpec::Serial { path, baud, format }, _) => {
                let baud = baud.unwrap_or(9600);
                let format = format.unwrap_or(link::SerialFormat::F7N1);
                Pac::new(link::open_bytes(path, baud, format)?, baud, format)
            }
            _ => unreachable!("checked in assign"),
        };
        let mut pac = pac.with_clock(Arc::clone(&ctx.clock));
        if let Some(t) = ctx.timeout {
            pac.set_timeout(t);
        }
        pac.set_retry(ctx.retry);
        if ctx.pac_check_etx {
            pac.set_check_rule(axisctl::proto::pac::CheckRule::WithEtx);
        }
        let name = if *spec == LinkSpec::Sim { "sim RS232".to_string() } else { spec.to_string() };
        plans.push(LinkPlan { name, sources: vec![Box::new(PacSource::new(pac, parse_axes(args)?))] });
    }
    Ok(plans)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn resolve(argv: &[&str]) -> anyhow::Result<Assignment> {
        let cli = crate::cli::Cli::try_parse_from(argv).unwrap();
        let ctx = Ctx::resolve(&cli.global).unwrap();
        let crate::cli::Command::Dashboard(args) = cli.command else { panic!("not a dashboard") };
        assign(&ctx, &args)
    }

    #[test]
    fn link_options_resolve_per_family() {
        let a = resolve(&["axisctl", "--link", "sim", "dashboard"]).unwrap();
        assert_eq!((a.cube, a.pac, a.cdios), (Some(LinkSpec::Sim), Some(LinkSpec::Sim), Some(LinkSpec::Sim)));
        let a =
            resolve(&["axisctl", "--link", "socketcan:can0", "dashboard", "--pac-link", "serial:/dev/ttyS0"]).unwrap();
        assert_eq!(a.cube, Some(LinkSpec::SocketCan { iface: "can0".into() }));
        assert_eq!(a.cdios, a.cube);
        assert!(matches!(a.pac, Some(LinkSpec::Serial { .. })));
        let a = resolve(&["axisctl", "--link", "sim", "dashboard", "--without", "pac"]).unwrap();
        assert_eq!(a.pac, None);
    }

    #[test]
    fn ambiguous_or_missing_links_are_usage_errors() {
        for argv in [
            &["axisctl", "dashboard"][..],
            &["axisctl", "--link", "serial:/dev/ttyS0", "dashboard"],
            &["axisctl", "dashboard", "--cdios-link", "serial:/dev/ttyS0"],
            &["axisctl", "dashboard", "--pac-link", "socketcan:can0"],
            &["axisctl", "--link", "sim", "dashboard", "--without", "robots"],
        ] {
            let e = resolve(argv).err().unwrap_or_else(|| panic!("{argv:?} accepted"));
            assert_eq!(super::super::classify(&e), axisctl::session::ErrorKind::Usage, "{argv:?}: {e}");
        }
    }
}
