//! Window statistics, features (seed eq10-12) and the local cost (eq13).
//!
//! A window's readings are folded into [`WindowStats`] as they arrive, so no
//! reading is stored: the features only need counts and sums of excursions.

use crate::config::{Excursion, FeatureConfig, Mode};
use serde::{Deserialize, Serialize};

/// Running statistics of the readings of one window.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct WindowStats {
    /// Number of readings.
    pub n: u32,
    /// Readings above G_H.
    pub n_hyper: u32,
    /// Σ (M − G_H) over readings above G_H (mg/dL).
    pub sum_hyper_mg_dl: f64,
    /// Readings below G_L.
    pub n_hypo: u32,
    /// Σ (G_L − M) over readings below G_L (mg/dL).
    pub sum_hypo_mg_dl: f64,
    /// Hyponumber: readings below 70 mg/dL (eq27).
    pub hyponumber: u32,
    /// N1: readings below 80 mg/dL (eq27).
    pub n1: u32,
    /// N2: readings above 130 mg/dL (eq27).
    pub n2: u32,
}

impl WindowStats {
    /// Adds one reading (mg/dL).
    pub fn push(&mut self, g_mg_dl: f64, cfg: &FeatureConfig) {
        self.n += 1;
        if g_mg_dl > cfg.g_high_mg_dl {
            self.n_hyper += 1;
            self.sum_hyper_mg_dl += g_mg_dl - cfg.g_high_mg_dl;
        }
        if g_mg_dl < cfg.g_low_mg_dl {
            self.n_hypo += 1;
            self.sum_hypo_mg_dl += cfg.g_low_mg_dl - g_mg_dl;
        }
        if g_mg_dl < cfg.hyponumber_below_mg_dl {
            self.hyponumber += 1;
        }
        if g_mg_dl < cfg.n1_below_mg_dl {
            self.n1 += 1;
        }
        if g_mg_dl > cfg.n2_above_mg_dl {
            self.n2 += 1;
        }
    }

    /// True when no reading fell in the window.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The features of this window for an advisor in `mode` (the reading of
    /// eq10-11 is `cfg.cgm_excursion` or `cfg.smbg_excursion`).
    pub fn features(&self, cfg: &FeatureConfig, mode: Mode) -> Features {
        Features::from_stats(self, cfg, mode)
    }
}

/// The feature vector F = (F_hyper, F_hypo) with its raw (mg/dL) parts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Features {
    /// Excursion above G_H (mg/dL), eq10: the mean over the readings above
    /// G_H (`out_of_range_mean`), or the sum of excursions divided by all
    /// readings of the window (`time_averaged`); 0 if none.
    pub raw_hyper_mg_dl: f64,
    /// Excursion below G_L (mg/dL), eq11, averaged like `raw_hyper_mg_dl`.
    pub raw_hypo_mg_dl: f64,
    /// Normalised F_hyper = clamp(raw / (G_max − G_H), 0, 1).
    pub hyper: f64,
    /// Normalised F_hypo = clamp(raw / (G_L − G_min), 0, 1).
    pub hypo: f64,
}

impl Features {
    /// Eq10-12 with the spec's normalisation (§3). With
    /// [`Excursion::OutOfRangeMean`] (the mode's reading, see
    /// [`FeatureConfig::excursion_for`]) each raw feature is the mean
    /// excursion of the out-of-range readings only; with
    /// [`Excursion::TimeAveraged`] it is the sum of excursions divided by all
    /// readings of the window, which does not depend on the sampling rate.
    pub fn from_stats(s: &WindowStats, cfg: &FeatureConfig, mode: Mode) -> Self {
        let time_averaged = cfg.excursion_for(mode) == Excursion::TimeAveraged;
        let mean = |sum: f64, n_out: u32| {
            let n = if time_averaged { s.n } else { n_out };
            if n_out > 0 && n > 0 {
                sum / f64::from(n)
            } else {
                0.0
            }
        };
        let raw_hyper = mean(s.sum_hyper_mg_dl, s.n_hyper); // eq10
        let raw_hypo = mean(s.sum_hypo_mg_dl, s.n_hypo); // eq11
        Self {
            raw_hyper_mg_dl: raw_hyper,
            raw_hypo_mg_dl: raw_hypo,
            hyper: (raw_hyper / (cfg.g_max_for(mode) - cfg.g_high_mg_dl)).clamp(0.0, 1.0),
            hypo: (raw_hypo / (cfg.g_low_mg_dl - cfg.g_min_for(mode))).clamp(0.0, 1.0),
        }
    }

