//! Insulin pump: increments, rounding, delivery speed, caps, exact totals,
//! the device log, bad input.
//!
//! Run: `cargo test --release -p abba-sim --test integration devices_pump::`

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_core::{EventKind, Timestamp, Units, UnitsPerHour};
use abba_sim::devices::pump::{Pump, PumpConfig};
use abba_sim::SimError;

fn pump() -> Pump {
    Pump::new(PumpConfig::default(), Timestamp(0)).unwrap()
}

/// Per-minute deliveries until the pump has no bolus left (basal 0).
fn deliver_all(p: &mut Pump) -> Vec<f64> {
    let mut out = Vec::new();
    while p.bolus_in_progress() {
        out.push(p.insulin_for_minute());
    }
    out
}

#[test]
fn a_4_u_bolus_takes_three_minutes() {
    let mut p = pump();
    let o = p.request_bolus(Units(4.0)).unwrap();
    assert_eq!(
        (o.programmed, o.capped, o.rounded),
        (Units(4.0), false, false)
    );
    assert_eq!(p.insulin_for_minute(), 1.5);
    assert_eq!(p.insulin_for_minute(), 1.5);
    assert_eq!(p.insulin_for_minute(), 1.0);
    assert_eq!(p.insulin_for_minute(), 0.0);
    assert_eq!(p.totals().bolus, Units(4.0));
    assert_eq!(p.now(), Timestamp(4));
}

#[test]
fn every_multiple_of_the_step_is_kept_exactly() {
    // Decimal amounts such as 0.15 or 0.35 are not exact floats; the pump
    // must still see them as whole steps, never one step less.
    for k in 0..=600u32 {
        for amount in [
            f64::from(k) * 0.05,
            f64::from(k) / 20.0,
            format!("{:.2}", f64::from(k) * 0.05).parse().unwrap(),
        ] {
            let mut p = pump();
            let o = p.request_bolus(Units(amount)).unwrap();
            let expected = f64::from(k) / 20.0;
            assert_eq!(
                o.programmed.0, expected,
                "request {amount}: expected {expected}, got {}",
                o.programmed.0
            );
            assert!(!o.rounded && !o.capped, "request {amount}: {o:?}");
        }
    }
}

#[test]
fn boluses_round_down_to_0_05_u() {
    for (req, expected) in [
        (4.07, 4.05),
        (4.099, 4.05),
        (0.049, 0.0),
        (0.051, 0.05),
        (29.999, 29.95),
        (1.234, 1.2),
    ] {
        let mut p = pump();
        let o = p.request_bolus(Units(req)).unwrap();
        assert_eq!(
            o.programmed,
            Units(expected),
            "request {req}: expected {expected}, got {:?}",
            o.programmed
        );
        assert!(o.rounded && !o.capped, "request {req}: {o:?}");
        let delivered: f64 = deliver_all(&mut p).iter().sum();
        assert!(
            (delivered - expected).abs() < 1e-12,
            "request {req}: delivered {delivered}"
        );
        assert_eq!(p.totals().bolus, Units(expected));
    }
    // A bolus that rounds to nothing is not delivered and not logged.
    let mut p = pump();
    let _ = p.request_bolus(Units(0.04)).unwrap();
    assert!(!p.bolus_in_progress());
    assert!(p.events().is_empty());
}

#[test]
fn boluses_above_30_u_are_capped_and_reported() {
    let mut p = pump();
    let o = p.request_bolus(Units(45.0)).unwrap();
    assert_eq!(
        (o.requested, o.programmed, o.capped),
        (Units(45.0), Units(30.0), true)
    );
    let d = deliver_all(&mut p);
    assert_eq!(d.len(), 20, "30 U at 1.5 U/min takes 20 minutes");
    assert!(d.iter().all(|&u| u == 1.5));
    assert_eq!(p.totals().bolus, Units(30.0));
    // Exactly the maximum is not capped; a hair above is.
    let o = pump().request_bolus(Units(30.0)).unwrap();
    assert!(!o.capped && !o.rounded);
    let o = pump().request_bolus(Units(30.01)).unwrap();
    assert!(o.capped && o.programmed == Units(30.0), "{o:?}");
    // Cozmo from the table: 75 U maximum.
    let mut cozmo = Pump::new(PumpConfig::from_table("Cozmo").unwrap(), Timestamp(0)).unwrap();
    let o = cozmo.request_bolus(Units(80.0)).unwrap();
    assert_eq!((o.programmed, o.capped), (Units(75.0), true));
    assert_eq!(deliver_all(&mut cozmo).len(), 50);
}

