//! Round trip: a simulated patient's device data exported as Nightscout
//! and read back gives exactly the event stream the trial fed the advisor
//! (same events, same minutes, same values).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_io::clock::AdvisorClock;
use abba_io::events::PersonSettings;
use abba_io::nightscout_out;
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::{ArmKind, RawTrialConfig, TrialConfig};
use abba_trial::runner::{build_cohort, trace_patient};

fn round_trip(patient: &str, arm: ArmKind, tz: &str, start: jiff::civil::Date) {
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: 10,
        days: 21,
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let (_, trace) = trace_patient(&config, &cohort, patient, ScenarioId::S1, arm).unwrap();
    let fed = trace.events.unwrap();
    let therapy = cohort
        .patients
        .iter()
        .find(|p| p.params.name == patient)
        .unwrap()
        .therapy;
    let zone = abba_io::time::zone(tz).unwrap();
    let clock = AdvisorClock::new(zone.clone(), start);
    let files = nightscout_out::write(&fed, &therapy, &clock).unwrap();
    let inputs = vec![
        ("entries.json".to_string(), files.entries.into_bytes()),
        ("treatments.json".to_string(), files.treatments.into_bytes()),
        ("profile.json".to_string(), files.profile.into_bytes()),
    ];
    let batch = abba_io::read_all(&inputs, &abba_io::ReadOptions::default()).unwrap();
    let mut person = PersonSettings::new(zone);
    person.first_day = Some(start);
    let stream = batch.to_events(&person).unwrap();
    assert!(stream.rejected.is_empty(), "{:?}", stream.rejected);
    // The stream has every kind, including basal changes after ABBA's first week.
    for kind in ["cgm", "meal_announced", "bolus", "basal_rate", "day_closed"] {
        assert!(
            stream.counts.get(kind).copied().unwrap_or(0) > 0,
            "{patient} {arm:?}: no {kind} in {:?}",
            stream.counts
        );
    }
    assert_eq!(
        stream.events.len(),
        fed.len(),
        "{patient} {arm:?}: counts {:?}",
        stream.counts
    );
    for (i, (a, b)) in stream.events.iter().zip(&fed).enumerate() {
        assert_eq!(a, b, "{patient} {arm:?}: event {i} differs");
    }
}

#[test]
fn abba_patient_exported_as_nightscout_reads_back_to_the_same_events() {
    round_trip(
        "adult#001",
        ArmKind::Abba,
        "Europe/Zurich",
        jiff::civil::date(2026, 1, 5),
    );
}

#[test]
fn r2r_patient_in_new_york_reads_back_to_the_same_events() {
    round_trip(
        "adult#003",
        ArmKind::R2r,
        "America/New_York",
        jiff::civil::date(2025, 5, 12),
    );
}
