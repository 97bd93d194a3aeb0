//! A person's recorded days as the simulator's inputs: per-minute insulin
//! as delivered, carbohydrate entries, and glucose readings, on the
//! advisor's local-minute clock (minute 0 = 00:00 of day 1 in the person's
//! zone).
//!
//! Insulin follows the delivery semantics of [`abba_core::event`]: the
//! scheduled basal rate, temporary basals (absolute or percent) in its
//! place, nothing between `Suspend` and `Resume` (which also cancels the
//! rest of an extended bolus), boluses at once and extended boluses spread
//! evenly. For closed-loop data this is the insulin the loop delivered.
//! A bolus within [`MEAL_BOLUS_WINDOW_MIN`] of a main meal's carbohydrate
//! entry is that meal's bolus (a carb-ratio what-if rescales it).

use crate::error::TwinError;
use abba_core::{Event, EventKind, MealSlot, TempBasalRate, MINUTES_PER_DAY};
use serde::{Deserialize, Serialize};

/// Minutes either side of a main meal within which a bolus is its bolus.
pub const MEAL_BOLUS_WINDOW_MIN: i64 = 20;

/// One carbohydrate entry (or a meal the fit found).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Meal {
    /// Local minute since 00:00 of day 1.
    pub minute: i64,
    /// Grams as logged (or as estimated for a found meal).
    pub grams: f64,
    /// Meal slot (a found meal is a snack).
    pub slot: MealSlot,
}

/// One bolus: immediate units at `minute`, and an extended part at
/// `extended_u_per_min` over `[minute, extended_end)` (ended early by a
/// suspension).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bolus {
    /// Local minute.
    pub minute: i64,
    /// Units delivered at once.
    pub immediate_u: f64,
    /// Rate of the extended part (U/min; 0 for a plain bolus).
    pub extended_u_per_min: f64,
    /// First minute after the extended part.
    pub extended_end: i64,
    /// The main meal this bolus belongs to (index into `MealSlot::MAIN`).
    pub meal_slot: Option<usize>,
}

/// What the basal program does in one minute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BasalMinute {
    /// Scheduled rate (U/h).
    pub scheduled_u_per_h: f64,
    /// Temporary basal in force, if any.
    pub temp: Option<TempBasalRate>,
    /// Delivery suspended.
    pub suspended: bool,
}

impl BasalMinute {
    /// Delivered U/min with the scheduled rate replaced by `scheduled`
    /// (an absolute temporary basal scaled by the same factor).
    pub fn delivered_u_per_min(&self, scheduled_u_per_h: f64) -> f64 {
        if self.suspended {
            return 0.0;
        }
        let rate = match self.temp {
            None => scheduled_u_per_h,
            Some(TempBasalRate::Percent(p)) => scheduled_u_per_h * p / 100.0,
            Some(TempBasalRate::UnitsPerHour(r)) if self.scheduled_u_per_h > 0.0 => {
                r.0 * scheduled_u_per_h / self.scheduled_u_per_h
            }
            Some(TempBasalRate::UnitsPerHour(r)) => r.0,
        };
        rate / 60.0
    }
}

/// Which device a reading came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ReadingKind {
    /// A CGM reading (interstitial glucose).
    Cgm,
    /// A meter reading.
    Smbg,
}

/// The recorded window: `days` whole local days from `start_minute`.
#[derive(Debug, Clone)]
pub struct Tape {
    /// First minute (00:00 of the first day).
    pub start_minute: i64,
    /// Whole days.
    pub days: usize,
    /// Basal program per minute of the window.
    pub basal: Vec<BasalMinute>,
    /// Boluses in the window.
    pub boluses: Vec<Bolus>,
    /// Carbohydrate entries in the window.
    pub meals: Vec<Meal>,
    /// Glucose readings (minute, mg/dL), of one kind: CGM when there are
    /// any, else meter readings.
    pub readings: Vec<(i64, f64)>,
    /// The kind of `readings`.
    pub reading_kind: ReadingKind,
}

impl Tape {
    /// The sensor's reading interval in minutes: the median gap between
    /// consecutive readings, taken between 5 (today's CGMs) and 15 (a
    /// Libre's historic record), so that a gap-ridden record is not
    /// mistaken for a slower sensor; 5 when there are fewer than two
    /// readings.
    pub fn cgm_interval_min(&self) -> f64 {
        let mut gaps: Vec<i64> = self
            .readings
            .windows(2)
            .map(|w| w[1].0 - w[0].0)
            .filter(|g| *g > 0)
            .collect();
        if gaps.is_empty() {
            return 5.0;
        }
        let mid = gaps.len() / 2;
        let (_, median, _) = gaps.select_nth_unstable(mid);
        (*median as f64).clamp(5.0, 15.0)
    }

