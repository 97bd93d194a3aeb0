//! Errors of abba-trial.

use std::path::PathBuf;

use abba_core::CoreError;
use thiserror::Error;

/// What can go wrong while running the trial or writing its report.
#[derive(Debug, Error)]
pub enum TrialError {
    /// A statistic or metric could not be computed (`what` says for which arm, week and metric).
    #[error("{what}: {source}")]
    Stats {
        /// Where: arm, week, metric.
        what: String,
        /// The underlying error.
        #[source]
        source: CoreError,
    },
    /// The results handed to the report are inconsistent (e.g. patients of
    /// one arm with different evaluation weeks, two arms with the same key).
    #[error("inconsistent trial results: {0}")]
    InconsistentResults(String),
    /// The compiled-in table of the paper could not be read.
    #[error("paper table {file}, line {line}: {reason}")]
    PaperTable {
        /// The table's file name.
        file: &'static str,
        /// Line number, from 1.
        line: usize,
        /// What was wrong, and what was expected.
        reason: String,
    },
    /// A file or directory could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A JSON document could not be serialized.
    #[error("cannot serialize {what} as JSON: {source}")]
    Json {
        /// Which document.
        what: &'static str,
        /// The underlying error.
        #[source]
        source: serde_json::Error,
    },
    /// A CSV table could not be written.
    #[error("cannot write CSV {what}: {reason}")]
    Csv {
        /// Which table.
        what: &'static str,
        /// The underlying error, as text.
        reason: String,
    },
    /// A figure could not be drawn.
    #[error("cannot draw figure {figure}: {reason}")]
    Plot {
        /// The figure's file name.
        figure: &'static str,
        /// The plotting backend's error, as text.
        reason: String,
    },
    /// The simulator failed (bad configuration, non-finite state, ...).
    #[error("{context}: {source}")]
    Sim {
        /// Which patient, arm and scenario.
        context: String,
        /// The simulator's error.
        #[source]
        source: abba_sim::SimError,
    },
    /// The advisor rejected an event or its configuration.
    #[error("{context}: {source}")]
    Advisor {
        /// Which patient, arm and scenario.
        context: String,
        /// The advisor's error.
        #[source]
        source: abba_advisor::AdvisorError,
    },
    /// A metric could not be computed for a patient's evaluation week.
    #[error("{context}: {source}")]
    Metric {
        /// Which patient, arm, scenario and week.
        context: String,
        /// The core error.
        #[source]
        source: CoreError,
    },
    /// The trial configuration is invalid.
    #[error("invalid trial configuration: {0}")]
    Config(String),
}
