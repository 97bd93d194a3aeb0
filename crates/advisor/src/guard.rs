//! Validation of the incoming event stream, shared by every advisor.
//!
//! An event is rejected with an [`AdvisorError`] (and the advisor's state is
//! left untouched) when:
//! - its timestamp is negative, beyond `limits.max_timestamp_min`, or earlier
//!   than an event already accepted (events at the same minute are fine);
//! - a value is not finite or outside the plausibility limits
//!   ([`EventLimits`]): glucose readings, announced carbohydrate (≥ 0), bolus
//!   (≥ 0), basal rate (≥ 0), temporary basal (rate, percentage, duration),
//!   extended bolus (total, immediate part ≤ total, duration);
//! - it is of a kind this advisor does not know (a kind added to abba-core
//!   later);
//! - it duplicates an event at the same minute: an identical event, or a
//!   second reading of the same kind (a device gives one reading per minute;
//!   two different basal rates in one minute are fine, the last one holds);
//! - it announces a main meal that was already announced that day or whose
//!   slot comes before one already announced that day (breakfast, lunch,
//!   dinner are announced in order; snacks are free);
//! - it closes a day that is already closed or earlier than one already
//!   closed. A `DayClosed` event closes the calendar day that contains the
//!   minute before it: 23:00 of D8 closes D8, 00:00 of D9 closes D8.

use crate::config::EventLimits;
use crate::error::AdvisorError;
use abba_core::{Event, EventKind, MealSlot, SettingValue, TempBasalRate, Timestamp};
use serde::{Deserialize, Serialize};

/// A serialisable copy of an accepted event's kind. (abba-core's `EventKind`
/// is an internally tagged enum whose newtype variants hold floats, which
/// serde_json cannot serialise, so the guard keeps its own form.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
enum Seen {
    Cgm(f64),
    Smbg(f64),
    Meal {
        carbs: f64,
        slot: MealSlot,
    },
    Bolus(f64),
    Basal(f64),
    DayClosed,
    TempBasalU(f64, u32),
    TempBasalPercent(f64, u32),
    Suspend,
    Resume,
    Extended(f64, f64, u32),
    /// An answer: 0 accepted, 1 rejected, 2 overridden.
    Answer(u8, SettingValue),
    Other,
}

impl From<&EventKind> for Seen {
    fn from(k: &EventKind) -> Self {
        match *k {
            EventKind::Cgm(g) => Seen::Cgm(g.0),
            EventKind::Smbg(g) => Seen::Smbg(g.0),
            EventKind::MealAnnounced { carbs, slot } => Seen::Meal {
                carbs: carbs.0,
                slot,
            },
            EventKind::Bolus(u) => Seen::Bolus(u.0),
            EventKind::BasalRate(r) => Seen::Basal(r.0),
            EventKind::DayClosed => Seen::DayClosed,
            EventKind::TempBasal { rate, duration_min } => match rate {
                TempBasalRate::UnitsPerHour(r) => Seen::TempBasalU(r.0, duration_min),
                TempBasalRate::Percent(p) => Seen::TempBasalPercent(p, duration_min),
            },
            EventKind::Suspend => Seen::Suspend,
            EventKind::Resume => Seen::Resume,
            EventKind::ExtendedBolus {
                total,
                immediate,
                duration_min,
            } => Seen::Extended(total.0, immediate.0, duration_min),
            EventKind::SuggestionAccepted(v) => Seen::Answer(0, v),
            EventKind::SuggestionRejected(v) => Seen::Answer(1, v),
            EventKind::SuggestionOverridden(v) => Seen::Answer(2, v),
            _ => Seen::Other,
        }
    }
}

/// Name of an event kind for messages.
pub fn kind_name(kind: &EventKind) -> &'static str {
    kind.name()
}

/// The calendar day (0-based index) that a `DayClosed` at `at` closes.
pub fn closed_day(at: Timestamp) -> i64 {
    at.plus(-1).day_index()
}

/// Stream state needed to validate the next event.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EventGuard {
    last_at: Option<Timestamp>,
    /// Events accepted at `last_at` (for duplicate detection); reused buffer.
    same_minute: Vec<Seen>,
    last_closed_day: Option<i64>,
    /// (day, highest main-meal index announced that day).
    last_main_meal: Option<(i64, usize)>,
    /// Day of the first accepted event (for `DayClosed`, the day it closes).
    first_day: Option<i64>,
}

