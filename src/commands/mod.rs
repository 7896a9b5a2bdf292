//! The subcommands. Each resolves what the user typed, validates it before
//! anything is sent, talks to the device through a session and prints.

pub(crate) mod backup;
mod batch;
mod bench;
mod cdios;
mod commission;
mod dashboard;
mod decode;
mod devices;
pub mod error_json;
pub mod exit;
pub mod input;
mod manual;
mod monitor;
mod names;
mod pac;
mod pac_limits;
mod plot;
mod powercube;
pub(crate) mod record;
mod send;
mod shell;
mod sim;
mod sim_tap;
mod takeover;
mod wait;

use std::io::Write;
use std::sync::Arc;
use std::time::Duration;

use axisctl::bench::{Bench, BenchError, BenchLink};
use axisctl::clock::{Clock, SystemClock};
use axisctl::device::{self, supervisor};
use axisctl::family::Family;
use axisctl::link::{self, LinkSpec};
use axisctl::open::{OpenError, Opener, SessionOptions};
use axisctl::proto::powercube::limits::LimitError;
use axisctl::proto::Refusal;
use axisctl::session::cdios::Cdios;
use axisctl::session::pac::{Pac, PacError};
use axisctl::session::powercube::PowerCube;
use axisctl::session::{ErrorKind, RetryPolicy, TraceEvent};
use axisctl::sim::bench::WireSpeed;

use crate::cli::{Cli, Command, Global, PowerCubeCommand};
use crate::output::Style;

/// Bad input ([`ErrorKind::Usage`]): nothing was sent.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// The device reports a fault or refuses ([`ErrorKind::Device`]).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct DeviceFault(pub String);

/// A device that should be there did not answer ([`ErrorKind::Timeout`]).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct NoAnswer(pub String);

/// Ctrl-C ([`ErrorKind::Interrupted`]; a moving device was halted first).
#[derive(Debug, thiserror::Error)]
#[error("interrupted{0}")]
pub struct Interrupted(pub String);

/// Progress or a result could not be written during a supervised motion:
/// the device was halted first ([`ErrorKind::Other`]).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct OutputFailed(pub String);

/// A failure already reported (by `batch`, line by line): the process
/// only exits with this code.
#[derive(Debug, thiserror::Error)]
#[error("exit {0}")]
pub struct Reported(pub u8);

pub fn usage(msg: impl Into<String>) -> anyhow::Error {
    UsageError(msg.into()).into()
}

/// The exit-code class of an error: the first cause in the chain that
/// knows its class decides (a device layer error knows it whole, including
/// the session failure it carries).
pub fn classify(err: &anyhow::Error) -> ErrorKind {
    for cause in err.chain() {
        if let Some(kind) = device_kind(cause) {
            return kind;
        }
        if cause.is::<OutputFailed>() {
            return ErrorKind::Other;
        }
        if cause.is::<UsageError>() || cause.is::<link::SpecError>() || cause.is::<BenchError>() {
            return ErrorKind::Usage;
        }
        if cause.is::<DeviceFault>() {
            return ErrorKind::Device;
        }
        if cause.is::<NoAnswer>() {
            return ErrorKind::Timeout;
        }
        if cause.is::<Interrupted>() {
            return ErrorKind::Interrupted;
        }
        if let Some(e) = cause.downcast_ref::<axisctl::session::SessionError>() {
            return e.kind();
        }
        if let Some(e) = cause.downcast_ref::<OpenError>() {
            return if e.is_mismatch() { ErrorKind::Usage } else { ErrorKind::Link };
        }
        if cause.is::<link::LinkError>() {
            return ErrorKind::Link;
        }
    }
    ErrorKind::Other
}

