//! S6's slow sensitivity drift: S1's days with each day's factor times
//! 1 + 0.3 · sin(2π (d − 9) / 42 + φ) from D9 on, φ one draw per patient;
//! the same seed gives the same drift, the first eight days are S1's, and
//! bad drift knobs are errors that name the field.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::scenario::{ScenarioConfig, ScenarioGenerator, ScenarioId, SensitivityDrift};

#[test]
fn s6_is_s1_times_a_slow_drift_of_plus_minus_30_percent() {
    let d = SensitivityDrift::default();
    assert_eq!((d.amplitude, d.period_days, d.from_day), (0.3, 42, 9));
    let mut phases = Vec::new();
    for patient in 1..=40u64 {
        let s1 = ScenarioGenerator::paper(ScenarioId::S1, 7, patient).unwrap();
        let s6 = ScenarioGenerator::paper(ScenarioId::S6, 7, patient).unwrap();
        let again = ScenarioGenerator::paper(ScenarioId::S6, 7, patient).unwrap();
        let ratios: Vec<f64> = (0..98)
            .map(|day| {
                let (a, b) = (s1.sensitivity_day(day), s6.sensitivity_day(day));
                assert_eq!(a.dawn, b.dawn, "patient {patient} day {day}: dawn changed");
                assert_eq!(b, again.sensitivity_day(day), "not deterministic");
                b.daily_factor / a.daily_factor
            })
            .collect();
        // D1-D8 (indices 0-7) are S1's.
        assert!(ratios[..8].iter().all(|r| *r == 1.0), "{ratios:?}");
        // From D9 the ratio is the sine: within ±30 %, back after 42 days.
        for r in &ratios[8..] {
            assert!((0.7 - 1e-12..=1.3 + 1e-12).contains(r), "{r}");
        }
        assert!((ratios[8] - ratios[8 + 42]).abs() < 1e-9);
        // The phase: r(D9) = 1 + 0.3 sin φ.
        phases.push(((ratios[8] - 1.0) / 0.3).clamp(-1.0, 1.0));
        // A slow drift: at most 2π · 0.3 / 42 a day.
        for w in ratios[8..].windows(2) {
            assert!((w[1] - w[0]).abs() <= 0.3 * std::f64::consts::TAU / 42.0 + 1e-12);
        }
        // The whole swing is reached over a cycle.
        let (lo, hi) = ratios[8..50]
            .iter()
            .fold((f64::MAX, f64::MIN), |(l, h), r| (l.min(*r), h.max(*r)));
        assert!(lo < 0.71 && hi > 1.29, "{lo} {hi}");
    }
    // The phase differs between patients.
    let spread = phases.iter().fold(f64::MIN, |m, p| m.max(*p))
        - phases.iter().fold(f64::MAX, |m, p| m.min(*p));
    assert!(spread > 1.0, "phases {phases:?}");
    // The paper's scenarios have no drift.
    for id in ScenarioId::ALL {
        assert!(ScenarioConfig::paper(id).sensitivity.drift.is_none());
    }
}

#[test]
fn bad_drift_knobs_name_the_field() {
    for (drift, field) in [
        (
            SensitivityDrift {
                amplitude: 1.0,
                ..SensitivityDrift::default()
            },
            "sensitivity.drift.amplitude",
        ),
        (
            SensitivityDrift {
                amplitude: f64::NAN,
                ..SensitivityDrift::default()
            },
            "sensitivity.drift.amplitude",
        ),
        (
            SensitivityDrift {
                period_days: 0,
                ..SensitivityDrift::default()
            },
            "sensitivity.drift.period_days",
        ),
        (
            SensitivityDrift {
                from_day: 0,
                ..SensitivityDrift::default()
            },
            "sensitivity.drift.from_day",
        ),
    ] {
        let mut c = ScenarioConfig::paper(ScenarioId::S6);
        c.sensitivity.drift = Some(drift);
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains(field) && e.contains("'S6'"), "{e}");
    }
}
