//! Sorting a day's glucose deviations into carb absorption, ISF, basal and
//! unannounced-meal periods (oref0 0.7.1 lib/autotune-prep/categorize.js).

use super::iob::{dosed, doses, iob_at};
use super::js;
use super::profile::Profile;
use super::{Carbs, DayData, Insulin, LocalClock, Reading};

/// Where a glucose datum went.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Category {
    /// Carb absorption (tunes the carb sensitivity factor).
    Csf,
    /// Correction insulin dominates (tunes ISF).
    Isf,
    /// Basal insulin dominates (tunes the hourly basals).
    Basal,
    /// An unannounced meal (or other unexplained rise).
    Uam,
}

/// Start or end of a carb-absorption stretch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Absorption {
    /// First datum of a stretch.
    Start,
    /// Last datum of a stretch.
    End,
}

/// One 5-minute glucose datum with what oref0 computes for it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Datum {
    /// When (ms since the epoch).
    pub at_ms: i64,
    /// Glucose (mg/dL; the mean of readings less than 2 min apart).
    pub glucose: f64,
    /// Mean change per 5 min over the last 20 min, to 0.01.
    pub avg_delta: f64,
    /// Blood-glucose impact of insulin activity (mg/dL per 5 min), to 0.01.
    pub bgi: f64,
    /// avg_delta − bgi, to 0.01 (positive deviations below 80 mg/dL are 0).
    pub deviation: f64,
    /// Where it went first (before UAM or CSF data are folded into basal/ISF).
    pub category: Category,
    /// Carb-absorption stretch marks.
    pub meal_absorption: Option<Absorption>,
    /// Carbs of the meal(s) being absorbed (CSF data).
    pub meal_carbs: f64,
}

/// One meal's carb-ratio period: from the carbs until COB is zero and IOB
/// is below half the basal rate.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CrDatum {
    /// IOB at the start (U).
    pub initial_iob: f64,
    /// Glucose at the start.
    pub initial_bg: f64,
    /// Start (ms).
    pub initial_ms: i64,
    /// IOB at the end (U).
    pub end_iob: f64,
    /// Glucose at the end.
    pub end_bg: f64,
    /// End (ms).
    pub end_ms: i64,
    /// Carbs entered in the period (g).
    pub carbs: f64,
    /// Insulin delivered in the period (U; boluses and net temps).
    pub insulin: f64,
}

/// The categorised day (oref0's autotune-prep output).
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct Prepped {
    /// Carb-ratio periods.
    pub cr: Vec<CrDatum>,
    /// Carb-absorption data.
    pub csf: Vec<Datum>,
    /// ISF data.
    pub isf: Vec<Datum>,
    /// Basal data.
    pub basal: Vec<Datum>,
    /// Unannounced-meal data as first sorted (before folding).
    pub uam: Vec<Datum>,
    /// What oref0 would log about folding UAM or CSF data (one line each).
    pub notes: Vec<String>,
}

const FIVE_MIN_BUCKET_MS: i64 = 2 * 60_000;
const SIX_HOURS_MS: i64 = 6 * 3_600_000;

/// Readings ≥ 39 mg/dL, newest first, with those less than 2 minutes after
/// a bucket's first reading averaged into it.
fn buckets(glucose: &[Reading]) -> Vec<(i64, f64)> {
    let mut g: Vec<&Reading> = glucose.iter().filter(|r| r.mg_dl >= 39.0).collect();
    g.sort_by_key(|x| std::cmp::Reverse(x.at_ms));
    let mut out: Vec<(i64, f64)> = Vec::with_capacity(g.len());
    let mut k = 0;
    for (i, r) in g.iter().enumerate() {
        if i == 0 || (r.at_ms - g[k].at_ms).abs() >= FIVE_MIN_BUCKET_MS {
            k = i;
            out.push((r.at_ms, r.mg_dl));
        } else if let Some(last) = out.last_mut() {
            let sum: f64 = g[k..=i].iter().map(|r| r.mg_dl).sum();
            last.1 = sum / (i - k + 1) as f64;
        }
    }
    out
}

