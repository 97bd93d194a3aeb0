//! Transfer-entropy initialisation (spec §7): insulin → glucose TE from the
//! first week's CGM and pump data, and its mapping to the initial policy θ0.
//!
//! Estimator (\[GUESS], spec §7.2): Schreiber's transfer entropy
//! (Schreiber, Phys. Rev. Lett. 85:461, 2000) with history length 1, plug-in
//! probabilities on equiprobable (quantile) bins, maximised over source lags
//! 0-120 min, bias-corrected by circularly shifted surrogates and floored at 0.
//! Insulin delivered per 5-min bin is first smoothed with an insulin-activity
//! kernel: the exponential activity curve with peak t_p and duration t_d
//! (the "exponential insulin model" of D. Maksimovic, 2017, as used by the
//! open-source Loop/oref projects; only the published formula is used):
//! τ = t_p(1 − t_p/t_d)/(1 − 2t_p/t_d), a = 2τ/t_d, S = 1/(1 − a + (1 + a)e^{−t_d/τ}),
//! activity(t) = S/τ²·t·(1 − t/t_d)·e^{−t/τ}, evaluated at bin midpoints and
//! normalised to sum 1.

use crate::config::{TeConfig, TeMapping};
use crate::error::AdvisorError;
use abba_core::{Event, EventKind, TempBasalRate, Timestamp, UnitsPerHour, MINUTES_PER_DAY};
use serde::{Deserialize, Serialize};

/// The result of one TE estimate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TeEstimate {
    /// Bias-corrected TE (bits): max(0, observed − surrogate mean).
    pub te_bits: f64,
    /// max over lags of TE_u on the real signals (bits).
    pub observed_bits: f64,
    /// Mean over the surrogates of their max-over-lags TE (bits).
    pub surrogate_mean_bits: f64,
    /// The lag (min) at which the observed TE peaked.
    pub best_lag_min: i64,
    /// Usable (g_t, g_t+1, ĩ_t−u) triples at lag 0.
    pub pairs: usize,
    /// Fraction of grid bins that held a CGM reading.
    pub glucose_coverage: f64,
}

/// Collects CGM and delivered insulin on a regular grid over the first week.
///
/// Insulin is counted as the pump delivers it (abba-core's event module
/// documents the semantics): the scheduled basal rate, replaced by a
/// temporary basal for its duration, nothing while suspended, boluses at
/// once and extended boluses spread over their duration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TeCollector {
    start_min: i64,
    bin_minutes: i64,
    glucose_sum: Vec<f64>,
    glucose_n: Vec<u32>,
    insulin_u: Vec<f64>,
    /// The scheduled basal rate (U/h).
    basal_u_per_h: f64,
    /// Insulin has been counted up to this minute.
    basal_since_min: i64,
    /// The temporary basal and the minute it ends (exclusive).
    temp_basal: Option<(TempBasalRate, i64)>,
    /// Delivery is suspended.
    suspended: bool,
    /// The extended part of a bolus still running: (U/min, end minute, exclusive).
    extended: Option<(f64, i64)>,
}

impl TeCollector {
    /// A grid of `days` days from 00:00 of day index `start_day`; the basal
    /// rate in force before the first `BasalRate` event is `basal` (the
    /// starting therapy: the pump runs it until told otherwise).
    pub fn new(start_day: i64, days: u32, bin_minutes: i64, basal: UnitsPerHour) -> Self {
        let n = (i64::from(days) * MINUTES_PER_DAY / bin_minutes).max(0) as usize;
        let start_min = start_day * MINUTES_PER_DAY;
        Self {
            start_min,
            bin_minutes,
            glucose_sum: vec![0.0; n],
            glucose_n: vec![0; n],
            insulin_u: vec![0.0; n],
            basal_u_per_h: basal.0,
            basal_since_min: start_min,
            temp_basal: None,
            suspended: false,
            extended: None,
        }
    }

    fn end_min(&self) -> i64 {
        self.start_min + self.insulin_u.len() as i64 * self.bin_minutes
    }

    fn bin(&self, at: Timestamp) -> Option<usize> {
        let m = at.minutes();
        if m < self.start_min || m >= self.end_min() {
            None
        } else {
            Some(((m - self.start_min) / self.bin_minutes) as usize)
        }
    }