    /// The last `days` local days of `events` that hold readings (the last
    /// day is the day of the last reading). `basal_u_per_h` is the
    /// scheduled basal in force before the log's first `BasalRate` (the
    /// person's therapy: a log whose profile began before day 1 has none);
    /// events before the window set the basal program in force at its start.
    pub fn from_events(
        events: &[Event],
        days: usize,
        basal_u_per_h: f64,
    ) -> Result<Tape, TwinError> {
        if days == 0 {
            return Err(TwinError::Setting("--days must be at least 1".into()));
        }
        let has_cgm = events.iter().any(|e| matches!(e.kind, EventKind::Cgm(_)));
        let reading = |k: &EventKind| match (k, has_cgm) {
            (EventKind::Cgm(g), true) => Some(g.0),
            (EventKind::Smbg(g), false) => Some(g.0),
            _ => None,
        };
        let Some(last) = events.iter().rev().find(|e| reading(&e.kind).is_some()) else {
            return Err(TwinError::Data(
                "no CGM or meter readings in the log: a twin needs glucose readings".into(),
            ));
        };
        let last_day = last.at.day_index();
        let first_day =
            (last_day + 1 - days as i64).max(events.first().map_or(last_day, |e| e.at.day_index()));
        let start = first_day * MINUTES_PER_DAY;
        let n_days = (last_day - first_day + 1) as usize;
        let n = n_days * MINUTES_PER_DAY as usize;
        let end = start + n as i64;

        let mut basal = Vec::with_capacity(n);
        let mut boluses: Vec<Bolus> = Vec::new();
        let mut meals = Vec::new();
        let mut readings = Vec::new();
        if !(basal_u_per_h.is_finite() && basal_u_per_h >= 0.0) {
            return Err(TwinError::Setting(format!(
                "the basal rate in force must be a finite number >= 0 U/h, got {basal_u_per_h}"
            )));
        }
        let mut state = BasalMinute {
            scheduled_u_per_h: basal_u_per_h,
            temp: None,
            suspended: false,
        };
        let mut temp_end = i64::MIN;
        let mut minute = events.first().map_or(start, |e| e.at.0.min(start));
        let mut i = 0;
        while minute < end {
            while i < events.len() && events[i].at.0 == minute {
                let e = events[i];
                i += 1;
                match e.kind {
                    EventKind::BasalRate(r) => state.scheduled_u_per_h = r.0,
                    EventKind::TempBasal { rate, duration_min } => {
                        if duration_min == 0 {
                            state.temp = None;
                        } else {
                            state.temp = Some(rate);
                            temp_end = minute + i64::from(duration_min);
                        }
                    }
                    EventKind::Suspend => {
                        state.suspended = true;
                        for b in boluses.iter_mut() {
                            if b.extended_end > minute {
                                b.extended_end = minute;
                            }
                        }
                    }
                    EventKind::Resume => state.suspended = false,
                    _ if minute < start => {}
                    EventKind::Bolus(u) => boluses.push(Bolus {
                        minute,
                        immediate_u: u.0,
                        extended_u_per_min: 0.0,
                        extended_end: minute,
                        meal_slot: None,
                    }),
                    EventKind::ExtendedBolus {
                        total,
                        immediate,
                        duration_min,
                    } => {
                        // A new extended bolus replaces the rest of a running one.
                        for b in boluses.iter_mut() {
                            if b.extended_end > minute {
                                b.extended_end = minute;
                            }
                        }
                        let rest = (total.0 - immediate.0).max(0.0);
                        let d = i64::from(duration_min.max(1));
                        boluses.push(Bolus {
                            minute,
                            immediate_u: immediate.0,
                            extended_u_per_min: rest / d as f64,
                            extended_end: minute + d,
                            meal_slot: None,
                        });
                    }
                    EventKind::MealAnnounced { carbs, slot } => meals.push(Meal {
                        minute,
                        grams: carbs.0,
                        slot,
                    }),
                    ref k => {
                        if let Some(g) = reading(k) {
                            readings.push((minute, g));
                        }
                    }
                }
            }
            if state.temp.is_some() && minute >= temp_end {
                state.temp = None;
            }
            if minute >= start {
                basal.push(state);
            }
            // Skip quiet stretches before the window in one go.
            minute = if minute < start {
                let next = events.get(i).map_or(start, |e| e.at.0);
                let next = next.min(start);
                if state.temp.is_some() && temp_end > minute {
                    next.min(temp_end).max(minute + 1)
                } else {
                    next.max(minute + 1)
                }
            } else {
                minute + 1
            };
        }
        link_meal_boluses(&meals, &mut boluses);
        Ok(Tape {
            start_minute: start,
            days: n_days,
            basal,
            boluses,
            meals,
            readings,
            reading_kind: if has_cgm {
                ReadingKind::Cgm
            } else {
                ReadingKind::Smbg
            },
        })
    }

