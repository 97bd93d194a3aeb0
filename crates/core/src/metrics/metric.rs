//! The metric keys of the protocol (§8) as a type: every metric abba reports
//! is a [`Metric`] with its key, label, unit and which direction is better.
//! A key that is not one of them cannot be built: parsing it is an error
//! naming the keys that exist, and serde refuses it the same way.

/// One metric of a glucose series (or, for [`Metric::TdiUPerDay`], of the
/// insulin delivered over the same window).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Metric {
    /// % of readings in the target band 70 ≤ g ≤ 180 mg/dL.
    Tir70To180,
    /// % of readings with 50 ≤ g < 70 mg/dL (the seed's hypoglycaemia).
    Hypo50To70,
    /// % of readings with g < 50 mg/dL (the seed's severe hypoglycaemia).
    SevereHypoLt50,
    /// % of readings with 180 < g ≤ 300 mg/dL (the seed's hyperglycaemia).
    Hyper180To300,
    /// % of readings with g > 300 mg/dL (the seed's severe hyperglycaemia).
    SevereHyperGt300,
    /// Low blood glucose index (Kovatchev).
    Lbgi,
    /// High blood glucose index (Kovatchev).
    Hbgi,
    /// Mean amplitude of glycaemic excursions (mg/dL).
    Mage,
    /// Mean total insulin delivered per day (U/day); not a glucose metric.
    TdiUPerDay,
    /// Mean glucose (mg/dL).
    MeanMgDl,
    /// Coefficient of variation (%).
    CvPct,
    /// Glucose management indicator (%).
    GmiPct,
    /// % of readings with g < 54 mg/dL.
    Below54,
    /// % of readings with g < 70 mg/dL.
    Below70,
    /// % of readings with g > 180 mg/dL.
    Above180,
    /// % of readings with g > 250 mg/dL.
    Above250,
}

/// The unit a metric is expressed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MetricUnit {
    /// Percent of readings (or, for CV and GMI, percent).
    Percent,
    /// mg/dL.
    MgDl,
    /// Insulin units per day.
    UnitsPerDay,
    /// A dimensionless index (LBGI, HBGI).
    Index,
}

impl MetricUnit {
    /// The unit as printed (`%`, `mg/dL`, `U/day`; empty for an index).
    pub fn symbol(self) -> &'static str {
        match self {
            MetricUnit::Percent => "%",
            MetricUnit::MgDl => "mg/dL",
            MetricUnit::UnitsPerDay => "U/day",
            MetricUnit::Index => "",
        }
    }
}

/// Which way a metric should move for a better outcome.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// More is better (time in range).
    HigherIsBetter,
    /// Less is better (time below or above range, risk indices, variability).
    LowerIsBetter,
    /// Neither side is better in itself (insulin dose, mean glucose: both
    /// are judged against a target, not minimised or maximised).
    Neither,
}

/// key, long label, short label (axes, narrow panels), unit, direction.
type Facts = (
    &'static str,
    &'static str,
    &'static str,
    MetricUnit,
    Direction,
);

impl Metric {
    /// The 16 metrics in the protocol's order (§8): the glucose metrics with
    /// `tdi_u_per_day` after `mage`.
    pub const ALL: [Metric; 16] = [
        Metric::Tir70To180,
        Metric::Hypo50To70,
        Metric::SevereHypoLt50,
        Metric::Hyper180To300,
        Metric::SevereHyperGt300,
        Metric::Lbgi,
        Metric::Hbgi,
        Metric::Mage,
        Metric::TdiUPerDay,
        Metric::MeanMgDl,
        Metric::CvPct,
        Metric::GmiPct,
        Metric::Below54,
        Metric::Below70,
        Metric::Above180,
        Metric::Above250,
    ];

    /// The 15 metrics of a glucose series ([`Self::ALL`] without
    /// `tdi_u_per_day`), in the protocol's order.
    pub const GLUCOSE: [Metric; 15] = {
        let a = Metric::ALL;
        [
            a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[9], a[10], a[11], a[12], a[13],
            a[14], a[15],
        ]
    };

    /// The seed paper's five glucose bands (its Table I), in its column order.
    pub const SEED_BANDS: [Metric; 5] = [
        Metric::Tir70To180,
        Metric::Hypo50To70,
        Metric::SevereHypoLt50,
        Metric::Hyper180To300,
        Metric::SevereHyperGt300,
    ];

