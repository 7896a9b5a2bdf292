//! `axisctl shell`: the batch engine at a terminal. Line editing, history
//! and completion come from rustyline (no system library); completion
//! walks the same clap tree that parses the lines.
//!
//! Ctrl-C at the prompt clears the line (the terminal is in raw mode, so it
//! is a key, not a signal); during a command it is the signal, and the
//! engine halts what the lines moved, as in a batch, then prompts again.
//! Ctrl-Z, at the prompt or during a command, halts what the lines moved,
//! then stops the shell; `fg` brings the prompt back.
//! Ctrl-D (or `exit`) ends the shell, and halts what its lines moved unless
//! told not to (`exit --keep-moving`); a failed line does not end it.

use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::Duration;

use axisctl::device::supervisor;
use rustyline::completion::{Completer, Pair};
use rustyline::error::ReadlineError;
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::validate::Validator;
use rustyline::{Config, Editor, Helper};

use super::batch::{Engine, REFUSED};
use super::{exit, Ctx, Reported};
use crate::cli::batch::ShellArgs;
use crate::output;
use axisctl::session::ErrorKind;

pub fn run(ctx: &Ctx, args: &ShellArgs) -> anyhow::Result<()> {
    let engine = Mutex::new(Engine::new(ctx)?);
    let helper = Complete { tree: lock(&engine).parser().clone() };
    let config = Config::builder()
        .auto_add_history(false)
        .completion_type(rustyline::CompletionType::List)
        .max_history_size(10_000)?
        .build();
    let mut ed: Editor<Complete, rustyline::history::DefaultHistory> = Editor::with_config(config)?;
    ed.set_helper(Some(helper));
    let history = args.history.clone().or_else(default_history);
    if let Some(path) = &history {
        // A first run has no history yet; an unreadable one is not worth
        // refusing the shell for.
        let _ = ed.load_history(path);
    }
    let link = if ctx.link_text.is_empty() { "no link" } else { &ctx.link_text };
    let prompt = format!("axisctl {link}> ");
    let at_prompt = AtomicBool::new(false);
    let ended = AtomicBool::new(false);
    let last = AtomicUsize::new(0);
    let terminal = Terminal::save();
    std::thread::scope(|scope| {
        scope.spawn(|| stop_at_the_prompt(&engine, (&at_prompt, &last), &ended, &terminal));
        let out = session(&engine, &mut ed, &prompt, history.as_deref(), (&at_prompt, &last));
        ended.store(true, Ordering::SeqCst);
        out
    })
}

/// The read-run loop, until Ctrl-D or `exit`.
fn session(
    engine: &Mutex<Engine<'_>>,
    ed: &mut Editor<Complete, rustyline::history::DefaultHistory>,
    prompt: &str,
    history: Option<&Path>,
    (at_prompt, last): (&AtomicBool, &AtomicUsize),
) -> anyhow::Result<()> {
    let mut n = 0;
    loop {
        at_prompt.store(true, Ordering::SeqCst);
        let read = ed.readline(prompt);
        // From here until the next prompt the watcher leaves a signal to the engine.
        let mut engine = lock(engine);
        at_prompt.store(false, Ordering::SeqCst);
        let text = match read {
            Ok(text) => text,
            Err(ReadlineError::Interrupted) => continue,
            Err(ReadlineError::Eof) => return leave(&mut engine, n, "Ctrl-D", true),
            Err(e) => return Err(e.into()),
        };
        n += 1;
        last.store(n, Ordering::SeqCst);
        let shown = super::batch::shown(&text);
        if shown.is_empty() {
            continue;
        }
        let _ = ed.add_history_entry(text.trim());
        if let Some(path) = history {
            save_history(ed, path);
        }
        match shown.as_str() {
            "exit" | "quit" => return leave(&mut engine, n, &shown, true),
            "exit --keep-moving" | "quit --keep-moving" => return leave(&mut engine, n, &shown, false),
            _ => {}
        }
        match engine.parse(&text) {
            Ok(Some(line)) => {
                let _ = engine.run(n, &shown, line);
            }
            Ok(None) => {}
            Err(e) => {
                engine.refused(n, &shown, &e);
            }
        }
        if engine.stop_if_requested(n).is_some() {
            // What the lines moved is halted: after Ctrl-Z the shell stops
            // now (it forgets that signal itself, and a signal that comes
            // while it is stopped is the watcher's); the next command starts afresh.
            if supervisor::suspend_if_asked().is_none() {
                supervisor::forget_signal();
            }
        }
        engine.first_failure = None;
        output::flush();
    }
}

