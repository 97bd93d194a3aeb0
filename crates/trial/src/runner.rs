//! The parallel runner: every patient × scenario × arm is an independent
//! job; rayon runs them and the results come back in job order, so serial
//! and parallel runs give identical bytes.

use crate::closed_loop::{run_patient_group, run_patient_group_with_init, run_patient_with, Trace};
use crate::error::TrialError;
use crate::protocol::{ArmKind, PlannedScenario, TrialConfig};
use crate::results::ArmResult;
use abba_advisor::abba::TeOutcome;
use abba_advisor::Mode;
use abba_sim::cohort::{Cohort, CohortConfig};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Progress of a run: jobs done out of the total (one job = one patient in
/// one scenario and arm). Called from worker threads.
pub trait Progress: Sync {
    /// `done` of `total` jobs finished.
    fn update(&self, done: usize, total: usize);
}

/// No progress reporting.
pub struct Silent;

impl Progress for Silent {
    fn update(&self, _done: usize, _total: usize) {}
}

/// A finished trial.
#[derive(Debug, Clone)]
pub struct TrialOutput {
    /// The configuration actually run (with the calibrated TE reference).
    pub config: TrialConfig,
    /// The cohort's first-week transfer entropies (bits) per advisor mode
    /// (`cgm`, `smbg`), when calibrated.
    pub first_week_te_bits: std::collections::BTreeMap<String, Vec<f64>>,
    /// The cohort that was simulated.
    pub cohort: Cohort,
    /// One entry per scenario × arm, in configuration order.
    pub arms: Vec<ArmResult>,
}

/// Builds the cohort of a configuration.
pub fn build_cohort(config: &TrialConfig) -> Result<Cohort, TrialError> {
    Cohort::generate(&CohortConfig::new(
        config.population,
        config.patients,
        config.cohort_seed,
    ))
    .map_err(|source| TrialError::Sim {
        context: "cohort".into(),
        source,
    })
}

/// Runs the whole trial. `threads` = 0 uses rayon's default pool (one
/// thread per core); 1 runs serially on the calling thread.
pub fn run_trial(
    config: &TrialConfig,
    threads: usize,
    progress: &dyn Progress,
) -> Result<TrialOutput, TrialError> {
    // The cohort is drawn in parallel on as many threads as the trial runs.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| TrialError::Config(format!("cannot start {threads} threads: {e}")))?;
    let cohort = pool.install(|| build_cohort(config))?;
    run_trial_on(config, cohort, threads, progress)
}

/// Runs the trial on a given cohort (e.g. a cohort without its public
/// patients, for calibration); `config`'s cohort fields are not used.
pub fn run_trial_on(
    config: &TrialConfig,
    cohort: Cohort,
    threads: usize,
    progress: &dyn Progress,
) -> Result<TrialOutput, TrialError> {
    let prepared = prepare_on(config, cohort, threads)?;
    let jobs = jobs(&prepared.config, prepared.cohort.patients.len());
    let results = run_jobs(&prepared, &jobs, progress)?;
    let arms = assemble(&prepared.config, prepared.cohort.patients.len(), results)?;
    Ok(TrialOutput {
        config: prepared.config,
        first_week_te_bits: prepared.first_week_te_bits,
        cohort: prepared.cohort,
        arms,
    })
}

/// A trial ready to run jobs: the cohort, the thread pool and the
/// configuration with the calibrated TE reference (the calibration uses the
/// whole cohort, so every shard of a trial computes the same one).
pub(crate) struct Prepared {
    /// The configuration actually run.
    pub(crate) config: TrialConfig,
    /// First-week TE per mode (see [`TrialOutput::first_week_te_bits`]).
    pub(crate) first_week_te_bits: std::collections::BTreeMap<String, Vec<f64>>,
    /// The cohort.
    pub(crate) cohort: Cohort,
    threads: usize,
    pool: rayon::ThreadPool,
}

/// Builds the cohort and calibrates the TE reference.
pub(crate) fn prepare(config: &TrialConfig, threads: usize) -> Result<Prepared, TrialError> {
    prepare_on(config, build_cohort(config)?, threads)
}

/// Calibrates the TE reference on `cohort`.
fn prepare_on(
    config: &TrialConfig,
    cohort: Cohort,
    threads: usize,
) -> Result<Prepared, TrialError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| TrialError::Config(format!("cannot start {threads} threads: {e}")))?;
    let mut config = config.clone();
    let mut first_week_te_bits = std::collections::BTreeMap::new();
    if config.calibrate_te_ref && config.runs_abba() {
        // The TE estimate does not depend on TE_ref, so one pass for both
        // modes.
        let mut raw = config.raw().clone();
        let by_mode = pool.install(|| calibrate_te(&config, &cohort, threads))?;
        for mode in [Mode::Cgm, Mode::Smbg] {
            let te = by_mode
                .iter()
                .find(|(m, _)| *m == mode)
                .map(|(_, te)| te.clone())
                .unwrap_or_default();
            match (mode, positive_median(&te)) {
                (Mode::Cgm, Some(m)) => raw.abba.te.te_ref_bits = m,
                (Mode::Smbg, Some(m)) => raw.te_ref_bits_smbg = Some(m),
                _ => {}
            }
            if !te.is_empty() {
                first_week_te_bits.insert(mode.name().to_string(), te);
            }
        }
        config = TrialConfig::try_from(raw)?;
    }
    Ok(Prepared {
        config,
        first_week_te_bits,
        cohort,
        threads,
        pool,
    })
}

