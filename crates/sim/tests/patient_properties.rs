//! Physiology properties of the patient model over all 30 public patients.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::inputs::{hard_days, InputDay, PlannedMeal};
use abba_sim::patient::{Patient, PatientParams, QuestRow, Solver};
use proptest::prelude::*;

fn public() -> Vec<PatientParams> {
    PatientParams::all_public().unwrap()
}

#[test]
fn every_public_patient_stays_at_basal_glucose_for_24h_without_food() {
    for p in public() {
        let gb = p.gb;
        let basal = p.basal_u_per_min();
        let mut patient = Patient::new(p.clone()).unwrap();
        let mut worst: f64 = 0.0;
        for _ in 0..1440 {
            patient.step(0.0, basal, 1.0).unwrap();
            worst = worst.max((patient.glucose_mg_dl() - gb).abs());
        }
        println!("{}: drift {worst:.2e} mg/dL", p.name);
        assert!(
            worst < 0.1,
            "{}: drift {worst} mg/dL (expected < 0.1)",
            p.name
        );
    }
}

#[test]
fn every_hard_day_runs_finite_for_every_patient() {
    for p in public() {
        let cr = QuestRow::for_patient(&p.name).unwrap().cr;
        for name in hard_days::NAMES {
            let day = hard_days::build(name, &p, cr).unwrap();
            let bg = day
                .simulate(&mut Patient::new(p.clone()).unwrap(), 1.0)
                .unwrap();
            assert!(bg.iter().all(|g| g.is_finite()), "{} {name}", p.name);
        }
    }
}

#[test]
fn default_solver_stays_close_to_the_reference_solver_on_hard_days() {
    // The default solver's own error against RK4 at h = 1/64 min; together
    // with simglucose's ~2e-4 mg/dL this bounds the gap to simglucose.
    for p in public() {
        let cr = QuestRow::for_patient(&p.name).unwrap().cr;
        for name in hard_days::NAMES {
            let day = hard_days::build(name, &p, cr).unwrap();
            let fine = day
                .simulate(
                    &mut Patient::with_solver(p.clone(), Solver::REFERENCE).unwrap(),
                    1.0,
                )
                .unwrap();
            let ours = day
                .simulate(&mut Patient::new(p.clone()).unwrap(), 1.0)
                .unwrap();
            let err = fine
                .iter()
                .zip(&ours)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                err < 0.01,
                "{} {name}: default vs reference {err} mg/dL",
                p.name
            );
        }
    }
}

fn day_with(p: &PatientParams, grams: f64, bolus: f64, extra_basal: f64) -> InputDay {
    InputDay::from_plan(
        600,
        p.basal_u_per_min() + extra_basal,
        &[PlannedMeal {
            minute: 60,
            grams,
            bolus_u: bolus,
        }],
        |_| false,
    )
}

fn run(p: &PatientParams, day: &InputDay, s: f64) -> Vec<f64> {
    day.simulate(&mut Patient::new(p.clone()).unwrap(), s)
        .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn more_insulin_never_gives_higher_glucose(
        who in 0usize..30, grams in 0.0f64..120.0, bolus in 0.0f64..10.0,
        more in 0.01f64..5.0, extra in 0.0f64..0.02, s in 0.5f64..1.5,
    ) {
        let p = &public()[who];
        let less = run(p, &day_with(p, grams, bolus, extra), s);
        let more_insulin = run(p, &day_with(p, grams, bolus + more, extra), s);
        // Compared while both runs are above 10 mg/dL (simglucose ends a run
        // there): below it the model's sign guards freeze Gp near zero and
        // the comparison no longer means anything physiological.
        let alive = less.iter().zip(&more_insulin).take_while(|(a, b)| **a > 10.0 && **b > 10.0);
        for (m, (a, b)) in alive.enumerate() {
            prop_assert!(*b <= *a + 1e-9, "{} minute {m}: {a} with less insulin, {b} with more", p.name);
        }
    }

    #[test]
    fn a_meal_raises_glucose(who in 0usize..30, grams in 5.0f64..120.0) {
        let p = &public()[who];
        let fasting = run(p, &day_with(p, 0.0, 0.0, 0.0), 1.0);
        let fed = run(p, &day_with(p, grams, 0.0, 0.0), 1.0);
        for (m, (a, b)) in fasting.iter().zip(&fed).enumerate() {
            prop_assert!(*b >= *a - 1e-9, "{} minute {m}: fed {b} < fasting {a}", p.name);
        }
        let peak_rise = fed.iter().zip(&fasting).map(|(b, a)| b - a).fold(0.0, f64::max);
        prop_assert!(peak_rise > 0.5 * grams / 10.0, "{}: {grams} g raised glucose by only {peak_rise}", p.name);
    }

    #[test]
    fn lower_insulin_sensitivity_never_gives_lower_glucose(who in 0usize..30, s in 0.5f64..0.99) {
        let p = &public()[who];
        let day = day_with(p, 50.0, 3.0, 0.0);
        let nominal = run(p, &day, 1.0);
        let resistant = run(p, &day, s);
        for (a, b) in nominal.iter().zip(&resistant) {
            prop_assert!(*b >= *a - 1e-9);
        }
    }
}

