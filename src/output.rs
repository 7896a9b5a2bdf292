//! Human and JSON output: colour only on a terminal and never with NO_COLOR.

use std::io::{IsTerminal, Write};

use axisctl::device::supervisor;
use axisctl::proto::powercube::flags::FlagClass;

#[derive(Debug, Clone, Copy)]
pub struct Style {
    pub color: bool,
}

impl Style {
    pub fn detect() -> Self {
        let color = std::io::stdout().is_terminal() && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty());
        Self { color }
    }

    fn paint(self, code: &str, text: &str) -> String {
        if self.color {
            format!("\x1b[{code}m{text}\x1b[0m")
        } else {
            text.to_string()
        }
    }

    pub fn error(self, text: &str) -> String {
        self.paint("1;31", text)
    }

    pub fn warn(self, text: &str) -> String {
        self.paint("33", text)
    }

    pub fn bold(self, text: &str) -> String {
        self.paint("1", text)
    }

    /// A flag name coloured by its class: errors red, warnings yellow.
    pub fn flag(self, name: &str, class: FlagClass) -> String {
        match class {
            FlagClass::Error => self.error(name),
            FlagClass::Warning => self.warn(name),
            _ => name.to_string(),
        }
    }
}

/// The progress spinner of `--wait`s: on stderr, hidden when that is not a
/// terminal and never with `--json`.
pub fn spinner(json: bool) -> Option<indicatif::ProgressBar> {
    (!json && std::io::stderr().is_terminal()).then(|| {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_spinner()),
        );
        bar
    })
}

/// Hex bytes as typed: `0a3c0000`, `0a 3c 00 00`, `0a:3c`, optionally `0x`-prefixed.
pub fn parse_hex_bytes(text: &str) -> Option<Vec<u8>> {
    let digits: String = text.chars().filter(|c| !c.is_whitespace() && *c != ':' && *c != ',').collect();
    let digits = digits.strip_prefix("0x").unwrap_or(&digits);
    if !digits.len().is_multiple_of(2) || !digits.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    (0..digits.len()).step_by(2).map(|i| u8::from_str_radix(&digits[i..i + 2], 16).ok()).collect()
}

/// The first write to stdout or stderr that failed: the binary's exit code
/// depends on its kind (a closed pipe is a normal end, a full disk is not).
static FAILURE: std::sync::OnceLock<(std::io::ErrorKind, String)> = std::sync::OnceLock::new();

/// Records a failed write of the command's output, here for the exit code
/// and for the motion supervisor, which stops a supervised wait on it.
pub fn note_failure(e: &std::io::Error) {
    let _ = FAILURE.set((e.kind(), e.to_string()));
    supervisor::note_output_failure(e);
}

/// The first output failure of the process, if any.
pub fn failure() -> Option<(std::io::ErrorKind, String)> {
    FAILURE.get().cloned()
}

/// Writes what stdout still buffers (a partial line); a failure is recorded.
pub fn flush() {
    if let Err(e) = std::io::stdout().flush() {
        note_failure(&e);
    }
}

/// Prints one JSON document on stdout. A failed write is not reported here
/// (a closed pipe after `| head` is normal); it is recorded for the exit code
/// and for the motion supervisor.
pub fn json(value: &serde_json::Value) {
    let mut out = std::io::stdout().lock();
    let written = serde_json::to_writer(&mut out, value).map_err(std::io::Error::from).and_then(|()| writeln!(out));
    if let Err(e) = written {
        note_failure(&e);
    }
}

/// One line on stdout that never panics: a failed write (a closed pipe,
/// `/dev/full`) is recorded instead.
pub fn line(args: std::fmt::Arguments) {
    if let Err(e) = writeln!(std::io::stdout(), "{args}") {
        note_failure(&e);
    }
}

/// Text on stdout without a line end, like [`line`].
pub fn text(args: std::fmt::Arguments) {
    if let Err(e) = write!(std::io::stdout(), "{args}") {
        note_failure(&e);
    }
}

/// One line on stderr that never panics. A failure does not change the exit
/// code (stderr is the diagnostics, not the result), but a supervised wait
/// still stops on it: it would go on blind.
pub fn err_line(args: std::fmt::Arguments) {
    if let Err(e) = writeln!(std::io::stderr(), "{args}") {
        supervisor::note_output_failure(&e);
    }
}

/// Text on stderr without a line end (a progress line redrawn in place), like [`err_line`].
pub fn err_text(args: std::fmt::Arguments) {
    if let Err(e) = write!(std::io::stderr(), "{args}") {
        supervisor::note_output_failure(&e);
    }
}

/// `println!` that never panics; see [`line`].
macro_rules! say {
    ($($t:tt)*) => { $crate::output::line(format_args!($($t)*)) };
}
pub(crate) use say;

/// `print!` that never panics; see [`text`].
macro_rules! say_part {
    ($($t:tt)*) => { $crate::output::text(format_args!($($t)*)) };
}
pub(crate) use say_part;

/// `eprint!` that never panics; see [`err_text`].
macro_rules! tell_part {
    ($($t:tt)*) => { $crate::output::err_text(format_args!($($t)*)) };
}
pub(crate) use tell_part;

/// Prints rows as an aligned table; the first row is the header.
pub fn table(rows: &[Vec<String>], style: Style) {
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let width = |c: usize| rows.iter().filter_map(|r| r.get(c)).map(|s| visible_len(s)).max().unwrap_or(0);
    let widths: Vec<usize> = (0..cols).map(width).collect();
    let mut out = std::io::stdout().lock();
    for (i, row) in rows.iter().enumerate() {
        let mut line = String::new();
        for (c, cell) in row.iter().enumerate() {
            if c + 1 == row.len() {
                line.push_str(cell);
            } else {
                line.push_str(cell);
                line.push_str(&" ".repeat(widths[c] - visible_len(cell) + 2));
            }
        }
        let line = if i == 0 { style.bold(&line) } else { line };
        if let Err(e) = writeln!(out, "{}", line.trim_end()) {
            note_failure(&e);
            return;
        }
    }
}

/// Length without ANSI escapes.
fn visible_len(s: &str) -> usize {
    let mut n = 0;
    let mut esc = false;
    for ch in s.chars() {
        match (esc, ch) {
            (false, '\x1b') => esc = true,
            (true, 'm') => esc = false,
            (true, _) => {}
            (false, _) => n += 1,
        }
    }
    n
}
