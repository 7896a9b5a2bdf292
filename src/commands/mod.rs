//! The subcommands. Each resolves what the user typed, validates it before
//! anything is sent, talks to the device through a session and prints.

mod cdios;
mod dashboard;
mod decode;
mod monitor;
mod pac;
mod powercube;
mod sim;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use axisctl::clock::{Clock, SystemClock};
use axisctl::link::log::{log_iface, LoggedByteLink, LoggedCanLink, TrafficLog};
use axisctl::link::{self, LinkSpec};
use axisctl::session::pac::Pac;
use axisctl::session::powercube::PowerCube;
use axisctl::session::{ErrorKind, RetryPolicy, TraceEvent};
use axisctl::sim::bench::{Bench, WireSpeed};

use crate::cli::{Cli, Command, Global};
use crate::output::Style;

/// Bad input: exit 2, and nothing was sent.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// The device reports a fault or refuses: exit 5.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DeviceFault(pub String);

/// Ctrl-C: exit 130 (a moving device was halted first).
#[derive(Debug, thiserror::Error)]
#[error("interrupted{0}")]
pub struct Interrupted(pub String);

pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    UsageError(msg.into()).into()
}

/// The exit-code class of an error anywhere in the chain.
pub fn classify(err: &anyhow::Error) -> ErrorKind {
    for cause in err.chain() {
        if cause.is::<UsageError>() || cause.is::<link::SpecError>() {
            return ErrorKind::Usage;
        }
        if cause.is::<DeviceFault>() {
            return ErrorKind::Device;
        }
        if cause.is::<Interrupted>() {
            return ErrorKind::Interrupted;
        }
        if let Some(e) = cause.downcast_ref::<axisctl::session::SessionError>() {
            return e.kind();
        }
        if cause.is::<link::LinkError>() {
            return ErrorKind::Link;
        }
    }
    ErrorKind::Other
}

/// What every command gets: the resolved global options.
pub struct Ctx {
    pub link: Option<LinkSpec>,
    pub json: bool,
    pub timeout: Option<Duration>,
    pub trace: bool,
    pub log: Option<std::path::PathBuf>,
    pub retry: RetryPolicy,
    pub style: Style,
    pub clock: Arc<dyn Clock>,
    /// `--pac-check-etx`: PA-CONTROL CHECK including ETX.
    pub pac_check_etx: bool,
}

impl Ctx {
    fn resolve(g: &Global) -> anyhow::Result<Self> {
        let link = g.link.as_deref().map(str::parse::<LinkSpec>).transpose()?;
        Ok(Self {
            link,
            json: g.json,
            timeout: g.timeout.map(Duration::from_millis),
            trace: g.trace,
            log: g.log.clone(),
            retry: RetryPolicy { read_retries: g.retries },
            style: Style::detect(),
            clock: Arc::new(SystemClock),
            pac_check_etx: g.pac_check_etx,
        })
    }

    pub fn link(&self) -> anyhow::Result<&LinkSpec> {
        self.link.as_ref().ok_or_else(|| {
            usage("no link given: pass --link URI or set AXISCTL_LINK (try --link sim for the simulated bench)")
        })
    }

    /// Opens a PowerCube session on the link: CAN for socketcan / slcan /
    /// sim, RS232 for serial (default 9600 8N1).
    pub fn powercube(&self) -> anyhow::Result<PowerCube> {
        let spec = self.link()?;
        let mut pc = match spec {
            LinkSpec::Serial { path, baud, format } => {
                let baud = baud.unwrap_or(9600);
                let l = link::open_bytes(path, baud, format.unwrap_or(link::SerialFormat::F8N1))?;
                PowerCube::over_rs232(self.logged_bytes(l)?, baud)
            }
            _ => PowerCube::over_can(self.can_link()?).with_clock(Arc::clone(&self.clock)),
        };
        if let Some(t) = self.timeout {
            pc.set_timeout(t);
        }
        pc.set_retry(self.retry);
        if self.trace {
            pc.set_tracer(Box::new(print_trace));
        }
        Ok(pc)
    }

