//! The maximum a posteriori fit, the search for unlogged meals, the days it
//! cannot explain, and the Laplace approximation.
//!
//! **Posterior.** In standardised coordinates z (z = 0 is the prior mean,
//! one unit one prior SD, [`crate::prior`]) the negative log posterior is
//! `n_eff/2 · ln(SSR(z)/n) + |z|²/2`: Gaussian residuals of one unknown SD
//! profiled out, with the n fitted readings counted as
//! `n_eff = n / readings per 30 min` independent ones (a model's error at
//! one CGM reading is nearly the same five minutes later; counting every
//! reading would make the prior and the bands meaninglessly tight).
//!
//! **Optimiser.** argmin's Nelder-Mead from [`STARTS`] starting points (the
//! prior mean and three spread along the sensitivity, basal-need and
//! dawn axes), each screened for `screen_iters` iterations; the best one
//! goes on for `iters_per_start`, then is refined after the meal search.
//! (Run to 250 iterations each, the starts ended within 0.5 % of each
//! other's cost; screening them costs 40 % fewer simulations per fit for
//! the same twins: BENCHMARKS.md, "A person's twin".)
//!
//! **Unlogged meals.** After the first fit, every stretch of the fitted days
//! where the observed glucose rises at least [`RISE_MG_DL`] within an hour
//! *and* that much above the twin's prediction, with no carbohydrate logged
//! from 90 minutes before to an hour after, is a candidate: a meal of 5-150 g
//! at one of three times (up to 30 minutes before the rise) is fitted to the
//! next four hours (argmin's Brent), and kept when it removes at least 40 %
//! of the squared error there. Found meals are snacks (no carb factor), are
//! listed with the twin, and are used in the refit and in replays of the
//! days they were found on; held-out days are never searched.
//!
//! **Days it cannot explain.** After the refit, a fitted day whose RMSE is
//! above both [`UNEXPLAINED_RMSE_MG_DL`] and 2.5 times the median day's is
//! marked, left out, and the twin refitted without it.
//!
//! **Uncertainty.** The Hessian of the negative log posterior at the MAP by
//! central differences (step 0.05 in z); its inverse is the posterior
//! covariance (a diagonal ridge is added until it is positive definite, and
//! said so). Bands come from [`BAND_SAMPLES`] draws from it, seeded by the
//! data's hash, so a twin's bands are the same bytes every time.
// Matrix code indexes rows and columns by number, as the formulas do.
#![allow(clippy::needless_range_loop)]

use crate::error::TwinError;
use crate::prior::{Prior, N_PARAMS};
use crate::sim::{self, RunInputs};
use crate::tape::{Meal, Tape};
use abba_core::{MealSlot, MINUTES_PER_DAY};
use argmin::core::{CostFunction, Error as ArgminError, Executor, State};
use argmin::solver::brent::BrentOpt;
use argmin::solver::neldermead::NelderMead;
use std::cell::Cell;

/// Minutes at the start of the window left out of the fit (insulin on
/// board from before is not known).
pub const BURN_IN_MIN: i64 = 180;
/// Starting points of the multi-start.
pub const STARTS: usize = 4;
/// Rise (mg/dL within an hour, observed and against the twin) that makes an
/// unlogged-meal candidate.
pub const RISE_MG_DL: f64 = 25.0;
/// Day RMSE (mg/dL) above which (and above 2.5 × the median day's) a day
/// is marked unexplained.
pub const UNEXPLAINED_RMSE_MG_DL: f64 = 40.0;
/// Posterior draws behind a band.
pub const BAND_SAMPLES: usize = 24;

/// The objective over one window: the readings that count and the inputs.
pub struct Problem<'a> {
    /// The recorded window.
    pub tape: &'a Tape,
    /// The prior.
    pub prior: &'a Prior,
    /// Per reading of the tape: counted in the fit.
    pub counted: Vec<bool>,
    /// Meals found by the fit (snacks, grams as estimated).
    pub found: Vec<Meal>,
    /// Recorded insulin per minute.
    pub insulin: Vec<f64>,
    /// Readings per 30 minutes (the residuals' correlation length).
    pub per_30_min: f64,
    /// Simulations run so far.
    pub sims: Cell<u64>,
}

