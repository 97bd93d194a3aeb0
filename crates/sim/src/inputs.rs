//! Open-loop input days: per-minute eaten carbohydrate and infused insulin.
//!
//! [`InputDay`] is what `abba simulate` replays; the built-in days below are
//! used by the README example, the benchmark and the accuracy checks. Each
//! builder turns a meal plan into 5 g/min eating through the same
//! [`EatingQueue`] the closed loop uses.
//!
//! An input day read from a file ([`InputDay::from_csv`]) is checked row by
//! row before anything is simulated: every rate must be a finite number
//! `>= 0` and within the physical limits [`MAX_CHO_G_PER_MIN`] and
//! [`MAX_INSULIN_U_PER_MIN`].

mod file;

pub use file::INPUT_COLUMNS;

use crate::patient::{EatingQueue, Patient, PatientParams, EAT_RATE_G_PER_MIN};
use crate::SimError;
use abba_core::MINUTES_PER_DAY;

/// The most carbohydrate an input minute may carry (g/min): the model's
/// eating rate. simglucose (and [`EatingQueue`]) eat an announced meal at
/// 5 g/min, so the model never sees a faster rate; a meal is given as
/// several minutes of at most 5 g/min (50 g is ten such minutes).
pub const MAX_CHO_G_PER_MIN: f64 = EAT_RATE_G_PER_MIN;

/// The most insulin an input minute may carry (U/min): the protocol pump's
/// largest bolus, 30 U ([`crate::devices::PumpConfig`]'s default
/// `max_bolus_u`), given within one minute as the reference days give a
/// bolus, plus one minute of its largest basal rate, 30 U/h. More than this
/// in one minute is not a dose a pump or a pen delivers.
pub const MAX_INSULIN_U_PER_MIN: f64 = 30.0 + 30.0 / 60.0;

/// Constant rates over one minute.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MinuteRates {
    /// Carbohydrate eaten during the minute (g/min).
    pub cho_g_per_min: f64,
    /// Insulin infused during the minute, basal plus bolus (U/min).
    pub insulin_u_per_min: f64,
}

/// A sequence of minutes of open-loop inputs, starting at minute 0.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct InputDay {
    /// One entry per minute.
    pub minutes: Vec<MinuteRates>,
}

/// One announced meal of a built-in day.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannedMeal {
    /// Minute the meal is announced (eating starts then).
    pub minute: usize,
    /// Carbohydrate (g).
    pub grams: f64,
    /// Bolus given in the meal's first minute (U); 0 for none.
    pub bolus_u: f64,
}

impl MinuteRates {
    /// Checks both rates: finite, `>= 0` and within [`MAX_CHO_G_PER_MIN`]
    /// and [`MAX_INSULIN_U_PER_MIN`]. The error names the column
    /// (`cho_g_per_min` or `insulin_u_per_min`), the value and the limit.
    pub fn check(&self) -> Result<(), String> {
        check_rate(
            "cho_g_per_min",
            self.cho_g_per_min,
            MAX_CHO_G_PER_MIN,
            "g/min",
            "the model eats at most 5 g/min (simglucose's eating rate); spread a meal over several minutes",
        )?;
        check_rate(
            "insulin_u_per_min",
            self.insulin_u_per_min,
            MAX_INSULIN_U_PER_MIN,
            "U/min",
            "the pump's largest bolus (30 U) plus a minute of its largest basal rate (30 U/h)",
        )
    }
}

fn check_rate(column: &str, v: f64, max: f64, unit: &str, why: &str) -> Result<(), String> {
    if !(v.is_finite() && v >= 0.0) {
        return Err(format!(
            "column '{column}': expected a finite rate >= 0 {unit}, got {v}"
        ));
    }
    if v > max {
        return Err(format!(
            "column '{column}': {v} {unit} is above the limit of {max} {unit} ({why})"
        ));
    }
    Ok(())
}

impl InputDay {
    /// Checks every minute with [`MinuteRates::check`]; the error names the
    /// minute (from 0).
    pub fn validate(&self) -> Result<(), SimError> {
        for (m, r) in self.minutes.iter().enumerate() {
            r.check()
                .map_err(|reason| SimError::Config(format!("input minute {m}: {reason}")))?;
        }
        Ok(())
    }

    /// Builds `n_minutes` of inputs: basal `basal_u_per_min` except where
    /// `suspended(minute)` is true, plus the meals (eaten at 5 g/min) and
    /// their boluses (in the meal's first minute, as the reference day).
    pub fn from_plan(
        n_minutes: usize,
        basal_u_per_min: f64,
        meals: &[PlannedMeal],
        suspended: impl Fn(usize) -> bool,
    ) -> Self {
        let mut queue = EatingQueue::new();
        let mut minutes = Vec::with_capacity(n_minutes);
        for m in 0..n_minutes {
            let mut insulin = if suspended(m) { 0.0 } else { basal_u_per_min };
            for meal in meals.iter().filter(|meal| meal.minute == m) {
                queue.add(meal.grams);
                insulin += meal.bolus_u;
            }
            minutes.push(MinuteRates {
                cho_g_per_min: queue.eat_minute(),
                insulin_u_per_min: insulin,
            });
        }
        Self { minutes }
    }

