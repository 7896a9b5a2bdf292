//! Where lock files live. A lock is only worth anything if nobody else can
//! write beside it: a planted lock would have us signal a process of someone
//! else's choosing, and a directory someone else owns can be made to swallow
//! our locks (a symlink, a directory we cannot write), so that an emergency
//! halt finds no holder. A directory is therefore used only when it is a
//! real directory of this user with mode 0700; in its place a private
//! `NAME-XXXXXX` beside it is used (made with mkdtemp, so it cannot be
//! planted in advance), and the process says so once.
//!
//! A halt may run in another environment than the holder (su, sudo -u, cron
//! drop `XDG_RUNTIME_DIR` and `TMPDIR`), so a holder writes its lock both in
//! its runtime directory and in its temporary directory, and a halt looks in
//! every place a holder may have written.

use std::ffi::{OsStr, OsString};
use std::os::unix::ffi::{OsStrExt, OsStringExt};
use std::os::unix::fs::{DirBuilderExt, MetadataExt};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use super::DIR_ENV;

/// A lock directory: `name` in `parent`, or a private `name-XXXXXX` beside it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct Place {
    parent: PathBuf,
    name: OsString,
}

/// The environment that decides the places, read once per use so that
/// tests can give their own.
#[derive(Debug, Clone)]
pub(super) struct Env {
    /// [`DIR_ENV`]: the one place, written and searched.
    pub over: Option<PathBuf>,
    /// `$XDG_RUNTIME_DIR`, when absolute.
    pub runtime: Option<PathBuf>,
    /// `/run/user/UID`, the runtime directory a session without
    /// `XDG_RUNTIME_DIR` has all the same.
    pub run_user: PathBuf,
    /// `std::env::temp_dir()` (`$TMPDIR`, else `/tmp`).
    pub temp: PathBuf,
    /// `/tmp`, where a holder without `TMPDIR` wrote.
    pub tmp: PathBuf,
    pub uid: u32,
}

impl Env {
    pub fn current() -> Self {
        // SAFETY: getuid cannot fail.
        let uid = unsafe { libc::getuid() };
        Self {
            over: std::env::var_os(DIR_ENV).filter(|d| !d.is_empty()).map(PathBuf::from),
            runtime: std::env::var_os("XDG_RUNTIME_DIR").map(PathBuf::from).filter(|d| d.is_absolute()),
            run_user: PathBuf::from(format!("/run/user/{uid}")),
            temp: std::env::temp_dir(),
            tmp: PathBuf::from("/tmp"),
            uid,
        }
    }

    fn temp_name(&self) -> String {
        format!("axisctl-{}", self.uid)
    }

    /// Where this process writes its locks: the runtime directory (when it
    /// has one) and the temporary one.
    pub fn write_places(&self) -> Vec<Place> {
        if let Some(dir) = &self.over {
            return vec![Place::of(dir)];
        }
        let runtime = match &self.runtime {
            Some(run) => Some(Place::new(run, "axisctl")),
            // Not made here: it is the login manager's, and without it there is none.
            None => private(&self.run_user, self.uid).is_ok().then(|| Place::new(&self.run_user, "axisctl")),
        };
        runtime.into_iter().chain([Place::new(&self.temp, &self.temp_name())]).collect()
    }

    /// Every place a holder of this user may have written to, whatever its environment.
    pub fn search_places(&self) -> Vec<Place> {
        if let Some(dir) = &self.over {
            return vec![Place::of(dir)];
        }
        let mut all = Vec::new();
        for p in [
            self.runtime.as_ref().map(|run| Place::new(run, "axisctl")),
            Some(Place::new(&self.run_user, "axisctl")),
            Some(Place::new(&self.temp, &self.temp_name())),
            Some(Place::new(&self.tmp, &self.temp_name())),
        ]
        .into_iter()
        .flatten()
        {
            if !all.contains(&p) {
                all.push(p);
            }
        }
        all
    }
}

impl Place {
    fn new(parent: &Path, name: &str) -> Self {
        Self { parent: parent.to_path_buf(), name: name.into() }
    }

