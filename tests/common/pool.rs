//! Running many example commands at once. Most of an example's time is a
//! simulated motion or a `--for` window, so a few at a time keep two cores
//! busy where one at a time leaves them idle.

use std::collections::BTreeSet;
use std::sync::{Condvar, Mutex};

/// How many examples run at once.
pub const WORKERS: usize = 4;

/// Calls `f` on every item, [`WORKERS`] at a time, starting each item only
/// after the items listed in `after[i]` have finished (whether `f` passed or
/// panicked on them). A panic in `f` is raised again once every item ran.
pub fn each_after<T: Sync>(items: &[T], after: &[Vec<usize>], f: impl Fn(&T) + Sync) {
    assert_eq!(items.len(), after.len());
    struct State {
        started: Vec<bool>,
        done: Vec<bool>,
    }
    let state = Mutex::new(State { started: vec![false; items.len()], done: vec![false; items.len()] });
    let finished = Condvar::new();
    let next = || -> Option<usize> {
        let mut s = state.lock().unwrap();
        loop {
            let ready = (0..items.len()).find(|&i| !s.started[i] && after[i].iter().all(|&d| s.done[d]));
            if let Some(i) = ready {
                s.started[i] = true;
                return Some(i);
            }
            if s.started.iter().all(|&b| b) {
                return None;
            }
            s = finished.wait(s).unwrap();
        }
    };
    let panics = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..WORKERS.min(items.len()) {
            scope.spawn(|| {
                while let Some(i) = next() {
                    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(&items[i])));
                    if let Err(p) = outcome {
                        panics.lock().unwrap().push(p);
                    }
                    state.lock().unwrap().done[i] = true;
                    finished.notify_all();
                }
            });
        }
    });
    if let Some(p) = panics.into_inner().unwrap().into_iter().next() {
        std::panic::resume_unwind(p);
    }
}

/// Calls `f` on every item, [`WORKERS`] at a time, in any order.
pub fn each<T: Sync>(items: &[T], f: impl Fn(&T) + Sync) {
    each_after(items, &vec![Vec::new(); items.len()], f);
}

/// The files a shell command line names: words with a file extension, and
/// what follows `--out`, `--plan`, `--log` or `>`.
pub fn files_named(line: &str) -> BTreeSet<String> {
    const EXTENSIONS: [&str; 10] = ["json", "jsonl", "csv", "toml", "txt", "log", "svg", "png", "md", "html"];
    let spaced = line.replace('>', " > ").replace('|', " | ");
    let words: Vec<&str> = spaced.split_whitespace().map(|w| w.trim_matches(['\'', '"'])).collect();
    let mut files = BTreeSet::new();
    for (i, w) in words.iter().enumerate() {
        let has_extension = w.rsplit_once('.').is_some_and(|(stem, ext)| !stem.is_empty() && EXTENSIONS.contains(&ext));
        let named = i > 0 && ["--out", "--plan", "--log", ">"].contains(&words[i - 1]) && *w != "-";
        if has_extension || named {
            files.insert(w.to_string());
        }
    }
    files
}

/// For each line, the earlier lines that name one of its files: a line
/// that reads `bench.json` waits for the one that wrote it, as it did when
/// the lines ran one by one in their order.
pub fn after_their_files(lines: &[String]) -> Vec<Vec<usize>> {
    let files: Vec<BTreeSet<String>> = lines.iter().map(|l| files_named(l)).collect();
    (0..lines.len()).map(|i| (0..i).filter(|&j| !files[i].is_disjoint(&files[j])).collect()).collect()
}

/// Runs each shell line with bash in `cwd`, the built `axisctl` first on
/// the PATH and the environment of [`crate::common::bin`], [`WORKERS`] at a
/// time (a line that names a file an earlier line wrote runs after it),
/// each under a deadline of `secs`. Returns the lines that failed, each
/// with its exit status and first line of stderr.
pub fn failing_lines(lines: &[String], cwd: &std::path::Path, secs: u64) -> Vec<String> {
    let bin_dir = std::path::Path::new(env!("CARGO_BIN_EXE_axisctl")).parent().unwrap().to_path_buf();
    let path = format!("{}:{}", bin_dir.display(), std::env::var("PATH").unwrap_or_default());
    let failed = Mutex::new(Vec::new());
    each_after(lines, &after_their_files(lines), |line| {
        let mut child = std::process::Command::new("bash")
            .args(["--norc", "--noprofile", "-c", line])
            .current_dir(cwd)
            .env("PATH", &path)
            .env_remove("AXISCTL_LINK")
            .env_remove("AXISCTL_BENCH")
            .env("NO_COLOR", "1")
            .env("AXISCTL_TIMEOUT", crate::common::TIMEOUT_MS)
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(secs);
        while child.try_wait().unwrap().is_none() {
            if std::time::Instant::now() > deadline {
                let _ = child.kill();
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
        let out = child.wait_with_output().unwrap();
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            failed.lock().unwrap().push(format!(
                "{line}: {:?} {}",
                out.status.code(),
                err.lines().next().unwrap_or("(ended by the deadline)")
            ));
        }
    });
    failed.into_inner().unwrap()
}
