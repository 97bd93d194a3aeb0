//! The one error type of abba-sim.

use thiserror::Error;

/// Everything that can go wrong in the simulator: bad input, failed
/// validation, or a non-finite solver result.
#[derive(Debug, Error)]
pub enum SimError {
    /// No patient of that name in the built-in tables.
    #[error("unknown patient '{name}' (known: {known})")]
    UnknownPatient {
        /// The name asked for.
        name: String,
        /// A short list of valid names.
        known: String,
    },
    /// A model parameter failed validation.
    #[error("patient {patient}: parameter {param} = {value} is invalid: {reason}")]
    InvalidParameter {
        /// Patient name.
        patient: String,
        /// Parameter name (as in vpatient_params.csv).
        param: String,
        /// The value found.
        value: f64,
        /// What was expected.
        reason: String,
    },
    /// A parameter table could not be read.
    #[error("parameter table {table}, line {line}: {reason}")]
    Table {
        /// Which table.
        table: String,
        /// 1-based line number (the header is line 1).
        line: u64,
        /// What was wrong.
        reason: String,
    },
    /// A file of per-minute inputs could not be read or holds an invalid
    /// or implausible value.
    #[error("{file}, line {line}: {reason}")]
    InputFile {
        /// The file as named by the caller.
        file: String,
        /// 1-based line number (the header is line 1).
        line: u64,
        /// What was wrong, naming the column and what was expected.
        reason: String,
    },
    /// A model input was invalid (negative, NaN, ...).
    #[error("patient {patient}, minute {minute}: invalid input: {reason}")]
    InvalidInput {
        /// Patient name.
        patient: String,
        /// Simulated minute.
        minute: i64,
        /// What was wrong.
        reason: String,
    },
    /// The solver produced a non-finite state.
    #[error("patient {patient}, minute {minute}: solver produced a non-finite state ({state})")]
    NonFinite {
        /// Patient name.
        patient: String,
        /// Simulated minute.
        minute: i64,
        /// Which state.
        state: String,
    },
    /// A device or scenario configuration was invalid.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// A device (CGM, meter, pump) was given an impossible input
    /// (a negative or non-finite dose, a non-finite glucose value, ...).
    #[error("{device}: invalid input: {reason}")]
    DeviceInput {
        /// Which device.
        device: String,
        /// What was wrong.
        reason: String,
    },
}
