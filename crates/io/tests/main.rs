//! The integration tests of `abba-io`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-io --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// Helpers of the test files, each compiled once.
mod common;
#[path = "support/tidepool_workbook.rs"]
mod tidepool_workbook;

// One module per test file.
mod aaps;
mod boundary;
mod carelink_clock;
mod carelink_layouts;
mod carelink_loop_dates;
mod careportal;
mod device_clocks;
mod dst;
mod events_mapping;
mod events_properties;
mod fixtures;
mod libreview_dates;
mod libreview_devices;
mod libreview_insulin;
mod loop_uploads;
mod never_panic;
mod nightscout_shapes;
mod nightscout_uploaders;
mod partial_files;
mod real_carelink;
mod real_exports;
mod real_variants;
mod tidepool_devices;
mod tidepool_model;
mod tidepool_xlsx;