    /// Feeds one device event (readings other than CGM, meals and day
    /// closings are ignored).
    pub fn event(&mut self, e: &Event) {
        match e.kind {
            EventKind::Cgm(g) => self.cgm(e.at, g.0),
            EventKind::Bolus(u) => self.bolus(e.at, u.0),
            EventKind::BasalRate(r) => self.basal(e.at, r.0),
            EventKind::TempBasal { rate, duration_min } => {
                self.integrate_basal_to(e.at.minutes());
                self.temp_basal =
                    (duration_min > 0).then(|| (rate, e.at.minutes() + i64::from(duration_min)));
            }
            EventKind::Suspend => {
                self.integrate_basal_to(e.at.minutes());
                self.suspended = true;
                self.extended = None;
            }
            EventKind::Resume => {
                self.integrate_basal_to(e.at.minutes());
                self.suspended = false;
            }
            EventKind::ExtendedBolus {
                total,
                immediate,
                duration_min,
            } => {
                self.integrate_basal_to(e.at.minutes());
                self.bolus(e.at, immediate.0);
                let rest = total.0 - immediate.0;
                self.extended = (duration_min > 0 && rest > 0.0).then(|| {
                    (
                        rest / f64::from(duration_min),
                        e.at.minutes() + i64::from(duration_min),
                    )
                });
            }
            _ => {}
        }
    }

    /// Adds a CGM reading.
    pub fn cgm(&mut self, at: Timestamp, g_mg_dl: f64) {
        if let Some(b) = self.bin(at) {
            self.glucose_sum[b] += g_mg_dl;
            self.glucose_n[b] += 1;
        }
    }

    /// Adds a delivered bolus (all of it in the bin of its timestamp).
    pub fn bolus(&mut self, at: Timestamp, units: f64) {
        if let Some(b) = self.bin(at) {
            self.insulin_u[b] += units;
        }
    }

    /// A new scheduled basal rate in force from `at`.
    pub fn basal(&mut self, at: Timestamp, rate_u_per_h: f64) {
        self.integrate_basal_to(at.minutes());
        self.basal_u_per_h = rate_u_per_h;
    }

    /// The basal rate (U/h) delivered at minute `t` and the minute it may
    /// change next (a temporary basal ending).
    fn basal_at(&self, t: i64) -> (f64, i64) {
        if self.suspended {
            return (0.0, i64::MAX);
        }
        match self.temp_basal {
            Some((rate, end)) if t < end => {
                (rate.delivered(UnitsPerHour(self.basal_u_per_h)).0, end)
            }
            _ => (self.basal_u_per_h, i64::MAX),
        }
    }

    /// Counts the insulin delivered from the last counted minute to `to_min`.
    fn integrate_basal_to(&mut self, to_min: i64) {
        let from = self.basal_since_min.max(self.start_min);
        let to = to_min.min(self.end_min());
        let mut t = from;
        while t < to {
            let b = ((t - self.start_min) / self.bin_minutes) as usize;
            let bin_end = self.start_min + (b as i64 + 1) * self.bin_minutes;
            let (rate, basal_change) = self.basal_at(t);
            let extended = match self.extended {
                Some((per_min, end)) if t < end && !self.suspended => Some((per_min, end)),
                _ => None,
            };
            let seg_end = bin_end
                .min(to)
                .min(basal_change)
                .min(extended.map_or(i64::MAX, |e| e.1));
            let rate_per_min = rate / 60.0;
            self.insulin_u[b] += rate_per_min * (seg_end - t) as f64;
            if let Some((per_min, _)) = extended {
                self.insulin_u[b] += per_min * (seg_end - t) as f64;
            }
            t = seg_end;
        }
        self.basal_since_min = self.basal_since_min.max(to_min);
    }

    /// Closes the collection at `at` and returns (glucose per bin, NaN where
    /// missing; insulin per bin, U). Bins after `at` have no glucose and only
    /// the basal known to be running.
    pub fn finish(mut self, at: Timestamp) -> (Vec<f64>, Vec<f64>) {
        self.integrate_basal_to(at.minutes());
        let g = self
            .glucose_sum
            .iter()
            .zip(&self.glucose_n)
            .map(|(s, &n)| if n > 0 { s / f64::from(n) } else { f64::NAN })
            .collect();
        (g, self.insulin_u)
    }
}

