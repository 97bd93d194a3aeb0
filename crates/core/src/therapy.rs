//! Therapy settings (a flat basal rate and three carb ratios) and meal slots.

use crate::error::{positive, CoreError};
use crate::units::{GramsPerUnit, UnitsPerHour};
use serde::{Deserialize, Serialize};

/// Which meal of the day a carbohydrate intake belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MealSlot {
    /// Breakfast (first main meal).
    Breakfast,
    /// Lunch (second main meal).
    Lunch,
    /// Dinner (third main meal).
    Dinner,
    /// A snack: no carb ratio of its own, no bolus in the paper's protocol.
    Snack,
}

impl MealSlot {
    /// The three main meals, in the order of the carb ratios.
    pub const MAIN: [MealSlot; 3] = [MealSlot::Breakfast, MealSlot::Lunch, MealSlot::Dinner];

    /// Index into `TherapySettings::carb_ratio` (None for a snack).
    pub fn main_index(self) -> Option<usize> {
        match self {
            MealSlot::Breakfast => Some(0),
            MealSlot::Lunch => Some(1),
            MealSlot::Dinner => Some(2),
            MealSlot::Snack => None,
        }
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            MealSlot::Breakfast => "breakfast",
            MealSlot::Lunch => "lunch",
            MealSlot::Dinner => "dinner",
            MealSlot::Snack => "snack",
        }
    }
}

/// What the advisor adjusts: one flat basal rate for the whole day and one
/// carbohydrate ratio per main meal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TherapySettings {
    /// Flat basal rate.
    pub basal: UnitsPerHour,
    /// Carb ratios for breakfast, lunch and dinner.
    pub carb_ratio: [GramsPerUnit; 3],
}

impl TherapySettings {
    /// Settings with one carb ratio for all three meals, validated.
    pub fn new(basal: UnitsPerHour, carb_ratio: GramsPerUnit) -> Result<Self, CoreError> {
        let s = Self {
            basal,
            carb_ratio: [carb_ratio; 3],
        };
        s.validate()?;
        Ok(s)
    }

    /// Checks that every setting is finite and strictly positive.
    pub fn validate(&self) -> Result<(), CoreError> {
        positive("basal rate (U/h)", self.basal.0)?;
        for cr in &self.carb_ratio {
            positive("carb ratio (g/U)", cr.0)?;
        }
        Ok(())
    }

    /// The carb ratio for a main meal (None for a snack).
    pub fn carb_ratio_for(&self, slot: MealSlot) -> Option<GramsPerUnit> {
        slot.main_index().map(|i| self.carb_ratio[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_positive_settings() {
        assert!(TherapySettings::new(UnitsPerHour(0.0), GramsPerUnit(10.0)).is_err());
        assert!(TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(f64::NAN)).is_err());
        let s = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap();
        assert_eq!(s.carb_ratio_for(MealSlot::Lunch), Some(GramsPerUnit(10.0)));
        assert_eq!(s.carb_ratio_for(MealSlot::Snack), None);
    }
}
