//! For build scripts (`[build-dependencies]`): records the git revision a
//! package was built from, so that reports can name it. One helper for every
//! crate that needs it (the CLI, the Python package).

use std::process::Command;

/// The short git revision of the checkout (`-dirty` when tracked files have
/// uncommitted changes), or `"unknown"` outside a git checkout.
pub fn git_revision() -> String {
    let rev = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| "unknown".to_string());
    // Mark a build from a work tree with uncommitted changes. Without the
    // optional locks, `git status` does not write the refreshed index back:
    // a fresh clone's first status would, and the newer .git/index would
    // then rerun this script (and rebuild its crate) on the next build.
    let dirty = Command::new("git")
        .args([
            "--no-optional-locks",
            "status",
            "--porcelain",
            "--untracked-files=no",
        ])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .is_some_and(|o| !o.stdout.is_empty());
    if dirty && rev != "unknown" {
        format!("{rev}-dirty")
    } else {
        rev
    }
}

/// Called from a build script of a crate two folders below the workspace
/// root (`crates/<name>`): sets the compile-time variable `ABBA_GIT_REV`
/// (read with `env!("ABBA_GIT_REV")`) and asks Cargo to run the script again
/// when the checkout's HEAD, refs or index change.
pub fn emit_git_revision() {
    println!("cargo:rustc-env=ABBA_GIT_REV={}", git_revision());
    println!("cargo:rerun-if-changed=../../.git/HEAD");
    println!("cargo:rerun-if-changed=../../.git/refs");
    println!("cargo:rerun-if-changed=../../.git/index");
}