    /// F as an array (hyper, hypo), eq12.
    pub fn vector(&self) -> [f64; 2] {
        [self.hyper, self.hypo]
    }

    /// ‖F‖² = F_hyper² + F_hypo².
    pub fn norm_sq(&self) -> f64 {
        self.hyper * self.hyper + self.hypo * self.hypo
    }
}

/// Local cost c = a_hyper·F_hyper + a_hypo·F_hypo (seed eq13).
pub fn local_cost(f: &Features, a_hyper: f64, a_hypo: f64) -> f64 {
    a_hyper * f.hyper + a_hypo * f.hypo
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats(values: &[f64]) -> WindowStats {
        let cfg = FeatureConfig::spec();
        let mut s = WindowStats::default();
        for &v in values {
            s.push(v, &cfg);
        }
        s
    }

    fn close(name: &str, expected: f64, got: f64) {
        assert!(
            (expected - got).abs() < 1e-12,
            "{name}: expected {expected}, got {got}"
        );
    }

    #[test]
    fn eq10_eq11_mean_excursion_of_out_of_range_samples_only() {
        // 200 and 250 are above 150 (excursions 50, 100 -> mean 75);
        // 60 is below 90 (excursion 30); 120 is in range and does not dilute.
        let s = stats(&[200.0, 120.0, 250.0, 60.0]);
        let f = s.features(&FeatureConfig::spec(), Mode::Smbg);
        close("raw hyper (eq10)", 75.0, f.raw_hyper_mg_dl);
        close("raw hypo (eq11)", 30.0, f.raw_hypo_mg_dl);
        assert_eq!((s.n, s.n_hyper, s.n_hypo), (4, 2, 1));
        // eq27 counts: <70: {60}; <80: {60}; >130: {200, 250}
        assert_eq!((s.hyponumber, s.n1, s.n2), (1, 1, 2));
    }

    #[test]
    fn eq12_normalisation_divides_by_250_and_50_and_clamps() {
        let f = stats(&[200.0, 250.0, 60.0]).features(&FeatureConfig::spec(), Mode::Smbg);
        close("F_hyper = 75/250", 0.3, f.hyper);
        close("F_hypo = 30/50", 0.6, f.hypo);
        assert_eq!(f.vector(), [f.hyper, f.hypo]);
        // 600 mg/dL: excursion 450 > 250 -> clamped to 1; 20 mg/dL: 70 > 50 -> 1.
        let f = stats(&[600.0, 20.0]).features(&FeatureConfig::spec(), Mode::Smbg);
        close("F_hyper clamped", 1.0, f.hyper);
        close("F_hypo clamped", 1.0, f.hypo);
    }

    #[test]
    fn in_range_or_empty_windows_give_zero_features() {
        let f = stats(&[90.0, 150.0, 120.0]).features(&FeatureConfig::spec(), Mode::Smbg);
        assert_eq!(f.vector(), [0.0, 0.0], "thresholds are strict");
        let s = stats(&[]);
        assert!(s.is_empty());
        assert_eq!(
            s.features(&FeatureConfig::spec(), Mode::Smbg).vector(),
            [0.0, 0.0]
        );
    }

    /// A day of 5-minute CGM readings at 120 mg/dL except `dip` readings at `low`.
    fn cgm_day(dip: usize, low: f64) -> WindowStats {
        let mut v = vec![120.0; 288 - dip];
        v.extend(std::iter::repeat_n(low, dip));
        stats(&v)
    }

    #[test]
    fn out_of_range_mean_weighs_a_15_minute_dip_like_a_whole_day() {
        let cfg = FeatureConfig::spec();
        let dip = cgm_day(3, 80.0).features(&cfg, Mode::Cgm);
        let all_day = stats(&[80.0; 288]).features(&cfg, Mode::Cgm);
        close("F_hypo: 15 min at 80 = a day at 80", all_day.hypo, dip.hypo);
        close("F_hypo = 10/50", 0.2, dip.hypo);
    }

    #[test]
    fn time_averaged_weighs_a_15_minute_dip_by_its_duration() {
        let cfg = FeatureConfig::default();
        assert_eq!(cfg.cgm_excursion, Excursion::TimeAveraged);
        let dip = cgm_day(3, 80.0).features(&cfg, Mode::Cgm);
        let all_day = stats(&[80.0; 288]).features(&cfg, Mode::Cgm);
        close("F_hypo of a day at 80", 0.2, all_day.hypo);
        close("15 min of 24 h = 1/96", all_day.hypo / 96.0, dip.hypo);
        // Hyper side: 2 of 4 readings 100 above G_H -> 200/4 = 50, divided
        // by CGM mode's G_max − G_H = 350 − 150 -> 0.25.
        let f = stats(&[250.0, 250.0, 120.0, 120.0]).features(&cfg, Mode::Cgm);
        close("time-averaged hyper", 0.25, f.hyper);
        // SMBG mode has its own knob: out-of-range mean (100 -> 0.4).
        let cfg = FeatureConfig {
            cgm_excursion: Excursion::TimeAveraged,
            ..FeatureConfig::spec()
        };
        let f = stats(&[250.0, 250.0, 120.0, 120.0]).features(&cfg, Mode::Smbg);
        close("SMBG hyper", 0.4, f.hyper);
    }

    #[test]
    fn smbg_excursion_knob_weighs_each_reading_as_a_quarter_of_the_day() {
        // One reading at 70 and three at 250: out-of-range means give the
        // low reading the whole day (20/50 = 0.4) and the three high ones
        // their mean (100/250 = 0.4); time-averaged, each reading counts for
        // a quarter: F_hypo = 20/4/50 = 0.1, F_hyper = 300/4/250 = 0.3.
        let day = stats(&[70.0, 250.0, 250.0, 250.0]);
        let literal = FeatureConfig::spec();
        let f = day.features(&literal, Mode::Smbg);
        close("literal F_hypo", 0.4, f.hypo);
        close("literal F_hyper", 0.4, f.hyper);
        let averaged = FeatureConfig {
            smbg_excursion: Excursion::TimeAveraged,
            ..literal.clone()
        };
        let f = day.features(&averaged, Mode::Smbg);
        close("time-averaged F_hypo", 0.1, f.hypo);
        close("time-averaged F_hyper", 0.3, f.hyper);
        // The SMBG knob leaves CGM mode alone, and the CGM knob SMBG mode.
        assert_eq!(
            day.features(&literal, Mode::Cgm),
            day.features(&averaged, Mode::Cgm)
        );
        let cgm_literal = FeatureConfig {
            cgm_excursion: Excursion::OutOfRangeMean,
            ..averaged.clone()
        };
        assert_eq!(
            day.features(&cgm_literal, Mode::Smbg),
            day.features(&averaged, Mode::Smbg)
        );
    }

    #[test]
    fn cgm_normalisation_knobs_change_cgm_mode_only() {
        let cfg = FeatureConfig {
            cgm_excursion: Excursion::TimeAveraged,
            cgm_g_min_mg_dl: Some(65.0),
            ..FeatureConfig::spec()
        };
        let s = stats(&[80.0, 120.0]);
        // Time-averaged raw = 10/2 = 5 mg/dL; divided by 90 − 65 = 25.
        close("CGM F_hypo", 0.2, s.features(&cfg, Mode::Cgm).hypo);
        // SMBG: out-of-range mean 10, divided by 90 − 40 = 50.
        close("SMBG F_hypo", 0.2, s.features(&cfg, Mode::Smbg).hypo);
        let default = FeatureConfig::default();
        close("CGM default", 0.1, s.features(&default, Mode::Cgm).hypo);
        // cgm_g_max: 2 of 4 readings 100 above G_H -> 50 mg/dL; /(250 − 150).
        let cfg = FeatureConfig {
            cgm_excursion: Excursion::TimeAveraged,
            cgm_g_max_mg_dl: Some(250.0),
            ..FeatureConfig::spec()
        };
        let s = stats(&[250.0, 250.0, 120.0, 120.0]);
        close("CGM F_hyper", 0.5, s.features(&cfg, Mode::Cgm).hyper);
        close("SMBG F_hyper", 0.4, s.features(&cfg, Mode::Smbg).hyper);
        // The defaults: time-averaged in both modes (50 mg/dL), divided by
        // 250 − 150 in SMBG mode and by 350 − 150 in CGM mode.
        close("default SMBG", 0.5, s.features(&default, Mode::Smbg).hyper);
        close("default CGM", 0.25, s.features(&default, Mode::Cgm).hyper);
    }

    #[test]
    fn eq13_local_cost_weights_hypo_ten_times() {
        let f = Features {
            hyper: 0.3,
            hypo: 0.6,
            ..Default::default()
        };
        close("c = 1*0.3 + 10*0.6", 6.3, local_cost(&f, 1.0, 10.0));
        close("norm^2", 0.45, f.norm_sq());
    }
}
