//! UVA/Padova 2008 type 1 diabetes simulator: the patient model and its
//! solver, virtual cohorts, CGM, SMBG meter and pump, and scenario generation.

pub mod cohort;
pub mod devices;
pub mod error;
pub mod inputs;
pub mod patient;
pub mod person;
pub mod scenario;

pub use error::SimError;
