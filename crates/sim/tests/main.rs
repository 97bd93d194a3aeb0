//! The integration tests of `abba-sim`, in one test binary: each
//! `tests/<name>.rs` beside this file is a module of it (one build and
//! one link for the crate instead of one per file). Run one file's tests
//! with `cargo test --release -p abba-sim --test integration <name>::`.
//! A new test file is declared below (the architecture test fails on
//! one that is not).
#![allow(clippy::unwrap_used, clippy::expect_used)]

// One module per test file.
mod cohort_derivation;
mod cohort_generation;
mod devices_cgm;
mod devices_meter;
mod devices_pump;
mod minute_state;
mod patient_properties;
mod patient_reference;
mod person;
mod scenario_generator;
mod scenario_properties;
mod sensitivity_drift;