fn device_kind(cause: &(dyn std::error::Error + 'static)) -> Option<ErrorKind> {
    if let Some(e) = cause.downcast_ref::<device::face::FaceError>() {
        return Some(e.kind());
    }
    if let Some(e) = cause.downcast_ref::<device::powercube::Error>() {
        return Some(e.kind());
    }
    if let Some(e) = cause.downcast_ref::<device::pac::Error>() {
        return Some(e.kind());
    }
    if let Some(e) = cause.downcast_ref::<device::cdios::Error>() {
        return Some(e.kind());
    }
    if let Some(e) = cause.downcast_ref::<axisctl::backup::ParseError>() {
        return Some(e.kind());
    }
    if let Some(e) = cause.downcast_ref::<axisctl::backup::Failed>() {
        return Some(e.kind);
    }
    cause.downcast_ref::<PacError>().map(PacError::kind)
}

/// What the device itself answered, when the error is its refusal or fault.
pub fn refusal(err: &anyhow::Error) -> Option<Refusal> {
    err.chain().find_map(|cause| {
        if let Some(e) = cause.downcast_ref::<device::face::FaceError>() {
            return e.refusal();
        }
        if let Some(e) = cause.downcast_ref::<device::powercube::Error>() {
            return e.refusal();
        }
        if let Some(e) = cause.downcast_ref::<device::pac::Error>() {
            return e.refusal();
        }
        if let Some(e) = cause.downcast_ref::<device::cdios::Error>() {
            return e.refusal();
        }
        match cause.downcast_ref::<PacError>() {
            Some(PacError::Session(s)) => s.refusal().cloned(),
            _ => cause.downcast_ref::<axisctl::session::SessionError>().and_then(|s| s.refusal().cloned()),
        }
    })
}

/// Advice for the command line that the library's message cannot give
/// (it does not know the CLI's flags): appended to the message.
pub fn hint(err: &anyhow::Error) -> Option<String> {
    use device::powercube::Error as Cube;
    err.chain().find_map(|cause| {
        match cause.downcast_ref::<Cube>() {
            Some(Cube::Limit(LimitError::Exceeds { .. })) => return Some(" (use --force to skip this check)".into()),
            Some(Cube::NotReady { module, .. }) => return Some(format!(": clear it with `axisctl reset -m {module}`")),
            Some(Cube::SyncMode { module }) => {
                return Some(format!(
                    ", so a wait would never end; nothing was sent. Move it with --sync, or clear the flag with \
                     `axisctl set-config -m {module} -sync-motion`"
                ))
            }
            Some(Cube::NotSyncMode { module }) => {
                return Some(format!("; nothing was sent. Set it with `axisctl set-config -m {module} +sync-motion`"))
            }
            _ => {}
        }
        match cause.downcast_ref::<device::pac::Error>() {
            Some(device::pac::Error::OutsideTraverseArea { .. }) => {
                Some(" (use --force to let the controller check)".into())
            }
            _ => None,
        }
    })
}

/// What every command gets: the resolved global options.
pub struct Ctx {
    /// The links of the bench (`--link`, a bench file), settled when a
    /// command asks for a link ([`Ctx::link`]): an offline command never
    /// does, so a bad value in the environment does not fail it.
    bench: Result<Option<Bench>, BenchError>,
    /// The family of the command being run, set by [`dispatch`]: the
    /// bench's link for it is the command's link.
    family: std::sync::Mutex<Option<Family>>,
    /// The subcommand being run as typed (`pac-online`), set by
    /// [`dispatch`]: the `command` key of its documents.
    command: std::sync::Mutex<String>,
    /// The links `-d` pinned for the command being run, one per family: the
    /// one its devices are on (a bench file may put a family on several
    /// links). Cleared by [`dispatch`] for each command.
    pinned: std::sync::Mutex<Vec<(Family, String)>>,
    /// The links as the user gave them, for the JSON envelope.
    pub link_text: String,
    pub json: bool,
    pub timeout: Option<Duration>,
    pub trace: bool,
    pub retry: RetryPolicy,
    pub style: Style,
    pub clock: Arc<dyn Clock>,
    /// `--pac-check-etx`: PA-CONTROL CHECK including ETX.
    pub pac_check_etx: bool,
    /// Opens every link of the command; its `sim` links share one bench.
    opener: Opener,
}

/// The bench file read when neither a link nor a bench file is given.
pub const BENCH_FILE: &str = "axisctl.toml";

/// The links of the command. A flag wins over a variable, and links over a
/// bench file: `--link`, `--bench`, `AXISCTL_LINK`, `AXISCTL_BENCH`, then
/// `axisctl.toml` in the working directory.
fn bench_of(g: &Global) -> Result<Option<Bench>, BenchError> {
    let links = || -> Result<Option<Bench>, BenchError> {
        let source = if g.link_from_env { "AXISCTL_LINK" } else { "--link" };
        let texts = g.link.iter().flat_map(|l| l.split(|c: char| c == ',' || c.is_whitespace()));
        Bench::from_specs(texts.filter(|t| !t.is_empty()), source).map(Some)
    };
    let file = || g.bench.as_deref().map(Bench::from_file).transpose();
    match (g.link.is_empty(), g.link_from_env, g.bench.is_some(), g.bench_from_env) {
        (false, false, _, _) => links(),
        (_, _, true, false) => file(),
        (false, true, _, _) => links(),
        (true, _, true, true) => file(),
        _ => {
            let default = std::path::Path::new(BENCH_FILE);
            if default.is_file() {
                Bench::from_file(default).map(Some)
            } else {
                Ok(None)
            }
        }
    }
}

impl Ctx {
    /// The subcommand being run, as typed (`pac-online`).
    pub fn command_name(&self) -> String {
        self.command.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    fn resolve(g: &Global) -> anyhow::Result<Self> {
        let link_text = g.link.join(" ");
        crate::output::set_link(&link_text);
        let clock: Arc<dyn Clock> = Arc::new(SystemClock);
        let opener = Opener::new(Arc::clone(&clock)).with_log(g.log.clone()).with_wire_speed(WireSpeed::from_env());
        Ok(Self {
            bench: bench_of(g),
            family: std::sync::Mutex::new(None),
            command: std::sync::Mutex::new(String::new()),
            pinned: std::sync::Mutex::new(Vec::new()),
            link_text,
            json: g.json,
            timeout: g.timeout.map(Duration::from_millis),
            trace: g.trace,
            retry: RetryPolicy { read_retries: g.retries },
            style: Style::detect(),
            clock,
            pac_check_etx: g.pac_check_etx,
            opener,
        })
    }

    /// The bench if links were given; an error if they do not parse, naming
    /// where they came from.
    pub fn given_bench(&self) -> anyhow::Result<Option<&Bench>> {
        match &self.bench {
            Ok(bench) => Ok(bench.as_ref()),
            // The error a single bad link always gave: the spec's, in the context of its source.
            Err(BenchError::Spec { origin, error }) => Err(anyhow::Error::new(error.clone()).context(origin.clone())),
            Err(e) => Err(e.clone().into()),
        }
    }

    /// The bench, or a usage error when no link is given.
    pub fn bench(&self) -> anyhow::Result<&Bench> {
        self.given_bench()?.ok_or_else(|| {
            usage(
                "no link given: pass --link URI, --bench FILE, set AXISCTL_LINK or AXISCTL_BENCH, or write axisctl.toml \
                 (try --link sim for the simulated bench)",
            )
        })
    }

    /// The command's link: the one carrying the family of the command being
    /// run, else the bench's only link.
    pub fn link(&self) -> anyhow::Result<&LinkSpec> {
        let bench = self.bench()?;
        Ok(&self.pick(bench)?.spec)
    }

    /// The link a document of `family` names: on a bench of several links
    /// or from a bench file the one that carries the family, not every link
    /// joined; the links as given when none carries it (the command then
    /// fails on it) or none was given.
    pub fn link_text_for(&self, family: Family) -> String {
        match self.given_bench() {
            Ok(Some(bench)) => {
                self.family_link(bench, family).map_or_else(|_| self.link_text.clone(), |l| l.text.clone())
            }
            _ => self.link_text.clone(),
        }
    }

    /// The link carrying `family`; a usage error naming the links when none does.
    pub fn link_for(&self, family: Family) -> anyhow::Result<&LinkSpec> {
        Ok(&self.family_link(self.bench()?, family)?.spec)
    }

    /// The link of `family`'s devices: the one `-d` pinned, else the first
    /// that carries the family.
    fn family_link<'b>(&self, bench: &'b Bench, family: Family) -> Result<&'b BenchLink, BenchError> {
        let pinned = self.pinned.lock().unwrap_or_else(|e| e.into_inner());
        match pinned.iter().find(|(f, _)| *f == family) {
            Some((_, text)) => {
                bench.links().iter().find(|l| l.text == *text).map_or_else(|| bench.link_for(family), Ok)
            }
            None => bench.link_for(family),
        }
    }

    /// Makes `link` the one every session of `family` opens for the rest of
    /// the command (see [`devices::of_family`]), and the link its documents name.
    pub fn pin_link(&self, family: Family, link: &BenchLink) {
        let mut pinned = self.pinned.lock().unwrap_or_else(|e| e.into_inner());
        pinned.retain(|(f, _)| *f != family);
        pinned.push((family, link.text.clone()));
        crate::output::set_link(&link.text);
    }

    /// Forgets the link `-d` pinned: each family's first link again (a pin
    /// lasts until the next command; `batch` arms a line's halt before it).
    pub fn unpin(&self) {
        self.pinned.lock().unwrap_or_else(|e| e.into_inner()).clear();
    }

    fn pick<'b>(&self, bench: &'b Bench) -> Result<&'b BenchLink, BenchError> {
        match *self.family.lock().unwrap_or_else(|e| e.into_inner()) {
            Some(f) => self.family_link(bench, f),
            None => bench.only_link(),
        }
    }

    /// The link if one was given (see [`Ctx::link`]).
    pub fn given_link(&self) -> anyhow::Result<Option<&LinkSpec>> {
        match self.given_bench()? {
            Some(bench) => Ok(Some(&self.pick(bench)?.spec)),
            None => Ok(None),
        }
    }

    /// The link opener behind every session of the command.
    pub fn opener(&self) -> &Opener {
        &self.opener
    }

    /// `--timeout`, `--retries`, `--trace` and `--pac-check-etx`, for any session.
    pub fn session_options(&self) -> SessionOptions {
        SessionOptions {
            timeout: self.timeout,
            retry: self.retry,
            trace: self.trace.then_some(print_trace as fn(TraceEvent)),
            pac_check_etx: self.pac_check_etx,
        }
    }

    /// A PowerCube session on the link: CAN for socketcan / slcan / sim,
    /// RS232 for serial (the family's serial default unless the link says).
    pub fn powercube(&self) -> anyhow::Result<PowerCube> {
        Ok(self.opener.powercube(self.link_for(Family::PowerCube)?, &self.session_options())?)
    }

    /// A PA-CONTROL session: a `serial:` link or the simulated controller (`sim`).
    pub fn pac(&self) -> anyhow::Result<Pac> {
        Ok(self.opener.pac(self.link_for(Family::Pac)?, &self.session_options())?)
    }

    /// A Cdios session: a CAN link or the simulated node (`sim`).
    pub fn cdios(&self) -> anyhow::Result<Cdios> {
        Ok(self.opener.cdios(self.link_for(Family::Cdios)?, &self.session_options())?)
    }

    /// A CAN link (the in-process bench for `sim`), logged with `--log`.
    pub fn can_link(&self) -> anyhow::Result<Box<dyn link::CanLink>> {
        Ok(self.opener.can(self.link()?, None)?)
    }
}

