//! Properties of the glucose metrics that hold for any series.
#![allow(clippy::unwrap_used)]

use abba_core::metrics::{mage_regular, mage_timed, metrics_regular, MageOptions};
use proptest::prelude::*;

/// A plausible CGM day or two: a random walk in mg/dL, clamped to [40, 400].
fn series() -> impl Strategy<Value = Vec<f64>> {
    (
        60.0f64..250.0,
        prop::collection::vec(-12.0f64..12.0, 40..600),
    )
        .prop_map(|(start, steps)| {
            let mut g = start;
            steps
                .into_iter()
                .map(|s| {
                    g = (g + s).clamp(40.0, 400.0);
                    g.round()
                })
                .collect()
        })
}

proptest! {
    #[test]
    fn bands_partition_the_readings(g in series()) {
        let m = metrics_regular(&g).unwrap();
        let total = m.tir_70_180 + m.hypo_50_70 + m.severe_hypo_lt50 + m.hyper_180_300
            + m.severe_hyper_gt300;
        prop_assert!((total - 100.0).abs() < 1e-9, "seed bands sum to {}", total);
        let consensus = m.below_70 + m.tir_70_180 + m.above_180;
        prop_assert!((consensus - 100.0).abs() < 1e-9, "consensus bands sum to {}", consensus);
        prop_assert!(m.below_54 <= m.below_70 && m.above_250 <= m.above_180);
    }

    #[test]
    fn mage_is_bounded_and_avg_lies_between_directions(g in series()) {
        let mage = mage_regular(&g, &MageOptions::default()).unwrap();
        let range = g.iter().cloned().fold(f64::MIN, f64::max) - g.iter().cloned().fold(f64::MAX, f64::min);
        if let (Some(p), Some(m), Some(a)) = (mage.plus, mage.minus, mage.avg) {
            prop_assert!(a >= p.min(m) - 1e-9 && a <= p.max(m) + 1e-9);
        }
        for v in [mage.avg, mage.plus, mage.minus, mage.max, mage.service].into_iter().flatten() {
            prop_assert!(v > 0.0 && v <= range, "MAGE {} outside (0, {}]", v, range);
        }
    }

    #[test]
    fn doubling_glucose_doubles_mage_exactly(g in series()) {
        // Every step (sums, means, SD, comparisons) scales exactly by 2.
        let once = mage_regular(&g, &MageOptions::default()).unwrap();
        let doubled: Vec<f64> = g.iter().map(|x| 2.0 * x).collect();
        let twice = mage_regular(&doubled, &MageOptions::default()).unwrap();
        prop_assert_eq!(once.avg.map(|v| 2.0 * v), twice.avg);
        prop_assert_eq!(once.plus.map(|v| 2.0 * v), twice.plus);
        prop_assert_eq!(once.minus.map(|v| 2.0 * v), twice.minus);
    }

    #[test]
    fn timed_readings_on_the_grid_equal_the_regular_series(g in series(), day in 0i64..20000) {
        // Readings at midnight + 5, 10, ... min are exactly iglu's grid.
        let t: Vec<f64> = (1..=g.len()).map(|k| (day * 1440) as f64 + 5.0 * k as f64).collect();
        let timed = mage_timed(&t, &g, &MageOptions::default()).unwrap();
        let regular = mage_regular(&g, &MageOptions::default()).unwrap();
        prop_assert_eq!(timed, regular);
    }
}
