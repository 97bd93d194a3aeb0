//! Virtual cohorts (protocol.md §2-§3): the 10 public patients of a group
//! unchanged, plus generated ones, each with its standard therapy.
//!
//! A generated patient mixes two distinct public patients A and B of its
//! group in log space, log p = w·log p_A + (1 − w)·log p_B + ε with
//! w ~ U(0, 1) and ε ~ N(0, 0.1²) independently for every *primary*
//! parameter ([`derive::PRIMARY`]); parameters common to every public
//! patient ([`derive::COMMON`]) keep their value; every steady-state
//! quantity is then derived ([`derive::derive_steady_state`]), so each
//! patient starts at an exact steady state at its basal rate. A candidate is
//! kept only if it passes the [`PlausibilityLimits`]; otherwise it is
//! counted as rejected, with the reason, and another is drawn.
//!
//! Determinism: the candidates for patient number n (adult#011 is 11) come
//! from one ChaCha8 stream seeded with
//! `derive_seed(cohort_seed, n, population tag, Stream::Cohort)`, so a
//! patient depends only on (seed, population, n): a smaller `size` gives a
//! prefix of a larger cohort. Draw order per candidate: index of A (uniform
//! over the 10), index of B (uniform over the other 9), w, then ε for each
//! primary parameter in [`derive::PRIMARY`] order.
//!
//! ```no_run
//! use abba_sim::cohort::{Cohort, CohortConfig, Population};
//! let cohort = Cohort::generate(&CohortConfig::new(Population::Adults, 100, 1)).unwrap();
//! assert_eq!(cohort.patients[0].params.name, "adult#001");
//! ```

pub mod derive;
mod io;
mod summary;
pub mod therapy;

pub use io::{read_csv, THERAPY_COLUMNS};
pub use summary::{CohortSummary, ParamStats, TitrationComparison, TitrationSummary};
pub use therapy::{StandardDay, Titration, TitrationRule};

use crate::patient::{PatientParams, QuestRow};
use crate::scenario::MealConfig;
use crate::SimError;
use abba_core::{derive_seed, GramsPerUnit, Stream, TherapySettings, UnitsPerHour};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The largest cohort [`Cohort::generate`] builds. Generating and checking
/// one patient takes a few milliseconds (about 3-5 ms on the reference
/// 2-core machine, see BENCHMARKS.md) and holding it about 2 kB, so 100,000
/// patients take several minutes and about 0.2 GB; a size far beyond would
/// run for hours or exhaust memory, and is refused up front.
pub const MAX_COHORT_SIZE: u32 = 100_000;

/// The three public groups.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Population {
    /// `adult#001`..: the paper's population.
    Adults,
    /// `adolescent#001`..
    Adolescents,
    /// `child#001`..
    Children,
}

impl Population {
    /// All three.
    pub const ALL: [Population; 3] = [
        Population::Adults,
        Population::Adolescents,
        Population::Children,
    ];

    /// Name prefix of the group's patients (`adult`, `adolescent`, `child`).
    pub fn prefix(self) -> &'static str {
        match self {
            Population::Adults => "adult",
            Population::Adolescents => "adolescent",
            Population::Children => "child",
        }
    }

    /// `adults`, `adolescents`, `children`.
    pub fn name(self) -> &'static str {
        match self {
            Population::Adults => "adults",
            Population::Adolescents => "adolescents",
            Population::Children => "children",
        }
    }

    /// The `scenario` slot of the cohort's seed derivation (never renumber).
    pub fn tag(self) -> u64 {
        match self {
            Population::Adults => 1,
            Population::Adolescents => 2,
            Population::Children => 3,
        }
    }

    /// The name of patient number `n` (1-based): `adult#001`.
    pub fn patient_name(self, n: u32) -> String {
        format!("{}#{:03}", self.prefix(), n)
    }

    /// The plausibility limits used by default for this group (see
    /// [`PlausibilityLimits`] for how they were chosen).
    pub fn default_limits(self) -> PlausibilityLimits {
        let (rate, day) = match self {
            Population::Adults => ([0.5, 3.0], [60.0, 300.0]),
            Population::Adolescents => ([0.3, 2.0], [60.0, 350.0]),
            Population::Children => ([0.15, 1.0], [30.0, 500.0]),
        };
        PlausibilityLimits {
            basal_glucose_mg_dl: [120.0, 170.0],
            basal_rate_u_per_h: rate,
            standard_day_mg_dl: day,
            standard_days: 2,
            steady_state_tolerance: 1e-9,
        }
    }
}

