//! Baselines behind the same [`crate::Advisor`] trait: the unchanged standard
//! therapy and run-to-run control (spec §10.2).

pub mod fixed;
pub mod r2r;
