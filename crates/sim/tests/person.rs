//! The simulated person's protocol: events out, settings in.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_core::{EventKind, Timestamp, UnitsPerHour};
use abba_sim::cohort::{Cohort, CohortConfig, Population};
use abba_sim::devices::DeviceSet;
use abba_sim::person::{Behaviour, DayClosing, VirtualPerson};
use abba_sim::scenario::{ScenarioConfig, ScenarioId};

fn person(id: ScenarioId, closing: DayClosing) -> VirtualPerson {
    let vp = Cohort::generate(&CohortConfig::new(Population::Adults, 1, 1))
        .unwrap()
        .patients
        .remove(0);
    let mut s = ScenarioConfig::paper(id);
    s.days = 3;
    VirtualPerson::new(
        &vp,
        1,
        &s,
        5,
        &DeviceSet::default(),
        Behaviour::paper(closing),
    )
    .unwrap()
}

/// Simulates one minute, answering nothing; returns the events.
fn minute(p: &mut VirtualPerson) -> Vec<abba_core::Event> {
    p.begin_minute().unwrap();
    let mut out = Vec::new();
    while let Some(e) = p.next_event().unwrap() {
        out.push(e);
    }
    p.finish_minute().unwrap();
    out
}

#[test]
fn nothing_leaves_the_person_before_the_app_s_first_day() {
    let mut p = person(ScenarioId::S2, DayClosing::AfterBedtimeReading);
    let mut before = 0;
    while p.now() < Timestamp::from_day_and_minute(1, 0) {
        before += minute(&mut p).len();
    }
    assert_eq!(before, 0);
    let first = minute(&mut p);
    assert!(
        matches!(first.as_slice(), [e] if matches!(e.kind, EventKind::Cgm(_))),
        "{first:?}"
    );
}

#[test]
fn the_minute_protocol_is_enforced() {
    let mut p = person(ScenarioId::S1, DayClosing::AtMidnight);
    p.begin_minute().unwrap();
    assert!(p.begin_minute().is_err(), "begin twice");
    let mut p = person(ScenarioId::S1, DayClosing::AtMidnight);
    p.begin_minute().unwrap();
    assert!(
        p.finish_minute().is_err(),
        "finish before the events were taken"
    );
}

#[test]
fn a_suggested_basal_is_on_the_pump_and_in_the_log_the_same_minute() {
    let mut p = person(ScenarioId::S1, DayClosing::AtMidnight);
    while p.now() < Timestamp::from_day_and_minute(1, 3) {
        minute(&mut p);
    }
    p.begin_minute().unwrap();
    while p.next_event().unwrap().is_some() {}
    let mut s = *p.settings();
    s.basal = UnitsPerHour(2.0);
    p.suggest(s).unwrap();
    let e = p.next_event().unwrap().unwrap();
    assert_eq!(e.kind, EventKind::BasalRate(UnitsPerHour(2.0)));
    assert_eq!(e.at, p.now());
    assert!(p.next_event().unwrap().is_none());
    let r = p.finish_minute().unwrap();
    assert_eq!(r.basal_u_per_h, 2.0);
    assert!((r.insulin_u_per_min - 2.0 / 60.0).abs() < 1e-12);
}
