//! The twin as stored: what it was fitted from (data range, hash,
//! revision), the identified parameters with prior and posterior, the meals
//! it found, the days it could not explain, the held-out check and the
//! grade; and the what-if replay.

use crate::check::{self, Banded, Grade, HeldOut, Ranges};
use crate::error::TwinError;
use crate::fit::{self, FitOptions, UnexplainedDay};
use crate::linalg;
use crate::prior::{Prior, NAMES, N_PARAMS};
use crate::sim::{self, RunInputs};
use crate::tape::{Meal, ReadingKind, Tape};
use abba_core::{Event, MINUTES_PER_DAY};
use abba_sim::cohort::Population;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// Said by every human-facing output of a twin.
pub const NOTICE: &str =
    "abba is research software, not a medical device: a twin's predictions are not medical advice";

/// Version of the stored form.
pub const FORMAT: u32 = 1;

/// What the twin was fitted from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataRange {
    /// First minute of the window (local minutes since 00:00 of day 1).
    pub start_minute: i64,
    /// Days in the window.
    pub days: usize,
    /// Days fitted (the first ones).
    pub fit_days: usize,
    /// Days held out (the last ones).
    pub held_out_days: usize,
    /// Kind of readings fitted.
    pub reading_kind: ReadingKind,
    /// Readings in the window.
    pub readings: usize,
    /// Hash of the log's events (a refit is due when it changes).
    pub events_hash: String,
    /// The scheduled basal in force before the log's first basal record (U/h).
    pub basal_in_force_u_per_h: f64,
}

/// One identified parameter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Name ([`NAMES`]).
    pub name: String,
    /// Fitted value (a multiplier; the basal need in U/h, the basal glucose
    /// in mg/dL, the absorption rate in 1/min).
    pub value: f64,
    /// Value at the prior mean.
    pub prior_value: f64,
    /// Prior SD of the log value.
    pub prior_log_sd: f64,
    /// Posterior SD of the log value (Laplace).
    pub posterior_log_sd: f64,
}

/// The fit's bookkeeping.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// RMSE over the fitted readings (mg/dL).
    pub rmse_mg_dl: f64,
    /// MARD over the fitted readings (%).
    pub mard_pct: f64,
    /// Readings fitted.
    pub readings: usize,
    /// Best negative log posterior of each start.
    pub start_costs: Vec<f64>,
    /// At the MAP point.
    pub cost: f64,
    /// Whole-window simulations.
    pub simulations: u64,
    /// Short runs of the meal search.
    pub local_runs: u64,
    /// Ridge added to the Hessian (0: none).
    pub hessian_ridge: f64,
}

/// A person's twin.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Twin {
    /// [`NOTICE`].
    pub notice: String,
    /// [`FORMAT`].
    pub format: u32,
    /// The person.
    pub person: String,
    /// 1 for the first fit, one more for each refit on new data.
    pub revision: u32,
    /// The data.
    pub data: DataRange,
    /// Identified parameters.
    pub estimates: Vec<Estimate>,
    /// The MAP point (standardised).
    pub z: Vec<f64>,
    /// Posterior covariance of z.
    pub covariance: Vec<Vec<f64>>,
    /// The prior (population and typical patient).
    pub prior: Prior,
    /// Unlogged meals found on the fitted days.
    pub found_meals: Vec<Meal>,
    /// Fitted days left out.
    pub unexplained_days: Vec<UnexplainedDay>,
    /// The fit.
    pub fit: FitSummary,
    /// The held-out check (absent when it could not be made).
    pub held_out: Option<HeldOut>,
    /// Why there is no held-out check.
    pub held_out_error: Option<String>,
    /// The grade.
    pub grade: Grade,
    /// Its rule applied.
    pub grade_reason: String,
    /// The replays' runs under the recorded settings, kept between replays
    /// (not stored, not compared).
    #[serde(skip)]
    recorded_runs: RecordedCache,
}

/// A replay's runs under the recorded settings over its last `days` days:
/// the MAP point's figures and each posterior draw's (`None` where the
/// draw's run failed). A replay is only made on the events the twin was
/// fitted on, so these are the same for every what-if replayed over as
/// many days: computed once, they halve the runs of every later replay
/// (a day's four suggestions in the trial's twin arm, a person's three).
#[derive(Debug)]
struct RecordedRuns {
    /// What the runs were made from ([`Twin::recorded_runs_key`]).
    key: String,
    map: Ranges,
    draws: Vec<Option<Ranges>>,
}

/// At most this many [`RecordedRuns`] (one per replay length) are kept.
const RECORDED_RUNS_KEPT: usize = 4;