/// Every value of `e` finite and within its plausibility limit
/// ([`EventLimits`]); an event kind this advisor does not know is refused.
fn check_values(e: &Event, limits: &EventLimits) -> Result<(), AdvisorError> {
    let at = e.at;
    match e.kind {
        EventKind::Cgm(g) => check_value(
            at,
            "CGM glucose (mg/dL)",
            g.0,
            limits.glucose_min_mg_dl,
            limits.glucose_max_mg_dl,
        ),
        EventKind::Smbg(g) => check_value(
            at,
            "SMBG glucose (mg/dL)",
            g.0,
            limits.glucose_min_mg_dl,
            limits.glucose_max_mg_dl,
        ),
        EventKind::MealAnnounced { carbs, .. } => check_value(
            at,
            "announced carbohydrate (g)",
            carbs.0,
            0.0,
            limits.carbs_max_g,
        ),
        EventKind::Bolus(u) => check_value(at, "bolus (U)", u.0, 0.0, limits.bolus_max_u),
        EventKind::BasalRate(r) => {
            check_value(at, "basal rate (U/h)", r.0, 0.0, limits.basal_max_u_per_h)
        }
        EventKind::SuggestionAccepted(v)
        | EventKind::SuggestionRejected(v)
        | EventKind::SuggestionOverridden(v) => check_answer(at, v, limits),
        EventKind::TempBasal { rate, duration_min } => {
            match rate {
                TempBasalRate::UnitsPerHour(r) => check_value(
                    at,
                    "temporary basal rate (U/h)",
                    r.0,
                    0.0,
                    limits.basal_max_u_per_h,
                )?,
                TempBasalRate::Percent(p) => check_value(
                    at,
                    "temporary basal (% of the scheduled rate)",
                    p,
                    0.0,
                    limits.temp_basal_max_percent,
                )?,
            }
            check_duration(
                at,
                "temporary basal duration (min)",
                duration_min,
                0,
                limits.temp_basal_max_min,
            )
        }
        EventKind::ExtendedBolus {
            total,
            immediate,
            duration_min,
        } => {
            check_value(
                at,
                "extended bolus total (U)",
                total.0,
                0.0,
                limits.bolus_max_u,
            )?;
            check_value(
                at,
                "extended bolus immediate part (U, at most the total)",
                immediate.0,
                0.0,
                total.0,
            )?;
            check_duration(
                at,
                "extended bolus duration (min)",
                duration_min,
                1,
                limits.extended_bolus_max_min,
            )
        }
        EventKind::Suspend | EventKind::Resume | EventKind::DayClosed => Ok(()),
        _ => Err(AdvisorError::UnsupportedEvent {
            at,
            kind: kind_name(&e.kind),
        }),
    }
}

/// The value an answer puts in force: a basal rate above zero, or a main
/// meal's carb ratio above zero.
fn check_answer(at: Timestamp, v: SettingValue, limits: &EventLimits) -> Result<(), AdvisorError> {
    match v {
        SettingValue::Basal { rate } => check_value(
            at,
            "basal rate in force (U/h)",
            rate.0,
            f64::MIN_POSITIVE,
            limits.basal_max_u_per_h,
        ),
        SettingValue::CarbRatio { slot, .. } if slot.main_index().is_none() => {
            Err(AdvisorError::InvalidValue {
                at,
                what: "carb ratio in force (only main meals have one)",
                expected: "breakfast, lunch or dinner".into(),
                got: f64::NAN,
            })
        }
        SettingValue::CarbRatio { ratio, .. } => check_value(
            at,
            "carb ratio in force (g/U)",
            ratio.0,
            f64::MIN_POSITIVE,
            limits.carbs_max_g,
        ),
    }
}

fn check_duration(
    at: Timestamp,
    what: &'static str,
    v: u32,
    lo: u32,
    hi: u32,
) -> Result<(), AdvisorError> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(AdvisorError::InvalidValue {
            at,
            what,
            expected: format!("a whole number of minutes in [{lo}, {hi}]"),
            got: f64::from(v),
        })
    }
}

fn check_value(
    at: Timestamp,
    what: &'static str,
    v: f64,
    lo: f64,
    hi: f64,
) -> Result<(), AdvisorError> {
    if abba_core::limits::within(v, lo, hi) {
        Ok(())
    } else {
        Err(AdvisorError::InvalidValue {
            at,
            what,
            expected: format!("a finite number in [{lo}, {hi}]"),
            got: v,
        })
    }
}

