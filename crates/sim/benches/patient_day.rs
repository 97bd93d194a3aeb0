//! One simulated patient-day: adult#001 on the paper's standard day (four
//! meals, three bolused), minute by minute, with the default solver and
//! with the alternatives; and three runs of one patient sharing the gut's
//! work as the trial's arms do. (Many patients stepped together:
//! `cargo bench -p abba-batch --bench batch_day`.)
//! `cargo bench -p abba-sim --bench patient_day`.

#![allow(clippy::expect_used, missing_docs)]

use abba_sim::inputs::InputDay;
use abba_sim::patient::{GutTape, Patient, PatientParams, Solver};
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
}

criterion_group!(benches, patient_day);
criterion_main!(benches);
