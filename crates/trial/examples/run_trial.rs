//! Runs a trial without writing the report and prints where the time went:
//! `cargo run --release -p abba-trial --example run_trial -- [patients] [days] [threads] [arms]`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_trial::protocol::RawTrialConfig;
use abba_trial::runner::{build_cohort, run_trial, Silent};
use abba_trial::TrialConfig;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |i: usize, d: u64| {
        std::env::args()
            .nth(i)
            .and_then(|s| s.parse().ok())
            .unwrap_or(d)
    };
    let arms = std::env::args()
        .nth(4)
        .map(|s| {
            s.split(',')
                .map(|a| a.parse().map_err(|e: String| e))
                .collect::<Result<Vec<_>, _>>()
        })
        .transpose()?
        .unwrap_or_else(|| abba_trial::ArmKind::DEFAULT.to_vec());
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: arg(1, 100) as u32,
        days: arg(2, 98) as u32,
        arms,
        ..RawTrialConfig::default()
    })?;
    let threads = arg(3, 0) as usize;
    let t = Instant::now();
    let cohort = build_cohort(&config)?;
    let cohort_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let out = run_trial(&config, threads, &Silent)?;
    let total_s = t.elapsed().as_secs_f64();
    let runs = out.arms.iter().map(|a| a.patients.len()).sum::<usize>();
    let patient_days = runs as f64 * f64::from(config.days);
    println!(
        "cohort of {} built in {cohort_s:.2} s; trial (cohort + TE calibration + {runs} patient-runs, {patient_days} patient-days) in {total_s:.2} s = {:.3} ms per patient-day (wall)",
        cohort.patients.len(),
        1e3 * total_s / patient_days
    );
    for arm in &out.arms {
        let w = |name: &str, f: &dyn Fn(&abba_core::metrics::GlucoseMetrics) -> f64| {
            let week: abba_trial::results::Week = name.parse().expect("a protocol week");
            let v: Vec<f64> = arm
                .patients
                .iter()
                .filter_map(|p| p.week(week))
                .map(|w| f(&w.metrics))
                .collect();
            v.iter().sum::<f64>() / v.len().max(1) as f64
        };
        println!(
            "{}/{:<8} TIR W1 {:5.1} W13 {:5.1} W14 {:5.1} | <70 W1 {:4.1} W13 {:4.1} W14 {:4.1} | >180 W1 {:4.1} W13 {:4.1} W14 {:4.1} | LBGI W1 {:4.2} W13 {:4.2} | HBGI W1 {:4.2} W13 {:4.2}",
            arm.scenario, arm.advisor,
            w("W1", &|m| m.tir_70_180), w("W13", &|m| m.tir_70_180), w("W14", &|m| m.tir_70_180),
            w("W1", &|m| m.below_70), w("W13", &|m| m.below_70), w("W14", &|m| m.below_70),
            w("W1", &|m| m.above_180), w("W13", &|m| m.above_180), w("W14", &|m| m.above_180),
            w("W1", &|m| m.lbgi), w("W13", &|m| m.lbgi),
            w("W1", &|m| m.hbgi), w("W13", &|m| m.hbgi),
        );
    }
    for arm in &out.arms {
        let failed: Vec<String> = arm
            .patients
            .iter()
            .filter_map(|p| p.failure.map(|f| format!("{} D{}", p.patient, f.day)))
            .collect();
        if !failed.is_empty() {
            println!(
                "{}/{}: {} failed runs: {}",
                arm.scenario,
                arm.advisor,
                failed.len(),
                failed.join(", ")
            );
        }
    }
    println!("TE reference (bits): {}", out.config.abba.te.te_ref_bits);
    Ok(())
}
