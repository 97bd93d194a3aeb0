//! A tiny synthetic "device" for the advisor's tests (not a patient model;
//! the advisor must not depend on abba-sim). Glucose is a deterministic
//! function of how the settings compare with the toy person's true needs, so
//! the direction of every adaptation can be checked.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::{Advisor, Mode};
use abba_core::{
    Event, EventKind, Grams, GramsPerUnit, MealSlot, MgDl, TherapySettings, Timestamp, Units,
    UnitsPerHour,
};

/// The toy person's true needs.
#[derive(Clone, Copy, Debug)]
pub struct Toy {
    /// Basal rate that keeps fasting glucose at 110.
    pub basal_need: f64,
    /// Carb ratios that keep post-meal glucose at ~130.
    pub cr_need: [f64; 3],
    /// Skip lunch on these day indices.
    pub skip_lunch_days: &'static [i64],
    /// Omit the pre-lunch SMBG on these day indices.
    pub no_prelunch_smbg_days: &'static [i64],
}

pub fn start() -> TherapySettings {
    TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap()
}

pub fn t(day: i64, minute: i64) -> Timestamp {
    Timestamp::from_day_and_minute(day, minute)
}

fn wobble(minutes: i64) -> f64 {
    // deterministic small variation, no randomness needed
    (minutes as f64 * 0.0137).sin() * 6.0 + (minutes as f64 * 0.0031).cos() * 4.0
}

impl Toy {
    /// Glucose at `at` given the settings in force for the last basal and meals.
    fn glucose(&self, at: Timestamp, basal: f64, meal_cr: &[Option<f64>; 3]) -> f64 {
        let fasting = 110.0 + 200.0 * (self.basal_need / basal - 1.0);
        let m = at.minute_of_day();
        let meal = |i: usize, from: i64, to: i64| -> f64 {
            match meal_cr[i] {
                Some(cr) if m >= from && m < to => 20.0 + 150.0 * (cr / self.cr_need[i] - 1.0),
                _ => 0.0,
            }
        };
        let g =
            fasting + meal(0, 420, 720) + meal(1, 720, 1110) + meal(2, 1110, 1440) + wobble(at.0);
        g.clamp(40.0, 400.0)
    }

    /// Runs the closed loop from 00:00 of day index `first_day` for `days` days,
    /// feeding `adv`; returns every event fed (all accepted).
    pub fn run(
        &self,
        adv: &mut dyn Advisor,
        mode: Mode,
        first_day: i64,
        days: i64,
        init_days: i64,
    ) -> Vec<Event> {
        let mut events = Vec::new();
        let feed = |adv: &mut dyn Advisor, e: Event, events: &mut Vec<Event>| {
            adv.observe(&e)
                .unwrap_or_else(|err| panic!("event {e:?} rejected: {err}"));
            events.push(e);
        };
        let mut basal_sent: Option<f64> = None;
        let mut meal_cr: [Option<f64>; 3] = [None; 3];
        for day in first_day..first_day + days {
            let in_init = day < first_day + init_days;
            for minute in 0..1440 {
                let at = t(day, minute);
                let basal = adv.settings().basal.0;
                if minute == 0 {
                    meal_cr = [None; 3];
                }
                let g = self.glucose(at, basal, &meal_cr);
                // readings
                if minute % 5 == 0 && (mode == Mode::Cgm || in_init) {
                    feed(adv, Event::new(at, EventKind::Cgm(MgDl(g))), &mut events);
                }
                if mode == Mode::Cgm && minute == 0 && day > first_day {
                    feed(adv, Event::new(at, EventKind::DayClosed), &mut events);
                }
                let smbg_time = [400, 700, 1090, 1380].contains(&minute);
                let omit = minute == 700 && self.no_prelunch_smbg_days.contains(&day);
                if mode == Mode::Smbg && smbg_time && !omit {
                    feed(
                        adv,
                        Event::new(at, EventKind::Smbg(MgDl(g.round()))),
                        &mut events,
                    );
                }
                // meals
                for (i, meal_min) in [(0usize, 420i64), (1, 720), (2, 1110)] {
                    if minute == meal_min && !(i == 1 && self.skip_lunch_days.contains(&day)) {
                        let carbs = [50.0, 60.0, 80.0][i];
                        feed(
                            adv,
                            Event::new(
                                at,
                                EventKind::MealAnnounced {
                                    carbs: Grams(carbs),
                                    slot: MealSlot::MAIN[i],
                                },
                            ),
                            &mut events,
                        );
                        let cr = adv.settings().carb_ratio[i].0;
                        meal_cr[i] = Some(cr);
                        feed(
                            adv,
                            Event::new(at, EventKind::Bolus(Units(carbs / cr))),
                            &mut events,
                        );
                    }
                }
                let basal_now = adv.settings().basal.0;
                if basal_sent != Some(basal_now) {
                    feed(
                        adv,
                        Event::new(at, EventKind::BasalRate(UnitsPerHour(basal_now))),
                        &mut events,
                    );
                    basal_sent = Some(basal_now);
                }
                if mode == Mode::Smbg && minute == 1380 {
                    feed(adv, Event::new(at, EventKind::DayClosed), &mut events);
                    // a basal change at 23:00 is delivered from the same minute
                    let b = adv.settings().basal.0;
                    if basal_sent != Some(b) {
                        feed(
                            adv,
                            Event::new(at, EventKind::BasalRate(UnitsPerHour(b))),
                            &mut events,
                        );
                        basal_sent = Some(b);
                    }
                }
            }
        }
        events
    }
}

pub const NEUTRAL: Toy = Toy {
    basal_need: 1.0,
    cr_need: [10.0, 10.0, 10.0],
    skip_lunch_days: &[],
    no_prelunch_smbg_days: &[],
};
