//! The paper's in-silico trial: closed loop, runner, statistics and report.

pub mod error;
pub mod results;
pub mod stats;

pub use error::TrialError;
