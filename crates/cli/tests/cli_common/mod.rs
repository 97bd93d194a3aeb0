//! What the CLI tests share: running the `abba` binary and checking that it
//! succeeded.
#![allow(dead_code)]

use std::process::{Command, Output};

/// Runs `abba` with `args` (no backtrace variables, so that the error text
/// is what a user sees).
pub fn abba(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .expect("run abba")
}

/// The standard output of a run that must have succeeded (a failure shows
/// its standard error).
pub fn ok(out: &Output) -> String {
    assert!(
        out.status.success(),
        "abba failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).expect("abba's output is UTF-8")
}

/// A new CGM-mode person `name` in `tz` in the store `db`, with a basal
/// rate of `basal` U/h and the carb ratios `carb_ratio` (g/U, three meals
/// as `abba person new` takes them); fails the test when refused.
pub fn new_cgm_person(db: &str, name: &str, tz: &str, basal: &str, carb_ratio: &str) {
    ok(&abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        name,
        "--tz",
        tz,
        "--mode",
        "cgm",
        "--basal",
        basal,
        "--carb-ratio",
        carb_ratio,
    ]));
}

/// A path `name` in a fresh temporary directory; the directory and all in
/// it are removed when the value is dropped (the tests left tens of MB of
/// reports in the temporary directory at every run).
pub struct TmpPath {
    path: std::path::PathBuf,
    _dir: tempfile::TempDir,
}

impl std::ops::Deref for TmpPath {
    type Target = std::path::Path;
    fn deref(&self) -> &std::path::Path {
        &self.path
    }
}

impl AsRef<std::path::Path> for TmpPath {
    fn as_ref(&self) -> &std::path::Path {
        &self.path
    }
}

impl AsRef<std::ffi::OsStr> for TmpPath {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.path.as_os_str()
    }
}

/// `name` in a new temporary directory whose name starts with `prefix`.
pub fn tmp_path(prefix: &str, name: &str) -> TmpPath {
    let dir = tempfile::Builder::new()
        .prefix(prefix)
        .tempdir()
        .expect("a temporary directory");
    TmpPath {
        path: dir.path().join(name),
        _dir: dir,
    }
}