/// The meals eaten by a candidate: logged grams times the slot's carb
/// factor, plus the found ones, in time order.
pub fn eaten_meals(tape: &Tape, factors: [f64; 3], found: &[Meal]) -> Vec<Meal> {
    let mut meals: Vec<Meal> = tape
        .meals
        .iter()
        .map(|m| Meal {
            grams: m.grams * m.slot.main_index().map_or(1.0, |s| factors[s]),
            ..*m
        })
        .chain(found.iter().copied())
        .collect();
    meals.sort_by_key(|m| m.minute);
    meals
}

/// The glucose the run starts from: the first reading of the first hour,
/// else the candidate's basal glucose.
pub fn start_glucose(tape: &Tape, fallback: f64) -> f64 {
    tape.readings
        .first()
        .filter(|(m, _)| *m < tape.start_minute + 60)
        .map_or(fallback, |r| r.1)
}

impl Problem<'_> {
    /// Predicted glucose per minute at z (with `insulin` in place of the
    /// recorded insulin when given), up to the last counted reading: the
    /// minutes after it (the held-out days, days left out at the end) are
    /// not simulated, as no fitted reading can see them. (A run's minutes
    /// do not depend on later ones, so the prediction is the same numbers
    /// as the whole window's, cut; the cut saved the two held-out days of
    /// every 14-day fit's simulations, 2/14 of them.)
    pub fn predict(&self, z: &[f64], insulin: Option<&[f64]>) -> Result<Vec<f64>, TwinError> {
        let (p, extras) = self.prior.params(z)?;
        let meals = eaten_meals(self.tape, extras.carb_factors, &self.found);
        self.sims.set(self.sims.get() + 1);
        let insulin = insulin.unwrap_or(&self.insulin);
        sim::run(
            &p,
            &RunInputs {
                start_minute: self.tape.start_minute,
                insulin_u_per_min: &insulin[..self.fitted_minutes().min(insulin.len())],
                meals: &meals,
                start_glucose_mg_dl: start_glucose(self.tape, p.gb),
                dawn_factor: extras.dawn_factor,
            },
        )
    }

    /// Minutes from the tape's start to just after its last counted
    /// reading (0 when none counts).
    pub fn fitted_minutes(&self) -> usize {
        self.tape
            .readings
            .iter()
            .zip(&self.counted)
            .filter(|(_, c)| **c)
            .map(|(&(m, _), _)| (m - self.tape.start_minute + 1).max(0) as usize)
            .max()
            .unwrap_or(0)
    }

    /// Sum of squared residuals and count over the counted readings.
    pub fn ssr(&self, pred: &[f64]) -> (f64, usize) {
        let mut s = 0.0;
        let mut n = 0;
        for (&(m, g), _) in self
            .tape
            .readings
            .iter()
            .zip(&self.counted)
            .filter(|(_, c)| **c)
        {
            let k = (m - self.tape.start_minute) as usize;
            s += (pred[k] - g).powi(2);
            n += 1;
        }
        (s, n)
    }

    /// The negative log posterior at z (infinite when the candidate has no
    /// steady state or the run fails).
    pub fn neg_log_posterior(&self, z: &[f64]) -> f64 {
        let Ok(pred) = self.predict(z, None) else {
            return f64::INFINITY;
        };
        let (ssr, n) = self.ssr(&pred);
        if n == 0 || !ssr.is_finite() {
            return f64::INFINITY;
        }
        let n_eff = n as f64 / self.per_30_min;
        let prior: f64 = z.iter().map(|v| v * v).sum::<f64>() / 2.0;
        n_eff / 2.0 * (ssr / n as f64).max(1e-6).ln() + prior
    }
}

impl CostFunction for Problem<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, z: &Self::Param) -> Result<f64, ArgminError> {
        let v = self.neg_log_posterior(z);
        // Nelder-Mead needs an order; a failed candidate is simply worst.
        Ok(if v.is_finite() { v } else { 1e30 })
    }
}

