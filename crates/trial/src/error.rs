//! The one error type of abba-trial.

use thiserror::Error;

/// What can stop a trial or its report.
#[derive(Debug, Error)]
pub enum TrialError {
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
    /// A metric could not be computed.
    #[error("{context}: {source}")]
    Metric {
        /// Where.
        context: String,
        /// The core error.
        #[source]
        source: abba_core::CoreError,
    },
    /// The trial configuration is invalid.
    #[error("invalid trial configuration: {0}")]
    Config(String),
    /// Writing the report failed.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// Something else went wrong while building the report.
    #[error("report: {0}")]
    Report(String),
}
