//! abba-twin: a person's twin — the UVA/Padova 2008 model fitted to their
//! own CGM (or meter) readings, delivered insulin and logged carbohydrate,
//! checked on days it did not see, and replayed under other settings.
//!
//! abba is research software, not a medical device: a twin's predictions
//! are not medical advice.
//!
//! How a twin is made ([`Twin::fit`]):
//!
//! 1. [`tape`]: the last days of the log as the simulator's inputs, on the
//!    person's local clock — insulin as delivered (temporary basals,
//!    suspensions and extended boluses included: for closed-loop data the
//!    loop's delivery), carbohydrate entries, readings.
//! 2. [`prior`]: the typical patient of the person's population (the centre
//!    of the cohort generator's distribution) and the eight identified
//!    parameters with their priors, and why those eight.
//! 3. [`fit`]: maximum a posteriori by argmin's Nelder-Mead from four
//!    starts; unlogged meals found and estimated, days it cannot explain
//!    marked and left out; a Laplace approximation for bands.
//! 4. [`check`]: the last days (default 2 of 14) are never fitted; the twin
//!    predicts them from their recorded inputs; RMSE, MARD, time in range
//!    and below 70 predicted and observed; a grade with its rule.
//! 5. [`Twin::replay`]: the last days under another basal or other carb
//!    ratios, with the recorded meals, beside the recorded settings, with
//!    bands from the posterior draws; deterministic for a given twin.
//! 6. [`file`]: stored beside the store with its data range, data hash and
//!    revision; `abba twin fit` refits only when the log changed.
//!
//! The crate depends on abba-core and abba-sim; the store, the service and
//! the advisor never depend on it.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod check;
pub mod error;
pub mod file;
pub mod fit;
mod linalg;
pub mod prior;
pub mod sim;
pub mod tape;
pub mod twin;

pub use check::{Banded, Grade, HeldOut, Ranges, MIN_FIT_DAYS};
pub use error::TwinError;
pub use twin::{BasalChange, Replay, Twin, TwinOptions, WhatIf, NOTICE};
