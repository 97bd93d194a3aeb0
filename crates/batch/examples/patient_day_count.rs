//! Runs the criterion bench's patient-day (adult#001, the standard day,
//! default solver) `N` times (first argument, default 100), one patient at
//! a time, (second argument `batch`) as a `PatientBatch` of `N` patients,
//! or (`arms`) as N/3 groups of three runs eating the same with different
//! insulin that share the gut's work (`GutTape`, as the trial's arms), and
//! prints the mean final glucose: a fixed workload for instruction
//! counts, e.g.
//! `valgrind --tool=callgrind target/release/examples/patient_day_count 20`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_batch::PatientBatch;
use abba_sim::inputs::InputDay;
use abba_sim::patient::{GutTape, Patient, PatientParams};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args().nth(1).map_or(Ok(100), |s| s.parse())?;
    let mode = std::env::args().nth(2).unwrap_or_default();
    let batch = mode == "batch";
    let params = PatientParams::public("adult#001")?;
    let day = InputDay::standard(&params, 10.0);
    let start = Patient::new(params)?;
    let mut g = 0.0;
    if mode == "arms" {
        // The trial's shape: three runs of the patient eating the same
        // with different insulin (×1, ×0.9, ×1.1), sharing the gut's work.
        let scale = [1.0, 0.9, 1.1];
        for _ in 0..n / 3 {
            let mut runs = vec![start.clone(); 3];
            let mut tape = GutTape::new();
            for r in &day.minutes {
                let inputs: Vec<_> = scale
                    .iter()
                    .map(|s| (r.cho_g_per_min, r.insulin_u_per_min * s, 1.0, 1.0))
                    .collect();
                for (p, i) in runs.iter_mut().zip(&inputs) {
                    p.step_split_shared(i.0, i.1, i.2, i.3, &mut tape)?;
                }
            }
            g += runs.iter().map(|p| p.glucose_mg_dl()).sum::<f64>();
        }
        println!(
            "{n} patient-days ({mode}), mean final G = {} mg/dL",
            g / (n / 3 * 3) as f64
        );
        return Ok(());
    }
    if batch {
        let mut b = PatientBatch::new(vec![start; n])?;
        let s = vec![1.0; n];
        let mut rates = vec![Default::default(); n];
        for r in &day.minutes {
            rates.fill(*r);
            b.step(&rates, &s)?;
        }
        g = (0..b.len()).map(|i| b.glucose_mg_dl(i)).sum();
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