/// Every job of a trial as (scenario index, arm index, patient index) into
/// the planned scenarios, the arms and the cohort, in report order.
pub(crate) fn jobs(config: &TrialConfig, patients: usize) -> Vec<(usize, usize, usize)> {
    let mut jobs = Vec::new();
    for si in 0..config.planned().len() {
        for ai in 0..config.arms.len() {
            for pi in 0..patients {
                jobs.push((si, ai, pi));
            }
        }
    }
    jobs
}

/// Runs `jobs` (in parallel unless the pool has one thread); the results
/// come back in the order of `jobs`.
pub(crate) fn run_jobs(
    prepared: &Prepared,
    jobs: &[(usize, usize, usize)],
    progress: &dyn Progress,
) -> Result<Vec<crate::results::PatientResult>, TrialError> {
    let config = &prepared.config;
    let cohort = &prepared.cohort;
    let scenarios = config.planned();
    let total = jobs.len();
    let done = AtomicUsize::new(0);
    // The jobs of one patient run together, in lock-step
    // (`run_patient_group`: the same results as one by one, bit for bit,
    // sharing the patient model's gut work).
    let groups = lockstep_groups(jobs);
    let group = |g: &Vec<usize>| {
        let pi = jobs[g[0]].2;
        let runs: Vec<_> = g
            .iter()
            .map(|&j| (&scenarios[jobs[j].0], config.arms[jobs[j].1]))
            .collect();
        let r = run_patient_group(config, &cohort.patients[pi], pi as u64 + 1, &runs);
        progress.update(done.fetch_add(g.len(), Ordering::Relaxed) + g.len(), total);
        r
    };
    let per_group: Vec<Vec<crate::results::PatientResult>> = if prepared.threads == 1 {
        groups.iter().map(group).collect::<Result<_, _>>()?
    } else {
        prepared
            .pool
            .install(|| groups.par_iter().map(group).collect::<Result<_, _>>())?
    };
    let mut results: Vec<Option<crate::results::PatientResult>> = vec![None; jobs.len()];
    for (g, rs) in groups.iter().zip(per_group) {
        for (&j, r) in g.iter().zip(rs) {
            results[j] = Some(r);
        }
    }
    results
        .into_iter()
        .map(|r| r.ok_or_else(|| TrialError::Config("a trial job produced no result".into())))
        .collect()
}

/// The indices of `jobs` grouped by patient, each group in job order, the
/// groups in the order of their first job.
fn lockstep_groups(jobs: &[(usize, usize, usize)]) -> Vec<Vec<usize>> {
    let mut index: std::collections::HashMap<usize, usize> = std::collections::HashMap::new();
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (j, &(_, _, pi)) in jobs.iter().enumerate() {
        let g = *index.entry(pi).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(j);
    }
    groups
}

