//! One simulated patient-day: adult#001 on the paper's standard day (four
//! meals, three bolused), minute by minute, with the default solver and
//! with the alternatives; and the same day for a `PatientBatch` of 64
//! patients (time per patient-day = time per iteration / 64); and three
//! runs of one patient sharing the gut's work as the trial's arms do.
//! `cargo bench -p abba-sim --bench patient_day`.

#![allow(clippy::expect_used, missing_docs)]

use abba_sim::inputs::InputDay;
use abba_sim::patient::{GutTape, Patient, PatientBatch, PatientParams, Solver};
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

    // A batch of the ten public adults, each on its own standard day,
    // 64 patients in all.
    const N: usize = 64;
    let adults: Vec<PatientParams> = (1..=10)
        .map(|i| PatientParams::public(&format!("adult#{i:03}")).expect("built-in patient"))
        .collect();
    let patients: Vec<Patient> = (0..N)
        .map(|k| Patient::new(adults[k % 10].clone()).expect("valid patient"))
        .collect();
    let days: Vec<InputDay> = (0..N)
        .map(|k| InputDay::standard(&adults[k % 10], 10.0))
        .collect();
    let start = PatientBatch::new(patients.clone()).expect("one solver");
    let sensitivity = vec![1.0; N];
    let mut group = c.benchmark_group("patient_day_64_adults");
    group.throughput(Throughput::Elements(N as u64));
    group.bench_function("one_by_one", |b| {
        b.iter(|| {
            let mut g = 0.0;
            for (p0, day) in patients.iter().zip(&days) {
                let mut p = p0.clone();
                for r in &day.minutes {
                    p.step(r.cho_g_per_min, r.insulin_u_per_min, 1.0)
                        .expect("finite");
                }
                g += p.glucose_mg_dl();
            }
            black_box(g)
        })
    });
    group.bench_function("batch", |b| {
        b.iter(|| {
            let mut batch = start.clone();
            let mut rates = vec![Default::default(); N];
            for m in 0..days[0].minutes.len() {
                for (r, day) in rates.iter_mut().zip(&days) {
                    *r = day.minutes[m];
                }
                batch.step(&rates, &sensitivity).expect("finite");
            }
            black_box(batch.glucose_mg_dl(0))
        })
    });
    group.finish();
}

criterion_group!(benches, patient_day);
criterion_main!(benches);
