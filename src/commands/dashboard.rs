//! `axisctl dashboard`: resolves which family lives on which link, opens
//! each link once, and hands the device sources to the TUI.
//!
//! Families on the same CAN link (PowerCube and Cdios on one bus) share one
//! opened link and one worker. `--link sim` builds one in-process bench:
//! PowerCube and Cdios on its in-memory CAN bus, the PA-CONTROL on its own
//! in-process serial line.

use std::io::IsTerminal;
use std::sync::Arc;

use axisctl::bench::Address;
use axisctl::family::{self, Family};
use axisctl::link::LinkSpec;
use axisctl::open::{OpenedLink, Opener, SessionOptions};
use axisctl::session::bus::CanBus;
use axisctl::tui::source::DeviceSource;
use axisctl::tui::worker::{Reopen, MAX_RATE, MIN_RATE};
use axisctl::tui::LinkPlan;

use super::{usage, Ctx};
use crate::cli::dashboard::DashboardArgs;
use crate::cli::ids::IdList;

pub fn run(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<()> {
    if !(MIN_RATE..=MAX_RATE).contains(&args.rate) {
        return Err(usage(format!("--rate {} is out of range {MIN_RATE} to {MAX_RATE} polls per second", args.rate)));
    }
    if !args.snapshot_dir.is_dir() {
        return Err(usage(format!("--snapshot-dir {}: no such directory", args.snapshot_dir.display())));
    }
    let plans = plan(ctx, args)?;
    if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
        return Err(usage("the dashboard needs a terminal (stdin and stdout); for scripts use the other commands"));
    }
    let r = axisctl::tui::run(plans, args.rate, args.snapshot_dir.clone(), Arc::clone(&ctx.clock));
    if let Some(t) = r.as_ref().err().and_then(|e| e.downcast_ref::<axisctl::tui::Terminated>()) {
        // The terminal is restored by now; exit as a shell reports a
        // process ended by the signal (143 SIGTERM, 129 SIGHUP).
        crate::output::err_line(format_args!("axisctl: {t}"));
        // Ctrl-Z sent with kill (the raw terminal turns the key into a
        // key): halted and restored, now stop as asked; continued, exit.
        axisctl::device::supervisor::suspend_if_asked();
        std::process::exit(128 + t.signal);
    }
    r
}

/// Which link each family is on, in registry order; a family left out has none.
#[derive(Debug, Default)]
struct Assignment(Vec<(Family, LinkSpec)>);

#[cfg(test)]
impl Assignment {
    fn get(&self, f: Family) -> Option<&LinkSpec> {
        self.0.iter().find(|(g, _)| *g == f).map(|(_, s)| s)
    }
}

/// The dashboard option naming a family's own link, and what it holds.
fn link_option(args: &DashboardArgs, f: Family) -> (&'static str, Option<&str>) {
    match f {
        Family::PowerCube => ("--cube-link", args.cube_link.as_deref()),
        Family::Pac => ("--pac-link", args.pac_link.as_deref()),
        Family::Cdios => ("--cdios-link", args.cdios_link.as_deref()),
    }
}

/// Whether `spec` can carry the family (`sim` carries every one).
fn fits(spec: &LinkSpec, f: Family) -> Result<(), String> {
    let kind = f.link_kind();
    match spec {
        LinkSpec::Sim(_) => Ok(()),
        LinkSpec::Serial { .. } if !kind.rs232() => {
            Err(format!("the {f} is on CAN (socketcan:, slcan:, socketcand: or sim)"))
        }
        LinkSpec::SocketCan { .. } | LinkSpec::Slcan { .. } | LinkSpec::Socketcand { .. } if !kind.can() => {
            Err(format!("the {f} talks RS232 (serial:TTY or sim)"))
        }
        _ => Ok(()),
    }
}

