//! The ten public adults, each on its own standard day, 64 patients in
//! all: one by one (`Patient::step`) and in one `PatientBatch` (time per
//! patient-day = time per iteration / 64).
//! `cargo bench -p abba-batch --bench batch_day`.

#![allow(clippy::expect_used, missing_docs)]

use abba_batch::PatientBatch;
use abba_sim::inputs::InputDay;
use abba_sim::patient::{Patient, PatientParams};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

fn batch_day(c: &mut Criterion) {
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

criterion_group!(benches, batch_day);
criterion_main!(benches);
