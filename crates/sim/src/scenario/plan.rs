//! The plan of one simulated day: plain data (serde), generated per
//! (patient, day) by [`super::ScenarioGenerator`].

use abba_core::{Grams, MealSlot, Timestamp, MINUTES_PER_DAY};
use serde::{Deserialize, Serialize};

/// Minutes in a day, as an array length.
pub const DAY_MINUTES: usize = MINUTES_PER_DAY as usize;

/// One meal of one day.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PlannedMeal {
    /// Which meal.
    pub slot: MealSlot,
    /// Actual time: the person starts eating (and announces) at this minute.
    pub at: Timestamp,
    /// Actual carbohydrate content (the drawn size, also recorded for a
    /// skipped meal, which is not eaten).
    pub carbs: Grams,
    /// The carbohydrate the person announces and boluses for; `None` for an
    /// unannounced meal (the snack) and for a skipped meal.
    pub announced: Option<Grams>,
    /// The meal is skipped: not eaten, not announced, not bolused (S4).
    pub skipped: bool,
}

impl PlannedMeal {
    /// The grams actually eaten (0 for a skipped meal).
    pub fn eaten(&self) -> Grams {
        if self.skipped {
            Grams(0.0)
        } else {
            self.carbs
        }
    }
}

/// What a finger-stick reading is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SmbgPurpose {
    /// Before a main meal (taken even if the meal is then skipped).
    BeforeMeal(MealSlot),
    /// The bedtime reading, the last of the day.
    Bedtime,
}

/// One scheduled finger-stick reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SmbgReading {
    /// When the reading is taken (time uncertainty included).
    pub at: Timestamp,
    /// What it is for.
    pub purpose: SmbgPurpose,
}

/// The insulin-sensitivity profile s(t) of one day.
///
/// On a day with variability, s(t) = daily factor × dawn factor, where the
/// dawn factor is 1 outside [start, end], falls linearly to `dawn_factor`
/// over the `ramp` minutes after `start`, stays there, and rises linearly
/// back to 1 over the `ramp` minutes before `end`. On a day without
/// variability s(t) = 1.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SensitivityDay {
    /// Factor for the whole day (1 on days without variability).
    pub daily_factor: f64,
    /// The dawn phenomenon of this day (`None` on days without variability).
    pub dawn: Option<Dawn>,
}

/// Shape of the dawn phenomenon.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Dawn {
    /// The lowest dawn factor.
    pub factor: f64,
    /// Start of the descending ramp, minutes after midnight.
    pub start_min: u32,
    /// End of the ascending ramp, minutes after midnight.
    pub end_min: u32,
    /// Length of each ramp, minutes.
    pub ramp_min: u32,
}

impl Dawn {
    /// The dawn factor at `minute_of_day` (a real number of minutes after midnight).
    pub fn factor_at(&self, minute_of_day: f64) -> f64 {
        let (start, end, ramp) = (
            f64::from(self.start_min),
            f64::from(self.end_min),
            f64::from(self.ramp_min),
        );
        let low = self.factor;
        if minute_of_day <= start || minute_of_day >= end {
            1.0
        } else if minute_of_day < start + ramp {
            1.0 + (low - 1.0) * (minute_of_day - start) / ramp
        } else if minute_of_day <= end - ramp {
            low
        } else {
            low + (1.0 - low) * (minute_of_day - (end - ramp)) / ramp
        }
    }
}

impl SensitivityDay {
    /// s(t) at `minute_of_day` (a real number in [0, 1440)).
    pub fn at(&self, minute_of_day: f64) -> f64 {
        match &self.dawn {
            Some(d) => self.daily_factor * d.factor_at(minute_of_day),
            None => self.daily_factor,
        }
    }

    /// The mean of s(t) over each minute [m, m+1) of the day, for a solver
    /// that holds the sensitivity constant within a minute. The ramps start
    /// and end on whole minutes, so s is linear inside every minute and its
    /// mean is exactly s(m + 0.5).
    pub fn per_minute(&self) -> [f64; DAY_MINUTES] {
        let mut out = [self.daily_factor; DAY_MINUTES];
        if let Some(d) = &self.dawn {
            let lo = d.start_min as usize;
            let hi = (d.end_min as usize).min(DAY_MINUTES);
            for (m, v) in out.iter_mut().enumerate().take(hi).skip(lo) {
                *v = self.daily_factor * d.factor_at(m as f64 + 0.5);
            }
        }
        out
    }
}

/// Everything the simulated person does on one day.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DayPlan {
    /// 0-based day index (day 1 of the paper is 0).
    pub day_index: u32,
    /// The day's meals in time order, skipped ones included (flagged).
    pub meals: Vec<PlannedMeal>,
    /// The insulin-sensitivity profile.
    pub sensitivity: SensitivityDay,
    /// Finger-stick readings in time order (empty when there are none).
    pub smbg: Vec<SmbgReading>,
    /// Whether the CGM is worn this day.
    pub cgm_worn: bool,
}

impl DayPlan {
    /// 1-based day number (D1..D98).
    pub fn day_number(&self) -> u32 {
        self.day_index + 1
    }

    /// Timestamp of `minute_of_day` on this day.
    pub fn at(&self, minute_of_day: u32) -> Timestamp {
        Timestamp::from_day_and_minute(i64::from(self.day_index), i64::from(minute_of_day))
    }

    /// The meal of a slot, if the plan has one.
    pub fn meal(&self, slot: MealSlot) -> Option<&PlannedMeal> {
        self.meals.iter().find(|m| m.slot == slot)
    }

    /// Whether a CGM worn this day with sample period `period_min` reads at
    /// `minute_of_day` (every multiple of the period from 00:00).
    pub fn cgm_sample_at(&self, minute_of_day: u32, period_min: u32) -> bool {
        self.cgm_worn && period_min > 0 && minute_of_day.is_multiple_of(period_min)
    }
}
