//! The paper's in-silico trial: closed loop, runner, statistics and report.

pub mod calibrate;
pub mod closed_loop;
pub mod error;
pub mod protocol;
pub mod report;
pub mod results;
pub mod runner;
pub mod stats;
pub mod w1_sensitivity;

pub use error::TrialError;
pub use protocol::{ArmKind, TrialConfig};