/// Groups the results of every job (in [`jobs`] order) into one
/// [`ArmResult`] per scenario × arm.
pub(crate) fn assemble(
    config: &TrialConfig,
    patients: usize,
    results: Vec<crate::results::PatientResult>,
) -> Result<Vec<ArmResult>, TrialError> {
    let expected = config.planned().len() * config.arms.len() * patients;
    if results.len() != expected {
        return Err(TrialError::Shard(format!(
            "{} patient results for {expected} jobs",
            results.len()
        )));
    }
    let mut arms = Vec::new();
    let mut it = results.into_iter();
    for s in config.planned() {
        for arm in &config.arms {
            let patients: Vec<_> = it.by_ref().take(patients).collect();
            arms.push(ArmResult {
                scenario: s.id,
                advisor: *arm,
                mode: s.mode,
                patients,
            });
        }
    }
    Ok(arms)
}

/// Each patient's transfer entropy from insulin to glucose over the
/// standard-therapy week, as ABBA itself estimates it at the end of its
/// initialisation week, per advisor mode (in cohort order; patients whose
/// estimate failed are left out). Runs the first configured scenario of
/// each mode just past the initialisation; a patient's runs of both modes
/// go together in lock-step (`run_patient_group_with_init`: the same
/// results as one at a time, sharing the gut's work: the scenarios share
/// their days).
fn calibrate_te(
    config: &TrialConfig,
    cohort: &Cohort,
    threads: usize,
) -> Result<Vec<(Mode, Vec<f64>)>, TrialError> {
    let planned: Vec<PlannedScenario> = [Mode::Cgm, Mode::Smbg]
        .into_iter()
        .filter_map(|mode| config.planned().iter().find(|p| p.mode == mode).cloned())
        .map(|mut s| {
            s.config.days = config.init_days + 2;
            s
        })
        .collect();
    let runs: Vec<_> = planned.iter().map(|s| (s, ArmKind::Abba)).collect();
    let one = |(pi, vp): (usize, &abba_sim::cohort::VirtualPatient)| {
        let results = run_patient_group_with_init(config, vp, pi as u64 + 1, &runs)?;
        Ok(results
            .into_iter()
            .map(|(_, init)| match init.map(|r| r.te) {
                Some(TeOutcome::Estimated(e)) => Some(e.te_bits),
                _ => None,
            })
            .collect::<Vec<_>>())
    };
    let all: Vec<Vec<Option<f64>>> = if threads == 1 {
        cohort
            .patients
            .iter()
            .enumerate()
            .map(one)
            .collect::<Result<_, TrialError>>()?
    } else {
        cohort
            .patients
            .par_iter()
            .enumerate()
            .map(one)
            .collect::<Result<_, TrialError>>()?
    };
    Ok(planned
        .iter()
        .enumerate()
        .map(|(k, s)| (s.mode, all.iter().filter_map(|p| p[k]).collect()))
        .collect())
}

/// The median of the values if there are any and it is positive (a trial
/// without a scenario of a mode has no estimate for that mode).
fn positive_median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = crate::stats::quantile_sorted(&sorted, 0.5);
    (median > 0.0).then_some(median)
}

/// Re-runs one patient of the trial's cohort in one scenario and arm with a
/// full trace (every minute, every decision). Runs are pure functions of the
/// configuration, so this reproduces exactly what the trial simulated.
pub fn trace_patient(
    config: &TrialConfig,
    cohort: &Cohort,
    patient: &str,
    scenario: abba_sim::scenario::ScenarioId,
    arm: ArmKind,
) -> Result<(crate::results::PatientResult, Trace), TrialError> {
    let Some(index) = cohort
        .patients
        .iter()
        .position(|p| p.params.name == patient)
    else {
        return Err(TrialError::Config(format!(
            "--trace: no patient '{patient}' in the cohort ({} .. {})",
            cohort
                .patients
                .first()
                .map_or("", |p| p.params.name.as_str()),
            cohort
                .patients
                .last()
                .map_or("", |p| p.params.name.as_str()),
        )));
    };
    let Some(planned) = config.planned_scenario(scenario) else {
        return Err(TrialError::Config(format!(
            "--trace: scenario {scenario} is not among the scenarios run"
        )));
    };
    let mut trace = Trace {
        events: Some(Vec::new()),
        decisions: Some(Vec::new()),
        minutes: Some(Vec::new()),
        init: None,
    };
    let result = run_patient_with(
        config,
        &cohort.patients[index],
        index as u64 + 1,
        planned,
        arm,
        &mut trace,
    )?;
    Ok((result, trace))
}
