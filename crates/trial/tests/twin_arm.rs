//! The ABBA arm with the twin check (issue 27, item 7): the twin is fitted
//! from the simulated person's device events, refitted weekly, and each
//! suggestion replayed on it. Paired with the plain ABBA arm (same person,
//! same days): with nothing held back the two runs are the same bit for
//! bit; with something held back, the settings differ.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::scenario::ScenarioId;
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::twin_arm::{run_patient, TwinArmOptions};
use abba_trial::TrialConfig;
use serde_json::Value;

#[test]
fn the_twin_checked_arm_fits_from_device_data_and_pairs_with_abba() {
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: 4,
        days: 21,
        calibrate_te_ref: false,
        scenarios: vec![ScenarioId::S1],
        arms: vec![ArmKind::Abba],
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let sc = config.planned_scenario(ScenarioId::S1).unwrap();
    let no = 4;
    let vp = &cohort.patients[no - 1];
    let plain = run_patient_with(
        &config,
        vp,
        no as u64,
        sc,
        ArmKind::Abba,
        &mut Trace::default(),
    )
    .unwrap();
    let (checked, stats) =
        run_patient(&config, vp, no as u64, sc, TwinArmOptions::default()).unwrap();
    eprintln!("{stats:?}");
    // The devices record from day 2: 20 closed days, fitted at the 14th
    // (the next refit would be at the 21st).
    assert_eq!(stats.fits, 1, "{stats:?}");
    assert!(stats.checked + stats.unchecked > 0, "{stats:?}");
    assert_eq!(checked.twin_check, Some(stats));
    assert_eq!(plain.twin_check, None);
    if stats.held_back == 0 {
        let mut unchecked = checked.clone();
        unchecked.twin_check = None;
        assert_eq!(unchecked, plain, "nothing held back: the same run");
    } else {
        assert_ne!(
            (
                checked.final_basal_u_per_h,
                checked.final_carb_ratio_g_per_u
            ),
            (plain.final_basal_u_per_h, plain.final_carb_ratio_g_per_u),
        );
    }
    // (That a second run is the same bytes, serial or parallel, is the
    // next test's: a twin's fit is the costly part of both.)
}

/// The arm through the runner and the report: `--arms abba,abba-twin` runs
/// it like any arm (paired with ABBA, same person, same days), the same
/// bytes serial and parallel, its result equals the library entry's, only
/// it carries the check's counts, and the report's notes carry the check's
/// counts summed over the arm's patients (held back among them); the plain
/// ABBA arm's notes have none.
#[test]
fn the_twin_arm_runs_through_the_runner_and_its_counts_are_reported() {
    use abba_trial::runner::{run_trial, Silent};
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: 2,
        days: 21,
        calibrate_te_ref: false,
        scenarios: vec![ScenarioId::S1],
        arms: vec![ArmKind::Abba, ArmKind::AbbaTwin],
        ..RawTrialConfig::default()
    })
    .unwrap();
    // The serial run, a parallel run and patient 2 alone, side by side (each
    // fit is serial; this test ends its binary's run, when the other test
    // thread has nothing left to do).
    let sc = config.planned_scenario(ScenarioId::S1).unwrap();
    let cohort = build_cohort(&config).unwrap();
    let (out, parallel, (alone, stats)) = std::thread::scope(|s| {
        let serial = s.spawn(|| run_trial(&config, 1, &Silent).unwrap());
        let parallel = s.spawn(|| run_trial(&config, 2, &Silent).unwrap());
        let alone = run_patient(
            &config,
            &cohort.patients[1],
            2,
            sc,
            TwinArmOptions::default(),
        )
        .unwrap();
        (serial.join().unwrap(), parallel.join().unwrap(), alone)
    });
    // The same bytes serial and parallel (its twins' fits included; the
    // check of trial_determinism.rs for this arm, here to share the run).
    assert_eq!(
        serde_json::to_string(&out.arms).unwrap(),
        serde_json::to_string(&parallel.arms).unwrap(),
        "serial and parallel differ"
    );
    for p in &out.arms[0].patients {
        assert!(p.twin_check.is_none(), "plain ABBA has no twin check");
    }
    for p in &out.arms[1].patients {
        let c = p.twin_check.expect("the abba-twin arm's counts");
        assert_eq!(c.fits, 1, "{c:?}");
    }
    let twin = out
        .arms
        .iter()
        .find(|a| a.advisor == ArmKind::AbbaTwin)
        .unwrap();
    assert_eq!(twin.key(), "S1/abba-twin");
    // The runner's run of patient 2 is the library entry's, on the
    // runner's cohort.
    assert_eq!(out.cohort.patients[1], cohort.patients[1]);
    assert_eq!(twin.patients[1], alone);
    let total = twin.patients.iter().map(|p| p.twin_check.unwrap()).fold(
        Default::default(),
        abba_trial::results::TwinCheckCounts::plus,
    );
    assert_eq!(total.fits, 2, "one fit per patient at the 14th closed day");
    assert!(total.fits >= stats.fits);
    let summary = abba_report::summary::summary_json(&out.arms, &Value::Null).unwrap();
    let notes = &summary["notes"]["arms"];
    let reported = &notes["S1/abba-twin"]["twin_check"];
    assert_eq!(reported["held_back"], total.held_back, "{reported}");
    assert_eq!(reported["checked"], total.checked, "{reported}");
    assert_eq!(reported["fits"], 2, "{reported}");
    assert!(notes["S1/abba"].get("twin_check").is_none());
    assert!(summary["arms"]["S1/abba-twin"]["weeks"]["W1"].is_object());
}
