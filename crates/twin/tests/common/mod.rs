//! Simulated persons as real people's data: a cohort member lives the
//! trial's scenario S1 (CGM, meals with ±50 % carb-counting errors, an
//! unannounced bedtime snack, rescue carbohydrate, daily sensitivity
//! factors, a dawn phenomenon) under fixed standard therapy; the device
//! events are written as Nightscout JSON (as `abba export` writes them),
//! read back by abba-io and imported into a person store, and the twin is
//! fitted from the store's events. The truth of a what-if is the same
//! person living the same days (same meals, same noise) under the other
//! settings.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use abba_advisor::Mode;
use abba_core::{Event, GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_io::clock::AdvisorClock;
use abba_io::read::{read_all, ReadOptions};
use abba_sim::cohort::{Population, VirtualPatient};
use abba_sim::person::MinuteRecord;
use abba_sim::scenario::ScenarioId;
use abba_store::{NewPerson, Store};
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::TrialConfig;
use abba_twin::{BasalChange, Ranges, Twin, TwinOptions, WhatIf};
use jiff::tz::TimeZone;

/// Days simulated (the trial's devices record from day 2 on, so the twin
/// gets the last 14).
pub const DAYS: u32 = 15;
/// Days a what-if is judged on (the last ones).
pub const REPLAY_DAYS: usize = 7;

/// One simulated member and its twin's findings.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// Patient name.
    pub name: String,
    /// Grade.
    pub grade: abba_twin::Grade,
    /// Held-out RMSE, MARD, and the mean-glucose RMSE.
    pub held_out: (f64, f64, f64),
    /// (fitted, true) basal rate holding basal glucose (U/h).
    pub basal_need: (f64, f64),
    /// (fitted, true) basal glucose (mg/dL).
    pub basal_glucose: (f64, f64),
    /// For the basal +10 % and the carb ratio +10 % what-ifs: predicted and
    /// true change of (time in range, time below 70), percentage points.
    pub what_if: Vec<(&'static str, [f64; 2], [f64; 2])>,
    /// Whole-window simulations of the fit.
    pub simulations: u64,
    /// Seconds the fit took.
    pub fit_seconds: f64,
    /// Meals the fit found.
    pub found_meals: usize,
    /// Fit RMSE (mg/dL).
    pub fit_rmse: f64,
    /// Held-out RMSE of the true parameters fed the logged inputs (the
    /// best a twin could do without knowing the true carbohydrate).
    pub oracle_rmse: f64,
    /// The fitted values.
    pub estimates: Vec<(String, f64)>,
}

fn config(population: Population, patients: u32) -> TrialConfig {
    TrialConfig::try_from(RawTrialConfig {
        population,
        patients,
        days: DAYS,
        calibrate_te_ref: false,
        scenarios: vec![ScenarioId::S1],
        arms: vec![ArmKind::Standard],
        ..RawTrialConfig::default()
    })
    .unwrap()
}

/// The member's days under `therapy`: events and minutes.
fn live(
    config: &TrialConfig,
    vp: &VirtualPatient,
    no: u64,
    therapy: TherapySettings,
) -> (Vec<Event>, Vec<MinuteRecord>) {
    let mut vp = vp.clone();
    vp.therapy = therapy;
    let sc = config.planned_scenario(ScenarioId::S1).unwrap();
    let mut trace = Trace {
        events: Some(Vec::new()),
        decisions: None,
        minutes: Some(Vec::new()),
        init: None,
    };
    run_patient_with(config, &vp, no, sc, ArmKind::Standard, &mut trace).unwrap();
    (trace.events.unwrap(), trace.minutes.unwrap())
}

/// The events as a Nightscout export, imported into a fresh store, and
/// read back from it.
fn through_the_store(name: &str, events: &[Event], therapy: TherapySettings) -> Vec<Event> {
    let dir = tempfile::tempdir().unwrap();
    let day1: jiff::civil::Date = "2026-03-02".parse().unwrap();
    let clock = AdvisorClock::new(TimeZone::UTC, day1);
    let files = abba_io::nightscout_out::write(events, &therapy, &clock).unwrap();
    let inputs = vec![
        ("entries.json".to_string(), files.entries.into_bytes()),
        ("treatments.json".to_string(), files.treatments.into_bytes()),
        ("profile.json".to_string(), files.profile.into_bytes()),
    ];
    let opts = ReadOptions {
        tz: Some(TimeZone::UTC),
        ..ReadOptions::default()
    };
    let batch = read_all(&inputs, &opts).unwrap();
    let mut store = Store::open(&dir.path().join("abba.db")).unwrap();
    let mut person = NewPerson::new(name, "UTC", Mode::Cgm, therapy);
    person.first_day = Some(day1);
    store.create_person(&person).unwrap();
    store.import(name, &batch).unwrap();
    store.events(name).unwrap()
}

/// Ranges of the true subcutaneous glucose every 5 minutes of the last
/// `days` days.
fn truth_ranges(minutes: &[MinuteRecord], days: usize) -> Ranges {
    let from = (DAYS as usize - days) as i64 * 1440;
    let g: Vec<f64> = minutes
        .iter()
        .filter(|m| m.minute >= from && m.minute % 5 == 0)
        .map(|m| m.subcutaneous_mg_dl)
        .collect();
    Ranges::of(&g).unwrap()
}

/// Member `no` (1-based) of the default cohort of `population`: simulated,
/// exported, imported, fitted, checked, and its what-ifs against the truth.
pub fn member(population: Population, no: u32) -> Outcome {
    let config = config(population, no);
    let cohort = build_cohort(&config).unwrap();
    let vp = &cohort.patients[no as usize - 1];
    let name = vp.params.name.clone();
    let base = vp.therapy;
    let (events, minutes) = live(&config, vp, u64::from(no), base);
    let logged = through_the_store(&name, &events, base);
    let started = std::time::Instant::now();
    let twin = Twin::fit(
        &name,
        &logged,
        &TwinOptions {
            population,
            basal_in_force_u_per_h: base.basal.0,
            ..TwinOptions::default()
        },
    )
    .unwrap();
    let fit_seconds = started.elapsed().as_secs_f64();
    let truth_base = truth_ranges(&minutes, REPLAY_DAYS);
    let mut what_if = Vec::new();
    let basal = TherapySettings {
        basal: UnitsPerHour(base.basal.0 * 1.1),
        ..base
    };
    let cr = TherapySettings {
        carb_ratio: base.carb_ratio.map(|r| GramsPerUnit(r.0 * 1.1)),
        ..base
    };
    for (label, therapy, change) in [
        (
            "basal +10 %",
            basal,
            WhatIf {
                basal: BasalChange::Factor(1.1),
                carb_ratio: None,
                carb_ratio_factor: None,
                carb_ratio_factors: None,
            },
        ),
        (
            "carb ratio +10 %",
            cr,
            WhatIf {
                basal: BasalChange::Keep,
                carb_ratio: None,
                carb_ratio_factor: Some(1.1),
                carb_ratio_factors: None,
            },
        ),
    ] {
        let (_, m) = live(&config, vp, u64::from(no), therapy);
        let t = truth_ranges(&m, REPLAY_DAYS).minus(&truth_base);
        let replay = twin.replay_for_validation(&logged, &change, REPLAY_DAYS);
        // The second what-if reuses the recorded settings' runs the first
        // one kept: the same replay as a twin read back from its stored
        // form, which keeps none.
        let stored = stored_form(&twin);
        assert_eq!(
            replay.as_ref().ok(),
            stored
                .replay_for_validation(&logged, &change, REPLAY_DAYS)
                .as_ref()
                .ok(),
            "{label}: a replay with the kept runs differs from one without"
        );
        let predicted = match replay {
            Ok(r) => [r.change.value.tir_pct, r.change.value.below_70_pct],
            Err(_) => [f64::NAN; 2],
        };
        what_if.push((label, predicted, [t.tir_pct, t.below_70_pct]));
    }
    // A clone shares the kept runs; changed, it must not use them.
    let (mut moved, mut moved_stored) = (twin.clone(), stored_form(&twin));
    moved.z[0] += 0.5;
    moved_stored.z[0] += 0.5;
    let change = WhatIf {
        basal: BasalChange::Factor(0.9),
        carb_ratio: None,
        carb_ratio_factor: None,
        carb_ratio_factors: None,
    };
    assert_eq!(
        moved
            .replay_for_validation(&logged, &change, REPLAY_DAYS)
            .ok(),
        moved_stored
            .replay_for_validation(&logged, &change, REPLAY_DAYS)
            .ok(),
        "a changed clone replayed with its original's kept runs"
    );
    let tape = twin.tape(&logged).unwrap();
    let oracle = abba_twin::sim::run(
        &vp.params,
        &abba_twin::sim::RunInputs {
            start_minute: tape.start_minute,
            insulin_u_per_min: &tape.recorded_insulin(),
            meals: &tape.meals,
            start_glucose_mg_dl: tape.readings[0].1,
            dawn_factor: 0.5,
        },
    )
    .unwrap();
    let from = tape.start_minute + 12 * 1440;
    let ho: Vec<f64> = tape
        .readings
        .iter()
        .filter(|r| r.0 >= from)
        .map(|&(m, g)| (oracle[(m - tape.start_minute) as usize] - g).powi(2))
        .collect();
    let oracle_rmse = (ho.iter().sum::<f64>() / ho.len() as f64).sqrt();
    let h = twin.held_out.as_ref();
    Outcome {
        name,
        grade: twin.grade,
        held_out: h.map_or((f64::NAN, f64::NAN, f64::NAN), |h| {
            (h.rmse_mg_dl, h.mard_pct, h.mean_glucose_rmse_mg_dl)
        }),
        basal_need: (
            twin.estimate("basal_need").unwrap().value,
            vp.params.basal_u_per_min() * 60.0,
        ),
        basal_glucose: (twin.estimate("basal_glucose").unwrap().value, vp.params.gb),
        what_if,
        simulations: twin.fit.simulations,
        fit_seconds,
        found_meals: twin.found_meals.len(),
        fit_rmse: twin.fit.rmse_mg_dl,
        oracle_rmse,
        estimates: twin
            .estimates
            .iter()
            .map(|e| (e.name.clone(), e.value))
            .collect(),
    }
}

/// `twin` read back from its stored form (which keeps no runs).
fn stored_form(twin: &Twin) -> Twin {
    serde_json::from_str(&serde_json::to_string(twin).unwrap()).unwrap()
}
