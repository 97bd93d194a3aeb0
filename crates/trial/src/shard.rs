//! A trial split into shards that run anywhere (another process, another
//! machine, a batch scheduler, a Dask worker) and merge into exactly the
//! output of a single run.
//!
//! The jobs of a trial are its (scenario, arm, patient) runs in report
//! order ([`crate::runner`]); shard `I/N` runs the `I`-th of `N` contiguous,
//! near-equal slices of that list, i.e. a few (scenario, arm, patient range)
//! blocks. Every shard builds the cohort and calibrates the TE reference
//! over the whole cohort itself (runs are pure functions of the
//! configuration, so all shards agree; the calibration costs
//! `init_days + 2` simulated days per patient and mode), then runs only its
//! jobs. [`merge`] checks that the shards belong to one trial and cover
//! every job exactly once, and returns the same [`TrialOutput`] as
//! [`run_trial`](crate::runner::run_trial): the report written from it is
//! byte-identical (tested in `tests/shard_merge.rs`).
//!
//! A shard file is JSON ([`ShardFile`]); floating-point numbers are written
//! with the shortest representation that reads back to the same bits.

use crate::error::TrialError;
use crate::protocol::TrialConfig;
use crate::results::{PatientResult, RunFailure, TwinCheckCounts, Week, WeekResult};
use crate::runner::{self, Progress, TrialOutput};
use abba_core::metrics::GlucoseMetrics;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The format tag of a shard file.
pub const SHARD_FORMAT: &str = "abba-trial-shard/1";

/// Shard `index` of `count` (1-based, as in `--shard 2/8`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShardSpec {
    /// Which shard, 1..=count.
    pub index: u32,
    /// How many shards the trial is split into (at least 1).
    pub count: u32,
}

impl ShardSpec {
    /// Shard `index` of `count`; errors unless 1 <= index <= count.
    pub fn new(index: u32, count: u32) -> Result<Self, TrialError> {
        if count == 0 || index == 0 || index > count {
            return Err(TrialError::Config(format!(
                "shard {index}/{count}: expected I/N with 1 <= I <= N"
            )));
        }
        Ok(Self { index, count })
    }

    /// The half-open range of job positions this shard runs out of `total`.
    pub fn range(&self, total: usize) -> std::ops::Range<usize> {
        let (i, n) = (self.index as usize, self.count as usize);
        (total * (i - 1) / n)..(total * i / n)
    }
}

impl std::fmt::Display for ShardSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl std::str::FromStr for ShardSpec {
    type Err = TrialError;
    fn from_str(s: &str) -> Result<Self, TrialError> {
        let bad = || {
            TrialError::Config(format!(
                "shard '{s}': expected I/N with whole numbers 1 <= I <= N (e.g. 2/8)"
            ))
        };
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let i = i.trim().parse().map_err(|_| bad())?;
        let n = n.trim().parse().map_err(|_| bad())?;
        Self::new(i, n)
    }
}

/// One job's result in a shard file: which job, and the patient's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardJob {
    /// Position of the job in the trial's job list (report order).
    pub job: usize,
    /// The patient's result.
    pub result: StoredPatient,
}

/// Everything a shard produced, as written to its file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardFile {
    /// [`SHARD_FORMAT`].
    pub format: String,
    /// Which shard.
    pub shard: ShardSpec,
    /// The configuration as requested (before TE calibration); all shards of
    /// one trial must have the same.
    pub requested: TrialConfig,
    /// The configuration actually run (with the calibrated TE reference).
    pub config: TrialConfig,
    /// First-week TE per mode.
    pub first_week_te_bits: BTreeMap<String, Vec<f64>>,
    /// Number of jobs of the whole trial.
    pub total_jobs: usize,
    /// This shard's jobs, in job order.
    pub jobs: Vec<ShardJob>,
}

/// Runs shard `spec` of the trial `config` (`threads` as in
/// [`run_trial`](crate::runner::run_trial)).
pub fn run_shard(
    config: &TrialConfig,
    spec: ShardSpec,
    threads: usize,
    progress: &dyn Progress,
) -> Result<ShardFile, TrialError> {
    let prepared = runner::prepare(config, threads)?;
    let all = runner::jobs(&prepared.config, prepared.cohort.patients.len());
    let range = spec.range(all.len());
    let results = runner::run_jobs(&prepared, &all[range.clone()], progress)?;
    Ok(ShardFile {
        format: SHARD_FORMAT.to_string(),
        shard: spec,
        requested: config.clone(),
        config: prepared.config,
        first_week_te_bits: prepared.first_week_te_bits,
        total_jobs: all.len(),
        jobs: range
            .zip(results)
            .map(|(job, r)| ShardJob {
                job,
                result: StoredPatient::from(&r),
            })
            .collect(),
    })
}

