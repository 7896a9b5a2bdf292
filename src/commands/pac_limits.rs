//! Where the limits of 0A8D / 0A8E live between processes. `pac-online`
//! reads them in home position (the only mode that reads parameters) and
//! keeps them per port, beside the port's lock; `pac-speed` and
//! `pac-accel`, which are valid only online and so cannot read them, check
//! against that copy. `pac-offline` forgets it: leaving online mode resets
//! the online values (manual 5.2.6.8), and parameters change only in home
//! position, so the next `pac-online` reads them afresh.
//!
//! With no copy (online by another way, another user, the in-process bench
//! of another process) the value goes out and the controller checks it
//! (QUIT 0x29): the documented fallback.

use std::io::{Read, Write};
use std::os::unix::fs::OpenOptionsExt;
use std::path::PathBuf;
use std::sync::Mutex;

use axisctl::device::pac::OnlineLimits;
use axisctl::link::lock;
use axisctl::link::LinkSpec;

/// The state file's kind (its extension beside the lock).
const KIND: &str = "pac-limits";
/// A state file is a few lines; a longer one is not read whole.
const MAX_LEN: u64 = 4096;

/// The in-process bench lives as long as the process (a batch, the shell):
/// its copy does too.
static SIM: Mutex<Option<OnlineLimits>> = Mutex::new(None);

fn path(spec: &LinkSpec) -> Option<PathBuf> {
    match spec {
        LinkSpec::Serial { path, .. } => lock::state_path(&lock::canonical(path), KIND),
        _ => None,
    }
}

/// The copy kept for the controller on `spec`, if any.
pub fn load(spec: &LinkSpec) -> Option<OnlineLimits> {
    if matches!(spec, LinkSpec::Sim(_)) {
        return SIM.lock().unwrap_or_else(|e| e.into_inner()).clone();
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path(spec)?).ok()?.take(MAX_LEN).read_to_end(&mut bytes).ok()?;
    OnlineLimits::parse(std::str::from_utf8(&bytes).ok()?)
}

/// Keeps `limits` for the next command on `spec`. A copy that cannot be
/// written only loses the local check (the controller still checks), so
/// the caller says so and goes on.
pub fn store(spec: &LinkSpec, limits: &OnlineLimits) -> std::io::Result<()> {
    if matches!(spec, LinkSpec::Sim(_)) {
        *SIM.lock().unwrap_or_else(|e| e.into_inner()) = Some(limits.clone());
        return Ok(());
    }
    let Some(path) = path(spec) else { return Ok(()) };
    // Written aside and renamed, so a reader never sees half a copy.
    let tmp = path.with_extension(format!("{KIND}.{}.tmp", std::process::id()));
    let written = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(&tmp)
        .and_then(|mut f| f.write_all(limits.to_text().as_bytes()))
        .and_then(|()| std::fs::rename(&tmp, &path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// Forgets the copy (the controller left online mode).
pub fn forget(spec: &LinkSpec) {
    if matches!(spec, LinkSpec::Sim(_)) {
        *SIM.lock().unwrap_or_else(|e| e.into_inner()) = None;
    } else if let Some(path) = path(spec) {
        let _ = std::fs::remove_file(path);
    }
}