/// Nelder-Mead from `start` (simplex step 0.5 in z), at most `iters`
/// iterations; returns the best z and its cost.
pub fn nelder_mead(
    problem: &Problem,
    start: &[f64],
    iters: u64,
) -> Result<(Vec<f64>, f64), TwinError> {
    let mut simplex = vec![start.to_vec()];
    for k in 0..start.len() {
        let mut v = start.to_vec();
        v[k] += 0.5;
        simplex.push(v);
    }
    let solver = NelderMead::new(simplex)
        .with_sd_tolerance(1e-4)
        .map_err(|e| TwinError::Optimiser(e.to_string()))?;
    let res = Executor::new(ProblemRef(problem), solver)
        .configure(|s| s.max_iters(iters))
        .run()
        .map_err(|e| TwinError::Optimiser(e.to_string()))?;
    let best = res
        .state()
        .get_best_param()
        .cloned()
        .ok_or_else(|| TwinError::Optimiser("Nelder-Mead returned no point".into()))?;
    let cost = res.state().get_best_cost();
    Ok((best, cost))
}

/// A borrowed problem for argmin's executor (which takes its problem by value).
struct ProblemRef<'p, 'a>(&'p Problem<'a>);

impl CostFunction for ProblemRef<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, z: &Self::Param) -> Result<f64, ArgminError> {
        self.0.cost(z)
    }
}

/// The multi-start's starting points: the prior mean, then one SD along
/// the sensitivity with half an SD of basal need, the opposite, and a
/// strong dawn effect (factor about 0.55).
pub fn starts() -> Vec<Vec<f64>> {
    let axes: [&[(usize, f64)]; STARTS] = [
        &[],
        &[(0, 1.0), (1, 0.5)],
        &[(0, -1.0), (1, -0.5)],
        &[(7, -1.5)],
    ];
    axes.iter()
        .map(|moves| {
            let mut z = vec![0.0; N_PARAMS];
            for &(k, v) in *moves {
                z[k] = v;
            }
            z
        })
        .collect()
}

/// The fit's options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitOptions {
    /// Days of the window fitted (the first `fit_days` of the tape).
    pub fit_days: usize,
    /// Nelder-Mead iterations of the best start's run (and of each refit).
    pub iters_per_start: u64,
    /// Nelder-Mead iterations of each start's screening run.
    pub screen_iters: u64,
    /// Search for unlogged meals.
    pub find_meals: bool,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            fit_days: 12,
            iters_per_start: 250,
            screen_iters: 60,
            find_meals: true,
        }
    }
}

/// A fitted day the twin cannot explain.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct UnexplainedDay {
    /// Local day index (0 = day 1 of the person's clock).
    pub day_index: i64,
    /// The day's RMSE under the twin before it was left out (mg/dL).
    pub rmse_mg_dl: f64,
}

/// What the fit found.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// The MAP point (standardised coordinates).
    pub z: Vec<f64>,
    /// Negative log posterior there.
    pub cost: f64,
    /// Best cost of each start after its screening run.
    pub start_costs: Vec<f64>,
    /// Unlogged meals found.
    pub found: Vec<Meal>,
    /// Days left out.
    pub unexplained: Vec<UnexplainedDay>,
    /// Posterior covariance of z.
    pub covariance: Vec<Vec<f64>>,
    /// Ridge added to the Hessian to make it positive definite (0: none).
    pub ridge: f64,
    /// Whole-window simulations run.
    pub simulations: u64,
    /// Short (at most 4.5 h) runs of the meal search.
    pub local_runs: u64,
    /// RMSE (mg/dL) and MARD (%) over the fitted readings.
    pub rmse_mg_dl: f64,
    /// MARD over the fitted readings (%).
    pub mard_pct: f64,
    /// Fitted readings.
    pub readings: usize,
}

/// Which readings of `tape` count: after the burn-in, on the first
/// `fit_days` days, not on `excluded` days.
fn counted(tape: &Tape, fit_days: usize, excluded: &[i64]) -> Vec<bool> {
    let end = tape.start_minute + fit_days as i64 * MINUTES_PER_DAY;
    tape.readings
        .iter()
        .map(|&(m, _)| {
            m >= tape.start_minute + BURN_IN_MIN && m < end && !excluded.contains(&Tape::day_of(m))
        })
        .collect()
}

