//! The exit codes of `cli-contract.md`, declared once: `main` exits with
//! them and `--help` lists them from here.

use axisctl::device::supervisor;
use axisctl::session::ErrorKind;

/// Each failure class, its exit code and how `--help` says it.
const CODES: &[(ErrorKind, u8, &str)] = &[
    (ErrorKind::Other, 1, "other failure"),
    (ErrorKind::Usage, 2, "usage / out of range (nothing sent)"),
    (ErrorKind::Link, 3, "link"),
    (ErrorKind::Timeout, 4, "timeout"),
    (ErrorKind::Device, 5, "device fault or refusal"),
    (ErrorKind::Malformed, 6, "malformed answer"),
    (ErrorKind::WaitTimeout, 7, "wait timed out (device stopped)"),
    (ErrorKind::Interrupted, 130, "interrupted"),
];

pub const SUCCESS: u8 = 0;

pub fn code(kind: ErrorKind) -> u8 {
    CODES.iter().find(|(k, _, _)| *k == kind).map_or(1, |(_, c, _)| *c)
}

/// Classifies a failure once for `main` and for each `batch` line: the
/// error to report (possibly reworded), its kind and its exit code.
pub fn classify_failure(e: anyhow::Error) -> (anyhow::Error, ErrorKind, u8) {
    // An interruption that no signal caused came from a failed output or a
    // panic (also one before the motion frame left, so nothing was sent):
    // said and exited as such, 1, not 130.
    let e = match (super::classify(&e), supervisor::caught()) {
        (ErrorKind::Interrupted, None) => super::stopped_by_output(e),
        _ => e,
    };
    let kind = super::classify(&e);
    // A supervised motion that a signal ended exits like the signal would
    // have (130 SIGINT, 143 SIGTERM, 129 SIGHUP, 131 SIGQUIT).
    let code = match (kind, supervisor::caught()) {
        (ErrorKind::Interrupted, Some(sig)) => supervisor::exit_code(sig),
        _ => code(kind),
    };
    (e, kind, code)
}

/// `Exit codes: 0 ok, 1 other failure, ...` for `--help`.
pub fn summary() -> String {
    let mut s = format!("Exit codes: {SUCCESS} ok");
    for (_, c, text) in CODES {
        s.push_str(&format!(", {c} {text}"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_its_own_code() {
        let kinds = [
            ErrorKind::Other,
            ErrorKind::Usage,
            ErrorKind::Link,
            ErrorKind::Timeout,
            ErrorKind::Device,
            ErrorKind::Malformed,
            ErrorKind::WaitTimeout,
            ErrorKind::Interrupted,
        ];
        let mut codes: Vec<_> = kinds.iter().map(|k| code(*k)).collect();
        assert_eq!(codes, [1, 2, 3, 4, 5, 6, 7, 130]);
        codes.dedup();
        assert_eq!(codes.len(), kinds.len());
        assert_eq!(
            summary(),
            "Exit codes: 0 ok, 1 other failure, 2 usage / out of range (nothing sent), 3 link, 4 timeout, \
             5 device fault or refusal, 6 malformed answer, \
             7 wait timed out (device stopped), 130 interrupted"
        );
    }
}
