//! The held-out check and the grade.
//!
//! The last days of the window are never fitted: the twin predicts them
//! from their recorded insulin and carbohydrate (no meal search there), run
//! on from the fitted days. Reported: CGM RMSE and MARD, the held-out days'
//! own mean-glucose RMSE (predicting every reading by the days' mean, the
//! bar a twin must clear to say anything), and time in 70-180 and below 70
//! mg/dL observed and predicted at the same minutes, with the band.
//!
//! **Grade** ([`grade`]):
//! - *not usable* when fewer than [`MIN_FIT_DAYS`] days were fitted (a
//!   fit is then refused: [`crate::Twin::fit`]), when the window has no delivered insulin or no logged
//!   carbohydrate (nothing to identify sensitivity or meals from), when the
//!   held-out days hold fewer than half of their expected readings (CGM:
//!   half of a day at the sensor's own interval, [`Tape::cgm_interval_min`]:
//!   144 a day for a 5-minute sensor, 48 for a Libre's 15-minute historic
//!   record; meter: 2 a day), or when the held-out RMSE is not below the
//!   mean-glucose RMSE;
//! - *good* when the held-out RMSE is at most 0.8 × the mean-glucose RMSE,
//!   the MARD at most 20 %, and the predicted time below 70 and time in
//!   range within 3 and 15 percentage points of the observed;
//! - *fair* otherwise.
//!
//! A twin that is not usable is said to be so, and replays refuse it.

use crate::error::TwinError;
use crate::tape::{ReadingKind, Tape};
use abba_core::metrics::metrics_regular;
use abba_core::units::GlucoseUnit;
use abba_core::MINUTES_PER_DAY;
use serde::{Deserialize, Serialize};

/// Time in ranges and risk indices of a series.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Ranges {
    /// % of values in 70-180 mg/dL.
    pub tir_pct: f64,
    /// % of values below 70 mg/dL.
    pub below_70_pct: f64,
    /// Low blood glucose index.
    pub lbgi: f64,
    /// High blood glucose index.
    pub hbgi: f64,
}

impl Ranges {
    /// The ranges of `values` (mg/dL; abba-core's definitions). A value
    /// below 1 mg/dL (a twin run into a crash) is an error, not clamped.
    pub fn of(values: &[f64]) -> Result<Ranges, TwinError> {
        if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v >= 1.0)) {
            return Err(TwinError::Data(format!(
                "the twin predicts glucose of {v} mg/dL: the candidate is not physiological"
            )));
        }
        let m = metrics_regular(values).map_err(|e| TwinError::Data(e.to_string()))?;
        Ok(Ranges {
            tir_pct: m.tir_70_180,
            below_70_pct: m.below_70,
            lbgi: m.lbgi,
            hbgi: m.hbgi,
        })
    }

    /// `self − other`, field by field.
    pub fn minus(&self, other: &Ranges) -> Ranges {
        Ranges {
            tir_pct: self.tir_pct - other.tir_pct,
            below_70_pct: self.below_70_pct - other.below_70_pct,
            lbgi: self.lbgi - other.lbgi,
            hbgi: self.hbgi - other.hbgi,
        }
    }
}

/// A value with its 5-95 % band over the posterior draws.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Banded {
    /// At the MAP point.
    pub value: Ranges,
    /// 5th percentile of each field over the draws.
    pub low: Ranges,
    /// 95th percentile of each field over the draws.
    pub high: Ranges,
}

fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let pos = q * (v.len() - 1) as f64;
    let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

impl Banded {
    /// The MAP value and the band of `draws` (the MAP value alone when there
    /// are none).
    pub fn new(value: Ranges, draws: &[Ranges]) -> Banded {
        if draws.is_empty() {
            return Banded {
                value,
                low: value,
                high: value,
            };
        }
        let field = |f: fn(&Ranges) -> f64, q: f64| {
            let mut v: Vec<f64> = draws.iter().map(f).collect();
            quantile(&mut v, q)
        };
        let at = |q: f64| Ranges {
            tir_pct: field(|r| r.tir_pct, q),
            below_70_pct: field(|r| r.below_70_pct, q),
            lbgi: field(|r| r.lbgi, q),
            hbgi: field(|r| r.hbgi, q),
        };
        Banded {
            value,
            low: at(0.05),
            high: at(0.95),
        }
    }
}

/// The fewest fitted days a twin is made from (besides its held-out
/// days): on fewer, one day's meals and insulin stand for the person's
/// sensitivity and meals, and the held-out check says little. (The
/// trial's twin arm fits on at least as many.)
pub const MIN_FIT_DAYS: usize = 3;

/// Why a fit on `fit_days` days is not made.
pub fn too_few_fit_days(fit_days: usize) -> String {
    format!(
        "fitted on {fit_days} day{}: a twin needs at least {MIN_FIT_DAYS} fitted days besides its held-out days",
        if fit_days == 1 { "" } else { "s" }
    )
}

