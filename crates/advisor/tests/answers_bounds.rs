//! The person's answers and the clinician's bounds: the next update starts
//! from the value in force (accepted, rejected or overridden), and no
//! suggestion leaves the bounds, a held one saying so (proptest).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::bounds::{ClinicianBounds, Range, Side};
use abba_advisor::{Abba, AbbaConfig, Advisor, Decision, DecisionDetail, Mode, Parameter};
use abba_core::{Event, EventKind, GramsPerUnit, MealSlot, SettingValue, UnitsPerHour};
use common::{start, Toy, NEUTRAL};
use proptest::prelude::*;

fn abba(mode: Mode) -> Abba {
    Abba::new(AbbaConfig::new(mode, 7), start()).unwrap()
}

/// Replays `events`, answering the first update of `p` that moved with `answer(old, new)`
/// right after it; returns the next update of `p`.
fn next_update_after_answer(
    mode: Mode,
    events: &[Event],
    p: Parameter,
    answer: impl Fn(f64, f64) -> EventKind,
) -> (Decision, Decision) {
    let mut a = abba(mode);
    let mut first: Option<Decision> = None;
    for e in events {
        a.observe(e).unwrap();
        for d in a.take_decisions() {
            if d.parameter != p || matches!(d.detail, DecisionDetail::Skipped { .. }) {
                continue;
            }
            match &first {
                // Answer a basal update that moved (carb ratios are often held by
                // the switch rule; their override below moves them anyway).
                None if d.old == d.new && p == Parameter::Basal => {}
                None => {
                    a.observe(&Event::new(e.at, answer(d.old, d.new))).unwrap();
                    first = Some(d);
                }
                Some(f) => return (f.clone(), d),
            }
        }
    }
    panic!("fewer than two updates of {p}");
}

fn value(p: Parameter, v: f64) -> SettingValue {
    match p {
        Parameter::Basal => SettingValue::Basal {
            rate: UnitsPerHour(v),
        },
        Parameter::CarbRatio(slot) => SettingValue::CarbRatio {
            slot,
            ratio: GramsPerUnit(v),
        },
    }
}

#[test]
fn the_next_update_starts_from_the_value_in_force() {
    for mode in [Mode::Cgm, Mode::Smbg] {
        // One setting off at a time (the switch rule holds a carb ratio
        // while the basal rate moves the other way).
        let basal_off = Toy {
            basal_need: 1.4,
            ..NEUTRAL
        };
        let ratio_off = Toy {
            cr_need: [7.0, 7.0, 7.0],
            ..NEUTRAL
        };
        for (toy, p) in [
            (basal_off, Parameter::Basal),
            (ratio_off, Parameter::CarbRatio(MealSlot::Lunch)),
        ] {
            let events = toy.run(&mut abba(mode), mode, 1, 28, 7);
            let (f, next) = next_update_after_answer(mode, &events, p, |_, new| {
                EventKind::SuggestionAccepted(value(p, new))
            });
            if p == Parameter::Basal {
                assert_ne!(f.old, f.new, "{mode:?} {p}: the first update moved");
            }
            assert_eq!(next.old, f.new, "{mode:?} {p}: accepted");
            let (f, next) = next_update_after_answer(mode, &events, p, |old, _| {
                EventKind::SuggestionRejected(value(p, old))
            });
            assert_eq!(
                next.old, f.old,
                "{mode:?} {p}: rejected keeps the previous value"
            );
            let own = f.old * 0.9;
            let (_, next) = next_update_after_answer(mode, &events, p, |_, _| {
                EventKind::SuggestionOverridden(value(p, own))
            });
            assert_eq!(next.old, own, "{mode:?} {p}: overridden");
            assert!((next.new / own - 1.0).abs() <= 0.05 + 1e-12);
        }
    }
}

