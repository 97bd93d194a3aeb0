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

/// The glucose unit a file declares, a person reads or a page shows.
/// Values are kept in mg/dL everywhere and converted only when read or
/// printed (by [`MG_DL_PER_MMOL_L`]). The one home of this choice: the
/// readers, the store, the pages and the reports all use it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum GlucoseUnit {
    /// Milligrams per decilitre (printed as whole numbers).
    #[default]
    #[serde(rename = "mg/dL")]
    MgDl,
    /// Millimoles per litre (printed with one decimal).
    #[serde(rename = "mmol/L")]
    MmolL,
}

impl GlucoseUnit {
    /// Reads a unit name as files write it (`mg/dL`, `mg/dl`, `mgdl`,
    /// `mmol/L`, `mmol/l`, `mmol`; case and spaces ignored).
    pub fn parse(text: &str) -> Option<Self> {
        let t: String = text
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_ascii_lowercase();
        match t.as_str() {
            "mg/dl" | "mgdl" | "mg" => Some(Self::MgDl),
            "mmol/l" | "mmoll" | "mmol" => Some(Self::MmolL),
            _ => None,
        }
    }

    /// `mg/dL` or `mmol/L`.
    pub fn label(self) -> &'static str {
        match self {
            Self::MgDl => "mg/dL",
            Self::MmolL => "mmol/L",
        }
    }

    /// A value given in this unit, in mg/dL.
    pub fn to_mg_dl(self, value: f64) -> f64 {
        match self {
            Self::MgDl => value,
            Self::MmolL => value * MG_DL_PER_MMOL_L,
        }
    }

    /// A value given in mg/dL, in this unit.
    pub fn from_mg_dl(self, mg_dl: f64) -> f64 {
        match self {
            Self::MgDl => mg_dl,
            Self::MmolL => mg_dl / MG_DL_PER_MMOL_L,
        }
    }

    /// A glucose value given in mg/dL, in this unit, as printed (whole
    /// mg/dL, mmol/L with one decimal).
    pub fn value(self, mg_dl: f64) -> String {
        match self {
            Self::MgDl => format!("{mg_dl:.0}"),
            Self::MmolL => format!("{:.1}", mg_dl / MG_DL_PER_MMOL_L),
        }
    }

    /// Like [`GlucoseUnit::value`] with the unit after it.
    pub fn with_unit(self, mg_dl: f64) -> String {
        format!("{} {}", self.value(mg_dl), self.label())
    }

    /// A range given in mg/dL, in this unit: `70-180 mg/dL`,
    /// `3.9-10.0 mmol/L`.
    pub fn range(self, lo_mg_dl: f64, hi_mg_dl: f64) -> String {
        format!(
            "{}-{} {}",
            self.value(lo_mg_dl),
            self.value(hi_mg_dl),
            self.label()
        )
    }

    /// An axis tick (mmol/L ticks are whole numbers).
    pub fn tick(self, mg_dl: f64) -> String {
        match self {
            Self::MgDl => format!("{mg_dl:.0}"),
            Self::MmolL => format!("{:.0}", mg_dl / MG_DL_PER_MMOL_L),
        }
    }
}

impl std::str::FromStr for GlucoseUnit {
    type Err = String;
    /// Strict: `mg/dL` or `mmol/L` (either case of the last letter), as
    /// command lines and settings give it.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "mg/dL" | "mg/dl" => Ok(Self::MgDl),
            "mmol/L" | "mmol/l" => Ok(Self::MmolL),
            other => Err(format!(
                "unknown glucose unit '{other}': expected mg/dL or mmol/L"
            )),
        }
    }
}

impl std::fmt::Display for GlucoseUnit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.label())
    }
}

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

    #[test]
    fn glucose_units_read_convert_and_print() {
        for t in ["mg/dL", "mg/dl", " MG / DL ", "mgdl", "mg"] {
            assert_eq!(GlucoseUnit::parse(t), Some(GlucoseUnit::MgDl), "{t}");
        }
        for t in ["mmol/L", "mmol/l", "MMOL", "mmol / L"] {
            assert_eq!(GlucoseUnit::parse(t), Some(GlucoseUnit::MmolL), "{t}");
        }
        assert_eq!(GlucoseUnit::parse("mmol/mol"), None);
        assert!("mgdl".parse::<GlucoseUnit>().is_err());
        assert_eq!("mmol/L".parse::<GlucoseUnit>(), Ok(GlucoseUnit::MmolL));
        let u = GlucoseUnit::MmolL;
        assert!((u.from_mg_dl(u.to_mg_dl(5.5)) - 5.5).abs() < 1e-12);
        assert_eq!(u.with_unit(99.0858), "5.5 mmol/L");
        assert_eq!(GlucoseUnit::MgDl.with_unit(99.4), "99 mg/dL");
        assert_eq!(u.tick(180.0), "10");
        assert_eq!(serde_json::to_string(&u).unwrap(), "\"mmol/L\"");
        assert_eq!(GlucoseUnit::default(), GlucoseUnit::MgDl);
    }
}