/// Readings per 30 minutes over the counted readings (at least 1).
fn per_30_min(tape: &Tape, counted: &[bool]) -> f64 {
    let n = counted.iter().filter(|c| **c).count() as f64;
    let mut days: Vec<i64> = tape
        .readings
        .iter()
        .zip(counted)
        .filter(|(_, c)| **c)
        .map(|(r, _)| Tape::day_of(r.0))
        .collect();
    days.dedup();
    (n / (days.len().max(1) as f64 * 48.0)).max(1.0)
}

/// Fits the twin to the first `options.fit_days` days of `tape`.
pub fn fit(tape: &Tape, prior: &Prior, options: &FitOptions) -> Result<FitOutcome, TwinError> {
    if options.fit_days == 0 || options.fit_days > tape.days {
        return Err(TwinError::Setting(format!(
            "{} fitted days asked of a window of {} days",
            options.fit_days, tape.days
        )));
    }
    let counted0 = counted(tape, options.fit_days, &[]);
    if counted0.iter().filter(|c| **c).count() < 12 {
        return Err(TwinError::Data(format!(
            "only {} readings on the {} fitted days after the first {} minutes: too few for a twin",
            counted0.iter().filter(|c| **c).count(),
            options.fit_days,
            BURN_IN_MIN
        )));
    }
    let mut problem = Problem {
        tape,
        prior,
        per_30_min: per_30_min(tape, &counted0),
        counted: counted0,
        found: Vec::new(),
        insulin: tape.recorded_insulin(),
        sims: Cell::new(0),
    };
    let mut start_costs = Vec::new();
    let mut best: Option<(Vec<f64>, f64)> = None;
    let screen = options.screen_iters.min(options.iters_per_start);
    for s in starts() {
        let (z, c) = nelder_mead(&problem, &s, screen)?;
        start_costs.push(c);
        if best.as_ref().is_none_or(|b| c < b.1) {
            best = Some((z, c));
        }
    }
    let (z, _) = best.ok_or_else(|| TwinError::Optimiser("no start converged".into()))?;
    // The best start goes on from a fresh simplex (Nelder-Mead keeps its
    // best vertex, so it ends no worse than it began).
    let (mut z, mut cost) = nelder_mead(&problem, &z, options.iters_per_start)?;
    let mut local_runs = 0;
    if options.find_meals {
        let (found, runs) = find_meals(&problem, &z, options.fit_days)?;
        local_runs = runs;
        if !found.is_empty() {
            problem.found = found;
            (z, cost) = nelder_mead(&problem, &z, options.iters_per_start)?;
        }
    }
    let unexplained = unexplained_days(&problem, &z, options.fit_days)?;
    if !unexplained.is_empty() {
        let days: Vec<i64> = unexplained.iter().map(|d| d.day_index).collect();
        problem.counted = counted(tape, options.fit_days, &days);
        if problem.counted.iter().filter(|c| **c).count() >= 12 {
            (z, cost) = nelder_mead(&problem, &z, options.iters_per_start)?;
        }
    }
    let (covariance, ridge) = laplace(&problem, &z)?;
    let pred = problem.predict(&z, None)?;
    let (ssr, n) = problem.ssr(&pred);
    let mard = tape
        .readings
        .iter()
        .zip(&problem.counted)
        .filter(|(_, c)| **c)
        .map(|(&(m, g), _)| (pred[(m - tape.start_minute) as usize] - g).abs() / g)
        .sum::<f64>()
        * 100.0
        / n.max(1) as f64;
    Ok(FitOutcome {
        z,
        cost,
        start_costs,
        found: problem.found.clone(),
        unexplained,
        covariance,
        ridge,
        simulations: problem.sims.get(),
        local_runs,
        rmse_mg_dl: (ssr / n.max(1) as f64).sqrt(),
        mard_pct: mard,
        readings: n,
    })
}

/// One candidate meal's fit to the four hours after it (argmin's Brent over grams).
struct LocalMeal<'a> {
    from: &'a sim::Paused,
    inputs: &'a RunInputs<'a>,
    minute: i64,
    to: usize,
    readings: &'a [(usize, f64)],
    runs: Cell<u64>,
}

