//! Property: whatever valid device data comes in (readings at any second,
//! meals, boluses, temporary basals, suspensions, profiles with several
//! segments, in any of three zones and across DST weeks), the mapped event
//! stream is accepted by the advisor's own event guard, event by event.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_advisor::{Advisor, EventLimits, FixedTherapy};
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_io::events::PersonSettings;
use common::read;
use proptest::prelude::*;
use serde_json::json;

/// Start instants: ordinary weeks and weeks holding a DST transition.
const STARTS: [&str; 4] = [
    "2024-01-08T00:00:00Z",
    "2024-03-28T00:00:00Z",
    "2024-10-24T00:00:00Z",
    "2024-11-01T00:00:00Z",
];
const ZONES: [&str; 3] = ["UTC", "Europe/Zurich", "America/New_York"];

#[derive(Debug, Clone)]
enum Item {
    Sgv(u32, u32),
    Mbg(u32, u32),
    Meal(u32, u32, u32),
    Bolus(u32, u32),
    Temp(u32, u32, u32),
    Suspend(u32, u32),
    Resume(u32),
}

fn item() -> impl Strategy<Value = Item> {
    let at = 0u32..7 * 86_400; // seconds within a week
    prop_oneof![
        8 => (at.clone(), 40u32..400).prop_map(|(t, g)| Item::Sgv(t, g)),
        1 => (at.clone(), 40u32..400).prop_map(|(t, g)| Item::Mbg(t, g)),
        2 => (at.clone(), 1u32..150, 0u32..150).prop_map(|(t, c, u)| Item::Meal(t, c, u)),
        1 => (at.clone(), 1u32..100).prop_map(|(t, u)| Item::Bolus(t, u)),
        1 => (at.clone(), 0u32..300, 0u32..240).prop_map(|(t, r, d)| Item::Temp(t, r, d)),
        1 => (at.clone(), 1u32..120).prop_map(|(t, d)| Item::Suspend(t, d)),
        1 => at.prop_map(Item::Resume),
    ]
}

fn nightscout(start: jiff::Timestamp, items: &[Item], segments: &[(u32, u32)]) -> Vec<u8> {
    let iso = |s: u32| (start + jiff::SignedDuration::from_secs(i64::from(s))).to_string();
    let mut v = vec![json!({
        "_id": "profile", "startDate": iso(0), "defaultProfile": "D",
        "store": {"D": {"basal": segments.iter().map(|&(m, r)| json!({"timeAsSeconds": m * 60, "value": f64::from(r) / 100.0})).collect::<Vec<_>>()}}
    })];
    for (i, it) in items.iter().enumerate() {
        let id = format!("x{i}");
        v.push(match *it {
            Item::Sgv(t, g) => json!({"_id": id, "type": "sgv", "sgv": g, "dateString": iso(t)}),
            Item::Mbg(t, g) => json!({"_id": id, "type": "mbg", "mbg": g, "dateString": iso(t)}),
            Item::Meal(t, c, u) => json!({"_id": id, "eventType": "Meal Bolus", "created_at": iso(t), "carbs": c, "insulin": f64::from(u) / 10.0}),
            Item::Bolus(t, u) => json!({"_id": id, "eventType": "Correction Bolus", "created_at": iso(t), "insulin": f64::from(u) / 10.0}),
            Item::Temp(t, r, d) => json!({"_id": id, "eventType": "Temp Basal", "created_at": iso(t), "absolute": f64::from(r) / 100.0, "duration": d}),
            Item::Suspend(t, d) => json!({"_id": id, "eventType": "Suspend Pump", "created_at": iso(t), "duration": d}),
            Item::Resume(t) => json!({"_id": id, "eventType": "Resume Pump", "created_at": iso(t)}),
        });
    }
    serde_json::to_vec(&v).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn mapped_events_pass_the_advisors_guard(
        start in 0usize..4,
        zone in 0usize..3,
        items in prop::collection::vec(item(), 1..300),
        cuts in prop::collection::btree_set(1u32..1440, 0..3),
        rates in prop::collection::vec(10u32..300, 4),
    ) {
        let start: jiff::Timestamp = STARTS[start].parse().unwrap();
        let segments: Vec<(u32, u32)> = std::iter::once(0).chain(cuts).zip(rates).collect();
        let bytes = nightscout(start, &items, &segments);
        let batch = read(&[("ns.json", bytes)], &abba_io::ReadOptions::default()).unwrap();
        let tz = abba_io::time::zone(ZONES[zone]).unwrap();
        let stream = batch.to_events(&PersonSettings::new(tz)).unwrap();
        let settings = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap();
        let mut guard = FixedTherapy::new(settings, EventLimits::default()).unwrap();
        for (i, e) in stream.events.iter().enumerate() {
            let accepted = guard.observe(e);
            prop_assert!(accepted.is_ok(), "event {} {:?}: {:?}", i, e, accepted.err().map(|x| x.to_string()));
        }
    }
}

