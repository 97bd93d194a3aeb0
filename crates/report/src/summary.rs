//! `summary.json` (protocol §8):
//!
//! ```text
//! { "manifest": {...},
//!   "arms": { "<scenario>/<advisor>": {
//!       "scenario", "advisor",
//!       "weeks":  { "W1": M, "W13": M, "W14": M },
//!       "weekly": [ {"week": "W1", ...M}, ... ],
//!       "wilcoxon": { "W1_vs_W13": { "<metric>": {"statistic", "p"} }, "W1_vs_W14": {...} } } },
//!   "notes": {...} }
//! ```
//!
//! M = `{ "<metric>": {"mean", "sd", "median", "q1", "q3"} }` over the arm's
//! patients for all 16 metrics of [`abba_core::Metric::ALL`] (see
//! [`crate::stats::summarize`]: SD with n − 1, type-7 quartiles).
//!
//! Choices:
//! - MAGE is undefined for a patient-week without a countable excursion; its
//!   summary is over the patients where it is defined, and the Wilcoxon test
//!   over the complete pairs. How many values were undefined is in
//!   `notes.arms.<key>` (`mage_undefined` per week, and `n_incomplete` of
//!   each test), so M keeps exactly the protocol's five fields. A metric
//!   with no defined value at all summarises to `null`; `sd` is `null` for
//!   a single patient.
//! - A week that was not simulated (a short trial) is `null` in `weeks`, is
//!   absent from `weekly`, and its comparisons in `wilcoxon` are `null`.
//! - Wilcoxon: paired by patient, d = later week − W1, two-sided, normal
//!   approximation with tie correction and Pratt's zero correction
//!   (SciPy's default), no continuity correction; `statistic` = min(W+, W−).
//!   All-zero differences give statistic 0, p = 1.
//! - A run that stopped early (plasma glucose below the failure threshold)
//!   contributes only the weeks that ended before the stop: later summaries
//!   are over fewer patients and tests over the complete pairs. The number
//!   of patients per week and every stop are in `notes.arms.<key>`.
//! - Extra per-arm facts (mode, number of patients, weeks present, patients
//!   per week, stopped runs, the counts above, z of every test) are under
//!   `notes.arms`, so that each arm object holds exactly the protocol's keys.

use serde_json::{json, Map, Value};

use abba_core::Metric;

use crate::error::ReportError;
use crate::results::{ArmResult, Week};
use crate::select::{
    arm_weeks, metric_column, ordered_arms, patients_with_week, stopped_runs, validate_arms,
};
use crate::stats::{
    summarize_present, wilcoxon_signed_rank_present, Wilcoxon, WilcoxonOptions, ZeroMethod,
};

/// The report's signed-rank test: protocol.md §7 asks for the normal
/// approximation "with tie and zero corrections", i.e. Pratt's treatment of
/// zero differences (ranked with the rest, then dropped, with the mean and
/// variance corrected), which matters for the sparse hypo bands.
pub const REPORT_WILCOXON: WilcoxonOptions = WilcoxonOptions {
    zero_method: ZeroMethod::Pratt,
    continuity_correction: false,
};

/// The comparisons of the `wilcoxon` object: (key, later week).
pub const COMPARISONS: [(&str, Week); 2] = [("W1_vs_W13", Week::W13), ("W1_vs_W14", Week::W14)];

/// M for one week of one arm: every metric key with its summary over patients
/// (or `null` when no patient has a defined value).
pub fn week_summary(arm: &ArmResult, week: Week) -> Result<Map<String, Value>, ReportError> {
    let mut m = Map::new();
    for key in Metric::ALL {
        let values = metric_column(arm, week, key);
        let summary = summarize_present(&values).map_err(|source| ReportError::Stats {
            what: format!("arm {}, week {week}, metric {key}", arm.key()),
            source,
        })?;
        m.insert(key.to_string(), json_of(&summary, "a metric summary")?);
    }
    Ok(m)
}

/// The paired test W1 vs `later` of metric `key` for one arm; `None` when no
/// patient has both values defined.
pub fn wilcoxon_vs_w1(
    arm: &ArmResult,
    later: Week,
    key: Metric,
) -> Result<Option<Wilcoxon>, ReportError> {
    let first = metric_column(arm, Week::W1, key);
    let second = metric_column(arm, later, key);
    if !first
        .iter()
        .zip(&second)
        .any(|(a, b)| a.is_some() && b.is_some())
    {
        return Ok(None);
    }
    wilcoxon_signed_rank_present(&first, &second, REPORT_WILCOXON)
        .map(Some)
        .map_err(|source| ReportError::Stats {
            what: format!("arm {}, W1 vs {later}, metric {key}", arm.key()),
            source,
        })
}

