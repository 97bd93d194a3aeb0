//! UVA/Padova 2008 type 1 diabetes simulator: the patient model and its
//! solver, virtual cohorts, CGM, SMBG meter and pump, scenario generation, and
//! the simulated person ([`person::VirtualPerson`]) who lives a scenario and
//! talks to an advisor only through device events and suggested settings.

pub mod cohort;
pub mod devices;
pub mod error;
pub mod inputs;
pub mod patient;
pub mod person;
pub mod scenario;

pub use error::SimError;
