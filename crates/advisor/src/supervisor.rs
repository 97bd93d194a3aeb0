//! The supervisory action P_s (seed eq26, eq27 in SMBG mode; eq29 in CGM mode).
//!
//! Sign convention: P_s is a relative change of the parameter. For the basal
//! rate (U/h) a positive P_s means more insulin; for a carb ratio (g/U) a
//! positive P_s means a larger ratio, i.e. *less* insulin.

use crate::config::{Mode, SupervisorConfig};
use crate::features::{Features, WindowStats};
use serde::{Deserialize, Serialize};

/// Which therapy parameter an agent adapts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParamKind {
    /// The flat basal rate.
    Basal,
    /// A carb ratio.
    CarbRatio,
}

/// Which branch of the supervisory rule fired (for explanations).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SupervisoryRule {
    /// eq26: no excursion, P_s = 0.
    SmbgCirInRange,
    /// eq26: hypo excursion present, P_s = +gain·F_hypo (CIR up, less insulin).
    SmbgCirHypo,
    /// eq26: hyper only, P_s = −gain·F_hyper (CIR down, more insulin).
    SmbgCirHyper,
    /// eq27 row 1: Hyponumber > 0, P_s = −F_hypo/8.
    SmbgBrHyponumber,
    /// eq27 row 2: N1 ≤ 1 and N2 ≥ 2, P_s = +F_hyper/30.
    SmbgBrMostlyHigh,
    /// eq27 row 3: N1 ≥ 2 and N2 ≤ 1, P_s = −F_hypo/30.
    SmbgBrMostlyLow,
    /// eq27 row 4: otherwise, P_s = 0.
    SmbgBrOther,
    /// eq29: F_hypo = 0, P_s = 0.
    CgmNoHypo,
    /// eq29: hypo only, P_s = ∓0.10·F_hypo.
    CgmHypoOnly,
    /// eq29: hypo and hyper, P_s = ∓0.05·F_hypo.
    CgmMixed,
}

/// P_s and the rule that produced it.
pub fn supervisory(
    mode: Mode,
    kind: ParamKind,
    f: &Features,
    counts: &WindowStats,
    cfg: &SupervisorConfig,
) -> (f64, SupervisoryRule) {
    match (mode, kind) {
        // eq26, the order of the cases as in the seed: hypo wins over hyper.
        (Mode::Smbg, ParamKind::CarbRatio) => {
            if f.hyper == 0.0 && f.hypo == 0.0 {
                (0.0, SupervisoryRule::SmbgCirInRange)
            } else if f.hypo > 0.0 {
                (cfg.smbg_cir_gain * f.hypo, SupervisoryRule::SmbgCirHypo)
            } else {
                (-cfg.smbg_cir_gain * f.hyper, SupervisoryRule::SmbgCirHyper)
            }
        }
        // eq27, first matching row wins (order [GUESS] as listed in the seed).
        (Mode::Smbg, ParamKind::Basal) => {
            if counts.hyponumber > 0 {
                (
                    -f.hypo / cfg.smbg_br_hypo_divisor,
                    SupervisoryRule::SmbgBrHyponumber,
                )
            } else if counts.n1 <= 1 && counts.n2 >= 2 {
                (
                    f.hyper / cfg.smbg_br_high_divisor,
                    SupervisoryRule::SmbgBrMostlyHigh,
                )
            } else if counts.n1 >= 2 && counts.n2 <= 1 {
                (
                    -f.hypo / cfg.smbg_br_low_divisor,
                    SupervisoryRule::SmbgBrMostlyLow,
                )
            } else {
                (0.0, SupervisoryRule::SmbgBrOther)
            }
        }
        // eq29: upper sign for BR (less basal), lower for CIR (larger ratio).
        (Mode::Cgm, _) => {
            let sign = match kind {
                ParamKind::Basal => -1.0,
                ParamKind::CarbRatio => 1.0,
            };
            if f.hypo == 0.0 {
                (0.0, SupervisoryRule::CgmNoHypo)
            } else if f.hyper == 0.0 {
                (
                    sign * cfg.cgm_hypo_only_gain * f.hypo,
                    SupervisoryRule::CgmHypoOnly,
                )
            } else {
                (
                    sign * cfg.cgm_mixed_gain * f.hypo,
                    SupervisoryRule::CgmMixed,
                )
            }
        }
    }
}

