//! What a trial produces: per patient, arm and evaluation week, the glucose
//! metrics of plasma glucose (every 5 min) and the mean total daily insulin.
//! The report is computed from these alone. Scenario, arm, mode and week are
//! typed; they serialise as `"S1"`, `"abba"`, `"cgm"` and `"W13"`.

use abba_advisor::Mode;
use abba_core::metrics::GlucoseMetrics;
use abba_core::{Metric, ScenarioId};
use serde::Serialize;

/// The arms (which advisor a result is of) are abba-advisor's; re-exported.
pub use abba_advisor::ArmKind;

/// An evaluation window of the protocol: `W1`..`W12` (Wk = D(7k−5)..D(7k+1)),
/// then the paper's `W13` (D84-D90) and `W14` (D92-D98). Ordered as the
/// protocol lists them; no other week can be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Week(u8);

const WEEK_NAMES: [&str; 14] = [
    "W1", "W2", "W3", "W4", "W5", "W6", "W7", "W8", "W9", "W10", "W11", "W12", "W13", "W14",
];

impl Week {
    /// W1 = D2-D8: standard therapy in every arm.
    pub const W1: Week = Week(1);
    /// W13 = D84-D90: after adaptation, with insulin-sensitivity variability.
    pub const W13: Week = Week(13);
    /// W14 = D92-D98: after adaptation, without it.
    pub const W14: Week = Week(14);
    /// All 14, in protocol order.
    pub const ALL: [Week; 14] = [
        Week(1),
        Week(2),
        Week(3),
        Week(4),
        Week(5),
        Week(6),
        Week(7),
        Week(8),
        Week(9),
        Week(10),
        Week(11),
        Week(12),
        Week(13),
        Week(14),
    ];
    /// The three weeks of Table I and of `summary.json`'s `weeks`.
    pub const TABLE: [Week; 3] = [Week::W1, Week::W13, Week::W14];

    /// Week `k` (1..=14), if it exists.
    pub fn new(k: u8) -> Option<Week> {
        (1..=14).contains(&k).then_some(Week(k))
    }

    /// 1..=14 (its position on a figure's week axis).
    pub fn number(self) -> u8 {
        self.0
    }

    /// `W1`..`W14`.
    pub fn name(self) -> &'static str {
        WEEK_NAMES[usize::from(self.0 - 1)]
    }

    /// First and last day (1-based, inclusive).
    pub fn days(self) -> (u32, u32) {
        match self.0 {
            13 => (84, 90),
            14 => (92, 98),
            k => {
                let k = u32::from(k);
                (7 * k - 5, 7 * k + 1)
            }
        }
    }
}

abba_core::named!(Week, "evaluation week", Week::name, parse_and_serde);

/// One evaluation window of one patient in one arm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeekResult {
    /// Which window.
    pub week: Week,
    /// First day (1-based, inclusive).
    pub first_day: u32,
    /// Last day (1-based, inclusive).
    pub last_day: u32,
    /// Metrics of plasma glucose sampled every 5 min over the window.
    pub metrics: GlucoseMetrics,
    /// Mean total insulin delivered per day over the window (U/day).
    pub tdi_u_per_day: f64,
    /// Plasma glucose every 5 min from 00:00 of the first day (mg/dL), kept
    /// for the Table I weeks (W1, W13, W14) only, for the cohort glucose
    /// profiles of `report.html`; empty otherwise. Not serialized.
    #[serde(skip)]
    pub plasma_5min_mg_dl: Vec<f32>,
}

impl WeekResult {
    /// The value of any of the 16 metrics; `None` only for an undefined MAGE.
    pub fn value(&self, metric: Metric) -> Option<f64> {
        match metric {
            Metric::TdiUPerDay => Some(self.tdi_u_per_day),
            glucose => self.metrics.get(glucose),
        }
    }
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
    /// What the twin check did over the run (the `abba-twin` arm only;
    /// absent, and not serialised, for every other arm).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub twin_check: Option<TwinCheckCounts>,
}

