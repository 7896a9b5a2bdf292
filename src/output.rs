//! Human and JSON output: colour only on a terminal and never with NO_COLOR.

use std::io::{IsTerminal, Write};

use axisctl::device::supervisor;
use axisctl::proto::flag_word::{FlagClass, FlagWord};

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
    let wrapped = batch_wrap(value);
    let value = wrapped.as_ref().unwrap_or(value);
    if wrapped.as_ref().is_some_and(serde_json::Value::is_null) {
        return;
    }
    let mut out = std::io::stdout().lock();
    let written = serde_json::to_writer(&mut out, value).map_err(std::io::Error::from).and_then(|()| writeln!(out));
    if let Err(e) = written {
        note_failure(&e);
    }
}

static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `-q`: the command's results are not printed; errors and warnings still
/// go to stderr, and the exit status says how it went.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// One line on stdout that never panics: a failed write (a closed pipe,
/// `/dev/full`) is recorded instead.
pub fn line(args: std::fmt::Arguments) {
    if quiet() {
        return;
    }
    if let Err(e) = writeln!(std::io::stdout(), "{args}") {
        note_failure(&e);
    }
}

/// Text on stdout without a line end, like [`line`].
pub fn text(args: std::fmt::Arguments) {
    if quiet() {
        return;
    }
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
    if quiet() {
        return;
    }
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

/// The device a command is addressing, kept for the error object: set each
/// time a device is addressed, so that a failure names the one it hit.
static TARGET: std::sync::Mutex<Option<serde_json::Map<String, serde_json::Value>>> = std::sync::Mutex::new(None);

/// The envelope every per-device JSON object starts with (docs/json.md):
/// the family's registry name, the device's address in the family's one
/// form and the link as given. Also records the address for
/// [`current_target`].
pub fn envelope(
    family: axisctl::family::Family,
    link: &str,
    address: &[(&'static str, u64)],
) -> serde_json::Map<String, serde_json::Value> {
    let mut doc = target(family, address);
    doc.insert("link".into(), link.into());
    doc
}

/// Records that the command now talks to this device; returns its address
/// with the family.
pub fn target(
    family: axisctl::family::Family,
    address: &[(&'static str, u64)],
) -> serde_json::Map<String, serde_json::Value> {
    let mut doc = serde_json::Map::new();
    doc.insert("family".into(), family.name().into());
    for (key, id) in address {
        doc.insert((*key).into(), (*id).into());
    }
    if let Ok(mut t) = TARGET.lock() {
        *t = Some(doc.clone());
    }
    doc
}

/// Forgets the device addressed last: what follows concerns several.
pub fn forget_target() {
    if let Ok(mut t) = TARGET.lock() {
        *t = None;
    }
}

/// The family and address of the device addressed last, if any.
pub fn current_target() -> Option<serde_json::Map<String, serde_json::Value>> {
    TARGET.lock().ok().and_then(|t| t.clone())
}

/// The document a command had to show although it failed (a restore that
/// wrote some values and failed others): under `--json` it goes into the
/// error object as `report`, since stdout stays empty on a failure.
static REPORT: std::sync::Mutex<Option<serde_json::Value>> = std::sync::Mutex::new(None);

/// Keeps `doc` for the error object of the failure that follows.
pub fn report_with_error(doc: serde_json::Value) {
    if let Ok(mut r) = REPORT.lock() {
        *r = Some(doc);
    }
}

/// The document [`report_with_error`] kept, taken.
pub fn take_error_report() -> Option<serde_json::Value> {
    REPORT.lock().ok().and_then(|mut r| r.take())
}

static LINK: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// Records the link as given (`--link` or `AXISCTL_LINK`) for the error
/// object, which names it like every device document does.
pub fn set_link(link: &str) {
    if let Ok(mut l) = LINK.lock() {
        *l = (!link.is_empty()).then(|| link.to_string());
    }
}

/// The link [`set_link`] recorded, if one was given.
pub fn current_link() -> Option<String> {
    LINK.lock().ok().and_then(|l| l.clone())
}

/// `{"value": v, "unit": "m"}`: a number with the manual's unit (`""` for
/// none), the one value shape of every family.
pub fn with_unit(value: serde_json::Value, unit: &str) -> serde_json::Value {
    serde_json::json!({"value": value, "unit": unit})
}

/// `envelope` followed by the command's own keys.
pub fn device_doc(
    mut envelope: serde_json::Map<String, serde_json::Value>,
    body: serde_json::Value,
) -> serde_json::Value {
    if let serde_json::Value::Object(b) = body {
        envelope.extend(b);
    }
    serde_json::Value::Object(envelope)
}

/// One set flag in the common detail shape of every family.
pub struct Detail<'a> {
    pub name: &'a str,
    /// The flag's bit(s) within the raw word.
    pub mask: u64,
    /// `error`, `warning`, `info` or `obsolete`.
    pub class: &'a str,
    pub description: &'a str,
}

/// The one `state` shape of all families: the raw word, the set flags by
/// name (and those that are errors or warnings), each explained, and the
/// set bits no flag names, as a mask.
pub fn state(raw: u64, set: &[Detail], unknown_bits: u64) -> serde_json::Value {
    let names = |class: Option<&str>| -> Vec<&str> {
        set.iter().filter(|d| class.is_none_or(|c| d.class == c)).map(|d| d.name).collect()
    };
    let details: Vec<_> = set
        .iter()
        .map(|d| serde_json::json!({"name": d.name, "mask": d.mask, "class": d.class, "description": d.description}))
        .collect();
    serde_json::json!({"raw": raw, "flags": names(None), "errors": names(Some("error")),
                       "warnings": names(Some("warning")), "details": details, "unknown_bits": unknown_bits})
}

/// A flag word (the PowerCube's CubeState, Config, DioSetup) in the `state` shape.
pub fn flag_word(word: &FlagWord, raw: u32) -> serde_json::Value {
    word.state_json(raw)
}

/// The batch line (`batch`, `shell` with `--json`) whose documents
/// [`json`] prints now, each wrapped in the line's result object.
struct BatchLine {
    line: usize,
    command: String,
    printed: bool,
    /// A halt the batch sends on its way out: reported in its error object.
    quiet: bool,
}

static BATCH_LINE: std::sync::Mutex<Option<BatchLine>> = std::sync::Mutex::new(None);

/// From now on every document [`json`] prints is `{"line", "command",
/// "result"}` (docs/json.md, batch); with `quiet` it is not printed.
pub fn begin_batch_line(line: usize, command: &str, quiet: bool) {
    if let Ok(mut b) = BATCH_LINE.lock() {
        *b = Some(BatchLine { line, command: command.to_string(), printed: false, quiet });
    }
}

/// Ends [`begin_batch_line`]: whether the line printed a document.
pub fn end_batch_line() -> bool {
    BATCH_LINE.lock().ok().and_then(|mut b| b.take()).is_some_and(|b| b.printed)
}

/// The wrapped document, `Null` for a quiet line, `None` outside a batch line.
fn batch_wrap(value: &serde_json::Value) -> Option<serde_json::Value> {
    let mut guard = BATCH_LINE.lock().ok()?;
    let b = guard.as_mut()?;
    b.printed = true;
    if b.quiet {
        return Some(serde_json::Value::Null);
    }
    Some(serde_json::json!({"line": b.line, "command": b.command, "result": value}))
}
