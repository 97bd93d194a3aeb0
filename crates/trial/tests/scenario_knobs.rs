//! The scenario knobs of issue 15 change what they claim: the target of
//! s(t) (`sensitivity.target`) and the person's hypoglycaemia treatment
//! (`hypo_treatment`, on in S5).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::scenario::{HypoTreatment, ScenarioConfig, ScenarioId, SensitivityTarget};
use abba_trial::closed_loop::run_patient;
use abba_trial::protocol::{PlannedScenario, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::{ArmKind, TrialConfig};

fn config() -> TrialConfig {
    TrialConfig::try_from(RawTrialConfig {
        patients: 2,
        days: 9,
        ..RawTrialConfig::default()
    })
    .unwrap()
}

fn w1(config: &TrialConfig, s: &ScenarioConfig) -> abba_trial::results::PatientResult {
    let cohort = build_cohort(config).unwrap();
    let planned = PlannedScenario {
        id: ScenarioId::S1,
        mode: TrialConfig::mode_for(s),
        config: s.clone(),
    };
    run_patient(config, &cohort.patients[0], 1, &planned, ArmKind::Standard).unwrap()
}

#[test]
fn sensitivity_target_vmx_leaves_the_liver_at_nominal_sensitivity() {
    let c = config();
    let mut s = c.scenario(ScenarioId::S1);
    let both = w1(&c, &s);
    s.sensitivity.target = SensitivityTarget::Vmx;
    let vmx = w1(&c, &s);
    let g = |r: &abba_trial::results::PatientResult| {
        r.week(abba_trial::results::Week::W1)
            .unwrap()
            .metrics
            .mean_mg_dl
    };
    // With s(t) < 1 at dawn, kp3·s suppresses less glucose output: scaling
    // kp3 too makes the week more hyperglycaemic than scaling Vmx alone.
    assert!(
        g(&both) > g(&vmx),
        "both {} vs Vmx only {}",
        g(&both),
        g(&vmx)
    );
    // Without any variability the target does not matter.
    let mut flat = c.scenario(ScenarioId::S1);
    flat.sensitivity.dawn_factor = 1.0;
    flat.sensitivity.daily_factor_min = 1.0;
    flat.sensitivity.daily_factor_max = 1.0;
    let a = w1(&c, &flat);
    flat.sensitivity.target = SensitivityTarget::Vmx;
    let b = w1(&c, &flat);
    assert_eq!(a, b);
}

#[test]
fn hypo_treatment_feeds_rescue_carbs_on_low_readings_only_when_on() {
    let c = config();
    let s1 = c.scenario(ScenarioId::S1);
    assert_eq!(s1.hypo_treatment, None, "off in the paper's scenarios");
    let s5 = c.scenario(ScenarioId::S5);
    assert_eq!(s5.hypo_treatment, Some(HypoTreatment::default()));
    let off = w1(&c, &s1);
    assert_eq!((off.rescue_treatments, off.rescue_carbs_g), (0, 0.0));
    // A threshold the person's CGM is often below: treatments happen, every
    // one 15 g, at most one per 15 minutes, and glucose rises.
    let mut high = s1.clone();
    high.hypo_treatment = Some(HypoTreatment {
        below_mg_dl: 140.0,
        ..HypoTreatment::default()
    });
    let on = w1(&c, &high);
    assert!(on.rescue_treatments > 0);
    assert_eq!(on.rescue_carbs_g, 15.0 * f64::from(on.rescue_treatments));
    assert!(on.rescue_treatments <= 9 * 96, "{}", on.rescue_treatments);
    let mean = |r: &abba_trial::results::PatientResult| {
        r.week(abba_trial::results::Week::W1)
            .unwrap()
            .metrics
            .mean_mg_dl
    };
    assert!(mean(&on) > mean(&off));
    // Invalid settings are rejected with the field named.
    let mut bad = s1;
    bad.hypo_treatment = Some(HypoTreatment {
        carbs_g: -1.0,
        ..HypoTreatment::default()
    });
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("hypo_treatment.carbs_g"), "{e}");
}
