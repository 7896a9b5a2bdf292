//! `axisctl batch`: many commands, one process, one open link. Each line is
//! parsed with the command line's own parser and run through the same
//! dispatch as a one-shot command; `shell` is the same engine at a
//! terminal. Consecutive reads on a CAN link go out pipelined ([`pipeline`]).
//!
//! Every line of a window ([`WINDOW`] lines) is parsed before the first
//! runs, so a typo on line 40 sends nothing; a longer batch streams window
//! by window, its memory bounded. The signals belong to the motion
//! supervisor from the start: a Ctrl-C ends the batch after the line that
//! runs (a supervised wait halts its device at once), and every device a
//! motion line addressed is halted, also one still moving from a line
//! without `--wait`. A batch that stops on a failure halts them the same
//! way: the lines that would have stopped them will not run.

mod pipeline;

use std::io::{BufRead, BufReader, Read};

use anyhow::Context;
use axisctl::device::registry;
use axisctl::device::supervisor::{self, HaltOutcome, MotionTarget, MovedDevices, Reach, RunFace};
use axisctl::family::Family;
use axisctl::session::ErrorKind;
use clap::parser::ValueSource;
use clap::FromArgMatches;
use serde_json::json;

use super::{error_json, exit, input, Ctx, On, Reported};
use crate::cli::batch::BatchArgs;
use crate::cli::{Cli, Command};
use crate::output;

/// Subcommands that take over the terminal, serve until stopped or start
/// another engine: they make no sense as a line. `commission` is a whole
/// procedure with its own confirmation on standard input and its report.
pub const REFUSED: &[&str] = &["sim", "dashboard", "batch", "shell", "commission"];

/// The global options (the ids of `cli::Global`): given to `batch` or
/// `shell` they apply to every line; on a line they are refused.
const GLOBAL: &[(&str, &str)] = &[
    ("link", "--link"),
    ("json", "--json"),
    ("timeout", "--timeout"),
    ("trace", "--trace"),
    ("log", "--log"),
    ("retries", "--retries"),
    ("pac_check_etx", "--pac-check-etx"),
    ("bench", "--bench"),
    ("quiet", "--quiet"),
];

/// One line, ready to run.
pub enum Line {
    Run {
        command: Box<Command>,
        /// The subcommand as typed, for its documents' `command` key.
        name: String,
    },
    /// `help`, `--help`: clap's text, printed when the line runs.
    Text(String),
}

/// A line that cannot run: bad input, exit 2.
#[derive(Debug)]
pub struct LineError {
    pub message: String,
    /// The argument clap names, for the error object.
    pub argument: Option<String>,
}

/// The engine: the parser, the options of every line and what the lines moved.
pub struct Engine<'a> {
    ctx: &'a Ctx,
    parser: clap::Command,
    /// Every device a motion line addressed, each once, in order: halted
    /// when a signal ends the run.
    moved: MovedDevices,
    /// The exit code of the first failure.
    pub first_failure: Option<u8>,
    /// The link each family's armed motions go out on: the run halts a
    /// family's devices through one face, opened on that link.
    armed_on: Vec<(Family, String)>,
}

impl<'a> Engine<'a> {
    /// Keeps the link open from the first line on and takes the signals.
    pub fn new(ctx: &'a Ctx) -> anyhow::Result<Self> {
        ctx.opener().keep_links_open();
        super::arm_interrupt()?;
        Ok(Self {
            ctx,
            parser: crate::cli::command(&exit::summary()),
            moved: MovedDevices::new(ctx.retry),
            first_failure: None,
            armed_on: Vec::new(),
        })
    }

    pub fn parser(&self) -> &clap::Command {
        &self.parser
    }

