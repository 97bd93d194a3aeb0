//! One simulated patient-day: adult#001 on the paper's standard day (four
//! meals, three bolused), minute by minute, with the default solver and
//! with the alternatives. `cargo bench -p abba-sim --bench patient_day`.

#![allow(clippy::expect_used, missing_docs)]

use abba_sim::inputs::InputDay;
use abba_sim::patient::{Patient, PatientParams, Solver};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

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
}

criterion_group!(benches, patient_day);
criterion_main!(benches);
