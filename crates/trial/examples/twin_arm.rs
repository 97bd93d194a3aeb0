//! The ABBA arm with the twin check against the plain ABBA arm, paired
//! (same persons, same days): per patient, what the check did and time in
//! range / below 70 mg/dL of the last whole week simulated.
//!
//! `cargo run --release -p abba-trial --example twin_arm -- --patients 6 --days 35`
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use abba_sim::scenario::ScenarioId;
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::twin_arm::{run_patient, TwinArmOptions};
use abba_trial::TrialConfig;

fn arg(name: &str, default: u32) -> u32 {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map_or(default, |v| v.parse().expect("a number"))
}

fn main() {
    let (patients, days) = (arg("--patients", 6), arg("--days", 35));
    let config = TrialConfig::try_from(RawTrialConfig {
        patients,
        days,
        calibrate_te_ref: false,
        scenarios: vec![ScenarioId::S1],
        arms: vec![ArmKind::Abba],
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let sc = config.planned_scenario(ScenarioId::S1).unwrap();
    println!("patient,week,fits,usable_fits,checked,held_back,unchecked,abba_tir,twin_tir,abba_below70,twin_below70");
    for (i, vp) in cohort.patients.iter().enumerate() {
        let no = i as u64 + 1;
        let plain =
            run_patient_with(&config, vp, no, sc, ArmKind::Abba, &mut Trace::default()).unwrap();
        let (checked, s) = run_patient(&config, vp, no, sc, TwinArmOptions::default()).unwrap();
        let (a, b) = (plain.weeks.last().unwrap(), checked.weeks.last().unwrap());
        println!(
            "{},{},{},{},{},{},{},{:.2},{:.2},{:.2},{:.2}",
            vp.params.name,
            a.week.name(),
            s.fits,
            s.usable_fits,
            s.checked,
            s.held_back,
            s.unchecked,
            a.metrics.tir_70_180,
            b.metrics.tir_70_180,
            a.metrics.below_70,
            b.metrics.below_70
        );
    }
}
