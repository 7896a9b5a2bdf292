//! `axisctl shell`: the batch engine at a terminal. Line editing, history
//! and completion come from rustyline (no system library); completion
//! walks the same clap tree that parses the lines.
//!
//! Ctrl-C at the prompt clears the line (the terminal is in raw mode, so it
//! is a key, not a signal); during a command it is the signal, and the
//! engine halts what the lines moved, as in a batch, then prompts again.
//! Ctrl-D (or `exit`) ends the shell; a failed line does not.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use axisctl::device::supervisor;
use rustyline::completion::{Completer, Pair};
use rustyline::error::ReadlineError;
use rustyline::highlight::Highlighter;
use rustyline::hint::Hinter;
use rustyline::validate::Validator;
use rustyline::{Config, Editor, Helper};

use super::batch::{Engine, REFUSED};
use super::Ctx;
use crate::cli::batch::ShellArgs;
use crate::output;

pub fn run(ctx: &Ctx, args: &ShellArgs) -> anyhow::Result<()> {
    let mut engine = Engine::new(ctx)?;
    let helper = Complete { tree: engine.parser().clone() };
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
    let mut n = 0;
    loop {
        let text = match ed.readline(&prompt) {
            Ok(text) => text,
            Err(ReadlineError::Interrupted) => continue,
            Err(ReadlineError::Eof) => break,
            Err(e) => return Err(e.into()),
        };
        n += 1;
        let shown = super::batch::shown(&text);
        if shown.is_empty() {
            continue;
        }
        let _ = ed.add_history_entry(text.trim());
        if let Some(path) = &history {
            save_history(&mut ed, path);
        }
        if matches!(shown.as_str(), "exit" | "quit") {
            break;
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
            // What the lines moved is halted: the next command starts afresh.
            supervisor::forget_signal();
        }
        engine.first_failure = None;
        output::flush();
    }
    Ok(())
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

/// Completion of subcommands and flags from the parser's tree.
struct Complete {
    tree: clap::Command,
}

impl Complete {
    /// The candidates for the word that ends at the cursor.
    fn candidates(&self, before: &str) -> (usize, Vec<Pair>) {
        let start = before.rfind(char::is_whitespace).map_or(0, |i| i + 1);
        let word = &before[start..];
        let done: Vec<&str> = before[..start].split_whitespace().collect();
        let sub = done.iter().find_map(|w| self.tree.find_subcommand(w));
        let mut out: Vec<String> = Vec::new();
        if word.starts_with('-') {
            let args = sub.into_iter().flat_map(|s| s.get_arguments()).chain(self.tree.get_arguments());
            for a in args.filter(|a| !a.is_hide_set()) {
                out.extend(a.get_long().map(|l| format!("--{l}")));
                out.extend(a.get_short().map(|s| format!("-{s}")));
            }
        } else if sub.is_none() {
            out.extend(
                self.tree
                    .get_subcommands()
                    .filter(|s| !s.is_hide_set() && !REFUSED.contains(&s.get_name()))
                    .map(|s| s.get_name().to_string()),
            );
        } else if let Some(sub) = sub {
            out.extend(sub.get_subcommands().map(|s| s.get_name().to_string()));
        }
        out.sort();
        out.dedup();
        let pairs = out
            .into_iter()
            .filter(|c| c.starts_with(word))
            .map(|c| Pair { display: c.clone(), replacement: format!("{c} ") })
            .collect();
        (start, pairs)
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
        assert!(complete("get-param --").contains(&"--timeout".to_string()), "global options too");
        assert_eq!(complete("watchdog o"), ["off", "on"]);
    }
}
