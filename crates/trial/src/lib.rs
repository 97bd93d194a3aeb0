//! The paper's in-silico trial: closed loop, runner, statistics and report.
//!
//! abba-trial reproduces the evaluation of ABBA (Sun et al., IEEE JBHI 2019;
//! `spec/protocol.md`): a cohort of virtual patients (abba-sim) lives 98
//! days in each of four scenarios (meals with varying size, time and carb
//! counting, a daily insulin sensitivity and a dawn effect; S1 with a CGM
//! throughout, S2-S4 with finger-stick SMBG after the first week, S3-S4 with
//! jittered measurement times, S4 with skipped meals), under each arm (ABBA,
//! fixed standard therapy, run-to-run), and the report compares the
//! evaluation weeks (W1, W13, W14) per arm: glucose metrics, summaries over
//! patients, paired Wilcoxon tests, Table I beside the paper's values, and
//! figures.
//!
//! ```
//! use abba_sim::scenario::ScenarioId;
//! use abba_trial::runner::{run_trial, Silent};
//! use abba_trial::protocol::RawTrialConfig;
//! use abba_trial::{ArmKind, TrialConfig};
//!
//! // A small trial: 2 patients, 9 days (the warm-up day, the standard
//! // therapy week, one more day), scenario S1, the fixed-therapy arm,
//! // checked in one step before anything runs.
//! let config = TrialConfig::try_from(RawTrialConfig {
//!     patients: 2,
//!     days: 9,
//!     scenarios: vec![ScenarioId::S1],
//!     arms: vec![ArmKind::Standard],
//!     ..RawTrialConfig::default()
//! })?;
//! let out = run_trial(&config, 1, &Silent)?;
//! assert_eq!(out.arms.len(), 1);
//! assert_eq!(out.arms[0].patients.len(), 2);
//! # Ok::<(), abba_trial::TrialError>(())
//! ```
//!
//! # Modules
//!
//! - [`protocol`]: [`protocol::RawTrialConfig`], every knob of the trial as
//!   written, and [`TrialConfig`], the plan checked from it.
//! - [`closed_loop`]: one patient in one scenario under one advisor, minute
//!   by minute: a simulated person (`abba_sim::person::VirtualPerson`) and
//!   the advisor exchanging events and settings.
//! - [`runner`]: the cohort, the TE calibration and every patient run,
//!   in parallel (rayon), reporting progress through [`runner::Progress`]
//!   (the library never prints).
//! - [`results`]: per-patient weekly metrics and the evaluation windows
//!   (abba-report's, re-exported).
//! - [`stats`]: summaries over patients and the Wilcoxon signed-rank test
//!   (no p-value below [`stats::MIN_PAIRS_FOR_P`] pairs; abba-report's,
//!   re-exported).
//! - [`report`]: the report folder and traced patients checked before the
//!   run, the manifest of what ran, and the report and traces written
//!   through abba-report (which builds every file from the results alone).
//!
//! # Contract
//!
//! - Determinism: the same configuration and seeds give the same bytes in
//!   every report file, serial or parallel.
//! - A configuration is checked in one step before any simulation starts
//!   (unknown fields refused at every level, every advisor validated);
//!   errors are a [`TrialError`] naming the field, patient, scenario or arm.
//! - A run whose plasma glucose falls below `failure_glucose_mg_dl` stops and
//!   is reported as stopped, not dropped.

pub mod calibrate;
pub mod closed_loop;
pub mod error;
pub mod protocol;
pub mod report;
pub mod runner;
pub mod shard;
pub mod twin_arm;
pub mod w1_sensitivity;

/// The results model and statistics live in abba-report; re-exported at
/// their old paths.
pub use abba_report::{results, stats};
pub use error::TrialError;
pub use protocol::{ArmKind, TrialConfig};
