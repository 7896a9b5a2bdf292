//! The exit codes of `cli-contract.md`, declared once: `main` exits with
//! them and `--help` lists them from here.

use axisctl::session::ErrorKind;

/// Each failure class, its exit code and how `--help` says it.
const CODES: &[(ErrorKind, u8, &str)] = &[
    (ErrorKind::Other, 1, "other failure"),
    (ErrorKind::Usage, 2, "usage / out of range (nothing sent)"),
    (ErrorKind::Link, 3, "link"),
    (ErrorKind::Timeout, 4, "timeout"),
    (ErrorKind::Device, 5, "device fault or refusal"),
    (ErrorKind::Malformed, 6, "malformed answer"),
    (ErrorKind::Interrupted, 130, "interrupted"),
];

pub const SUCCESS: u8 = 0;

pub fn code(kind: ErrorKind) -> u8 {
    CODES.iter().find(|(k, _, _)| *k == kind).map_or(1, |(_, c, _)| *c)
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
            ErrorKind::Interrupted,
        ];
        let mut codes: Vec<_> = kinds.iter().map(|k| code(*k)).collect();
        assert_eq!(codes, [1, 2, 3, 4, 5, 6, 130]);
        codes.dedup();
        assert_eq!(codes.len(), kinds.len());
        assert_eq!(
            summary(),
            "Exit codes: 0 ok, 1 other failure, 2 usage / out of range (nothing sent), 3 link, 4 timeout, \
             5 device fault or refusal, 6 malformed answer, 130 interrupted"
        );
    }
}