/// Merges the shards of one trial (in any order) into the output of a
/// single run. Errors name what does not fit: a different trial, a missing
/// or repeated shard, a job not covered or covered twice.
pub fn merge(shards: &[ShardFile]) -> Result<TrialOutput, TrialError> {
    let bad = |m: String| Err(TrialError::Shard(m));
    let Some(first) = shards.first() else {
        return bad("no shards to merge".into());
    };
    let count = first.shard.count;
    let mut seen = vec![false; count as usize];
    for s in shards {
        if s.format != SHARD_FORMAT {
            return bad(format!(
                "shard {}: format '{}', expected '{SHARD_FORMAT}'",
                s.shard, s.format
            ));
        }
        if s.shard.count != count {
            return bad(format!(
                "shard {} belongs to a split into {} shards, shard {} to {count}",
                s.shard, s.shard.count, first.shard
            ));
        }
        if s.requested != first.requested || s.config != first.config {
            return bad(format!(
                "shard {} was run with a different trial configuration than shard {}",
                s.shard, first.shard
            ));
        }
        if s.first_week_te_bits != first.first_week_te_bits || s.total_jobs != first.total_jobs {
            return bad(format!(
                "shard {} disagrees with shard {} on the TE calibration or the number of jobs",
                s.shard, first.shard
            ));
        }
        let slot = &mut seen[(s.shard.index - 1) as usize];
        if *slot {
            return bad(format!("shard {} is given twice", s.shard));
        }
        *slot = true;
    }
    if let Some(i) = seen.iter().position(|s| !s) {
        return bad(format!("shard {}/{count} is missing", i + 1));
    }
    let mut results: Vec<Option<PatientResult>> = vec![None; first.total_jobs];
    for s in shards {
        let expected = s.shard.range(first.total_jobs);
        for j in &s.jobs {
            if !expected.contains(&j.job) {
                return bad(format!(
                    "shard {} holds job {} outside its range {}..{}",
                    s.shard, j.job, expected.start, expected.end
                ));
            }
            if results[j.job].replace(j.result.to_result()).is_some() {
                return bad(format!("job {} appears twice", j.job));
            }
        }
    }
    let mut ordered = Vec::with_capacity(results.len());
    for (job, r) in results.into_iter().enumerate() {
        match r {
            Some(r) => ordered.push(r),
            None => return bad(format!("job {job} is in no shard")),
        }
    }
    let cohort = runner::build_cohort(&first.config)?;
    let arms = runner::assemble(&first.config, cohort.patients.len(), ordered)?;
    Ok(TrialOutput {
        config: first.config.clone(),
        first_week_te_bits: first.first_week_te_bits.clone(),
        cohort,
        arms,
    })
}

/// Writes a shard file (compact JSON).
pub fn write_shard(path: &std::path::Path, shard: &ShardFile) -> Result<(), TrialError> {
    let bytes = serde_json::to_vec(shard)
        .map_err(|e| TrialError::Shard(format!("cannot encode shard {}: {e}", shard.shard)))?;
    std::fs::write(path, bytes).map_err(|source| TrialError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a shard file; the error names the file.
pub fn read_shard(path: &std::path::Path) -> Result<ShardFile, TrialError> {
    let text = std::fs::read_to_string(path).map_err(|source| TrialError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|e| {
        TrialError::Config(format!(
            "{}: not an abba trial shard file ({e})",
            path.display()
        ))
    })
}

/// A [`PatientResult`] with every field, for a shard file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StoredPatient {
    patient: String,
    weeks: Vec<StoredWeek>,
    final_basal_u_per_h: f64,
    final_carb_ratio_g_per_u: [f64; 3],
    start_basal_u_per_h: f64,
    start_carb_ratio_g_per_u: f64,
    pump_capped: u32,
    min_glucose_mg_dl: f64,
    failure: Option<(u32, u32, f64)>,
    rescue_carbs_g: f64,
    rescue_treatments: u32,
    /// The abba-twin arm's counts (absent for every other arm, so shards
    /// of trials without the arm read and write as before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    twin_check: Option<TwinCheckCounts>,
}

/// A [`WeekResult`] with every metric field (including the ones the report
/// JSON leaves out).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct StoredWeek {
    week: Week,
    first_day: u32,
    last_day: u32,
    /// tir, hypo, severe hypo, hyper, severe hyper, lbgi, hbgi, mean, cv,
    /// gmi, <54, <70, >180, >250, sd.
    values: [f64; 15],
    mage: Option<f64>,
    n_readings: usize,
    tdi_u_per_day: f64,
    /// 5-minute plasma glucose of W1, W13 and W14 (for the cohort profiles
    /// of `report.html`; empty for other weeks).
    #[serde(default)]
    plasma_5min_mg_dl: Vec<f32>,
}

