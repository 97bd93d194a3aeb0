//! The integration tests of `abba-store`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-store --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
mod common;
#[path = "../../io/tests/support/tidepool_workbook.rs"]
mod tidepool_workbook;

// One module per test file.
mod app_events;
mod backends;
mod before_day_1;
mod implausible;
mod import_log;
mod nightscout_670g;
mod person_age;
mod person_names;
mod person_path;
mod pump_ids;
mod reexports;
mod tidepool;
mod trips;
mod two_routes;