    /// Minutes in the window.
    pub fn minutes(&self) -> usize {
        self.basal.len()
    }

    /// Per-minute insulin (U/min) with the scheduled basal at `basal(minute
    /// index, recorded scheduled U/h)` and each main meal's bolus times
    /// `meal_bolus_factor[slot]`.
    pub fn insulin(
        &self,
        basal: &dyn Fn(usize, f64) -> f64,
        meal_bolus_factor: [f64; 3],
    ) -> Vec<f64> {
        let mut u: Vec<f64> = self
            .basal
            .iter()
            .enumerate()
            .map(|(k, b)| b.delivered_u_per_min(basal(k, b.scheduled_u_per_h)))
            .collect();
        let n = u.len() as i64;
        for b in &self.boluses {
            let f = b.meal_slot.map_or(1.0, |s| meal_bolus_factor[s]);
            let k = b.minute - self.start_minute;
            if (0..n).contains(&k) {
                u[k as usize] += f * b.immediate_u;
            }
            for m in b.minute..b.extended_end {
                let k = m - self.start_minute;
                if (0..n).contains(&k) {
                    u[k as usize] += f * b.extended_u_per_min;
                }
            }
        }
        u
    }

    /// Per-minute insulin as recorded.
    pub fn recorded_insulin(&self) -> Vec<f64> {
        self.insulin(&|_, s| s, [1.0; 3])
    }

    /// Total insulin delivered in the window (U).
    pub fn total_insulin_u(&self) -> f64 {
        self.recorded_insulin().iter().sum()
    }

    /// Total carbohydrate logged in the window (g).
    pub fn total_carbs_g(&self) -> f64 {
        self.meals.iter().map(|m| m.grams).sum()
    }

    /// Mean scheduled basal rate over the window (U/h).
    pub fn mean_scheduled_basal_u_per_h(&self) -> f64 {
        let n = self.basal.len().max(1) as f64;
        self.basal.iter().map(|b| b.scheduled_u_per_h).sum::<f64>() / n
    }

    /// Local day index (0 = day 1) of a minute.
    pub fn day_of(minute: i64) -> i64 {
        minute.div_euclid(MINUTES_PER_DAY)
    }

    /// The carb ratio each main meal's bolus implies (median of grams per
    /// unit of its meal boluses; `None` for a slot without one).
    pub fn used_carb_ratios(&self) -> [Option<f64>; 3] {
        let mut out = [None; 3];
        for (s, slot) in out.iter_mut().enumerate() {
            let mut r: Vec<f64> = self
                .meals
                .iter()
                .filter(|m| m.slot.main_index() == Some(s))
                .filter_map(|m| {
                    let u: f64 = self
                        .boluses
                        .iter()
                        .filter(|b| b.meal_slot == Some(s))
                        .filter(|b| (b.minute - m.minute).abs() <= MEAL_BOLUS_WINDOW_MIN)
                        .map(|b| {
                            b.immediate_u
                                + b.extended_u_per_min * (b.extended_end - b.minute) as f64
                        })
                        .sum();
                    (u > 0.0).then(|| m.grams / u)
                })
                .collect();
            if !r.is_empty() {
                r.sort_by(f64::total_cmp);
                *slot = Some(r[r.len() / 2]);
            }
        }
        out
    }
}