    fn of(dir: &Path) -> Self {
        let parent = dir.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        Self { parent: parent.to_path_buf(), name: dir.file_name().unwrap_or(dir.as_os_str()).to_os_string() }
    }

    fn dir(&self) -> PathBuf {
        self.parent.join(&self.name)
    }

    /// The directory to write locks in, made private on first use. When the
    /// place itself is not private, a private one beside it (the first
    /// already there, else a new one), said once; `None` when neither can be had.
    pub fn writable(&self, uid: u32) -> Option<PathBuf> {
        let dir = self.dir();
        let _ = std::fs::DirBuilder::new().recursive(true).mode(0o700).create(&dir);
        let why = match private(&dir, uid) {
            Ok(()) => return Some(dir),
            Err(why) => why,
        };
        let instead = self.fallbacks(uid).into_iter().next().or_else(|| mkdtemp(&self.parent, &self.name));
        let told = match &instead {
            Some(other) => format!("lock files go to {} instead", other.display()),
            None => "no lock file is written there".into(),
        };
        notice(&dir, &format!("lock directory {} is not used ({why}): {told}", dir.display()));
        instead
    }

    /// The private directories of this place: itself, and those beside it.
    pub fn readable(&self, uid: u32) -> Vec<PathBuf> {
        let dir = self.dir();
        private(&dir, uid).is_ok().then_some(dir).into_iter().chain(self.fallbacks(uid)).collect()
    }

    /// The private `name-XXXXXX` directories beside the place, in name order.
    fn fallbacks(&self, uid: u32) -> Vec<PathBuf> {
        let mut prefix = self.name.as_bytes().to_vec();
        prefix.push(b'-');
        let Ok(entries) = std::fs::read_dir(&self.parent) else { return Vec::new() };
        let mut found: Vec<PathBuf> = entries
            .filter_map(Result::ok)
            .filter(|e| e.file_name().as_bytes().starts_with(&prefix))
            .map(|e| e.path())
            .filter(|p| private(p, uid).is_ok())
            .collect();
        found.sort();
        found
    }
}

/// Whether `dir` is a directory of user `uid` that nobody else may enter:
/// not a symlink, owned by `uid`, mode 0700. `Err` says why not.
pub(super) fn private(dir: &Path, uid: u32) -> Result<(), String> {
    let meta = std::fs::symlink_metadata(dir).map_err(|e| e.to_string())?;
    let mode = meta.mode() & 0o7777;
    if meta.file_type().is_symlink() {
        Err("it is a symbolic link".into())
    } else if !meta.is_dir() {
        Err("it is not a directory".into())
    } else if meta.uid() != uid {
        Err(format!("it belongs to UID {}", meta.uid()))
    } else if mode != 0o700 {
        Err(format!("its mode is {mode:04o}, not 0700"))
    } else {
        Ok(())
    }
}

/// A new private directory `parent/name-XXXXXX` (mkdtemp(3): a name nobody
/// could guess, made with mode 0700, never through a symlink).
fn mkdtemp(parent: &Path, name: &OsStr) -> Option<PathBuf> {
    let mut template = parent.join(name).into_os_string().into_vec();
    template.extend_from_slice(b"-XXXXXX\0");
    if template[..template.len() - 1].contains(&0) {
        return None;
    }
    // SAFETY: a NUL-terminated buffer that mkdtemp fills in place.
    let made = unsafe { libc::mkdtemp(template.as_mut_ptr().cast()) };
    template.pop();
    (!made.is_null()).then(|| PathBuf::from(OsString::from_vec(template)))
}

/// Where a notice goes ([`super::on_notice`]); nowhere until set.
pub(super) static NOTICE: OnceLock<fn(&str)> = OnceLock::new();

/// Says `text` once per process for `dir`: a refused directory is looked at
/// on every open, the person needs to hear it once.
fn notice(dir: &Path, text: &str) {
    static TOLD: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    let mut told = TOLD.lock().unwrap_or_else(|e| e.into_inner());
    if told.iter().any(|d| d == dir) {
        return;
    }
    told.push(dir.to_path_buf());
    if let Some(say) = NOTICE.get() {
        say(text);
    }
}
