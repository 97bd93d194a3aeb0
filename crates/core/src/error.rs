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
