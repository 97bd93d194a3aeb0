//! What `PatientBatch` keeps of each patient: every instruction set gives
//! the same bits, a patient taken out goes on alone, and a patient's
//! trajectory does not depend on its company. (Unit tests of the crate
//! once; here, so that the crate's heavy vector code is compiled once for
//! the tests, not a second time with `cfg(test)`.)

use abba_batch::{Isa, PatientBatch};
use abba_sim::inputs::{hard_days, InputDay, MinuteRates};
use abba_sim::patient::{Patient, PatientParams, QuestRow};

/// Every public patient on one hard day (their meals at different
/// times and sizes, so groups have quiet and busy lanes), with a
/// sensitivity varying by patient.
fn cohort_day() -> (Vec<Patient>, Vec<InputDay>) {
    let mut patients = Vec::new();
    let mut days = Vec::new();
    for (k, p) in PatientParams::all_public().unwrap().into_iter().enumerate() {
        let cr = QuestRow::for_patient(&p.name).unwrap().cr;
        let name = hard_days::NAMES[k % hard_days::NAMES.len()];
        days.push(hard_days::build(name, &p, cr).unwrap());
        patients.push(Patient::new(p).unwrap());
    }
    (patients, days)
}

/// Insulin sensitivity of the k-th patient of [`cohort_day`].
fn sensitivity(k: usize) -> f64 {
    0.8 + 0.05 * (k % 9) as f64
}

fn run(mut batch: PatientBatch, days: &[InputDay], s: &[f64]) -> Vec<[f64; 13]> {
    let n = batch.len();
    let minutes = days.iter().map(|d| d.minutes.len()).min().unwrap();
    let mut out = Vec::new();
    for m in 0..minutes {
        let rates: Vec<MinuteRates> = days.iter().map(|d| d.minutes[m]).collect();
        batch.step(&rates, s).unwrap();
        out.extend((0..n).map(|i| batch.state_array(i)));
    }
    out
}

fn bits(states: &[[f64; 13]]) -> Vec<u64> {
    states.iter().flatten().map(|v| v.to_bits()).collect()
}

#[test]
fn every_instruction_set_gives_the_same_bits() {
    let (patients, days) = cohort_day();
    let s: Vec<f64> = (0..patients.len()).map(sensitivity).collect();
    let detected = bits(&run(
        PatientBatch::new(patients.clone()).unwrap(),
        &days,
        &s,
    ));
    let mut isas = vec![Isa::Baseline];
    #[cfg(target_arch = "x86_64")]
    {
        if pulp::x86::V3::try_new().is_some() {
            isas.push(Isa::Avx2);
        }
        if pulp::x86::V4::try_new().is_some() {
            isas.push(Isa::Avx512);
        }
    }
    for isa in isas {
        let batch = PatientBatch::new(patients.clone()).unwrap().with_isa(isa);
        assert!(bits(&run(batch, &days, &s)) == detected, "{isa:?} differs");
    }
}

/// `patient(i)` hands out patient i as it stands (minute, state,
/// eating bookkeeping), and it goes on alone as it would have in the
/// batch (within the exp's 2 ulp).
#[test]
fn a_patient_taken_out_goes_on_alone() {
    let (patients, days) = cohort_day();
    let n = patients.len();
    let s: Vec<f64> = (0..n).map(sensitivity).collect();
    let mut batch = PatientBatch::new(patients).unwrap();
    // Stop in the middle of a meal for some patients.
    let stop = 8 * 60 + 5;
    for m in 0..stop {
        let rates: Vec<MinuteRates> = days.iter().map(|d| d.minutes[m]).collect();
        batch.step(&rates, &s).unwrap();
    }
    let mut alone: Vec<Patient> = (0..n).map(|i| batch.patient(i).unwrap()).collect();
    for (i, p) in alone.iter().enumerate() {
        assert_eq!(p.minute(), stop as i64);
        assert_eq!(p.state_array(), &batch.state_array(i));
        assert_eq!(p.dbar_mg().to_bits(), batch.dbar_mg(i).to_bits());
    }
    for m in stop..stop + 120 {
        let rates: Vec<MinuteRates> = days.iter().map(|d| d.minutes[m]).collect();
        batch.step(&rates, &s).unwrap();
        for (i, p) in alone.iter_mut().enumerate() {
            p.step(rates[i].cho_g_per_min, rates[i].insulin_u_per_min, s[i])
                .unwrap();
            let diff = (p.glucose_mg_dl() - batch.glucose_mg_dl(i)).abs();
            assert!(diff < 1e-9, "patient {i} minute {m}: {diff:e} mg/dL");
        }
    }
}

/// A patient's trajectory does not depend on which patients share its
/// batch, nor on its place there: whether its busy minutes are
/// sub-stepped alone or gathered with others, the operations are the
/// same.
#[test]
fn a_patient_is_the_same_in_any_company() {
    let (patients, days) = cohort_day();
    let n = patients.len();
    let s: Vec<f64> = (0..n).map(sensitivity).collect();
    let together = run(PatientBatch::new(patients.clone()).unwrap(), &days, &s);
    for k in [0, 7, n - 1] {
        let alone = run(
            PatientBatch::new(vec![patients[k].clone()]).unwrap(),
            &days[k..=k],
            &s[k..=k],
        );
        let mine: Vec<[f64; 13]> = together.iter().skip(k).step_by(n).copied().collect();
        assert!(bits(&alone) == bits(&mine), "patient {k} differs alone");
    }
}

/// `replace(i, p)` starts patient i afresh in place (an environment's new
/// episode): from then on it goes exactly as `p` in a batch of its own,
/// and the others go on unchanged, to the bit.
#[test]
fn a_patient_replaced_goes_on_as_a_new_one_and_the_others_unchanged() {
    let (patients, days) = cohort_day();
    let n = patients.len();
    let s: Vec<f64> = (0..n).map(sensitivity).collect();
    let stop = 6 * 60 + 30;
    let mut batch = PatientBatch::new(patients.clone()).unwrap();
    let mut untouched = PatientBatch::new(patients.clone()).unwrap();
    for m in 0..stop {
        let rates: Vec<MinuteRates> = days.iter().map(|d| d.minutes[m]).collect();
        batch.step(&rates, &s).unwrap();
        untouched.step(&rates, &s).unwrap();
    }
    // Patient 17 becomes patient 3 at minute 0 (another group's).
    let k = 17;
    let fresh = patients[3].clone();
    batch.replace(k, fresh.clone()).unwrap();
    let mut alone = PatientBatch::new(vec![fresh]).unwrap();
    assert_eq!(batch.minute(k), 0);
    for m in stop..stop + 240 {
        let mut rates: Vec<MinuteRates> = days.iter().map(|d| d.minutes[m]).collect();
        let mine = days[3].minutes[m - stop];
        rates[k] = mine;
        batch.step(&rates, &s).unwrap();
        alone.step(&[mine], &s[k..=k]).unwrap();
        let mut others = rates.clone();
        others[k] = days[k].minutes[m];
        untouched.step(&others, &s).unwrap();
        assert!(
            bits(&[batch.state_array(k)]) == bits(&[alone.state_array(0)]),
            "minute {m}: the replaced patient differs from its run alone"
        );
        for i in (0..n).filter(|&i| i != k) {
            assert!(
                bits(&[batch.state_array(i)]) == bits(&[untouched.state_array(i)]),
                "minute {m}: patient {i} changed with its neighbour"
            );
        }
    }
    assert!(batch.replace(n, patients[0].clone()).is_err());
}
