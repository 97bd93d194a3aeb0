//! The paper's in-silico trial: closed loop, runner, and the glue to the
//! report (abba-report builds and writes it from the results).

pub mod closed_loop;
pub mod error;
pub mod protocol;
pub mod report;
pub mod runner;

/// The results model and statistics live in abba-report; re-exported at
/// their old paths.
pub use abba_report::{results, stats};
pub use error::TrialError;
pub use protocol::{ArmKind, TrialConfig};
