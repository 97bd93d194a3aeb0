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
    /// ABBA whose suggestions pass the twin check (a trial arm: the twin,
    /// fitted from the simulated person's device data, holds back a
    /// suggestion predicted to raise time below 70 mg/dL; abba-trial's
    /// `twin_arm`).
    #[serde(rename = "abba-twin")]
    AbbaTwin,
}

impl ArmKind {
    /// All arms, in report order.
    pub const ALL: [ArmKind; 5] = [
        ArmKind::Abba,
        ArmKind::Standard,
        ArmKind::R2r,
        ArmKind::Autotune,
        ArmKind::AbbaTwin,
    ];

    /// The arms that are an advisor of their own (every arm but
    /// `abba-twin`, which is ABBA with the twin check, needs a twin and so
    /// a simulator, and runs only in the trial).
    pub const ADVISORS: [ArmKind; 4] = [
        ArmKind::Abba,
        ArmKind::Standard,
        ArmKind::R2r,
        ArmKind::Autotune,
    ];

    /// The arms a trial runs unless told otherwise (the paper's three);
    /// autotune and abba-twin are opt-in (`--arms abba,standard,r2r,autotune`),
    /// so that the default trial's files stay what they were.
    pub const DEFAULT: [ArmKind; 3] = [ArmKind::Abba, ArmKind::Standard, ArmKind::R2r];

    /// `abba`, `standard`, `r2r`, `autotune`, `abba-twin`: the name used everywhere (reports, CLI,
    /// [`Advisor::name`](crate::Advisor::name)).
    pub fn name(self) -> &'static str {
        match self {
            ArmKind::Abba => "abba",
            ArmKind::Standard => "standard",
            ArmKind::R2r => "r2r",
            ArmKind::Autotune => "autotune",
            ArmKind::AbbaTwin => "abba-twin",
        }
    }

    /// The arm in a figure's legend: `ABBA`, `standard therapy`, ...
    pub fn label(self) -> &'static str {
        match self {
            ArmKind::Abba => "ABBA",
            ArmKind::Standard => "standard therapy",
            ArmKind::R2r => "run-to-run",
            ArmKind::Autotune => "autotune (oref0)",
            ArmKind::AbbaTwin => "ABBA with the twin check",
        }
    }

    /// The arm in a table's column header: `ABBA`, `standard`, ...
    pub fn short_label(self) -> &'static str {
        match self {
            ArmKind::Abba => "ABBA",
            ArmKind::Standard => "standard",
            ArmKind::R2r => "run-to-run",
            ArmKind::Autotune => "autotune",
            ArmKind::AbbaTwin => "ABBA+twin",
        }
    }

    /// The arm as a table's title, with the measurement mode it ran in.
    pub fn title(self, mode: crate::Mode) -> String {
        let mode = mode.name().to_uppercase();
        match self {
            ArmKind::Abba => format!("ABBA ({mode} mode)"),
            ArmKind::Standard => "standard therapy (settings never change)".to_string(),
            ArmKind::R2r => format!("run-to-run baseline ({mode} mode)"),
            ArmKind::Autotune => {
                "autotune (oref0), nightly over the previous day's CGM".to_string()
            }
            ArmKind::AbbaTwin => format!("ABBA ({mode} mode) with the twin check"),
        }
    }

    /// The trial configuration's section holding this arm's knobs.
    pub fn config_section(self) -> &'static str {
        match self {
            ArmKind::Abba => "abba",
            ArmKind::Standard => "fixed_limits",
            ArmKind::R2r => "r2r",
            ArmKind::Autotune => "autotune",
            ArmKind::AbbaTwin => "twin_check",
        }
    }

    /// The arm's colour in figures (Okabe-Ito, distinguishable by people
    /// with colour-vision deficiency), as RGB.
    pub fn colour_rgb(self) -> (u8, u8, u8) {
        match self {
            ArmKind::Abba => (0, 114, 178),
            ArmKind::Standard => (90, 90, 90),
            ArmKind::R2r => (213, 94, 0),
            ArmKind::Autotune => (0, 158, 115),
            ArmKind::AbbaTwin => (204, 121, 167),
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
            .ok_or_else(|| {
                format!("unknown arm '{s}' (expected abba, standard, r2r, autotune or abba-twin)")
            })
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

    #[test]
    fn every_arm_has_its_own_labels_and_colour() {
        for (i, a) in ArmKind::ALL.iter().enumerate() {
            for b in &ArmKind::ALL[i + 1..] {
                assert_ne!(a.label(), b.label());
                assert_ne!(a.short_label(), b.short_label());
                assert_ne!(a.colour_rgb(), b.colour_rgb());
                assert_ne!(a.config_section(), b.config_section());
            }
        }
    }
}
