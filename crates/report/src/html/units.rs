//! The glucose unit a reader chooses for a page: mg/dL or mmol/L. Values
//! are kept in mg/dL everywhere and converted only when printed.

use abba_core::units::MG_DL_PER_MMOL_L;
use serde::{Deserialize, Serialize};

/// mg/dL or mmol/L.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum GlucoseUnit {
    /// Milligrams per decilitre (whole numbers).
    #[default]
    #[serde(rename = "mg/dL")]
    MgDl,
    /// Millimoles per litre (one decimal).
    #[serde(rename = "mmol/L")]
    MmolL,
}

impl GlucoseUnit {
    /// `mg/dL` or `mmol/L`.
    pub fn label(self) -> &'static str {
        match self {
            GlucoseUnit::MgDl => "mg/dL",
            GlucoseUnit::MmolL => "mmol/L",
        }
    }

    /// A glucose value given in mg/dL, in this unit, as printed (whole
    /// mg/dL, mmol/L with one decimal).
    pub fn value(self, mg_dl: f64) -> String {
        match self {
            GlucoseUnit::MgDl => format!("{mg_dl:.0}"),
            GlucoseUnit::MmolL => format!("{:.1}", mg_dl / MG_DL_PER_MMOL_L),
        }
    }

    /// Like [`GlucoseUnit::value`] with the unit after it.
    pub fn with_unit(self, mg_dl: f64) -> String {
        format!("{} {}", self.value(mg_dl), self.label())
    }

    /// An axis tick (mmol/L ticks are whole numbers).
    pub fn tick(self, mg_dl: f64) -> String {
        match self {
            GlucoseUnit::MgDl => format!("{mg_dl:.0}"),
            GlucoseUnit::MmolL => format!("{:.0}", mg_dl / MG_DL_PER_MMOL_L),
        }
    }

    /// A value in this unit, converted to mg/dL.
    pub fn to_mg_dl(self, v: f64) -> f64 {
        match self {
            GlucoseUnit::MgDl => v,
            GlucoseUnit::MmolL => v * MG_DL_PER_MMOL_L,
        }
    }
}

impl std::str::FromStr for GlucoseUnit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "mg/dL" | "mg/dl" => Ok(GlucoseUnit::MgDl),
            "mmol/L" | "mmol/l" => Ok(GlucoseUnit::MmolL),
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