/// The whole `summary.json` document. The arms must be consistent
/// ([`validate_arms`] is applied).
pub fn summary_json(arms: &[ArmResult], manifest: &Value) -> Result<Value, ReportError> {
    validate_arms(arms)?;
    let mut arms_obj = Map::new();
    let mut notes_arms = Map::new();
    for arm in ordered_arms(arms) {
        let weeks_present = arm_weeks(arm);
        let has = |w: Week| weeks_present.contains(&w);

        let mut weeks = Map::new();
        for w in Week::TABLE {
            let v = if has(w) {
                Value::Object(week_summary(arm, w)?)
            } else {
                Value::Null
            };
            weeks.insert(w.to_string(), v);
        }

        let mut weekly = Vec::with_capacity(weeks_present.len());
        let mut mage_undefined = Map::new();
        let mut n_per_week = Map::new();
        for &w in &weeks_present {
            n_per_week.insert(w.to_string(), json!(patients_with_week(arm, w)));
            let mut m = week_summary(arm, w)?;
            m.insert("week".to_string(), Value::String(w.to_string()));
            weekly.push(Value::Object(m));
            // Undefined among the patients that have the week.
            let undefined = arm
                .patients
                .iter()
                .filter_map(|p| p.week(w))
                .filter(|wk| wk.metrics.mage.is_none())
                .count();
            mage_undefined.insert(w.to_string(), json!(undefined));
        }

        let mut wilcoxon = Map::new();
        let mut wilcoxon_notes = Map::new();
        for (name, later) in COMPARISONS {
            if !(has(Week::W1) && has(later)) {
                wilcoxon.insert(name.to_string(), Value::Null);
                continue;
            }
            let mut tests = Map::new();
            let mut details = Map::new();
            for key in Metric::ALL {
                let test = wilcoxon_vs_w1(arm, later, key)?;
                tests.insert(key.to_string(), json_of(&test, "a Wilcoxon test")?);
                details.insert(
                    key.to_string(),
                    match test {
                        Some(t) => json!({
                            "z": finite_or_null(t.z),
                            "w_plus": t.w_plus,
                            "w_minus": t.w_minus,
                            "n_nonzero": t.n_nonzero,
                            "n_zero": t.n_zero,
                            "n_incomplete": t.n_incomplete,
                        }),
                        None => Value::Null,
                    },
                );
            }
            wilcoxon.insert(name.to_string(), Value::Object(tests));
            wilcoxon_notes.insert(name.to_string(), Value::Object(details));
        }

        arms_obj.insert(
            arm.key(),
            json!({
                "scenario": arm.scenario,
                "advisor": arm.advisor,
                "weeks": Value::Object(weeks),
                "weekly": Value::Array(weekly),
                "wilcoxon": Value::Object(wilcoxon),
            }),
        );
        let mut note = json!({
                "mode": arm.mode,
                "n_patients": arm.patients.len(),
                "weeks_present": weeks_present,
                "n_patients_per_week": Value::Object(n_per_week),
                "stopped_runs": stopped_runs(arm)
                    .into_iter()
                    .map(|(patient, f)| json!({
                        "patient": patient,
                        "day": f.day,
                        "minute_of_day": f.minute_of_day,
                        "glucose_mg_dl": finite_or_null(f.glucose_mg_dl),
                    }))
                    .collect::<Vec<_>>(),
                "mage_undefined": Value::Object(mage_undefined),
                "wilcoxon": Value::Object(wilcoxon_notes),
        });
        // The abba-twin arm's counts, summed over its patients (only that
        // arm has them: other arms' notes are as they always were).
        let twin_counts: Vec<_> = arm.patients.iter().filter_map(|p| p.twin_check).collect();
        if !twin_counts.is_empty() {
            let total = twin_counts
                .iter()
                .fold(crate::results::TwinCheckCounts::default(), |a, b| {
                    a.plus(*b)
                });
            note["twin_check"] = json_of(&total, "the twin check's counts")?;
        }
        notes_arms.insert(arm.key(), note);
    }
    Ok(json!({
        "manifest": manifest,
        "arms": Value::Object(arms_obj),
        "notes": {
            "arms": Value::Object(notes_arms),
            "methods": {
                "summary": "over the patients of the arm: mean; sample SD (n - 1; null for one patient); median and quartiles Q1, Q3 by linear interpolation (Hyndman-Fan type 7, R's default)",
                "undefined_values": "MAGE is undefined for a patient-week without a countable excursion: summaries use the defined values only and tests the complete pairs only; counts in notes.arms.<arm>.mage_undefined and .wilcoxon.<test>.<metric>.n_incomplete; a metric with no defined value is null",
                "wilcoxon": "paired by patient, d = later week - W1; two-sided; normal approximation with tie correction; zero differences ranked then dropped with corrected mean and variance (Pratt, SciPy's zero_method='pratt'); no continuity correction; statistic = min(W+, W-); all differences zero gives statistic 0, p 1; p is null with fewer than 10 ranked pairs (too few for the normal approximation)",
                "weeks": "W1 = D2-D8 (standard therapy); Wk = D(7k-5)-D(7k+1) for k = 1..12; W13 = D84-D90; W14 = D92-D98; D91 not evaluated; a week not simulated is null in 'weeks', absent from 'weekly', and its comparisons are null",
                "stopped_runs": "a run stops when plasma glucose falls below the trial's failure threshold; the patient then contributes only the weeks that ended before the stop, so later summaries are over fewer patients (notes.arms.<arm>.n_patients_per_week) and tests over the complete pairs only (n_incomplete); every stop is listed in notes.arms.<arm>.stopped_runs",
                "glucose": "metrics of plasma glucose sampled every 5 min; tdi_u_per_day = mean total insulin delivered per day over the week",
            },
        },
    }))
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn json_of<T: serde::Serialize>(value: &T, what: &'static str) -> Result<Value, ReportError> {
    serde_json::to_value(value).map_err(|source| ReportError::Json { what, source })
}
