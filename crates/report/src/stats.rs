//! Statistics over patients: the summary of one metric (mean, SD, median,
//! quartiles) and the paired Wilcoxon signed-rank test (protocol §7-§8).
//!
//! Choices, stated once:
//! - SD is the sample SD (n − 1); with one patient it is undefined (`None`,
//!   JSON `null`).
//! - Quantiles are Hyndman & Fan type 7 (R's `quantile()` default, NumPy's
//!   `linear`): with the values sorted x₀ ≤ … ≤ x₍ₙ₋₁₎ and h = (n − 1)·p,
//!   Q(p) = x⌊h⌋ + (h − ⌊h⌋)·(x⌊h⌋₊₁ − x⌊h⌋).
//! - Wilcoxon signed-rank, paired, two-sided, normal approximation
//!   (as SciPy's `wilcoxon(x, y, zero_method="wilcox", correction=False,
//!   method="approx")` by default):
//!   d = second − first; zero differences are dropped before ranking
//!   (Wilcoxon's original rule, SciPy's default and R's `wilcox.test`);
//!   |d| are ranked with average ranks for ties; W+ and W− are the rank sums
//!   of positive and negative d; the statistic is min(W+, W−);
//!   z = (W+ − n(n+1)/4) / σ with σ² = n(n+1)(2n+1)/24 − Σ(t³ − t)/48 over tie
//!   groups of size t (the tie correction); p = 2·(1 − Φ(|z|)) = erfc(|z|/√2).
//!   Pratt's rule (zeros ranked, then their ranks dropped, with Cureton's
//!   adjustment of mean and variance) and the continuity correction are
//!   available through [`WilcoxonOptions`]. When every difference is zero the
//!   result is statistic 0, p = 1 (no evidence of a change), not NaN.
//! - No p-value below [`MIN_PAIRS_FOR_P`] ranked pairs (`p` is `None`, JSON
//!   `null`; the statistic is still given): the normal approximation is
//!   poor for so few pairs (SciPy warns below 10), and with 5 or fewer the
//!   exact test cannot reach p < 0.05 at all (its smallest two-sided p is
//!   2/2ⁿ), so a number there would mislead. Ranked pairs are the non-zero
//!   differences under Wilcoxon's rule and every pair under Pratt's.
//!
//! Φ comes from `libm::erfc` (a port of musl's erfc, accurate to about 1 ulp;
//! libm is already in the dependency tree, so no heavier statistics crate is
//! needed for one function).
//!
//! Errors are [`abba_core::CoreError`] (`Metric`), which the trial's own
//! error type can wrap.

use abba_core::CoreError;
use serde::Serialize;

/// Summary of one metric over patients (the protocol's M entry).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Summary {
    /// Arithmetic mean.
    pub mean: f64,
    /// Sample SD (n − 1); `None` for a single value.
    pub sd: Option<f64>,
    /// Median (type-7 quantile at 0.5).
    pub median: f64,
    /// First quartile (type 7).
    pub q1: f64,
    /// Third quartile (type 7).
    pub q3: f64,
    /// Number of values summarised. Not serialized.
    #[serde(skip)]
    pub n: usize,
}

fn stats_error(metric: &'static str, reason: String) -> CoreError {
    CoreError::Metric { metric, reason }
}

fn check_finite(metric: &'static str, label: &str, values: &[f64]) -> Result<(), CoreError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(stats_error(
            metric,
            format!(
                "{label}value {i} is {}, expected a finite number",
                values[i]
            ),
        )),
        None => Ok(()),
    }
}

/// Mean, SD, median and quartiles of `values` (at least one, all finite).
pub fn summarize(values: &[f64]) -> Result<Summary, CoreError> {
    const WHAT: &str = "summary";
    if values.is_empty() {
        return Err(stats_error(WHAT, "no values".to_string()));
    }
    check_finite(WHAT, "", values)?;
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n as f64;
    let sd = (n > 1).then(|| {
        let ss: f64 = values.iter().map(|v| (v - mean) * (v - mean)).sum();
        (ss / (n - 1) as f64).sqrt()
    });
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    Ok(Summary {
        mean,
        sd,
        median: quantile_sorted(&sorted, 0.5),
        q1: quantile_sorted(&sorted, 0.25),
        q3: quantile_sorted(&sorted, 0.75),
        n,
    })
}

/// Summary of the values that are defined (`None` marks a patient for whom
/// the metric is undefined, e.g. a MAGE without any countable excursion);
/// `Ok(None)` when no value is defined. `n` of the summary tells how many
/// values it holds.
pub fn summarize_present(values: &[Option<f64>]) -> Result<Option<Summary>, CoreError> {
    let present: Vec<f64> = values.iter().flatten().copied().collect();
    if present.is_empty() {
        return Ok(None);
    }
    summarize(&present).map(Some)
}

