//! Runs the criterion bench's patient-day (adult#001, the standard day,
//! default solver) `N` times (first argument, default 100), one patient at
//! a time or (second argument `batch`) as a `PatientBatch` of `N` patients,
//! and prints the mean final glucose: a fixed workload for instruction
//! counts, e.g.
//! `valgrind --tool=callgrind target/release/examples/patient_day_count 20`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::inputs::InputDay;
use abba_sim::patient::{Patient, PatientBatch, PatientParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let batch = std::env::args().nth(2).as_deref() == Some("batch");
    let params = PatientParams::public("adult#001")?;
    let day = InputDay::standard(&params, 10.0);
    let start = Patient::new(params)?;
    let mut g = 0.0;
    if batch {
        let mut b = PatientBatch::new(vec![start; n])?;
        let s = vec![1.0; n];
        let mut rates = vec![Default::default(); n];
        for r in &day.minutes {
            rates.fill(*r);
            b.step(&rates, &s)?;
        }
        g = b.patients().iter().map(|p| p.glucose_mg_dl()).sum();
    } else {
        for _ in 0..n {
            let mut p = start.clone();
            for r in &day.minutes {
                p.step(r.cho_g_per_min, r.insulin_u_per_min, 1.0)?;
            }
            g += p.glucose_mg_dl();
        }
    }
    println!("{n} patient-days, mean final G = {} mg/dL", g / n as f64);
    Ok(())
}