impl std::fmt::Display for Population {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Population {
    type Err = SimError;
    fn from_str(s: &str) -> Result<Self, SimError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "adults" | "adult" => Ok(Population::Adults),
            "adolescents" | "adolescent" => Ok(Population::Adolescents),
            "children" | "child" => Ok(Population::Children),
            _ => Err(SimError::Config(format!(
                "unknown population '{s}' (expected adults, adolescents or children)"
            ))),
        }
    }
}

/// What a patient must satisfy to be in a cohort.
///
/// The checks, in order: the parameters pass [`PatientParams::validate`]
/// and admit a steady state; the initial state is a steady state
/// (max |dx/dt| below `steady_state_tolerance` at the exact basal rate);
/// basal glucose Gb and the steady-state basal rate lie in their ranges;
/// the carb-ratio titration succeeds (generated patients); and a standard
/// day under standard therapy (nominal meals 07:00 50 g, 12:00 60 g,
/// 18:30 80 g bolused exactly with the standard carb ratio, 23:00 15 g
/// unbolused, the rounded basal rate, nominal sensitivity), repeated
/// `standard_days` times from the steady state, keeps plasma glucose within
/// `standard_day_mg_dl`.
///
/// The defaults come from the public patients, who are plausible by
/// definition: every public patient of a group passes its group's limits
/// (a test checks it), and the ranges reach a little beyond theirs, so that
/// generated patients are as varied as the public ones but not more extreme.
/// Public Gb lies in 133-153 mg/dL in all groups; public basal rates are
/// 0.89-1.73 U/h (adults), 0.56-0.92 (adolescents), 0.29-0.52 (children);
/// on the standard day under their Quest therapy public adults stay in
/// 84-210 mg/dL, adolescents in 85-305, children in 36-452 (the public
/// children's own therapy is that loose, so their limits must be too).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PlausibilityLimits {
    /// Allowed basal plasma glucose Gb (mg/dL), [low, high].
    pub basal_glucose_mg_dl: [f64; 2],
    /// Allowed steady-state basal rate (U/h), [low, high].
    pub basal_rate_u_per_h: [f64; 2],
    /// Allowed plasma glucose during the standard days (mg/dL), [low, high].
    pub standard_day_mg_dl: [f64; 2],
    /// Number of standard days simulated.
    pub standard_days: u32,
    /// Largest |dx/dt| accepted at the initial state.
    pub steady_state_tolerance: f64,
}

/// How to build a cohort.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CohortConfig {
    /// Which group.
    pub population: Population,
    /// Number of patients (the first min(size, 10) are the public ones).
    pub size: u32,
    /// Cohort seed.
    pub seed: u64,
    /// SD of the log-space noise ε on every primary parameter (0.1).
    pub mix_noise_sd: f64,
    /// Basal-rate increment of the pump (0.05 U/h).
    pub basal_increment_u_per_h: f64,
    /// The carb-ratio titration rule.
    pub titration: TitrationRule,
    /// Plausibility checks.
    pub limits: PlausibilityLimits,
    /// Candidates drawn for one patient before giving up with an error.
    pub max_candidates_per_patient: u32,
}

impl CohortConfig {
    /// The protocol's defaults for `population`, `size` and `seed`.
    pub fn new(population: Population, size: u32, seed: u64) -> Self {
        Self {
            population,
            size,
            seed,
            mix_noise_sd: 0.1,
            basal_increment_u_per_h: 0.05,
            titration: TitrationRule::default(),
            limits: population.default_limits(),
            max_candidates_per_patient: 10_000,
        }
    }
}

/// Where a patient comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Origin {
    /// One of the public patients, unchanged.
    Public,
    /// A log-space mix of two public patients.
    Generated {
        /// Patient A.
        parent_a: String,
        /// Patient B.
        parent_b: String,
        /// Weight of A.
        w: f64,
        /// Candidates rejected before this one was accepted.
        rejected_before: u32,
    },
}

/// Where the standard carb ratio comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CarbRatioSource {
    /// Quest.csv (public patients).
    Quest,
    /// The titration rule (generated patients).
    Titrated,
}

