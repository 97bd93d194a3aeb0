//! The parallel runner: every patient × scenario × arm is an independent
//! job; rayon runs them and the results come back in job order, so serial
//! and parallel runs give identical bytes.

use crate::closed_loop::run_patient;
use crate::error::TrialError;
use crate::protocol::TrialConfig;
use crate::results::ArmResult;
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

/// Runs the whole trial. `threads` = 0 uses rayon's default pool; 1 runs
/// serially on the calling thread.
pub fn run_trial(
    config: &TrialConfig,
    threads: usize,
    progress: &dyn Progress,
) -> Result<TrialOutput, TrialError> {
    config.validate()?;
    let cohort = build_cohort(config)?;
    let scenarios: Vec<_> = config
        .scenarios
        .iter()
        .map(|id| config.scenario(*id))
        .collect();
    let mut jobs = Vec::new();
    for (si, _) in scenarios.iter().enumerate() {
        for (ai, _) in config.arms.iter().enumerate() {
            for pi in 0..cohort.patients.len() {
                jobs.push((si, ai, pi));
            }
        }
    }
    let total = jobs.len();
    let done = AtomicUsize::new(0);
    let job = |&(si, ai, pi): &(usize, usize, usize)| {
        let r = run_patient(
            config,
            &cohort.patients[pi],
            pi as u64 + 1,
            &scenarios[si],
            config.arms[ai],
        );
        progress.update(done.fetch_add(1, Ordering::Relaxed) + 1, total);
        r
    };
    let results: Vec<_> = if threads == 1 {
        jobs.iter().map(job).collect::<Result<_, _>>()?
    } else {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| TrialError::Config(format!("cannot start {threads} threads: {e}")))?;
        pool.install(|| jobs.par_iter().map(job).collect::<Result<_, _>>())?
    };
    let mut arms = Vec::new();
    let mut it = results.into_iter();
    for s in &scenarios {
        for arm in &config.arms {
            let patients: Vec<_> = it.by_ref().take(cohort.patients.len()).collect();
            arms.push(ArmResult {
                scenario: s.name.clone(),
                advisor: arm.name().to_string(),
                mode: TrialConfig::mode_for(s).name().to_string(),
                patients,
            });
        }
    }
    Ok(TrialOutput { cohort, arms })
}