    /// Opens a PA-CONTROL session: a `serial:` link (default 9600 7N1) or
    /// the in-process simulated controller (`sim`).
    pub fn pac(&self) -> anyhow::Result<Pac> {
        use axisctl::proto::pac::CheckRule;
        let spec = self.link()?;
        let mut pac = match spec {
            LinkSpec::Serial { path, baud, format } => {
                let baud = baud.unwrap_or(9600);
                let format = format.unwrap_or(link::SerialFormat::F7N1);
                Pac::new(self.logged_bytes(link::open_bytes(path, baud, format)?)?, baud, format)
            }
            LinkSpec::Sim => {
                let bench = self.sim_bench()?;
                let l: Box<dyn link::ByteLink> = Box::new(bench.pac_link(Arc::clone(&self.clock)));
                Pac::new(self.logged_bytes(l)?, 9600, link::SerialFormat::F7N1).with_clock(Arc::clone(&self.clock))
            }
            _ => return Err(usage(format!("{spec} is a CAN link; the PA-CONTROL talks RS232 (serial:TTY or sim)"))),
        };
        if let Some(t) = self.timeout {
            pac.set_timeout(t);
        }
        pac.set_retry(self.retry);
        if self.pac_check_etx {
            pac.set_check_rule(CheckRule::WithEtx);
        }
        if self.trace {
            pac.set_tracer(Box::new(print_trace));
        }
        Ok(pac)
    }

    /// A CAN link (the in-process bench for `sim`), logged with `--log`.
    pub fn can_link(&self) -> anyhow::Result<Box<dyn link::CanLink>> {
        let spec = self.link()?;
        let l: Box<dyn link::CanLink> = match spec {
            LinkSpec::Sim => Box::new(self.sim_bench()?.bus.open()),
            LinkSpec::Serial { .. } => {
                return Err(usage(format!(
                    "{spec} is a serial link; this command needs CAN (socketcan:, slcan: or sim)"
                )))
            }
            _ => link::open_can(spec)?,
        };
        Ok(match &self.log {
            Some(path) => Box::new(LoggedCanLink::new(l, TrafficLog::append(path, &log_iface(spec))?)),
            None => l,
        })
    }

    /// The in-process bench behind `--link sim`, at wire speed if
    /// `AXISCTL_SIM_WIRE_SPEED` asks for it.
    pub fn sim_bench(&self) -> anyhow::Result<Bench> {
        let mut bench = Bench::contract(Arc::clone(&self.clock));
        let wire = WireSpeed::from_env().map_err(usage)?;
        if wire.is_some() {
            axisctl::sim::serve::precise_timers();
        }
        bench.set_wire_speed(wire);
        Ok(bench)
    }

    fn logged_bytes(&self, l: Box<dyn link::ByteLink>) -> anyhow::Result<Box<dyn link::ByteLink>> {
        Ok(match (&self.log, &self.link) {
            (Some(path), Some(spec)) => Box::new(LoggedByteLink::new(l, TrafficLog::append(path, &log_iface(spec))?)),
            _ => l,
        })
    }
}

fn print_trace(ev: TraceEvent) {
    match ev {
        TraceEvent::Sent(s) => eprintln!("-> {s}"),
        TraceEvent::Received(s) => eprintln!("<- {s}"),
        TraceEvent::Note(s) => eprintln!("   {s}"),
    }
}

static INTERRUPTED: AtomicBool = AtomicBool::new(false);
static HANDLER: OnceLock<Result<(), String>> = OnceLock::new();

/// Installs the Ctrl-C handler (only around waits: elsewhere Ctrl-C ends the
/// process at once, which is safe since nothing moves on our behalf).
pub fn arm_interrupt() -> anyhow::Result<()> {
    HANDLER
        .get_or_init(|| ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst)).map_err(|e| e.to_string()))
        .clone()
        .map_err(|e| anyhow::anyhow!("cannot install the Ctrl-C handler: {e}"))
}

pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    let ctx = Ctx::resolve(&cli.global)?;
    match cli.command {
        Command::Decode { kind, value } => decode::run(&ctx, &kind, &value),
        Command::Sim(args) => sim::run(&ctx, &args),
        Command::Monitor(args) => monitor::run(&ctx, &args),
        Command::Cdios(c) => cdios::run(&ctx, c),
        Command::Dashboard(args) => dashboard::run(&ctx, &args),
        Command::Pac(cmd) => pac::run(&ctx, cmd),
        other => powercube::run(&ctx, other),
    }
}
