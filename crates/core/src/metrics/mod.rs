//! Glucose metrics with the definitions of iglu (Broll et al., the R package
//! for CGM metrics, and its Python port iglu-python), so that our numbers can
//! be checked against theirs.
//!
//! Definitions (all glucose in mg/dL):
//! - percentages count **readings**, not time: `in range` is inclusive
//!   (70 ≤ g ≤ 180), `below t` is strict (g < t), `above t` is strict (g > t);
//!   the seed paper's bands are hypo [50, 70), severe hypo < 50,
//!   hyper (180, 300], severe hyper > 300;
//! - SD is the sample SD (n − 1); CV = 100·SD/mean; GMI = 3.31 + 0.02392·mean
//!   (Bergenstal et al. 2018);
//! - LBGI/HBGI (Kovatchev et al.): f(g) = 1.509·((ln g)^1.084 − 5.381),
//!   r = 10·f²; LBGI = Σ_{f<0} r / n and HBGI = Σ_{f>0} r / n, i.e. averaged
//!   over **all** readings;
//! - MAGE: iglu's default moving-average algorithm (Fernandes et al. 2022),
//!   direction "avg"; see [`mage`].
//!
//! Two entry points: [`metrics_regular`] for a gap-free series sampled every
//! 5 min (the trial's plasma glucose; no timestamps needed) and
//! [`metrics_timed`] for timestamped, possibly irregular readings (a CGM
//! export).
//!
//! ```
//! use abba_core::metrics::metrics_regular;
//! // One day every 5 min: 130 ± 40 mg/dL, a swing every ~10 h.
//! let day: Vec<f64> = (0..288).map(|i| 130.0 + 40.0 * (i as f64 / 20.0).sin()).collect();
//! let m = metrics_regular(&day).unwrap();
//! assert_eq!(m.tir_70_180, 100.0);
//! let mage = m.mage.unwrap();
//! assert!(mage > 60.0 && mage <= 80.0, "{mage}");
//! ```

mod grid;
pub mod mage;
pub mod metric;

use serde::Serialize;

use crate::error::CoreError;
pub use grid::GRID_MINUTES;
pub use mage::{mage_regular, mage_timed, Mage, MageDirection, MageOptions};
pub use metric::{Direction, Metric, MetricUnit};

/// The metrics of one series of readings. The field names are the metric keys
/// of the protocol (§8, [`Metric::GLUCOSE`]), and serialize as exactly those
/// 15 keys (`sd_mg_dl` and `n_readings` are not serialized).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GlucoseMetrics {
    /// % of readings in the target band 70 ≤ g ≤ 180 mg/dL.
    pub tir_70_180: f64,
    /// % of readings with 50 ≤ g < 70 mg/dL (the seed's hypoglycaemia).
    pub hypo_50_70: f64,
    /// % of readings with g < 50 mg/dL (the seed's severe hypoglycaemia).
    pub severe_hypo_lt50: f64,
    /// % of readings with 180 < g ≤ 300 mg/dL (the seed's hyperglycaemia).
    pub hyper_180_300: f64,
    /// % of readings with g > 300 mg/dL (the seed's severe hyperglycaemia).
    pub severe_hyper_gt300: f64,
    /// Low blood glucose index (Kovatchev), averaged over all readings.
    pub lbgi: f64,
    /// High blood glucose index (Kovatchev), averaged over all readings.
    pub hbgi: f64,
    /// MAGE in mg/dL, iglu's moving-average algorithm, direction "avg";
    /// `None` (JSON `null`) when no segment holds a countable excursion.
    pub mage: Option<f64>,
    /// Mean glucose, mg/dL.
    pub mean_mg_dl: f64,
    /// Coefficient of variation, % (100·SD/mean, SD with n − 1).
    pub cv_pct: f64,
    /// Glucose management indicator, % (3.31 + 0.02392·mean).
    pub gmi_pct: f64,
    /// % of readings with g < 54 mg/dL (2019 consensus).
    pub below_54: f64,
    /// % of readings with g < 70 mg/dL (2019 consensus).
    pub below_70: f64,
    /// % of readings with g > 180 mg/dL (2019 consensus).
    pub above_180: f64,
    /// % of readings with g > 250 mg/dL (2019 consensus).
    pub above_250: f64,
    /// Sample standard deviation (n − 1), mg/dL. Not serialized.
    #[serde(skip)]
    pub sd_mg_dl: f64,
    /// Number of readings the metrics were computed from. Not serialized.
    #[serde(skip)]
    pub n_readings: usize,
}

