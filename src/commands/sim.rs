//! `axisctl sim`: serve the simulated bench on pseudo-terminals (or a
//! SocketCAN interface) until SIGINT / SIGTERM; one JSON line per served link.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context as _;
use axisctl::family::{self, Family};
use axisctl::link::{self, LinkSpec};
use axisctl::sim::bench::{Bench, BenchConfig, PowerCubeRs232};
use axisctl::sim::fault::{ByteFaults, ByteProtocol, FaultSpec, Injector, Trip};
use axisctl::sim::serve;

use super::sim_tap::{self, Protocol};
use super::{usage, Ctx};
use crate::cli::SimArgs;

enum Where {
    PtySerial,
    PtySlcan,
    SocketCan(String),
}

/// Where `--FAMILY WHERE` serves the family, as far as its link kind allows.
fn parse_where(text: &str, family: Family) -> anyhow::Result<Where> {
    let kind = family.link_kind();
    let w = match text {
        "pty-serial" => Where::PtySerial,
        "pty-slcan" => Where::PtySlcan,
        _ => match text.parse::<LinkSpec>() {
            Ok(LinkSpec::SocketCan { iface }) => Where::SocketCan(iface),
            _ => {
                let forms: Vec<_> =
                    [(kind.rs232(), "pty-serial"), (kind.can(), "pty-slcan"), (kind.can(), "socketcan:IFACE")]
                        .into_iter()
                        .filter_map(|(ok, f)| ok.then_some(f))
                        .collect();
                return Err(usage(format!("--{} {text:?}: expected {}", family.name(), family::join_or(&forms))));
            }
        },
    };
    match (&w, kind.can(), kind.rs232()) {
        (Where::PtySerial, _, false) => Err(usage(format!(
            "--{} pty-serial: {} is CAN only (pty-slcan or socketcan:IFACE)",
            family.name(),
            family.display_name()
        ))),
        (Where::PtySlcan | Where::SocketCan(_), false, _) => Err(usage(format!(
            "--{} {text:?}: the {} is served on pty-serial only",
            family.name(),
            family.display_name()
        ))),
        _ => Ok(w),
    }
}

/// One line per served link, flushed at once: a client waits for it. A
/// failed write is recorded; the caller stops serving, since no client can
/// learn the link.
fn announce(family: Family, link: &str) {
    let mut out = std::io::stdout().lock();
    let written = writeln!(out, "{}", serde_json::json!({"family": family, "link": link})).and_then(|()| out.flush());
    if let Err(e) = written {
        crate::output::note_failure(&e);
    }
}

fn serial_format(f: Family) -> link::SerialFormat {
    f.serial_default().map_or(link::SerialFormat::F8N1, |d| d.format)
}

/// The `--link` a client passes to reach a served line. What equals the
/// family's default is left out, so that the link has no `&` and pastes
/// into a shell unquoted: `serial:/dev/pts/8` for the PA-CONTROL's 9600 7N1.
fn serial_uri(path: &str, baud: u32, f: Family) -> String {
    let default = f.serial_default();
    let baud = (default.map(|d| d.baud) != Some(baud)).then_some(baud);
    LinkSpec::Serial { path: path.into(), baud, format: default.is_none().then(|| serial_format(f)) }.to_string()
}

/// The bus name the simulated daemon serves, as `socketcand -i can0` would.
const SOCKETCAND_BUS: &str = "can0";

/// Listens on `addr` (`HOST:PORT`, port 0 for any); the link a client
/// passes. A wildcard address is announced as the loopback one.
fn bind_socketcand(addr: &str) -> anyhow::Result<(std::net::TcpListener, String)> {
    let parsed: std::net::SocketAddr = addr.parse().map_err(|_| {
        usage(format!("--socketcand {addr:?}: expected IP:PORT, e.g. 127.0.0.1:29536 (port 0: any free port)"))
    })?;
    let listener = std::net::TcpListener::bind(parsed)
        .map_err(|source| link::LinkError::Open { path: addr.to_string(), source })
        .context("--socketcand")?;
    let local = listener.local_addr()?;
    let ip = match local.ip() {
        std::net::IpAddr::V4(v4) if v4.is_unspecified() => std::net::Ipv4Addr::LOCALHOST.into(),
        std::net::IpAddr::V6(v6) if v6.is_unspecified() => std::net::Ipv6Addr::LOCALHOST.into(),
        ip => ip,
    };
    let spec = LinkSpec::Socketcand { host: ip.to_string(), port: local.port(), bus: SOCKETCAND_BUS.into(), rtt: None };
    Ok((listener, spec.to_string()))
}

