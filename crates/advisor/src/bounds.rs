//! Clinician bounds: the range a person's clinician allows for the basal
//! rate and for each main meal's carb ratio. They are applied after the
//! 5 %-a-day clamp, so no suggestion ever leaves them, and a suggestion held
//! at a bound says so in its explanation ([`BoundHeld`]).

use crate::error::AdvisorError;
use crate::parameter::Parameter;
use serde::{Deserialize, Serialize};

/// An inclusive range `[min, max]` (U/h or g/U).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Range {
    /// Lowest value allowed.
    pub min: f64,
    /// Highest value allowed.
    pub max: f64,
}

impl Range {
    /// True when `v` lies in the range.
    pub fn contains(&self, v: f64) -> bool {
        v >= self.min && v <= self.max
    }
}

/// The clinician's bounds; `None` means no bound for that setting.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ClinicianBounds {
    /// Bounds of the basal rate (U/h).
    pub basal: Option<Range>,
    /// Bounds of the carb ratios of breakfast, lunch and dinner (g/U).
    pub carb_ratio: [Option<Range>; 3],
}

/// Which bound held a suggestion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// The lower bound.
    Lower,
    /// The upper bound.
    Upper,
}

/// A suggestion held at a clinician bound: what the advisor wanted and
/// where it was held.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BoundHeld {
    /// Which bound.
    pub side: Side,
    /// The bound's value (the suggestion).
    pub bound: f64,
    /// The value after the 5 % clamp, before the bound.
    pub requested: f64,
    /// The value in force lay outside the bounds (bounds set after it was
    /// put in force, or a pump profile outside them): the suggestion moved
    /// into them, by more than the 5 % a day if need be.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub from_outside: bool,
}

impl ClinicianBounds {
    /// The range of a parameter, if any.
    pub fn range(&self, p: Parameter) -> Option<Range> {
        match p {
            Parameter::Basal => self.basal,
            Parameter::CarbRatio(s) => s.main_index().and_then(|i| self.carb_ratio[i]),
        }
    }

    /// Checks every range: finite, positive, `min <= max`.
    pub fn validate(&self) -> Result<(), AdvisorError> {
        let all = std::iter::once(("basal rate bounds", self.basal)).chain(
            ["breakfast", "lunch", "dinner"]
                .into_iter()
                .zip(self.carb_ratio),
        );
        for (what, r) in all {
            if let Some(r) = r {
                if !(r.min.is_finite() && r.max.is_finite() && r.min > 0.0 && r.min <= r.max) {
                    return Err(AdvisorError::Config {
                        field: format!("clinician bounds ({what})"),
                        problem: format!(
                            "expected 0 < min <= max, both finite; got {}-{}",
                            r.min, r.max
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Checks that each range holds a value the pump can be set to (a
    /// multiple of its step): otherwise the bounds and the pump's steps
    /// cannot both hold a suggestion. The error names the setting, the
    /// range and the nearest values on the step.
    pub fn check_steps(&self, steps: crate::steps::PumpSteps) -> Result<(), AdvisorError> {
        for p in Parameter::MAIN {
            let Some(r) = self.range(p) else { continue };
            let step = match p {
                Parameter::Basal => steps.basal_u_per_h,
                Parameter::CarbRatio(_) => steps.carb_ratio_g_per_u,
            };
            if crate::steps::nearest_within(r.min, step, r.min, r.max).is_none() {
                let below = (r.min / step).floor() * step;
                return Err(AdvisorError::Config {
                    field: format!("clinician bounds ({p})"),
                    problem: format!(
                        "no value on the pump's step of {step} {} lies in {}-{}: widen them to \
                         hold one (for example {:.3} or {:.3})",
                        p.unit(),
                        r.min,
                        r.max,
                        below,
                        below + step
                    ),
                });
            }
        }
        Ok(())
    }

    /// Checks that each setting's value in force (`value`) lies inside its
    /// range: the error names the setting, the value and the range.
    pub fn check_in_force(&self, value: impl Fn(Parameter) -> f64) -> Result<(), AdvisorError> {
        for p in Parameter::MAIN {
            if let Some(r) = self.range(p) {
                let v = value(p);
                if !r.contains(v) {
                    return Err(AdvisorError::Config {
                        field: format!("clinician bounds ({p})"),
                        problem: format!(
                            "the value in force {v} {} lies outside {}-{}",
                            p.unit(),
                            r.min,
                            r.max
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Holds `v` inside the parameter's range; says which bound held it.
    pub fn hold(&self, p: Parameter, v: f64) -> (f64, Option<BoundHeld>) {
        match self.range(p) {
            Some(r) if v < r.min => (
                r.min,
                Some(BoundHeld {
                    side: Side::Lower,
                    bound: r.min,
                    requested: v,
                    from_outside: false,
                }),
            ),
            Some(r) if v > r.max => (
                r.max,
                Some(BoundHeld {
                    side: Side::Upper,
                    bound: r.max,
                    requested: v,
                    from_outside: false,
                }),
            ),
            _ => (v, None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_core::MealSlot;

    #[test]
    fn bounds_must_hold_a_value_on_the_pumps_step() {
        let steps = crate::steps::PumpSteps::default();
        let b = |basal: (f64, f64), lunch: (f64, f64)| ClinicianBounds {
            basal: Some(Range {
                min: basal.0,
                max: basal.1,
            }),
            carb_ratio: [
                None,
                Some(Range {
                    min: lunch.0,
                    max: lunch.1,
                }),
                None,
            ],
        };
        assert!(b((0.9, 0.9), (8.0, 8.0)).check_steps(steps).is_ok());
        assert!(b((0.91, 0.95), (8.05, 8.1)).check_steps(steps).is_ok());
        let e = b((0.91, 0.93), (8.0, 9.0))
            .check_steps(steps)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("clinician bounds (basal rate)")
                && e.contains("0.91-0.93")
                && e.contains("0.900 or 0.950"),
            "{e}"
        );
        let e = b((0.5, 1.0), (8.01, 8.09))
            .check_steps(steps)
            .unwrap_err()
            .to_string();
        assert!(e.contains("lunch") && e.contains("8.01-8.09"), "{e}");
    }

    #[test]
    fn holds_at_the_bound_and_says_which() {
        let b = ClinicianBounds {
            basal: Some(Range { min: 0.5, max: 1.0 }),
            carb_ratio: [
                None,
                Some(Range {
                    min: 8.0,
                    max: 12.0,
                }),
                None,
            ],
        };
        assert_eq!(b.hold(Parameter::Basal, 0.8), (0.8, None));
        let (v, h) = b.hold(Parameter::Basal, 1.04);
        assert_eq!(v, 1.0);
        assert_eq!(h.map(|h| h.side), Some(Side::Upper));
        let (v, h) = b.hold(Parameter::CarbRatio(MealSlot::Lunch), 7.9);
        assert_eq!((v, h.map(|h| h.side)), (8.0, Some(Side::Lower)));
        assert_eq!(
            b.hold(Parameter::CarbRatio(MealSlot::Dinner), 99.0),
            (99.0, None)
        );
        let bad = ClinicianBounds {
            basal: Some(Range { min: 2.0, max: 1.0 }),
            ..ClinicianBounds::default()
        };
        assert!(bad.validate().is_err());
    }
}