/// Categorises a day. `profile` is the profile being tuned (its basal,
/// ISF, carb ratio and insulin curve); the day's `insulin` must reach back
/// far enough for IOB (oref0 downloads 18 h before the day).
pub fn categorize(day: &DayData, profile: &Profile, clock: &dyn LocalClock) -> Prepped {
    let mut out = Prepped::default();
    let b = buckets(&day.glucose);
    if b.len() < 6 {
        out.notes.push(format!(
            "only {} glucose readings: nothing to categorise",
            b.len()
        ));
        return out;
    }
    let model = profile.insulin();
    let carb_ratio = profile.carb_ratio.unwrap_or(f64::NAN);
    // Meals newest first, a meal uploaded twice once; those before the
    // oldest reading dropped (but the newest is always kept).
    let mut meals = meal_inputs(&day.carbs);
    let repeated = day.carbs.iter().filter(|c| c.grams > 0.0).count() - meals.len();
    if repeated > 0 {
        out.notes.push(format!(
            "{repeated} carb entr{} within 2 s of another taken once, as oref0 does",
            if repeated == 1 { "y" } else { "ies" }
        ));
    }
    let oldest = b[b.len() - 1].0;
    let mut i = meals.len();
    while i > 1 {
        i -= 1;
        if meals[i].at_ms < oldest {
            meals.remove(i);
        }
    }
    let mut history: Vec<&Insulin> = day.insulin.iter().collect();
    history.sort_by_key(|x| std::cmp::Reverse(x.at_ms()));

    let mut data: Vec<Datum> = Vec::new();
    let mut calculating_cr = false;
    let mut absorbing = false;
    let mut uam = false;
    let (mut meal_cob, mut meal_carbs, mut cr_carbs) = (0.0f64, 0.0f64, 0.0f64);
    let mut last: Option<Category> = None;
    let (mut cr_iob0, mut cr_bg0, mut cr_t0) = (f64::NAN, f64::NAN, 0i64);
    let mut cr_periods: Vec<(f64, f64, i64, f64, f64, i64, f64)> = Vec::new();
    let (mut csf, mut isf, mut basal, mut uams) = (vec![], vec![], vec![], vec![]);

    for i in (1..=b.len() - 5).rev() {
        let (t, bg) = b[i];
        let mut my_carbs = 0.0;
        if let Some(m) = meals.last() {
            if m.at_ms < t {
                if m.grams >= 1.0 {
                    meal_cob += m.grams;
                    meal_carbs += m.grams;
                    my_carbs = m.grams;
                }
                meals.pop();
            }
        }
        if bg < 40.0 || b[i + 4].1 < 40.0 {
            continue;
        }
        let avg_delta = js::fixed2((bg - b[i + 4].1) / 4.0);
        let minute = clock.minute_of_day(t);
        let sens = profile.isf_at(minute);
        let recent: Vec<&Insulin> = history
            .iter()
            .copied()
            .filter(|r| t - r.at_ms() < SIX_HOURS_MS && t - r.at_ms() > 0)
            .collect();
        let current_basal = profile.basal_at(minute);
        let basal_bgi = js::round_to(current_basal * sens / 60.0 * 5.0, 2);
        let (iob, activity) = iob_at(&doses(&recent, profile, Some(t), clock), &model, t);
        let bgi = js::round_to(-activity * sens * 5.0, 2);
        let mut deviation = avg_delta - bgi;
        if bg < 80.0 && deviation > 0.0 {
            deviation = 0.0;
        }
        let deviation = js::fixed2(deviation);

        if meal_cob > 0.0 {
            let ci = deviation.max(profile.min_5m_carbimpact);
            let absorbed = ci * carb_ratio / sens;
            meal_cob = (meal_cob - absorbed).max(0.0);
        }

        if meal_cob > 0.0 || calculating_cr {
            cr_carbs += my_carbs;
            if !calculating_cr {
                cr_iob0 = iob;
                cr_bg0 = bg;
                cr_t0 = t;
            }
            if i > 1 && (meal_cob > 0.0 || iob > current_basal / 2.0) {
                calculating_cr = true;
            } else {
                let elapsed = js::round((t - cr_t0) as f64 / 60_000.0);
                if elapsed < 60.0 || (i == 1 && meal_cob > 0.0) {
                    out.notes
                        .push(format!("ignoring {elapsed} min carb-ratio period"));
                } else {
                    cr_periods.push((cr_iob0, cr_bg0, cr_t0, iob, bg, t, cr_carbs));
                }
                cr_carbs = 0.0;
                calculating_cr = false;
            }
        }

        let mut datum = Datum {
            at_ms: t,
            glucose: bg,
            avg_delta,
            bgi,
            deviation,
            category: Category::Basal,
            meal_absorption: None,
            meal_carbs: 0.0,
        };
        if meal_cob > 0.0 || absorbing || meal_carbs > 0.0 {
            absorbing = iob.partial_cmp(&(current_basal / 2.0)) != Some(std::cmp::Ordering::Less)
                && deviation > 0.0;
            if !absorbing && meal_cob == 0.0 {
                meal_carbs = 0.0;
            }
            if last != Some(Category::Csf) {
                datum.meal_absorption = Some(Absorption::Start);
            }
            last = Some(Category::Csf);
            datum.category = Category::Csf;
            datum.meal_carbs = meal_carbs;
            csf.push(data.len());
        } else {
            if last == Some(Category::Csf) {
                if let Some(&j) = csf.last() {
                    let d: &mut Datum = &mut data[j];
                    d.meal_absorption = Some(Absorption::End);
                }
            }
            if iob > 2.0 * current_basal || deviation > 6.0 || uam {
                uam = deviation > 0.0;
                last = Some(Category::Uam);
                datum.category = Category::Uam;
                uams.push(data.len());
            } else if basal_bgi > -4.0 * bgi || (avg_delta > 0.0 && avg_delta > -2.0 * bgi) {
                last = Some(Category::Basal);
                basal.push(data.len());
            } else {
                last = Some(Category::Isf);
                datum.category = Category::Isf;
                isf.push(data.len());
            }
        }
        data.push(datum);
    }

    let all = doses(&history, profile, None, clock);
    out.cr = cr_periods
        .into_iter()
        .map(|(iob0, bg0, t0, iob1, bg1, t1, carbs)| CrDatum {
            initial_iob: iob0,
            initial_bg: bg0,
            initial_ms: t0,
            end_iob: iob1,
            end_bg: bg1,
            end_ms: t1,
            carbs,
            insulin: dosed(&all, t0, t1),
        })
        .collect();

    let pick = |ix: &[usize]| -> Vec<Datum> { ix.iter().map(|&j| data[j].clone()).collect() };
    let mut csf_d = pick(&csf);
    let mut isf_d = pick(&isf);
    let mut basal_d = pick(&basal);
    let uam_d = pick(&uams);
    let by_deviation = |v: &mut Vec<Datum>| {
        // JavaScript's a - b, in node's order (NaN is no order).
        super::js_sort::sort_by(v, |a, b| a.deviation - b.deviation);
        v.truncate(v.len() / 2);
    };
    if csf_d.len() > 12 {
        out.notes.push(
            "at least 1 h of carb absorption: all meals taken as announced, UAM data counted as basal"
                .into(),
        );
        basal_d.extend(uam_d.iter().cloned());
    } else {
        if 2 * basal_d.len() < uam_d.len() {
            out.notes.push(format!(
                "too many deviations look like unannounced meals: {} UAM added to {} basal, lowest half kept",
                uam_d.len(),
                basal_d.len()
            ));
            basal_d.extend(uam_d.iter().cloned());
            by_deviation(&mut basal_d);
        }
        if 2 * isf_d.len() < uam_d.len() && isf_d.len() < 10 {
            out.notes.push(format!(
                "{} UAM added to {} ISF data, lowest half kept",
                uam_d.len(),
                isf_d.len()
            ));
            isf_d.extend(uam_d.iter().cloned());
            by_deviation(&mut isf_d);
        }
    }
    if 4 * basal_d.len() + isf_d.len() < csf_d.len() && isf_d.len() < 10 {
        out.notes.push(format!(
            "too many deviations look like meals: {} carb-absorption data counted as ISF",
            csf_d.len()
        ));
        isf_d.append(&mut csf_d);
    }
    out.csf = csf_d;
    out.isf = isf_d;
    out.basal = basal_d;
    out.uam = uam_d;
    out
}

