//! Plausibility limits of therapy settings: the one home of the ranges that
//! every entry point (the CLI's `person new` and `answer --set`, the
//! service's create-person body, profile imports, the clinician's bounds)
//! checks a value against before it reaches the store or the advisor.
//!
//! The ranges follow LoopKit's therapy-setting guardrails (carb ratio
//! 1-150 g/U; ISF 10-500 mg/dL/U) and what pumps can deliver as a scheduled
//! basal rate (the smallest step of current pumps, 0.025 U/h, up to 35 U/h,
//! the largest rate any of them programs). A value outside is refused with
//! the limit named, never clamped.

use crate::error::CoreError;
use crate::therapy::TherapySettings;

/// The range a therapy value must lie in (both ends included).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limit {
    /// What the value is, with its unit ("basal rate (U/h)").
    pub what: &'static str,
    /// Smallest plausible value.
    pub min: f64,
    /// Largest plausible value.
    pub max: f64,
    /// The range in words, for error messages.
    pub expected: &'static str,
}

/// Scheduled basal rate in U/h.
pub const BASAL_U_PER_H: Limit = Limit {
    what: "basal rate (U/h)",
    min: 0.025,
    max: 35.0,
    expected: "between 0.025 and 35 U/h (the range pumps can program)",
};

/// Carbohydrate ratio in g/U.
pub const CARB_RATIO_G_PER_U: Limit = Limit {
    what: "carb ratio (g/U)",
    min: 1.0,
    max: 150.0,
    expected: "between 1 and 150 g/U (LoopKit's guardrails)",
};

/// Insulin sensitivity factor in mg/dL per U.
pub const ISF_MG_DL_PER_U: Limit = Limit {
    what: "insulin sensitivity (mg/dL/U)",
    min: 10.0,
    max: 500.0,
    expected: "between 10 and 500 mg/dL/U (LoopKit's guardrails)",
};

/// The range test of every crate's checks: `value` is a finite number in
/// `[lo, hi]`, both ends included (NaN and the infinities never are). The
/// checks built on it (here [`Limit::check`]; a configuration field, an
/// event's value, a file's field elsewhere) each say the failure in their
/// own error.
pub fn within(value: f64, lo: f64, hi: f64) -> bool {
    value.is_finite() && value >= lo && value <= hi
}

/// How far after the receiving clock (the server's, or the importing
/// machine's) a record may be dated and still be accepted: device clocks
/// drift by minutes. Anything later cannot be true yet and is refused.
pub const FUTURE_SKEW_MINUTES: i64 = 10;

impl Limit {
    /// Checks `value` against the limit: finite and within `[min, max]`.
    pub fn check(&self, value: f64) -> Result<f64, CoreError> {
        if within(value, self.min, self.max) {
            Ok(value)
        } else {
            Err(CoreError::OutOfRange {
                what: self.what,
                expected: self.expected,
                got: value,
            })
        }
    }

    /// Checks a range `[lo, hi]` (a clinician's bound): both ends within the
    /// limit and `lo <= hi`.
    pub fn check_range(&self, lo: f64, hi: f64) -> Result<(f64, f64), CoreError> {
        self.check(lo)?;
        self.check(hi)?;
        if lo <= hi {
            Ok((lo, hi))
        } else {
            Err(CoreError::OutOfRange {
                what: self.what,
                expected: "a range whose lower end is not above its upper end",
                got: lo,
            })
        }
    }
}

/// Checks every value of a therapy (flat basal and three carb ratios)
/// against the plausibility limits.
pub fn check_therapy(settings: &TherapySettings) -> Result<(), CoreError> {
    BASAL_U_PER_H.check(settings.basal.0)?;
    for cr in &settings.carb_ratio {
        CARB_RATIO_G_PER_U.check(cr.0)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GramsPerUnit, UnitsPerHour};

    #[test]
    fn within_is_finite_and_both_ends_included() {
        assert!(within(1.0, 1.0, 2.0));
        assert!(within(2.0, 1.0, 2.0));
        assert!(within(1.5, 1.0, 2.0));
        for out in [0.999, 2.001, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert!(!within(out, 1.0, 2.0), "{out}");
        }
        // Not even an infinite range holds an infinity.
        assert!(!within(f64::INFINITY, 0.0, f64::INFINITY));
        assert!(within(f64::MAX, 0.0, f64::INFINITY));
    }

    #[test]
    fn values_outside_the_limits_are_refused_with_the_limit_named() {
        for bad in [90.0, 0.0001, 0.0, -1.0, f64::NAN, f64::INFINITY, 1e300] {
            let e = BASAL_U_PER_H.check(bad).unwrap_err().to_string();
            assert!(e.contains("0.025") && e.contains("35"), "{e}");
        }
        assert_eq!(BASAL_U_PER_H.check(0.025), Ok(0.025));
        assert_eq!(BASAL_U_PER_H.check(35.0), Ok(35.0));
        assert!(CARB_RATIO_G_PER_U.check(300.0).is_err());
        assert!(CARB_RATIO_G_PER_U.check(0.5).is_err());
        assert!(CARB_RATIO_G_PER_U.check(150.0).is_ok());
        assert!(CARB_RATIO_G_PER_U.check_range(12.0, 7.0).is_err());
        assert!(CARB_RATIO_G_PER_U.check_range(7.0, 15.0).is_ok());
    }

    #[test]
    fn a_therapy_is_checked_value_by_value() {
        let mut t = TherapySettings {
            basal: UnitsPerHour(0.9),
            carb_ratio: [GramsPerUnit(10.0), GramsPerUnit(12.0), GramsPerUnit(11.0)],
        };
        assert!(check_therapy(&t).is_ok());
        t.carb_ratio[2] = GramsPerUnit(300.0);
        let e = check_therapy(&t).unwrap_err().to_string();
        assert!(e.contains("carb ratio") && e.contains("300"), "{e}");
    }
}
