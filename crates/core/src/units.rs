//! Unit newtypes used at public boundaries. Inside hot code plain `f64` is
//! used with the unit in the variable name; every conversion constant is
//! defined here, once.

use serde::{Deserialize, Serialize};

/// Picomoles of insulin in one international unit (U).
pub const PMOL_PER_UNIT: f64 = 6000.0;
/// Milligrams in one gram.
pub const MG_PER_G: f64 = 1000.0;
/// Minutes in one hour.
pub const MINUTES_PER_HOUR: f64 = 60.0;
/// mg/dL per mmol/L of glucose (molar mass 180.16 g/mol).
pub const MG_DL_PER_MMOL_L: f64 = 18.0156;

macro_rules! newtype {
    ($(#[$doc:meta])* $name:ident, $unit:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default, Serialize, Deserialize)]
        #[serde(transparent)]
        pub struct $name(pub f64);

        impl $name {
            /// The bare number.
            pub fn value(self) -> f64 {
                self.0
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{} {}", self.0, $unit)
            }
        }
    };
}

newtype!(
    /// A glucose concentration in mg/dL.
    MgDl, "mg/dL"
);
newtype!(
    /// A mass of carbohydrate in grams.
    Grams, "g"
);
newtype!(
    /// An amount of insulin in international units.
    Units, "U"
);
newtype!(
    /// An insulin rate in units per hour (a basal rate).
    UnitsPerHour, "U/h"
);
newtype!(
    /// A carbohydrate ratio: grams of carbohydrate covered by one unit of insulin.
    GramsPerUnit, "g/U"
);

impl UnitsPerHour {
    /// The same rate in U/min.
    pub fn per_minute(self) -> f64 {
        self.0 / MINUTES_PER_HOUR
    }
    /// Builds a rate from U/min.
    pub fn from_per_minute(u_per_min: f64) -> Self {
        Self(u_per_min * MINUTES_PER_HOUR)
    }
}

impl MgDl {
    /// Builds a glucose value from mmol/L.
    pub fn from_mmol_l(mmol_l: f64) -> Self {
        Self(mmol_l * MG_DL_PER_MMOL_L)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basal_rate_converts_between_hours_and_minutes() {
        let r = UnitsPerHour(1.2);
        assert!((r.per_minute() - 0.02).abs() < 1e-15);
        assert!((UnitsPerHour::from_per_minute(0.02).0 - 1.2).abs() < 1e-12);
    }

    #[test]
    fn mmol_converts_to_mg_dl() {
        assert!((MgDl::from_mmol_l(5.5).0 - 99.0858).abs() < 1e-9);
    }
}
