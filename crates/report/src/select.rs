//! What the report reads from the results: the arms in report order, the
//! weeks an arm has, one metric's values over an arm's patients, stopped
//! runs; and the check that results can be reported without dropping or
//! guessing anything ([`validate_arms`]).

use std::collections::BTreeSet;

use abba_core::Metric;

use crate::error::ReportError;
use crate::results::{ArmResult, PatientResult, RunFailure, Week};

/// The evaluation weeks of `arm`: those any of its patients has, in
/// protocol order (W1..W12, W13, W14). Patients whose run stopped early
/// (see [`validate_arms`]) may lack the later ones.
pub fn arm_weeks(arm: &ArmResult) -> Vec<Week> {
    Week::ALL
        .into_iter()
        .filter(|w| arm.patients.iter().any(|p| p.week(*w).is_some()))
        .collect()
}

/// The weeks the report's tables show: W1, W13 and W14 when the run has
/// them; a shorter run shows W1 and its last two weeks (a 30-day run: W1,
/// W3, W4), so that no table is all W1 rows, which are standard therapy in
/// every arm.
pub fn table_weeks(arms: &[ArmResult]) -> Vec<Week> {
    let mut present: Vec<Week> = Week::ALL
        .into_iter()
        .filter(|w| arms.iter().any(|a| arm_weeks(a).contains(w)))
        .collect();
    if present.contains(&Week::W13) || present.contains(&Week::W14) {
        return Week::TABLE
            .into_iter()
            .filter(|w| present.contains(w))
            .collect();
    }
    let later: Vec<Week> = present.split_off(present.len().min(1));
    let tail = &later[later.len().saturating_sub(2)..];
    present.extend_from_slice(tail);
    present
}

/// The weeks any of `arms` has, in protocol order.
pub fn run_weeks(arms: &[ArmResult]) -> Vec<Week> {
    Week::ALL
        .into_iter()
        .filter(|w| arms.iter().any(|a| arm_weeks(a).contains(w)))
        .collect()
}

/// `W1-W4`, `W1-W14` or `W1, W3, W13` (runs of consecutive weeks joined).
pub fn week_span(weeks: &[Week]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < weeks.len() {
        let mut j = i;
        while j + 1 < weeks.len() && weeks[j + 1].number() == weeks[j].number() + 1 {
            j += 1;
        }
        parts.push(if j > i + 1 {
            format!("{}-{}", weeks[i], weeks[j])
        } else if j == i + 1 {
            format!("{}, {}", weeks[i], weeks[j])
        } else {
            weeks[i].to_string()
        });
        i = j + 1;
    }
    parts.join(", ")
}

/// Which weeks the run has and which the tables show, as one sentence
/// (a short run says that the paper's W13 and W14 need 98 days).
pub fn weeks_note(arms: &[ArmResult]) -> String {
    let present = run_weeks(arms);
    let shown = table_weeks(arms);
    let missing: Vec<Week> = [Week::W13, Week::W14]
        .into_iter()
        .filter(|w| !present.contains(w))
        .collect();
    let why = match missing.as_slice() {
        [] => String::new(),
        [w] => format!(" ({w}, a week of the paper, is not simulated in this run)"),
        _ => " (the paper's W13 = D84-D90 and W14 = D92-D98 need 98 days)".to_string(),
    };
    format!(
        "Weeks simulated: {}{why}; the tables show {}.",
        week_span(&present),
        week_span(&shown)
    )
}

/// How many patients of `arm` have week `week`.
pub fn patients_with_week(arm: &ArmResult, week: Week) -> usize {
    arm.patients
        .iter()
        .filter(|p| p.week(week).is_some())
        .count()
}

/// The patients of `arm` whose run stopped early (plasma glucose below the
/// trial's failure threshold).
pub fn stopped_runs(arm: &ArmResult) -> Vec<(&str, RunFailure)> {
    arm.patients
        .iter()
        .filter_map(|p| p.failure.map(|f| (p.patient.as_str(), f)))
        .collect()
}

