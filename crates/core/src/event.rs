//! The device event log: everything a person's devices record that the
//! advisor may see.
//!
//! The kinds are what real pumps, sensors and meters record. New kinds may
//! be added (the enum is `#[non_exhaustive]`); the serialised form of every
//! existing kind never changes: `{"type": "<snake_case kind>", "value": ...}`.
//!
//! Delivery semantics (what a consumer that integrates insulin must count):
//! - `BasalRate(r)`: the *scheduled* basal rate is `r` from this minute on.
//! - `TempBasal { rate, duration_min }`: for `duration_min` minutes from this
//!   minute, `rate` replaces the scheduled rate (an absolute U/h, or a
//!   percentage of the scheduled rate, which then follows any scheduled
//!   change); afterwards the scheduled rate resumes. A new temporary basal
//!   replaces a running one; `duration_min` = 0 cancels it.
//! - `Suspend` … `Resume`: nothing is delivered in between. A suspension
//!   cancels the rest of any extended bolus (as pumps do); a temporary basal
//!   keeps its clock and is in force after `Resume` if it has not ended.
//! - `Bolus(u)`: `u` delivered at once.
//! - `ExtendedBolus { total, immediate, duration_min }`: `immediate` at once,
//!   the rest (`total − immediate`) spread evenly over `duration_min`
//!   minutes from this minute. A new extended bolus replaces the rest of a
//!   running one.

use crate::therapy::{MealSlot, TherapySettings};
use crate::time::Timestamp;
use crate::units::{Grams, GramsPerUnit, MgDl, Units, UnitsPerHour};
use serde::{Deserialize, Serialize};

/// The rate of a temporary basal, as the pump records it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TempBasalRate {
    /// An absolute rate.
    UnitsPerHour(UnitsPerHour),
    /// A percentage of the scheduled rate (100 = unchanged, 0 = nothing).
    Percent(f64),
}

impl TempBasalRate {
    /// The rate delivered (U/h) while the scheduled rate is `scheduled`.
    pub fn delivered(self, scheduled: UnitsPerHour) -> UnitsPerHour {
        match self {
            TempBasalRate::UnitsPerHour(r) => r,
            TempBasalRate::Percent(p) => UnitsPerHour(scheduled.0 * p / 100.0),
        }
    }
}

/// One device-visible happening.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", content = "value", rename_all = "snake_case")]
#[non_exhaustive]
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
    /// The scheduled basal rate in force from now on.
    BasalRate(UnitsPerHour),
    /// The last reading of the day was announced (SMBG mode) or midnight passed (CGM mode).
    DayClosed,
    /// A temporary basal rate for a while (see the module docs).
    TempBasal {
        /// The rate in force meanwhile.
        rate: TempBasalRate,
        /// How long, in minutes (0 cancels a running temporary basal).
        duration_min: u32,
    },
    /// Insulin delivery stopped (until `Resume`).
    Suspend,
    /// Insulin delivery resumed after a `Suspend`.
    Resume,
    /// An extended (square- or dual-wave) bolus (see the module docs).
    ExtendedBolus {
        /// All the insulin of this bolus, the immediate part included.
        total: Units,
        /// The part delivered at once (0 for a pure extended bolus).
        #[serde(default)]
        immediate: Units,
        /// Minutes over which `total − immediate` is spread.
        duration_min: u32,
    },
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

