//! The motion supervisor: what stands between a commanded motion and a
//! process that ends without stopping it.
//!
//! It is armed before the first motion byte leaves. From then on SIGINT,
//! SIGTERM, SIGHUP, SIGQUIT and the other [`SIGNALS`] whose default would
//! end it no longer end the process, and SIGTSTP,
//! SIGTTIN and SIGTTOU no longer stop it: the handler only records the
//! signal and wakes the wait ([`sleep`] sleeps on a pipe the handler writes
//! to, so a signal cuts any poll interval short). The wait sees
//! [`stop_requested`], halts the device and returns; the binary then exits
//! with 128 + the signal's number, after a job-control stop once it has
//! stopped and been continued ([`suspend_if_asked`]: the motion is not
//! resumed). Arming also unblocks these signals on the arming thread (a
//! mask inherited blocked would make Ctrl-C do nothing), and ignores
//! SIGXFSZ, so a write past `ulimit -f` fails with EFBIG and halts like any
//! failed write instead of killing the process. A failed output write is recorded
//! the same way ([`note_output_failure`]): a wait whose progress cannot be
//! shown halts rather than panics. The device face's
//! [`Moving`](crate::device::face::Moving) handle halts on a panic of the
//! waiting thread itself; the panic hook ([`install_panic_hook`], set by the
//! binary at start) records a panic on any other thread the same way, so
//! the wait (or the dashboard) halts what it moved and says why.
//!
//! Before it is armed the signals keep their default action: nothing moves
//! on our behalf yet. A one-shot motion without a wait is never armed for:
//! once it is acknowledged the process ends and the axis moves on,
//! unsupervised.

use std::panic::{self, PanicHookInfo};
use std::sync::Once;

mod moved;

pub use super::registry::target::MotionTarget;
pub use moved::{HaltOutcome, MovedDevices, Reach, RunFace};

pub use crate::clock::stop::{
    arm, caught, exit_code, forget_signal, ignore_file_size_signal, job_stop, log_failure, note_log_failure,
    note_output_failure, note_panic, output_failure, panic_failure, signal_name, sleep, stop_reason, stop_requested,
    suspend_if_asked, ArmError, StopReason, JOB_STOPS, SIGNALS,
};

/// Chains a hook in front of the current panic hook (once per process) that
/// records every panic, on any thread, as a reason to stop
/// ([`note_panic`]), then lets the previous hook print it. A thread that
/// panics may have been the one that knew a device was moving; the
/// supervised wait or the dashboard that sees the record halts what it
/// moved. Needs `panic = "unwind"` (the default) for the
/// [`Moving`](crate::device::face::Moving) handle's drop to run at all.
pub fn install_panic_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            note_panic(&describe_panic(info));
            previous(info);
        }));
    });
}

/// `thread 'name' panicked at file:line: message`, short enough for the
/// one-line error that follows the halt.
pub fn describe_panic(info: &PanicHookInfo<'_>) -> String {
    let payload = info.payload();
    let msg = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "no message".into());
    let thread = std::thread::current();
    let name = thread.name().unwrap_or("unnamed");
    match info.location() {
        Some(at) => format!("thread '{name}' at {}:{}: {msg}", at.file(), at.line()),
        None => format!("thread '{name}': {msg}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_follow_the_shell_convention() {
        assert_eq!(exit_code(libc::SIGINT), 130);
        assert_eq!(exit_code(libc::SIGTERM), 143);
        assert_eq!(exit_code(libc::SIGHUP), 129);
        assert_eq!(exit_code(libc::SIGQUIT), 131);
        assert_eq!(exit_code(libc::SIGTSTP), 148);
        assert_eq!(exit_code(libc::SIGTTIN), 149);
        assert_eq!(exit_code(libc::SIGTTOU), 150);
    }

    #[test]
    fn stop_reasons_say_what_happened() {
        assert_eq!(StopReason::Signal(libc::SIGTERM).to_string(), "SIGTERM");
        assert_eq!(
            StopReason::Panic("thread 'x' at a.rs:1: boom".into()).to_string(),
            "a thread panicked (thread 'x' at a.rs:1: boom)"
        );
        assert_eq!(StopReason::Output("Broken pipe".into()).to_string(), "output failed (Broken pipe)");
    }

    /// The hook records a panic process-wide (a stop that never resets), so
    /// it runs in a child process of this test binary.
    #[test]
    fn a_panic_on_another_thread_is_recorded_with_its_thread_and_message() {
        const CHILD: &str = "AXISCTL_SUPERVISOR_TEST_CHILD";
        if std::env::var_os(CHILD).is_none() {
            let name = "device::supervisor::tests::a_panic_on_another_thread_is_recorded_with_its_thread_and_message";
            let out = std::process::Command::new(std::env::current_exe().unwrap())
                .args(["--exact", name, "--nocapture"])
                .env(CHILD, "1")
                .output()
                .unwrap();
            let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
            assert!(out.status.success() && text.contains("1 passed"), "{text}");
            return;
        }
        assert_eq!(panic_failure(), None);
        install_panic_hook();
        install_panic_hook(); // once per process: a second call chains nothing
        let line = line!() + 2;
        let worker = std::thread::Builder::new().name("worker".into());
        let r = worker.spawn(|| panic!("boom {}", 7)).unwrap().join();
        assert!(r.is_err());
        assert_eq!(panic_failure().as_deref(), Some(format!("thread 'worker' at {}:{line}: boom 7", file!()).as_str()));
        assert!(stop_requested(), "a panic anywhere is a reason to stop");
        // A literal message, on an unnamed thread (kept: the first panic counts).
        let r = std::thread::spawn(|| panic!("static")).join();
        assert!(r.is_err());
        assert!(panic_failure().unwrap().ends_with("boom 7"));
    }
}
