//! A cohort's summary: per-parameter statistics, rejections and the
//! comparison of titrated with Quest carb ratios.

use super::{CarbRatioSource, Cohort, Origin, Population, Rejections};
use crate::patient::{PatientParams, QuestRow};
use crate::SimError;
use serde::Serialize;

/// Mean, SD (n − 1), min and max of one column over the cohort.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamStats {
    /// Column name.
    pub name: String,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (n − 1); `None` (JSON `null`) for a
    /// one-patient cohort, where it is undefined.
    pub sd: Option<f64>,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
}

impl ParamStats {
    fn of(name: &str, v: &[f64]) -> Self {
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        let sd = (v.len() >= 2)
            .then(|| (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
        Self {
            name: name.to_string(),
            mean,
            sd,
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

/// Titrated against Quest carb ratio for one public patient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TitrationComparison {
    /// Patient.
    pub name: String,
    /// Quest.csv's CR (g/U).
    pub quest_g_per_u: f64,
    /// The titration rule's clinic value (g/U).
    pub titrated_g_per_u: f64,
    /// The rule's value before rounding (g/U).
    pub titrated_exact_g_per_u: f64,
    /// titrated_exact / quest.
    pub ratio: f64,
}

/// How the titration rule compares with Quest.csv over the public patients
/// of the cohort.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TitrationSummary {
    /// Per public patient.
    pub patients: Vec<TitrationComparison>,
    /// Geometric mean of titrated/Quest.
    pub geometric_mean_ratio: f64,
    /// Sample SD of log(titrated/Quest); `None` (JSON `null`) with fewer
    /// than 2 public patients, where it is undefined.
    pub sd_log_ratio: Option<f64>,
    /// Pearson correlation of log titrated with log Quest; `None` with
    /// fewer than 2 public patients or when either side does not vary.
    pub correlation_log: Option<f64>,
    /// Patients whose titrated ratio is within ±20 % of Quest's.
    pub within_20_percent: usize,
    /// Patients whose ratio the hypoglycaemia floor (not the return to
    /// baseline) set.
    pub nadir_limited: usize,
}

/// What `abba cohort --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CohortSummary {
    /// Group.
    pub population: Population,
    /// Number of patients.
    pub size: usize,
    /// Public patients in the cohort.
    pub public: usize,
    /// Generated patients.
    pub generated: usize,
    /// Cohort seed.
    pub seed: u64,
    /// Statistics of every numeric column of the patient table, in table
    /// order, then of the standard therapy.
    pub parameters: Vec<ParamStats>,
    /// Rejected candidates.
    pub rejections: Rejections,
    /// Titration against Quest (public patients).
    pub titration_vs_quest: TitrationSummary,
    /// Plasma glucose range over the standard days (min of the minima, max
    /// of the maxima).
    pub standard_day_range_mg_dl: [f64; 2],
    /// The configuration (titration rule, limits, ...).
    pub config: super::CohortConfig,
}

impl Cohort {
    /// The summary of this cohort.
    pub fn summary(&self) -> Result<CohortSummary, SimError> {
        let ps = &self.patients;
        let mut parameters = Vec::new();
        parameters.push(ParamStats::of(
            "i",
            &ps.iter().map(|p| f64::from(p.params.i)).collect::<Vec<_>>(),
        ));
        for (k, name) in crate::patient::params::X0_COLUMNS.iter().enumerate() {
            let v: Vec<f64> = ps.iter().map(|p| p.params.x0[k]).collect();
            parameters.push(ParamStats::of(name, &v));
        }
        for (k, name) in PatientParams::SCALAR_COLUMNS.iter().enumerate() {
            let v: Vec<f64> = ps.iter().map(|p| p.params.scalars()[k]).collect();
            parameters.push(ParamStats::of(name, &v));
        }
        let basal: Vec<f64> = ps.iter().map(|p| p.therapy.basal.0).collect();
        parameters.push(ParamStats::of("basal_u_per_h", &basal));
        let cr: Vec<f64> = ps.iter().map(|p| p.therapy.carb_ratio[0].0).collect();
        parameters.push(ParamStats::of("carb_ratio_g_per_u", &cr));
        let tcr: Vec<f64> = ps.iter().map(|p| p.titration.carb_ratio_g_per_u).collect();
        parameters.push(ParamStats::of("titrated_carb_ratio_g_per_u", &tcr));

        let quest = QuestRow::all()?;
        let mut rows = Vec::new();
        let mut nadir_limited = 0;
        for p in ps.iter().filter(|p| p.origin == Origin::Public) {
            let q = quest
                .iter()
                .find(|q| q.name == p.params.name)
                .ok_or_else(|| SimError::UnknownPatient {
                    name: p.params.name.clone(),
                    known: "Quest.csv has no row for this patient".into(),
                })?;
            if p.titration.nadir_limited {
                nadir_limited += 1;
            }
            rows.push(TitrationComparison {
                name: p.params.name.clone(),
                quest_g_per_u: q.cr,
                titrated_g_per_u: p.titration.carb_ratio_g_per_u,
                titrated_exact_g_per_u: p.titration.exact_g_per_u,
                ratio: p.titration.exact_g_per_u / q.cr,
            });
        }
        let n = rows.len() as f64;
        let lr: Vec<f64> = rows.iter().map(|r| r.ratio.ln()).collect();
        let m = lr.iter().sum::<f64>() / n;
        let sd = (rows.len() >= 2)
            .then(|| (lr.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
        let lq: Vec<f64> = rows.iter().map(|r| r.quest_g_per_u.ln()).collect();
        let lt: Vec<f64> = rows.iter().map(|r| r.titrated_exact_g_per_u.ln()).collect();
        let (mq, mt) = (lq.iter().sum::<f64>() / n, lt.iter().sum::<f64>() / n);
        let cov: f64 = lq.iter().zip(&lt).map(|(a, b)| (a - mq) * (b - mt)).sum();
        let vq: f64 = lq.iter().map(|a| (a - mq).powi(2)).sum();
        let vt: f64 = lt.iter().map(|b| (b - mt).powi(2)).sum();
        let rows_n = rows.len();
        let titration_vs_quest = TitrationSummary {
            within_20_percent: rows.iter().filter(|r| (r.ratio - 1.0).abs() <= 0.2).count(),
            patients: rows,
            geometric_mean_ratio: m.exp(),
            sd_log_ratio: sd,
            correlation_log: (rows_n >= 2 && vq > 0.0 && vt > 0.0).then(|| cov / (vq * vt).sqrt()),
            nadir_limited,
        };
        let public = ps
            .iter()
            .filter(|p| p.carb_ratio_source == CarbRatioSource::Quest)
            .count();
        Ok(CohortSummary {
            population: self.config.population,
            size: ps.len(),
            public,
            generated: ps.len() - public,
            seed: self.config.seed,
            parameters,
            rejections: self.rejections.clone(),
            titration_vs_quest,
            standard_day_range_mg_dl: [
                ps.iter()
                    .map(|p| p.checks.standard_day.min_mg_dl)
                    .fold(f64::INFINITY, f64::min),
                ps.iter()
                    .map(|p| p.checks.standard_day.max_mg_dl)
                    .fold(f64::NEG_INFINITY, f64::max),
            ],
            config: self.config.clone(),
        })
    }
}
