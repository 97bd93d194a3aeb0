//! The paper's in-silico trial: closed loop, runner, statistics and report.

pub mod closed_loop;
pub mod error;
pub mod manifest;
pub mod protocol;
pub mod report;
pub mod results;
pub mod runner;
pub mod shard;
pub mod stats;

pub use error::TrialError;
pub use protocol::{ArmKind, TrialConfig};