    /// Parses one line: `None` for a blank line or a comment.
    pub fn parse(&mut self, text: &str) -> Result<Option<Line>, LineError> {
        let bad = |message: String| LineError { message, argument: None };
        // A file saved with a byte order mark (Windows editors) starts with
        // U+FEFF, which is no part of the first command's name.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let words = shlex::split(text).ok_or_else(|| bad("unbalanced quotes or a trailing backslash".into()))?;
        if words.is_empty() {
            return Ok(None);
        }
        let argv: Vec<String> = std::iter::once("axisctl".to_string()).chain(words).collect();
        // A line naming a device with -d takes the parser's -d form, for
        // this line only (cli::for_words).
        let mut with_device;
        let parser = if crate::cli::names_device(&argv) {
            with_device = crate::cli::for_words(self.parser.clone(), &argv);
            &mut with_device
        } else {
            &mut self.parser
        };
        let matches = match parser.try_get_matches_from_mut(argv) {
            Ok(m) => m,
            Err(e) if !e.use_stderr() => return Ok(Some(Line::Text(e.render().to_string()))),
            Err(e) => {
                let e = crate::cli::suggest::subcommand(e, parser);
                let doc = error_json::usage(&e, exit::code(ErrorKind::Usage));
                let mut message = doc["error"]["message"].as_str().unwrap_or_default().to_string();
                // clap's tips ("a similar subcommand exists") are what fixes a typo.
                for tip in e.render().to_string().lines().filter_map(|l| l.trim().strip_prefix("tip: ")) {
                    message.push_str(&format!(" ({tip})"));
                }
                let argument = doc["error"]["argument"].as_str().map(str::to_string);
                return Err(LineError { message, argument });
            }
        };
        let name = matches.subcommand_name().unwrap_or_default().to_string();
        if REFUSED.contains(&name.as_str()) {
            return Err(bad(format!(
                "`{name}` cannot run as a line of batch or shell (refused: {})",
                REFUSED.join(", ")
            )));
        }
        let mut at = Some(&matches);
        while let Some(m) = at {
            if let Some((_, flag)) = GLOBAL.iter().find(|(id, _)| m.value_source(id) == Some(ValueSource::CommandLine))
            {
                return Err(LineError {
                    message: format!(
                        "{flag} on a line: give it to batch or shell itself, before the file (it applies to every line)"
                    ),
                    argument: Some((*flag).to_string()),
                });
            }
            at = m.subcommand().map(|(_, sub)| sub);
        }
        let cli = Cli::from_arg_matches(&matches).map_err(|e| bad(e.to_string()))?;
        let name = matches.subcommand_name().unwrap_or_default().to_string();
        Ok(Some(Line::Run { command: Box::new(cli.command), name }))
    }

    /// Runs one parsed line and reports its result: on stdout (`--json`:
    /// one object per document), a failure on stderr (`--json`: its error
    /// object on stdout, in line). `Err` holds the failure's exit code.
    pub fn run(&mut self, n: usize, text: &str, line: Line) -> Result<(), u8> {
        let (command, name) = match line {
            Line::Text(help) => {
                output::text(format_args!("{help}"));
                return Ok(());
            }
            Line::Run { command, name } => (command, name),
        };
        // Armed before the line sends its motion: a line without `--wait`
        // leaves it running, and the run answers for it from then on.
        let bench = self.ctx.given_bench().ok().flatten();
        let named_on = std::cell::Cell::new(None);
        let names = |r: &axisctl::bench::DeviceRef| {
            let bench = bench?;
            let at = bench.resolve(r).ok()?;
            named_on.set(bench.link_of(at).ok());
            Some(at)
        };
        let refused = match command.starts_motion(&names) {
            Some(target) => self.arm_on(target, named_on.get()).err(),
            None => None,
        };
        self.report(n, text, |ctx| match refused {
            Some(e) => Err(e),
            None => super::dispatch(ctx, &name, *command),
        })
    }

    /// Arms the halt of `target` on the link its line moves it on: `on`, the
    /// link its `-d` devices are on, else its family's first (not a link an
    /// earlier line's `-d` left pinned). The run halts a family through one
    /// face, so a line that would move a family on a second link is refused
    /// before it sends anything.
    fn arm_on(&mut self, target: MotionTarget, on: Option<&axisctl::bench::BenchLink>) -> anyhow::Result<()> {
        let family = target.family();
        self.ctx.unpin();
        if let Some(link) = on {
            self.ctx.pin_link(family, link);
        }
        let link = self.ctx.link_text_for(family);
        let moving: Vec<Family> = self.moved.targets().iter().map(|t| t.family()).collect();
        self.armed_on.retain(|(f, _)| moving.contains(f));
        match self.armed_on.iter().find(|(f, _)| *f == family) {
            Some((_, first)) if *first != link => {
                return Err(super::usage(format!(
                    "this run moved {family} devices on {first}; this line would move one on {link}, which a \
                     failure could not halt with them: run it in a batch of its own; nothing was sent"
                )))
            }
            Some(_) => {}
            None => self.armed_on.push((family, link)),
        }
        self.moved.arm(&mut Reached(self.ctx), target);
        Ok(())
    }

