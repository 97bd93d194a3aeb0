//! The settings ABBA advises: the basal rate and the carb ratio of each main
//! meal (one name used by the decisions, the bounds and the steps).

use abba_core::MealSlot;
use serde::{Deserialize, Serialize};

/// Which setting a decision is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "slot")]
pub enum Parameter {
    /// The flat basal rate (U/h).
    Basal,
    /// The carb ratio of a main meal (g/U).
    CarbRatio(MealSlot),
}

impl std::fmt::Display for Parameter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Parameter::Basal => write!(f, "basal rate"),
            Parameter::CarbRatio(s) => write!(f, "{} carb ratio", s.name()),
        }
    }
}

impl Parameter {
    /// The four settings ABBA advises: the basal rate, then the carb ratios
    /// of breakfast, lunch and dinner.
    pub const MAIN: [Parameter; 4] = [
        Parameter::Basal,
        Parameter::CarbRatio(MealSlot::Breakfast),
        Parameter::CarbRatio(MealSlot::Lunch),
        Parameter::CarbRatio(MealSlot::Dinner),
    ];

    /// Unit of the parameter's values.
    pub fn unit(self) -> &'static str {
        match self {
            Parameter::Basal => "U/h",
            Parameter::CarbRatio(_) => "g/U",
        }
    }
}
