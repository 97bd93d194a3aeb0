//! Values a pump can set: the pump's basal-rate step and carb-ratio step,
//! and the rounding of a suggestion to them.
//!
//! A suggestion is rounded to the nearest multiple of the step that still
//! lies on the side of the value in force the advisor asked for, within the
//! 5 %-a-day clamp and the clinician's bounds; when no such multiple exists
//! (the change is smaller than one step) the value in force stays: "no
//! change". A basal schedule of several segments is scaled by one daily
//! factor and each segment rounded the same way (the paper's flat rate is
//! the one-segment case).

use crate::error::AdvisorError;
use serde::{Deserialize, Serialize};

/// Basal steps pumps program (U/h).
pub const BASAL_STEPS: [f64; 3] = [0.01, 0.025, 0.05];
/// Carb-ratio steps pumps program (g/U).
pub const CARB_RATIO_STEPS: [f64; 2] = [0.1, 1.0];

/// The smallest change a person's pump can make to each setting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PumpSteps {
    /// Basal-rate step (U/h): 0.05 (default), 0.025 or 0.01.
    pub basal_u_per_h: f64,
    /// Carb-ratio step (g/U): 0.1 (default) or 1.
    pub carb_ratio_g_per_u: f64,
}

impl Default for PumpSteps {
    fn default() -> Self {
        Self {
            basal_u_per_h: 0.05,
            carb_ratio_g_per_u: 0.1,
        }
    }
}

impl PumpSteps {
    /// Checks that both steps are ones pumps use.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        let known = |v: f64, set: &[f64]| set.iter().any(|s| (s - v).abs() < 1e-12);
        if !known(self.basal_u_per_h, &BASAL_STEPS) {
            return Err(AdvisorError::Config {
                field: "pump basal step (U/h)".into(),
                problem: format!("expected 0.05, 0.025 or 0.01, got {}", self.basal_u_per_h),
            });
        }
        if !known(self.carb_ratio_g_per_u, &CARB_RATIO_STEPS) {
            return Err(AdvisorError::Config {
                field: "pump carb-ratio step (g/U)".into(),
                problem: format!("expected 0.1 or 1, got {}", self.carb_ratio_g_per_u),
            });
        }
        Ok(())
    }
}

/// `k · step` without the binary noise of the product (0.05 · 17 is
/// 0.8500000000000001 in f64): rounded to 9 decimals, below any step.
pub fn multiple(k: i64, step: f64) -> f64 {
    ((k as f64) * step * 1e9).round() / 1e9
}

/// True when `v` is a multiple of `step` (to 1e-9).
pub fn on_step(v: f64, step: f64) -> bool {
    (v - multiple((v / step).round() as i64, step)).abs() < 1e-9
}

/// The multiple of `step` nearest to `target` within `[lo, hi]`, if any.
pub fn nearest_within(target: f64, step: f64, lo: f64, hi: f64) -> Option<f64> {
    if !(target.is_finite() && lo <= hi && step > 0.0) {
        return None;
    }
    let k_lo = (lo / step - 1e-9).ceil() as i64;
    let k_hi = (hi / step + 1e-9).floor() as i64;
    if k_lo > k_hi {
        return None;
    }
    let k = ((target / step).round() as i64).clamp(k_lo, k_hi);
    let v = multiple(k, step);
    // The 1e-9 slack above must not let a value out of its interval.
    (v >= lo - 1e-9 && v <= hi + 1e-9).then_some(v.clamp(lo, hi))
}

/// Rounds `requested` (a change from `old`) to `step`: the nearest multiple
/// on the requested side of `old`, within `[old·(1−max), old·(1+max)]` and
/// `allowed` (the clinician's bounds). `old` when no multiple fits (a change
/// smaller than one step) or nothing was asked. When `old` itself lies
/// outside `allowed`, the multiple inside `allowed` nearest to `requested`,
/// whatever the clamp.
pub fn round_change(
    old: f64,
    requested: f64,
    step: f64,
    max_relative_change: f64,
    allowed: Option<(f64, f64)>,
) -> f64 {
    if !(requested.is_finite() && old.is_finite()) {
        return old;
    }
    if let Some((a, b)) = allowed.filter(|&(a, b)| old < a || old > b) {
        // The value in force lies outside the clinician's bounds (set after
        // it): the bounds come before the clamp, so the value moves into
        // them, to the multiple inside nearest to the request (the bound
        // itself when no multiple fits between them).
        let target = requested.clamp(a, b);
        return nearest_within(target, step, a, b).unwrap_or(target);
    }
    if requested == old {
        return old;
    }
    let (mut lo, mut hi) = if requested > old {
        (old, old * (1.0 + max_relative_change))
    } else {
        (old * (1.0 - max_relative_change), old)
    };
    if let Some((a, b)) = allowed {
        lo = lo.max(a);
        hi = hi.min(b);
    }
    match nearest_within(requested, step, lo, hi) {
        // Landing back on `old` (when `old` is itself on the step) is no change.
        Some(v) if (v - old).abs() > 1e-9 => v,
        _ => old,
    }
}

