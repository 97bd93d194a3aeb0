//! The integration tests of `abba-service`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-service --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
mod common;

// One module per test file.
mod access;
mod advice_parity;
mod connections;
mod effects;
mod heads;
mod hostile;
mod implausible;
mod limits;
mod live_advisor;
mod mixed_load;
mod openapi;
mod pages;
mod person_input;
mod probe;
mod refit;
mod seq;
mod web_parity;
