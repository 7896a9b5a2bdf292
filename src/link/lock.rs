//! Who holds a device. A serial port is opened exclusively (TIOCEXCL), so a
//! second process cannot even send a halt while a wait or the dashboard
//! holds it. Each open port therefore leaves a lock file naming its holder:
//! PID, process start time, executable and command line. An emergency halt
//! from another terminal reads it to find whom to ask to let go, and the
//! "device busy" error of every other command names the holder.
//!
//! A lock file is a claim, not proof: before anything acts on it, [`Holder::check`]
//! asks the kernel. The start time defeats PID reuse, and the executable must
//! be axisctl, so a process that is not axisctl is never signalled.
//!
//! The lock lives in per-user directories (`$XDG_RUNTIME_DIR/axisctl/` and
//! `$TMPDIR/axisctl-$UID/`, or [`DIR_ENV`]; see [`dir`] for why two, and what
//! makes one fit): there is no room "next to" a `/dev/pts/N`. Its name comes
//! from the canonical device path, so two spellings of one adapter (a
//! `/dev/serial/by-id/` link and its `/dev/ttyACM0`) meet.

mod dir;

use std::fmt;
use std::io::{self, Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use dir::Env;

/// Overrides the lock directory (tests, or a site that wants a shared one).
pub const DIR_ENV: &str = "AXISCTL_LOCK_DIR";
/// First line of every lock file: a file without it is not ours.
const MAGIC: &str = "axisctl-lock 1";
/// A lock file is a few lines; anything longer is garbage and is not read whole.
const MAX_LEN: u64 = 4096;
/// Longest command line recorded, so a huge argument cannot bloat the file.
const MAX_WHAT: usize = 300;

/// The process named by a lock file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Holder {
    pub pid: u32,
    /// Start time in clock ticks after boot (`/proc/PID/stat` field 22).
    pub start: u64,
    /// The executable the holder recorded for itself.
    pub exe: PathBuf,
    /// Its command line, arguments only (e.g. `--link slcan:/dev/ttyACM0 dashboard`).
    pub what: String,
    /// The canonical device path the lock is for.
    pub device: String,
    /// It is an emergency halt taking the device over ([`taking_over`]): it
    /// lets go by itself in a moment, and is never signalled.
    pub halting: bool,
}

/// What the kernel says about the process a lock file names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// A live axisctl process, started when the lock says: it may be asked to halt.
    Axisctl,
    /// The process is gone, or its PID now belongs to a process started later.
    Stale,
    /// A live process that is not axisctl: never signalled.
    NotAxisctl(String),
    /// `/proc` could not say (a process in the middle of exiting has no
    /// executable any more): never signalled, but worth asking again.
    Unchecked(String),
}

/// A lock file that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unreadable lock file: {0}")]
pub struct BadLock(pub String);

impl Holder {
    /// This process, as the holder of `device`. `None` where `/proc` cannot say
    /// who we are (then no lock is written: nobody could verify it).
    pub fn me(device: &str) -> Option<Self> {
        let pid = std::process::id();
        let start = proc_start(pid).ok()??;
        let exe = std::fs::read_link("/proc/self/exe").ok()?;
        // args_os: an argument that is not UTF-8 must not panic here.
        let args: Vec<String> = std::env::args_os().skip(1).map(|a| a.to_string_lossy().into_owned()).collect();
        Some(Self {
            pid,
            start,
            exe: without_deleted(&exe),
            what: one_line(&args.join(" ")),
            device: device.into(),
            halting: TAKING_OVER.load(Ordering::SeqCst),
        })
    }

    /// The lock file's text.
    pub fn to_text(&self) -> String {
        format!(
            "{MAGIC}\npid {}\nstart {}\nexe {}\nwhat {}\ndevice {}\n{}",
            self.pid,
            self.start,
            one_line(&self.exe.to_string_lossy()),
            one_line(&self.what),
            one_line(&self.device),
            // Only then: a reader that does not know the line ignores it.
            if self.halting { "role halt\n" } else { "" }
        )
    }

