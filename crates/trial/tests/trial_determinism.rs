//! A short trial is a pure function of its configuration: serial and
//! parallel runs, and repeated runs, give identical results.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::runner::{run_trial, Silent};
use abba_trial::TrialConfig;

fn short() -> TrialConfig {
    TrialConfig::try_from(RawTrialConfig {
        patients: 8,
        days: 21,
        scenarios: vec![ScenarioId::S1, ScenarioId::S4],
        ..RawTrialConfig::default()
    })
    .unwrap()
}

#[test]
fn serial_and_parallel_runs_are_identical() {
    let config = short();
    let serial = run_trial(&config, 1, &Silent).unwrap();
    let parallel = run_trial(&config, 2, &Silent).unwrap();
    let again = run_trial(&config, 2, &Silent).unwrap();
    let a = serde_json::to_string(&serial.arms).unwrap();
    let b = serde_json::to_string(&parallel.arms).unwrap();
    let c = serde_json::to_string(&again.arms).unwrap();
    assert_eq!(a, b, "serial and parallel differ");
    assert_eq!(b, c, "two parallel runs differ");
    assert_eq!(serial.arms.len(), 6);
    for arm in &serial.arms {
        assert_eq!(arm.patients.len(), 8);
        // 21 days hold W1 (D2-D8), W2 (D9-D15) and W3 (D16-D22 does not fit).
        assert_eq!(arm.patients[0].weeks.len(), 2);
    }
}

#[test]
fn arms_share_the_standard_therapy_week() {
    // Every arm runs standard therapy during W1 on the same scenario
    // realisation, so W1 is identical across arms of a CGM-mode scenario.
    // (In SMBG mode the first basal update comes at the bedtime reading of
    // D8, spec §2.4, so the last hour of W1 may differ.)
    let out = run_trial(&short(), 2, &Silent).unwrap();
    {
        let s = ScenarioId::S1;
        let w1: Vec<String> = out
            .arms
            .iter()
            .filter(|a| a.scenario == s)
            .map(|a| {
                serde_json::to_string(&a.patients.iter().map(|p| &p.weeks[0]).collect::<Vec<_>>())
                    .unwrap()
            })
            .collect();
        assert_eq!(w1.len(), 3);
        assert!(
            w1.iter().all(|w| *w == w1[0]),
            "{s}: W1 differs between arms"
        );
    }
}
