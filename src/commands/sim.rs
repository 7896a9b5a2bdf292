//! `axisctl sim`: serve the simulated bench on pseudo-terminals (or a
//! SocketCAN interface) until SIGINT / SIGTERM; one JSON line per served link.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::Context as _;
use axisctl::link::{self, LinkSpec};
use axisctl::sim::bench::{Bench, BenchConfig};
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
    if !(1..=axisctl::proto::pac::table::MAX_AXES).contains(&args.axes) {
        return Err(usage(format!("--axes: {} is not 1..={}", args.axes, axisctl::proto::pac::table::MAX_AXES)));
    }
    let cfg = BenchConfig { modules, linear, axes: args.axes };
    let only_some = args.powercube.is_some() || args.pac.is_some() || args.cdios.is_some();
    let powercube_where = match &args.powercube {
        Some(w) => Some(parse_where(w, "powercube")?),
        None if !only_some => Some(Where::PtySlcan),
        None => None,
    };
    // The PA-CONTROL has only its RS232 port.
    let pac_where = match args.pac.as_deref() {
        Some("pty-serial") => Some(Where::PtySerial),
        Some(other) => return Err(usage(format!("--pac {other:?}: the PA-CONTROL is served on pty-serial only"))),
        None if !only_some => Some(Where::PtySerial),
        None => None,
    };
    if args.cdios.is_some() {
        return Err(usage("the Cdios simulator is not served yet"));
    }

    let bench = Bench::new(&cfg, Arc::clone(&ctx.clock));
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        ctrlc::set_handler(move || stop.store(true, Ordering::SeqCst))
            .context("installing the SIGINT/SIGTERM handler")?;
    }
    let mut threads = Vec::new();
    if let Some(w) = powercube_where {
        match w {
            Where::PtySerial => {
                let (master, path) = link::pty::open_pair()?;
                announce("powercube", &format!("serial:{path}?baud=9600&format=8N1"));
                let (pc, clock, stop) = (Arc::clone(&bench.powercube), Arc::clone(&ctx.clock), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::rs232(Box::new(master), pc, clock, &stop)));
            }
            Where::PtySlcan => {
                let (master, path) = link::pty::open_pair()?;
                announce("powercube", &format!("slcan:{path}"));
                let (client, stop) = (bench.bus.open(), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::slcan(Box::new(master), client, &stop)));
            }
            Where::SocketCan(iface) => {
                let spec = LinkSpec::SocketCan { iface: iface.clone() };
                let ext = link::open_can(&spec).with_context(|| format!("opening {spec}"))?;
                announce("powercube", &spec.to_string());
                let (client, stop) = (bench.bus.open(), Arc::clone(&stop));
                threads.push(std::thread::spawn(move || serve::bridge(ext, client, &stop)));
            }
        }
    }
    if let Some(Where::PtySerial) = pac_where {
        let (master, path) = link::pty::open_pair()?;
        announce("pac", &format!("serial:{path}?baud=9600&format=7N1"));
        let (pac, clock, stop) = (Arc::clone(&bench.pac), Arc::clone(&ctx.clock), Arc::clone(&stop));
        threads.push(std::thread::spawn(move || serve::pac(Box::new(master), pac, clock, &stop)));
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
