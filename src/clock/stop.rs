//! Why a supervised wait must stop now, kept below every layer that can
//! notice it: a caught signal ([`SIGNALS`]: SIGINT, SIGTERM, SIGHUP, SIGQUIT
//! and the others that would end the process; [`JOB_STOPS`]: SIGTSTP,
//! SIGTTIN, SIGTTOU, that would stop it), a failed output write, a
//! failed traffic-log write, a panic on any thread. A caught signal or a
//! panic also wakes [`sleep`], so a poll interval never delays the halt.
//! The policy (when to arm, what to halt) is the motion supervisor's,
//! `device::supervisor`.

use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Mutex;
use std::time::Duration;

/// The signals that halt a supervised motion and then end the process:
/// every signal whose default action ends it, but the crash reports (SIGSEGV,
/// SIGBUS, SIGFPE, SIGILL, SIGTRAP, SIGSYS, SIGABRT: no halt can safely run
/// in a process that faulted) and the real-time signals.
pub const SIGNALS: [i32; 11] = [
    libc::SIGINT,
    libc::SIGTERM,
    libc::SIGHUP,
    libc::SIGQUIT,
    libc::SIGUSR1,
    libc::SIGUSR2,
    libc::SIGALRM,
    libc::SIGVTALRM,
    libc::SIGPROF,
    libc::SIGIO,
    libc::SIGPWR,
];

/// The job-control signals that would stop the process where it stands
/// (Ctrl-Z; a background job that reads or writes its terminal): a
/// supervised motion is halted first, and the process stops afterwards
/// ([`suspend_if_asked`]), once nothing it moved is left moving.
pub const JOB_STOPS: [i32; 3] = [libc::SIGTSTP, libc::SIGTTIN, libc::SIGTTOU];

static CAUGHT: AtomicI32 = AtomicI32::new(0);
static WAKE_WRITE: AtomicI32 = AtomicI32::new(-1);
static WAKE_READ: AtomicI32 = AtomicI32::new(-1);
static OUTPUT_FAILED: AtomicBool = AtomicBool::new(false);
static OUTPUT_ERROR: Mutex<Option<String>> = Mutex::new(None);
static PANICKED: AtomicBool = AtomicBool::new(false);
static PANIC_TEXT: Mutex<Option<String>> = Mutex::new(None);
static LOG_ERROR: Mutex<Option<String>> = Mutex::new(None);
static INSTALLED: Mutex<Option<Result<(), String>>> = Mutex::new(None);

/// The signals could not be taken over.
#[derive(Debug, Clone, thiserror::Error)]
#[error("cannot install the signal handlers: {0}")]
pub struct ArmError(String);

extern "C" fn on_signal(sig: libc::c_int) {
    // Only async-signal-safe work here: an atomic store, sigaction(2) and a write(2).
    let _ = CAUGHT.compare_exchange(0, sig, Ordering::SeqCst, Ordering::SeqCst);
    if sig == libc::SIGTTIN || sig == libc::SIGTTOU {
        // The terminal read or write that raised it is restarted after this
        // handler and would raise it again, for ever: from now on it fails
        // (a read) or goes through (a write), so the halt can proceed.
        set_action(sig, libc::SIG_IGN);
    }
    wake();
}

/// sigaction(2) with `handler` (a function, `SIG_IGN` or `SIG_DFL`), no
/// flag but SA_RESTART and an empty mask. Async-signal-safe.
fn set_action(sig: libc::c_int, handler: libc::sighandler_t) -> bool {
    // SAFETY: a zeroed sigaction with a valid handler; SA_RESTART keeps
    // blocking reads of the link from failing with EINTR.
    unsafe {
        let mut act: libc::sigaction = std::mem::zeroed();
        act.sa_sigaction = handler;
        act.sa_flags = libc::SA_RESTART;
        libc::sigemptyset(&mut act.sa_mask);
        libc::sigaction(sig, &act, std::ptr::null_mut()) == 0
    }
}

fn handler() -> libc::sighandler_t {
    on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t
}

/// Wakes a [`sleep`] in progress. Async-signal-safe.
fn wake() {
    let fd = WAKE_WRITE.load(Ordering::SeqCst);
    if fd >= 0 {
        let byte = 1u8;
        // SAFETY: fd is the write end of our non-blocking pipe; a full pipe
        // already wakes the reader, so a failed write loses nothing.
        unsafe {
            libc::write(fd, (&byte as *const u8).cast(), 1);
        }
    }
}