/// Marks each main meal's nearest bolus within the window as its bolus.
fn link_meal_boluses(meals: &[Meal], boluses: &mut [Bolus]) {
    for m in meals {
        let Some(slot) = m.slot.main_index() else {
            continue;
        };
        let nearest = boluses
            .iter_mut()
            .filter(|b| b.meal_slot.is_none())
            .filter(|b| (b.minute - m.minute).abs() <= MEAL_BOLUS_WINDOW_MIN)
            .min_by_key(|b| (b.minute - m.minute).abs());
        if let Some(b) = nearest {
            b.meal_slot = Some(slot);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_core::{Grams, MgDl, Timestamp, Units, UnitsPerHour};

    fn ev(at: i64, kind: EventKind) -> Event {
        Event::new(Timestamp(at), kind)
    }

    #[test]
    fn delivered_insulin_follows_temp_basals_suspensions_and_extended_boluses() {
        let events = vec![
            ev(0, EventKind::BasalRate(UnitsPerHour(1.2))),
            ev(0, EventKind::Cgm(MgDl(120.0))),
            ev(
                60,
                EventKind::TempBasal {
                    rate: TempBasalRate::Percent(50.0),
                    duration_min: 30,
                },
            ),
            ev(
                120,
                EventKind::ExtendedBolus {
                    total: Units(3.0),
                    immediate: Units(1.0),
                    duration_min: 20,
                },
            ),
            ev(130, EventKind::Suspend),
            ev(140, EventKind::Resume),
            ev(
                420,
                EventKind::MealAnnounced {
                    carbs: Grams(50.0),
                    slot: MealSlot::Breakfast,
                },
            ),
            ev(425, EventKind::Bolus(Units(5.0))),
            ev(1439, EventKind::Cgm(MgDl(110.0))),
        ];
        let t = Tape::from_events(&events, 1, 0.0).unwrap();
        let u = t.recorded_insulin();
        assert_eq!(u.len(), 1440);
        assert!((u[10] - 0.02).abs() < 1e-12);
        assert!(
            (u[70] - 0.01).abs() < 1e-12,
            "half rate during the temp basal"
        );
        assert!((u[95] - 0.02).abs() < 1e-12, "temp basal ended");
        // 1 U at once, 0.1 U/min for 10 minutes, then the suspension ends it.
        assert!((u[120] - (1.0 + 0.1 + 0.02)).abs() < 1e-12);
        assert!((u[129] - 0.12).abs() < 1e-12);
        assert_eq!(u[130], 0.0);
        assert!((u[140] - 0.02).abs() < 1e-12);
        assert_eq!(t.boluses[1].meal_slot, Some(0));
        assert_eq!(t.used_carb_ratios()[0], Some(10.0));
        // Halving breakfast boluses halves that bolus only.
        let half = t.insulin(&|_, s| s, [0.5, 1.0, 1.0]);
        assert!((half[425] - (2.5 + 0.02)).abs() < 1e-12);
        assert!((half[120] - u[120]).abs() < 1e-12);
        assert_eq!(t.readings, vec![(0, 120.0), (1439, 110.0)]);
    }

    #[test]
    fn the_window_is_the_last_days_with_the_basal_in_force_at_its_start() {
        let mut events = vec![ev(0, EventKind::BasalRate(UnitsPerHour(0.6)))];
        for d in 0..5 {
            events.push(ev(d * 1440 + 600, EventKind::Cgm(MgDl(100.0))));
        }
        let t = Tape::from_events(&events, 2, 0.0).unwrap();
        assert_eq!(t.start_minute, 3 * 1440);
        assert_eq!(t.days, 2);
        assert!((t.recorded_insulin()[0] - 0.01).abs() < 1e-12);
        assert_eq!(t.readings.len(), 2);
        // Without a BasalRate record, the basal in force is the one given.
        let cgm_only: Vec<Event> = events[1..].to_vec();
        let t = Tape::from_events(&cgm_only, 2, 0.9).unwrap();
        assert!((t.recorded_insulin()[0] - 0.015).abs() < 1e-12);
        let none = Tape::from_events(&[ev(0, EventKind::Bolus(Units(1.0)))], 2, 1.0).unwrap_err();
        assert!(
            none.to_string().contains("no CGM or meter readings"),
            "{none}"
        );
    }

    #[test]
    fn the_sensor_interval_is_the_median_gap_so_a_libre_is_not_taken_for_a_gappy_cgm() {
        let libre: Vec<Event> = (0..96)
            .map(|k| ev(k * 15, EventKind::Cgm(MgDl(100.0))))
            .collect();
        let t = Tape::from_events(&libre, 1, 0.0).unwrap();
        assert_eq!(t.cgm_interval_min(), 15.0);
        // A 5-minute sensor with a 3-hour gap stays a 5-minute sensor.
        let gappy: Vec<Event> = (0..288)
            .filter(|k| !(100..136).contains(k))
            .map(|k| ev(k * 5, EventKind::Cgm(MgDl(100.0))))
            .collect();
        let t = Tape::from_events(&gappy, 1, 0.0).unwrap();
        assert_eq!(t.cgm_interval_min(), 5.0);
        // A 1-minute record expects no more than a 5-minute one.
        let fast: Vec<Event> = (0..1440)
            .map(|k| ev(k, EventKind::Cgm(MgDl(100.0))))
            .collect();
        assert_eq!(
            Tape::from_events(&fast, 1, 0.0).unwrap().cgm_interval_min(),
            5.0
        );
    }
}
