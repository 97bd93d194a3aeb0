//! What can go wrong when a twin is fitted, checked, stored or replayed.

use abba_sim::SimError;

/// A twin error: each names what was wrong and, where there is one, the
/// file, field or minute.
#[derive(Debug, thiserror::Error)]
pub enum TwinError {
    /// The records cannot give a twin (no readings, too few days, ...).
    #[error("{0}")]
    Data(String),
    /// A what-if setting or an option is out of its range.
    #[error("{0}")]
    Setting(String),
    /// The simulator refused a candidate or an input.
    #[error("simulator: {0}")]
    Sim(#[from] SimError),
    /// The optimiser failed.
    #[error("optimiser: {0}")]
    Optimiser(String),
    /// A stored twin file cannot be read or written.
    #[error("{path}: {reason}")]
    File {
        /// The file.
        path: String,
        /// What went wrong.
        reason: String,
    },
}