/// `dashboard -d`: each family of the devices named, on the link they are
/// on, showing those devices only: the PowerCube modules, the PA-CONTROL
/// axes (with their controller, the pane's head; `pac` alone: the
/// controller), the Cdios modules of one node.
fn named(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<(Assignment, Setup)> {
    let named = super::devices::any_family(ctx, &args.device)?;
    super::devices::pin_families(ctx, &named)?;
    let mut a = Assignment::default();
    for f in Family::ALL {
        if let Some((_, link)) = named.iter().find(|(at, _)| at.family() == f) {
            a.0.push((f, link.spec.clone()));
        }
    }
    let list = |id: &dyn Fn(Address) -> Option<u8>| {
        let ids: Vec<u8> = named.iter().filter_map(|(at, _)| id(*at)).collect();
        IdList(ids)
    };
    let has = |f: Family| a.0.iter().any(|(g, _)| *g == f);
    let mut setup = Setup::new(ctx, args);
    setup.modules = has(Family::PowerCube).then(|| {
        list(&|at| match at {
            Address::PowerCube { module } => Some(module),
            _ => None,
        })
    });
    setup.axes = has(Family::Pac).then(|| {
        list(&|at| match at {
            Address::Pac { axis } => axis,
            _ => None,
        })
    });
    let cdios: Vec<(u8, u8)> = named
        .iter()
        .filter_map(|(at, _)| match at {
            Address::Cdios { node, module } => Some((*node, *module)),
            _ => None,
        })
        .collect();
    if let Some((node, _)) = cdios.first() {
        if let Some((other, _)) = cdios.iter().find(|(n, _)| n != node) {
            return Err(usage(format!(
                "the dashboard shows one Cdios node; {} names nodes {node} and {other}",
                args.device.iter().map(ToString::to_string).collect::<Vec<_>>().join(",")
            )));
        }
        setup.node = *node;
        setup.cdios_modules = Some(IdList(cdios.iter().map(|(_, m)| *m).collect()));
    }
    Ok((a, setup))
}

fn assign(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<Assignment> {
    // A bench of several links or a bench file: each family on the link
    // that carries it, so that every device of every link is shown.
    let bench = ctx.given_bench()?.filter(|b| !b.is_single());
    let global = match bench {
        Some(_) => None,
        None => ctx.given_link()?.cloned(),
    };
    if let Some(g @ LinkSpec::Serial { .. }) = &global {
        if Family::ALL.iter().all(|f| link_option(args, *f).1.is_none() || !f.link_kind().rs232()) {
            let opts: Vec<_> = Family::ALL
                .into_iter()
                .filter(|f| f.link_kind().rs232())
                .map(|f| format!("{} ({f})", link_option(args, f).0))
                .collect();
            return Err(usage(format!(
                "{g} is a serial line, which carries one family: pass it as {}",
                family::join_or(&opts.iter().map(String::as_str).collect::<Vec<_>>())
            )));
        }
    }
    let mut a = Assignment::default();
    for f in Family::ALL.into_iter().filter(|f| !args.without.contains(f)) {
        let (opt, given) = link_option(args, f);
        let spec = match given {
            Some(text) => {
                let spec = text.parse::<LinkSpec>()?;
                fits(&spec, f).map_err(|why| usage(format!("{opt} {spec}: {why}")))?;
                spec
            }
            None if bench.is_some() => match bench.and_then(|b| b.links().iter().find(|l| l.carries(f))) {
                Some(l) => l.spec.clone(),
                None => continue,
            },
            // The global link serves every family it fits, except a serial
            // line: that carries one family, named by its own option.
            None => match global.clone().filter(|g| g.is_can() && fits(g, f).is_ok()) {
                Some(g) => g,
                None => continue,
            },
        };
        a.0.push((f, spec));
    }
    if a.0.is_empty() {
        return Err(usage(
            "no link given: pass --link URI (or --cube-link / --pac-link / --cdios-link); try --link sim for the simulated bench",
        ));
    }
    Ok(a)
}

/// What the device sources are built with, owned: a lost link is opened
/// again on its worker's thread, long after the arguments are gone. Each
/// family builds its source from it in its folder
/// (`commands/<family>/dashboard.rs`).
#[derive(Clone)]
pub struct Setup {
    pub opts: SessionOptions,
    pub modules: Option<IdList>,
    pub axes: Option<IdList>,
    pub node: u8,
    pub cdios_modules: Option<IdList>,
    pub retry: axisctl::session::RetryPolicy,
}

impl Setup {
    fn new(ctx: &Ctx, args: &DashboardArgs) -> Self {
        Self {
            // The screen is the trace: frames printed on stderr would tear it.
            opts: SessionOptions { trace: None, ..ctx.session_options() },
            modules: args.modules.clone(),
            axes: args.axes.clone(),
            node: args.node,
            cdios_modules: args.cdios_modules.clone(),
            retry: ctx.retry,
        }
    }

    /// The device source of `family` on an opened link (one that fits it:
    /// `assign` checked).
    fn source(&self, opener: &Opener, family: Family, link: OpenedLink) -> Box<dyn DeviceSource> {
        (super::family_cli(family).dashboard_source)(self, opener, link)
    }

    /// Opens `spec` and builds the sources of `fams` on it.
    fn open(
        &self,
        opener: &Opener,
        clock: &Arc<dyn axisctl::clock::Clock>,
        spec: &LinkSpec,
        can: bool,
        fams: &[Family],
    ) -> anyhow::Result<Vec<Box<dyn DeviceSource>>> {
        if can {
            let bus = CanBus::new(opener.can(spec, None)?, Arc::clone(clock));
            Ok(fams.iter().map(|&f| self.source(opener, f, OpenedLink::Can(Box::new(bus.port(f))))).collect())
        } else {
            fams.iter().map(|&f| Ok(self.source(opener, f, opener.open(spec, f)?))).collect()
        }
    }
}

/// How the status bar names a link.
fn link_name(spec: &LinkSpec, can: bool) -> String {
    match (spec, can) {
        (LinkSpec::Sim(_), true) => "sim CAN".into(),
        (LinkSpec::Sim(_), false) => "sim RS232".into(),
        _ => spec.to_string(),
    }
}

fn plan(ctx: &Ctx, args: &DashboardArgs) -> anyhow::Result<Vec<LinkPlan>> {
    // Ids were checked by clap, and `-d` by the bench, before any link
    // opens: a typo sends nothing.
    let (a, setup) = match args.device.is_empty() {
        true => (assign(ctx, args)?, Setup::new(ctx, args)),
        false => named(ctx, args)?,
    };
    let opener = ctx.opener();
    // Families on one CAN link share it and its worker; a serial line carries
    // one family. Links keep the order in which their first family comes.
    let mut links: Vec<(&LinkSpec, bool, Vec<Family>)> = Vec::new();
    for (f, spec) in &a.0 {
        let can = Opener::is_can(spec, *f);
        match links.iter_mut().find(|(s, c, _)| can && *c && *s == spec) {
            Some((_, _, fams)) => fams.push(*f),
            None => links.push((spec, can, vec![*f])),
        }
    }
    let mut plans = Vec::new();
    for (spec, can, fams) in links {
        let sources = setup.open(opener, &ctx.clock, spec, can, &fams)?;
        // A real link is opened again from the same path when it is lost;
        // the in-process simulator cannot go away.
        let reopen: Option<Reopen> = (!matches!(spec, LinkSpec::Sim(_))).then(|| {
            let (setup, opener, clock, spec) = (setup.clone(), opener.fresh(), Arc::clone(&ctx.clock), spec.clone());
            Box::new(move || setup.open(&opener, &clock, &spec, can, &fams).map_err(|e| format!("{e:#}"))) as Reopen
        });
        plans.push(LinkPlan { name: link_name(spec, can), sources, reopen });
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
        assert_eq!(
            (a.get(Family::PowerCube).cloned(), a.get(Family::Pac).cloned(), a.get(Family::Cdios).cloned()),
            (
                Some(LinkSpec::Sim(Default::default())),
                Some(LinkSpec::Sim(Default::default())),
                Some(LinkSpec::Sim(Default::default()))
            )
        );
        let a =
            resolve(&["axisctl", "--link", "socketcan:can0", "dashboard", "--pac-link", "serial:/dev/ttyS0"]).unwrap();
        assert_eq!(a.get(Family::PowerCube).cloned(), Some(LinkSpec::SocketCan { iface: "can0".into() }));
        assert_eq!(a.get(Family::Cdios).cloned(), a.get(Family::PowerCube).cloned());
        assert!(matches!(a.get(Family::Pac).cloned(), Some(LinkSpec::Serial { .. })));
        let a = resolve(&["axisctl", "--link", "sim", "dashboard", "--without", "pac"]).unwrap();
        assert_eq!(a.get(Family::Pac).cloned(), None);
    }

    /// On a bench of several links (or a bench file) each family takes the
    /// link that carries it; a family option still wins.
    #[test]
    fn a_bench_gives_each_family_its_link() {
        let (can, serial) = ("slcan:/dev/axisctl-a", "serial:/dev/axisctl-b");
        let a = resolve(&["axisctl", "--link", can, "--link", serial, "dashboard"]).unwrap();
        let text = |f| a.get(f).map(ToString::to_string);
        assert_eq!(text(Family::PowerCube).as_deref(), Some("slcan:/dev/axisctl-a?bitrate=1000000"));
        assert_eq!(text(Family::Cdios), text(Family::PowerCube));
        assert_eq!(text(Family::Pac).as_deref(), Some("serial:/dev/axisctl-b"));
        let a = resolve(&["axisctl", "--link", can, "--link", "socketcan:can1", "dashboard"]).unwrap();
        assert_eq!(a.get(Family::Pac), None, "no link carries the PA-CONTROL: left out");
        let a = resolve(&["axisctl", "--link", can, "--link", serial, "dashboard", "--cdios-link", "socketcan:can1"])
            .unwrap();
        assert_eq!(a.get(Family::Cdios).map(ToString::to_string).as_deref(), Some("socketcan:can1"));
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("bench.toml");
        std::fs::write(&file, format!("[[link]]\nspec = \"{serial}\"\n[[link]]\nspec = \"{can}\"\n")).unwrap();
        let a = resolve(&["axisctl", "--bench", file.to_str().unwrap(), "dashboard"]).unwrap();
        assert_eq!(a.0.len(), 3, "{a:?}");
        assert_eq!(a.get(Family::Pac).map(ToString::to_string).as_deref(), Some("serial:/dev/axisctl-b"));
    }

    #[test]
    fn ambiguous_or_missing_links_are_usage_errors() {
        for argv in [
            &["axisctl", "dashboard"][..],
            &["axisctl", "--link", "serial:/dev/ttyS0", "dashboard"],
            &["axisctl", "dashboard", "--cdios-link", "serial:/dev/ttyS0"],
            &["axisctl", "dashboard", "--pac-link", "socketcan:can0"],
        ] {
            let e = resolve(argv).err().unwrap_or_else(|| panic!("{argv:?} accepted"));
            assert_eq!(super::super::classify(&e), axisctl::session::ErrorKind::Usage, "{argv:?}: {e}");
        }
        // Checked by clap (exit 2) before anything opens.
        for argv in [
            &["axisctl", "--link", "sim", "dashboard", "--without", "robots"][..],
            &["axisctl", "--link", "sim", "dashboard", "--modules", "0"],
            &["axisctl", "--link", "sim", "dashboard", "--axes", "17"],
            &["axisctl", "--link", "sim", "dashboard", "--cdios-modules", "16"],
            &["axisctl", "--link", "sim", "dashboard", "--node", "128"],
        ] {
            let e = crate::cli::Cli::try_parse_from(argv).err().unwrap_or_else(|| panic!("{argv:?} accepted"));
            assert!(e.use_stderr(), "{argv:?}");
        }
        let cli =
            crate::cli::Cli::try_parse_from(["axisctl", "dashboard", "--without", "PA-CONTROL", "--axes", "2,1-2"]);
        let crate::cli::Command::Dashboard(args) = cli.unwrap().command else { panic!("not a dashboard") };
        assert_eq!((args.without, args.axes.map(|l| l.0)), (vec![Family::Pac], Some(vec![1, 2])));
    }

    /// Runs every source of the plans once: a scan and a poll of each device,
    /// which is traffic on every link.
    fn exercise(argv: &[&str]) {
        let cli = crate::cli::Cli::try_parse_from(argv).unwrap();
        let ctx = Ctx::resolve(&cli.global).unwrap();
        let crate::cli::Command::Dashboard(args) = cli.command else { panic!("not a dashboard") };
        for p in plan(&ctx, &args).unwrap() {
            for mut s in p.sources {
                let devices = s.discover().unwrap_or_else(|e| panic!("{}: {e}", p.name));
                assert!(!devices.is_empty(), "{}: no device", p.name);
                for d in devices {
                    let _ = s.poll(d);
                }
            }
        }
    }

    /// The devices the dashboard of `argv` shows (each source's discovery, in
    /// the order of its links), after one poll of each; the PowerCube
    /// modules its traffic names (`--log`, as candump ids 0x0A0..0x0DF).
    fn shown(argv: &[&str]) -> (Vec<Address>, std::collections::BTreeSet<u32>) {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("frames.log");
        let mut all = vec!["axisctl", "--log", log.to_str().unwrap()];
        all.extend_from_slice(&argv[1..]);
        let cli = crate::cli::Cli::try_parse_from(&all).unwrap();
        let ctx = Ctx::resolve(&cli.global).unwrap();
        let crate::cli::Command::Dashboard(args) = cli.command else { panic!("not a dashboard") };
        let mut out = Vec::new();
        for p in plan(&ctx, &args).unwrap() {
            for mut s in p.sources {
                let devices = s.discover().unwrap_or_else(|e| panic!("{}: {e}", p.name));
                for d in &devices {
                    let _ = s.poll(*d);
                }
                out.extend(devices);
            }
        }
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        let modules = text
            .lines()
            .filter_map(|l| axisctl::proto::candump::parse_candump_line(l).ok())
            .map(|(_, _, f)| f.id())
            .filter(|id| (0x0A0..=0x0DF).contains(id))
            .map(|id| id & 0x1F)
            .collect();
        (out, modules)
    }

    /// `-d` shows exactly the devices named, of every family, by address or
    /// bench file name; a PA-CONTROL axis with its controller.
    #[test]
    fn d_shows_exactly_the_devices_named() {
        let bench = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/sim-bench.toml");
        let (pc, pac, cdios) = (
            |module| Address::PowerCube { module },
            |axis| Address::Pac { axis },
            |node, module| Address::Cdios { node, module },
        );
        let (devices, modules) = shown(&["axisctl", "--link", "sim", "dashboard", "-d", "pac:2,powercube:5,cdios:1/1"]);
        assert_eq!(devices, [pc(5), cdios(1, 1), pac(None), pac(Some(2))]);
        assert_eq!(modules, [5].into(), "no frame of another module");
        let (devices, _) = shown(&["axisctl", "--bench", bench, "dashboard", "-d", "gripper,shoulder"]);
        assert_eq!(devices, [pc(3), cdios(1, 0)], "no PA-CONTROL source");
        let (devices, _) = shown(&["axisctl", "--link", "sim", "dashboard", "--device", "pac"]);
        assert_eq!(devices, [pac(None)]);
    }

    #[test]
    fn a_device_the_dashboard_cannot_show_is_refused_before_opening() {
        for argv in [
            &["axisctl", "--link", "sim", "dashboard", "-d", "cdios:1/0,cdios:2/0"][..],
            &["axisctl", "--link", "sim", "dashboard", "-d", "wrist"],
            &["axisctl", "--link", "socketcan:axisctl-none", "dashboard", "-d", "pac:1"],
        ] {
            let cli = crate::cli::Cli::try_parse_from(argv).unwrap();
            let ctx = Ctx::resolve(&cli.global).unwrap();
            let crate::cli::Command::Dashboard(args) = cli.command else { panic!("not a dashboard") };
            let e = plan(&ctx, &args).err().unwrap_or_else(|| panic!("{argv:?} accepted"));
            assert_eq!(super::super::classify(&e), axisctl::session::ErrorKind::Usage, "{argv:?}: {e}");
        }
        for argv in [
            &["axisctl", "--link", "sim", "dashboard", "-d", "powercube:3", "-m", "3"][..],
            &["axisctl", "--link", "sim", "dashboard", "-d", "powercube:3", "--without", "pac"],
            &["axisctl", "--link", "sim", "dashboard", "-d", "pac:1", "--pac-link", "sim"],
        ] {
            let e = crate::cli::Cli::try_parse_from(argv).err().unwrap_or_else(|| panic!("{argv:?} accepted"));
            assert!(e.use_stderr(), "{argv:?}");
        }
    }

    /// The families of the CAN frames in a traffic log, and its serial lines.
    fn logged(path: &std::path::Path) -> (Vec<Family>, Vec<String>) {
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let (mut can, mut serial) = (Vec::new(), Vec::new());
        for line in text.lines() {
            match axisctl::proto::candump::parse_candump_line(line) {
                Ok((_, _, frame)) => can.extend(axisctl::monitor::describe(&frame).family),
                Err(_) => serial.push(line.to_string()),
            }
        }
        (can, serial)
    }

    #[test]
    fn log_records_every_sim_link_of_the_dashboard() {
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("sim.log");
        exercise(&["axisctl", "--log", log.to_str().unwrap(), "--link", "sim", "dashboard", "--modules", "3"]);
        let (can, serial) = logged(&log);
        assert!(can.contains(&Family::PowerCube), "no PowerCube CAN frame logged");
        assert!(can.contains(&Family::Cdios), "no Cdios frame logged");
        // PA-CONTROL frames open with SOH STX.
        assert!(serial.iter().any(|l| l.contains(") tx 01 02 ")), "no PA-CONTROL request logged: {serial:?}");
        assert!(serial.iter().any(|l| l.contains(") rx 01 02 ")), "no PA-CONTROL answer logged: {serial:?}");
    }

    #[test]
    fn log_records_the_powercube_rs232_line_of_the_dashboard() {
        use std::sync::atomic::{AtomicBool, Ordering};
        let clock: Arc<dyn axisctl::clock::Clock> = Arc::new(axisctl::clock::SystemClock);
        let bench = axisctl::sim::bench::Bench::contract(Arc::clone(&clock));
        let (master, pty) = axisctl::link::pty::open_pair().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let server = {
            let (cubes, stop) = (axisctl::sim::bench::PowerCubeRs232(Arc::clone(&bench.powercube)), Arc::clone(&stop));
            std::thread::spawn(move || {
                axisctl::sim::serve::serial(
                    Box::new(master),
                    cubes,
                    clock,
                    &stop,
                    None,
                    Default::default(),
                    Default::default(),
                )
            })
        };
        let dir = tempfile::tempdir().unwrap();
        let log = dir.path().join("rs232.log");
        let link = format!("serial:{pty}");
        exercise(&["axisctl", "--log", log.to_str().unwrap(), "dashboard", "--cube-link", &link, "--modules", "3"]);
        stop.store(true, Ordering::SeqCst);
        server.join().unwrap().unwrap();
        let (can, serial) = logged(&log);
        assert!(can.is_empty(), "{can:?}");
        assert!(serial.iter().any(|l| l.contains(") tx 02 ")), "no PowerCube RS232 request logged: {serial:?}");
        assert!(serial.iter().any(|l| l.contains(") rx 02 ")), "no PowerCube RS232 answer logged: {serial:?}");
    }
}