#[test]
fn bad_inputs_are_rejected_with_the_minute() {
    let mut p = Patient::new(PatientParams::public("adult#002").unwrap()).unwrap();
    p.step(0.0, 0.01, 1.0).unwrap();
    let e = p.step(-1.0, 0.01, 1.0).unwrap_err().to_string();
    assert!(e.contains("minute 1") && e.contains("carbohydrate"), "{e}");
    let e = p.step(0.0, f64::NAN, 1.0).unwrap_err().to_string();
    assert!(e.contains("insulin"), "{e}");
    let e = p.step(0.0, 0.01, 0.0).unwrap_err().to_string();
    assert!(e.contains("sensitivity"), "{e}");
}

/// Runs of one patient that eat the same share the gut's kempt values
/// through a `GutTape`: every run's state stays bit-identical to stepping
/// it alone, with different insulin per run, different sensitivities, and
/// a run whose meals differ (it never matches the tape and computes its own).
#[test]
fn gut_tape_sharing_is_bit_identical_to_stepping_alone() {
    use abba_sim::patient::GutTape;
    for p in public() {
        let day = InputDay::standard(&p, 10.0);
        let insulin_scale = [1.0, 0.7, 1.4];
        let mut alone: Vec<Patient> = (0..4).map(|_| Patient::new(p.clone()).unwrap()).collect();
        let mut shared = alone.clone();
        let mut tape = GutTape::new();
        for (m, r) in day.minutes.iter().enumerate() {
            let s = 1.0 + 0.2 * (m as f64 / 300.0).sin();
            for k in 0..4 {
                // Run 3 eats 10 % less: its gut state differs.
                let cho = if k == 3 {
                    0.9 * r.cho_g_per_min
                } else {
                    r.cho_g_per_min
                };
                let ins = r.insulin_u_per_min * insulin_scale[k % 3];
                alone[k].step_split(cho, ins, s, 1.0 / s).unwrap();
                shared[k]
                    .step_split_shared(cho, ins, s, 1.0 / s, &mut tape)
                    .unwrap();
                assert_eq!(
                    alone[k].state_array().map(f64::to_bits),
                    shared[k].state_array().map(f64::to_bits),
                    "{} run {k} minute {m}",
                    p.name
                );
            }
        }
        // Runs 1 and 2 replayed run 0's minutes; run 3's differ from
        // minute 420 on, when it eats less, and run 0 can then not replay them.
        assert!(tape.replays() >= 2 * 1440, "{}: {}", p.name, tape.replays());
    }
}