/// Takes over [`SIGNALS`] and [`JOB_STOPS`] (once per process): from now
/// on they are recorded instead of ending or stopping the process. Call it
/// before the first motion byte of a supervised motion is sent, on the
/// thread that will wait or spawn the threads that do.
///
/// A process may start with these signals blocked (a mask inherited from
/// its parent): Ctrl-C and SIGTERM would then stay pending for ever and the
/// motion run to its end. Every call unblocks them on the calling thread,
/// and threads it spawns later inherit its mask. A signal left pending
/// while they were blocked is acted on now, before any motion byte.
pub fn arm() -> Result<(), ArmError> {
    let mut installed = INSTALLED.lock().unwrap_or_else(|e| e.into_inner());
    if installed.is_none() {
        *installed = Some(install());
    }
    installed.clone().unwrap_or(Ok(())).map_err(ArmError)?;
    drop(installed);
    unblock().map_err(ArmError)
}

/// Unblocks the supervised signals on the calling thread.
fn unblock() -> Result<(), String> {
    // SAFETY: a sigset filled by sigemptyset / sigaddset, then handed to
    // pthread_sigmask for this thread only.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for sig in SIGNALS.into_iter().chain(JOB_STOPS).chain([libc::SIGXFSZ]) {
            libc::sigaddset(&mut set, sig);
        }
        match libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut()) {
            0 => Ok(()),
            e => Err(std::io::Error::from_raw_os_error(e).to_string()),
        }
    }
}

/// A write past the file size limit (`ulimit -f`, RLIMIT_FSIZE) raises
/// SIGXFSZ, whose default ends the process at once, with a motion running
/// and no halt. Ignored, the write fails with EFBIG instead, which the
/// output and `--log` failure paths report and halt on.
pub fn ignore_file_size_signal() {
    set_action(libc::SIGXFSZ, libc::SIG_IGN);
}

fn install() -> Result<(), String> {
    let mut fds = [-1; 2];
    // SAFETY: pipe2 writes two descriptors into fds.
    if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_NONBLOCK | libc::O_CLOEXEC) } != 0 {
        return Err(std::io::Error::last_os_error().to_string());
    }
    WAKE_READ.store(fds[0], Ordering::SeqCst);
    WAKE_WRITE.store(fds[1], Ordering::SeqCst);
    ignore_file_size_signal();
    for sig in SIGNALS.into_iter().chain(JOB_STOPS) {
        if !set_action(sig, handler()) {
            return Err(std::io::Error::last_os_error().to_string());
        }
    }
    Ok(())
}

/// The first signal caught since [`arm`], if any.
pub fn caught() -> Option<i32> {
    match CAUGHT.load(Ordering::SeqCst) {
        0 => None,
        sig => Some(sig),
    }
}

/// Forgets the signal [`caught`] holds, once what it stopped was halted:
/// `shell` goes on to its next command, whose supervised waits must not
/// see an old Ctrl-C. A failed output or a panic stays recorded.
pub fn forget_signal() {
    CAUGHT.store(0, Ordering::SeqCst);
}

/// The job-control stop [`caught`] holds, if that is what was caught.
pub fn job_stop() -> Option<i32> {
    caught().filter(|sig| JOB_STOPS.contains(sig))
}

/// Stops the process as the job-control signal [`caught`] asked, if one
/// did; returns it once the process is continued (`fg`, SIGCONT). Call it
/// only when what the stop interrupted is halted and its links are closed:
/// a stopped process answers no signal, so an emergency halt from another
/// terminal must find the port free and nothing moving.
///
/// The signal itself is raised with its default action, so a shell reports
/// the job as stopped as usual, and the kernel drops it for a process group
/// that no shell could continue (an orphaned one): then the call returns at
/// once. The signal is forgotten first: one that comes while the process is
/// stopped (a SIGTERM, then SIGCONT) is news and recorded as such.
pub fn suspend_if_asked() -> Option<i32> {
    let sig = job_stop()?;
    let _ = CAUGHT.compare_exchange(sig, 0, Ordering::SeqCst, Ordering::SeqCst);
    set_action(sig, libc::SIG_DFL);
    // SAFETY: a sigset of one signal, unblocked on this thread before it is
    // raised on it (a blocked one would stay pending and stop nothing).
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        libc::sigaddset(&mut set, sig);
        libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
        libc::raise(sig);
    }
    set_action(sig, handler());
    Some(sig)
}

