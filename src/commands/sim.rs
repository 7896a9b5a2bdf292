//! `axisctl sim`: serve the simulated bench on pseudo-terminals (or a
//! SocketCAN interface) until SIGINT / SIGTERM; one JSON line per served link.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context as _;
use axisctl::link::{self, LinkSpec};
use axisctl::sim::bench::{Bench, BenchConfig, PowerCubeRs232};
use axisctl::sim::fault::{ByteFaults, ByteProtocol, FaultSpec, Injector, Trip};
use axisctl::sim::serve;

use super::{usage, Ctx};
use crate::cli::SimArgs;

fn parse_list(text: &str, what: &str, max: u8) -> anyhow::Result<Vec<u8>> {
    text.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<u8>().ok().filter(|v| *v <= max).ok_or_else(|| usage(format!("{what}: {s:?} is not 0..={max}")))
        })
        .collect()
}

enum Where {
    PtySerial,
    PtySlcan,
    SocketCan(String),
}

fn parse_where(text: &str, family: &str) -> anyhow::Result<Where> {
    match text {
        "pty-serial" => Ok(Where::PtySerial),
        "pty-slcan" => Ok(Where::PtySlcan),
        _ => match text.parse::<LinkSpec>() {
            Ok(LinkSpec::SocketCan { iface }) => Ok(Where::SocketCan(iface)),
            _ => Err(usage(format!("--{family} {text:?}: expected pty-serial, pty-slcan or socketcan:IFACE"))),
        },
    }
}

fn announce(family: &str, link: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{}", serde_json::json!({"family": family, "link": link}));
    let _ = out.flush();
}

pub fn run(ctx: &Ctx, args: &SimArgs) -> anyhow::Result<()> {
    let modules = parse_list(&args.modules, "--modules", 31)?;
    if modules.contains(&0) {
        return Err(usage("--modules: PowerCube ids are 1..31"));
    }
    let linear = parse_list(&args.linear, "--linear", 31)?;
    if !(1..=127).contains(&args.node) {
        return Err(usage(format!("--node {}: Cdios node ids are 1..127", args.node)));
    }
    let cdios_modules = parse_list(&args.cdios_modules, "--cdios-modules", 15)?;
    if !(1..=axisctl::proto::pac::table::MAX_AXES).contains(&args.axes) {
        return Err(usage(format!("--axes: {} is not 1..={}", args.axes, axisctl::proto::pac::table::MAX_AXES)));
    }
    let cfg = BenchConfig { modules, linear, node: args.node, cdios_modules, axes: args.axes };
    let only_some = args.powercube.is_some() || args.pac.is_some() || args.cdios.is_some();
    // What is served where: with no family option, PowerCube and Cdios share one slcan bus.
    let mut served: Vec<(Where, Vec<&str>)> = Vec::new();
    match (&args.powercube, &args.cdios) {
        (None, None) if !only_some => served.push((Where::PtySlcan, vec!["powercube", "cdios"])),
        (pc, cd) => {
            if let Some(w) = pc {
                served.push((parse_where(w, "powercube")?, vec!["powercube"]));
            }
            if let Some(w) = cd {
                match parse_where(w, "cdios")? {
                    Where::PtySerial => {
                        return Err(usage("--cdios pty-serial: Cdios is CAN only (pty-slcan or socketcan:IFACE)"))
                    }
                    w => served.push((w, vec!["cdios"])),
                }
            }
        }
    }
    // The PA-CONTROL has only its RS232 port.
    let pac_where = match args.pac.as_deref() {
        Some("pty-serial") => Some(Where::PtySerial),
        Some(other) => return Err(usage(format!("--pac {other:?}: the PA-CONTROL is served on pty-serial only"))),
        None if !only_some => Some(Where::PtySerial),
        None => None,
    };

    let faults = args
        .fault
        .as_deref()
        .map(|f| f.parse::<FaultSpec>().map_err(|e| usage(format!("--fault: {e}"))))
        .transpose()?;
    let bench = Bench::new(&cfg, Arc::clone(&ctx.clock));
    if args.wire_speed {
        bench.bus.set_bitrate(Some(args.bitrate));
        serve::precise_timers();
    }
    if let Some(spec) = faults {
        bench.inject_faults(spec, args.fault_seed);
    }
    // Every serial line draws its faults from its own generator.
    let noise = |protocol, seed_offset: u64| match faults {
        None => serve::Noise::default(),
        Some(spec) => {
            let inj = Arc::new(std::sync::Mutex::new(Injector::new(spec, args.fault_seed.wrapping_add(seed_offset))));
            let trip = spec.trip.map(|d| match protocol {
                ByteProtocol::PowerCube => Trip::new(d).powercube(Arc::clone(&bench.powercube)),
                ByteProtocol::Pac => Trip::new(d).pac(Arc::clone(&bench.pac)),
            });
            serve::Noise { faults: spec.touches_answers().then(|| ByteFaults::new(inj, protocol)), trip }
        }
    };
    let pace = |format| args.wire_speed.then(|| serve::Pace::serial(args.baud, format));
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst))
            .context("installing the SIGINT/SIGTERM handler")?;
    }
    let mut threads = Vec::new();
    for (w, families) in served {
        let announce_all = |link: &str| families.iter().for_each(|f| announce(f, link));
        match w {
            Where::PtySerial => {
                let (master, path) = link::pty::open_pair()?;
                announce_all(&format!("serial:{path}?baud={}&format=8N1", args.baud));
                let (pc, clock, stop) = (Arc::clone(&bench.powercube), Arc::clone(&ctx.clock), Arc::clone(&stop));
                let (pace, noise) = (pace(link::SerialFormat::F8N1), noise(ByteProtocol::PowerCube, 1));
                threads.push(std::thread::spawn(move || {
                    serve::serial(Box::new(master), PowerCubeRs232(pc), clock, &stop, pace, noise)
                }));
            }
            Where::PtySlcan => {
                let (master, path) = link::pty::open_pair()?;
                announce_all(&format!("slcan:{path}"));
                let (client, stop) = (bench.bus.open(), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::slcan(Box::new(master), client, &stop)));
            }
            Where::SocketCan(iface) => {
                let spec = LinkSpec::SocketCan { iface: iface.clone() };
                let ext = link::open_can(&spec).with_context(|| format!("opening {spec}"))?;
                announce_all(&spec.to_string());
                let (client, stop) = (bench.bus.open(), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::bridge(ext, client, &stop)));
            }
        }
    }
    if let Some(Where::PtySerial) = pac_where {
        let (master, path) = link::pty::open_pair()?;
        announce("pac", &format!("serial:{path}?baud={}&format=7N1", args.baud));
        let (pac, clock, stop) = (Arc::clone(&bench.pac), Arc::clone(&ctx.clock), Arc::clone(&stop));
        let (pace, noise) = (pace(link::SerialFormat::F7N1), noise(ByteProtocol::Pac, 2));
        threads.push(std::thread::spawn(move || serve::serial(Box::new(master), pac, clock, &stop, pace, noise)));
    }
    for t in threads {
        match t.join() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(e).context("serving the simulated bench"),
            Err(_) => anyhow::bail!("a serving thread panicked"),
        }
    }
    Ok(())
}