/// The sessions of one link of the bench, opened by the command's opener:
/// where the device registry gets a face of each family.
pub struct On<'a> {
    pub opener: &'a Opener,
    pub spec: &'a LinkSpec,
    pub opts: SessionOptions,
}

impl device::registry::Sessions for On<'_> {
    type Error = OpenError;
    fn powercube(&mut self) -> Result<PowerCube, OpenError> {
        self.opener.powercube(self.spec, &self.opts)
    }
    fn pac(&mut self) -> Result<Pac, OpenError> {
        self.opener.pac(self.spec, &self.opts)
    }
    fn cdios(&mut self) -> Result<Cdios, OpenError> {
        self.opener.cdios(self.spec, &self.opts)
    }
}

/// The sessions of the whole bench, each family on the link that carries
/// it (`Ctx::powercube` and its siblings): where a run over devices of
/// several families, each on its own link, gets them.
pub struct OnBench<'a>(pub &'a Ctx);

impl device::registry::Sessions for OnBench<'_> {
    type Error = anyhow::Error;
    fn powercube(&mut self) -> anyhow::Result<PowerCube> {
        self.0.powercube()
    }
    fn pac(&mut self) -> anyhow::Result<Pac> {
        self.0.pac()
    }
    fn cdios(&mut self) -> anyhow::Result<Cdios> {
        self.0.cdios()
    }
}