#[test]
fn a_non_main_meal_answer_is_rejected() {
    let mut a = abba(Mode::Cgm);
    let e = Event::new(
        common::t(1, 0),
        EventKind::SuggestionOverridden(SettingValue::CarbRatio {
            slot: MealSlot::Snack,
            ratio: GramsPerUnit(10.0),
        }),
    );
    assert!(a.observe(&e).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn suggestions_stay_in_the_clinician_bounds(
        basal_need in 0.4f64..2.5,
        cr_need in 5.0f64..20.0,
        smbg in any::<bool>(),
        lo in 0.90f64..1.0,
        hi in 1.0f64..1.10,
        cr_lo in 0.90f64..1.0,
        cr_hi in 1.0f64..1.10,
    ) {
        let mode = if smbg { Mode::Smbg } else { Mode::Cgm };
        let s = start();
        let bounds = ClinicianBounds {
            basal: Some(Range { min: s.basal.0 * lo, max: s.basal.0 * hi }),
            carb_ratio: [Some(Range { min: s.carb_ratio[0].0 * cr_lo, max: s.carb_ratio[0].0 * cr_hi }); 3],
        };
        let mut a = abba(mode).with_bounds(bounds).unwrap();
        let toy = Toy { basal_need, cr_need: [cr_need; 3], ..NEUTRAL };
        toy.run(&mut a, mode, 1, 16, 7);
        let d = a.take_decisions();
        prop_assert!(d.len() > 10);
        for d in d {
            let r = bounds.range(d.parameter).unwrap();
            prop_assert!(r.contains(d.new), "{}", d);
            prop_assert!((d.new / d.old - 1.0).abs() <= 0.05 + 1e-12, "{}", d);
            if let DecisionDetail::Abba(x) = &d.detail {
                match x.bound {
                    Some(b) => {
                        prop_assert_eq!(d.new, b.bound);
                        match b.side {
                            Side::Lower => prop_assert!(b.requested < r.min),
                            Side::Upper => prop_assert!(b.requested > r.max),
                        }
                        prop_assert!(d.to_string().contains("held at the clinician's"));
                    }
                    None => prop_assert!(r.contains(x.applied.new)),
                }
            }
        }
    }
}

#[test]
fn bounds_must_contain_the_value_in_force() {
    let b = ClinicianBounds {
        basal: Some(Range { min: 1.5, max: 2.0 }),
        ..ClinicianBounds::default()
    };
    let e = abba(Mode::Cgm).with_bounds(b).unwrap_err();
    assert!(e.to_string().contains("outside"), "{e}");
}

#[test]
fn a_value_in_force_outside_later_bounds_moves_into_them() {
    // Bounds set after the therapy in force (1 U/h, 10 g/U) exclude it:
    // the first update moves each setting into them, past the 5 % a day,
    // on the pump's step, and says so; no update stays outside.
    let bounds = ClinicianBounds {
        basal: Some(Range {
            min: 0.61,
            max: 0.83,
        }),
        carb_ratio: [Some(Range {
            min: 11.03,
            max: 12.0,
        }); 3],
    };
    assert!(abba(Mode::Cgm).with_bounds(bounds).is_err());
    for steps in [None, Some(abba_advisor::PumpSteps::default())] {
        let mut a = abba(Mode::Cgm).with_later_bounds(bounds).unwrap();
        if let Some(s) = steps {
            a = a.with_pump_steps(s).unwrap();
        }
        NEUTRAL.run(&mut a, Mode::Cgm, 1, 12, 7);
        let moved: Vec<Decision> = a
            .take_decisions()
            .into_iter()
            .filter(|d| !matches!(d.detail, DecisionDetail::Skipped { .. }))
            .collect();
        assert!(moved.len() > 8, "{moved:?}");
        for p in Parameter::MAIN {
            let first = moved.iter().find(|d| d.parameter == p).unwrap();
            let r = bounds.range(p).unwrap();
            assert!(!r.contains(first.old), "{first}");
            assert!(r.contains(first.new), "{steps:?}: {first}");
            if steps.is_some() {
                let step = if p == Parameter::Basal { 0.05 } else { 0.1 };
                assert!(abba_advisor::steps::on_step(first.new, step), "{first}");
            }
            let words = abba_advisor::words::reasons(first, &AbbaConfig::new(Mode::Cgm, 7));
            let text = words.join(" ");
            assert!(
                text.contains("lies outside your clinician's bounds"),
                "{text}"
            );
            assert!(!text.contains("no change"), "{text}");
        }
        for d in &moved {
            assert!(bounds.range(d.parameter).unwrap().contains(d.new), "{d}");
        }
    }
}