impl EventKind {
    /// A short name for messages ("CGM reading", "temporary basal", ...).
    pub fn name(&self) -> &'static str {
        match self {
            EventKind::Cgm(_) => "CGM reading",
            EventKind::Smbg(_) => "SMBG reading",
            EventKind::MealAnnounced { .. } => "meal announcement",
            EventKind::Bolus(_) => "bolus",
            EventKind::BasalRate(_) => "basal rate",
            EventKind::DayClosed => "day closed",
            EventKind::TempBasal { .. } => "temporary basal",
            EventKind::Suspend => "suspend",
            EventKind::Resume => "resume",
            EventKind::ExtendedBolus { .. } => "extended bolus",
            EventKind::SuggestionAccepted(_) => "suggestion accepted",
            EventKind::SuggestionRejected(_) => "suggestion rejected",
            EventKind::SuggestionOverridden(_) => "suggestion overridden",
        }
    }
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

    /// Puts the value in force in `settings` (a snack's ratio changes
    /// nothing: the settings have none).
    pub fn put_in_force(self, settings: &mut TherapySettings) {
        match self {
            SettingValue::Basal { rate } => settings.basal = rate,
            SettingValue::CarbRatio { slot, ratio } => {
                if let Some(i) = slot.main_index() {
                    settings.carb_ratio[i] = ratio;
                }
            }
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
    fn a_setting_value_puts_its_own_setting_in_force_and_a_snack_none() {
        let start = TherapySettings {
            basal: UnitsPerHour(1.0),
            carb_ratio: [GramsPerUnit(10.0), GramsPerUnit(11.0), GramsPerUnit(12.0)],
        };
        let mut s = start;
        SettingValue::Basal {
            rate: UnitsPerHour(0.8),
        }
        .put_in_force(&mut s);
        assert_eq!(s.basal, UnitsPerHour(0.8));
        assert_eq!(s.carb_ratio, start.carb_ratio);
        for (i, slot) in MealSlot::MAIN.into_iter().enumerate() {
            let mut s = start;
            SettingValue::CarbRatio {
                slot,
                ratio: GramsPerUnit(20.0),
            }
            .put_in_force(&mut s);
            assert_eq!(s.carb_ratio[i], GramsPerUnit(20.0));
            assert_eq!(s.basal, start.basal);
        }
        let mut s = start;
        SettingValue::CarbRatio {
            slot: MealSlot::Snack,
            ratio: GramsPerUnit(20.0),
        }
        .put_in_force(&mut s);
        assert_eq!(s, start);
    }

    fn old_kinds() -> Vec<Event> {
        vec![
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
        ]
    }

    /// The serialised form of the kinds that existed before the enum grew
    /// (written by hand from the format saved event logs use).
    const OLD_KINDS_JSON: &str = concat!(
        r#"[{"at":5,"kind":{"type":"cgm","value":142.5}},"#,
        r#"{"at":6,"kind":{"type":"smbg","value":98.0}},"#,
        r#"{"at":420,"kind":{"type":"meal_announced","value":{"carbs":50.0,"slot":"breakfast"}}},"#,
        r#"{"at":420,"kind":{"type":"bolus","value":5.05}},"#,
        r#"{"at":421,"kind":{"type":"basal_rate","value":1.25}},"#,
        r#"{"at":1380,"kind":{"type":"day_closed"}}]"#
    );

    #[test]
    fn existing_kinds_keep_their_serialised_form() {
        let json = serde_json::to_string(&old_kinds()).unwrap();
        assert_eq!(json, OLD_KINDS_JSON);
        let back: Vec<Event> = serde_json::from_str(OLD_KINDS_JSON).unwrap();
        assert_eq!(back, old_kinds());
    }

    #[test]
    fn new_kinds_round_trip_through_json() {
        let events = [
            Event::new(
                Timestamp(600),
                EventKind::TempBasal {
                    rate: TempBasalRate::UnitsPerHour(UnitsPerHour(0.4)),
                    duration_min: 90,
                },
            ),
            Event::new(
                Timestamp(700),
                EventKind::TempBasal {
                    rate: TempBasalRate::Percent(150.0),
                    duration_min: 0,
                },
            ),
            Event::new(Timestamp(800), EventKind::Suspend),
            Event::new(Timestamp(830), EventKind::Resume),
            Event::new(
                Timestamp(900),
                EventKind::ExtendedBolus {
                    total: Units(6.0),
                    immediate: Units(2.0),
                    duration_min: 120,
                },
            ),
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
            json.contains(
                r#"{"type":"temp_basal","value":{"rate":{"units_per_hour":0.4},"duration_min":90}}"#
            ),
            "{json}"
        );
        assert!(json.contains(r#"{"type":"suspend"}"#), "{json}");
        let back: Vec<Event> = serde_json::from_str(&json).unwrap();
        assert_eq!(back, events);
        // The immediate part may be left out: a pure extended bolus.
        let square: Event = serde_json::from_str(
            r#"{"at":1,"kind":{"type":"extended_bolus","value":{"total":3.0,"duration_min":60}}}"#,
        )
        .unwrap();
        assert_eq!(
            square.kind,
            EventKind::ExtendedBolus {
                total: Units(3.0),
                immediate: Units(0.0),
                duration_min: 60
            }
        );
    }

    #[test]
    fn temp_basal_rate_is_absolute_or_relative_to_the_schedule() {
        let abs = TempBasalRate::UnitsPerHour(UnitsPerHour(0.3));
        assert_eq!(abs.delivered(UnitsPerHour(1.0)), UnitsPerHour(0.3));
        let rel = TempBasalRate::Percent(50.0);
        assert_eq!(rel.delivered(UnitsPerHour(1.2)), UnitsPerHour(0.6));
    }

    #[test]
    fn answer_kinds_round_trip_through_json() {
        let events = [
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
        let back: Vec<Event> = serde_json::from_str(&json).unwrap();
        assert_eq!(back, events);
    }
}
