//! The version `--version` shows: the package version, and the git commit
//! when built from a checkout. Without git (a crate tarball, no git
//! installed) it is the package version alone; the build never fails on it.

use std::path::PathBuf;
use std::process::Command;

fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git").args(args).output().ok()?;
    let text = String::from_utf8(out.stdout).ok()?;
    (out.status.success() && !text.trim().is_empty()).then(|| text.trim().to_string())
}

fn main() {
    let version = std::env::var("CARGO_PKG_VERSION").unwrap_or_default();
    let commit = git(&["rev-parse", "--short=12", "HEAD"]);
    let shown = match &commit {
        Some(c) => format!("{version} (git {c})"),
        None => version,
    };
    println!("cargo:rustc-env=AXISCTL_VERSION={shown}");
    println!("cargo:rerun-if-changed=build.rs");
    // A new commit moves HEAD or the branch it points to: both are watched
    // (in a worktree HEAD lives in its own git dir, branches in the common one).
    // Only files that exist: cargo takes a missing one as changed, and would
    // build again at every invocation (a repository without packed-refs).
    if let (Some(dir), Some(common)) = (git(&["rev-parse", "--git-dir"]), git(&["rev-parse", "--git-common-dir"])) {
        let mut watched = vec![PathBuf::from(&dir).join("HEAD"), PathBuf::from(&common).join("packed-refs")];
        if let Some(branch) = git(&["symbolic-ref", "-q", "HEAD"]) {
            watched.push(PathBuf::from(&common).join(branch));
        }
        for path in watched.iter().filter(|p| p.exists()) {
            println!("cargo:rerun-if-changed={}", path.display());
        }
    }
}
