//! From the action P_e to the new parameter value: eq16-21 and the 5 % clamp.

use crate::config::RecentLow;
use crate::supervisor::ParamKind;
use serde::{Deserialize, Serialize};

/// Every intermediate value of one parameter update.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Applied {
    /// AP_old, the value in use.
    pub old: f64,
    /// AP_new = AP_old·(1 + P_e) (eq16).
    pub ap_new: f64,
    /// AP_fusion = m·AP_old + (1−m)·AP_new (eq17-18).
    pub ap_fusion: f64,
    /// l = 1: the CIR was frozen because BR and bolus insulin would move together (eq20-21).
    pub switch_fired: bool,
    /// The relative-change clamp changed the value.
    pub clamp_fired: bool,
    /// The non-finite guard fired (a non-finite action left the value unchanged).
    pub non_finite: bool,
    /// The optional hypo guard (`update.hypo_guard`) cancelled an insulin increase.
    #[serde(default)]
    pub hypo_guard_fired: bool,
    /// SMBG mode: the recent-low rule (`update.smbg_recent_low_*`) that
    /// cancelled an insulin increase.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recent_low: Option<RecentLow>,
    /// AP_final, the value from now on.
    pub new: f64,
}

/// Applies eq16-21 and the clamp.
///
/// `br_change` is (BR_old, BR_final) of the most recent basal update, used by
/// the CIR switch rule (eq21); `None` (no basal update yet) means l = 0.
pub fn apply_action(
    kind: ParamKind,
    old: f64,
    p_e: f64,
    fusion_m: f64,
    br_change: Option<(f64, f64)>,
    switch_rule: bool,
    max_relative_change: f64,
) -> Applied {
    let ap_new = old + p_e * old; // eq16
    let ap_fusion = fusion_m * old + (1.0 - fusion_m) * ap_new; // eq17 (eq18 for m = 0.5)
    let mut switch_fired = false;
    // eq19 (BR_final = BR_fusion) and eq20-21 for the CIRs.
    let mut value = ap_fusion;
    if kind == ParamKind::CarbRatio && switch_rule {
        if let Some((br_old, br_final)) = br_change {
            let l =
                (br_final > br_old && ap_fusion < old) || (br_final < br_old && ap_fusion > old);
            if l {
                switch_fired = true;
                value = old; // eq20 with l = 1
            }
        }
    }
    if !value.is_finite() {
        return Applied {
            old,
            ap_new,
            ap_fusion,
            switch_fired,
            clamp_fired: false,
            non_finite: true,
            hypo_guard_fired: false,
            recent_low: None,
            new: old,
        };
    }
    // The seed's "maximum change within 5 %", applied last ([GUESS] ordering).
    let lo = old * (1.0 - max_relative_change);
    let hi = old * (1.0 + max_relative_change);
    let clamped = value.clamp(lo, hi);
    Applied {
        old,
        ap_new,
        ap_fusion,
        switch_fired,
        clamp_fired: clamped != value,
        non_finite: false,
        hypo_guard_fired: false,
        recent_low: None,
        new: clamped,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(name: &str, expected: f64, got: f64) {
        assert!(
            (expected - got).abs() < 1e-12,
            "{name}: expected {expected}, got {got}"
        );
    }

    #[test]
    fn eq16_to_eq19_basal() {
        // BR 1.0 U/h, P_e = +0.06: AP_new = 1.06, fusion = 1.03, final = 1.03 (inside 5 %).
        let a = apply_action(ParamKind::Basal, 1.0, 0.06, 0.5, None, true, 0.05);
        check("eq16 AP_new", 1.06, a.ap_new);
        check("eq17/18 AP_fusion", 1.03, a.ap_fusion);
        check("eq19 BR_final", 1.03, a.new);
        assert!(!a.clamp_fired && !a.switch_fired);
    }

    #[test]
    fn five_percent_clamp_saturates_at_p_e_of_ten_percent() {
        // P_e = -0.3: fusion = 0.85 -> clamped to 0.95.
        let a = apply_action(ParamKind::Basal, 1.0, -0.3, 0.5, None, true, 0.05);
        check("fusion", 0.85, a.ap_fusion);
        check("clamped", 0.95, a.new);
        assert!(a.clamp_fired);
        // P_e = +0.1 exactly reaches +5 % without firing.
        let a = apply_action(ParamKind::CarbRatio, 10.0, 0.1, 0.5, None, true, 0.05);
        check("edge", 10.5, a.new);
        assert!(!a.clamp_fired);
    }

    #[test]
    fn eq20_eq21_switch_rule() {
        // BR went up (1.0 -> 1.02) and the CIR would go down (more bolus): frozen, l = 1.
        let a = apply_action(
            ParamKind::CarbRatio,
            10.0,
            -0.04,
            0.5,
            Some((1.0, 1.02)),
            true,
            0.05,
        );
        check("fusion", 9.8, a.ap_fusion);
        assert!(a.switch_fired);
        check("eq20 l=1 keeps CIR_old", 10.0, a.new);
        // BR down and CIR up (less bolus): frozen too.
        let a = apply_action(
            ParamKind::CarbRatio,
            10.0,
            0.04,
            0.5,
            Some((1.0, 0.98)),
            true,
            0.05,
        );
        assert!(a.switch_fired);
        check("eq20 l=1", 10.0, a.new);
        // BR up, CIR up (basal more, bolus less): l = 0, fused value used.
        let a = apply_action(
            ParamKind::CarbRatio,
            10.0,
            0.04,
            0.5,
            Some((1.0, 1.02)),
            true,
            0.05,
        );
        assert!(!a.switch_fired);
        check("eq20 l=0", 10.2, a.new);
        // BR unchanged: l = 0.
        let a = apply_action(
            ParamKind::CarbRatio,
            10.0,
            -0.04,
            0.5,
            Some((1.0, 1.0)),
            true,
            0.05,
        );
        check("eq21 BR unchanged", 9.8, a.new);
        // The rule never applies to the basal rate itself.
        let a = apply_action(
            ParamKind::Basal,
            1.0,
            -0.04,
            0.5,
            Some((1.0, 1.02)),
            true,
            0.05,
        );
        check("basal unaffected", 0.98, a.new);
        // Disabled by the knob.
        let a = apply_action(
            ParamKind::CarbRatio,
            10.0,
            -0.04,
            0.5,
            Some((1.0, 1.02)),
            false,
            0.05,
        );
        check("switch off", 9.8, a.new);
    }

    #[test]
    fn non_finite_action_leaves_value_unchanged() {
        let a = apply_action(ParamKind::Basal, 1.0, f64::NAN, 0.5, None, true, 0.05);
        assert!(a.non_finite);
        check("unchanged", 1.0, a.new);
    }
}