    /// Runs `line` as line `n` and reports it: what it prints, in line
    /// under `--json` (`"result": null` when it printed nothing), or its
    /// failure. `Err` holds the failure's exit code.
    fn report(&mut self, n: usize, text: &str, line: impl FnOnce(&Ctx) -> anyhow::Result<()>) -> Result<(), u8> {
        output::forget_target();
        if self.ctx.json {
            output::begin_batch_line(n, text, false);
        }
        let result = line(self.ctx);
        let printed = output::end_batch_line();
        match result {
            Ok(()) => {
                if self.ctx.json && !printed {
                    output::json(&json!({"line": n, "command": text, "result": null}));
                }
                output::flush();
                Ok(())
            }
            Err(e) => Err(self.failed(n, text, e)),
        }
    }

    /// Reports a failed line and returns its exit code, the one a one-shot
    /// run of it would have exited with.
    pub fn failed(&mut self, n: usize, text: &str, e: anyhow::Error) -> u8 {
        let (e, kind, code) = exit::classify_failure(e);
        let message = error_json::message(&e);
        if self.ctx.json {
            let doc = error_json::failure(kind.as_str(), code, message, super::refusal(&e).as_ref());
            output::json(&json!({"line": n, "command": text, "error": doc["error"]}));
        } else {
            output::err_line(format_args!("axisctl: line {n} ({text}): {message}"));
        }
        output::flush();
        self.first_failure.get_or_insert(code);
        code
    }

    /// A line that did not parse: bad input, reported like a failed line.
    pub fn refused(&mut self, n: usize, text: &str, e: &LineError) -> u8 {
        let code = exit::code(ErrorKind::Usage);
        if self.ctx.json {
            let mut error = json!({"kind": "usage", "exit_code": code, "message": e.message});
            if let Some(arg) = &e.argument {
                error["argument"] = json!(arg);
            }
            output::json(&json!({"line": n, "command": text, "error": error}));
        } else {
            output::err_line(format_args!("axisctl: line {n} ({text}): {}", e.message));
        }
        self.first_failure.get_or_insert(code);
        code
    }

    /// After a signal (or a failed output): halts every device the lines
    /// moved, each once, and says so. Returns the exit code the stop asks
    /// for (128 + the signal), or `None` when nothing asked to stop.
    pub fn stop_if_requested(&mut self, after: usize) -> Option<u8> {
        if !supervisor::stop_requested() {
            return None;
        }
        let why = supervisor::stop_reason().map(|r| r.to_string()).unwrap_or_else(|| "a stop".into());
        let halts = self.halt_moved();
        let code = supervisor::caught().map_or(exit::code(ErrorKind::Other), supervisor::exit_code);
        let halted = if halts.is_empty() { "no line had moved a device".into() } else { said(&halts) };
        let message = format!("stopped by {why} after line {after}; halted: {halted}");
        output::forget_target();
        if self.ctx.json {
            let kind = if supervisor::caught().is_some() { "interrupted" } else { "other" };
            let doc = error_json::failure(kind, code, message, None);
            output::json(&json!({"line": after, "command": null, "error": doc["error"]}));
        } else {
            output::err_line(format_args!("axisctl: {message}"));
        }
        output::flush();
        self.first_failure.get_or_insert(code);
        Some(code)
    }