impl EventGuard {
    /// Day of the first accepted event, if any.
    pub fn first_day(&self) -> Option<i64> {
        self.first_day
    }

    /// Checks `e` against the stream so far without changing anything:
    /// its time, a duplicate at its minute, its values, the order of the
    /// day's main meals and of closed days.
    pub fn check(&self, e: &Event, limits: &EventLimits) -> Result<(), AdvisorError> {
        self.check_time(e, limits)?;
        check_values(e, limits)?;
        match e.kind {
            EventKind::MealAnnounced { slot, .. } => self.check_meal_order(e, slot),
            EventKind::DayClosed => self.check_day_closed(e),
            _ => Ok(()),
        }
    }

    /// Within the clock's range, not before an event already accepted,
    /// and not a second event of one kind at the same minute.
    fn check_time(&self, e: &Event, limits: &EventLimits) -> Result<(), AdvisorError> {
        let kind = kind_name(&e.kind);
        let m = e.at.minutes();
        if m < 0 || m > limits.max_timestamp_min {
            return Err(AdvisorError::TimestampRange {
                minutes: m,
                kind,
                max: limits.max_timestamp_min,
            });
        }
        let Some(prev) = self.last_at else {
            return Ok(());
        };
        if e.at < prev {
            return Err(AdvisorError::OutOfOrder {
                at: e.at,
                kind,
                previous: prev,
            });
        }
        if e.at == prev {
            let this = Seen::from(&e.kind);
            for seen in &self.same_minute {
                let same_reading_kind = matches!(
                    (seen, &this),
                    (Seen::Cgm(_), Seen::Cgm(_)) | (Seen::Smbg(_), Seen::Smbg(_))
                );
                if *seen == this || same_reading_kind {
                    return Err(AdvisorError::Duplicate {
                        at: e.at,
                        kind,
                        detail: format!("an event {seen:?} was already accepted at this minute"),
                    });
                }
            }
        }
        Ok(())
    }

    /// Main meals are announced once each a day, in order.
    fn check_meal_order(&self, e: &Event, slot: MealSlot) -> Result<(), AdvisorError> {
        if let (Some(i), Some((day, last))) = (slot.main_index(), self.last_main_meal) {
            if day == e.at.day_index() && i <= last {
                return Err(AdvisorError::Duplicate {
                    at: e.at,
                    kind: kind_name(&e.kind),
                    detail: format!(
                        "{} announced after {} on the same day (main meals are announced once each, in order)",
                        slot.name(),
                        MealSlot::MAIN[last].name()
                    ),
                });
            }
        }
        Ok(())
    }

    /// A day is closed once, after the days already closed.
    fn check_day_closed(&self, e: &Event) -> Result<(), AdvisorError> {
        let d = closed_day(e.at);
        match self.last_closed_day {
            Some(last) if d <= last => Err(AdvisorError::Duplicate {
                at: e.at,
                kind: kind_name(&e.kind),
                detail: format!(
                    "it closes day D{} but D{} is already closed",
                    d + 1,
                    last + 1
                ),
            }),
            _ => Ok(()),
        }
    }

