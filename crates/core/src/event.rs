//! The device event log: everything a person's devices record that the
//! advisor may see.

use crate::therapy::MealSlot;
use crate::time::Timestamp;
use crate::units::{Grams, GramsPerUnit, MgDl, Units, UnitsPerHour};
use serde::{Deserialize, Serialize};

/// One device-visible happening.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", content = "value", rename_all = "snake_case")]
pub enum EventKind {
    /// A CGM reading.
    Cgm(MgDl),
    /// A finger-stick (SMBG) reading.
    Smbg(MgDl),
    /// The person announced a meal with the carbohydrate they estimated.
    MealAnnounced {
        /// Estimated carbohydrate.
        carbs: Grams,
        /// Which meal.
        slot: MealSlot,
    },
    /// Bolus insulin delivered.
    Bolus(Units),
    /// The basal rate in force from now on.
    BasalRate(UnitsPerHour),
    /// The last reading of the day was announced (SMBG mode) or midnight passed (CGM mode).
    DayClosed,
    /// The person's answer to a suggestion: they put the suggested value in
    /// force.
    SuggestionAccepted(SettingValue),
    /// The person's answer to a suggestion: they rejected it and kept the
    /// previous value, which stays in force.
    SuggestionRejected(SettingValue),
    /// The person's answer to a suggestion: they rejected it and put their
    /// own value in force.
    SuggestionOverridden(SettingValue),
}

/// One therapy setting with the value a person put in force (the payload of
/// the answer events: the advisor's next update starts from it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "setting", rename_all = "snake_case")]
pub enum SettingValue {
    /// The flat basal rate.
    Basal {
        /// The rate in force.
        rate: UnitsPerHour,
    },
    /// A main meal's carb ratio.
    CarbRatio {
        /// The meal (breakfast, lunch or dinner).
        slot: MealSlot,
        /// The ratio in force.
        ratio: GramsPerUnit,
    },
}

impl SettingValue {
    /// The value as a plain number (U/h or g/U).
    pub fn number(self) -> f64 {
        match self {
            SettingValue::Basal { rate } => rate.0,
            SettingValue::CarbRatio { ratio, .. } => ratio.0,
        }
    }
}

/// An event with its time.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// When it happened.
    pub at: Timestamp,
    /// What happened.
    pub kind: EventKind,
}

impl Event {
    /// An event at `at`.
    pub fn new(at: Timestamp, kind: EventKind) -> Self {
        Self { at, kind }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_round_trip_through_json() {
        let events = [
            Event::new(Timestamp(5), EventKind::Cgm(MgDl(142.5))),
            Event::new(Timestamp(6), EventKind::Smbg(MgDl(98.0))),
            Event::new(
                Timestamp(420),
                EventKind::MealAnnounced {
                    carbs: Grams(50.0),
                    slot: MealSlot::Breakfast,
                },
            ),
            Event::new(Timestamp(420), EventKind::Bolus(Units(5.05))),
            Event::new(Timestamp(421), EventKind::BasalRate(UnitsPerHour(1.25))),
            Event::new(Timestamp(1380), EventKind::DayClosed),
            Event::new(
                Timestamp(1380),
                EventKind::SuggestionAccepted(SettingValue::Basal {
                    rate: UnitsPerHour(1.2),
                }),
            ),
            Event::new(
                Timestamp(1381),
                EventKind::SuggestionOverridden(SettingValue::CarbRatio {
                    slot: MealSlot::Lunch,
                    ratio: GramsPerUnit(11.5),
                }),
            ),
        ];
        let json = serde_json::to_string(&events).unwrap();
        assert!(
            json.contains(r#"{"at":5,"kind":{"type":"cgm","value":142.5}}"#),
            "{json}"
        );
        let back: Vec<Event> = serde_json::from_str(&json).unwrap();
        assert_eq!(back, events);
    }
}
