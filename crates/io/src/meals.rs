//! Meal windows: carbohydrate entries become breakfast, lunch and dinner
//! announcements or snacks by their local time, as the paper's system
//! "defines the type of meal based on the meal time".

use abba_core::MealSlot;
use serde::{Deserialize, Serialize};

use crate::error::IoError;

/// Local-time windows `[start, end)` in minutes of the day for the three
/// main meals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct MealWindows {
    /// Breakfast window.
    pub breakfast: (u32, u32),
    /// Lunch window.
    pub lunch: (u32, u32),
    /// Dinner window.
    pub dinner: (u32, u32),
}

impl Default for MealWindows {
    /// Breakfast 05:00-10:30, lunch 10:30-15:30, dinner 15:30-22:00.
    fn default() -> Self {
        Self {
            breakfast: (300, 630),
            lunch: (630, 930),
            dinner: (930, 1320),
        }
    }
}

fn hhmm(m: u32) -> String {
    format!("{:02}:{:02}", m / 60, m % 60)
}

impl MealWindows {
    /// Parses `HH:MM-HH:MM` for one window.
    pub fn parse_window(text: &str) -> Result<(u32, u32), IoError> {
        let bad = || IoError::Settings(format!("meal window \"{text}\": expected HH:MM-HH:MM"));
        let (a, b) = text.split_once('-').ok_or_else(bad)?;
        let m = |s: &str| -> Option<u32> {
            let (h, mi) = s.trim().split_once(':')?;
            let (h, mi): (u32, u32) = (h.parse().ok()?, mi.parse().ok()?);
            (h <= 24 && mi < 60 && h * 60 + mi <= 1440).then_some(h * 60 + mi)
        };
        Ok((m(a).ok_or_else(bad)?, m(b).ok_or_else(bad)?))
    }

    /// Checks that the windows are non-empty, in order and do not overlap.
    pub fn validate(&self) -> Result<(), IoError> {
        let w = [self.breakfast, self.lunch, self.dinner];
        for (i, (s, e)) in w.iter().enumerate() {
            if s >= e {
                return Err(IoError::Settings(format!(
                    "the {} window {}-{} is empty",
                    MealSlot::MAIN[i].name(),
                    hhmm(*s),
                    hhmm(*e)
                )));
            }
        }
        if w[0].1 > w[1].0 || w[1].1 > w[2].0 {
            return Err(IoError::Settings(
                "meal windows must be in order breakfast, lunch, dinner and must not overlap"
                    .into(),
            ));
        }
        Ok(())
    }

    /// The main meal whose window holds `minute_of_day`, if any.
    pub fn window_of(&self, minute_of_day: u32) -> Option<MealSlot> {
        [self.breakfast, self.lunch, self.dinner]
            .iter()
            .position(|&(s, e)| (s..e).contains(&minute_of_day))
            .map(|i| MealSlot::MAIN[i])
    }

    /// The rule in words (printed with every mapping).
    pub fn rule(&self) -> String {
        format!(
            "carbohydrate entries are breakfast {}-{}, lunch {}-{}, dinner {}-{} (local time); the \
             first entry of a day in a window is that meal, a later one in the same window and any \
             entry outside the windows is a snack",
            hhmm(self.breakfast.0), hhmm(self.breakfast.1), hhmm(self.lunch.0), hhmm(self.lunch.1), hhmm(self.dinner.0), hhmm(self.dinner.1)
        )
    }
}