impl GlucoseMetrics {
    /// Each metric of [`Metric::GLUCOSE`] with its value (`None` only for an
    /// undefined MAGE).
    pub fn entries(&self) -> [(Metric, Option<f64>); 15] {
        Metric::GLUCOSE.map(|m| (m, self.get(m)))
    }

    /// The value of one metric: `None` for an undefined MAGE, and for
    /// [`Metric::TdiUPerDay`], which is not a metric of a glucose series
    /// (the trial's week results carry it beside these).
    pub fn get(&self, metric: Metric) -> Option<f64> {
        match metric {
            Metric::Tir70To180 => Some(self.tir_70_180),
            Metric::Hypo50To70 => Some(self.hypo_50_70),
            Metric::SevereHypoLt50 => Some(self.severe_hypo_lt50),
            Metric::Hyper180To300 => Some(self.hyper_180_300),
            Metric::SevereHyperGt300 => Some(self.severe_hyper_gt300),
            Metric::Lbgi => Some(self.lbgi),
            Metric::Hbgi => Some(self.hbgi),
            Metric::Mage => self.mage,
            Metric::TdiUPerDay => None,
            Metric::MeanMgDl => Some(self.mean_mg_dl),
            Metric::CvPct => Some(self.cv_pct),
            Metric::GmiPct => Some(self.gmi_pct),
            Metric::Below54 => Some(self.below_54),
            Metric::Below70 => Some(self.below_70),
            Metric::Above180 => Some(self.above_180),
            Metric::Above250 => Some(self.above_250),
        }
    }
}

/// Metrics of a gap-free series sampled every 5 min (mg/dL). MAGE uses the
/// series itself as iglu's 5-min grid.
///
/// Errors: fewer than 2 readings, or a reading that is not finite and > 0.
pub fn metrics_regular(glucose_mg_dl: &[f64]) -> Result<GlucoseMetrics, CoreError> {
    let mut m = basic_metrics(glucose_mg_dl)?;
    m.mage = mage_regular(glucose_mg_dl, &MageOptions::default())?.value(MageDirection::Avg);
    Ok(m)
}

/// Metrics of timestamped readings: `times_min` in minutes from a midnight
/// (for example minutes since 1970-01-01 00:00 of the local wall clock),
/// strictly increasing, one per glucose value (mg/dL). The percentages and
/// moments count the readings as given; MAGE interpolates them on iglu's
/// 5-min grid (see [`mage_timed`]).
///
/// Errors: fewer than 2 readings, lengths that differ, a reading that is not
/// finite and > 0, a time that is not finite or not after the previous one.
pub fn metrics_timed(
    times_min: &[f64],
    glucose_mg_dl: &[f64],
) -> Result<GlucoseMetrics, CoreError> {
    let mut m = basic_metrics(glucose_mg_dl)?;
    m.mage =
        mage_timed(times_min, glucose_mg_dl, &MageOptions::default())?.value(MageDirection::Avg);
    Ok(m)
}

/// Checks that every glucose value is finite and > 0 mg/dL.
pub(crate) fn validate_glucose(glucose_mg_dl: &[f64]) -> Result<(), CoreError> {
    for (index, &g) in glucose_mg_dl.iter().enumerate() {
        if !(g.is_finite() && g > 0.0) {
            return Err(CoreError::BadReading {
                index,
                what: "glucose (mg/dL)",
                expected: "a finite number > 0",
                got: g,
            });
        }
    }
    Ok(())
}

/// Kovatchev's symmetrised risk: f(g) = 1.509·((ln g)^1.084 − 5.381)
/// (Kovatchev et al., Diabetes Care 1997), g in mg/dL.
fn kovatchev_f(g_mg_dl: f64) -> f64 {
    1.509 * (g_mg_dl.ln().powf(1.084) - 5.381)
}