/// The exit code a caught signal asks for: 128 + its number (130 for
/// SIGINT, 143 for SIGTERM, 129 for SIGHUP, 131 for SIGQUIT, 148 for
/// SIGTSTP, 149 for SIGTTIN, 150 for SIGTTOU).
pub fn exit_code(sig: i32) -> u8 {
    (128 + sig).clamp(0, 255) as u8
}

/// A signal's name for messages.
pub fn signal_name(sig: i32) -> &'static str {
    match sig {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        libc::SIGHUP => "SIGHUP",
        libc::SIGQUIT => "SIGQUIT",
        libc::SIGUSR1 => "SIGUSR1",
        libc::SIGUSR2 => "SIGUSR2",
        libc::SIGALRM => "SIGALRM",
        libc::SIGVTALRM => "SIGVTALRM",
        libc::SIGPROF => "SIGPROF",
        libc::SIGIO => "SIGIO",
        libc::SIGPWR => "SIGPWR",
        libc::SIGTSTP => "SIGTSTP",
        libc::SIGTTIN => "SIGTTIN",
        libc::SIGTTOU => "SIGTTOU",
        _ => "a signal",
    }
}

/// Records that progress or a result could not be written (a closed pipe,
/// a full disk): a supervised wait then halts instead of going on blind.
pub fn note_output_failure(err: &std::io::Error) {
    if !OUTPUT_FAILED.swap(true, Ordering::SeqCst) {
        *OUTPUT_ERROR.lock().unwrap_or_else(|e| e.into_inner()) = Some(err.to_string());
    }
}

/// Records that the traffic log (`--log`) could not be written. The traffic
/// goes on (a halt must never wait for the log); a supervised wait halts as
/// on any output failure, and the binary reports [`log_failure`] at the end.
pub fn note_log_failure(err: &std::io::Error) {
    let mut log = LOG_ERROR.lock().unwrap_or_else(|e| e.into_inner());
    if log.is_none() {
        *log = Some(err.to_string());
        drop(log);
        note_output_failure(&std::io::Error::new(err.kind(), format!("--log: {err}")));
    }
}

/// The first failed write of the traffic log, if any.
pub fn log_failure() -> Option<String> {
    LOG_ERROR.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// The first output failure recorded, if any.
pub fn output_failure() -> Option<String> {
    if OUTPUT_FAILED.load(Ordering::SeqCst) {
        OUTPUT_ERROR.lock().unwrap_or_else(|e| e.into_inner()).clone()
    } else {
        None
    }
}

/// Records that a thread panicked (`what`: the thread and the message):
/// whatever that thread was doing, nobody can vouch for the motion any
/// more, so a supervised wait (or the dashboard) halts what it moved. Called
/// from the panic hook, so it must not panic nor block: the text is kept
/// only if its lock is free at once.
pub fn note_panic(what: &str) {
    if !PANICKED.swap(true, Ordering::SeqCst) {
        if let Ok(mut text) = PANIC_TEXT.try_lock() {
            *text = Some(what.to_string());
        }
    }
    wake();
}

/// The first panic recorded, if any ("a panic" when its text was lost).
pub fn panic_failure() -> Option<String> {
    if PANICKED.load(Ordering::SeqCst) {
        let text = PANIC_TEXT.lock().unwrap_or_else(|e| e.into_inner()).clone();
        Some(text.unwrap_or_else(|| "a panic".into()))
    } else {
        None
    }
}

/// Why a supervised wait was told to stop, for the message after the halt.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StopReason {
    /// A caught signal (its number).
    Signal(i32),
    /// A thread panicked.
    Panic(String),
    /// An output (or `--log`) write failed.
    Output(String),
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Signal(sig) => f.write_str(signal_name(*sig)),
            Self::Panic(what) => write!(f, "a thread panicked ({what})"),
            Self::Output(io) => write!(f, "output failed ({io})"),
        }
    }
}

/// The reason [`stop_requested`] holds: a signal first (it sets the exit
/// code), then a panic, then a failed output.
pub fn stop_reason() -> Option<StopReason> {
    caught()
        .map(StopReason::Signal)
        .or_else(|| panic_failure().map(StopReason::Panic))
        .or_else(|| output_failure().map(StopReason::Output))
}

