//! Errors of abba-core.

use thiserror::Error;

/// What can go wrong when building core values from raw input.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CoreError {
    /// A quantity was not a finite number or was outside its allowed range.
    #[error("{what} must be {expected}, got {got}")]
    OutOfRange {
        /// Which quantity.
        what: &'static str,
        /// What was expected, in words.
        expected: &'static str,
        /// The value received.
        got: f64,
    },
    /// A metric could not be computed from the readings given.
    #[error("cannot compute {metric}: {reason}")]
    Metric {
        /// Which metric.
        metric: &'static str,
        /// Why not.
        reason: String,
    },
    /// One reading of a series was invalid (`index` counts from 0).
    #[error("reading {index}: {what} must be {expected}, got {got}")]
    BadReading {
        /// Position of the reading in the series, from 0.
        index: usize,
        /// Which quantity.
        what: &'static str,
        /// What was expected, in words.
        expected: &'static str,
        /// The value received.
        got: f64,
    },
    /// Reading times were not strictly increasing.
    #[error("reading {index}: time {got} min is not after the previous reading's time {previous} min (times must be strictly increasing)")]
    UnsortedTimes {
        /// Position of the offending reading, from 0.
        index: usize,
        /// Time of the reading before it, in minutes.
        previous: f64,
        /// Its own time, in minutes.
        got: f64,
    },
    /// A name (of a scenario, metric, ...) that is not one of the known ones.
    #[error("unknown {what} '{got}' (expected {expected})")]
    UnknownName {
        /// What kind of name.
        what: &'static str,
        /// The name received.
        got: String,
        /// The names that exist, in words.
        expected: String,
    },
}

/// Checks that `value` is finite and strictly positive.
pub fn positive(what: &'static str, value: f64) -> Result<f64, CoreError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(CoreError::OutOfRange {
            what,
            expected: "a finite number > 0",
            got: value,
        })
    }
}

/// Checks that `value` is finite and not negative.
pub fn non_negative(what: &'static str, value: f64) -> Result<f64, CoreError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(CoreError::OutOfRange {
            what,
            expected: "a finite number >= 0",
            got: value,
        })
    }
}