    /// Records an accepted event (call after `check` succeeded).
    pub fn commit(&mut self, e: &Event) {
        if self.last_at != Some(e.at) {
            self.same_minute.clear();
            self.last_at = Some(e.at);
        }
        self.same_minute.push(Seen::from(&e.kind));
        if self.first_day.is_none() {
            self.first_day = Some(match e.kind {
                EventKind::DayClosed => closed_day(e.at),
                _ => e.at.day_index(),
            });
        }
        match e.kind {
            EventKind::DayClosed => self.last_closed_day = Some(closed_day(e.at)),
            EventKind::MealAnnounced { slot, .. } => {
                if let Some(i) = slot.main_index() {
                    self.last_main_meal = Some((e.at.day_index(), i));
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_core::{Grams, MealSlot, MgDl, Units};

    fn ev(min: i64, kind: EventKind) -> Event {
        Event::new(Timestamp(min), kind)
    }

    fn feed(g: &mut EventGuard, e: Event) -> Result<(), AdvisorError> {
        let l = EventLimits::default();
        g.check(&e, &l)?;
        g.commit(&e);
        Ok(())
    }

    #[test]
    fn rejects_bad_streams_with_clear_errors() {
        let mut g = EventGuard::default();
        feed(&mut g, ev(100, EventKind::Cgm(MgDl(120.0)))).unwrap();
        let e = feed(&mut g, ev(99, EventKind::Cgm(MgDl(120.0)))).unwrap_err();
        assert!(matches!(e, AdvisorError::OutOfOrder { .. }), "{e}");
        let e = feed(&mut g, ev(100, EventKind::Cgm(MgDl(121.0)))).unwrap_err();
        assert!(matches!(e, AdvisorError::Duplicate { .. }), "{e}");
        feed(&mut g, ev(100, EventKind::Smbg(MgDl(121.0)))).unwrap();
        let e = feed(&mut g, ev(105, EventKind::Cgm(MgDl(f64::NAN)))).unwrap_err();
        assert!(e.to_string().contains("CGM glucose"), "{e}");
        assert!(feed(&mut g, ev(105, EventKind::Cgm(MgDl(5000.0)))).is_err());
        assert!(feed(&mut g, ev(105, EventKind::Bolus(Units(-1.0)))).is_err());
        assert!(feed(&mut g, ev(-5, EventKind::Bolus(Units(1.0)))).is_err());
        let meal = |slot| EventKind::MealAnnounced {
            carbs: Grams(50.0),
            slot,
        };
        feed(&mut g, ev(420, meal(MealSlot::Lunch))).unwrap();
        let e = feed(&mut g, ev(500, meal(MealSlot::Breakfast))).unwrap_err();
        assert!(
            e.to_string().contains("breakfast announced after lunch"),
            "{e}"
        );
        feed(&mut g, ev(1440 + 420, meal(MealSlot::Breakfast))).unwrap();
        feed(&mut g, ev(1440, EventKind::DayClosed)).unwrap_err(); // out of order
        feed(&mut g, ev(1440 + 1380, EventKind::DayClosed)).unwrap();
        let e = feed(&mut g, ev(2880, EventKind::DayClosed)).unwrap_err();
        assert!(e.to_string().contains("already closed"), "{e}");
        feed(&mut g, ev(2881, EventKind::DayClosed)).unwrap();
    }

    #[test]
    fn pump_kinds_are_checked_against_their_limits() {
        let mut g = EventGuard::default();
        let temp = |rate, duration_min| EventKind::TempBasal { rate, duration_min };
        let pct = TempBasalRate::Percent;
        feed(&mut g, ev(10, temp(pct(80.0), 120))).unwrap();
        let e = feed(&mut g, ev(11, temp(pct(300.0), 60))).unwrap_err();
        assert!(e.to_string().contains("% of the scheduled rate"), "{e}");
        let e = feed(&mut g, ev(11, temp(pct(50.0), 5000))).unwrap_err();
        assert!(e.to_string().contains("temporary basal duration"), "{e}");
        let abs = |r| TempBasalRate::UnitsPerHour(abba_core::UnitsPerHour(r));
        assert!(feed(&mut g, ev(11, temp(abs(-0.1), 60))).is_err());
        feed(&mut g, ev(11, temp(abs(0.0), 0))).unwrap(); // cancel
        feed(&mut g, ev(12, EventKind::Suspend)).unwrap();
        let e = feed(&mut g, ev(12, EventKind::Suspend)).unwrap_err();
        assert!(matches!(e, AdvisorError::Duplicate { .. }), "{e}");
        feed(&mut g, ev(40, EventKind::Resume)).unwrap();
        let ext = |total, immediate, duration_min| EventKind::ExtendedBolus {
            total: Units(total),
            immediate: Units(immediate),
            duration_min,
        };
        feed(&mut g, ev(50, ext(4.0, 1.0, 120))).unwrap();
        let e = feed(&mut g, ev(51, ext(4.0, 5.0, 120))).unwrap_err();
        assert!(e.to_string().contains("at most the total"), "{e}");
        assert!(feed(&mut g, ev(51, ext(4.0, 0.0, 0))).is_err());
        assert!(feed(&mut g, ev(51, ext(80.0, 0.0, 60))).is_err());
        assert!(feed(&mut g, ev(51, ext(4.0, 0.0, 800))).is_err());
    }
}
