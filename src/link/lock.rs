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
//! The lock lives in a per-user runtime directory (`$XDG_RUNTIME_DIR/axisctl/`,
//! else `/tmp/axisctl-$UID/`, or [`DIR_ENV`]): there is no room "next to" a
//! `/dev/pts/N`. Its name comes from the canonical device path, so two spellings
//! of one adapter (a `/dev/serial/by-id/` link and its `/dev/ttyACM0`) meet.

use std::fmt;
use std::io::{self, Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::fs::{DirBuilderExt, MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

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
}

/// What the kernel says about the process a lock file names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Verdict {
    /// A live axisctl process, started when the lock says: it may be asked to halt.
    Axisctl,
    /// The process is gone, or its PID now belongs to a process started later.
    Stale,
    /// A live process that is not axisctl, or that cannot be checked: never signalled.
    NotAxisctl(String),
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
        Some(Self { pid, start, exe: without_deleted(&exe), what: one_line(&args.join(" ")), device: device.into() })
    }

    /// The lock file's text.
    pub fn to_text(&self) -> String {
        format!(
            "{MAGIC}\npid {}\nstart {}\nexe {}\nwhat {}\ndevice {}\n",
            self.pid,
            self.start,
            one_line(&self.exe.to_string_lossy()),
            one_line(&self.what),
            one_line(&self.device)
        )
    }

    /// Reads a lock file's text. Never panics, whatever the bytes.
    pub fn parse(text: &str) -> Result<Self, BadLock> {
        let mut lines = text.lines();
        if lines.next() != Some(MAGIC) {
            return Err(BadLock("not an axisctl lock".into()));
        }
        let (mut pid, mut start, mut exe, mut what, mut device) = (None, None, None, None, None);
        for line in lines {
            let (key, value) = line.split_once(' ').unwrap_or((line, ""));
            match key {
                "pid" => pid = Some(value.parse::<u32>().map_err(|_| BadLock(format!("bad pid {value:?}")))?),
                "start" => start = Some(value.parse::<u64>().map_err(|_| BadLock(format!("bad start {value:?}")))?),
                "exe" => exe = Some(PathBuf::from(value)),
                "what" => what = Some(value.to_string()),
                "device" => device = Some(value.to_string()),
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
        })
    }

    /// Asks the kernel whether the lock still tells the truth, and whether the
    /// process is axisctl: the executable it runs is the one it recorded, and
    /// that is an `axisctl` binary or this very program.
    pub fn check(&self) -> Verdict {
        match proc_start(self.pid) {
            Ok(Some(start)) if start == self.start => {}
            Ok(_) => return Verdict::Stale,
            Err(e) => return Verdict::NotAxisctl(format!("cannot read /proc/{}/stat: {e}", self.pid)),
        }
        if is_zombie(self.pid) {
            return Verdict::Stale;
        }
        let exe_link = format!("/proc/{}/exe", self.pid);
        let actual = match std::fs::read_link(&exe_link) {
            Ok(p) => without_deleted(&p),
            Err(e) => return Verdict::NotAxisctl(format!("cannot read {exe_link}: {e}")),
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
    /// drives and exiting. The check is made again at the last moment, on a
    /// pidfd where the kernel has them, so the signal cannot reach a process
    /// that took over the PID in between.
    pub fn terminate(&self) -> Result<(), TerminateError> {
        if self.pid == std::process::id() {
            return Err(TerminateError::Itself);
        }
        let pidfd = pidfd_open(self.pid);
        match self.check() {
            Verdict::Axisctl => {}
            Verdict::Stale => return Err(TerminateError::Gone),
            Verdict::NotAxisctl(why) => return Err(TerminateError::NotAxisctl(why)),
        }
        let sent = match pidfd {
            Some(fd) => pidfd_sigterm(&fd),
            // SAFETY: kill(2) on a PID just checked; positive, so never a group.
            None => match unsafe { libc::kill(self.pid as libc::pid_t, libc::SIGTERM) } {
                0 => Ok(()),
                _ => Err(io::Error::last_os_error()),
            },
        };
        sent.map_err(|e| match e.raw_os_error() {
            Some(libc::ESRCH) => TerminateError::Gone,
            _ => TerminateError::Refused(e),
        })
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
    #[error("SIGTERM was refused: {0}")]
    Refused(io::Error),
}

/// A lock file this process holds; removed when dropped.
#[derive(Debug)]
pub struct Lock {
    path: PathBuf,
    me: Holder,
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Only while it still names us: a lock is never taken from someone else.
        if read(&self.path).is_some_and(|h| h.pid == self.me.pid && h.start == self.me.start) {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

impl Lock {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Records this process as the holder of `device`, which it has just opened
/// exclusively: no one else can hold the device now, so a lock already there
/// is stale and is replaced. `None` when no lock could be written; the device
/// works as before, only an emergency halt cannot find its holder.
pub fn acquire(device: &str) -> Option<Lock> {
    acquire_in(&lock_dir()?, device)
}

fn acquire_in(dir: &Path, device: &str) -> Option<Lock> {
    let device = canonical(device);
    let path = lock_path_in(dir, &device);
    let me = Holder::me(&device)?;
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
        Ok(()) => Some(Lock { path, me }),
        Err(_) => {
            let _ = std::fs::remove_file(&tmp);
            None
        }
    }
}

/// The holder a lock file names for `device`: `None` without a lock file,
/// `Some(Err)` for one that does not parse.
pub fn holder(device: &str) -> Option<Result<Holder, BadLock>> {
    holder_in(&lock_dir()?, device)
}

fn holder_in(dir: &Path, device: &str) -> Option<Result<Holder, BadLock>> {
    let path = lock_path_in(dir, &canonical(device));
    let text = read_text(&path).ok()?;
    Some(Holder::parse(&text))
}

/// Who holds `device`, said for a "device busy" error.
pub fn describe(device: &str) -> String {
    match holder(device) {
        None => "no axisctl lock names its holder: is another program using it?".into(),
        Some(Err(e)) => format!("{e}; is another program using it?"),
        Some(Ok(h)) => match h.check() {
            Verdict::Axisctl => format!("held by axisctl, {h}"),
            Verdict::Stale => {
                format!("its lock names PID {}, which has exited: is another program using it?", h.pid)
            }
            Verdict::NotAxisctl(why) => format!("its lock names PID {}, which is not axisctl ({why})", h.pid),
        },
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

/// The lock file of a canonical device path: `/dev/pts/3` is `%2Fdev%2Fpts%2F3.lock`.
pub fn lock_path(device: &str) -> Option<PathBuf> {
    Some(lock_path_in(&lock_dir()?, device))
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

/// The per-user lock directory, created private on first use. `None` when it
/// cannot be made, or is not a private directory of this user (someone else
/// could then plant a lock and have us signal their choice of process).
pub fn lock_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os(DIR_ENV).filter(|d| !d.is_empty()) {
        Some(d) => PathBuf::from(d),
        None => match std::env::var_os("XDG_RUNTIME_DIR").map(PathBuf::from).filter(|d| d.is_absolute()) {
            Some(run) => run.join("axisctl"),
            // SAFETY: getuid cannot fail.
            None => std::env::temp_dir().join(format!("axisctl-{}", unsafe { libc::getuid() })),
        },
    };
    let _ = std::fs::DirBuilder::new().recursive(true).mode(0o700).create(&dir);
    let meta = std::fs::symlink_metadata(&dir).ok()?;
    // SAFETY: getuid cannot fail.
    let private = meta.is_dir() && meta.uid() == unsafe { libc::getuid() } && meta.mode() & 0o022 == 0;
    private.then_some(dir)
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
fn pidfd_sigterm(fd: &OwnedFd) -> io::Result<()> {
    use std::os::fd::AsRawFd;
    // SAFETY: a live pidfd; a null siginfo means "as kill(2) would".
    let r =
        unsafe { libc::syscall(libc::SYS_pidfd_send_signal, fd.as_raw_fd(), libc::SIGTERM, std::ptr::null::<u8>(), 0) };
    if r == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

#[cfg(not(target_os = "linux"))]
fn pidfd_sigterm(_fd: &OwnedFd) -> io::Result<()> {
    Err(io::Error::from(io::ErrorKind::Unsupported))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn me() -> Holder {
        Holder::me("/dev/pts/99").expect("/proc knows this process")
    }

    #[test]
    fn a_lock_reads_back_as_written() {
        let h = me();
        assert_eq!(Holder::parse(&h.to_text()), Ok(h.clone()));
        assert_eq!(h.pid, std::process::id());
        assert!(h.to_text().starts_with("axisctl-lock 1\npid "), "{}", h.to_text());
    }

    #[test]
    fn garbage_never_parses_and_never_panics() {
        let good = me().to_text();
        for text in [
            "",
            "\n\n",
            "pid 12\nstart 3\nexe /bin/axisctl\n",
            "axisctl-lock 1\n",
            "axisctl-lock 1\npid\nstart\nexe\n",
            "axisctl-lock 1\npid -5\nstart 3\nexe /bin/axisctl\n",
            "axisctl-lock 1\npid 0\nstart 3\nexe /bin/axisctl\n",
            "axisctl-lock 1\npid 99999999999\nstart 3\nexe /bin/axisctl\n",
            "axisctl-lock 1\npid 12\nstart x\nexe /bin/axisctl\n",
            "axisctl-lock 1\npid 12\nstart 3\nexe relative/axisctl\n",
            "axisctl-lock 1\npid 12\nstart 3\n",
            "\u{0}\u{ffff}))(( ",
        ] {
            assert!(Holder::parse(text).is_err(), "{text:?} parsed");
        }
        // Every prefix and every single-byte corruption of a real lock.
        for cut in 0..good.len() {
            let _ = Holder::parse(&good[..cut]);
        }
        let bytes = good.as_bytes();
        for i in 0..bytes.len() {
            for b in [0u8, b'\n', b' ', b')', 0xff] {
                let mut v = bytes.to_vec();
                v[i] = b;
                let _ = Holder::parse(&String::from_utf8_lossy(&v));
            }
        }
    }

    #[test]
    fn stat_fields_are_counted_after_the_last_parenthesis() {
        let line = "42 (a) b (c)) S 1 42 42 0 -1 4194560 100 0 0 0 1 2 0 0 20 0 1 0 987654 1000 10";
        assert_eq!(stat_field(line, 3), Some("S"));
        assert_eq!(stat_field(line, 22), Some("987654"));
        assert_eq!(stat_field("no parenthesis", 22), None);
        assert_eq!(stat_field("1 (x) S", 22), None);
        assert_eq!(stat_field("1 (x) S", 1), None);
    }

    #[test]
    fn this_very_program_counts_as_axisctl_and_a_forged_exe_is_caught() {
        // The test binary is not named axisctl, yet it is "this very program".
        assert_eq!(me().check(), Verdict::Axisctl);
        let forged = Holder { exe: PathBuf::from("/usr/local/bin/axisctl"), ..me() };
        assert!(matches!(forged.check(), Verdict::NotAxisctl(why) if why.contains("not the /usr/local/bin/axisctl")));
    }

    #[test]
    fn a_live_process_that_is_not_axisctl_is_never_signalled() {
        let mut sleep = std::process::Command::new("sleep").arg("30").spawn().unwrap();
        let pid = sleep.id();
        let start = proc_start(pid).unwrap().unwrap();
        let exe = without_deleted(&std::fs::read_link(format!("/proc/{pid}/exe")).unwrap());
        // Honest (it says it runs sleep) and forged (it claims axisctl): both refused.
        for exe in [exe, PathBuf::from("/usr/bin/axisctl")] {
            let h = Holder { pid, start, exe, what: "60".into(), device: "/dev/x".into() };
            assert!(matches!(h.check(), Verdict::NotAxisctl(_)), "{:?}", h.check());
            assert!(matches!(h.terminate(), Err(TerminateError::NotAxisctl(_))));
        }
        assert!(sleep.try_wait().unwrap().is_none(), "sleep was signalled");
        sleep.kill().unwrap();
        sleep.wait().unwrap();
    }

    #[test]
    fn a_dead_or_reused_pid_is_stale() {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        let dead = Holder { pid, start: 1, exe: PathBuf::from("/bin/true"), what: String::new(), device: "/d".into() };
        assert_eq!(dead.check(), Verdict::Stale);
        assert!(dead.is_gone());
        assert!(matches!(dead.terminate(), Err(TerminateError::Gone)));
        let reused = Holder { start: me().start + 1, ..me() };
        assert_eq!(reused.check(), Verdict::Stale);
        assert!(matches!(me().terminate(), Err(TerminateError::Itself)), "never signals itself");
    }

    #[test]
    fn lock_names_escape_the_path() {
        let dir = Path::new("/run/user/1/axisctl");
        assert_eq!(lock_path_in(dir, "/dev/pts/3"), dir.join("%2Fdev%2Fpts%2F3.lock"));
        assert_ne!(lock_path_in(dir, "/dev/a%2Fb"), lock_path_in(dir, "/dev/a/b"));
    }

    #[test]
    fn a_lock_is_written_replaces_a_stale_one_and_goes_with_its_holder() {
        let dir = tempfile::tempdir().unwrap();
        let device = "/dev/axisctl-lock-test";
        let path = lock_path_in(dir.path(), device);
        std::fs::write(&path, "garbage from a crashed run").unwrap();
        assert!(matches!(holder_in(dir.path(), device), Some(Err(_))));
        let lock = acquire_in(dir.path(), device).expect("written");
        assert_eq!(lock.path(), path);
        let h = holder_in(dir.path(), device).unwrap().unwrap();
        assert_eq!((h.pid, h.device.as_str()), (std::process::id(), device));
        drop(lock);
        assert!(holder_in(dir.path(), device).is_none(), "removed on drop");
        // A lock that names someone else by then is theirs: left alone.
        let lock = acquire_in(dir.path(), device).unwrap();
        let other = Holder { pid: 1, ..h };
        std::fs::write(&path, other.to_text()).unwrap();
        drop(lock);
        assert_eq!(holder_in(dir.path(), device), Some(Ok(other)));
        let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(leftovers.len(), 1, "{leftovers:?}");
    }
}