#[test]
fn boluses_queue_behind_one_in_progress() {
    let mut p = pump();
    let _ = p.request_bolus(Units(2.0)).unwrap();
    assert_eq!(p.insulin_for_minute(), 1.5);
    let _ = p.request_bolus(Units(2.0)).unwrap();
    assert_eq!(p.pending_bolus(), Units(2.5));
    assert_eq!(deliver_all(&mut p), vec![1.5, 1.0]);
    assert_eq!(p.totals().bolus, Units(4.0));
}

#[test]
fn basal_is_set_to_the_nearest_0_05_u_per_h_ties_to_even() {
    for (req, expected, rounded) in [
        (0.85, 0.85, false),
        (0.87, 0.85, true),
        (0.88, 0.9, true),
        (0.125, 0.1, true), // 2.5 steps -> 2
        (0.175, 0.2, true), // 3.5 steps -> 4
        (1.025, 1.0, true), // 20.5 steps -> 20
        (1.075, 1.1, true), // 21.5 steps -> 22
        (0.02, 0.0, true),
        (0.0, 0.0, false),
    ] {
        let mut p = pump();
        let o = p.set_basal(UnitsPerHour(req)).unwrap();
        assert_eq!(
            o.set,
            UnitsPerHour(expected),
            "request {req}: expected {expected}, got {:?}",
            o.set
        );
        assert_eq!((o.rounded, o.capped), (rounded, false), "request {req}");
        assert_eq!(p.basal_rate(), UnitsPerHour(expected));
    }
    let o = pump().set_basal(UnitsPerHour(40.0)).unwrap();
    assert_eq!((o.set, o.capped), (UnitsPerHour(30.0), true));
    let mut cozmo = Pump::new(PumpConfig::from_table("Cozmo").unwrap(), Timestamp(0)).unwrap();
    let o = cozmo.set_basal(UnitsPerHour(40.0)).unwrap();
    assert_eq!((o.set, o.capped), (UnitsPerHour(35.0), true));
}

#[test]
fn totals_are_exact_over_a_long_run() {
    // 98 days at 0.85 U/h with a meal bolus three times a day.
    let mut p = pump();
    let _ = p.set_basal(UnitsPerHour(0.85)).unwrap();
    let mut programmed_steps: u64 = 0;
    let mut per_minute_sum = 0.0;
    let days = 98;
    for minute in 0..days * 1440 {
        if [7 * 60, 12 * 60, 19 * 60].contains(&(minute % 1440)) {
            let day = minute / 1440;
            let o = p
                .request_bolus(Units(3.0 + (day % 7) as f64 * 0.37))
                .unwrap();
            programmed_steps += (o.programmed.0 * 20.0).round() as u64;
        }
        per_minute_sum += p.insulin_for_minute();
    }
    let t = p.totals();
    // Basal: 17 steps of 0.05 U/h for 98 days = 0.85·24·98 U, as an exact ratio.
    assert_eq!(t.basal, Units((17 * 1440 * days) as f64 / 1200.0));
    assert_eq!(t.basal.0, 1999.2);
    assert_eq!(t.bolus, Units(programmed_steps as f64 / 20.0));
    let total = t.total().0;
    println!("total {total}, sum of per-minute rates {per_minute_sum}");
    assert!(
        (per_minute_sum - total).abs() < 1e-8,
        "per-minute sum {per_minute_sum} vs total {total}"
    );
}

#[test]
fn basal_delivery_per_minute_is_rate_over_60() {
    let mut p = pump();
    let _ = p.set_basal(UnitsPerHour(1.2)).unwrap();
    for _ in 0..60 {
        assert!((p.insulin_for_minute() - 0.02).abs() < 1e-15);
    }
    assert_eq!(p.totals().basal, Units(1.2));
    let _ = p.request_bolus(Units(1.0)).unwrap();
    assert!((p.insulin_for_minute() - 1.02).abs() < 1e-15);
}

#[test]
fn the_device_log_records_basal_changes_and_boluses() {
    let mut p = Pump::new(PumpConfig::default(), Timestamp(1000)).unwrap();
    let _ = p.set_basal(UnitsPerHour(0.87)).unwrap();
    for _ in 0..30 {
        p.insulin_for_minute();
    }
    let _ = p.request_bolus(Units(5.03)).unwrap();
    p.insulin_for_minute();
    let events: Vec<_> = p.drain_events().collect();
    assert_eq!(events.len(), 2);
    assert_eq!(events[0].at, Timestamp(1000));
    assert_eq!(events[0].kind, EventKind::BasalRate(UnitsPerHour(0.85)));
    assert_eq!(events[1].at, Timestamp(1030));
    assert_eq!(events[1].kind, EventKind::Bolus(Units(5.0)));
    assert!(p.events().is_empty());
}

