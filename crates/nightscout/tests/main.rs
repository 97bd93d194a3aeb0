//! The integration tests of `abba-nightscout`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-nightscout --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
mod common;

// One module per test file.
mod background;
mod by_id;
mod copies;
mod dst;
mod loop_modes;
mod quirks;
mod real_shapes;
mod sync;
mod write_back;
