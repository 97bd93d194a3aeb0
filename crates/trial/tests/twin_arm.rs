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
    if stats.held_back == 0 {
        assert_eq!(checked, plain, "nothing held back: the same run");
    } else {
        assert_ne!(
            (
                checked.final_basal_u_per_h,
                checked.final_carb_ratio_g_per_u
            ),
            (plain.final_basal_u_per_h, plain.final_carb_ratio_g_per_u),
        );
    }
    // Deterministic.
    let (again, stats2) =
        run_patient(&config, vp, no as u64, sc, TwinArmOptions::default()).unwrap();
    assert_eq!(again, checked);
    assert_eq!(stats2, stats);
}