/// Type-7 quantile of values already sorted ascending (not empty), p in [0, 1].
pub fn quantile_sorted(sorted: &[f64], p: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * p.clamp(0.0, 1.0);
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// How zero differences enter the signed-rank test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ZeroMethod {
    /// Drop zeros before ranking (Wilcoxon 1945; SciPy's default, R's `wilcox.test`).
    #[default]
    Wilcox,
    /// Rank zeros with the rest, then drop their ranks; mean and variance
    /// adjusted as in Cureton (1967) (SciPy's `zero_method="pratt"`).
    Pratt,
}

/// Options of [`wilcoxon_signed_rank`]; the default is SciPy's default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WilcoxonOptions {
    /// Treatment of zero differences.
    pub zero_method: ZeroMethod,
    /// Shift W+ by 0.5 towards the mean before standardising (R's default, not SciPy's).
    pub continuity_correction: bool,
}

/// The fewest ranked pairs for which a p-value is given (see the module
/// docs for why).
pub const MIN_PAIRS_FOR_P: usize = 10;

/// Result of the paired signed-rank test (serializes as `{"statistic", "p"}`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Wilcoxon {
    /// min(W+, W−).
    pub statistic: f64,
    /// Two-sided p-value, normal approximation; `None` (JSON `null`) with
    /// fewer than [`MIN_PAIRS_FOR_P`] ranked pairs, where it is not
    /// meaningful.
    pub p: Option<f64>,
    /// Standardised W+ (positive when `second` tends to exceed `first`); 0 when all d are zero.
    #[serde(skip)]
    pub z: f64,
    /// Rank sum of positive differences.
    #[serde(skip)]
    pub w_plus: f64,
    /// Rank sum of negative differences.
    #[serde(skip)]
    pub w_minus: f64,
    /// Pairs with a non-zero difference.
    #[serde(skip)]
    pub n_nonzero: usize,
    /// Pairs with a zero difference.
    #[serde(skip)]
    pub n_zero: usize,
    /// Pairs left out because a value was undefined ([`wilcoxon_signed_rank_present`]).
    #[serde(skip)]
    pub n_incomplete: usize,
}

/// [`wilcoxon_signed_rank`] on the complete pairs only: a pair where either
/// value is `None` (an undefined metric) is left out and counted in
/// `n_incomplete`. Error when no pair is complete.
pub fn wilcoxon_signed_rank_present(
    first: &[Option<f64>],
    second: &[Option<f64>],
    options: WilcoxonOptions,
) -> Result<Wilcoxon, CoreError> {
    if first.len() != second.len() {
        return Err(stats_error(
            "Wilcoxon signed-rank test",
            format!(
                "paired samples differ in length: {} and {}",
                first.len(),
                second.len()
            ),
        ));
    }
    let (a, b): (Vec<f64>, Vec<f64>) = first
        .iter()
        .zip(second)
        .filter_map(|(x, y)| Some(((*x)?, (*y)?)))
        .unzip();
    let mut w = wilcoxon_signed_rank(&a, &b, options)?;
    w.n_incomplete = first.len() - a.len();
    Ok(w)
}