impl CarbRatioSource {
    /// `quest` or `titrated`.
    pub fn name(self) -> &'static str {
        match self {
            CarbRatioSource::Quest => "quest",
            CarbRatioSource::Titrated => "titrated",
        }
    }
}

/// The measured values behind the plausibility checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CheckValues {
    /// Largest |dx/dt| at the initial state.
    pub steady_state_residual: f64,
    /// Steady-state basal rate before rounding (U/h).
    pub exact_basal_u_per_h: f64,
    /// Plasma glucose over the standard days.
    pub standard_day: StandardDay,
}

/// One patient of a cohort.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VirtualPatient {
    /// Model parameters (the 62 columns of vpatient_params.csv).
    pub params: PatientParams,
    /// Standard therapy: rounded steady-state basal and one carb ratio for all meals.
    pub therapy: TherapySettings,
    /// Where the carb ratio comes from.
    pub carb_ratio_source: CarbRatioSource,
    /// The titration result (computed for every patient, public ones included).
    pub titration: Titration,
    /// Public or generated.
    pub origin: Origin,
    /// What the plausibility checks measured.
    pub checks: CheckValues,
}

/// Rejected candidates.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rejections {
    /// Total candidates rejected.
    pub total: u64,
    /// Count per reason (the check that failed).
    pub by_reason: BTreeMap<String, u64>,
}

/// A cohort: patients and how many candidates were rejected on the way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Cohort {
    /// How it was built.
    pub config: CohortConfig,
    /// The patients in order (public ones first).
    pub patients: Vec<VirtualPatient>,
    /// Rejected candidates of the generated patients.
    pub rejections: Rejections,
}

/// Why a candidate (or a public patient) fails the checks.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckFailure {
    /// Short key for counting (`basal_glucose`, `standard_day_low`,
    /// `invalid_parameter:b`, ...).
    pub reason: String,
    /// What was found.
    pub detail: String,
}

/// The failure for a parameter that does not validate, keyed by parameter.
fn invalid_parameter(e: SimError) -> CheckFailure {
    let reason = match &e {
        SimError::InvalidParameter { param, .. } => format!("invalid_parameter:{param}"),
        _ => "invalid_parameter".to_string(),
    };
    CheckFailure {
        reason,
        detail: e.to_string(),
    }
}

fn in_range(v: f64, r: [f64; 2]) -> bool {
    abba_core::limits::within(v, r[0], r[1])
}

/// Runs the plausibility checks on derived parameters with the given carb
/// ratio; returns the measured values or the first failure.
pub fn check_patient(
    p: &PatientParams,
    carb_ratio_g_per_u: f64,
    config: &CohortConfig,
) -> Result<CheckValues, CheckFailure> {
    let lim = &config.limits;
    let fail = |reason: &str, detail| {
        Err(CheckFailure {
            reason: reason.to_string(),
            detail,
        })
    };
    if let Err(e) = p.validate() {
        return Err(invalid_parameter(e));
    }
    let residual = derive::steady_state_residual(p)
        .iter()
        .fold(0.0f64, |m, v| m.max(v.abs()));
    if residual.is_nan() || residual >= lim.steady_state_tolerance {
        return fail(
            "not_steady",
            format!("max |dx/dt| = {residual:e} at the initial state"),
        );
    }
    if !in_range(p.gb, lim.basal_glucose_mg_dl) {
        return fail(
            "basal_glucose",
            format!(
                "Gb = {:.1} mg/dL outside [{}, {}]",
                p.gb, lim.basal_glucose_mg_dl[0], lim.basal_glucose_mg_dl[1]
            ),
        );
    }
    let exact_basal = p.basal_u_per_min() * abba_core::units::MINUTES_PER_HOUR;
    if !in_range(exact_basal, lim.basal_rate_u_per_h) {
        return fail(
            "basal_rate",
            format!(
                "basal rate {exact_basal:.3} U/h outside [{}, {}]",
                lim.basal_rate_u_per_h[0], lim.basal_rate_u_per_h[1]
            ),
        );
    }
    let basal = therapy::standard_basal_u_per_h(p, config.basal_increment_u_per_h);
    let day = match therapy::standard_day(
        p,
        &MealConfig::default(),
        basal,
        carb_ratio_g_per_u,
        lim.standard_days,
    ) {
        Ok(d) => d,
        Err(e) => return fail("standard_day_failed", e.to_string()),
    };
    let r = lim.standard_day_mg_dl;
    if day.min_mg_dl < r[0] {
        return fail(
            "standard_day_low",
            format!(
                "standard day falls to {:.1} mg/dL (< {})",
                day.min_mg_dl, r[0]
            ),
        );
    }
    if day.max_mg_dl > r[1] {
        return fail(
            "standard_day_high",
            format!(
                "standard day rises to {:.1} mg/dL (> {})",
                day.max_mg_dl, r[1]
            ),
        );
    }
    Ok(CheckValues {
        steady_state_residual: residual,
        exact_basal_u_per_h: exact_basal,
        standard_day: day,
    })
}