    fn facts(self) -> Facts {
        use Direction::{HigherIsBetter as Up, LowerIsBetter as Down, Neither};
        use MetricUnit::{Index, MgDl, Percent, UnitsPerDay};
        match self {
            Metric::Tir70To180 => (
                "tir_70_180",
                "% time in target 70-180 mg/dL",
                "% time 70-180 mg/dL",
                Percent,
                Up,
            ),
            Metric::Hypo50To70 => (
                "hypo_50_70",
                "% time in hypo 50-<70 mg/dL",
                "% time 50-<70 mg/dL",
                Percent,
                Down,
            ),
            Metric::SevereHypoLt50 => (
                "severe_hypo_lt50",
                "% time in severe hypo <50 mg/dL",
                "% time < 50 mg/dL",
                Percent,
                Down,
            ),
            Metric::Hyper180To300 => (
                "hyper_180_300",
                "% time in hyper >180-300 mg/dL",
                "% time >180-300 mg/dL",
                Percent,
                Down,
            ),
            Metric::SevereHyperGt300 => (
                "severe_hyper_gt300",
                "% time in severe hyper >300 mg/dL",
                "% time > 300 mg/dL",
                Percent,
                Down,
            ),
            Metric::Lbgi => ("lbgi", "LBGI", "LBGI", Index, Down),
            Metric::Hbgi => ("hbgi", "HBGI", "HBGI", Index, Down),
            Metric::Mage => ("mage", "MAGE (mg/dL)", "MAGE (mg/dL)", MgDl, Down),
            Metric::TdiUPerDay => (
                "tdi_u_per_day",
                "TDI (U/day)",
                "TDI (U/day)",
                UnitsPerDay,
                Neither,
            ),
            Metric::MeanMgDl => (
                "mean_mg_dl",
                "mean glucose (mg/dL)",
                "mean glucose (mg/dL)",
                MgDl,
                Neither,
            ),
            Metric::CvPct => ("cv_pct", "CV (%)", "CV (%)", Percent, Down),
            Metric::GmiPct => ("gmi_pct", "GMI (%)", "GMI (%)", Percent, Down),
            Metric::Below54 => (
                "below_54",
                "% time <54 mg/dL",
                "% time < 54 mg/dL",
                Percent,
                Down,
            ),
            Metric::Below70 => (
                "below_70",
                "% time <70 mg/dL",
                "% time < 70 mg/dL",
                Percent,
                Down,
            ),
            Metric::Above180 => (
                "above_180",
                "% time >180 mg/dL",
                "% time > 180 mg/dL",
                Percent,
                Down,
            ),
            Metric::Above250 => (
                "above_250",
                "% time >250 mg/dL",
                "% time > 250 mg/dL",
                Percent,
                Down,
            ),
        }
    }

    /// The protocol's key (`tir_70_180`, ...): the JSON field and CSV column name.
    pub fn key(self) -> &'static str {
        self.facts().0
    }

    /// A human label with its unit, for tables (`% time in target 70-180 mg/dL`).
    pub fn label(self) -> &'static str {
        self.facts().1
    }

    /// A shorter label with its unit, for figure axes and narrow panels
    /// (`% time 70-180 mg/dL`).
    pub fn short_label(self) -> &'static str {
        self.facts().2
    }

    /// The unit of its values.
    pub fn unit(self) -> MetricUnit {
        self.facts().3
    }

    /// Which way is better.
    pub fn direction(self) -> Direction {
        self.facts().4
    }

    /// Whether it is one of the seed paper's five glucose bands.
    pub fn is_seed_band(self) -> bool {
        Metric::SEED_BANDS.contains(&self)
    }
}

crate::named!(Metric, "metric", Metric::key, parse_and_serde);

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn every_key_parses_back_to_its_metric() {
        for m in Metric::ALL {
            assert_eq!(m.key().parse::<Metric>().unwrap(), m);
            let json = serde_json::to_string(&m).unwrap();
            assert_eq!(json, format!("\"{}\"", m.key()));
            assert_eq!(serde_json::from_str::<Metric>(&json).unwrap(), m);
            assert!(!m.label().is_empty() && !m.short_label().is_empty());
        }
        let mut keys: Vec<&str> = Metric::ALL.iter().map(|m| m.key()).collect();
        keys.sort_unstable();
        keys.dedup();
        assert_eq!(keys.len(), 16, "keys are distinct");
    }

    #[test]
    fn an_unknown_key_cannot_be_parsed() {
        for bad in ["tir", "TIR_70_180", "unknown metric", "", "tdi"] {
            let e = bad.parse::<Metric>().unwrap_err().to_string();
            assert!(
                e.contains(&format!("'{bad}'")) && e.contains("tir_70_180"),
                "{e}"
            );
            let json = format!("\"{bad}\"");
            let e = serde_json::from_str::<Metric>(&json)
                .unwrap_err()
                .to_string();
            assert!(e.contains("unknown metric"), "{e}");
        }
    }

    #[test]
    fn the_error_lists_exactly_the_keys_that_exist() {
        let e = "x".parse::<Metric>().unwrap_err().to_string();
        for m in Metric::ALL {
            assert!(e.contains(m.key()), "{} missing from {e}", m.key());
        }
    }

    #[test]
    fn glucose_metrics_are_all_but_tdi_in_order() {
        let without: Vec<Metric> = Metric::ALL
            .into_iter()
            .filter(|m| *m != Metric::TdiUPerDay)
            .collect();
        assert_eq!(without, Metric::GLUCOSE.to_vec());
        assert!(Metric::SEED_BANDS
            .iter()
            .all(|m| m.unit() == MetricUnit::Percent));
        assert_eq!(Metric::Tir70To180.direction(), Direction::HigherIsBetter);
        assert_eq!(Metric::Below70.direction(), Direction::LowerIsBetter);
    }
}