/// What the twin check of the `abba-twin` arm did in one run: twins
/// fitted, suggestions replayed on a usable twin, and of them the ones held
/// back (answered "rejected" for the person, so the value in force stayed).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TwinCheckCounts {
    /// Twins fitted.
    pub fits: u32,
    /// Of them, usable (grade good or fair).
    pub usable_fits: u32,
    /// Fits that failed.
    pub failed_fits: u32,
    /// Suggestions replayed on a usable twin.
    pub checked: u32,
    /// Of them, held back.
    pub held_back: u32,
    /// Suggestions that passed unchecked (no usable twin yet, or a replay
    /// that failed).
    pub unchecked: u32,
}

impl TwinCheckCounts {
    /// The sum of two runs' counts.
    pub fn plus(self, o: Self) -> Self {
        Self {
            fits: self.fits + o.fits,
            usable_fits: self.usable_fits + o.usable_fits,
            failed_fits: self.failed_fits + o.failed_fits,
            checked: self.checked + o.checked,
            held_back: self.held_back + o.held_back,
            unchecked: self.unchecked + o.unchecked,
        }
    }
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
    /// The result of evaluation window `week`, if it was simulated.
    pub fn week(&self, week: Week) -> Option<&WeekResult> {
        self.weeks.iter().find(|w| w.week == week)
    }
}

/// All patients of one scenario × advisor arm.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArmResult {
    /// Which scenario.
    pub scenario: ScenarioId,
    /// Which arm.
    pub advisor: ArmKind,
    /// The advisor's mode in this arm.
    pub mode: Mode,
    /// One entry per patient, in cohort order.
    pub patients: Vec<PatientResult>,
}

impl ArmResult {
    /// `S1/abba` style key.
    pub fn key(&self) -> String {
        format!("{}/{}", self.scenario, self.advisor)
    }
}

/// The evaluation windows: (week, first day, last day), days 1-based inclusive.
pub fn evaluation_windows() -> Vec<(Week, u32, u32)> {
    Week::ALL
        .into_iter()
        .map(|w| {
            let (a, b) = w.days();
            (w, a, b)
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn windows_follow_the_protocol() {
        let w = evaluation_windows();
        assert_eq!(w.len(), 14);
        assert_eq!(w[0], (Week::W1, 2, 8));
        assert_eq!((w[11].0.name(), w[11].1, w[11].2), ("W12", 79, 85));
        assert_eq!(w[12], (Week::W13, 84, 90));
        assert_eq!(w[13], (Week::W14, 92, 98));
    }

    #[test]
    fn weeks_exist_only_from_1_to_14_and_keep_their_names() {
        assert!(Week::new(0).is_none() && Week::new(15).is_none());
        for (k, w) in (1u8..).zip(Week::ALL) {
            assert_eq!(Week::new(k), Some(w));
            assert_eq!(w.name(), format!("W{k}"));
            assert_eq!(w.name().parse::<Week>().unwrap(), w);
            assert_eq!(serde_json::to_string(&w).unwrap(), format!("\"W{k}\""));
        }
        assert!("W15".parse::<Week>().is_err() && "w1".parse::<Week>().is_err());
        assert!(serde_json::from_str::<Week>("\"W0\"").is_err());
    }

    #[test]
    fn typed_fields_serialise_as_the_old_strings() {
        let arm = ArmResult {
            scenario: ScenarioId::S2,
            advisor: ArmKind::R2r,
            mode: Mode::Smbg,
            patients: Vec::new(),
        };
        assert_eq!(
            serde_json::to_string(&arm).unwrap(),
            r#"{"scenario":"S2","advisor":"r2r","mode":"smbg","patients":[]}"#
        );
        assert_eq!(arm.key(), "S2/r2r");
    }
}