/// Percent of readings below 54, below 70, in 70-180, above 180 and above
/// 250 mg/dL, as [`GlucoseMetrics`] computes them (`below_54`, `below_70`,
/// `tir_70_180`, `above_180`, `above_250`, the same bits), without the
/// risk indices, SD and MAGE: for pooled profiles of many readings where
/// only the ranges are drawn. Errors: no reading, or one not finite and > 0.
pub fn range_percentages(glucose_mg_dl: &[f64]) -> Result<[f64; 5], CoreError> {
    if glucose_mg_dl.is_empty() {
        return Err(CoreError::Metric {
            metric: "time in ranges",
            reason: "no readings".into(),
        });
    }
    validate_glucose(glucose_mg_dl)?;
    let mut count = [0usize; 5];
    for &g in glucose_mg_dl {
        let bands = [
            g < 54.0,
            g < 70.0,
            (70.0..=180.0).contains(&g),
            g > 180.0,
            g > 250.0,
        ];
        for (c, hit) in count.iter_mut().zip(bands) {
            *c += usize::from(hit);
        }
    }
    let nf = glucose_mg_dl.len() as f64;
    Ok(count.map(|c| 100.0 * c as f64 / nf))
}

/// Everything but MAGE (left `None`), in one pass for the sums and one for the SD.
fn basic_metrics(glucose_mg_dl: &[f64]) -> Result<GlucoseMetrics, CoreError> {
    let n = glucose_mg_dl.len();
    if n < 2 {
        return Err(CoreError::Metric {
            metric: "glucose metrics",
            reason: format!("need at least 2 readings (for the SD), got {n}"),
        });
    }
    validate_glucose(glucose_mg_dl)?;
    let mut count = [0usize; 9];
    let (mut sum, mut low_risk, mut high_risk) = (0.0, 0.0, 0.0);
    for &g in glucose_mg_dl {
        sum += g;
        let bands = [
            (70.0..=180.0).contains(&g),
            (50.0..70.0).contains(&g),
            g < 50.0,
            g > 180.0 && g <= 300.0,
            g > 300.0,
            g < 54.0,
            g < 70.0,
            g > 180.0,
            g > 250.0,
        ];
        for (c, hit) in count.iter_mut().zip(bands) {
            *c += usize::from(hit);
        }
        let f = kovatchev_f(g);
        let r = 10.0 * f * f;
        if f < 0.0 {
            low_risk += r;
        } else if f > 0.0 {
            high_risk += r;
        }
    }
    let nf = n as f64;
    let mean = sum / nf;
    let ss: f64 = glucose_mg_dl.iter().map(|g| (g - mean) * (g - mean)).sum();
    let sd = (ss / (nf - 1.0)).sqrt();
    let pct = |c: usize| 100.0 * c as f64 / nf;
    Ok(GlucoseMetrics {
        tir_70_180: pct(count[0]),
        hypo_50_70: pct(count[1]),
        severe_hypo_lt50: pct(count[2]),
        hyper_180_300: pct(count[3]),
        severe_hyper_gt300: pct(count[4]),
        lbgi: low_risk / nf,
        hbgi: high_risk / nf,
        mage: None,
        mean_mg_dl: mean,
        cv_pct: 100.0 * sd / mean,
        gmi_pct: 3.31 + 0.02392 * mean,
        below_54: pct(count[5]),
        below_70: pct(count[6]),
        above_180: pct(count[7]),
        above_250: pct(count[8]),
        sd_mg_dl: sd,
        n_readings: n,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn range_percentages_are_the_metrics_own() {
        let g: Vec<f64> = (0..2000)
            .map(|i| 40.0 + (i as f64 * 7.31) % 320.0)
            .chain([54.0, 70.0, 180.0, 250.0])
            .collect();
        let m = basic_metrics(&g).unwrap();
        let r = range_percentages(&g).unwrap();
        let expected = [
            m.below_54,
            m.below_70,
            m.tir_70_180,
            m.above_180,
            m.above_250,
        ];
        assert_eq!(r.map(f64::to_bits), expected.map(f64::to_bits));
        assert!(range_percentages(&[]).is_err());
        assert!(range_percentages(&[100.0, f64::NAN]).is_err());
    }

    #[test]
    fn bands_follow_iglu_boundaries() {
        // One reading on each boundary.
        let g = [50.0, 54.0, 70.0, 180.0, 250.0, 300.0, 49.0, 301.0];
        let m = metrics_regular(&g).unwrap();
        let p = |k: f64| 100.0 * k / 8.0;
        assert_eq!(m.tir_70_180, p(2.0), "70 and 180 are in range");
        assert_eq!(m.hypo_50_70, p(2.0), "50 and 54 are hypo, 70 is not");
        assert_eq!(m.severe_hypo_lt50, p(1.0));
        assert_eq!(m.hyper_180_300, p(2.0), "250 and 300, not 180");
        assert_eq!(m.severe_hyper_gt300, p(1.0));
        assert_eq!(m.below_54, p(2.0), "49 and 50; 54 is not below 54");
        assert_eq!(m.below_70, p(3.0));
        assert_eq!(m.above_180, p(3.0));
        assert_eq!(m.above_250, p(2.0), "300 and 301; 250 is not above 250");
    }

    #[test]
    fn moments_and_gmi() {
        let m = metrics_regular(&[100.0, 200.0]).unwrap();
        let sd = 50.0 * 2f64.sqrt();
        assert!((m.mean_mg_dl - 150.0).abs() < 1e-12);
        assert!((m.sd_mg_dl - sd).abs() < 1e-12, "sd {} vs {sd}", m.sd_mg_dl);
        assert!((m.cv_pct - 100.0 * sd / 150.0).abs() < 1e-12);
        assert!((m.gmi_pct - (3.31 + 0.02392 * 150.0)).abs() < 1e-12);
        assert_eq!(m.mage, None, "two readings hold no excursion");
    }

    #[test]
    fn risk_indices_average_over_all_readings() {
        // f(112.5) ≈ 0: the neutral point of Kovatchev's scale.
        let g = [60.0, 250.0];
        let m = metrics_regular(&g).unwrap();
        let f_lo = kovatchev_f(60.0);
        let f_hi = kovatchev_f(250.0);
        assert!(f_lo < 0.0 && f_hi > 0.0);
        assert!((m.lbgi - 10.0 * f_lo * f_lo / 2.0).abs() < 1e-12);
        assert!((m.hbgi - 10.0 * f_hi * f_hi / 2.0).abs() < 1e-12);
    }

    #[test]
    fn bad_input_is_an_error() {
        assert!(matches!(
            metrics_regular(&[]),
            Err(CoreError::Metric { .. })
        ));
        assert!(matches!(
            metrics_regular(&[100.0, f64::NAN]),
            Err(CoreError::BadReading { index: 1, .. })
        ));
        assert!(matches!(
            metrics_regular(&[100.0, 120.0, 0.0]),
            Err(CoreError::BadReading { index: 2, .. })
        ));
        assert!(matches!(
            metrics_timed(&[0.0, 10.0, 5.0], &[100.0, 110.0, 120.0]),
            Err(CoreError::UnsortedTimes { index: 2, .. })
        ));
        assert!(matches!(
            metrics_timed(&[0.0, 5.0, 5.0], &[100.0, 110.0, 120.0]),
            Err(CoreError::UnsortedTimes { index: 2, .. })
        ));
        assert!(matches!(
            metrics_timed(&[0.0, 5.0], &[100.0, 110.0, 120.0]),
            Err(CoreError::Metric { .. })
        ));
    }

    #[test]
    fn serializes_exactly_the_fifteen_keys() {
        let m = metrics_regular(&[100.0, 200.0, 150.0]).unwrap();
        let v = serde_json::to_value(m).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(|k| k.as_str()).collect();
        let mut want: Vec<&str> = Metric::GLUCOSE.iter().map(|m| m.key()).collect();
        want.sort_unstable();
        let mut got = keys.clone();
        got.sort_unstable();
        assert_eq!(got, want);
        // Each field serializes under its metric's key with its value.
        for (metric, value) in m.entries() {
            assert_eq!(v[metric.key()].as_f64(), value, "{metric}");
        }
        assert_eq!(m.get(Metric::MeanMgDl), Some(150.0));
        assert_eq!(m.get(Metric::TdiUPerDay), None);
    }
}