/// A trace line on stderr. A failed write (a closed pipe, a full disk)
/// must not panic in the middle of a motion: it is recorded, and a
/// supervised wait halts on it.
fn print_trace(ev: TraceEvent) {
    let (dir, s) = match ev {
        TraceEvent::Sent(s) => ("->", s),
        TraceEvent::Received(s) => ("<-", s),
        TraceEvent::Note(s) => ("  ", s),
    };
    if let Err(e) = writeln!(std::io::stderr(), "{dir} {s}") {
        supervisor::note_output_failure(&e);
    }
}

/// Hands the signals to the motion supervisor (before the first byte of a
/// supervised motion, and around loops that end on Ctrl-C): from then on
/// SIGINT, SIGTERM, SIGHUP and SIGQUIT are recorded, not fatal. Before it
/// they end the process at once, which is safe since nothing moves on our
/// behalf.
pub fn arm_interrupt() -> anyhow::Result<()> {
    Ok(supervisor::arm()?)
}

/// A signal arrived or the output failed since [`arm_interrupt`].
pub fn interrupted() -> bool {
    supervisor::stop_requested()
}

/// The error of a supervised wait that ended on a failed output write or a
/// panic on another thread rather than on a signal: said as such, not as an
/// interruption.
pub fn stopped_by_output(err: anyhow::Error) -> anyhow::Error {
    match supervisor::stop_reason() {
        Some(why @ (supervisor::StopReason::Output(_) | supervisor::StopReason::Panic(_))) => {
            OutputFailed(format!("{why}, so the motion was stopped: {err:#}")).into()
        }
        _ => err,
    }
}