    /// The paper's standard day for a patient with carb ratio `cr_g_per_u`:
    /// breakfast 07:00 50 g, lunch 12:00 60 g, dinner 18:30 80 g, each
    /// bolused CHO/CR at meal time; bedtime snack 23:00 15 g without bolus;
    /// the steady-state basal rate.
    pub fn standard(params: &PatientParams, cr_g_per_u: f64) -> Self {
        let meals = [
            PlannedMeal {
                minute: 420,
                grams: 50.0,
                bolus_u: 50.0 / cr_g_per_u,
            },
            PlannedMeal {
                minute: 720,
                grams: 60.0,
                bolus_u: 60.0 / cr_g_per_u,
            },
            PlannedMeal {
                minute: 1110,
                grams: 80.0,
                bolus_u: 80.0 / cr_g_per_u,
            },
            PlannedMeal {
                minute: 1380,
                grams: 15.0,
                bolus_u: 0.0,
            },
        ];
        Self::from_plan(
            MINUTES_PER_DAY as usize,
            params.basal_u_per_min(),
            &meals,
            |_| false,
        )
    }

    /// Simulates `params` from its initial state through these inputs and
    /// returns plasma glucose (mg/dL) at every minute 0..=N.
    pub fn simulate(&self, patient: &mut Patient, sensitivity: f64) -> Result<Vec<f64>, SimError> {
        let mut bg = Vec::with_capacity(self.minutes.len() + 1);
        bg.push(patient.glucose_mg_dl());
        for r in &self.minutes {
            patient.step(r.cho_g_per_min, r.insulin_u_per_min, sensitivity)?;
            bg.push(patient.glucose_mg_dl());
        }
        Ok(bg)
    }

    /// Total carbohydrate eaten (g).
    pub fn total_cho_g(&self) -> f64 {
        self.minutes.iter().map(|r| r.cho_g_per_min).sum()
    }

    /// Total insulin infused (U).
    pub fn total_insulin_u(&self) -> f64 {
        self.minutes.iter().map(|r| r.insulin_u_per_min).sum()
    }
}

/// Named harder days used to check the solver beyond the reference day.
pub mod hard_days {
    use super::*;

    /// Names of the built-in hard days.
    pub const NAMES: [&str; 5] = [
        "standard",
        "overlapping-meals",
        "missed-boluses",
        "insulin-suspension",
        "long-fast",
    ];

    /// Builds the hard day `name` for a patient with carb ratio `cr`.
    pub fn build(name: &str, params: &PatientParams, cr: f64) -> Option<InputDay> {
        let basal = params.basal_u_per_min();
        let day = 1440;
        Some(match name {
            "standard" => InputDay::standard(params, cr),
            // A second meal announced while the first is still being eaten,
            // and a snack on top of a stomach that is still full.
            "overlapping-meals" => InputDay::from_plan(
                day,
                basal,
                &[
                    PlannedMeal {
                        minute: 420,
                        grams: 70.0,
                        bolus_u: 70.0 / cr,
                    },
                    PlannedMeal {
                        minute: 428,
                        grams: 37.0,
                        bolus_u: 37.0 / cr,
                    },
                    PlannedMeal {
                        minute: 480,
                        grams: 23.0,
                        bolus_u: 0.0,
                    },
                    PlannedMeal {
                        minute: 720,
                        grams: 90.0,
                        bolus_u: 90.0 / cr,
                    },
                    PlannedMeal {
                        minute: 745,
                        grams: 40.0,
                        bolus_u: 0.0,
                    },
                    PlannedMeal {
                        minute: 1110,
                        grams: 120.0,
                        bolus_u: 120.0 / cr,
                    },
                ],
                |_| false,
            ),
            // Meals without boluses: long hyperglycaemia, renal excretion.
            "missed-boluses" => InputDay::from_plan(
                day,
                basal,
                &[
                    PlannedMeal {
                        minute: 420,
                        grams: 60.0,
                        bolus_u: 0.0,
                    },
                    PlannedMeal {
                        minute: 720,
                        grams: 80.0,
                        bolus_u: 0.0,
                    },
                    PlannedMeal {
                        minute: 1110,
                        grams: 100.0,
                        bolus_u: 100.0 / cr,
                    },
                ],
                |_| false,
            ),
            // Six hours with no insulin at all after a bolused breakfast:
            // X falls towards -Ib and Uid may turn negative.
            "insulin-suspension" => InputDay::from_plan(
                day,
                basal,
                &[PlannedMeal {
                    minute: 420,
                    grams: 50.0,
                    bolus_u: 50.0 / cr,
                }],
                |m| (600..960).contains(&m),
            ),
            // 24 hours without food, with a large correction bolus in the
            // morning: a deep, long fall.
            "long-fast" => InputDay::from_plan(
                day,
                basal,
                &[PlannedMeal {
                    minute: 480,
                    grams: 0.0,
                    bolus_u: 4.0,
                }],
                |_| false,
            ),
            _ => return None,
        })
    }
}
