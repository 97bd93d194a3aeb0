//! The trial's report (protocol §7-§8), computed only from the result types
//! of [`results`]. abba-report depends on abba-core and abba-advisor, never
//! on the simulator: the same report can be built from any source of
//! results.
//!
//! | file | built by |
//! |---|---|
//! | `summary.json`, `summary_notes.json` | [`summary::summary_json`] |
//! | `table1.md`, `table1.csv` | [`table1::table1_markdown`], [`table1::table1_csv`] (rows: [`table1::table1_rows`]) |
//! | `patients.csv` | [`patients_csv::patients_csv`] |
//! | `fig5_lbgi_hbgi.svg`, `fig6_mage.svg`, `fig7_tdi.svg`, `fig_arms.svg` | [`figures`] (data), drawn by [`chart`] |
//! | `report.html` | [`html::trial_page::trial_report_html`] (the person report: [`html::person`]) |
//! | `manifest.json` | the manifest passed in, with the run's facts ([`manifest`]) |
//! | `traces/*.csv`, `traces/*.decisions.jsonl` | [`trace`] |
//!
//! Every piece is a pure function of the arms (and the manifest), so it can
//! be tested in memory; [`files::build_report`] assembles all of them, and a
//! checked [`out_dir::ReportDir`] writes them. The output is byte-identical
//! for identical input: JSON objects have sorted keys (serde_json's default
//! map), lists follow the protocol's order, and numbers are printed with the
//! shortest representation that round-trips.
//!
//! Scenario, arm, mode, week and metric are types
//! ([`abba_core::ScenarioId`], [`ArmKind`], [`abba_advisor::Mode`],
//! [`Week`], [`abba_core::Metric`]), so a report cannot name a metric or
//! week that does not exist. The input is checked before anything is
//! computed (see [`select::validate_arms`]): inconsistent results are an
//! error, never silently dropped.

pub mod chart;
pub mod error;
pub mod figures;
pub mod files;
pub mod html;
pub mod manifest;
pub mod out_dir;
pub mod patients_csv;
pub mod results;
pub mod select;
pub mod stats;
pub mod summary;
pub mod table1;
pub mod trace;

pub use error::ReportError;
pub use files::{
    build_report, build_report_with, ReportExtras, ReportFile, W1Block, REPORT_FILES, W1_FILE,
};
pub use manifest::RunInfo;
pub use out_dir::ReportDir;
pub use results::{
    ArmKind, ArmResult, PatientResult, RunFailure, TwinCheckCounts, Week, WeekResult,
};
