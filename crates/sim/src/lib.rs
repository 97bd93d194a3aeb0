//! The UVA/Padova 2008 type 1 diabetes simulator: the patient model and its
//! solver, virtual cohorts, CGM, SMBG meter and pump, and scenario generation.
//!
//! abba-sim is the simulated world of the in-silico trial: it stands in for
//! a person with type 1 diabetes and their devices. It computes the model
//! simglucose computes (`spec/uva-padova-model.md`), minute by minute, and
//! matches simglucose's reference trajectories (BENCHMARKS.md gives the
//! measured agreement and speed). The advisor never sees this crate: it gets
//! only device events, so the same advisor runs on real data.
//!
//! ```
//! use abba_sim::cohort::{Cohort, CohortConfig, Population};
//! use abba_sim::inputs::InputDay;
//! use abba_sim::patient::{Patient, PatientParams, QuestRow};
//!
//! // One public patient through the paper's standard day (three bolused
//! // meals and a snack, steady-state basal): plasma glucose every minute.
//! let params = PatientParams::public("adult#001")?;
//! let carb_ratio = QuestRow::for_patient("adult#001")?.cr;
//! let day = InputDay::standard(&params, carb_ratio);
//! let mut patient = Patient::new(params)?;
//! let glucose = day.simulate(&mut patient, 1.0)?;
//! assert_eq!(glucose.len(), 1441);
//! assert!(glucose.iter().all(|g| (70.0..250.0).contains(g)));
//!
//! // A cohort: the 10 public adults, then generated ones (adult#011, ...),
//! // each with its standard therapy; a pure function of the seed.
//! let cohort = Cohort::generate(&CohortConfig::new(Population::Adults, 12, 1))?;
//! assert_eq!(cohort.patients[11].params.name, "adult#012");
//!
//! // Implausible input is refused with the limit named, never simulated.
//! let file = "minute,cho_g_per_min,insulin_u_per_min\n0,0,100\n";
//! let e = InputDay::from_csv("in.csv", file).unwrap_err();
//! assert!(e.to_string().contains("limit of 30.5 U/min"));
//! # Ok::<(), abba_sim::SimError>(())
//! ```
//!
//! # Modules
//!
//! - [`patient`]: parameters of the 30 public patients (simglucose's tables,
//!   `data/`), the 13-state model, its solver and the eating queue.
//! - [`inputs`]: open-loop input days (per-minute carbohydrate and insulin),
//!   their CSV form and physical limits, and the built-in hard days.
//! - [`cohort`]: virtual cohorts (public patients plus generated mixtures),
//!   their plausibility checks and titrated standard therapy.
//! - [`devices`]: CGM (simglucose's noise model), SMBG meter and insulin
//!   pump with a real pump's increments and limits.
//! - [`scenario`]: the trial's scenarios S1-S4 and the daily meal and
//!   sensitivity plans they generate.
//! - [`person`]: the simulated person ([`person::VirtualPerson`]) who lives a
//!   scenario with their devices and talks to an advisor only through device
//!   events out and suggested settings in.
//!
//! # Contract
//!
//! - Units are in the names (`_mg_dl`, `_g_per_min`, `_u_per_min`, ...) or in
//!   abba-core's unit types; time is whole simulated minutes from 0.
//! - Everything random is drawn from seeded ChaCha8 streams
//!   (`abba_core::derive_seed`): the same seed gives the same numbers, on
//!   any thread count.
//! - Bad input (a negative or non-finite rate, an unknown patient, an
//!   invalid parameter or configuration) is a [`SimError`] naming what was
//!   wrong; nothing is clamped or guessed, and the library never prints.

pub mod cohort;
pub mod devices;
pub mod error;
pub mod inputs;
pub mod patient;
pub mod person;
pub mod scenario;

pub use error::SimError;