/// The insulin-activity kernel weights per bin (sum 1).
pub fn activity_kernel(cfg: &TeConfig) -> Vec<f64> {
    let tp = cfg.kernel_peak_min;
    let td = cfg.kernel_duration_min;
    let tau = tp * (1.0 - tp / td) / (1.0 - 2.0 * tp / td);
    let a = 2.0 * tau / td;
    let s = 1.0 / (1.0 - a + (1.0 + a) * (-td / tau).exp());
    let step = cfg.bin_minutes as f64;
    let n = (td / step).ceil() as usize;
    let mut k: Vec<f64> = (0..n)
        .map(|j| {
            let t = (j as f64 + 0.5) * step;
            if t >= td {
                0.0
            } else {
                s / (tau * tau) * t * (1.0 - t / td) * (-t / tau).exp()
            }
        })
        .collect();
    let total: f64 = k.iter().sum();
    for w in &mut k {
        *w /= total;
    }
    k
}

const MISSING: u8 = u8::MAX;

/// Quantile bins: thresholds at the b/B quantiles; ties share a bin.
fn quantile_bins(x: &[f64], bins: usize) -> Vec<u8> {
    let mut sorted: Vec<f64> = x.iter().copied().filter(|v| v.is_finite()).collect();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    let thresholds: Vec<f64> = (1..bins)
        .map(|b| sorted.get(b * n / bins).copied().unwrap_or(f64::INFINITY))
        .collect();
    x.iter()
        .map(|v| {
            if v.is_finite() {
                thresholds.iter().filter(|&&t| *v >= t).count() as u8
            } else {
                MISSING
            }
        })
        .collect()
}

/// The counting space of [`te_at_lag`], reused across lags and
/// surrogates. A missing glucose pair goes to an extra row and a missing
/// source bin to an extra column of the (glucose pair, source) table, so
/// the count of a time step is one branch-free increment; four tables
/// take the steps in turn, so that consecutive steps in one cell (glucose
/// moves slowly) do not wait on each other's increment.
struct TeCounts {
    /// Four tables of (b² + 1) rows × (b + 1) columns.
    tables: Vec<u32>,
    /// The (a, b, c) counts of the valid cells, `(a·b + b')·b + c`.
    counts: Vec<u32>,
    n_b: Vec<u32>,
    n_ab: Vec<u32>,
    n_bc: Vec<u32>,
}

impl TeCounts {
    fn new(b: usize) -> Self {
        Self {
            tables: vec![0; 4 * (b * b + 1) * (b + 1)],
            counts: vec![0; b * b * b],
            n_b: vec![0; b],
            n_ab: vec![0; b * b],
            n_bc: vec![0; b * b],
        }
    }
}

/// TE_u for one lag on binned signals (`rows[t]`: the table row of the
/// glucose pair (t + 1, t), times the row length; `cols[t]`: the source
/// bin at t, see `max_over_lags`); returns (bits, triples used).
fn te_at_lag(rows: &[u32], cols: &[u8], lag: usize, b: usize, w: &mut TeCounts) -> (f64, usize) {
    let cells = (b * b + 1) * (b + 1);
    w.tables.fill(0);
    let xs = rows.get(lag..).unwrap_or(&[]);
    let cs = &cols[..xs.len()];
    let mut xq = xs.chunks_exact(4);
    let mut cq = cs.chunks_exact(4);
    for (x4, c4) in (&mut xq).zip(&mut cq) {
        for k in 0..4 {
            w.tables[k * cells + x4[k] as usize + c4[k] as usize] += 1;
        }
    }
    for (x, c) in xq.remainder().iter().zip(cq.remainder()) {
        w.tables[*x as usize + *c as usize] += 1;
    }
    let mut n = 0usize;
    for row in 0..b * b {
        for c in 0..b {
            let cell = row * (b + 1) + c;
            let k = (0..4).map(|q| w.tables[q * cells + cell]).sum::<u32>();
            w.counts[row * b + c] = k;
            n += k as usize;
        }
    }
    if n == 0 {
        return (0.0, 0);
    }
    let counts = &w.counts;
    // TE = Σ p(a,b,c) log2[ p(a,b,c) p(b) / (p(b,c) p(a,b)) ]
    w.n_b.fill(0);
    w.n_ab.fill(0);
    w.n_bc.fill(0);
    for a in 0..b {
        for bb in 0..b {
            for c in 0..b {
                let k = counts[(a * b + bb) * b + c];
                w.n_b[bb] += k;
                w.n_ab[a * b + bb] += k;
                w.n_bc[bb * b + c] += k;
            }
        }
    }
    let mut te = 0.0;
    for a in 0..b {
        for bb in 0..b {
            for c in 0..b {
                let k = counts[(a * b + bb) * b + c];
                if k == 0 {
                    continue;
                }
                let ratio = f64::from(k) * f64::from(w.n_b[bb])
                    / (f64::from(w.n_bc[bb * b + c]) * f64::from(w.n_ab[a * b + bb]));
                te += f64::from(k) / n as f64 * ratio.log2();
            }
        }
    }
    (te, n)
}

