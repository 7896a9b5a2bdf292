//! The report's directory. A run owns the files it writes there and
//! nothing else: a rerun into the same `--out` removes the files the
//! earlier run's report names (its reports, plan, backup, recordings), so
//! no recording of a device that is no longer planned survives beside the
//! new report, and leaves anything else as it is, said on stderr. A
//! directory that holds files but no commissioning report is someone
//! else's: refused before anything is sent.

use std::path::{Path, PathBuf};

use axisctl::commission::report::SCHEMA;
use axisctl::commission::BACKUP_FILE;

/// The files every run writes, whatever its plan.
pub const FIXED: [&str; 4] = ["report.json", "report.md", "report.html", "plan.toml"];

/// What a rerun finds in `--out`.
#[derive(Debug, Default)]
pub struct Earlier {
    /// The earlier run's files, removed before the new report is written.
    pub owned: Vec<PathBuf>,
    /// Files that are no run's: kept.
    pub foreign: Vec<String>,
}

/// Checks `--out` before anything is sent: missing or empty is fine; a
/// directory with an earlier report is taken over; anything else is an
/// error (the message, for a usage error).
pub fn inspect(out: &Path) -> Result<Earlier, String> {
    let entries = match std::fs::read_dir(out) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Earlier::default()),
        Err(e) => return Err(format!("--out {}: {e}", out.display())),
    };
    let mut names = Vec::new();
    for e in entries {
        let e = e.map_err(|e| format!("--out {}: {e}", out.display()))?;
        names.push(e.file_name().to_string_lossy().into_owned());
    }
    names.sort();
    if names.is_empty() {
        return Ok(Earlier::default());
    }
    let Some(listed) = earlier_report_files(&out.join("report.json")) else {
        let shown: Vec<&str> = names.iter().take(3).map(String::as_str).collect();
        return Err(format!(
            "--out {} holds files that are no commissioning report's ({}{}): give a new or empty directory, or \
             the directory of an earlier run to replace its report; nothing was sent",
            out.display(),
            shown.join(", "),
            if names.len() > shown.len() { ", ..." } else { "" }
        ));
    };
    let mut earlier = Earlier::default();
    for name in names {
        let path = out.join(&name);
        if listed.contains(&name) && path.is_file() {
            earlier.owned.push(path);
        } else {
            earlier.foreign.push(name);
        }
    }
    Ok(earlier)
}

/// The file names an earlier report says its run wrote; `None` when
/// `path` is no readable commissioning report.
fn earlier_report_files(path: &Path) -> Option<Vec<String>> {
    let text = std::fs::read_to_string(path).ok()?;
    let doc: serde_json::Value = serde_json::from_str(&text).ok()?;
    if doc["schema"] != SCHEMA {
        return None;
    }
    let mut files: Vec<String> = FIXED.iter().chain([&BACKUP_FILE]).map(|s| s.to_string()).collect();
    for c in doc["checks"].as_array()? {
        for key in ["recording", "file"] {
            // Plain names only: a report is a file anyone may have edited,
            // and removing follows it no further than the directory itself.
            if let Some(name) = c[key].as_str().filter(|n| plain_name(n)) {
                files.push(name.to_string());
            }
        }
    }
    Some(files)
}

fn plain_name(name: &str) -> bool {
    !name.is_empty() && name != "." && name != ".." && !name.contains(['/', '\\'])
}

/// Removes the earlier run's files; a file already gone is no error.
pub fn clear(earlier: &Earlier) -> Result<(), String> {
    for p in &earlier.owned {
        match std::fs::remove_file(p) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(format!("removing the earlier run's {}: {e}", p.display())),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_plain_names_are_removed() {
        for bad in ["", ".", "..", "../x.csv", "/etc/passwd", "a\\b"] {
            assert!(!plain_name(bad), "{bad}");
        }
        assert!(plain_name("powercube-3-move_forward.csv"));
    }

    #[test]
    fn a_directory_is_new_empty_an_earlier_runs_or_refused() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("r");
        assert!(inspect(&out).unwrap().owned.is_empty(), "missing: fine");
        std::fs::create_dir(&out).unwrap();
        assert!(inspect(&out).unwrap().owned.is_empty(), "empty: fine");
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        let err = inspect(&out).unwrap_err();
        assert!(err.contains("notes.txt") && err.contains("nothing was sent"), "{err}");
        let report = serde_json::json!({"schema": SCHEMA, "checks": [
            {"recording": "a.csv"}, {"file": "backup.json"}, {"recording": "../outside.csv"}
        ]});
        std::fs::write(out.join("report.json"), report.to_string()).unwrap();
        for f in ["a.csv", "report.md", "backup.json"] {
            std::fs::write(out.join(f), "").unwrap();
        }
        let e = inspect(&out).unwrap();
        let owned: Vec<String> =
            e.owned.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(owned, ["a.csv", "backup.json", "report.json", "report.md"]);
        assert_eq!(e.foreign, ["notes.txt"]);
        clear(&e).unwrap();
        let left: Vec<String> =
            std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        assert_eq!(left, ["notes.txt"]);
        // Another tool's report.json is no commissioning report.
        std::fs::write(out.join("report.json"), "{\"schema\": \"other/1\", \"checks\": []}").unwrap();
        assert!(inspect(&out).is_err());
    }
}
