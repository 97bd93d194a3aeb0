//! A linked person's week across a daylight-saving change, synced in two
//! parts (the second's window read again crossing the change): every
//! reading once at its instant, the changed day of 23 (or 25) hours, the
//! advisor's clock in order, advice given.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_io::record::RecordKind;
use abba_nightscout::site::credential;
use abba_nightscout::{link, sync};
use common::server::{iso, Server, Site};
use common::*;
use jiff::civil::{date, Date};
use jiff::{SignedDuration, Timestamp};
use serde_json::{json, Value};
use std::collections::BTreeMap;

/// 5-minute instants from local midnight 3 days before `change` to local
/// midnight 4 days after it.
fn week(tz: &str, change: Date) -> Vec<Timestamp> {
    let zone = jiff::tz::TimeZone::get(tz).unwrap();
    let midnight = |days: i64| {
        change
            .checked_add(jiff::Span::new().days(days))
            .unwrap()
            .to_zoned(zone.clone())
            .unwrap()
            .timestamp()
    };
    let (start, end) = (midnight(-3), midnight(4));
    (0..)
        .map(|i| start.checked_add(SignedDuration::from_mins(5 * i)).unwrap())
        .take_while(|t| *t < end)
        .collect()
}

fn entry(i: usize, t: Timestamp) -> Value {
    let ms = t.as_millisecond();
    json!({"_id": object_id(ms, i), "type": "sgv", "sgv": 90 + (i * 7) % 90,
        "date": ms, "dateString": iso(ms), "device": "xDrip-DexcomG6"})
}

fn check(tz: &str, change: Date, hours_that_day: usize) {
    let dir = tempfile::tempdir().unwrap();
    let instants = week(tz, change);
    let zone = jiff::tz::TimeZone::get(tz).unwrap();
    let entries: Vec<Value> = instants
        .iter()
        .enumerate()
        .rev()
        .map(|(i, t)| entry(i, *t))
        .collect();
    // The fixture's profile in the person's zone, in force from before.
    let mut profile = data(1).profile;
    for p in &mut profile {
        p["store"]["Default"]["timezone"] = json!(tz);
    }
    let start = instants[0].as_millisecond() - 86_400_000;
    profile[0]["mills"] = json!(start);
    profile[0]["startDate"] = json!(iso(start));
    profile[0]["created_at"] = json!(iso(start));
    let d = Data {
        entries: entries.clone(),
        treatments: Vec::new(),
        profile,
    };
    let files = export(dir.path(), &d);
    let mut new = person(&files);
    new.tz = tz.to_string();
    let db = dir.path().join("dst.db");
    let mut store = abba_store::Store::open(&db).unwrap();
    store.create_person(&new).unwrap();
    // The site holds the week up to noon of the changed day, then all.
    let noon = change
        .at(12, 0, 0, 0)
        .to_zoned(zone.clone())
        .unwrap()
        .timestamp()
        .as_millisecond();
    let mut site = Site::new(SECRET);
    site.add(
        "entries",
        entries
            .iter()
            .filter(|e| e["date"].as_i64().unwrap() < noon)
            .cloned()
            .collect(),
    );
    site.add("profile", d.profile.clone());
    let srv = Server::start(site);
    let secret = credential(None, Some(SECRET)).unwrap();
    link(&mut store, "ana", &srv.url, secret, false, &fast_client()).unwrap();
    sync(&mut store, "ana", &sync_opts()).unwrap();
    srv.with(|s| {
        s.add(
            "entries",
            entries
                .iter()
                .filter(|e| e["date"].as_i64().unwrap() >= noon)
                .cloned()
                .collect(),
        )
    });
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(r.warnings.is_empty() && r.gone.is_empty(), "{r:?}");

    // Every reading once, at its instant.
    let got: Vec<Timestamp> = store
        .records("ana")
        .unwrap()
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Cgm { .. }))
        .map(|r| r.at)
        .collect();
    let mut sorted = got.clone();
    sorted.sort();
    assert_eq!(
        sorted, instants,
        "{tz} {change}: readings lost, duplicated or moved"
    );
    // The person's local days: 24 hours each, the changed one 23 or 25.
    let mut per_day: BTreeMap<Date, usize> = BTreeMap::new();
    for t in &got {
        *per_day.entry(zone.to_datetime(*t).date()).or_default() += 1;
    }
    assert_eq!(per_day.len(), 7, "{per_day:?}");
    for (day, n) in &per_day {
        let hours = if *day == change { hours_that_day } else { 24 };
        assert_eq!(*n, hours * 12, "{tz} {day}");
    }
    // The advisor's clock: in order, the changed day's minutes inside it.
    let cgm: Vec<_> = store
        .events("ana")
        .unwrap()
        .into_iter()
        .filter(|e| matches!(e.kind, abba_core::EventKind::Cgm(_)))
        .map(|e| e.at)
        .collect();
    assert_eq!(cgm.len(), instants.len());
    assert!(cgm.windows(2).all(|w| w[0] < w[1]), "{tz}: out of order");
    let on_day: Vec<_> = cgm.iter().filter(|t| t.day_index() == 3).collect();
    assert_eq!(on_day.len(), hours_that_day * 12, "{tz} {change}");
    assert!(on_day
        .iter()
        .all(|t| (0..1440).contains(&t.minute_of_day())));
    // Advice is given, and a synced store equals a file import.
    store.advise("ana").unwrap();
    let mut imported = abba_store::Store::open(&dir.path().join("files.db")).unwrap();
    imported.create_person(&new).unwrap();
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&store, &imported);
    assert_eq!(advice(&mut store), advice(&mut imported));
}

#[test]
fn berlin_spring_forward_through_a_linked_persons_days() {
    check("Europe/Berlin", date(2026, 3, 29), 23);
}

#[test]
fn berlin_fall_back_through_a_linked_persons_days() {
    check("Europe/Berlin", date(2026, 10, 25), 25);
}

#[test]
fn new_york_spring_forward_through_a_linked_persons_days() {
    check("America/New_York", date(2026, 3, 8), 23);
}

#[test]
fn new_york_fall_back_through_a_linked_persons_days() {
    check("America/New_York", date(2026, 11, 1), 25);
}
