//! The integration tests of `abba-batch`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-batch --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// One module per test file.
mod company;
mod patient_batch;
