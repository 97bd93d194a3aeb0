//! What a trial produces: per patient, arm and evaluation week, the glucose
//! metrics of plasma glucose (every 5 min) and the mean total daily insulin.
//! The report is computed from these alone.

use abba_core::metrics::GlucoseMetrics;
use serde::Serialize;

/// One evaluation window of one patient in one arm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeekResult {
    /// `W1`..`W12` (Wk = D(7k−5)..D(7k+1)), then the paper's `W13` (D84-D90) and `W14` (D92-D98).
    pub week: String,
    /// First day (1-based, inclusive).
    pub first_day: u32,
    /// Last day (1-based, inclusive).
    pub last_day: u32,
    /// Metrics of plasma glucose sampled every 5 min over the window.
    pub metrics: GlucoseMetrics,
    /// Mean total insulin delivered per day over the window (U/day).
    pub tdi_u_per_day: f64,
}

/// One patient's run in one arm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PatientResult {
    /// Patient name (e.g. `adult#001`).
    pub patient: String,
    /// The evaluation windows that fit in the simulated days, in the order
    /// W1..W12, W13, W14.
    pub weeks: Vec<WeekResult>,
    /// The settings in force at the end of the run: basal (U/h) and the three carb ratios (g/U).
    pub final_basal_u_per_h: f64,
    /// Final carb ratios for breakfast, lunch, dinner (g/U).
    pub final_carb_ratio_g_per_u: [f64; 3],
    /// Starting (standard-therapy) basal (U/h).
    pub start_basal_u_per_h: f64,
    /// Starting carb ratio (g/U).
    pub start_carb_ratio_g_per_u: f64,
    /// Boluses the pump capped at its maximum, and basal requests it capped.
    pub pump_capped: u32,
    /// Minimum plasma glucose over the whole run (mg/dL).
    pub min_glucose_mg_dl: f64,
    /// Set when plasma glucose fell below the trial's failure threshold: the
    /// run stopped there, and only the evaluation windows that ended before
    /// it are in `weeks`.
    pub failure: Option<RunFailure>,
    /// Rescue carbohydrate eaten over the run (g; 0 unless the scenario
    /// has hypoglycaemia treatment).
    pub rescue_carbs_g: f64,
    /// Number of hypoglycaemia treatments over the run.
    pub rescue_treatments: u32,
}

/// Where a run stopped because plasma glucose fell below the failure
/// threshold (simglucose ends a run below 10 mg/dL the same way: the 2008
/// model has no counter-regulation, and past that point it only holds
/// glucose near zero).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RunFailure {
    /// Day (1-based) of the failure.
    pub day: u32,
    /// Minute of that day.
    pub minute_of_day: u32,
    /// Plasma glucose then (mg/dL).
    pub glucose_mg_dl: f64,
}

impl PatientResult {
    /// The result of evaluation window `week` (e.g. `W13`), if it was simulated.
    pub fn week(&self, week: &str) -> Option<&WeekResult> {
        self.weeks.iter().find(|w| w.week == week)
    }
}

/// All patients of one scenario × advisor arm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArmResult {
    /// `S1`..`S4`.
    pub scenario: String,
    /// `abba`, `standard` or `r2r`.
    pub advisor: String,
    /// The advisor's mode in this arm (`cgm` or `smbg`).
    pub mode: String,
    /// One entry per patient, in cohort order.
    pub patients: Vec<PatientResult>,
}

impl ArmResult {
    /// `S1/abba` style key.
    pub fn key(&self) -> String {
        format!("{}/{}", self.scenario, self.advisor)
    }
}

/// The evaluation windows: (name, first day, last day), days 1-based inclusive.
pub fn evaluation_windows() -> Vec<(String, u32, u32)> {
    let mut w: Vec<(String, u32, u32)> = (1..=12)
        .map(|k| (format!("W{k}"), 7 * k - 5, 7 * k + 1))
        .collect();
    w.push(("W13".into(), 84, 90));
    w.push(("W14".into(), 92, 98));
    w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_follow_the_protocol() {
        let w = evaluation_windows();
        assert_eq!(w.len(), 14);
        assert_eq!(w[0], ("W1".to_string(), 2, 8));
        assert_eq!(w[11], ("W12".to_string(), 79, 85));
        assert_eq!(w[12], ("W13".to_string(), 84, 90));
        assert_eq!(w[13], ("W14".to_string(), 92, 98));
    }
}