/// Paired, two-sided Wilcoxon signed-rank test of `second − first` (e.g.
/// W13 − W1 per patient), with the normal approximation and tie correction;
/// see the module docs for the exact definition.
pub fn wilcoxon_signed_rank(
    first: &[f64],
    second: &[f64],
    options: WilcoxonOptions,
) -> Result<Wilcoxon, CoreError> {
    const WHAT: &str = "Wilcoxon signed-rank test";
    if first.len() != second.len() {
        return Err(stats_error(
            WHAT,
            format!(
                "paired samples differ in length: {} and {}",
                first.len(),
                second.len()
            ),
        ));
    }
    if first.is_empty() {
        return Err(stats_error(WHAT, "no pairs".to_string()));
    }
    check_finite(WHAT, "first sample: ", first)?;
    check_finite(WHAT, "second sample: ", second)?;
    let d: Vec<f64> = first.iter().zip(second).map(|(a, b)| b - a).collect();
    let n_zero = d.iter().filter(|&&x| x == 0.0).count();
    let n_nonzero = d.len() - n_zero;
    let ranked_pairs = match options.zero_method {
        ZeroMethod::Wilcox => n_nonzero,
        ZeroMethod::Pratt => d.len(),
    };
    let enough = ranked_pairs >= MIN_PAIRS_FOR_P;
    if n_nonzero == 0 {
        return Ok(Wilcoxon {
            statistic: 0.0,
            p: enough.then_some(1.0),
            z: 0.0,
            w_plus: 0.0,
            w_minus: 0.0,
            n_nonzero,
            n_zero,
            n_incomplete: 0,
        });
    }
    let ranked: Vec<f64> = match options.zero_method {
        ZeroMethod::Wilcox => d.iter().copied().filter(|&x| x != 0.0).collect(),
        ZeroMethod::Pratt => d.clone(),
    };
    let (ranks, _) = average_ranks_of_abs(&ranked);
    let (mut w_plus, mut w_minus) = (0.0, 0.0);
    for (&x, &r) in ranked.iter().zip(&ranks) {
        if x > 0.0 {
            w_plus += r;
        } else if x < 0.0 {
            w_minus += r;
        }
    }
    // Tie groups among the non-zero differences only (zeros under Pratt are
    // accounted for by Cureton's adjustment below).
    let nonzero: Vec<f64> = d.iter().copied().filter(|&x| x != 0.0).collect();
    let (_, tie_sizes) = average_ranks_of_abs(&nonzero);
    let tie_term: f64 = tie_sizes
        .iter()
        .map(|&t| {
            let t = t as f64;
            t * t * t - t
        })
        .sum();
    let count = ranked.len() as f64;
    let mut mean = count * (count + 1.0) / 4.0;
    let mut var24 = count * (count + 1.0) * (2.0 * count + 1.0) - tie_term / 2.0;
    if options.zero_method == ZeroMethod::Pratt {
        let z0 = n_zero as f64;
        mean -= z0 * (z0 + 1.0) / 4.0;
        var24 -= z0 * (z0 + 1.0) * (2.0 * z0 + 1.0);
    }
    let sigma = (var24 / 24.0).sqrt();
    let mut centred = w_plus - mean;
    if options.continuity_correction && centred != 0.0 {
        centred -= 0.5 * centred.signum();
    }
    let (z, p) = if sigma > 0.0 {
        let z = centred / sigma;
        (z, libm::erfc(z.abs() / std::f64::consts::SQRT_2).min(1.0))
    } else {
        (0.0, 1.0)
    };
    Ok(Wilcoxon {
        statistic: w_plus.min(w_minus),
        p: enough.then_some(p),
        z,
        w_plus,
        w_minus,
        n_nonzero,
        n_zero,
        n_incomplete: 0,
    })
}

