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

/// The night of an SMBG basal window that starts the evening before
/// (`features.smbg_night_fall_mg_dl`): the evening's and the morning's
/// readings apart, and the two readings that tell whether the night fell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct NightStats {
    /// The readings of the evening before.
    pub evening: WindowStats,
    /// The readings of the morning (from midnight to the window's end).
    pub morning: WindowStats,
    /// The evening's last reading (mg/dL).
    pub last_evening_mg_dl: Option<f64>,
    /// The morning's first reading (mg/dL).
    pub first_morning_mg_dl: Option<f64>,
}

impl NightStats {
    /// Adds a reading of the evening before.
    pub fn push_evening(&mut self, g_mg_dl: f64, cfg: &FeatureConfig) {
        self.evening.push(g_mg_dl, cfg);
        self.last_evening_mg_dl = Some(g_mg_dl);
    }

    /// Adds a reading of the morning.
    pub fn push_morning(&mut self, g_mg_dl: f64, cfg: &FeatureConfig) {
        self.morning.push(g_mg_dl, cfg);
        self.first_morning_mg_dl.get_or_insert(g_mg_dl);
    }

    /// How far glucose fell from the evening's last reading to the
    /// morning's first (mg/dL; negative: it rose), when both exist.
    pub fn fall_mg_dl(&self) -> Option<f64> {
        Some(self.last_evening_mg_dl? - self.first_morning_mg_dl?)
    }

    /// The window's statistics, evening then morning; when the night fell
    /// by at least `fall_mg_dl`, the evening's readings count as in range
    /// above G_L (their hyper excursions and N2 left out, their hypo parts
    /// kept).
    pub fn window(&self, fall_mg_dl: f64) -> WindowStats {
        let e = self.evening;
        let m = self.morning;
        let fell = self.fall_mg_dl().is_some_and(|f| f >= fall_mg_dl);
        let (n_hyper, sum_hyper, n2) = if fell {
            (0, 0.0, 0)
        } else {
            (e.n_hyper, e.sum_hyper_mg_dl, e.n2)
        };
        WindowStats {
            n: e.n + m.n,
            n_hyper: n_hyper + m.n_hyper,
            sum_hyper_mg_dl: sum_hyper + m.sum_hyper_mg_dl,
            n_hypo: e.n_hypo + m.n_hypo,
            sum_hypo_mg_dl: e.sum_hypo_mg_dl + m.sum_hypo_mg_dl,
            hyponumber: e.hyponumber + m.hyponumber,
            n1: e.n1 + m.n1,
            n2: n2 + m.n2,
        }
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
    fn a_high_bedtime_reading_whose_night_fell_counts_as_in_range_and_its_lows_always_count() {
        let cfg = FeatureConfig::default();
        let night = |evening: &[f64], morning: &[f64]| {
            let mut n = NightStats::default();
            for g in evening {
                n.push_evening(*g, &cfg);
            }
            for g in morning {
                n.push_morning(*g, &cfg);
            }
            n
        };
        // Bedtime 200, fasting 140: the night fell 60 mg/dL.
        let fell = night(&[200.0], &[140.0]);
        assert_eq!(fell.fall_mg_dl(), Some(60.0));
        // With a threshold of 30 the bedtime reading counts as in range:
        // no hyper excursion, not in N2, but still one of the two readings.
        let w = fell.window(30.0);
        assert_eq!((w.n, w.n_hyper, w.n2), (2, 0, 1));
        assert_eq!(w.sum_hyper_mg_dl, 0.0);
        // With 60 it still counts as in range (at least the threshold); with
        // 61 the night did not fall enough: both readings as they are.
        assert_eq!(fell.window(60.0), w);
        assert_eq!(fell.window(61.0), stats(&[200.0, 140.0]));
        // A night that rose (160 -> 190): the bedtime reading counts.
        let rose = night(&[160.0], &[190.0]);
        assert_eq!(rose.window(0.0), stats(&[160.0, 190.0]));
        // A low bedtime reading is never discounted, however far the night fell.
        let low = night(&[85.0], &[60.0]);
        let w = low.window(0.0);
        assert_eq!((w.n_hypo, w.hyponumber, w.n1), (2, 1, 1));
        assert_eq!(w, stats(&[85.0, 60.0]));
        // Without a morning reading (or an evening one) there is no fall.
        assert_eq!(night(&[220.0], &[]).window(0.0), stats(&[220.0]));
        assert_eq!(night(&[], &[220.0]).window(0.0), stats(&[220.0]));
        // The fall is measured from the evening's last reading to the
        // morning's first.
        let two = night(&[120.0, 230.0], &[180.0, 250.0]);
        assert_eq!(two.fall_mg_dl(), Some(50.0));
        let w = two.window(40.0);
        assert_eq!((w.n, w.n_hyper, w.n2), (4, 2, 2));
        assert_eq!(w.sum_hyper_mg_dl, 30.0 + 100.0);
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