pub fn run(ctx: &Ctx, args: &SimArgs) -> anyhow::Result<()> {
    // Ids and their ranges were checked by clap.
    let cfg = BenchConfig {
        modules: args.modules.0.clone(),
        linear: args.linear.0.clone(),
        node: args.node,
        cdios_modules: args.cdios_modules.0.clone(),
        axes: args.axes,
    };
    let only_some = args.powercube.is_some() || args.pac.is_some() || args.cdios.is_some() || args.socketcand.is_some();
    // Bound before anything is served: a bad or taken address fails the start.
    let socketcand = args.socketcand.as_deref().map(bind_socketcand).transpose()?;
    // What is served where: with no family option, PowerCube and Cdios share one slcan bus.
    let mut served: Vec<(Where, Vec<Family>)> = Vec::new();
    match (&args.powercube, &args.cdios) {
        (None, None) if !only_some => served.push((Where::PtySlcan, vec![Family::PowerCube, Family::Cdios])),
        (pc, cd) => {
            for (w, f) in [(pc, Family::PowerCube), (cd, Family::Cdios)] {
                if let Some(w) = w {
                    served.push((parse_where(w, f)?, vec![f]));
                }
            }
        }
    }
    let pac_where = match args.pac.as_deref() {
        Some(w) => Some(parse_where(w, Family::Pac)?),
        None if !only_some => Some(Where::PtySerial),
        None => None,
    };

    let faults = args
        .fault
        .as_deref()
        .map(|f| f.parse::<FaultSpec>().map_err(|e| usage(format!("--fault: {e}"))))
        .transpose()?;
    let bench = Bench::new(&cfg, Arc::clone(&ctx.clock));
    if ctx.trace {
        axisctl::sim::shared::lock(&bench.powercube)
            .set_tracer(Some(|s| crate::output::err_line(format_args!("sim: {s}"))));
    }
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
                ByteProtocol::PowerCube => Trip::new(d).watch(bench.powercube.clone()),
                ByteProtocol::Pac => Trip::new(d).watch(bench.pac.clone()),
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
    // One log line per frame or chunk, each link under a name of its own.
    let mut names = std::collections::HashMap::<&str, usize>::new();
    let mut log = |kind: &'static str| -> anyhow::Result<Option<link::log::TrafficLog>> {
        let Some(path) = ctx.opener().log_path() else { return Ok(None) };
        let n = names.entry(kind).or_default();
        let iface = format!("{kind}{n}");
        *n += 1;
        Ok(Some(link::log::TrafficLog::append(path, &iface)?))
    };
    let tap = |link: &str, protocol, log| sim_tap::tap(link, protocol, ctx.trace, log);
    let mut threads = Vec::new();
    for (w, families) in served {
        let announce_all = |link: &str| families.iter().for_each(|f| announce(*f, link));
        match w {
            Where::PtySerial => {
                let (master, path) = link::pty::open_pair()?;
                let uri = serial_uri(&path, args.baud, Family::PowerCube);
                announce_all(&uri);
                let tap = tap(&uri, Protocol::Serial(Family::PowerCube), log("serial")?);
                let (pc, clock, stop) = (Arc::clone(&bench.powercube), Arc::clone(&ctx.clock), Arc::clone(&stop));
                let (pace, noise) = (pace(serial_format(Family::PowerCube)), noise(ByteProtocol::PowerCube, 1));
                threads.push(std::thread::spawn(move || {
                    serve::serial(Box::new(master), PowerCubeRs232(pc), clock, &stop, pace, noise, tap)
                }));
            }
            Where::PtySlcan => {
                let (master, path) = link::pty::open_pair()?;
                let uri = format!("slcan:{path}");
                announce_all(&uri);
                let tap = tap(&uri, Protocol::Can, log("slcan")?);
                let (client, stop) = (bench.bus.open(), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::slcan(Box::new(master), client, &stop, tap)));
            }
            Where::SocketCan(iface) => {
                let spec = LinkSpec::SocketCan { iface: iface.clone() };
                let ext = ctx.opener().can(&spec, None).with_context(|| format!("opening {spec}"))?;
                announce_all(&spec.to_string());
                // The interface's link logs its frames itself (`--log`).
                let tap = tap(&spec.to_string(), Protocol::Can, None);
                let (client, stop) = (bench.bus.open(), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::bridge(ext, client, &stop, tap)));
            }
        }
    }
    if let Some((listener, uri)) = socketcand {
        announce(Family::PowerCube, &uri);
        announce(Family::Cdios, &uri);
        let tap = tap(&uri, Protocol::Can, log("socketcand")?);
        let (bus, stop) = (bench.bus.clone(), Arc::clone(&stop));
        threads.push(std::thread::spawn(move || serve::socketcand::serve(listener, bus, SOCKETCAND_BUS, &stop, tap)));
    }
    if let Some(Where::PtySerial) = pac_where {
        let (master, path) = link::pty::open_pair()?;
        let uri = serial_uri(&path, args.baud, Family::Pac);
        announce(Family::Pac, &uri);
        let tap = tap(&uri, Protocol::Serial(Family::Pac), log("serial")?);
        let (pac, clock, stop) = (Arc::clone(&bench.pac), Arc::clone(&ctx.clock), Arc::clone(&stop));
        let (pace, noise) = (pace(serial_format(Family::Pac)), noise(ByteProtocol::Pac, 2));
        threads.push(std::thread::spawn(move || serve::serial(Box::new(master), pac, clock, &stop, pace, noise, tap)));
    }
    // The links could not be printed (a full disk): nobody can learn them,
    // so serving on would only hang. A reader that took the lines it wanted
    // and closed the pipe is served on.
    if crate::output::failure().is_some_and(|(kind, _)| kind != std::io::ErrorKind::BrokenPipe) {
        return Ok(());
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
