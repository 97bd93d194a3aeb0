//! Errors of abba-trial.

use std::path::PathBuf;

use abba_core::CoreError;
use thiserror::Error;

/// What can go wrong while running the trial or writing its report.
#[derive(Debug, Error)]
pub enum TrialError {
    /// The report could not be built or written, or its folder cannot be used.
    #[error(transparent)]
    Report(#[from] abba_report::ReportError),
    /// Shards that do not make one trial, or results that do not fit it.
    #[error("trial shards: {0}")]
    Shard(String),
    /// A file or directory could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The path.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
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