/// The binary's side of the family registry (the library's is
/// `device::registry`): what each family's folder in `commands/` answers
/// for, picked by family here, beside the dispatch that names every family
/// anyway. A fourth family gives its `CLI`.
pub struct FamilyCli {
    /// Its names (`params`, `flags`, completion).
    pub names: &'static dyn names::Names,
    /// Its dashboard source on a link that fits it.
    pub dashboard_source: fn(&dashboard::Setup, &Opener, axisctl::open::OpenedLink) -> DashboardSource,
    /// How `sim --trace` says its own serial line, if it has one.
    pub serial_trace: Option<fn() -> Box<dyn sim_tap::SerialTrace>>,
    /// Its devices on one link of a backup, a diff or a restore.
    pub backup_live: fn() -> Box<dyn backup::live::LiveFamily>,
    /// The values of one of its devices for `record DEVICE.VALUE`, checked.
    pub record_plan: fn(axisctl::bench::Address, &[String]) -> anyhow::Result<RecordPlan>,
    /// Its commands typed on its own line for `send`, if it has one.
    pub line: Option<crate::cli::send::LineCommand>,
}

type DashboardSource = Box<dyn axisctl::tui::source::DeviceSource>;
type RecordPlan = Box<dyn record::several::Plan>;

pub fn family_cli(family: Family) -> &'static FamilyCli {
    match family {
        Family::PowerCube => &powercube::CLI,
        Family::Pac => &pac::CLI,
        Family::Cdios => &cdios::CLI,
    }
}

/// The names `family` lists (`params`, `flags`, completion).
pub fn names_of(family: Family) -> &'static dyn names::Names {
    family_cli(family).names
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    let ctx = Ctx::resolve(&cli.global)?;
    dispatch(&ctx, &cli.name, cli.command)
}

/// Runs one subcommand with the resolved options: a process's one
/// command, or each line of `batch` and `shell`.
pub fn dispatch(ctx: &Ctx, name: &str, command: Command) -> anyhow::Result<()> {
    name.clone_into(&mut ctx.command.lock().unwrap_or_else(|e| e.into_inner()));
    let family = match &command {
        // Whole-bench commands: every family (crate::commands::bench).
        Command::PowerCube(PowerCubeCommand::Scan { .. }) => None,
        Command::PowerCube(PowerCubeCommand::Halt { target }) if target.all || target.device.is_some() => None,
        Command::PowerCube(_) => Some(Family::PowerCube),
        Command::Pac(_) => Some(Family::Pac),
        Command::Cdios(_) => Some(Family::Cdios),
        _ => None,
    };
    *ctx.family.lock().unwrap_or_else(|e| e.into_inner()) = family;
    ctx.unpin();
    // The error object names the link the command's family uses.
    crate::output::set_link(&family.map_or_else(|| ctx.link_text.clone(), |f| ctx.link_text_for(f)));
    match command {
        Command::Decode { kind, value } => decode::run(ctx, &kind, &value),
        Command::Sim(args) => sim::run(ctx, &args),
        Command::Monitor(args) => monitor::run(ctx, &args),
        Command::Send(args) => send::run(ctx, &args),
        Command::Cdios(c) => cdios::run(ctx, c),
        Command::Dashboard(args) => dashboard::run(ctx, &args),
        Command::Pac(cmd) => pac::run(ctx, cmd),
        Command::Backup(cmd) => backup::run(ctx, cmd),
        Command::PowerCube(c) => powercube::run(ctx, c),
        Command::Params { family } => names::params(ctx, family),
        Command::Flags { word } => names::flags(ctx, word.as_deref()),
        Command::Record(args) => record::run(ctx, args),
        Command::Plot(args) => plot::run(ctx, &args),
        Command::Commission(args) => commission::run(ctx, args),
        Command::Completions { shell } => manual::completions(shell),
        Command::Man { dir } => manual::man(dir.as_deref()),
        Command::Batch(args) => batch::run(ctx, &args),
        Command::Shell(args) => shell::run(ctx, &args),
    }
}
