//! `Patient::minute_state` / `with_minute_state`: the hand-over to another
//! stepper (`abba-batch`).

#![allow(clippy::unwrap_used)]

use abba_sim::patient::{Patient, PatientParams};

#[test]
fn a_patient_continued_from_its_own_state_steps_the_same() {
    let params = PatientParams::public("adult#003").unwrap();
    let mut a = Patient::new(params.clone()).unwrap();
    for m in 0..90 {
        let cho = if (30..40).contains(&m) { 5.0 } else { 0.0 };
        a.step(cho, 0.02, 1.0).unwrap();
    }
    let mut b = Patient::new(params)
        .unwrap()
        .with_minute_state(a.minute_state())
        .unwrap();
    assert_eq!(b.minute(), 90);
    for _ in 0..60 {
        a.step(0.0, 0.02, 1.0).unwrap();
        b.step(0.0, 0.02, 1.0).unwrap();
        assert_eq!(a.state_array(), b.state_array());
    }
    assert_eq!(a.dbar_mg().to_bits(), b.dbar_mg().to_bits());
}

#[test]
fn a_non_finite_state_is_refused_with_its_name() {
    let p = Patient::new(PatientParams::public("adult#001").unwrap()).unwrap();
    let mut state = p.minute_state();
    state.x[4] = f64::NAN;
    let err = p.with_minute_state(state).unwrap_err().to_string();
    assert!(err.contains("gt") && err.contains("adult#001"), "{err}");
}