/// A basal schedule: (minute of the local day it starts, rate U/h), the
/// first at minute 0, minutes strictly increasing.
pub type Segments = Vec<(u32, f64)>;

/// Time-weighted mean rate of a schedule (its daily total / 24 h).
pub fn mean_rate(segments: &[(u32, f64)]) -> f64 {
    let mut total = 0.0;
    for (i, &(from, rate)) in segments.iter().enumerate() {
        let to = segments.get(i + 1).map_or(1440, |s| s.0);
        total += rate * f64::from(to.saturating_sub(from));
    }
    total / 1440.0
}

/// Checks a schedule's shape (first segment at 00:00, increasing minutes
/// below 1440, finite positive rates).
pub fn validate_segments(segments: &[(u32, f64)]) -> Result<(), AdvisorError> {
    let bad = |problem: String| AdvisorError::Config {
        field: "basal schedule".into(),
        problem,
    };
    match segments.first() {
        Some((0, _)) => {}
        Some((m, _)) => {
            return Err(bad(format!(
                "the first segment starts at minute {m}, not 00:00"
            )))
        }
        None => return Err(bad("no segment".into())),
    }
    for w in segments.windows(2) {
        if w[1].0 <= w[0].0 || w[1].0 >= 1440 {
            return Err(bad(format!(
                "segment starts must increase within the day (minute {} after {})",
                w[1].0, w[0].0
            )));
        }
    }
    if let Some((m, r)) = segments.iter().find(|s| !(s.1.is_finite() && s.1 > 0.0)) {
        return Err(bad(format!("the rate from minute {m} is {r} U/h")));
    }
    Ok(())
}

/// Scales every segment of `old` by the factor `requested_mean / mean(old)`
/// and rounds each to `step` within its own clamp. Each segment keeps the
/// side of the change; the clinician's bounds, if any, hold the new mean
/// (when rounding would carry it outside, the schedule stays; a schedule
/// whose mean lies outside them moves into them, unclamped).
pub fn scale_schedule(
    old: &[(u32, f64)],
    requested_mean: f64,
    step: f64,
    max_relative_change: f64,
    allowed_mean: Option<(f64, f64)>,
) -> Segments {
    let m = mean_rate(old);
    if !(m > 0.0 && requested_mean.is_finite()) {
        return old.to_vec();
    }
    if let Some((a, b)) = allowed_mean.filter(|&(a, b)| m < a || m > b) {
        return into_bounds(old, requested_mean.clamp(a, b), step, a, b);
    }
    let f = requested_mean / m;
    let new: Segments = old
        .iter()
        .map(|&(from, r)| {
            (
                from,
                round_change(r, r * f, step, max_relative_change, None),
            )
        })
        .collect();
    let nm = mean_rate(&new);
    match allowed_mean {
        Some((a, b)) if nm < a - 1e-12 || nm > b + 1e-12 => old.to_vec(),
        _ => new,
    }
}

/// A schedule whose mean lies outside the clinician's bounds `[a, b]`,
/// scaled by one factor to `target` (inside them) without the clamp: each
/// segment rounded to the nearest step, or towards the bounds when that
/// carries the mean outside, or unrounded when no rounding fits.
fn into_bounds(old: &[(u32, f64)], target: f64, step: f64, a: f64, b: f64) -> Segments {
    let f = target / mean_rate(old);
    let scaled = |round: fn(f64) -> f64| -> Segments {
        old.iter()
            .map(|&(from, r)| (from, multiple((round(r * f / step) as i64).max(1), step)))
            .collect()
    };
    let inside = |s: &Segments| {
        let m = mean_rate(s);
        m >= a - 1e-9 && m <= b + 1e-9
    };
    [scaled(f64::round), scaled(f64::floor), scaled(f64::ceil)]
        .into_iter()
        .find(inside)
        .unwrap_or_else(|| old.iter().map(|&(from, r)| (from, r * f)).collect())
}