/// A spread of glucose (an RMSE) given in mg/dL, in `units` as printed
/// (one decimal in mg/dL, two in mmol/L).
pub fn spread(units: GlucoseUnit, mg_dl: f64) -> String {
    match units {
        GlucoseUnit::MgDl => format!("{mg_dl:.1}"),
        GlucoseUnit::MmolL => format!("{:.2}", units.from_mg_dl(mg_dl)),
    }
}

/// The plain grade of a twin.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Grade {
    /// Predicts held-out days well.
    Good,
    /// Predicts better than the mean, not well.
    Fair,
    /// Not to be used.
    NotUsable,
}

impl Grade {
    /// `good`, `fair`, `not usable`.
    pub fn name(self) -> &'static str {
        match self {
            Grade::Good => "good",
            Grade::Fair => "fair",
            Grade::NotUsable => "not usable",
        }
    }
}

/// What the held-out days showed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOut {
    /// Held-out days.
    pub days: usize,
    /// Readings on them.
    pub readings: usize,
    /// RMSE of the twin's prediction (mg/dL).
    pub rmse_mg_dl: f64,
    /// MARD of the twin's prediction (%).
    pub mard_pct: f64,
    /// RMSE of predicting each reading by the held-out days' mean (mg/dL).
    pub mean_glucose_rmse_mg_dl: f64,
    /// Observed ranges.
    pub observed: Ranges,
    /// Predicted ranges at the same minutes, with the band.
    pub predicted: Banded,
}