fn therapy_settings(
    p: &PatientParams,
    cr: f64,
    config: &CohortConfig,
) -> Result<TherapySettings, SimError> {
    let basal = therapy::standard_basal_u_per_h(p, config.basal_increment_u_per_h);
    TherapySettings::new(UnitsPerHour(basal), GramsPerUnit(cr)).map_err(|e| {
        SimError::InvalidParameter {
            patient: p.name.clone(),
            param: "standard therapy".into(),
            value: f64::NAN,
            reason: e.to_string(),
        }
    })
}

impl Cohort {
    /// Builds the cohort: the public patients of the group, then generated
    /// ones. Fails if a public patient fails the checks (the limits are then
    /// inconsistent with the group), if a patient needs more than
    /// `max_candidates_per_patient` candidates, or on invalid configuration.
    pub fn generate(config: &CohortConfig) -> Result<Cohort, SimError> {
        Self::generate_with_progress(config, &mut |_, _| {})
    }

    /// Like [`Cohort::generate`], calling `progress(done, total)` after each
    /// patient (the library never prints; the caller shows progress).
    pub fn generate_with_progress(
        config: &CohortConfig,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Cohort, SimError> {
        let cfg_err = |m: String| Err(SimError::Config(m));
        if !(config.mix_noise_sd.is_finite() && config.mix_noise_sd >= 0.0) {
            return cfg_err(format!(
                "cohort mix_noise_sd must be a finite number >= 0, got {}",
                config.mix_noise_sd
            ));
        }
        if !(config.basal_increment_u_per_h.is_finite() && config.basal_increment_u_per_h > 0.0) {
            return cfg_err(format!(
                "cohort basal_increment_u_per_h must be > 0, got {}",
                config.basal_increment_u_per_h
            ));
        }
        if config.size == 0 {
            return cfg_err("cohort size must be at least 1".into());
        }
        if config.size > MAX_COHORT_SIZE {
            return cfg_err(format!(
                "cohort size {} is above the limit of {MAX_COHORT_SIZE} patients: each generated \
                 patient takes a few milliseconds to draw and check and about 2 kB to hold, so \
                 {MAX_COHORT_SIZE} patients already take several minutes on one core",
                config.size
            ));
        }
        let total = config.size as usize;
        let prefix = format!("{}#", config.population.prefix());
        let public: Vec<PatientParams> = PatientParams::all_public()?
            .into_iter()
            .filter(|p| p.name.starts_with(&prefix))
            .collect();
        let quest = QuestRow::all()?;
        let mut patients = Vec::with_capacity(config.size as usize);
        for p in public.iter().take(config.size as usize) {
            let q = quest.iter().find(|q| q.name == p.name).ok_or_else(|| {
                SimError::UnknownPatient {
                    name: p.name.clone(),
                    known: "Quest.csv has no row for this patient".into(),
                }
            })?;
            let checks =
                check_patient(p, q.cr, config).map_err(|f| SimError::InvalidParameter {
                    patient: p.name.clone(),
                    param: format!("plausibility ({})", f.reason),
                    value: f64::NAN,
                    reason: format!(
                        "{}; a public patient must pass its group's plausibility limits",
                        f.detail
                    ),
                })?;
            let titration = therapy::titrate_carb_ratio(p, &config.titration)?;
            patients.push(VirtualPatient {
                therapy: therapy_settings(p, q.cr, config)?,
                params: p.clone(),
                carb_ratio_source: CarbRatioSource::Quest,
                titration,
                origin: Origin::Public,
                checks,
            });
            progress(patients.len(), total);
        }
        // Each generated patient has its own random stream (its number), so
        // they are drawn in parallel, a chunk at a time (progress for each
        // patient as its chunk is gathered), and gathered in order: the same cohort, and the
        // same first error, as one at a time.
        let mut rejections = Rejections::default();
        let numbers: Vec<u32> = ((public.len() as u32 + 1)..=config.size).collect();
        for chunk in numbers.chunks(GENERATION_CHUNK) {
            let drawn: Vec<Result<(VirtualPatient, Rejections), SimError>> = chunk
                .par_iter()
                .map(|&n| {
                    let mut r = Rejections::default();
                    generate_patient(config, &public, n, &mut r).map(|vp| (vp, r))
                })
                .collect();
            for d in drawn {
                let (vp, r) = d?;
                rejections.total += r.total;
                for (reason, count) in r.by_reason {
                    *rejections.by_reason.entry(reason).or_insert(0) += count;
                }
                patients.push(vp);
                progress(patients.len(), total);
            }
        }
        Ok(Cohort {
            config: config.clone(),
            patients,
            rejections,
        })
    }
}

/// Generated patients drawn in parallel between two progress reports.
const GENERATION_CHUNK: usize = 64;

/// Draws candidates for patient number `n` until one passes the checks.
fn generate_patient(
    config: &CohortConfig,
    public: &[PatientParams],
    n: u32,
    rejections: &mut Rejections,
) -> Result<VirtualPatient, SimError> {
    let k = public.len();
    if k < 2 {
        return Err(SimError::Config(format!(
            "population {} has {k} public patients; mixing needs at least 2",
            config.population
        )));
    }
    let name = config.population.patient_name(n);
    let seed = derive_seed(
        config.seed,
        u64::from(n),
        config.population.tag(),
        Stream::Cohort,
    );
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, config.mix_noise_sd)
        .map_err(|e| SimError::Config(format!("cohort mix_noise_sd: {e}")))?;
    for attempt in 0..config.max_candidates_per_patient {
        let ia = rng.gen_range(0..k);
        let mut ib = rng.gen_range(0..k - 1);
        if ib >= ia {
            ib += 1;
        }
        let w: f64 = rng.gen();
        let (a, b) = (&public[ia], &public[ib]);
        let mut p = a.clone();
        p.name = name.clone();
        p.i = n;
        for col in derive::PRIMARY {
            let eps = noise.sample(&mut rng);
            let (va, vb) = match (a.scalar(col), b.scalar(col)) {
                (Some(va), Some(vb)) => (va, vb),
                _ => {
                    return Err(SimError::Config(format!(
                        "primary parameter {col} is not a column of the patient table"
                    )))
                }
            };
            let v = (w * va.ln() + (1.0 - w) * vb.ln() + eps).exp();
            if let Some(slot) = p.scalar_mut(col) {
                *slot = v;
            }
        }
        let mut reject = |reason: &str| {
            rejections.total += 1;
            *rejections.by_reason.entry(reason.to_string()).or_insert(0) += 1;
        };
        if let Err(e) = derive::derive_steady_state(&mut p) {
            let param = match e {
                SimError::InvalidParameter { param, .. } => param,
                _ => String::new(),
            };
            reject(&format!("no_steady_state:{param}"));
            continue;
        }
        if let Err(e) = p.validate() {
            reject(&invalid_parameter(e).reason);
            continue;
        }
        let titration = match therapy::titrate_carb_ratio(&p, &config.titration) {
            Ok(t) => t,
            Err(_) => {
                reject("titration_failed");
                continue;
            }
        };
        match check_patient(&p, titration.carb_ratio_g_per_u, config) {
            Ok(checks) => {
                return Ok(VirtualPatient {
                    therapy: therapy_settings(&p, titration.carb_ratio_g_per_u, config)?,
                    params: p,
                    carb_ratio_source: CarbRatioSource::Titrated,
                    titration,
                    origin: Origin::Generated {
                        parent_a: a.name.clone(),
                        parent_b: b.name.clone(),
                        w,
                        rejected_before: attempt,
                    },
                    checks,
                })
            }
            Err(f) => reject(&f.reason),
        }
    }
    Err(SimError::Config(format!(
        "{name}: no plausible candidate in {} draws; the plausibility limits may be too strict",
        config.max_candidates_per_patient
    )))
}
