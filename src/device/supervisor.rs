//! The motion supervisor: what stands between a commanded motion and a
//! process that ends without stopping it.
//!
//! It is armed before the first motion byte leaves. From then on SIGINT,
//! SIGTERM, SIGHUP and SIGQUIT no longer end the process: the handler only
//! records the signal and wakes the wait ([`sleep`] sleeps on a pipe the
//! handler writes to, so a signal cuts any poll interval short). The wait
//! sees [`stop_requested`], halts the device and returns; the binary then
//! exits with 128 + the signal's number. A failed output write is recorded
//! the same way ([`note_output_failure`]): a wait whose progress cannot be
//! shown halts rather than panics. [`guard`] halts on a panic.
//!
//! Before it is armed the signals keep their default action: nothing moves
//! on our behalf yet. A one-shot motion without a wait is never armed for:
//! once it is acknowledged the process ends and the axis moves on,
//! unsupervised.

use std::panic::{self, AssertUnwindSafe};

pub use crate::clock::stop::{
    arm, caught, exit_code, log_failure, note_log_failure, note_output_failure, output_failure, signal_name, sleep,
    stop_requested, ArmError, SIGNALS,
};

/// Runs `body` on the device and halts it with `halt` if `body` panics,
/// then lets the panic go on: a bug in a wait never leaves an axis moving.
pub fn guard<D, R>(dev: &mut D, body: impl FnOnce(&mut D) -> R, halt: impl FnOnce(&mut D)) -> R {
    match panic::catch_unwind(AssertUnwindSafe(|| body(&mut *dev))) {
        Ok(r) => r,
        Err(payload) => {
            let _ = panic::catch_unwind(AssertUnwindSafe(|| halt(dev)));
            panic::resume_unwind(payload)
        }
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
    }

    #[test]
    fn a_panic_in_the_body_halts_then_goes_on() {
        let mut halted = false;
        let r = panic::catch_unwind(AssertUnwindSafe(|| {
            guard(&mut halted, |_| panic!("bug in a wait"), |h| *h = true);
        }));
        assert!(r.is_err(), "the panic goes on after the halt");
        assert!(halted, "the device was halted");
        let mut halted = false;
        assert_eq!(guard(&mut halted, |_| 7, |h| *h = true), 7);
        assert!(!halted, "no halt without a panic");
    }
}
