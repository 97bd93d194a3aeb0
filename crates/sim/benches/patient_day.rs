//! One simulated patient-day: adult#001 on the paper's standard day (four
//! meals, three bolused), minute by minute, with the default solver and
//! with the alternatives; and three runs of one patient sharing the gut's
//! work as the trial's arms do. (Many patients stepped together:
//! `cargo bench -p abba-batch --bench batch_day`.)
//! `cargo bench -p abba-sim --bench patient_day`.

#![allow(clippy::expect_used, missing_docs)]

use abba_sim::inputs::InputDay;
use abba_sim::patient::{GutTape, Pair, Patient, PatientParams, Solver, SplitInput};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

fn patient_day(c: &mut Criterion) {
    let params = PatientParams::public("adult#001").expect("built-in patient");
    let day = InputDay::standard(&params, 10.0);
    let mut group = c.benchmark_group("patient_day");
    for (label, solver) in [
        ("rk4_h1", Solver::fixed(1)),
        ("rk4_h1/2", Solver::fixed(2)),
        ("default_gut_adaptive", Solver::DEFAULT),
        ("rk4_h1/4", Solver::fixed(4)),
    ] {
        let start = Patient::with_solver(params.clone(), solver).expect("valid patient");
        group.bench_function(label, |b| {
            b.iter(|| {
                let mut p = start.clone();
                for r in &day.minutes {
                    p.step(r.cho_g_per_min, r.insulin_u_per_min, 1.0)
                        .expect("finite");
                }
                black_box(p.glucose_mg_dl())
            })
        });
    }
    group.finish();

    // The trial's shape: three runs of adult#001 on the standard day (the
    // three arms of one scenario), eating the same but with different
    // insulin (×1, ×0.9, ×1.1), stepped in lock-step and sharing the gut's
    // work through a `GutTape` (time per patient-day = time / 3).
    let start = Patient::new(params.clone()).expect("valid patient");
    let mut group = c.benchmark_group("patient_day_3_arms");
    group.throughput(Throughput::Elements(3));
    for (label, shared) in [("alone", false), ("gut_shared", true)] {
        group.bench_function(label, |b| {
            b.iter(|| {
                let mut runs = [start.clone(), start.clone(), start.clone()];
                let mut tape = GutTape::new();
                for r in &day.minutes {
                    for (p, scale) in runs.iter_mut().zip([1.0, 0.9, 1.1]) {
                        let ins = r.insulin_u_per_min * scale;
                        if shared {
                            p.step_split_shared(r.cho_g_per_min, ins, 1.0, 1.0, &mut tape)
                        } else {
                            p.step_split(r.cho_g_per_min, ins, 1.0, 1.0)
                        }
                        .expect("finite");
                    }
                }
                black_box(runs[2].glucose_mg_dl())
            })
        });
    }
    group.finish();

    // The trial's group: ten runs of adult#001 (its arms and scenarios)
    // eating the same with different insulin (×0.8 .. ×1.25), sharing the
    // gut, stepped one by one or two by two with their bodies side by side
    // (`Pair`), as the trial steps them (time per patient-day = time / 10).
    let mut group = c.benchmark_group("patient_day_10_runs");
    group.throughput(Throughput::Elements(10));
    let scale: [f64; 10] = std::array::from_fn(|k| 0.8 + 0.05 * k as f64);
    for (label, paired) in [("one_by_one", false), ("two_by_two", true)] {
        group.bench_function(label, |b| {
            b.iter(|| {
                let mut runs: Vec<Patient> = (0..10).map(|_| start.clone()).collect();
                let mut tape = GutTape::new();
                for r in &day.minutes {
                    let input = |k: usize| SplitInput {
                        cho_g_per_min: r.cho_g_per_min,
                        insulin_u_per_min: r.insulin_u_per_min * scale[k],
                        sensitivity: 1.0,
                        egp_sensitivity: 1.0,
                    };
                    if paired {
                        for (j, pair) in runs.chunks_exact_mut(2).enumerate() {
                            let [a, b] = pair else { unreachable!() };
                            Patient::step_split_shared_side::<Pair, 2>(
                                [a, b],
                                [input(2 * j), input(2 * j + 1)],
                                &mut tape,
                            )
                            .expect("finite");
                        }
                    } else {
                        for (k, p) in runs.iter_mut().enumerate() {
                            let i = input(k);
                            p.step_split_shared(
                                i.cho_g_per_min,
                                i.insulin_u_per_min,
                                1.0,
                                1.0,
                                &mut tape,
                            )
                            .expect("finite");
                        }
                    }
                }
                black_box(runs[9].glucose_mg_dl())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, patient_day);
criterion_main!(benches);