fn max_over_lags(g: &[u8], i: &[u8], cfg: &TeConfig, w: &mut TeCounts) -> (f64, usize, usize) {
    let mut best = (f64::NEG_INFINITY, 0usize);
    let mut pairs0 = 0;
    // The table row of the (next glucose, glucose) pair of every t,
    // computed once for all lags (row b² where either is missing), and
    // the source's column (b where missing).
    let b = cfg.bins;
    let rows: Vec<u32> = (0..g.len().saturating_sub(1))
        .map(|t| {
            let (a, bb) = (g[t + 1], g[t]);
            let row = if a == MISSING || bb == MISSING {
                b * b
            } else {
                a as usize * b + bb as usize
            };
            (row * (b + 1)) as u32
        })
        .collect();
    let cols: Vec<u8> = i
        .iter()
        .map(|&c| if c == MISSING { b as u8 } else { c })
        .collect();
    for lag in 0..=cfg.max_lag_steps {
        let (te, n) = te_at_lag(&rows, &cols, lag, b, w);
        if lag == 0 {
            pairs0 = n;
        }
        if te > best.0 {
            best = (te, lag);
        }
    }
    (best.0, best.1, pairs0)
}

/// Bias-corrected insulin → glucose TE of signals on a regular grid.
///
/// `glucose_mg_dl[t]` is NaN where no reading; `insulin_u[t]` is the insulin
/// delivered in bin t. Ĩ_t is only defined once a full kernel of history is
/// available (the first 6 h are not used as source values).
pub fn transfer_entropy(
    glucose_mg_dl: &[f64],
    insulin_u: &[f64],
    cfg: &TeConfig,
) -> Result<TeEstimate, AdvisorError> {
    cfg.validate()?;
    if glucose_mg_dl.len() != insulin_u.len() {
        return Err(AdvisorError::InsufficientData {
            what: "transfer entropy",
            detail: format!(
                "glucose has {} bins but insulin has {}",
                glucose_mg_dl.len(),
                insulin_u.len()
            ),
        });
    }
    let n = glucose_mg_dl.len();
    if let Some(bad) = insulin_u.iter().find(|u| !u.is_finite() || **u < 0.0) {
        return Err(AdvisorError::InsufficientData {
            what: "transfer entropy",
            detail: format!("insulin per bin must be finite and >= 0, found {bad}"),
        });
    }
    let kernel = activity_kernel(cfg);
    let itil: Vec<f64> = (0..n)
        .map(|t| {
            if t + 1 < kernel.len() {
                f64::NAN
            } else {
                kernel
                    .iter()
                    .enumerate()
                    .map(|(j, k)| k * insulin_u[t - j])
                    .sum()
            }
        })
        .collect();
    let g_bins = quantile_bins(glucose_mg_dl, cfg.bins);
    let i_bins = quantile_bins(&itil, cfg.bins);
    let mut counts = TeCounts::new(cfg.bins);
    let (observed, best_lag, pairs) = max_over_lags(&g_bins, &i_bins, cfg, &mut counts);
    let coverage = glucose_mg_dl.iter().filter(|g| g.is_finite()).count() as f64 / n.max(1) as f64;
    if pairs < cfg.min_pairs {
        return Err(AdvisorError::InsufficientData {
            what: "transfer entropy",
            detail: format!(
                "{pairs} usable glucose/insulin triples, need at least {} (glucose coverage {:.0} %)",
                cfg.min_pairs,
                100.0 * coverage
            ),
        });
    }
    let min_shift = cfg.min_surrogate_shift_steps;
    let mut surrogate_sum = 0.0;
    if cfg.surrogates > 0 {
        if n <= 2 * min_shift {
            return Err(AdvisorError::InsufficientData {
                what: "transfer entropy surrogates",
                detail: format!("{n} bins, need more than {} for the shifts", 2 * min_shift),
            });
        }
        let span = n - 2 * min_shift;
        let mut shifted = vec![MISSING; n];
        for s in 0..cfg.surrogates {
            // Evenly spaced deterministic shifts in [min_shift, n − min_shift].
            let shift = min_shift + s * span / cfg.surrogates.max(2).saturating_sub(1).max(1);
            let shift = shift.min(n - min_shift);
            for (t, v) in shifted.iter_mut().enumerate() {
                *v = i_bins[(t + shift) % n];
            }
            surrogate_sum += max_over_lags(&g_bins, &shifted, cfg, &mut counts).0;
        }
    }
    let surrogate_mean = if cfg.surrogates > 0 {
        surrogate_sum / cfg.surrogates as f64
    } else {
        0.0
    };
    Ok(TeEstimate {
        te_bits: (observed - surrogate_mean).max(0.0),
        observed_bits: observed,
        surrogate_mean_bits: surrogate_mean,
        best_lag_min: best_lag as i64 * cfg.bin_minutes,
        pairs,
        glucose_coverage: coverage,
    })
}