/// The end of the shell (`how`: Ctrl-D or the line that ended it): what its
/// lines moved is halted and said, as a stop by a signal halts it, unless
/// `halt` is false (`exit --keep-moving`), which says what may still move.
/// A device left moving when the operator walks away from the terminal is
/// one nobody watches, so leaving it so must be asked for.
fn leave(engine: &mut Engine<'_>, n: usize, how: &str, halt: bool) -> anyhow::Result<()> {
    if !halt {
        engine.may_still_move(n, how);
        return Ok(());
    }
    let halts = engine.halt_moved();
    if halts.is_empty() {
        return Ok(());
    }
    output::err_line(format_args!("axisctl: {how} ends the shell; halted: {}", super::batch::said(&halts)));
    output::flush();
    if halts.iter().any(|h| h.result.is_err()) {
        return Err(Reported(exit::code(ErrorKind::Other)).into());
    }
    Ok(())
}

fn lock<'m, 'a>(engine: &'m Mutex<Engine<'a>>) -> MutexGuard<'m, Engine<'a>> {
    engine.lock().unwrap_or_else(|e| e.into_inner())
}

/// A signal while the shell waits at its prompt (SIGTERM from an emergency
/// halt in another terminal, which needs the port; SIGHUP from a closed
/// terminal): the line editor would not return before a key, so this
/// thread halts what the lines moved, gives the terminal back and ends the
/// process with the signal's code, releasing the link.
fn stop_at_the_prompt(
    engine: &Mutex<Engine<'_>>,
    (at_prompt, last): (&AtomicBool, &AtomicUsize),
    ended: &AtomicBool,
    terminal: &Terminal,
) {
    while !ended.load(Ordering::SeqCst) {
        supervisor::sleep(Duration::from_millis(50));
        if supervisor::caught().is_none() || !at_prompt.load(Ordering::SeqCst) {
            continue;
        }
        // The prompt may be returning with a line: then the engine has it.
        let Ok(mut engine) = engine.try_lock() else { continue };
        if !at_prompt.load(Ordering::SeqCst) {
            continue;
        }
        if supervisor::job_stop().is_some() {
            // Ctrl-Z at the prompt: the line editor sends SIGTSTP to the
            // process group. What the lines moved is halted, then the shell
            // stops as asked; continued (`fg`), the prompt goes on.
            engine.stop_if_requested(last.load(Ordering::SeqCst));
            engine.first_failure = None;
            supervisor::suspend_if_asked();
            continue;
        }
        terminal.restore();
        output::err_line(format_args!(""));
        let code = engine.stop_if_requested(last.load(Ordering::SeqCst)).unwrap_or(1);
        output::flush();
        std::process::exit(code.into());
    }
}

/// The terminal's settings before the line editor's raw mode, to give them
/// back when the process ends from another thread.
struct Terminal(Option<libc::termios>);

impl Terminal {
    fn save() -> Self {
        // SAFETY: tcgetattr fills the zeroed struct, or fails on a non-terminal.
        unsafe {
            let mut t: libc::termios = std::mem::zeroed();
            Self((libc::tcgetattr(libc::STDIN_FILENO, &mut t) == 0).then_some(t))
        }
    }

    fn restore(&self) {
        if let Some(t) = &self.0 {
            // SAFETY: settings tcgetattr returned for the same descriptor.
            unsafe {
                libc::tcsetattr(libc::STDIN_FILENO, libc::TCSANOW, t);
            }
        }
    }
}

/// `$XDG_STATE_HOME/axisctl/history`, else `~/.local/state/axisctl/history`.
fn default_history() -> Option<PathBuf> {
    let state = std::env::var_os("XDG_STATE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").filter(|v| !v.is_empty()).map(|h| Path::new(&h).join(".local/state")))?;
    Some(state.join("axisctl").join("history"))
}

fn save_history(ed: &mut Editor<Complete, rustyline::history::DefaultHistory>, path: &Path) {
    if let Some(dir) = path.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    if let Err(e) = ed.save_history(path) {
        output::err_line(format_args!("axisctl: cannot save the history to {}: {e}", path.display()));
    }
}

/// Completion from the parser's tree, by the engine behind the shells'
/// completion (`cli::complete`): subcommands, their flags, and values from
/// the tables (parameter names, Config flags, decode kinds, record values,
/// module ids of the bench file). The global options and the commands a
/// line may not run are not offered: a line refuses them.
struct Complete {
    tree: clap::Command,
}