/// The held-out check of `pred` (per minute of the tape) against the
/// readings on the tape's days from `fit_days` on; `draws` are the same
/// predictions under posterior draws.
pub fn held_out(
    tape: &Tape,
    fit_days: usize,
    pred: &[f64],
    draws: &[Vec<f64>],
) -> Result<HeldOut, TwinError> {
    let from = tape.start_minute + fit_days as i64 * MINUTES_PER_DAY;
    let rs: Vec<(usize, f64)> = tape
        .readings
        .iter()
        .filter(|r| r.0 >= from)
        .map(|&(m, g)| ((m - tape.start_minute) as usize, g))
        .collect();
    if rs.len() < 2 {
        return Err(TwinError::Data(format!(
            "{} readings on the {} held-out days: the twin cannot be checked",
            rs.len(),
            tape.days - fit_days
        )));
    }
    let n = rs.len() as f64;
    let obs: Vec<f64> = rs.iter().map(|r| r.1).collect();
    let at = |p: &[f64]| -> Vec<f64> { rs.iter().map(|&(k, _)| p[k]).collect() };
    let p = at(pred);
    let rmse = (p
        .iter()
        .zip(&obs)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let mard = p
        .iter()
        .zip(&obs)
        .map(|(a, b)| (a - b).abs() / b)
        .sum::<f64>()
        * 100.0
        / n;
    let mean = obs.iter().sum::<f64>() / n;
    let base = (obs.iter().map(|b| (b - mean).powi(2)).sum::<f64>() / n).sqrt();
    let draws: Vec<Ranges> = draws
        .iter()
        .filter_map(|d| Ranges::of(&at(d)).ok())
        .collect();
    Ok(HeldOut {
        days: tape.days - fit_days,
        readings: rs.len(),
        rmse_mg_dl: rmse,
        mard_pct: mard,
        mean_glucose_rmse_mg_dl: base,
        observed: Ranges::of(&obs)?,
        predicted: Banded::new(Ranges::of(&p)?, &draws),
    })
}

/// The grade and its reason (module docs), its glucose in `units` (the
/// person's).
pub fn grade(
    tape: &Tape,
    fit_days: usize,
    check: Option<&HeldOut>,
    units: GlucoseUnit,
) -> (Grade, String) {
    if fit_days < MIN_FIT_DAYS {
        return (Grade::NotUsable, too_few_fit_days(fit_days));
    }
    if tape.total_insulin_u() <= 0.0 {
        return (
            Grade::NotUsable,
            "no insulin delivered in the window: insulin sensitivity cannot be identified".into(),
        );
    }
    if tape.total_carbs_g() <= 0.0 {
        return (
            Grade::NotUsable,
            "no carbohydrate logged in the window: meals cannot be identified".into(),
        );
    }
    let Some(h) = check else {
        return (
            Grade::NotUsable,
            "the held-out days could not be checked".into(),
        );
    };
    let per_day = match tape.reading_kind {
        ReadingKind::Cgm => 0.5 * MINUTES_PER_DAY as f64 / tape.cgm_interval_min(),
        ReadingKind::Smbg => 2.0,
    };
    if (h.readings as f64) < per_day * h.days as f64 {
        return (
            Grade::NotUsable,
            format!(
                "{} readings on {} held-out days: fewer than half the expected",
                h.readings, h.days
            ),
        );
    }
    let (rmse, mean) = (
        spread(units, h.rmse_mg_dl),
        spread(units, h.mean_glucose_rmse_mg_dl),
    );
    let (unit, low) = (units.label(), units.value(70.0));
    if h.rmse_mg_dl >= h.mean_glucose_rmse_mg_dl {
        return (
            Grade::NotUsable,
            format!(
                "held-out RMSE {rmse} {unit} is not below the {mean} {unit} of the days' own mean glucose"
            ),
        );
    }
    let d_tbr = (h.predicted.value.below_70_pct - h.observed.below_70_pct).abs();
    let d_tir = (h.predicted.value.tir_pct - h.observed.tir_pct).abs();
    if h.rmse_mg_dl <= 0.8 * h.mean_glucose_rmse_mg_dl
        && h.mard_pct <= 20.0
        && d_tbr <= 3.0
        && d_tir <= 15.0
    {
        (
            Grade::Good,
            format!(
                "held-out RMSE {rmse} <= 0.8 x {mean} {unit}, MARD {:.1} % <= 20 %, time below {low} within {:.1} <= 3 pp and in range within {:.1} <= 15 pp",
                h.mard_pct, d_tbr, d_tir
            ),
        )
    } else {
        (
            Grade::Fair,
            format!(
                "held-out RMSE {rmse} below the mean glucose's {mean} {unit}, but not good (MARD {:.1} %, time below {low} off by {:.1} pp, in range by {:.1} pp)",
                h.mard_pct, d_tbr, d_tir
            ),
        )
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use abba_core::{Event, EventKind, Grams, MealSlot, MgDl, Timestamp, Units, UnitsPerHour};

    /// `days` days of 5-minute CGM readings, a basal rate and three meals
    /// with their boluses a day.
    pub(crate) fn days_of_events(days: i64) -> Vec<Event> {
        let mut v = vec![Event::new(
            Timestamp(0),
            EventKind::BasalRate(UnitsPerHour(1.0)),
        )];
        for d in 0..days {
            for k in 0..288 {
                let m = d * 1440 + k * 5;
                let g = 140.0 + 40.0 * ((m as f64) / 240.0).sin();
                v.push(Event::new(Timestamp(m), EventKind::Cgm(MgDl(g))));
            }
            for (at, slot) in [
                (420, MealSlot::Breakfast),
                (750, MealSlot::Lunch),
                (1110, MealSlot::Dinner),
            ] {
                let m = d * 1440 + at;
                v.push(Event::new(
                    Timestamp(m),
                    EventKind::MealAnnounced {
                        carbs: Grams(50.0),
                        slot,
                    },
                ));
                v.push(Event::new(Timestamp(m + 1), EventKind::Bolus(Units(5.0))));
            }
        }
        v.sort_by_key(|e| e.at);
        v
    }

    fn ranges(tir: f64, below: f64) -> Ranges {
        Ranges {
            tir_pct: tir,
            below_70_pct: below,
            lbgi: 1.0,
            hbgi: 3.0,
        }
    }

    #[test]
    fn fewer_fitted_days_than_the_least_are_not_usable() {
        let tape = Tape::from_events(&days_of_events(4), 4, 1.0).unwrap();
        for fit_days in 0..MIN_FIT_DAYS {
            let (g, why) = grade(&tape, fit_days, None, GlucoseUnit::MgDl);
            assert_eq!(g, Grade::NotUsable, "{fit_days}");
            assert!(why.contains("at least 3 fitted days"), "{why}");
        }
    }

    #[test]
    fn the_grade_speaks_the_persons_unit() {
        let tape = Tape::from_events(&days_of_events(5), 5, 1.0).unwrap();
        let h = HeldOut {
            days: 2,
            readings: 576,
            rmse_mg_dl: 18.0,
            mard_pct: 9.0,
            mean_glucose_rmse_mg_dl: 36.0,
            observed: ranges(70.0, 2.0),
            predicted: Banded {
                value: ranges(72.0, 2.5),
                low: ranges(65.0, 1.0),
                high: ranges(80.0, 4.0),
            },
        };
        let (g, mg) = grade(&tape, 3, Some(&h), GlucoseUnit::MgDl);
        assert_eq!(g, Grade::Good);
        assert!(
            mg.contains("0.8 x 36.0 mg/dL") && mg.contains("below 70 "),
            "{mg}"
        );
        let (g, mmol) = grade(&tape, 3, Some(&h), GlucoseUnit::MmolL);
        assert_eq!(g, Grade::Good);
        assert!(!mmol.contains("mg/dL"), "{mmol}");
        assert!(
            mmol.contains("RMSE 1.00 <= 0.8 x 2.00 mmol/L") && mmol.contains("below 3.9 "),
            "{mmol}"
        );
    }
}