/// The twin's [`RecordedRuns`]. A clone shares them (each is found by what
/// it was made from, so a clone whose fields are then changed finds none);
/// every cache is equal (it holds what the twin's own fields determine).
#[derive(Default)]
struct RecordedCache(std::sync::Mutex<Vec<std::sync::Arc<RecordedRuns>>>);

impl RecordedCache {
    fn kept(&self) -> std::sync::MutexGuard<'_, Vec<std::sync::Arc<RecordedRuns>>> {
        // (A panic while the list was held leaves a list of whole entries.)
        self.0
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl Clone for RecordedCache {
    fn clone(&self) -> Self {
        RecordedCache(std::sync::Mutex::new(self.kept().clone()))
    }
}

impl PartialEq for RecordedCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for RecordedCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "RecordedCache({} kept)", self.kept().len())
    }
}

/// How to fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TwinOptions {
    /// Days of the window (the last days of the log).
    pub days: usize,
    /// Of them, held out at the end.
    pub held_out_days: usize,
    /// The person's population (the prior).
    pub population: Population,
    /// Nelder-Mead iterations per start.
    pub iters_per_start: u64,
    /// The scheduled basal in force before the log's first basal record
    /// (U/h; the person's therapy in force).
    pub basal_in_force_u_per_h: f64,
    /// The person's glucose unit: the grade's words use it.
    pub units: abba_core::units::GlucoseUnit,
}

impl Default for TwinOptions {
    fn default() -> Self {
        Self {
            basal_in_force_u_per_h: 0.0,
            days: 14,
            held_out_days: 2,
            population: Population::Adults,
            iters_per_start: FitOptions::default().iters_per_start,
            units: abba_core::units::GlucoseUnit::MgDl,
        }
    }
}