impl Complete {
    /// The candidates for the word that ends at the cursor.
    fn candidates(&self, before: &str) -> (usize, Vec<Pair>) {
        let start = before.rfind(char::is_whitespace).map_or(0, |i| i + 1);
        let word = &before[start..];
        let done: Vec<&str> = before[..start].split_whitespace().collect();
        let mut words: Vec<std::ffi::OsString> = vec!["axisctl".into()];
        words.extend(done.iter().map(std::ffi::OsString::from));
        words.push(word.into());
        let index = words.len() - 1;
        let mut tree = self.tree.clone();
        let here = std::env::current_dir().ok();
        let found = clap_complete::engine::complete(&mut tree, words, index, here.as_deref()).unwrap_or_default();
        let global: Vec<String> = self
            .tree
            .get_arguments()
            .flat_map(|a| {
                a.get_long().map(|l| format!("--{l}")).into_iter().chain(a.get_short().map(|s| format!("-{s}")))
            })
            .collect();
        let first = done.is_empty();
        let mut out: Vec<String> = found
            .into_iter()
            .filter(|c| !c.is_hide_set())
            .map(|c| c.get_value().to_string_lossy().into_owned())
            .filter(|c| !(first && (REFUSED.contains(&c.as_str()) || c == "help")))
            .filter(|c| first || !global.contains(c) || self.sub_has(&done, c))
            .filter(|c| c.starts_with(word) || c.to_ascii_lowercase().starts_with(&word.to_ascii_lowercase()))
            .collect();
        out.sort();
        out.dedup();
        let pairs = out.into_iter().map(|c| Pair { display: c.clone(), replacement: format!("{c} ") }).collect();
        (start, pairs)
    }

    /// Whether the line's subcommand has `flag` of its own (`-m` is both a
    /// global short and no subcommand's, `--all` a subcommand's).
    fn sub_has(&self, done: &[&str], flag: &str) -> bool {
        let Some(sub) = done.iter().find_map(|w| self.tree.find_subcommand(w)) else { return false };
        sub.get_arguments().any(|a| {
            a.get_long().is_some_and(|l| flag == format!("--{l}"))
                || a.get_short().is_some_and(|s| flag == format!("-{s}"))
        })
    }
}

impl Completer for Complete {
    type Candidate = Pair;

    fn complete(&self, line: &str, pos: usize, _: &rustyline::Context<'_>) -> rustyline::Result<(usize, Vec<Pair>)> {
        Ok(self.candidates(&line[..pos]))
    }
}

impl Hinter for Complete {
    type Hint = String;
}

impl Highlighter for Complete {
    fn highlight_prompt<'b, 's: 'b, 'p: 'b>(&'s self, prompt: &'p str, _default: bool) -> Cow<'b, str> {
        Cow::Borrowed(prompt)
    }
}

impl Validator for Complete {}

impl Helper for Complete {}

#[cfg(test)]
mod tests {
    use super::*;

    fn complete(before: &str) -> Vec<String> {
        let c = Complete { tree: crate::cli::command("") };
        c.candidates(before).1.into_iter().map(|p| p.display).collect()
    }

    #[test]
    fn completes_subcommands_and_their_flags_from_the_tree() {
        assert!(complete("pac-a").contains(&"pac-axis".to_string()), "{:?}", complete("pac-a"));
        assert!(complete("pac-a").iter().all(|c| c.starts_with("pac-a")));
        assert!(!complete("").contains(&"dashboard".to_string()), "refused lines are not offered");
        assert!(complete("get-param --a").contains(&"--all".to_string()));
        assert!(!complete("get-param --").contains(&"--timeout".to_string()), "a line refuses global options");
        assert_eq!(complete("watchdog o"), ["off", "on"]);
    }

    #[test]
    fn completes_values_from_the_tables_as_the_shells_do() {
        assert!(complete("get-param -m 3 Act").contains(&"ActPos".to_string()), "{:?}", complete("get-param -m 3 Act"));
        assert!(complete("get-param -m 3 act").iter().all(|c| c.to_ascii_lowercase().starts_with("act")));
        assert!(complete("decode cube").contains(&"cube-state".to_string()), "{:?}", complete("decode cube"));
        assert!(
            complete("set-config -m 3 -bra").contains(&"-brake-present".to_string()),
            "{:?}",
            complete("set-config -m 3 -bra")
        );
        assert!(complete("move-ramp --").contains(&"--vel".to_string()), "{:?}", complete("move-ramp --"));
    }
}
