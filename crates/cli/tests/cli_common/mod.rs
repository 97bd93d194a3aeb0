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
