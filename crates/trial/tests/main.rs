//! The integration tests of `abba-trial`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-trial --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
#[path = "../../report/tests/common/browser.rs"]
mod browser;

// One module per test file.
mod closed_loop_behaviour;
mod report_html;
mod scenario_knobs;
mod shard_merge;
mod simulated_answers;
mod trial_config;
mod trial_determinism;
mod twin_arm;
