//! Scenario generation (protocol.md §4): each patient's daily life in the
//! in-silico trial — the meal plan (actual time and size, announced carbs,
//! skipped meals), the insulin-sensitivity profile s(t) and the SMBG and
//! CGM schedules.
//!
//! A [`ScenarioConfig`] holds every number of the protocol as a field whose
//! default is the paper's value; [`ScenarioConfig::paper`] gives S1-S4. A
//! [`ScenarioGenerator`] turns it and the patient's [`StreamSeeds`] into one
//! [`DayPlan`] per day, each a pure function of (seeds, day index).
//!
//! ```
//! use abba_sim::scenario::{ScenarioGenerator, ScenarioId};
//! let gen = ScenarioGenerator::paper(ScenarioId::S4, 42, 1).unwrap();
//! let day = gen.day(0);
//! assert_eq!(day.meals.len(), 4);
//! let s = day.sensitivity.per_minute();
//! assert!((s[5 * 60] / day.sensitivity.daily_factor - 0.5).abs() < 1e-12);
//! ```

mod config;
mod generate;
mod plan;

pub use config::{
    CgmWear, HypoTreatment, MealConfig, MealTemplate, ScenarioConfig, ScenarioId,
    SensitivityConfig, SensitivityDrift, SensitivityTarget, SkipConfig, SmbgConfig,
};
pub use generate::{ScenarioGenerator, StreamSeeds};
pub use plan::{Dawn, DayPlan, PlannedMeal, SensitivityDay, SmbgPurpose, SmbgReading, DAY_MINUTES};
