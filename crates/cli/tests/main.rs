//! The integration tests of `abba`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
/// Headless Chromium for the person report (abba-report's own helper).
#[path = "../../report/tests/common/browser.rs"]
mod browser;
mod cli_common;
/// The loopback Nightscout server (abba-nightscout's own test helper).
#[path = "../../nightscout/tests/common/mod.rs"]
mod common;
/// The CLI's reference app (`abba app`), compiled as a module here.
#[path = "../src/remote.rs"]
#[allow(dead_code)]
mod remote;
mod service_common;
mod store_common;
#[path = "../../io/tests/support/tidepool_workbook.rs"]
mod tidepool_workbook;
mod web_common;

// One module per test file.
mod app_cli;
mod app_e2e;
mod app_lost_acks;
mod architecture;
mod autotune_cli;
mod bad_input_cli;
mod cli_beside_service;
mod cohort_cli;
mod copies_cli;
mod events_cli;
mod metrics_cli;
mod metrics_formats;
mod nightscout_cli;
mod nightscout_round_trip;
mod person_names_cli;
mod pipes_cli;
mod readme;
mod replicas;
mod report_cli;
mod serve_cli;
mod serve_output;
mod simulate_cli;
mod store_cli;
mod store_copy_cli;
mod store_equivalence;
mod store_migration;
mod tidepool_cli;
mod trial_cli;
mod twin_effect_cli;
mod twin_refit_cli;
mod uploaders_cli;
mod vendor_quirks_cli;
mod web_browser;