/// Two bolus records in one minute are two doses: one event with their sum
/// (two equal events in a minute would be taken by the advisor for a
/// repeat, and rejected); so are two snacks. Found by the property above.
#[test]
fn doses_of_one_minute_become_one_event_with_their_sum() {
    let start: jiff::Timestamp = STARTS[0].parse().unwrap();
    let t = 22 * 3600 + 30 * 60;
    let items = [
        Item::Bolus(t, 67),
        Item::Bolus(t + 20, 67),
        Item::Meal(t + 3 * 3600, 12, 0),
        Item::Meal(t + 3 * 3600 + 30, 12, 0),
    ];
    let bytes = nightscout(start, &items, &[(0, 100)]);
    let batch = read(&[("ns.json", bytes)], &abba_io::ReadOptions::default()).unwrap();
    let tz = abba_io::time::zone("UTC").unwrap();
    let stream = batch.to_events(&PersonSettings::new(tz)).unwrap();
    let boluses: Vec<f64> = stream
        .events
        .iter()
        .filter_map(|e| match e.kind {
            abba_core::EventKind::Bolus(u) => Some(u.0),
            _ => None,
        })
        .collect();
    // The correction boluses, then the meals' (0 U) boluses, each once.
    assert_eq!(boluses.len(), 2, "{:?}", stream.events);
    assert!((boluses[0] - 13.4).abs() < 1e-9);
    assert_eq!(boluses[1], 0.0);
    let snacks: Vec<f64> = stream
        .events
        .iter()
        .filter_map(|e| match e.kind {
            abba_core::EventKind::MealAnnounced { carbs, .. } => Some(carbs.0),
            _ => None,
        })
        .collect();
    assert_eq!(snacks, vec![24.0], "{:?}", stream.events);
    let settings = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap();
    let mut guard = FixedTherapy::new(settings, EventLimits::default()).unwrap();
    for e in &stream.events {
        guard.observe(e).unwrap();
    }
}

/// A suspension with a duration that ends in the minute another
/// suspension begins and is resumed: two resumes in one minute, which the
/// advisor's guard takes for a repeat. One is kept, the other counted.
/// Found by the property above (its shrunk case).
#[test]
fn two_resumes_of_one_minute_are_one_event() {
    let items = [
        Item::Suspend(490_946, 1),
        Item::Resume(490_946),
        Item::Suspend(484_680, 104),
    ];
    let start: jiff::Timestamp = STARTS[0].parse().unwrap();
    let bytes = nightscout(start, &items, &[(0, 10)]);
    let batch = read(&[("ns.json", bytes)], &abba_io::ReadOptions::default()).unwrap();
    let tz = abba_io::time::zone(ZONES[0]).unwrap();
    let stream = batch.to_events(&PersonSettings::new(tz)).unwrap();
    let settings = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap();
    let mut guard = FixedTherapy::new(settings, EventLimits::default()).unwrap();
    for e in &stream.events {
        guard.observe(e).unwrap();
    }
    let resumes = stream
        .events
        .iter()
        .filter(|e| matches!(e.kind, abba_core::EventKind::Resume))
        .count();
    assert_eq!(resumes, 1, "{:?}", stream.events);
    assert!(
        stream.rejected.iter().any(|r| r.kind == "resume"
            && r.reason
                .starts_with("a suspend and a resume after a resume of the same minute")),
        "{:?}",
        stream.rejected
    );
}

/// A suspension, a resume and a suspension again within one minute (a
/// pump alarm resumed and suspending again, a person pressing twice): the
/// pump is suspended after the minute, as the last record says; sorting
/// the minute's events by kind put the resume last and left the pump
/// running. Four within a minute (suspend, resume, suspend, resume) leave
/// it running. The advisor's guard accepts the stream.
#[test]
fn a_suspend_resume_suspend_of_one_minute_ends_it_suspended() {
    let start: jiff::Timestamp = STARTS[0].parse().unwrap();
    let t = 9 * 3600 + 10;
    let u = 15 * 3600 + 5;
    let items = [
        Item::Sgv(t - 300, 120),
        Item::Suspend(t, 120),
        Item::Resume(t + 15),
        Item::Suspend(t + 40, 120),
        Item::Sgv(t + 300, 121),
        Item::Suspend(u, 60),
        Item::Resume(u + 10),
        Item::Suspend(u + 20, 60),
        Item::Resume(u + 30),
        Item::Sgv(u + 300, 122),
    ];
    let bytes = nightscout(start, &items, &[(0, 100)]);
    let batch = read(&[("ns.json", bytes)], &abba_io::ReadOptions::default()).unwrap();
    let tz = abba_io::time::zone("UTC").unwrap();
    let stream = batch.to_events(&PersonSettings::new(tz)).unwrap();
    let settings = TherapySettings::new(UnitsPerHour(1.0), GramsPerUnit(10.0)).unwrap();
    let mut guard = FixedTherapy::new(settings, EventLimits::default()).unwrap();
    for e in &stream.events {
        guard.observe(e).unwrap();
    }
    let pump = |minute_of_day: i64| -> Vec<&'static str> {
        stream
            .events
            .iter()
            .filter(|e| e.at.minute_of_day() == minute_of_day)
            .filter_map(|e| match e.kind {
                abba_core::EventKind::Suspend => Some("suspend"),
                abba_core::EventKind::Resume => Some("resume"),
                _ => None,
            })
            .collect()
    };
    assert_eq!(pump(9 * 60), vec!["suspend"], "{:?}", stream.events);
    assert_eq!(
        pump(15 * 60),
        vec!["suspend", "resume"],
        "{:?}",
        stream.events
    );
    // The suspension of 09:00 ends after its 120 min.
    assert_eq!(pump(11 * 60), vec!["resume"], "{:?}", stream.events);
    let dropped: Vec<&str> = stream
        .rejected
        .iter()
        .filter(|r| r.reason.contains("of the same minute"))
        .map(|r| r.kind.as_str())
        .collect();
    assert_eq!(
        dropped,
        vec!["resume", "suspend", "resume", "suspend"],
        "{:?}",
        stream.rejected
    );
}