/// Whether a supervised wait must halt now: a signal was caught, a thread
/// panicked, or the output failed.
pub fn stop_requested() -> bool {
    caught().is_some() || PANICKED.load(Ordering::SeqCst) || OUTPUT_FAILED.load(Ordering::SeqCst)
}

/// Sleeps for `d` or until a signal arrives (or the output failed),
/// whichever comes first. Before [`arm`] it is a plain sleep.
pub fn sleep(d: Duration) {
    let fd = WAKE_READ.load(Ordering::SeqCst);
    if fd < 0 {
        std::thread::sleep(d);
        return;
    }
    let deadline = std::time::Instant::now() + d;
    loop {
        if stop_requested() {
            return;
        }
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        if left.is_zero() {
            return;
        }
        // ppoll, not poll: a pause shorter than a millisecond (the paced
        // samples of a recording) must not last one.
        let timeout = libc::timespec {
            tv_sec: left.as_secs().min(i32::MAX as u64) as libc::time_t,
            tv_nsec: left.subsec_nanos().into(),
        };
        let mut pfd = libc::pollfd { fd, events: libc::POLLIN, revents: 0 };
        // SAFETY: one valid pollfd, a valid timespec, no signal mask.
        unsafe {
            libc::ppoll(&mut pfd, 1, &timeout, std::ptr::null());
        }
        // Drain the wake bytes; `caught` keeps the signal itself.
        let mut buf = [0u8; 16];
        // SAFETY: reading into a local buffer from our non-blocking pipe.
        while unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) } > 0 {}
    }
}

#[cfg(test)]
mod tests {
    //! The state here is process-wide (signal handlers, flags that never
    //! reset), so each scenario runs in a child process of this test binary:
    //! the test starts itself again with [`CHILD`] naming it.
    use super::*;
    use std::process::{Command, Stdio};
    use std::time::Instant;

    const CHILD: &str = "AXISCTL_STOP_TEST_CHILD";

    /// True in the child (run the scenario); in the parent, runs the test
    /// `name` in a child, fails if it fails or outlives 20 s, and returns false.
    fn in_child(name: &str) -> bool {
        if std::env::var(CHILD).as_deref() == Ok(name) {
            return true;
        }
        let mut child = Command::new(std::env::current_exe().unwrap())
            .args(["--exact", &format!("clock::stop::tests::{name}"), "--nocapture"])
            .env(CHILD, name)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let deadline = Instant::now() + Duration::from_secs(20);
        while child.try_wait().unwrap().is_none() {
            if Instant::now() > deadline {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{name}: the child hung");
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let out = child.wait_with_output().unwrap();
        let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        assert!(out.status.success(), "{name}: {:?}\n{text}", out.status);
        assert!(text.contains("1 passed"), "{name} did not run in the child:\n{text}");
        false
    }

    fn took(f: impl FnOnce()) -> Duration {
        let t0 = Instant::now();
        f();
        t0.elapsed()
    }

    /// A thread that only receives signals, so the sleeping thread is woken
    /// by the pipe alone, not by an interrupted poll(2).
    fn signal_catcher() -> libc::pthread_t {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            // SAFETY: pthread_self has no preconditions.
            tx.send(unsafe { libc::pthread_self() }).unwrap();
            loop {
                std::thread::park();
            }
        });
        rx.recv().unwrap()
    }

    fn send(thread: libc::pthread_t, sig: i32) {
        // SAFETY: the thread lives for the whole process.
        assert_eq!(unsafe { libc::pthread_kill(thread, sig) }, 0);
    }

    #[test]
    fn signal_names_for_messages() {
        assert_eq!(signal_name(libc::SIGINT), "SIGINT");
        assert_eq!(signal_name(libc::SIGTERM), "SIGTERM");
        assert_eq!(signal_name(libc::SIGHUP), "SIGHUP");
        assert_eq!(signal_name(libc::SIGQUIT), "SIGQUIT");
        assert_eq!(signal_name(libc::SIGTSTP), "SIGTSTP");
        assert_eq!(signal_name(libc::SIGTTIN), "SIGTTIN");
        assert_eq!(signal_name(libc::SIGTTOU), "SIGTTOU");
        assert_eq!(signal_name(libc::SIGUSR1), "SIGUSR1");
        assert_eq!(signal_name(libc::SIGUSR2), "SIGUSR2");
        assert_eq!(signal_name(libc::SIGALRM), "SIGALRM");
        assert_eq!(signal_name(libc::SIGVTALRM), "SIGVTALRM");
        assert_eq!(signal_name(libc::SIGPROF), "SIGPROF");
        assert_eq!(signal_name(libc::SIGIO), "SIGIO");
        assert_eq!(signal_name(libc::SIGPWR), "SIGPWR");
        assert_eq!(signal_name(libc::SIGSEGV), "a signal");
    }

