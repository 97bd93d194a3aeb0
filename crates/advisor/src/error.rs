//! The one error type of abba-advisor.

use abba_core::Timestamp;
use thiserror::Error;

/// Everything that can go wrong in the advisor: bad configuration, bad
/// events (rejected, never used), bad saved state, or too little data for an
/// estimate.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum AdvisorError {
    /// A configuration field is outside its allowed range.
    #[error("invalid configuration: field `{field}` {problem}")]
    Config {
        /// Dotted path of the field, e.g. `critic.gamma`.
        field: String,
        /// What is wrong with it, including the value received.
        problem: String,
    },
    /// The event's timestamp is earlier than an event already accepted.
    #[error("event at {at} ({kind}) is out of order: an event at {previous} was already accepted")]
    OutOfOrder {
        /// Timestamp of the rejected event.
        at: Timestamp,
        /// Kind of the rejected event.
        kind: &'static str,
        /// Timestamp of the latest accepted event.
        previous: Timestamp,
    },
    /// The event's timestamp is outside the representable range.
    #[error("event at minute {minutes} ({kind}): timestamp must be within 0..={max} minutes")]
    TimestampRange {
        /// Minutes since the start of the log.
        minutes: i64,
        /// Kind of the rejected event.
        kind: &'static str,
        /// Largest accepted timestamp.
        max: i64,
    },
    /// A value carried by the event is not finite or not plausible.
    #[error("event at {at}: {what} must be {expected}, got {got}")]
    InvalidValue {
        /// Timestamp of the rejected event.
        at: Timestamp,
        /// Which value (with its unit).
        what: &'static str,
        /// The accepted range, in words.
        expected: String,
        /// The value received.
        got: f64,
    },
    /// The event repeats or contradicts one already accepted.
    #[error("event at {at} ({kind}) rejected as a duplicate: {detail}")]
    Duplicate {
        /// Timestamp of the rejected event.
        at: Timestamp,
        /// Kind of the rejected event.
        kind: &'static str,
        /// What it duplicates.
        detail: String,
    },
    /// The event is of a kind this advisor does not know how to use (a kind
    /// added to abba-core after this advisor was written); it is rejected
    /// rather than silently ignored.
    #[error("event at {at} ({kind}): this advisor does not support this kind of event")]
    UnsupportedEvent {
        /// Timestamp of the rejected event.
        at: Timestamp,
        /// Kind of the rejected event.
        kind: &'static str,
    },
    /// Saved advisor state could not be read or is inconsistent.
    #[error("invalid saved advisor state: {0}")]
    State(String),
    /// Not enough data to estimate something (e.g. transfer entropy).
    #[error("insufficient data for {what}: {detail}")]
    InsufficientData {
        /// What could not be estimated.
        what: &'static str,
        /// Why, with the counts involved.
        detail: String,
    },
}

/// Shorthand for configuration errors.
pub(crate) fn config_err(field: &str, problem: impl Into<String>) -> AdvisorError {
    AdvisorError::Config {
        field: field.to_string(),
        problem: problem.into(),
    }
}

/// Checks `lo <= value <= hi` (and finiteness) for a configuration field.
pub(crate) fn check_range(field: &str, value: f64, lo: f64, hi: f64) -> Result<(), AdvisorError> {
    if abba_core::limits::within(value, lo, hi) {
        Ok(())
    } else {
        Err(config_err(
            field,
            format!("must be a finite number in [{lo}, {hi}], got {value}"),
        ))
    }
}

/// Checks `lo <= value <= hi` for a whole-number configuration field.
pub(crate) fn check_count<T>(field: &str, value: T, lo: T, hi: T) -> Result<(), AdvisorError>
where
    T: PartialOrd + std::fmt::Display,
{
    if value >= lo && value <= hi {
        Ok(())
    } else {
        Err(config_err(
            field,
            format!("must be in {lo}..={hi}, got {value}"),
        ))
    }
}

/// Checks `value > 0` (and finiteness) for a configuration field.
pub(crate) fn check_positive(field: &str, value: f64) -> Result<(), AdvisorError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(config_err(
            field,
            format!("must be a finite number > 0, got {value}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_checks_name_the_field_and_the_range() {
        assert!(check_range("gain", 0.5, 0.0, 1.0).is_ok());
        for bad in [-0.1, 1.1, f64::NAN, f64::INFINITY] {
            let e = check_range("gain", bad, 0.0, 1.0).unwrap_err().to_string();
            assert!(e.contains("gain") && e.contains("[0, 1]"), "{e}");
        }
        assert!(check_count("init_days", 60_u32, 1, 60).is_ok());
        let e = check_count("init_days", 0_u32, 1, 60).unwrap_err();
        assert_eq!(
            e,
            config_err("init_days", "must be in 1..=60, got 0"),
            "the message of the four checks it replaces"
        );
        assert!(check_count("limits.max_timestamp_min", 0_i64, 1, i64::MAX / 4).is_err());
    }
}