impl LocalMeal<'_> {
    fn ssr(&self, grams: f64) -> Result<f64, TwinError> {
        self.runs.set(self.runs.get() + 1);
        let mut at = self.from.clone();
        let mut out = Vec::with_capacity(self.to - at.k);
        let meal = Meal {
            minute: self.minute,
            grams,
            slot: MealSlot::Snack,
        };
        sim::advance(&mut at, self.inputs, Some(meal), self.to, &mut out, None)?;
        Ok(self
            .readings
            .iter()
            .map(|&(k, g)| (out[k - self.from.k] - g).powi(2))
            .sum())
    }
}

impl CostFunction for LocalMeal<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, grams: &f64) -> Result<f64, ArgminError> {
        Ok(self.ssr(*grams).unwrap_or(1e30))
    }
}

/// Searches the fitted days for unlogged meals (module docs); returns them
/// and the number of short runs it took.
pub fn find_meals(
    problem: &Problem,
    z: &[f64],
    fit_days: usize,
) -> Result<(Vec<Meal>, u64), TwinError> {
    const EVERY: usize = 15;
    const AFTER_MIN: i64 = 240;
    let tape = problem.tape;
    let (p, extras) = problem.prior.params(z)?;
    let meals = eaten_meals(tape, extras.carb_factors, &[]);
    let inputs = RunInputs {
        start_minute: tape.start_minute,
        insulin_u_per_min: &problem.insulin,
        meals: &meals,
        start_glucose_mg_dl: start_glucose(tape, p.gb),
        dawn_factor: extras.dawn_factor,
    };
    let n = problem.insulin.len();
    let mut at = sim::start(&p, &inputs)?;
    let mut pred = Vec::with_capacity(n);
    let mut cps = Vec::new();
    sim::advance(
        &mut at,
        &inputs,
        None,
        n,
        &mut pred,
        Some((&mut cps, EVERY)),
    )?;
    problem.sims.set(problem.sims.get() + 1);
    let end = tape.start_minute + fit_days as i64 * MINUTES_PER_DAY;
    let rs: Vec<(i64, f64)> = tape
        .readings
        .iter()
        .copied()
        .filter(|&(m, _)| m >= tape.start_minute && m < end)
        .collect();
    let idx = |m: i64| (m - tape.start_minute) as usize;
    let mut found = Vec::new();
    let mut runs = 0;
    let mut next_allowed = i64::MIN;
    for (i, &(t, g)) in rs.iter().enumerate() {
        if t < next_allowed {
            continue;
        }
        let Some(&(tj, gj)) = rs[i..].iter().find(|r| r.0 >= t + 60) else {
            break;
        };
        if tj > t + 75 {
            continue;
        }
        let rise = gj - g;
        let against = (gj - pred[idx(tj)]) - (g - pred[idx(t)]);
        let logged = tape
            .meals
            .iter()
            .any(|m| (t - 90..=t + 60).contains(&m.minute));
        if rise < RISE_MG_DL || against < RISE_MG_DL || logged {
            continue;
        }
        let local: Vec<(usize, f64)> = rs
            .iter()
            .filter(|r| r.0 >= t && r.0 < (t + AFTER_MIN).min(end))
            .map(|&(m, g)| (idx(m), g))
            .collect();
        let base: f64 = local.iter().map(|&(k, g)| (pred[k] - g).powi(2)).sum();
        let mut best: Option<(f64, f64, i64)> = None;
        for back in [0usize, 1, 2] {
            let Some(c) = (idx(t) / EVERY).checked_sub(back) else {
                continue;
            };
            let from = &cps[c];
            let minute = tape.start_minute + from.k as i64;
            let problem1 = LocalMeal {
                from,
                inputs: &inputs,
                minute,
                to: idx(t + AFTER_MIN).min(n),
                readings: &local,
                runs: Cell::new(0),
            };
            let solver = BrentOpt::new(5.0, 150.0);
            let res = Executor::new(&problem1, solver)
                .configure(|s| s.max_iters(40))
                .run()
                .map_err(|e| TwinError::Optimiser(e.to_string()))?;
            runs += problem1.runs.get();
            let grams = res.state().get_best_param().copied().unwrap_or(0.0);
            let ssr = res.state().get_best_cost();
            if best.is_none_or(|b| ssr < b.1) {
                best = Some((grams, ssr, minute));
            }
        }
        if let Some((grams, ssr, minute)) = best {
            if ssr <= 0.6 * base {
                found.push(Meal {
                    minute,
                    grams,
                    slot: MealSlot::Snack,
                });
                next_allowed = t + 180;
            }
        }
    }
    Ok((found, runs))
}