    // Armed, a signal no longer ends the process: it is recorded (the first
    // one wins), it cuts a 30 s sleep short, and every later sleep returns at once.
    #[test]
    fn an_armed_signal_is_recorded_and_wakes_the_sleep() {
        if !in_child("an_armed_signal_is_recorded_and_wakes_the_sleep") {
            return;
        }
        assert_eq!(caught(), None);
        assert!(!stop_requested());
        let d = took(|| sleep(Duration::from_millis(100)));
        assert!(d >= Duration::from_millis(100), "before arm: a plain sleep ({d:?})");
        arm().unwrap();
        arm().unwrap();
        let d = took(|| sleep(Duration::from_millis(100)));
        assert!(d >= Duration::from_millis(100) && d < Duration::from_secs(5), "armed, no signal: {d:?}");
        assert!(!stop_requested());
        let catcher = signal_catcher();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            send(catcher, libc::SIGTERM);
        });
        let d = took(|| sleep(Duration::from_secs(30)));
        assert!(d < Duration::from_secs(10), "the signal woke the sleep: {d:?}");
        assert_eq!(caught(), Some(libc::SIGTERM));
        assert!(stop_requested());
        send(catcher, libc::SIGINT);
        assert_eq!(caught(), Some(libc::SIGTERM), "the first signal is kept");
        assert!(took(|| sleep(Duration::from_secs(30))) < Duration::from_secs(10));
        assert_eq!(output_failure(), None);
    }

    // A failed output write asks a supervised wait to stop, and keeps its
    // first error; before arm a sleep stays a plain sleep.
    #[test]
    fn an_output_failure_stops_the_wait_and_keeps_the_first_error() {
        if !in_child("an_output_failure_stops_the_wait_and_keeps_the_first_error") {
            return;
        }
        assert_eq!(output_failure(), None);
        note_output_failure(&std::io::Error::other("broken pipe"));
        assert_eq!(output_failure().as_deref(), Some("broken pipe"));
        note_output_failure(&std::io::Error::other("later"));
        assert_eq!(output_failure().as_deref(), Some("broken pipe"), "the first error is kept");
        assert_eq!(caught(), None);
        assert!(stop_requested(), "an output failure alone asks for the stop");
        assert_eq!(log_failure(), None);
        let d = took(|| sleep(Duration::from_millis(100)));
        assert!(d >= Duration::from_millis(100), "before arm: a plain sleep ({d:?})");
        arm().unwrap();
        assert!(took(|| sleep(Duration::from_secs(30))) < Duration::from_secs(10));
    }

    // A failed --log write is kept for the final report and stops the wait
    // as an output failure that names the log.
    #[test]
    fn a_log_failure_is_kept_and_stops_the_wait() {
        if !in_child("a_log_failure_is_kept_and_stops_the_wait") {
            return;
        }
        assert_eq!(log_failure(), None);
        note_log_failure(&std::io::Error::other("no space left"));
        assert_eq!(log_failure().as_deref(), Some("no space left"));
        assert_eq!(output_failure().as_deref(), Some("--log: no space left"));
        assert!(stop_requested());
        note_log_failure(&std::io::Error::other("later"));
        assert_eq!(log_failure().as_deref(), Some("no space left"), "the first error is kept");
    }

    fn mask_of_this_thread() -> libc::sigset_t {
        // SAFETY: a query: the current mask is written into `old`.
        unsafe {
            let mut old: libc::sigset_t = std::mem::zeroed();
            assert_eq!(libc::pthread_sigmask(libc::SIG_BLOCK, std::ptr::null(), &mut old), 0);
            old
        }
    }

    fn action_of(sig: i32) -> libc::sighandler_t {
        // SAFETY: a query: the current action is written into `old`.
        unsafe {
            let mut old: libc::sigaction = std::mem::zeroed();
            assert_eq!(libc::sigaction(sig, std::ptr::null(), &mut old), 0);
            old.sa_sigaction
        }
    }

    // A mask inherited blocked is lifted on the arming thread (else Ctrl-C
    // and SIGTERM would stay pending while the motion runs on); SIGXFSZ is
    // ignored, so a write past the file size limit fails instead of killing
    // the process; a job-control stop is recorded and wakes the sleep
    // instead of stopping the process, and SIGTTOU is ignored from then on
    // (the terminal write that raised it is restarted and would raise it again).
    #[test]
    fn arm_unblocks_the_signals_ignores_sigxfsz_and_records_a_job_stop() {
        if !in_child("arm_unblocks_the_signals_ignores_sigxfsz_and_records_a_job_stop") {
            return;
        }
        let all: Vec<i32> = SIGNALS.into_iter().chain(JOB_STOPS).chain([libc::SIGXFSZ]).collect();
        // SAFETY: a local set handed to pthread_sigmask for this thread.
        unsafe {
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            for &sig in &all {
                libc::sigaddset(&mut set, sig);
            }
            assert_eq!(libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()), 0);
        }
        assert_eq!(action_of(libc::SIGXFSZ), libc::SIG_DFL);
        arm().unwrap();
        let mask = mask_of_this_thread();
        for &sig in &all {
            // SAFETY: a membership query on a filled set.
            assert_eq!(unsafe { libc::sigismember(&mask, sig) }, 0, "signal {sig} still blocked");
        }
        assert_eq!(action_of(libc::SIGXFSZ), libc::SIG_IGN);
        assert_eq!(job_stop(), None);
        let catcher = signal_catcher();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            send(catcher, libc::SIGTTOU);
        });
        let d = took(|| sleep(Duration::from_secs(30)));
        assert!(d < Duration::from_secs(10), "the job-control stop woke the sleep: {d:?}");
        assert_eq!((caught(), job_stop()), (Some(libc::SIGTTOU), Some(libc::SIGTTOU)));
        assert!(stop_requested());
        assert_eq!(action_of(libc::SIGTTOU), libc::SIG_IGN, "a second SIGTTOU is not raised for ever");
        // Raised on this thread, whose mask arm unblocked, each is handled
        // before raise returns (the first signal stays the one recorded).
        for sig in [libc::SIGTTIN, libc::SIGTSTP, libc::SIGINT] {
            // SAFETY: raise on this thread.
            assert_eq!(unsafe { libc::raise(sig) }, 0);
        }
        assert_eq!(action_of(libc::SIGTTIN), libc::SIG_IGN, "nor a second SIGTTIN");
        assert_eq!(action_of(libc::SIGTSTP), handler(), "SIGTSTP keeps its handler");
        assert_eq!(action_of(libc::SIGINT), handler(), "SIGINT keeps its handler");
        assert_eq!(caught(), Some(libc::SIGTTOU));
    }

    // Only a job-control stop is one: SIGINT is not.
    #[test]
    fn an_ending_signal_is_no_job_stop() {
        if !in_child("an_ending_signal_is_no_job_stop") {
            return;
        }
        arm().unwrap();
        // SAFETY: raise on this thread, whose mask arm just unblocked.
        assert_eq!(unsafe { libc::raise(libc::SIGINT) }, 0);
        assert_eq!((caught(), job_stop()), (Some(libc::SIGINT), None));
        assert_eq!(suspend_if_asked(), None, "nothing to stop for");
        assert_eq!(caught(), Some(libc::SIGINT), "and the signal is kept");
    }

    // A process started with stdin closed gets fd 0 for the wake pipe's read
    // end; that is a real descriptor, so a signal must still cut the sleep short.
    #[test]
    fn a_wake_pipe_on_fd_0_still_wakes_the_sleep() {
        if !in_child("a_wake_pipe_on_fd_0_still_wakes_the_sleep") {
            return;
        }
        // SAFETY: nothing in this child reads stdin.
        assert_eq!(unsafe { libc::close(0) }, 0);
        arm().unwrap();
        assert_eq!(WAKE_READ.load(Ordering::SeqCst), 0, "pipe2 took the lowest free descriptor");
        let catcher = signal_catcher();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            send(catcher, libc::SIGTERM);
        });
        let d = took(|| sleep(Duration::from_secs(15)));
        assert!(d < Duration::from_secs(10), "the signal woke the sleep: {d:?}");
        assert_eq!(caught(), Some(libc::SIGTERM));
    }
}