    /// Reads a lock file's text. Never panics, whatever the bytes.
    pub fn parse(text: &str) -> Result<Self, BadLock> {
        let mut lines = text.lines();
        if lines.next() != Some(MAGIC) {
            return Err(BadLock("not an axisctl lock".into()));
        }
        let (mut pid, mut start, mut exe, mut what, mut device) = (None, None, None, None, None);
        let mut halting = false;
        for line in lines {
            let (key, value) = line.split_once(' ').unwrap_or((line, ""));
            match key {
                "pid" => pid = Some(value.parse::<u32>().map_err(|_| BadLock(format!("bad pid {value:?}")))?),
                "start" => start = Some(value.parse::<u64>().map_err(|_| BadLock(format!("bad start {value:?}")))?),
                "exe" => exe = Some(PathBuf::from(value)),
                "what" => what = Some(value.to_string()),
                "device" => device = Some(value.to_string()),
                "role" => halting = value == "halt",
                _ => {}
            }
        }
        let missing = |k: &str| BadLock(format!("no {k}"));
        let pid = pid.ok_or_else(|| missing("pid"))?;
        if pid == 0 || pid > i32::MAX as u32 {
            // kill(0) and negative PIDs address process groups.
            return Err(BadLock(format!("bad pid {pid}")));
        }
        Ok(Self {
            pid,
            start: start.ok_or_else(|| missing("start"))?,
            exe: exe.filter(|e| e.is_absolute()).ok_or_else(|| missing("absolute exe"))?,
            what: what.unwrap_or_default(),
            device: device.unwrap_or_default(),
            halting,
        })
    }

    /// Asks the kernel whether the lock still tells the truth, and whether the
    /// process is axisctl: the executable it runs is the one it recorded, and
    /// that is an `axisctl` binary or this very program.
    pub fn check(&self) -> Verdict {
        match proc_start(self.pid) {
            Ok(Some(start)) if start == self.start => {}
            Ok(_) => return Verdict::Stale,
            Err(e) => return Verdict::Unchecked(format!("cannot read /proc/{}/stat: {e}", self.pid)),
        }
        if is_zombie(self.pid) {
            return Verdict::Stale;
        }
        let exe_link = format!("/proc/{}/exe", self.pid);
        let actual = match std::fs::read_link(&exe_link) {
            Ok(p) => without_deleted(&p),
            Err(e) => return Verdict::Unchecked(format!("cannot read {exe_link}: {e}")),
        };
        if actual != self.exe {
            return Verdict::NotAxisctl(format!(
                "it runs {}, not the {} its lock names",
                actual.display(),
                self.exe.display()
            ));
        }
        let named_axisctl = actual.file_name().is_some_and(|n| n == "axisctl");
        if named_axisctl || same_file(Path::new(&exe_link), Path::new("/proc/self/exe")) {
            Verdict::Axisctl
        } else {
            Verdict::NotAxisctl(format!("it runs {}, which is not axisctl", actual.display()))
        }
    }

    /// Whether the process has ended (gone, reused, or a zombie: its ports are closed).
    pub fn is_gone(&self) -> bool {
        !matches!(proc_start(self.pid), Ok(Some(s)) if s == self.start) || is_zombie(self.pid)
    }