#[test]
fn bad_requests_are_errors_and_change_nothing() {
    let mut p = pump();
    let _ = p.set_basal(UnitsPerHour(1.0)).unwrap();
    for bad in [-0.05, -1e-12, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let e = p.request_bolus(Units(bad));
        assert!(
            matches!(e, Err(SimError::DeviceInput { .. })),
            "bolus {bad}: {e:?}"
        );
        let e = p.set_basal(UnitsPerHour(bad));
        assert!(
            matches!(e, Err(SimError::DeviceInput { .. })),
            "basal {bad}: {e:?}"
        );
    }
    assert_eq!(p.basal_rate(), UnitsPerHour(1.0));
    assert!(!p.bolus_in_progress());
    assert_eq!(p.events().len(), 1);
}

#[test]
fn bad_configurations_are_clear_errors() {
    let cases: [(PumpConfig, &str); 5] = [
        (
            PumpConfig {
                bolus_increment_u: 0.03,
                ..PumpConfig::default()
            },
            "bolus_increment_u",
        ),
        (
            PumpConfig {
                basal_increment_u_per_h: 0.0,
                ..PumpConfig::default()
            },
            "basal_increment_u_per_h",
        ),
        (
            PumpConfig {
                max_bolus_u: 30.01,
                ..PumpConfig::default()
            },
            "max_bolus_u",
        ),
        (
            PumpConfig {
                max_basal_u_per_h: f64::NAN,
                ..PumpConfig::default()
            },
            "max_basal_u_per_h",
        ),
        (
            PumpConfig {
                bolus_speed_u_per_min: 0.0,
                ..PumpConfig::default()
            },
            "bolus_speed_u_per_min",
        ),
    ];
    for (cfg, field) in cases {
        let e = Pump::new(cfg, Timestamp(0)).unwrap_err().to_string();
        assert!(
            e.contains(field),
            "expected an error naming {field}, got: {e}"
        );
    }
    // Other real increments are fine: 0.025 U, 0.1 U/h.
    let cfg = PumpConfig {
        bolus_increment_u: 0.025,
        basal_increment_u_per_h: 0.1,
        ..PumpConfig::default()
    };
    let mut p = Pump::new(cfg, Timestamp(0)).unwrap();
    assert_eq!(
        p.request_bolus(Units(1.06)).unwrap().programmed,
        Units(1.05)
    );
    assert_eq!(
        p.set_basal(UnitsPerHour(0.86)).unwrap().set,
        UnitsPerHour(0.9)
    );
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A bolus is a whole number of 0.05 U steps, never more than asked,
        /// less by under one step (unless capped), capped exactly above 30 U,
        /// and delivered in full at 1.5 U/min at most.
        #[test]
        fn bolus_rounding_and_capping(req in 0.0f64..100.0) {
            let mut p = pump();
            let o = p.request_bolus(Units(req)).unwrap();
            let steps = o.programmed.0 * 20.0;
            prop_assert!((steps - steps.round()).abs() < 1e-9, "{o:?}");
            prop_assert_eq!(o.capped, req > 30.0);
            if o.capped {
                prop_assert_eq!(o.programmed, Units(30.0));
            } else {
                prop_assert!(o.programmed.0 <= req + 1e-12 && req - o.programmed.0 < 0.05, "{o:?}");
            }
            let d = deliver_all(&mut p);
            prop_assert!(d.iter().all(|&u| u <= 1.5));
            prop_assert_eq!(d.len() as f64, (o.programmed.0 / 1.5 - 1e-9).ceil().max(0.0));
            prop_assert_eq!(p.totals().bolus, o.programmed);
        }

        /// A basal rate is the nearest 0.05 U/h step (within half a step) or
        /// the 30 U/h cap.
        #[test]
        fn basal_rounding_and_capping(req in 0.0f64..40.0) {
            let mut p = pump();
            let o = p.set_basal(UnitsPerHour(req)).unwrap();
            let steps = o.set.0 * 20.0;
            prop_assert!((steps - steps.round()).abs() < 1e-9, "{o:?}");
            prop_assert_eq!(o.capped, req > 30.0);
            if o.capped {
                prop_assert_eq!(o.set, UnitsPerHour(30.0));
            } else {
                prop_assert!((o.set.0 - req).abs() <= 0.025 + 1e-12, "{o:?}");
            }
        }
    }
}
