//! The integration tests of `abba-advisor`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-advisor --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
mod common;

// One module per test file.
mod answers_bounds;
mod autotune_oref0;
mod deps;
mod determinism;
mod pump_kinds;
mod safety;
mod timeline;
