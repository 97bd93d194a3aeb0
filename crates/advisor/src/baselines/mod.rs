//! Baselines behind the same [`crate::Advisor`] trait: the unchanged standard
//! therapy, run-to-run control (spec §10.2) and oref0's autotune.

pub mod autotune;
pub mod fixed;
pub mod r2r;