impl CostFunction for &LocalMeal<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, grams: &f64) -> Result<f64, ArgminError> {
        (*self).cost(grams)
    }
}

/// Fitted days whose RMSE is above both [`UNEXPLAINED_RMSE_MG_DL`] and
/// 2.5 times the median day's.
pub fn unexplained_days(
    problem: &Problem,
    z: &[f64],
    fit_days: usize,
) -> Result<Vec<UnexplainedDay>, TwinError> {
    let tape = problem.tape;
    let pred = problem.predict(z, None)?;
    let mut by_day: Vec<(i64, f64, usize)> = Vec::new();
    for (&(m, g), _) in tape
        .readings
        .iter()
        .zip(&problem.counted)
        .filter(|(_, c)| **c)
    {
        let d = Tape::day_of(m);
        let r2 = (pred[(m - tape.start_minute) as usize] - g).powi(2);
        match by_day.last_mut() {
            Some(last) if last.0 == d => {
                last.1 += r2;
                last.2 += 1;
            }
            _ => by_day.push((d, r2, 1)),
        }
    }
    let rmse: Vec<(i64, f64)> = by_day
        .iter()
        .map(|&(d, s, n)| (d, (s / n as f64).sqrt()))
        .collect();
    let mut sorted: Vec<f64> = rmse.iter().map(|r| r.1).collect();
    sorted.sort_by(f64::total_cmp);
    let Some(&median) = sorted.get(sorted.len() / 2) else {
        return Ok(Vec::new());
    };
    let _ = fit_days;
    Ok(rmse
        .into_iter()
        .filter(|&(_, r)| r > UNEXPLAINED_RMSE_MG_DL && r > 2.5 * median)
        .map(|(day_index, rmse_mg_dl)| UnexplainedDay {
            day_index,
            rmse_mg_dl,
        })
        .collect())
}

/// The Laplace approximation at z: the inverse Hessian of the negative log
/// posterior (central differences) and the ridge it needed.
pub fn laplace(problem: &Problem, z: &[f64]) -> Result<(Vec<Vec<f64>>, f64), TwinError> {
    const H: f64 = 0.05;
    let n = z.len();
    let f = |dz: &[(usize, f64)]| {
        let mut v = z.to_vec();
        for &(k, d) in dz {
            v[k] += d;
        }
        problem.neg_log_posterior(&v)
    };
    let f0 = f(&[]);
    let mut hess = vec![vec![0.0; n]; n];
    for i in 0..n {
        hess[i][i] = (f(&[(i, H)]) - 2.0 * f0 + f(&[(i, -H)])) / (H * H);
        for j in 0..i {
            let v = (f(&[(i, H), (j, H)]) - f(&[(i, H), (j, -H)]) - f(&[(i, -H), (j, H)])
                + f(&[(i, -H), (j, -H)]))
                / (4.0 * H * H);
            hess[i][j] = v;
            hess[j][i] = v;
        }
    }
    if hess.iter().flatten().any(|v| !v.is_finite()) {
        return Err(TwinError::Optimiser(
            "the posterior's curvature is not finite at the fitted point (a neighbouring candidate has no steady state)".into(),
        ));
    }
    let mut ridge = 0.0;
    loop {
        let mut a = hess.clone();
        for (k, row) in a.iter_mut().enumerate() {
            row[k] += ridge;
        }
        if let Some(l) = crate::linalg::cholesky(&a) {
            return Ok((crate::linalg::inverse_from_cholesky(&l), ridge));
        }
        ridge = if ridge == 0.0 { 1e-3 } else { ridge * 10.0 };
        if ridge > 1e6 {
            return Err(TwinError::Optimiser(
                "the posterior's curvature cannot be made positive definite".into(),
            ));
        }
    }
}