    /// Waits up to `within` for the process to end; true once it has.
    pub fn wait_gone(&self, within: Duration) -> bool {
        let deadline = Instant::now() + within;
        loop {
            if self.is_gone() {
                return true;
            }
            if Instant::now() >= deadline {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// Sends SIGTERM, which an axisctl holder answers by halting what it
    /// drives and exiting, then SIGCONT: a holder stopped with Ctrl-Z would
    /// otherwise keep the SIGTERM pending, and the port, for as long as it
    /// stays stopped. The check is made again at the last moment, on a pidfd
    /// where the kernel has them, so the signals cannot reach a process that
    /// took over the PID in between.
    pub fn terminate(&self) -> Result<(), TerminateError> {
        if self.pid == std::process::id() {
            return Err(TerminateError::Itself);
        }
        let pidfd = pidfd_open(self.pid);
        match self.check() {
            Verdict::Axisctl => {}
            Verdict::Stale => return Err(TerminateError::Gone),
            Verdict::NotAxisctl(why) => return Err(TerminateError::NotAxisctl(why)),
            Verdict::Unchecked(why) => return Err(TerminateError::Unchecked(why)),
        }
        let signal = |sig| match &pidfd {
            Some(fd) => pidfd_signal(fd, sig),
            // SAFETY: kill(2) on a PID just checked; positive, so never a group.
            None => match unsafe { libc::kill(self.pid as libc::pid_t, sig) } {
                0 => Ok(()),
                _ => Err(io::Error::last_os_error()),
            },
        };
        signal(libc::SIGTERM).map_err(|e| match e.raw_os_error() {
            Some(libc::ESRCH) => TerminateError::Gone,
            _ => TerminateError::Refused(e),
        })?;
        // A process that was not stopped ignores it; one that is gone needs none.
        let _ = signal(libc::SIGCONT);
        Ok(())
    }
}

impl fmt::Display for Holder {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "PID {} ({}", self.pid, self.exe.display())?;
        if !self.what.is_empty() {
            write!(f, " {}", self.what)?;
        }
        write!(f, ")")
    }
}

/// Why a holder was not signalled.
#[derive(Debug, thiserror::Error)]
pub enum TerminateError {
    #[error("it has already exited")]
    Gone,
    /// A process never signals itself: it holds the port through another link of its own.
    #[error("it is this very process")]
    Itself,
    #[error("it is not axisctl ({0}), so it was not signalled")]
    NotAxisctl(String),
    #[error("it could not be checked ({0}), so it was not signalled")]
    Unchecked(String),
    #[error("SIGTERM was refused: {0}")]
    Refused(io::Error),
}

/// A lock file this process holds, in each place it writes; removed when dropped.
#[derive(Debug)]
pub struct Lock {
    paths: Vec<PathBuf>,
    me: Holder,
}

impl Drop for Lock {
    fn drop(&mut self) {
        for path in &self.paths {
            // Only while it still names us: a lock is never taken from someone else.
            if read(path).is_some_and(|h| h.pid == self.me.pid && h.start == self.me.start) {
                let _ = std::fs::remove_file(path);
            }
        }
    }
}

impl Lock {
    /// The lock files written, the runtime directory's first.
    pub fn paths(&self) -> &[PathBuf] {
        &self.paths
    }
}

static TAKING_OVER: AtomicBool = AtomicBool::new(false);

/// From now on this process's locks say it is an emergency halt taking a
/// device over: another halt at the same moment waits for it to let go
/// instead of signalling it (two halts at once must both go out). Set by
/// [`crate::open::Opener::take_over`], which only the one-shot halts use.
pub fn taking_over() {
    TAKING_OVER.store(true, Ordering::SeqCst);
}

/// Where a notice about the lock directories goes (a directory that is not
/// private and is not used): the binary prints it on stderr. Said once per
/// directory and process; the first call sets it.
pub fn on_notice(say: fn(&str)) {
    let _ = dir::NOTICE.set(say);
}

/// Records this process as the holder of `device`, which it has just opened
/// exclusively: no one else can hold the device now, so a lock already there
/// is stale and is replaced. `None` when no lock could be written; the device
/// works as before, only an emergency halt cannot find its holder.
pub fn acquire(device: &str) -> Option<Lock> {
    acquire_with(&Env::current(), device)
}

fn acquire_with(env: &Env, device: &str) -> Option<Lock> {
    let dirs: Vec<PathBuf> = env.write_places().iter().filter_map(|p| p.writable(env.uid)).collect();
    acquire_in(&dirs, device)
}

fn acquire_in(dirs: &[PathBuf], device: &str) -> Option<Lock> {
    let device = canonical(device);
    let me = Holder::me(&device)?;
    let paths: Vec<PathBuf> = dirs.iter().filter_map(|dir| write_in(dir, &device, &me)).collect();
    (!paths.is_empty()).then_some(Lock { paths, me })
}

fn write_in(dir: &Path, device: &str, me: &Holder) -> Option<PathBuf> {
    let path = lock_path_in(dir, device);
    // Written aside and renamed, so a reader never sees half a lock.
    let tmp = path.with_extension(format!("{}.tmp", me.pid));
    let written = std::fs::OpenOptions::new()
        .write(true)
        .create(true)
        .truncate(true)
        .mode(0o600)
        .open(&tmp)
        .and_then(|mut f| f.write_all(me.to_text().as_bytes()))
        .and_then(|_| std::fs::rename(&tmp, &path));
    match written {
        Ok(()) => Some(path),
        Err(_) => {
            let _ = std::fs::remove_file(&tmp);
            None
        }
    }
}

/// What the lock files of a device say about its holder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Found {
    /// No lock file names a holder.
    Nothing,
    /// A lock file that does not parse, and none that does.
    Unreadable(BadLock),
    /// The most telling holder named, with what the kernel says of it.
    Holder(Holder, Verdict),
}