/// `D45 03:20` style time of a stopped run.
pub fn failure_time(f: &RunFailure) -> String {
    format!(
        "D{} {:02}:{:02}",
        f.day,
        f.minute_of_day / 60,
        f.minute_of_day % 60
    )
}

/// The values of `metric` in week `week` for every patient of `arm`, in
/// patient order (`None` for an undefined MAGE or a week the patient lacks).
pub fn metric_column(arm: &ArmResult, week: Week, metric: Metric) -> Vec<Option<f64>> {
    arm.patients
        .iter()
        .map(|p| p.week(week).and_then(|w| w.value(metric)))
        .collect()
}

/// The arms in report order: scenario S1..S4, then arm abba, standard, r2r.
pub fn ordered_arms(arms: &[ArmResult]) -> Vec<&ArmResult> {
    let mut v: Vec<&ArmResult> = arms.iter().collect();
    v.sort_by_key(|a| (a.scenario, a.advisor));
    v
}

/// Checks that the results can be reported without dropping or guessing
/// anything:
/// - at least one arm, and no two arms with the same `scenario/advisor` key;
/// - every arm has at least one patient, and no patient name twice;
/// - every patient's weeks are evaluation windows of the protocol (name and
///   days as in [`Week::days`]), in protocol order, each once;
/// - all patients of one arm whose run completed have the same weeks (paired
///   statistics need them); a patient whose run stopped early (`failure`)
///   has a leading part of them, and none that ends after the stop day.
///
/// Stopped runs are reported, not hidden: each summary is over the patients
/// that have the week, and the counts are in the report.
pub fn validate_arms(arms: &[ArmResult]) -> Result<(), ReportError> {
    let bad = |msg: String| Err(ReportError::InconsistentResults(msg));
    if arms.is_empty() {
        return bad("no arms to report".to_string());
    }
    let mut keys = BTreeSet::new();
    for arm in arms {
        let key = arm.key();
        if !keys.insert(key.clone()) {
            return bad(format!("arm {key} appears more than once"));
        }
        if arm.patients.is_empty() {
            return bad(format!("arm {key} has no patients"));
        }
        let mut names = BTreeSet::new();
        for p in &arm.patients {
            if !names.insert(p.patient.as_str()) {
                return bad(format!(
                    "arm {key}: patient {} appears more than once",
                    p.patient
                ));
            }
            let mut last: Option<Week> = None;
            for w in &p.weeks {
                let (first_day, last_day) = w.week.days();
                if (w.first_day, w.last_day) != (first_day, last_day) {
                    return bad(format!(
                        "arm {key}, patient {}, week {}: days D{}-D{}, expected D{first_day}-D{last_day}",
                        p.patient, w.week, w.first_day, w.last_day
                    ));
                }
                if last.is_some_and(|l| w.week <= l) {
                    return bad(format!(
                        "arm {key}, patient {}: week {} is repeated or out of order (expected W1..W12, W13, W14)",
                        p.patient, w.week
                    ));
                }
                if let Some(f) = p.failure {
                    if w.last_day > f.day {
                        return bad(format!(
                            "arm {key}, patient {}: week {} ends on D{} but the run stopped on D{}",
                            p.patient, w.week, w.last_day, f.day
                        ));
                    }
                }
                last = Some(w.week);
            }
        }
        let names_of = |p: &PatientResult| -> Vec<String> {
            p.weeks.iter().map(|w| w.week.to_string()).collect()
        };
        if let Some(full) = arm.patients.iter().find(|p| p.failure.is_none()) {
            let theirs = names_of(full);
            for p in &arm.patients {
                let mine = names_of(p);
                let ok = if p.failure.is_none() {
                    mine == theirs
                } else {
                    theirs.starts_with(&mine)
                };
                if !ok {
                    return bad(format!(
                        "arm {key}: patient {} has weeks [{}] but patient {} has [{}]{}",
                        p.patient,
                        mine.join(", "),
                        full.patient,
                        theirs.join(", "),
                        if p.failure.is_some() {
                            " (a stopped run must have a leading part of them)"
                        } else {
                            ""
                        }
                    ));
                }
            }
        }
    }
    Ok(())
}