/// FNV-1a over the events' JSON: the identity of the data a twin came from.
pub fn events_hash(events: &[Event]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for e in events {
        let bytes = serde_json::to_vec(e).unwrap_or_default();
        for b in e.at.0.to_le_bytes().iter().chain(&bytes) {
            h ^= u64::from(*b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

fn draws(z: &[f64], cov: &[Vec<f64>], hash: &str, n: usize) -> Vec<Vec<f64>> {
    let Some(l) = linalg::cholesky(cov) else {
        return Vec::new();
    };
    let seed = u64::from_str_radix(hash, 16).unwrap_or(0);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let e: Vec<f64> = (0..z.len())
                .map(|_| StandardNormal.sample(&mut rng))
                .collect();
            linalg::correlated(z, &l, &e)
        })
        .collect()
}

/// One run of the twin at z with `insulin` and the recorded meals (times
/// the carb factors) plus the found ones.
fn predict(
    prior: &Prior,
    tape: &Tape,
    found: &[Meal],
    z: &[f64],
    insulin: &[f64],
) -> Result<Vec<f64>, TwinError> {
    let (p, extras) = prior.params(z)?;
    let meals = fit::eaten_meals(tape, extras.carb_factors, found);
    sim::run(
        &p,
        &RunInputs {
            start_minute: tape.start_minute,
            insulin_u_per_min: insulin,
            meals: &meals,
            start_glucose_mg_dl: fit::start_glucose(tape, p.gb),
            dawn_factor: extras.dawn_factor,
        },
    )
}

impl Twin {
    /// Fits the twin of `person` from the log's `events`.
    pub fn fit(person: &str, events: &[Event], options: &TwinOptions) -> Result<Twin, TwinError> {
        if options.held_out_days == 0 || options.held_out_days >= options.days {
            return Err(TwinError::Setting(format!(
                "held-out days must be at least 1 and fewer than the {} days of the window, got {}",
                options.days, options.held_out_days
            )));
        }
        let tape = Tape::from_events(events, options.days, options.basal_in_force_u_per_h)?;
        if tape.days <= options.held_out_days {
            return Err(TwinError::Data(format!(
                "the log holds {} days with readings; a twin needs more than the {} held-out days",
                tape.days, options.held_out_days
            )));
        }
        let fit_days = tape.days - options.held_out_days;
        if fit_days < check::MIN_FIT_DAYS {
            return Err(TwinError::Data(format!(
                "the log holds {} days with readings in the {}-day window, {} of them held out: {}",
                tape.days,
                options.days,
                options.held_out_days,
                check::too_few_fit_days(fit_days)
            )));
        }
        let prior = Prior::new(options.population, tape.mean_scheduled_basal_u_per_h())?;
        let outcome = fit::fit(
            &tape,
            &prior,
            &FitOptions {
                fit_days,
                iters_per_start: options.iters_per_start,
                find_meals: true,
                ..FitOptions::default()
            },
        )?;
        let hash = events_hash(events);
        let insulin = tape.recorded_insulin();
        let pred = predict(&prior, &tape, &outcome.found, &outcome.z, &insulin)?;
        let sample_preds: Vec<Vec<f64>> =
            draws(&outcome.z, &outcome.covariance, &hash, fit::BAND_SAMPLES)
                .iter()
                .filter_map(|z| predict(&prior, &tape, &outcome.found, z, &insulin).ok())
                .collect();
        let (held_out, held_out_error) =
            match check::held_out(&tape, fit_days, &pred, &sample_preds) {
                Ok(h) => (Some(h), None),
                Err(e) => (None, Some(e.to_string())),
            };
        let (grade, grade_reason) = check::grade(&tape, fit_days, held_out.as_ref(), options.units);
        let at_prior = prior.values(&prior_zero());
        let fitted = prior.values(&outcome.z);
        let estimates = (0..N_PARAMS)
            .map(|k| Estimate {
                name: NAMES[k].to_string(),
                value: fitted[k],
                prior_value: at_prior[k],
                prior_log_sd: prior.sd[k],
                posterior_log_sd: prior.sd[k] * outcome.covariance[k][k].max(0.0).sqrt(),
            })
            .collect();
        Ok(Twin {
            notice: NOTICE.into(),
            format: FORMAT,
            person: person.into(),
            revision: 1,
            data: DataRange {
                start_minute: tape.start_minute,
                days: tape.days,
                fit_days,
                held_out_days: options.held_out_days,
                reading_kind: tape.reading_kind,
                readings: tape.readings.len(),
                events_hash: hash,
                basal_in_force_u_per_h: options.basal_in_force_u_per_h,
            },
            estimates,
            z: outcome.z,
            covariance: outcome.covariance,
            prior,
            found_meals: outcome.found,
            unexplained_days: outcome.unexplained,
            fit: FitSummary {
                rmse_mg_dl: outcome.rmse_mg_dl,
                mard_pct: outcome.mard_pct,
                readings: outcome.readings,
                start_costs: outcome.start_costs,
                cost: outcome.cost,
                simulations: outcome.simulations + 1 + sample_preds.len() as u64,
                local_runs: outcome.local_runs,
                hessian_ridge: outcome.ridge,
            },
            held_out,
            held_out_error,
            grade,
            grade_reason,
            recorded_runs: RecordedCache::default(),
        })
    }

    /// The estimate named `name`.
    pub fn estimate(&self, name: &str) -> Option<&Estimate> {
        self.estimates.iter().find(|e| e.name == name)
    }

    /// The window this twin was fitted on, rebuilt from `events`; refused
    /// when the log changed since (then the twin must be refitted).
    pub fn tape(&self, events: &[Event]) -> Result<Tape, TwinError> {
        if events_hash(events) != self.data.events_hash {
            return Err(TwinError::Data(format!(
                "the log changed since twin revision {} of {} was fitted: run `abba twin fit` first",
                self.revision, self.person
            )));
        }
        Tape::from_events(events, self.data.days, self.data.basal_in_force_u_per_h)
    }

    /// Re-simulates the last `days` days of the window under `what_if`
    /// beside the recorded settings (module docs of [`crate`]).
    pub fn replay(
        &self,
        events: &[Event],
        what_if: &WhatIf,
        days: usize,
    ) -> Result<Replay, TwinError> {
        self.replay_inner(events, what_if, days, true)
    }

    /// [`Twin::replay`] whatever the grade: for validating twins against a
    /// simulated truth only, never for a person's advice.
    pub fn replay_for_validation(
        &self,
        events: &[Event],
        what_if: &WhatIf,
        days: usize,
    ) -> Result<Replay, TwinError> {
        self.replay_inner(events, what_if, days, false)
    }

    /// Everything a replay's runs under the recorded settings depend on
    /// besides the events (which must be the fitted ones): the fitted
    /// point, its covariance (the draws), the prior, the found meals, the
    /// data range and the replay's length (`None`, nothing kept, should
    /// they not serialise).
    fn recorded_runs_key(&self, days: usize) -> Option<String> {
        serde_json::to_string(&(
            &self.z,
            &self.covariance,
            &self.prior,
            &self.found_meals,
            &self.data,
            days,
        ))
        .ok()
    }

    fn replay_inner(
        &self,
        events: &[Event],
        what_if: &WhatIf,
        days: usize,
        graded: bool,
    ) -> Result<Replay, TwinError> {
        if graded && self.grade == Grade::NotUsable {
            return Err(TwinError::Data(format!(
                "twin revision {} of {} is not usable ({}); it is not used for replays",
                self.revision, self.person, self.grade_reason
            )));
        }
        let tape = self.tape(events)?;
        if days == 0 || days > tape.days {
            return Err(TwinError::Setting(format!(
                "--days {days}: expected 1 to the {} days of the twin's window",
                tape.days
            )));
        }
        let used = tape.used_carb_ratios();
        let bolus_factor = what_if.meal_bolus_factors(&used)?;
        let recorded = tape.recorded_insulin();
        let changed = match what_if.basal {
            BasalChange::Keep => tape.insulin(&|_, s| s, bolus_factor),
            BasalChange::Rate(x) => tape.insulin(&|_, _| x, bolus_factor),
            BasalChange::Factor(f) => tape.insulin(&|_, s| s * f, bolus_factor),
        };
        let from = (tape.days - days) * MINUTES_PER_DAY as usize;
        let grid = |p: &[f64]| -> Vec<f64> { p[from..].iter().step_by(5).copied().collect() };
        let zs = draws(
            &self.z,
            &self.covariance,
            &self.data.events_hash,
            fit::BAND_SAMPLES,
        );
        let run = |z: &[f64], insulin: &[f64]| -> Result<Ranges, TwinError> {
            Ranges::of(&grid(&predict(
                &self.prior,
                &tape,
                &self.found_meals,
                z,
                insulin,
            )?))
        };
        let key = self.recorded_runs_key(days);
        let kept = key.as_ref().and_then(|key| {
            self.recorded_runs
                .kept()
                .iter()
                .find(|r| &r.key == key)
                .cloned()
        });
        let recorded_runs = match kept {
            Some(r) => r,
            None => {
                let r = std::sync::Arc::new(RecordedRuns {
                    // (without a key the runs serve this replay only)
                    key: key.clone().unwrap_or_default(),
                    map: run(&self.z, &recorded)?,
                    draws: zs.iter().map(|z| run(z, &recorded).ok()).collect(),
                });
                if key.is_some() {
                    let mut list = self.recorded_runs.kept();
                    if list.len() >= RECORDED_RUNS_KEPT {
                        list.remove(0);
                    }
                    list.push(r.clone());
                }
                r
            }
        };
        let base = recorded_runs.map;
        let new = run(&self.z, &changed)?;
        let mut base_d = Vec::new();
        let mut new_d = Vec::new();
        let mut delta_d = Vec::new();
        let mut failed = 0;
        for (z, a) in zs.iter().zip(&recorded_runs.draws) {
            // A draw counts when both of its runs succeed.
            match a.map(|a| (a, run(z, &changed))) {
                Some((a, Ok(b))) => {
                    delta_d.push(b.minus(&a));
                    base_d.push(a);
                    new_d.push(b);
                }
                _ => failed += 1,
            }
        }
        let from_minute = tape.start_minute + from as i64;
        let observed: Vec<f64> = tape
            .readings
            .iter()
            .filter(|r| r.0 >= from_minute)
            .map(|r| r.1)
            .collect();
        Ok(Replay {
            notice: NOTICE.into(),
            days,
            what_if: *what_if,
            used_carb_ratios: used,
            observed: Ranges::of(&observed).ok(),
            twin_recorded: Banded::new(base, &base_d),
            twin_what_if: Banded::new(new, &new_d),
            change: Banded::new(new.minus(&base), &delta_d),
            failed_draws: failed,
            draws: delta_d.len(),
        })
    }
}

fn prior_zero() -> [f64; N_PARAMS] {
    [0.0; N_PARAMS]
}

/// How the basal changes in a what-if.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", content = "value", rename_all = "snake_case")]
pub enum BasalChange {
    /// As recorded.
    Keep,
    /// The scheduled basal replaced by this flat rate (U/h); absolute
    /// temporary basals scaled by the same factor.
    Rate(f64),
    /// Every scheduled rate and absolute temporary basal times this factor.
    Factor(f64),
}

/// A what-if: other settings on the recorded days.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WhatIf {
    /// The basal.
    pub basal: BasalChange,
    /// New carb ratios (breakfast, lunch, dinner; g/U): each main meal's
    /// recorded bolus is scaled by the ratio its bolus implied over the new one.
    pub carb_ratio: Option<[f64; 3]>,
    /// Or: every carb ratio times this factor.
    pub carb_ratio_factor: Option<f64>,
    /// And/or: each main meal's carb ratio (breakfast, lunch, dinner) times
    /// its own factor (one suggestion changes one meal's ratio).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub carb_ratio_factors: Option<[f64; 3]>,
}

impl WhatIf {
    /// One setting times `factor`, the rest as recorded: the basal rate
    /// (`meal` `None`) or one main meal's carb ratio (what one suggestion
    /// changes; a snack has no ratio, so it changes nothing).
    pub fn one_setting(meal: Option<abba_core::MealSlot>, factor: f64) -> WhatIf {
        let mut w = WhatIf {
            basal: BasalChange::Keep,
            carb_ratio: None,
            carb_ratio_factor: None,
            carb_ratio_factors: None,
        };
        match meal {
            None => w.basal = BasalChange::Factor(factor),
            Some(slot) => {
                let mut f = [1.0; 3];
                if let Some(i) = slot.main_index() {
                    f[i] = factor;
                }
                w.carb_ratio_factors = Some(f);
            }
        }
        w
    }

    /// Checks the settings against abba-core's plausibility limits.
    pub fn check(&self) -> Result<(), TwinError> {
        use abba_core::limits;
        match self.basal {
            BasalChange::Keep => {}
            BasalChange::Rate(x) => {
                limits::BASAL_U_PER_H
                    .check(x)
                    .map_err(|e| TwinError::Setting(format!("--basal: {e}")))?;
            }
            BasalChange::Factor(f) => {
                if !(f.is_finite() && (0.5..=2.0).contains(&f)) {
                    return Err(TwinError::Setting(format!(
                        "--basal-factor {f}: expected a number from 0.5 to 2"
                    )));
                }
            }
        }
        if let Some(cr) = self.carb_ratio {
            for (k, r) in cr.iter().enumerate() {
                limits::CARB_RATIO_G_PER_U.check(*r).map_err(|e| {
                    TwinError::Setting(format!("--carb-ratio value {}: {e}", k + 1))
                })?;
            }
        }
        if let Some(f) = self.carb_ratio_factor {
            if !(f.is_finite() && (0.5..=2.0).contains(&f)) {
                return Err(TwinError::Setting(format!(
                    "--carb-ratio-factor {f}: expected a number from 0.5 to 2"
                )));
            }
        }
        for (k, f) in self.carb_ratio_factors.iter().flatten().enumerate() {
            if !(f.is_finite() && (0.5..=2.0).contains(f)) {
                return Err(TwinError::Setting(format!(
                    "carb ratio factor {} ({f}): expected a number from 0.5 to 2",
                    k + 1
                )));
            }
        }
        Ok(())
    }

    /// The factor on each main meal's recorded bolus.
    fn meal_bolus_factors(&self, used: &[Option<f64>; 3]) -> Result<[f64; 3], TwinError> {
        self.check()?;
        let mut f = [1.0; 3];
        if let Some(cr) = self.carb_ratio {
            for s in 0..3 {
                if let Some(u) = used[s] {
                    f[s] = u / cr[s];
                }
            }
        }
        if let Some(k) = self.carb_ratio_factor {
            f = f.map(|v| v / k);
        }
        if let Some(k) = self.carb_ratio_factors {
            for s in 0..3 {
                f[s] /= k[s];
            }
        }
        Ok(f)
    }
}

/// A replay's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Replay {
    /// [`NOTICE`].
    pub notice: String,
    /// Days replayed (the last ones of the window).
    pub days: usize,
    /// The settings.
    pub what_if: WhatIf,
    /// The carb ratio each main meal's boluses implied (g/U).
    pub used_carb_ratios: [Option<f64>; 3],
    /// The readings of those days.
    pub observed: Option<Ranges>,
    /// The twin under the recorded settings.
    pub twin_recorded: Banded,
    /// The twin under the what-if.
    pub twin_what_if: Banded,
    /// What-if minus recorded, with the band of the difference.
    pub change: Banded,
    /// Posterior draws behind the bands.
    pub draws: usize,
    /// Draws whose candidate failed (no steady state or a crash).
    pub failed_draws: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fit_on_fewer_days_than_the_least_is_refused_with_why() {
        // 4 days with readings, 2 held out: 2 fitted.
        let events = crate::check::tests::days_of_events(4);
        let options = TwinOptions {
            days: 4,
            held_out_days: 2,
            basal_in_force_u_per_h: 1.0,
            ..TwinOptions::default()
        };
        let e = Twin::fit("ana", &events, &options).unwrap_err().to_string();
        assert!(e.contains("fitted on 2 days"), "{e}");
        assert!(e.contains("at least 3 fitted days"), "{e}");
    }
}