/// Looks for the holder of `device` in every place a holder of this user may
/// have written. Where several locks name someone, a live axisctl process
/// wins, then one that is not axisctl, then one that could not be checked,
/// then an exited one.
pub fn find(device: &str) -> Found {
    find_with(&Env::current(), device)
}

fn find_with(env: &Env, device: &str) -> Found {
    let dirs: Vec<PathBuf> = env.search_places().iter().flat_map(|p| p.readable(env.uid)).collect();
    find_in(&dirs, device)
}

fn find_in(dirs: &[PathBuf], device: &str) -> Found {
    let device = canonical(device);
    let mut found = Found::Nothing;
    for dir in dirs {
        let Ok(text) = read_text(&lock_path_in(dir, &device)) else { continue };
        let next = match Holder::parse(&text) {
            Ok(h) => {
                let verdict = h.check();
                Found::Holder(h, verdict)
            }
            Err(e) => Found::Unreadable(e),
        };
        if rank(&next) > rank(&found) {
            found = next;
        }
    }
    found
}

fn rank(found: &Found) -> u8 {
    match found {
        Found::Nothing => 0,
        Found::Unreadable(_) => 1,
        Found::Holder(_, Verdict::Stale) => 2,
        Found::Holder(_, Verdict::Unchecked(_)) => 3,
        Found::Holder(_, Verdict::NotAxisctl(_)) => 4,
        Found::Holder(_, Verdict::Axisctl) => 5,
    }
}

/// Who holds `device`, said for a "device busy" error.
pub fn describe(device: &str) -> String {
    match find(device) {
        Found::Nothing => "no axisctl lock names its holder: is another program using it?".into(),
        Found::Unreadable(e) => format!("{e}; is another program using it?"),
        Found::Holder(h, Verdict::Axisctl) => format!("held by axisctl, {h}"),
        Found::Holder(h, Verdict::Stale) => {
            format!("its lock names PID {}, which has exited: is another program using it?", h.pid)
        }
        Found::Holder(h, Verdict::NotAxisctl(why)) => {
            format!("its lock names PID {}, which is not axisctl ({why})", h.pid)
        }
        Found::Holder(h, Verdict::Unchecked(why)) => {
            format!("its lock names PID {}, which cannot be checked ({why})", h.pid)
        }
    }
}

fn read(path: &Path) -> Option<Holder> {
    Holder::parse(&read_text(path).ok()?).ok()
}