/// The meals oref0's meal history takes, newest first: carb entries with
/// grams > 0 in order of `created_at` (latest first, ties in the given
/// order), each dropped when its own `timestamp` is within
/// [`super::DUPLICATE_MEAL_MS`] of a meal taken before it.
fn meal_inputs(carbs: &[Carbs]) -> Vec<Carbs> {
    let mut all: Vec<Carbs> = carbs.iter().filter(|c| c.grams > 0.0).copied().collect();
    all.sort_by_key(|x| std::cmp::Reverse(x.at_ms));
    let mut taken: Vec<Carbs> = Vec::with_capacity(all.len());
    for c in all {
        let repeat = c.stamp_ms.is_some_and(|t| {
            taken
                .iter()
                .any(|m| (m.at_ms - t).abs() < super::DUPLICATE_MEAL_MS)
        });
        if !repeat {
            taken.push(c);
        }
    }
    taken
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::baselines::autotune::UtcClock;

    const H: i64 = 3_600_000;

    fn profile() -> Profile {
        Profile::flat(1.0, 50.0, 10.0, 5.0).unwrap()
    }

    /// 5-min readings over 24 h from `f(hours since start)`.
    fn day(f: impl Fn(f64) -> f64, insulin: Vec<Insulin>, carbs: Vec<Carbs>) -> DayData {
        DayData {
            glucose: (0..288)
                .map(|k| Reading {
                    at_ms: 10 * H + k * 300_000,
                    mg_dl: f(k as f64 / 12.0),
                })
                .collect(),
            insulin,
            carbs,
        }
    }

    fn kinds(p: &Prepped) -> (usize, usize, usize, usize) {
        (p.basal.len(), p.isf.len(), p.csf.len(), p.uam.len())
    }

    #[test]
    fn flat_glucose_without_boluses_is_basal() {
        let p = categorize(&day(|_| 110.0, vec![], vec![]), &profile(), &UtcClock);
        // 288 readings: the newest and the four oldest are never categorised.
        assert_eq!(kinds(&p), (283, 0, 0, 0));
        assert!(p.basal.iter().all(|d| d.deviation == 0.0 && d.bgi == 0.0));
    }

    #[test]
    fn a_fall_after_a_correction_bolus_is_isf() {
        // 2 U at hour 2; glucose falls 50 mg/dL per U as the curve says
        // (roughly), then stays flat.
        let bolus = Insulin::Bolus {
            at_ms: 12 * H,
            units: 2.0,
        };
        let m = profile().insulin();
        let f = |h: f64| {
            let t = (h - 2.0) * 60.0;
            if t <= 0.0 {
                200.0
            } else {
                200.0 - 100.0 * (1.0 - m.at(1.0, t.round()).1)
            }
        };
        let p = categorize(&day(f, vec![bolus], vec![]), &profile(), &UtcClock);
        let (_, isf, csf, uam) = kinds(&p);
        assert!(isf >= 20, "ISF data: {isf}");
        assert_eq!((csf, uam), (0, 0));
        // Each ISF datum is one where insulin dominates: BGI well below zero.
        assert!(p.isf.iter().all(|d| d.bgi < -0.25 * 50.0 / 12.0));
    }

    #[test]
    fn a_meal_uploaded_twice_is_taken_once_only_when_its_timestamp_says_so() {
        let c = |at_ms: i64, grams: f64, stamp_ms: Option<i64>| Carbs {
            at_ms,
            grams,
            stamp_ms,
        };
        let t = 14 * H;
        // Newest first: the copy 600 ms later is taken, and the first
        // upload (its `timestamp` 600 ms before it) dropped.
        let taken = meal_inputs(&[c(t, 40.0, Some(t)), c(t + 600, 40.0, None)]);
        assert_eq!(taken, [c(t + 600, 40.0, None)]);
        // Within 2 s, exclusive; whatever the grams.
        let taken = meal_inputs(&[c(t, 40.0, Some(t)), c(t + 1_999, 25.0, None)]);
        assert_eq!(taken.len(), 1);
        let taken = meal_inputs(&[c(t, 40.0, Some(t)), c(t + 2_000, 40.0, None)]);
        assert_eq!(taken.len(), 2);
        // Without a `timestamp` of its own an entry is never a copy, even
        // at the same instant; zero grams are no meal.
        let taken = meal_inputs(&[c(t, 40.0, None), c(t, 40.0, None), c(t, 0.0, None)]);
        assert_eq!(taken.len(), 2);
        // The check is against meals taken, not against every entry: a
        // dropped copy does not drop a third.
        let taken = meal_inputs(&[
            c(t + 3_000, 40.0, None),
            c(t + 1_500, 40.0, Some(t + 1_500)),
            c(t, 40.0, Some(t)),
        ]);
        assert_eq!(taken, [c(t + 3_000, 40.0, None), c(t, 40.0, Some(t))]);
    }

    #[test]
    fn a_meal_is_carb_absorption_from_start_to_end() {
        let carbs = Carbs {
            at_ms: 14 * H,
            grams: 40.0,
            stamp_ms: None,
        };
        let bolus = Insulin::Bolus {
            at_ms: 14 * H,
            units: 4.0,
        };
        let f = |h: f64| {
            let t = h - 4.0;
            if (0.0..3.0).contains(&t) {
                110.0 + 60.0 * (t * std::f64::consts::PI / 3.0).sin()
            } else {
                110.0
            }
        };
        let p = categorize(&day(f, vec![bolus], vec![carbs]), &profile(), &UtcClock);
        assert!(p.csf.len() > 12, "carb absorption: {}", p.csf.len());
        assert_eq!(p.csf[0].meal_absorption, Some(Absorption::Start));
        assert_eq!(p.csf[0].meal_carbs, 40.0);
        assert_eq!(p.csf.last().unwrap().meal_absorption, Some(Absorption::End));
        assert!(p.csf.iter().all(|d| d.at_ms > 14 * H));
        assert_eq!(p.cr.len(), 1);
        assert_eq!(p.cr[0].carbs, 40.0);
        // The bolus came with the carbs, before the first reading after
        // them: it is in the period's starting IOB, not in its insulin.
        assert_eq!(p.cr[0].insulin, 0.0);
        assert!(p.cr[0].initial_iob > 3.5, "{}", p.cr[0].initial_iob);
    }

    #[test]
    fn an_unannounced_rise_is_uam() {
        let f = |h: f64| {
            let t = h - 6.0;
            if (0.0..1.0).contains(&t) {
                110.0 + 80.0 * t
            } else if t >= 1.0 {
                190.0
            } else {
                110.0
            }
        };
        let p = categorize(&day(f, vec![], vec![]), &profile(), &UtcClock);
        // Rising 6.7 mg/dL per 5 min without carbs: deviation > 6.
        assert!(p.uam.len() >= 8, "UAM: {}", p.uam.len());
        assert!(p
            .uam
            .iter()
            .all(|d| d.deviation > 0.0 || d.category == Category::Uam));
        // Fewer than 1 h of carb absorption and twice as many basal as UAM
        // data: the UAM data stay out of the basal data.
        assert_eq!(p.basal.len() + p.uam.len(), 283);
    }
}