/// Runs stepped two at a time (`Patient::step_split_shared_side`, the
/// bodies side by side in one vector) stay bit-identical to each run
/// stepped alone: pairs that eat the same (the first records the gut, the
/// second pair replays it), a pair whose second run eats less (each goes
/// alone), and a pair of two different patients (different constants).
#[test]
fn pair_stepping_is_bit_identical_to_stepping_alone() {
    use abba_sim::patient::{GutTape, Pair, SplitInput};
    let all = public();
    for (i, p) in all.iter().enumerate() {
        let other = all[(i + 1) % all.len()].clone();
        let day = InputDay::standard(p, 10.0);
        let scale = [1.0, 0.7, 1.4, 1.1, 0.9, 1.2];
        let mut alone: Vec<Patient> = (0..6)
            .map(|k| Patient::new(if k == 5 { other.clone() } else { p.clone() }).unwrap())
            .collect();
        let mut paired = alone.clone();
        let mut tape = GutTape::new();
        for (m, r) in day.minutes.iter().enumerate() {
            let s = 1.0 + 0.2 * (m as f64 / 300.0).sin();
            let input = |k: usize| SplitInput {
                // Run 3 eats 10 % less: its gut differs from run 2's.
                cho_g_per_min: if k == 3 { 0.9 } else { 1.0 } * r.cho_g_per_min,
                insulin_u_per_min: r.insulin_u_per_min * scale[k],
                sensitivity: s,
                egp_sensitivity: 1.0 / s,
            };
            for (k, run) in alone.iter_mut().enumerate() {
                let i = input(k);
                run.step_split(
                    i.cho_g_per_min,
                    i.insulin_u_per_min,
                    i.sensitivity,
                    i.egp_sensitivity,
                )
                .unwrap();
            }
            for (j, pair) in paired.chunks_exact_mut(2).enumerate() {
                let [a, b] = pair else { unreachable!() };
                Patient::step_split_shared_side::<Pair, 2>(
                    [a, b],
                    [input(2 * j), input(2 * j + 1)],
                    &mut tape,
                )
                .unwrap();
            }
            for (k, (a, b)) in alone.iter().zip(&paired).enumerate() {
                assert_eq!(
                    a.state_array().map(f64::to_bits),
                    b.state_array().map(f64::to_bits),
                    "{} run {k} minute {m}",
                    p.name
                );
            }
        }
        // The second run of the first pair replays every minute.
        assert!(tape.replays() >= 1440, "{}: {}", p.name, tape.replays());
    }
}

/// A pair whose second run's input is refused: the error names it, the
/// first run has taken its minute as it would have alone, and the second
/// has not moved.
#[test]
fn pair_stepping_with_a_refused_input_steps_the_runs_before_it() {
    use abba_sim::patient::{GutTape, Pair, SplitInput};
    let p = PatientParams::public("adult#001").unwrap();
    let start = Patient::new(p).unwrap();
    let good = SplitInput {
        cho_g_per_min: 5.0,
        insulin_u_per_min: 0.02,
        sensitivity: 1.0,
        egp_sensitivity: 1.0,
    };
    let bad = SplitInput {
        insulin_u_per_min: -1.0,
        ..good
    };
    let mut alone = start.clone();
    alone.step_split(5.0, 0.02, 1.0, 1.0).unwrap();
    let (mut a, mut b) = (start.clone(), start.clone());
    let mut tape = GutTape::new();
    let e = Patient::step_split_shared_side::<Pair, 2>([&mut a, &mut b], [good, bad], &mut tape)
        .unwrap_err()
        .to_string();
    assert!(e.contains("insulin rate"), "{e}");
    assert_eq!(
        a.state_array().map(f64::to_bits),
        alone.state_array().map(f64::to_bits)
    );
    assert_eq!(a.minute(), 1);
    assert_eq!(b.minute(), 0);
    assert_eq!(b.state_array(), start.state_array());
}

/// Two runs whose stomachs are equal (both empty before the first meal) but
/// whose Qgut is not: the tape replays the gut's whole minute (Qgut at each
/// stage and at the end), so its key must hold Qgut too, or the second run
/// would take the first's. Each run stays bit-identical to stepping alone.
#[test]
fn gut_tape_tells_runs_with_different_qgut_apart() {
    use abba_sim::patient::GutTape;
    let p = PatientParams::public("adult#001").unwrap();
    let mut other = p.clone();
    other.x0[2] = 5000.0;
    let day = InputDay::standard(&p, 10.0);
    let mut alone = [
        Patient::new(p.clone()).unwrap(),
        Patient::new(other).unwrap(),
    ];
    let mut shared = alone.clone();
    let mut tape = GutTape::new();
    for (m, r) in day.minutes.iter().enumerate() {
        for k in 0..2 {
            alone[k]
                .step_split(r.cho_g_per_min, r.insulin_u_per_min, 1.0, 1.0)
                .unwrap();
            shared[k]
                .step_split_shared(r.cho_g_per_min, r.insulin_u_per_min, 1.0, 1.0, &mut tape)
                .unwrap();
            assert_eq!(
                alone[k].state_array().map(f64::to_bits),
                shared[k].state_array().map(f64::to_bits),
                "run {k} minute {m}"
            );
        }
    }
}