fn read_text(path: &Path) -> io::Result<String> {
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(MAX_LEN).read_to_end(&mut bytes)?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// The device path every spelling of it resolves to.
pub fn canonical(device: &str) -> String {
    std::fs::canonicalize(device).map(|p| p.to_string_lossy().into_owned()).unwrap_or_else(|_| device.into())
}

/// Where this process writes the lock of a canonical device path, in its
/// runtime directory when it has one: `/dev/pts/3` is `%2Fdev%2Fpts%2F3.lock`.
pub fn lock_path(device: &str) -> Option<PathBuf> {
    let env = Env::current();
    let dir = env.write_places().iter().find_map(|p| p.writable(env.uid))?;
    Some(lock_path_in(&dir, device))
}

/// A file of what else is known about a device (`kind`, e.g. `pac-limits`),
/// beside its lock in this process's first private directory: the
/// directories' checks (ours, 0700, no symlink) hold for it too.
pub fn state_path(device: &str, kind: &str) -> Option<PathBuf> {
    lock_path(device).map(|p| p.with_extension(kind))
}

/// The lock file of `device` in `dir`.
pub fn lock_path_in(dir: &Path, device: &str) -> PathBuf {
    let name: String = device
        .chars()
        .map(|c| match c {
            '/' => "%2F".to_string(),
            '%' => "%25".to_string(),
            c => c.to_string(),
        })
        .collect();
    dir.join(format!("{name}.lock"))
}

/// When process `pid` started (`/proc/PID/stat` field 22, clock ticks after
/// boot); `Ok(None)` when there is no such process.
pub fn proc_start(pid: u32) -> io::Result<Option<u64>> {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(text) => Ok(stat_field(&text, 22).and_then(|f| f.parse().ok())),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(e),
    }
}

fn is_zombie(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).ok().and_then(|t| stat_field(&t, 3).map(|s| s == "Z"))
        == Some(true)
}

/// Field `n` (1-based, as proc(5) counts) of a stat line. The command name
/// (field 2) is in parentheses and may hold spaces and parentheses itself, so
/// the fields after it are counted from its last `)`.
fn stat_field(text: &str, n: usize) -> Option<&str> {
    let rest = &text[text.rfind(')')? + 1..];
    rest.split_whitespace().nth(n.checked_sub(3)?)
}

/// `/proc/PID/exe` of a program whose file was replaced (a rebuild) ends in " (deleted)".
fn without_deleted(p: &Path) -> PathBuf {
    let s = p.to_string_lossy();
    PathBuf::from(s.strip_suffix(" (deleted)").unwrap_or(&s))
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Text that fits one line of the lock file.
fn one_line(s: &str) -> String {
    s.chars().map(|c| if c.is_control() { ' ' } else { c }).take(MAX_WHAT).collect()
}

/// A pidfd for `pid`, where the kernel has them (Linux 5.3).
#[cfg(target_os = "linux")]
fn pidfd_open(pid: u32) -> Option<OwnedFd> {
    use std::os::fd::FromRawFd;
    // SAFETY: pidfd_open(2) takes a PID and flags; it returns a new fd or -1.
    let fd = unsafe { libc::syscall(libc::SYS_pidfd_open, pid as libc::pid_t, 0) };
    // SAFETY: a fresh fd that nothing else owns.
    (fd >= 0).then(|| unsafe { OwnedFd::from_raw_fd(fd as libc::c_int) })
}

#[cfg(not(target_os = "linux"))]
fn pidfd_open(_pid: u32) -> Option<OwnedFd> {
    None
}

#[cfg(target_os = "linux")]
fn pidfd_signal(fd: &OwnedFd, sig: libc::c_int) -> io::Result<()> {
    use std::os::fd::AsRawFd;
    // SAFETY: a live pidfd; a null siginfo means "as kill(2) would".
    let r = unsafe { libc::syscall(libc::SYS_pidfd_send_signal, fd.as_raw_fd(), sig, std::ptr::null::<u8>(), 0) };
    if r == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(not(target_os = "linux"))]
fn pidfd_signal(_fd: &OwnedFd, _sig: libc::c_int) -> io::Result<()> {
    Err(io::Error::from(io::ErrorKind::Unsupported))
}

#[cfg(test)]
mod tests;