/// Scales a schedule to a new mean without a clamp (a value the person or
/// the clinician put in force), each segment rounded to `step` (at least one
/// step).
pub fn rescale_schedule(old: &[(u32, f64)], mean: f64, step: Option<f64>) -> Segments {
    let m = mean_rate(old);
    let f = if m > 0.0 { mean / m } else { 1.0 };
    old.iter()
        .map(|&(from, r)| {
            let v = r * f;
            let v = match step {
                Some(s) => multiple(((v / s).round() as i64).max(1), s),
                None => v,
            };
            (from, v)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_change_below_one_step_is_no_change() {
        assert_eq!(round_change(0.9, 0.898, 0.05, 0.05, None), 0.9);
        // 0.95 would leave the 5 % clamp (0.945): the clamp wins, no change.
        assert_eq!(round_change(0.9, 0.93, 0.05, 0.05, None), 0.9);
        assert_eq!(round_change(1.0, 1.04, 0.05, 0.05, None), 1.05);
        assert_eq!(round_change(10.0, 9.966, 0.1, 0.05, None), 10.0);
        assert_eq!(round_change(10.0, 9.94, 0.1, 0.05, None), 9.9);
        // Off the step, the nearest multiple on the asked side.
        assert_eq!(round_change(0.898, 0.92, 0.05, 0.05, None), 0.9);
    }

    #[test]
    fn a_value_in_force_outside_the_bounds_moves_into_them() {
        // 1.2 in force, bounds 0.5-1.0 (set later), held at 1.0: past the
        // clamp, onto the bound, not "no change".
        assert_eq!(round_change(1.2, 1.0, 0.05, 0.05, Some((0.5, 1.0))), 1.0);
        assert_eq!(round_change(1.2, 0.91, 0.05, 0.05, Some((0.5, 0.91))), 0.9);
        assert_eq!(round_change(0.4, 0.5, 0.1, 0.05, Some((0.55, 2.0))), 0.6);
        // No multiple between the bounds: the bound itself.
        assert_eq!(
            round_change(1.2, 0.92, 0.05, 0.05, Some((0.91, 0.93))),
            0.92
        );
        let s = vec![(0, 1.0), (360, 1.4), (1200, 1.1)];
        let n = scale_schedule(&s, 0.9, 0.05, 0.05, Some((0.8, 0.9)));
        let m = mean_rate(&n);
        assert!((0.8..=0.9).contains(&m), "{n:?}: {m}");
        assert!(n.iter().all(|&(_, r)| on_step(r, 0.05)), "{n:?}");
    }

    #[test]
    fn a_schedule_is_scaled_by_one_factor_and_each_segment_rounded() {
        let s = vec![(0, 0.8), (180, 1.0), (420, 1.2), (720, 0.9), (1080, 1.1)];
        let up = scale_schedule(&s, mean_rate(&s) * 1.05, 0.05, 0.05, None);
        for ((_, a), (_, b)) in s.iter().zip(&up) {
            assert!(on_step(*b, 0.05), "{b}");
            assert!(*b >= *a && *b <= a * 1.05 + 1e-9, "{a} -> {b}");
        }
        assert!(up.iter().zip(&s).any(|(n, o)| n.1 > o.1));
        assert_eq!(mean_rate(&[(0, 1.0)]), 1.0);
        assert!(validate_segments(&[(60, 1.0)]).is_err());
        assert!(validate_segments(&[(0, 1.0), (0, 2.0)]).is_err());
    }

    #[test]
    fn only_the_pumps_steps_are_accepted() {
        assert!(PumpSteps::default().validate().is_ok());
        let bad = PumpSteps {
            basal_u_per_h: 0.03,
            ..PumpSteps::default()
        };
        assert!(bad.validate().is_err());
    }

    proptest! {
        /// After rounding every suggestion is a multiple of the step, on
        /// the asked side of the value in force, within the 5 % clamp and
        /// the clinician's bounds.
        #[test]
        fn rounding_stays_in_the_clamp_the_bounds_and_the_step(
            k_old in 1i64..2000,
            rel in -0.05f64..0.05,
            step_i in 0usize..3,
            lo_rel in 0.8f64..1.0,
            hi_rel in 1.0f64..1.2,
        ) {
            let step = BASAL_STEPS[step_i];
            let old = multiple(k_old, step);
            let requested = old * (1.0 + rel);
            let bounds = (old * lo_rel, old * hi_rel);
            let v = round_change(old, requested, step, 0.05, Some(bounds));
            prop_assert!(on_step(v, step), "{v} not on {step}");
            prop_assert!(v >= old * 0.95 - 1e-9 && v <= old * 1.05 + 1e-9);
            prop_assert!(v >= bounds.0.min(old) - 1e-9 && v <= bounds.1.max(old) + 1e-9);
            prop_assert!((v - old) * (requested - old) >= 0.0, "{old} -> {requested} gave {v}");
            prop_assert!((v - old).abs() <= (requested - old).abs() + step / 2.0 + 1e-9);
        }

        #[test]
        fn a_scaled_schedule_stays_in_each_segments_clamp(
            rates in proptest::collection::vec(1i64..200, 1..8),
            rel in -0.05f64..0.05,
        ) {
            let step = 0.05;
            let s: Segments = rates.iter().enumerate().map(|(i, &k)| (i as u32 * 180, multiple(k, step))).collect();
            let new = scale_schedule(&s, mean_rate(&s) * (1.0 + rel), step, 0.05, None);
            for ((_, a), (_, b)) in s.iter().zip(&new) {
                prop_assert!(on_step(*b, step));
                prop_assert!(*b >= a * 0.95 - 1e-9 && *b <= a * 1.05 + 1e-9);
            }
        }
    }
}