/// TE of one person's first week from their device events (for calibrating
/// `te.te_ref_bits` over a cohort). The grid starts at 00:00 of the first
/// event's day and spans `init_days` days; `start_basal` is the basal rate
/// running before the first `BasalRate` event. Events must be chronological.
pub fn first_week_te(
    events: &[Event],
    start_basal: UnitsPerHour,
    init_days: u32,
    cfg: &TeConfig,
) -> Result<TeEstimate, AdvisorError> {
    cfg.validate()?;
    let Some(first) = events.first() else {
        return Err(AdvisorError::InsufficientData {
            what: "transfer entropy",
            detail: "no events".to_string(),
        });
    };
    let start_day = first.at.day_index();
    let mut c = TeCollector::new(start_day, init_days, cfg.bin_minutes, start_basal);
    let mut last = first.at;
    for e in events {
        if e.at < last {
            return Err(AdvisorError::OutOfOrder {
                at: e.at,
                kind: crate::guard::kind_name(&e.kind),
                previous: last,
            });
        }
        last = e.at;
        c.event(e);
    }
    let end = Timestamp::from_day_and_minute(start_day + i64::from(init_days), 0);
    let (g, i) = c.finish(end);
    transfer_entropy(&g, &i, cfg)
}

/// TE_ref as the spec defines it: the median bias-corrected TE (bits) of a
/// training cohort's first weeks (e.g. from [`first_week_te`] per person).
pub fn median_te_ref(te_bits: &[f64]) -> Result<f64, AdvisorError> {
    let mut v: Vec<f64> = te_bits.to_vec();
    if v.is_empty() || v.iter().any(|x| !x.is_finite() || *x < 0.0) {
        return Err(AdvisorError::InsufficientData {
            what: "TE reference",
            detail: format!("need at least one finite TE >= 0, got {te_bits:?}"),
        });
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let median = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    if median > 0.0 {
        Ok(median)
    } else {
        Err(AdvisorError::InsufficientData {
            what: "TE reference",
            detail: "the median TE is 0 bits; TE_ref must be > 0".into(),
        })
    }
}

/// TE_n from a TE estimate (spec §7.3), clamped to [te_n_min, te_n_max].
pub fn te_scale(te_bits: f64, cfg: &TeConfig) -> f64 {
    let raw = match cfg.mapping {
        TeMapping::Proportional => te_bits / cfg.te_ref_bits,
        TeMapping::Inverse => {
            if te_bits > 0.0 {
                cfg.te_ref_bits / te_bits
            } else {
                f64::INFINITY
            }
        }
        TeMapping::Constant => 1.0,
        TeMapping::Linear {
            intercept,
            slope_per_bit,
        } => intercept + slope_per_bit * te_bits,
    };
    if raw.is_nan() {
        1.0
    } else {
        raw.clamp(cfg.te_n_min, cfg.te_n_max)
    }
}

/// θ0 for (BR, CIR) from TE_n: TE_n·theta0_br and TE_n·theta0_cir.
pub fn theta0(te_n: f64, cfg: &TeConfig) -> ([f64; 2], [f64; 2]) {
    (
        [te_n * cfg.theta0_br[0], te_n * cfg.theta0_br[1]],
        [te_n * cfg.theta0_cir[0], te_n * cfg.theta0_cir[1]],
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_core::Units;

    #[test]
    fn kernel_peaks_near_75_min_and_sums_to_one() {
        let k = activity_kernel(&TeConfig::default());
        assert_eq!(k.len(), 72);
        let sum: f64 = k.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12, "sum {sum}");
        let peak = k
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(j, _)| j)
            .unwrap();
        // bin midpoint 72.5 or 77.5 min
        assert!(peak == 14 || peak == 15, "peak bin {peak}");
    }

    #[test]
    fn te_of_independent_signals_is_near_zero_and_driven_signal_is_positive() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let n = 2016;
        let insulin: Vec<f64> = (0..n)
            .map(|_| {
                if rng.gen_bool(0.05) {
                    rng.gen_range(1.0..6.0)
                } else {
                    0.08
                }
            })
            .collect();
        let cfg = TeConfig::default();
        let k = activity_kernel(&cfg);
        // Driven: glucose falls with insulin action (plus noise and slow drift).
        let mean_u = insulin.iter().sum::<f64>() / n as f64;
        let mut g = vec![150.0; n];
        for t in 1..n {
            let act: f64 = (0..k.len().min(t + 1)).map(|j| k[j] * insulin[t - j]).sum();
            let step = 0.05 * (150.0 - g[t - 1]) - 60.0 * (act - mean_u);
            g[t] = (g[t - 1] + step + rng.gen_range(-3.0..3.0)).clamp(40.0, 400.0);
        }
        let driven = transfer_entropy(&g, &insulin, &cfg).unwrap();
        let noise: Vec<f64> = (0..n).map(|_| rng.gen_range(80.0..200.0)).collect();
        let indep = transfer_entropy(&noise, &insulin, &cfg).unwrap();
        assert!(
            driven.te_bits > 0.02,
            "driven TE expected > 0.02 bits, got {driven:?}"
        );
        assert!(
            indep.te_bits < 0.01,
            "independent TE expected < 0.01 bits, got {indep:?}"
        );
    }

    #[test]
    fn too_little_data_is_an_error() {
        let g = vec![f64::NAN; 2016];
        let i = vec![0.1; 2016];
        let e = transfer_entropy(&g, &i, &TeConfig::default()).unwrap_err();
        assert!(e.to_string().contains("0 usable"), "{e}");
    }

    #[test]
    fn basal_is_integrated_per_bin() {
        let mut c = TeCollector::new(1, 1, 5, UnitsPerHour(1.2));
        c.basal(Timestamp::from_day_and_minute(1, 7), 0.6);
        c.bolus(Timestamp::from_day_and_minute(1, 12), 2.0);
        let (_, ins) = c.finish(Timestamp::from_day_and_minute(2, 0));
        // bin 0: 5 min at 0.02 U/min = 0.1 ; bin 1: 2 min at 0.02 + 3 min at 0.01 = 0.07;
        // bin 2: 5 min at 0.01 + 2 U bolus = 2.05
        for (b, exp) in [(0, 0.1), (1, 0.07), (2, 2.05), (287, 0.05)] {
            assert!(
                (ins[b] - exp).abs() < 1e-12,
                "bin {b}: expected {exp}, got {}",
                ins[b]
            );
        }
    }

    #[test]
    fn temp_basal_suspend_and_extended_bolus_count_what_is_delivered() {
        let t = |m| Timestamp::from_day_and_minute(1, m);
        let mut c = TeCollector::new(1, 1, 5, UnitsPerHour(1.2));
        // 00:10-00:20 temp basal 0.6 U/h for 10 min, then 1.2 U/h again.
        c.event(&Event::new(
            t(10),
            EventKind::TempBasal {
                rate: TempBasalRate::UnitsPerHour(UnitsPerHour(0.6)),
                duration_min: 10,
            },
        ));
        // 00:30 a 50 % temp basal for 60 min; at 00:40 the schedule moves to
        // 2.4 U/h, so the temp delivers 1.2 U/h from then on.
        c.event(&Event::new(
            t(30),
            EventKind::TempBasal {
                rate: TempBasalRate::Percent(50.0),
                duration_min: 60,
            },
        ));
        c.event(&Event::new(t(40), EventKind::BasalRate(UnitsPerHour(2.4))));
        // 00:50 cancel the temp basal (duration 0): 2.4 U/h again.
        c.event(&Event::new(
            t(50),
            EventKind::TempBasal {
                rate: TempBasalRate::Percent(0.0),
                duration_min: 0,
            },
        ));
        // 01:00 extended bolus 3 U with 1 U now and 2 U over 20 min;
        // suspended at 01:10 (cancels the rest), resumed at 01:30.
        c.event(&Event::new(
            t(60),
            EventKind::ExtendedBolus {
                total: Units(3.0),
                immediate: Units(1.0),
                duration_min: 20,
            },
        ));
        c.event(&Event::new(t(70), EventKind::Suspend));
        c.event(&Event::new(t(90), EventKind::Resume));
        let (_, ins) = c.finish(Timestamp::from_day_and_minute(2, 0));
        let per5 = |u_per_h: f64| u_per_h / 60.0 * 5.0;
        let expected = [
            (0, per5(1.2)),
            (1, per5(1.2)),
            (2, per5(0.6)),
            (3, per5(0.6)),
            (4, per5(1.2)),
            (5, per5(1.2)),
            (6, per5(0.6)),
            (7, per5(0.6)),
            (8, per5(1.2)),
            (9, per5(1.2)),
            (10, per5(2.4)),
            (11, per5(2.4)),
            (12, per5(2.4) + 1.0 + 0.5),
            (13, per5(2.4) + 0.5),
            (14, 0.0),
            (17, 0.0),
            (18, per5(2.4)),
            (287, per5(2.4)),
        ];
        for (b, exp) in expected {
            assert!(
                (ins[b] - exp).abs() < 1e-12,
                "bin {b}: expected {exp}, got {}",
                ins[b]
            );
        }
        let total: f64 = ins.iter().sum();
        // Segment by segment (U/h × min / 60), plus 1 U immediate and the
        // 1 U of the extended part delivered before the suspension.
        let exp_total = (1.2 * 10.0 + 0.6 * 10.0 + 1.2 * 10.0 + 0.6 * 10.0 + 1.2 * 10.0) / 60.0
            + 2.4 * 20.0 / 60.0
            + 2.4 * (1440.0 - 90.0) / 60.0
            + 2.0;
        assert!((total - exp_total).abs() < 1e-9, "{total} vs {exp_total}");
    }

    #[test]
    fn median_reference() {
        assert_eq!(median_te_ref(&[0.03, 0.01, 0.02]).unwrap(), 0.02);
        assert_eq!(median_te_ref(&[0.04, 0.01, 0.02, 0.03]).unwrap(), 0.025);
        assert!(median_te_ref(&[]).is_err());
        assert!(median_te_ref(&[0.0, 0.0, 0.1]).is_err());
        assert!(median_te_ref(&[f64::NAN]).is_err());
    }

    #[test]
    fn mapping_scales_and_clamps() {
        let cfg = TeConfig::default();
        let check = |name: &str, exp: f64, got: f64| {
            assert!(
                (exp - got).abs() < 1e-12,
                "{name}: expected {exp}, got {got}"
            )
        };
        check("proportional", 1.5, te_scale(0.03, &cfg));
        check("clamped low", 0.25, te_scale(0.0, &cfg));
        check("clamped high", 4.0, te_scale(1.0, &cfg));
        let (br, cir) = theta0(2.0, &cfg);
        assert_eq!(br, [2.0 * cfg.theta0_br[0], 2.0 * cfg.theta0_br[1]]);
        assert_eq!(cir, [2.0 * cfg.theta0_cir[0], 2.0 * cfg.theta0_cir[1]]);
        let inv = TeConfig {
            mapping: TeMapping::Inverse,
            ..TeConfig::default()
        };
        check("inverse", 0.5, te_scale(0.04, &inv));
    }
}