    /// The run ends on a failure: what its lines moved is halted, as after
    /// a signal. A move that a batch left running when it gave up has no
    /// one watching it, and the lines that would have stopped it (a `halt`
    /// further down) will not run. Says what it halted, after the failure.
    pub fn halt_after_failure(&mut self, after: usize) {
        if self.moved.is_empty() {
            return;
        }
        let halts = self.halt_moved();
        output::forget_target();
        if self.ctx.json {
            let halted: Vec<serde_json::Value> = halts
                .iter()
                .map(|h| match &h.result {
                    Ok(_) => json!({"stop": h.target.to_string()}),
                    Err(e) => json!({"stop": h.target.to_string(), "error": e}),
                })
                .collect();
            output::json(&json!({"line": after, "command": null, "halted": halted}));
        } else {
            output::err_line(format_args!("axisctl: stopped after line {after} failed; halted: {}", said(&halts)));
        }
        output::flush();
    }

    /// What the lines moved may still move: said when the run ends without
    /// halting it (`--keep-going` past a failure, `exit --keep-moving`), and
    /// let go of, on purpose.
    pub fn may_still_move(&mut self, after: usize, why: &str) {
        if self.moved.is_empty() {
            return;
        }
        let stops: Vec<String> = self.moved.targets().iter().map(ToString::to_string).collect();
        if self.ctx.json {
            output::json(&json!({"line": after, "command": null, "may_move": stops}));
        } else {
            let list: Vec<String> = stops.iter().map(|s| format!("`{s}`")).collect();
            output::err_line(format_args!("axisctl: {why}; not halted, may still move: {}", list.join(", ")));
        }
        output::flush();
        self.moved.release();
    }

    /// Halts every device the lines moved, each once, and forgets them.
    pub fn halt_moved(&mut self) -> Vec<HaltOutcome> {
        self.moved.halt(&mut Reached(self.ctx))
    }
}

/// The halts as the last message says them: each by the command that stops
/// the device by hand, with its failure if it failed.
pub fn said(halts: &[HaltOutcome]) -> String {
    let done: Vec<String> = halts
        .iter()
        .map(|h| match &h.result {
            Ok(_) => format!("`{}`", h.target),
            Err(e) => format!("`{}` failed: {e}", h.target),
        })
        .collect();
    done.join(", ")
}

/// The devices of the halts, opened on the link the run keeps open.
struct Reached<'a>(&'a Ctx);

fn reason(e: anyhow::Error) -> String {
    error_json::message(&e)
}

impl Reach for Reached<'_> {
    fn face(&mut self, family: Family, node: Option<u8>) -> Result<Box<RunFace>, String> {
        let ctx = self.0;
        let spec = ctx.link_for(family).map_err(reason)?;
        let mut sessions = On { opener: ctx.opener(), spec, opts: ctx.session_options() };
        registry::open(family, node, &mut sessions, ctx.retry).map_err(|e| reason(e.into()))
    }
}

/// Lines read, parsed and run at a time: a batch of up to this many lines
/// is parsed whole before its first line runs; a longer one runs window by
/// window, so that its memory and its time before the first line stay
/// bounded whatever its length.
pub const WINDOW: usize = 10_000;

/// `axisctl batch [FILE|-] [--keep-going]`.
pub fn run(ctx: &Ctx, args: &BatchArgs) -> anyhow::Result<()> {
    let mut script = Script::open(args.file.as_deref())?;
    let mut engine = Engine::new(ctx)?;
    let mut last = 0;
    let ended = run_windows(ctx, args, &mut script, &mut engine, &mut last);
    // A stop by a signal has halted already and said so.
    if let Err(Ended::Stopped(code)) = ended {
        return Err(Reported(code).into());
    }
    let failed = engine.first_failure.is_some() || ended.is_err();
    if failed && args.keep_going && ended.is_ok() {
        engine.may_still_move(last, "--keep-going ran every line past a failure");
    } else if failed {
        engine.halt_after_failure(last);
    } else {
        // A batch that ran to its end leaves its motions as its lines left
        // them: a script may end by starting one.
        engine.moved.release();
    }
    match (ended, engine.first_failure) {
        (Err(Ended::Input(e)), _) => Err(e),
        (_, Some(code)) => Err(Reported(code).into()),
        _ => Ok(()),
    }
}

/// Why a batch ended before its last line.
enum Ended {
    /// A signal (or a failed output): its code; what moved is halted.
    Stopped(u8),
    /// A line failed, or a window held a line that does not parse (reported).
    Failed,
    /// The input could not be read further.
    Input(anyhow::Error),
}

