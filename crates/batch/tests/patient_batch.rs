//! A `PatientBatch` against the same patients stepped one by one.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_batch::PatientBatch;
use abba_sim::inputs::{hard_days, InputDay, MinuteRates};
use abba_sim::patient::{Patient, PatientParams, QuestRow, Solver};

/// Every public patient on every built-in hard day (150 patient-days, an
/// odd number, so a partial group of lanes is exercised too), with
/// insulin sensitivity varying across patients and minutes: the plasma
/// glucose of the batch stays within 1e-9 mg/dL of one-by-one stepping at
/// every minute, and every other state within 1e-9 relative.
#[test]
fn batch_matches_one_by_one() {
    let mut params = Vec::new();
    let mut days: Vec<InputDay> = Vec::new();
    for p in PatientParams::all_public().unwrap() {
        let cr = QuestRow::for_patient(&p.name).unwrap().cr;
        for name in hard_days::NAMES {
            days.push(hard_days::build(name, &p, cr).unwrap());
            params.push(p.clone());
        }
    }
    params.pop();
    days.pop();
    let n = params.len();
    assert_eq!(n % 2, 1);
    let sensitivity =
        |k: usize, minute: usize| 0.7 + 0.6 * (((k * 7 + minute / 60) % 11) as f64 / 10.0);
    let mut singles: Vec<Patient> = params
        .iter()
        .map(|p| Patient::new(p.clone()).unwrap())
        .collect();
    let mut batch = PatientBatch::new(singles.clone()).unwrap();
    let minutes = days.iter().map(|d| d.minutes.len()).min().unwrap();
    let mut worst_g: f64 = 0.0;
    let mut worst_rel: f64 = 0.0;
    for m in 0..minutes {
        let rates: Vec<MinuteRates> = days.iter().map(|d| d.minutes[m]).collect();
        let s: Vec<f64> = (0..n).map(|k| sensitivity(k, m)).collect();
        batch.step(&rates, &s).unwrap();
        for (k, p) in singles.iter_mut().enumerate() {
            p.step(rates[k].cho_g_per_min, rates[k].insulin_u_per_min, s[k])
                .unwrap();
            assert_eq!(batch.minute(k), p.minute());
            worst_g = worst_g.max((batch.glucose_mg_dl(k) - p.glucose_mg_dl()).abs());
            for (x, y) in batch.state_array(k).iter().zip(p.state_array()) {
                worst_rel = worst_rel.max((x - y).abs() / y.abs().max(1.0));
            }
        }
    }
    println!(
        "largest |G_batch - G_single| = {worst_g:e} mg/dL, largest state difference {worst_rel:e}"
    );
    assert!(worst_g <= 1e-9, "glucose differs by {worst_g:e} mg/dL");
    assert!(
        worst_rel <= 1e-9,
        "a state differs by {worst_rel:e} (relative)"
    );
}

#[test]
fn batch_rejects_mixed_solvers_and_wrong_input_lengths() {
    let p = PatientParams::public("adult#001").unwrap();
    let a = Patient::new(p.clone()).unwrap();
    let b = Patient::with_solver(p, Solver::fixed(2)).unwrap();
    assert!(PatientBatch::new(vec![a.clone(), b]).is_err());
    let mut batch = PatientBatch::new(vec![a.clone(), a]).unwrap();
    assert!(batch.step(&[MinuteRates::default()], &[1.0, 1.0]).is_err());
}

#[test]
fn batch_reports_bad_input_of_one_patient() {
    let p = PatientParams::public("adult#001").unwrap();
    let a = Patient::new(p).unwrap();
    let mut batch = PatientBatch::new(vec![a; 9]).unwrap();
    let mut rates = vec![MinuteRates::default(); 9];
    rates[3].insulin_u_per_min = -1.0;
    let err = batch.step(&rates, &[1.0; 9]).unwrap_err().to_string();
    assert!(err.contains("insulin"), "{err}");
}