impl From<&PatientResult> for StoredPatient {
    fn from(p: &PatientResult) -> Self {
        Self {
            patient: p.patient.clone(),
            weeks: p
                .weeks
                .iter()
                .map(|w| {
                    let m = &w.metrics;
                    StoredWeek {
                        week: w.week,
                        first_day: w.first_day,
                        last_day: w.last_day,
                        values: [
                            m.tir_70_180,
                            m.hypo_50_70,
                            m.severe_hypo_lt50,
                            m.hyper_180_300,
                            m.severe_hyper_gt300,
                            m.lbgi,
                            m.hbgi,
                            m.mean_mg_dl,
                            m.cv_pct,
                            m.gmi_pct,
                            m.below_54,
                            m.below_70,
                            m.above_180,
                            m.above_250,
                            m.sd_mg_dl,
                        ],
                        mage: m.mage,
                        n_readings: m.n_readings,
                        tdi_u_per_day: w.tdi_u_per_day,
                        plasma_5min_mg_dl: w.plasma_5min_mg_dl.clone(),
                    }
                })
                .collect(),
            final_basal_u_per_h: p.final_basal_u_per_h,
            final_carb_ratio_g_per_u: p.final_carb_ratio_g_per_u,
            start_basal_u_per_h: p.start_basal_u_per_h,
            start_carb_ratio_g_per_u: p.start_carb_ratio_g_per_u,
            pump_capped: p.pump_capped,
            min_glucose_mg_dl: p.min_glucose_mg_dl,
            failure: p.failure.map(|f| (f.day, f.minute_of_day, f.glucose_mg_dl)),
            rescue_carbs_g: p.rescue_carbs_g,
            rescue_treatments: p.rescue_treatments,
            twin_check: p.twin_check,
        }
    }
}

impl StoredPatient {
    fn to_result(&self) -> PatientResult {
        PatientResult {
            patient: self.patient.clone(),
            weeks: self
                .weeks
                .iter()
                .map(|w| {
                    let v = &w.values;
                    WeekResult {
                        week: w.week,
                        first_day: w.first_day,
                        last_day: w.last_day,
                        metrics: GlucoseMetrics {
                            tir_70_180: v[0],
                            hypo_50_70: v[1],
                            severe_hypo_lt50: v[2],
                            hyper_180_300: v[3],
                            severe_hyper_gt300: v[4],
                            lbgi: v[5],
                            hbgi: v[6],
                            mage: w.mage,
                            mean_mg_dl: v[7],
                            cv_pct: v[8],
                            gmi_pct: v[9],
                            below_54: v[10],
                            below_70: v[11],
                            above_180: v[12],
                            above_250: v[13],
                            sd_mg_dl: v[14],
                            n_readings: w.n_readings,
                        },
                        tdi_u_per_day: w.tdi_u_per_day,
                        plasma_5min_mg_dl: w.plasma_5min_mg_dl.clone(),
                    }
                })
                .collect(),
            final_basal_u_per_h: self.final_basal_u_per_h,
            final_carb_ratio_g_per_u: self.final_carb_ratio_g_per_u,
            start_basal_u_per_h: self.start_basal_u_per_h,
            start_carb_ratio_g_per_u: self.start_carb_ratio_g_per_u,
            pump_capped: self.pump_capped,
            min_glucose_mg_dl: self.min_glucose_mg_dl,
            failure: self
                .failure
                .map(|(day, minute_of_day, glucose_mg_dl)| RunFailure {
                    day,
                    minute_of_day,
                    glucose_mg_dl,
                }),
            rescue_carbs_g: self.rescue_carbs_g,
            rescue_treatments: self.rescue_treatments,
            twin_check: self.twin_check,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn shard_specs_parse_and_split_every_job_once() {
        assert_eq!(
            "2/8".parse::<ShardSpec>().unwrap(),
            ShardSpec::new(2, 8).unwrap()
        );
        for bad in ["0/3", "4/3", "1/0", "3", "a/b", ""] {
            assert!(bad.parse::<ShardSpec>().is_err(), "{bad}");
        }
        for total in [0, 1, 7, 120, 1201] {
            for n in 1..=9 {
                let mut next = 0;
                for i in 1..=n {
                    let r = ShardSpec::new(i, n).unwrap().range(total);
                    assert_eq!(r.start, next);
                    assert!(r.len() <= total / n as usize + 1);
                    next = r.end;
                }
                assert_eq!(next, total);
            }
        }
    }
}
