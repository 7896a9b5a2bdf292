//! Files and standard input that commands read whole (backups, recordings),
//! read with a ceiling: `/dev/zero` or an endless pipe is refused once the
//! ceiling is passed, instead of growing the process until the system kills
//! it. Each ceiling is far above what the command ever writes itself.

use std::io::Read;
use std::path::Path;

use super::usage;

/// A backup (`restore`, `diff`): one of a full bench (31 modules, a
/// PA-CONTROL with its axes, a Cdios node) is about 300 KiB.
pub const BACKUP: u64 = 4 << 20;

/// A recording for `plot`: about 200 000 samples of JSON Lines.
pub const RECORDING: u64 = 32 << 20;

/// A commissioning plan or a bench file: a plan for 31 modules with every
/// check and inline settings is about 60 KiB.
pub const PLAN: u64 = 1 << 20;

/// One line of a batch: a command line is a few hundred bytes.
pub const BATCH_LINE: usize = 64 << 10;

/// `path` (`-` is standard input) read whole, as text: bad input (exit 2,
/// nothing sent) when it cannot be read, is not UTF-8 or is larger than
/// `limit` bytes, which is said with what the file was taken for.
pub fn read_text(path: &Path, limit: u64, what: &str) -> anyhow::Result<String> {
    let name = path.display().to_string();
    let cannot = |e: std::io::Error| usage(format!("cannot read {name}: {e}"));
    if name == "-" {
        bounded(std::io::stdin().lock(), limit, "standard input", what)
    } else {
        bounded(std::fs::File::open(path).map_err(cannot)?, limit, &name, what)
    }
}

/// At most `limit` bytes of `from`: one byte more is the refusal, so an
/// endless source costs `limit` bytes and no more time than reading them.
pub fn bounded(from: impl Read, limit: u64, name: &str, what: &str) -> anyhow::Result<String> {
    let mut bytes = Vec::new();
    from.take(limit + 1).read_to_end(&mut bytes).map_err(|e| usage(format!("cannot read {name}: {e}")))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(name, limit, what));
    }
    String::from_utf8(bytes).map_err(|e| usage(format!("{name} is not UTF-8 text ({e}); nothing was sent")))
}

pub fn too_large(name: &str, limit: u64, what: &str) -> anyhow::Error {
    usage(format!("{name} is larger than {}, the most {what} may be; nothing was sent", size(limit)))
}

/// A ceiling as people say it.
pub fn size(bytes: u64) -> String {
    if bytes >= 1 << 20 && bytes.is_multiple_of(1 << 20) {
        format!("{} MiB", bytes >> 20)
    } else if bytes >= 1 << 10 && bytes.is_multiple_of(1 << 10) {
        format!("{} KiB", bytes >> 10)
    } else {
        format!("{bytes} bytes")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_source_up_to_the_limit_is_read_and_one_byte_more_is_refused() {
        assert_eq!(bounded(&b"abcd"[..], 4, "f", "a test").unwrap(), "abcd");
        let e = bounded(&b"abcde"[..], 4, "f", "a test").unwrap_err();
        assert_eq!(e.to_string(), "f is larger than 4 bytes, the most a test may be; nothing was sent");
        assert_eq!(super::super::classify(&e), axisctl::session::ErrorKind::Usage);
    }

    #[test]
    fn an_endless_source_is_read_only_to_its_limit() {
        let e = bounded(std::io::repeat(b'['), 1 << 20, "-", "a backup").unwrap_err();
        assert!(e.to_string().contains("larger than 1 MiB"), "{e}");
    }

    #[test]
    fn sizes_are_said_in_the_largest_whole_unit() {
        assert_eq!(size(BACKUP), "4 MiB");
        assert_eq!(size(BATCH_LINE as u64), "64 KiB");
        assert_eq!(size(1000), "1000 bytes");
    }
}