/// True if a relative change `p` of a parameter of `kind` would add insulin.
pub fn adds_insulin(kind: ParamKind, p: f64) -> bool {
    match kind {
        ParamKind::Basal => p > 0.0,
        ParamKind::CarbRatio => p < 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::FeatureConfig;

    fn window(values: &[f64]) -> (Features, WindowStats) {
        let cfg = FeatureConfig::spec();
        let mut s = WindowStats::default();
        for &v in values {
            s.push(v, &cfg);
        }
        (s.features(&cfg, Mode::Smbg), s)
    }

    fn check(name: &str, expected: f64, got: f64) {
        assert!(
            (expected - got).abs() < 1e-12,
            "{name}: expected {expected}, got {got}"
        );
    }

    #[test]
    fn eq26_smbg_cir() {
        let c = SupervisorConfig::default();
        // Hyper only: 200 -> F_hyper = 50/250 = 0.2 -> P_s = -0.02*0.2 = -0.004 (CIR down: more insulin).
        let (f, s) = window(&[200.0]);
        let (p, r) = supervisory(Mode::Smbg, ParamKind::CarbRatio, &f, &s, &c);
        check("eq26 hyper", -0.004, p);
        assert_eq!(r, SupervisoryRule::SmbgCirHyper);
        assert!(adds_insulin(ParamKind::CarbRatio, p));
        // Hypo present (even with hyper): 65 -> F_hypo = 25/50 = 0.5 -> +0.01 (CIR up: less insulin).
        let (f, s) = window(&[200.0, 65.0]);
        let (p, r) = supervisory(Mode::Smbg, ParamKind::CarbRatio, &f, &s, &c);
        check("eq26 hypo", 0.01, p);
        assert_eq!(r, SupervisoryRule::SmbgCirHypo);
        let (f, s) = window(&[100.0, 140.0]);
        check(
            "eq26 in range",
            0.0,
            supervisory(Mode::Smbg, ParamKind::CarbRatio, &f, &s, &c).0,
        );
    }

    #[test]
    fn eq27_smbg_br_rows_in_order() {
        let c = SupervisorConfig::default();
        // Row 1: a reading < 70. 60 -> F_hypo = 30/50 = 0.6 -> P_s = -0.6/8 = -0.075.
        let (f, s) = window(&[60.0, 200.0, 210.0, 220.0]);
        let (p, r) = supervisory(Mode::Smbg, ParamKind::Basal, &f, &s, &c);
        check("eq27 row 1", -0.075, p);
        assert_eq!(r, SupervisoryRule::SmbgBrHyponumber);
        // Row 2: N1 = 0, N2 = 3. Excursions 50, 100, 0(140 not > 150), 150 -> mean of (50,100,150)=100 -> F = 0.4 -> +0.4/30.
        let (f, s) = window(&[200.0, 250.0, 140.0, 300.0]);
        let (p, r) = supervisory(Mode::Smbg, ParamKind::Basal, &f, &s, &c);
        check("eq27 row 2", 0.4 / 30.0, p);
        assert_eq!(r, SupervisoryRule::SmbgBrMostlyHigh);
        assert!(adds_insulin(ParamKind::Basal, p));
        // Row 3: N1 = 2 (75, 78), N2 = 1, none < 70. F_hypo = mean(15, 12)/50 = 0.27 -> -0.27/30.
        let (f, s) = window(&[75.0, 78.0, 100.0, 200.0]);
        let (p, r) = supervisory(Mode::Smbg, ParamKind::Basal, &f, &s, &c);
        check("eq27 row 3", -0.27 / 30.0, p);
        assert_eq!(r, SupervisoryRule::SmbgBrMostlyLow);
        // Row 4: N1 = 1, N2 = 1.
        let (f, s) = window(&[75.0, 100.0, 110.0, 200.0]);
        let (p, r) = supervisory(Mode::Smbg, ParamKind::Basal, &f, &s, &c);
        check("eq27 row 4", 0.0, p);
        assert_eq!(r, SupervisoryRule::SmbgBrOther);
    }

    #[test]
    fn eq29_cgm_signs() {
        let c = SupervisorConfig::default();
        // Hypo only: 65 -> F_hypo = 0.5. BR: -0.05; CIR: +0.05.
        let (f, s) = window(&[65.0, 100.0]);
        check(
            "eq29 BR hypo only",
            -0.05,
            supervisory(Mode::Cgm, ParamKind::Basal, &f, &s, &c).0,
        );
        check(
            "eq29 CIR hypo only",
            0.05,
            supervisory(Mode::Cgm, ParamKind::CarbRatio, &f, &s, &c).0,
        );
        // Mixed: F_hypo = 0.5 -> ∓0.025.
        let (f, s) = window(&[65.0, 250.0]);
        let (p, r) = supervisory(Mode::Cgm, ParamKind::Basal, &f, &s, &c);
        check("eq29 BR mixed", -0.025, p);
        assert_eq!(r, SupervisoryRule::CgmMixed);
        check(
            "eq29 CIR mixed",
            0.025,
            supervisory(Mode::Cgm, ParamKind::CarbRatio, &f, &s, &c).0,
        );
        // Hyper only: P_s = 0 (CGM supervisor never asks for more insulin).
        let (f, s) = window(&[300.0]);
        check(
            "eq29 hyper only",
            0.0,
            supervisory(Mode::Cgm, ParamKind::Basal, &f, &s, &c).0,
        );
    }
}
