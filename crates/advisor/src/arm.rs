//! Which advisor an arm of a trial (or a person's session) runs: the arm is
//! one typed thing and the measurement [`Mode`](crate::Mode) another.

use serde::{Deserialize, Serialize};

/// The advisors abba offers; the arms of every trial scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArmKind {
    /// ABBA (CGM mode in S1, SMBG mode in S2-S4).
    Abba,
    /// Standard therapy, never changed.
    Standard,
    /// Run-to-run basal and carb-ratio adaptation.
    R2r,
    /// OpenAPS oref0's autotune, nightly.
    Autotune,
}

impl ArmKind {
    /// All arms, in report order.
    pub const ALL: [ArmKind; 4] = [
        ArmKind::Abba,
        ArmKind::Standard,
        ArmKind::R2r,
        ArmKind::Autotune,
    ];

    /// The arms a trial runs unless told otherwise (the paper's three);
    /// autotune is opt-in (`--arms abba,standard,r2r,autotune`), so that the
    /// default trial's files stay what they were.
    pub const DEFAULT: [ArmKind; 3] = [ArmKind::Abba, ArmKind::Standard, ArmKind::R2r];

    /// `abba`, `standard`, `r2r`, `autotune`: the name used everywhere (reports, CLI,
    /// [`Advisor::name`](crate::Advisor::name)).
    pub fn name(self) -> &'static str {
        match self {
            ArmKind::Abba => "abba",
            ArmKind::Standard => "standard",
            ArmKind::R2r => "r2r",
            ArmKind::Autotune => "autotune",
        }
    }
}

impl std::fmt::Display for ArmKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for ArmKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        ArmKind::ALL
            .into_iter()
            .find(|a| a.name() == s)
            .ok_or_else(|| format!("unknown arm '{s}' (expected abba, standard, r2r or autotune)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back() {
        for a in ArmKind::ALL {
            assert_eq!(a.name().parse::<ArmKind>().unwrap(), a);
            assert_eq!(serde_json::to_string(&a).unwrap(), format!("\"{a}\""));
        }
        assert!("abba-cgm".parse::<ArmKind>().is_err());
    }
}