/// Runs the script window by window; `last` follows the last line run.
fn run_windows(
    ctx: &Ctx,
    args: &BatchArgs,
    script: &mut Script,
    engine: &mut Engine<'_>,
    last: &mut usize,
) -> Result<(), Ended> {
    loop {
        let window = script.window(WINDOW).map_err(Ended::Input)?;
        if window.is_empty() {
            return Ok(());
        }
        // Every line of the window is parsed before the first runs: a bad
        // line sends nothing of its window.
        let mut lines = Vec::new();
        let mut bad = false;
        for (n, raw) in &window {
            let shown = shown(raw);
            match engine.parse(raw) {
                Ok(Some(line)) => lines.push((*n, shown, line)),
                Ok(None) => {}
                Err(e) => {
                    engine.refused(*n, &shown, &e);
                    bad = true;
                }
            }
        }
        drop(window);
        if bad {
            if !ctx.json {
                match *last {
                    0 => output::err_line(format_args!("axisctl: nothing was run: fix the lines above")),
                    n => output::err_line(format_args!("axisctl: lines after {n} were not run: fix the lines above")),
                }
            }
            return Err(Ended::Failed);
        }
        let mut pipeline = pipeline::Pipeline::new(ctx, &lines);
        for (i, (n, text, line)) in lines.into_iter().enumerate() {
            if let Some(code) = engine.stop_if_requested(*last) {
                return Err(Ended::Stopped(code));
            }
            *last = n;
            let ran = match pipeline.answered(ctx, i) {
                Some(answered) => engine.run_answered(n, &text, answered),
                None => engine.run(n, &text, line),
            };
            if let Some(code) = engine.stop_if_requested(n) {
                return Err(Ended::Stopped(code));
            }
            if ran.is_err() && !args.keep_going {
                return Err(Ended::Failed);
            }
        }
    }
}

/// The commands, read a window of lines at a time, each line bounded.
struct Script {
    from: Box<dyn BufRead>,
    name: String,
    /// The number of the last line read.
    read: usize,
}

impl Script {
    fn open(file: Option<&std::path::Path>) -> anyhow::Result<Self> {
        let stdin = || Self { from: Box::new(std::io::stdin().lock()), name: "standard input".into(), read: 0 };
        Ok(match file {
            None => stdin(),
            Some(p) if p.as_os_str() == "-" => stdin(),
            Some(p) => {
                let f = std::fs::File::open(p)
                    .map_err(|e| super::usage(format!("cannot read {}: {e}; nothing was run", p.display())))?;
                Self { from: Box::new(BufReader::new(f)), name: p.display().to_string(), read: 0 }
            }
        })
    }

    /// The next lines, up to `max`, numbered; none at the end. A line longer
    /// than [`input::BATCH_LINE`] or not UTF-8 is bad input.
    fn window(&mut self, max: usize) -> anyhow::Result<Vec<(usize, String)>> {
        let mut out = Vec::new();
        while out.len() < max {
            let mut bytes = Vec::new();
            let limit = input::BATCH_LINE as u64 + 1;
            (&mut self.from)
                .take(limit)
                .read_until(b'\n', &mut bytes)
                .with_context(|| format!("reading the commands from {}", self.name))?;
            if bytes.is_empty() {
                break;
            }
            self.read += 1;
            let n = self.read;
            if bytes.last() == Some(&b'\n') {
                bytes.pop();
            } else if bytes.len() > input::BATCH_LINE {
                return Err(super::usage(format!(
                    "{}: line {n} is longer than {}, the most a batch line may be; it was not run",
                    self.name,
                    input::size(input::BATCH_LINE as u64)
                )));
            }
            if bytes.last() == Some(&b'\r') {
                bytes.pop();
            }
            let text = String::from_utf8(bytes)
                .map_err(|_| super::usage(format!("{}: line {n} is not UTF-8 text; it was not run", self.name)))?;
            out.push((n, text));
        }
        Ok(out)
    }
}

/// A line as reported (`"command"`): its words, quoted where they need it,
/// without the comment; as typed when it does not split.
pub fn shown(raw: &str) -> String {
    shlex::split(raw)
        .and_then(|words| shlex::try_join(words.iter().map(String::as_str)).ok())
        .unwrap_or_else(|| raw.trim().to_string())
}