/// Average ranks (1-based) of |x| and the sizes of the tie groups (> 1).
fn average_ranks_of_abs(x: &[f64]) -> (Vec<f64>, Vec<usize>) {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].abs().total_cmp(&x[b].abs()));
    let mut ranks = vec![0.0; x.len()];
    let mut ties = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && x[order[end]].abs() == x[order[start]].abs() {
            end += 1;
        }
        // Positions start..end (0-based) share the mean of ranks start+1..=end.
        let rank = (start + 1 + end) as f64 / 2.0;
        for &i in &order[start..end] {
            ranks[i] = rank;
        }
        if end - start > 1 {
            ties.push(end - start);
        }
        start = end;
    }
    (ranks, ties)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn close(name: &str, expected: f64, got: f64, tol: f64) {
        assert!(
            (expected - got).abs() <= tol,
            "{name}: expected {expected}, got {got}"
        );
    }

    #[test]
    fn quantiles_are_type_7() {
        // R: quantile(c(1, 2, 3, 4, 10), c(.25, .5, .75)) = 2, 3, 4.
        let s = summarize(&[10.0, 1.0, 3.0, 2.0, 4.0]).unwrap();
        assert_eq!((s.q1, s.median, s.q3), (2.0, 3.0, 4.0));
        // R: quantile(1:4, c(.25, .5, .75)) = 1.75, 2.5, 3.25.
        let s = summarize(&[4.0, 3.0, 2.0, 1.0]).unwrap();
        assert_eq!((s.q1, s.median, s.q3), (1.75, 2.5, 3.25));
        close("mean", 2.5, s.mean, 1e-15);
        close("sd", (5.0f64 / 3.0).sqrt(), s.sd.unwrap(), 1e-15);
        // R: quantile(c(7, 15, 36, 39, 40, 41), .25) = 20.25, .75 = 39.75.
        let s = summarize(&[7.0, 15.0, 36.0, 39.0, 40.0, 41.0]).unwrap();
        close("q1", 20.25, s.q1, 1e-12);
        close("median", 37.5, s.median, 1e-12);
        close("q3", 39.75, s.q3, 1e-12);
    }

    #[test]
    fn summary_of_one_value_has_no_sd_and_bad_input_is_an_error() {
        let s = summarize(&[5.0]).unwrap();
        assert_eq!(
            (s.mean, s.sd, s.median, s.q1, s.q3),
            (5.0, None, 5.0, 5.0, 5.0)
        );
        assert!(summarize(&[]).is_err());
        assert!(summarize(&[1.0, f64::NAN]).is_err());
        let json = serde_json::to_value(summarize(&[1.0, 2.0]).unwrap()).unwrap();
        let mut keys: Vec<&String> = json.as_object().unwrap().keys().collect();
        keys.sort();
        assert_eq!(keys, ["mean", "median", "q1", "q3", "sd"]);
    }

    #[test]
    fn wilcoxon_matches_scipy_documentation_example() {
        // SciPy's wilcoxon docs: d = [6, 8, 14, 16, 23, 24, 28, 29, 41, -48,
        // 49, 56, 60, -67, 75]; method="approx" gives statistic 24 and
        // p = 0.04088813291185591. By hand: W− = 10 + 14 = 24, W+ = 96,
        // z = (96 − 60)/√310 = 2.0446626.
        let d = [
            6.0, 8.0, 14.0, 16.0, 23.0, 24.0, 28.0, 29.0, 41.0, -48.0, 49.0, 56.0, 60.0, -67.0,
            75.0,
        ];
        let zeros = vec![0.0; d.len()];
        let w = wilcoxon_signed_rank(&zeros, &d, WilcoxonOptions::default()).unwrap();
        println!("{w:?}");
        assert_eq!((w.w_plus, w.w_minus, w.statistic), (96.0, 24.0, 24.0));
        close("z", 36.0 / 310f64.sqrt(), w.z, 1e-12);
        close("p", 0.04088813291185591, w.p.unwrap(), 1e-12);
        // Swapping the samples flips the sign of z, not p.
        let back = wilcoxon_signed_rank(&d, &zeros, WilcoxonOptions::default()).unwrap();
        close("z swapped", -w.z, back.z, 1e-15);
        close("p swapped", w.p.unwrap(), back.p.unwrap(), 1e-15);
    }

    #[test]
    fn wilcoxon_ties_and_zeros_by_hand() {
        // d = [1, 2, 2, −3, 4, 4, 4, 0, 0, −5] (second − first).
        let first = [10.0; 10];
        let d = [1.0, 2.0, 2.0, -3.0, 4.0, 4.0, 4.0, 0.0, 0.0, -5.0];
        let second: Vec<f64> = first.iter().zip(d).map(|(a, x)| a + x).collect();

        // Wilcox: zeros dropped, n = 8; ranks 1, 2.5, 2.5, 4, 6, 6, 6, 8;
        // W+ = 24, W− = 12; mean 18; σ² = 8·9·17/24 − (6 + 24)/48 = 50.375;
        // z = 6/√50.375 = 0.84536394. Only 8 ranked pairs: no p-value.
        let w = wilcoxon_signed_rank(&first, &second, WilcoxonOptions::default()).unwrap();
        assert_eq!((w.n_nonzero, w.n_zero), (8, 2));
        assert_eq!((w.w_plus, w.w_minus, w.statistic), (24.0, 12.0, 12.0));
        close("z", 6.0 / 50.375f64.sqrt(), w.z, 1e-12);
        assert_eq!(w.p, None);

        // Pratt: zeros get ranks 1.5, 1.5, the rest 3, 4.5, 4.5, 6, 8, 8, 8, 10;
        // W+ = 36, W− = 16; mean 10·11/4 − 2·3/4 = 26;
        // σ² = (10·11·21 − 2·3·5 − (6 + 24)/2)/24 = 94.375;
        // z = 10/√94.375; p = 0.3033058289841122 (Python math.erfc).
        let pratt = WilcoxonOptions {
            zero_method: ZeroMethod::Pratt,
            continuity_correction: false,
        };
        let w = wilcoxon_signed_rank(&first, &second, pratt).unwrap();
        assert_eq!((w.w_plus, w.w_minus, w.statistic), (36.0, 16.0, 16.0));
        close("z pratt", 10.0 / 94.375f64.sqrt(), w.z, 1e-12);
        close("p pratt", 0.3033058289841122, w.p.unwrap(), 1e-12);

        // Continuity correction (R's default): z = (6 − 0.5)/√50.375 (8
        // ranked pairs again: no p-value).
        let corrected = WilcoxonOptions {
            zero_method: ZeroMethod::Wilcox,
            continuity_correction: true,
        };
        let w = wilcoxon_signed_rank(&first, &second, corrected).unwrap();
        close("z corrected", 5.5 / 50.375f64.sqrt(), w.z, 1e-12);
        assert_eq!(w.p, None);
    }

    #[test]
    fn all_zero_differences_give_p_one() {
        let x: Vec<f64> = (0..12).map(|k| f64::from(k) * 0.5).collect();
        // Wilcoxon's rule drops every pair: none is left to rank.
        let w = wilcoxon_signed_rank(&x, &x, WilcoxonOptions::default()).unwrap();
        assert_eq!(
            (w.statistic, w.p, w.n_zero, w.n_nonzero),
            (0.0, None, 12, 0)
        );
        let pratt = WilcoxonOptions {
            zero_method: ZeroMethod::Pratt,
            ..WilcoxonOptions::default()
        };
        let w = wilcoxon_signed_rank(&x, &x, pratt).unwrap();
        assert_eq!((w.statistic, w.p), (0.0, Some(1.0)));
        let json = serde_json::to_value(w).unwrap();
        assert_eq!(json, serde_json::json!({"statistic": 0.0, "p": 1.0}));
    }

    #[test]
    fn no_p_value_below_the_minimum_number_of_pairs() {
        // One patient: a statistic, but no p-value.
        let w = wilcoxon_signed_rank(&[100.0], &[80.0], WilcoxonOptions::default()).unwrap();
        assert_eq!((w.statistic, w.p), (0.0, None));
        let json = serde_json::to_value(w).unwrap();
        assert_eq!(json, serde_json::json!({"statistic": 0.0, "p": null}));
        for n in [2, MIN_PAIRS_FOR_P - 1, MIN_PAIRS_FOR_P] {
            let a = vec![0.0; n];
            let b: Vec<f64> = (1..=n).map(|k| k as f64).collect();
            let w = wilcoxon_signed_rank(&a, &b, WilcoxonOptions::default()).unwrap();
            assert_eq!(w.p.is_some(), n >= MIN_PAIRS_FOR_P, "n = {n}");
        }
    }

    #[test]
    fn undefined_values_are_left_out_and_counted() {
        let s = summarize_present(&[Some(1.0), None, Some(3.0)])
            .unwrap()
            .unwrap();
        assert_eq!((s.n, s.mean, s.median), (2, 2.0, 2.0));
        assert_eq!(summarize_present(&[None, None]).unwrap(), None);
        // The scipy example again, with two incomplete pairs added.
        let d = [
            6.0, 8.0, 14.0, 16.0, 23.0, 24.0, 28.0, 29.0, 41.0, -48.0, 49.0, 56.0, 60.0, -67.0,
            75.0,
        ];
        let mut first: Vec<Option<f64>> = vec![Some(0.0); d.len()];
        let mut second: Vec<Option<f64>> = d.iter().map(|&x| Some(x)).collect();
        first.extend([None, Some(1.0)]);
        second.extend([Some(5.0), None]);
        let w = wilcoxon_signed_rank_present(&first, &second, WilcoxonOptions::default()).unwrap();
        assert_eq!((w.statistic, w.n_nonzero, w.n_incomplete), (24.0, 15, 2));
        close("p", 0.04088813291185591, w.p.unwrap(), 1e-12);
        assert!(
            wilcoxon_signed_rank_present(&[None], &[Some(1.0)], WilcoxonOptions::default())
                .is_err()
        );
    }

    #[test]
    fn one_sided_data_and_bad_input() {
        // Ten all-positive differences: W+ = 55, W− = 0, z = 27.5/√96.25,
        // p = 0.00506203212626787 (Python math.erfc).
        let a = [0.0; 10];
        let b: Vec<f64> = (1..=10).map(f64::from).collect();
        let w = wilcoxon_signed_rank(&a, &b, WilcoxonOptions::default()).unwrap();
        assert_eq!((w.statistic, w.w_plus), (0.0, 55.0));
        close("z", 27.5 / 96.25f64.sqrt(), w.z, 1e-12);
        close("p", 0.00506203212626787, w.p.unwrap(), 1e-12);
        assert!(wilcoxon_signed_rank(&a, &b[..9], WilcoxonOptions::default()).is_err());
        assert!(wilcoxon_signed_rank(&[], &[], WilcoxonOptions::default()).is_err());
        assert!(
            wilcoxon_signed_rank(&[1.0], &[f64::INFINITY], WilcoxonOptions::default()).is_err()
        );
    }
}
