//! Records before the person's day 1 are stored, not used: a Dexcom
//! Clarity export starting 2025-03-15 imported first sets day 1; the
//! pump's CareLink export (MiniMed 630G, from 2025-03-13) imported after it
//! is stored whole, its 13th and 14th said "stored, not used", and the
//! advisor gives what it gives when those two days were never imported.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::TempDir;

use abba_advisor::Mode;
use abba_io::read::{read_all, Batch, ReadOptions};
use abba_io::therapy::therapy_from_files;
use abba_io::RecordKind;
use abba_store::person::TherapySource;
use abba_store::{NewPerson, Store};
use jiff::civil::Date;
use jiff::tz::TimeZone;
use std::path::PathBuf;

const IO_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../io/tests/data");
const ZONE: &str = "America/Chicago";
const HEADER: &str = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID";

fn carelink() -> PathBuf {
    PathBuf::from(format!("{IO_DATA}/carelink_630g_us_synthetic.csv"))
}

/// Clarity's export (Dexcom G6) of 2025-03-15 and 16, local wall times.
fn clarity() -> (String, Vec<u8>) {
    let mut s = format!("{HEADER}\r\n1,,Device,,,Dexcom G6 Mobile App,android G6,,,,,,,\r\n");
    let start = jiff::civil::date(2025, 3, 15).at(0, 0, 0, 0);
    for (index, m) in (2..).zip((0..2 * 1440).step_by(5)) {
        let t = start + jiff::SignedDuration::from_mins(m);
        s.push_str(&format!(
            "{index},{},EGV,,,,android G6,{},,,,,,\r\n",
            t.strftime("%Y-%m-%dT%H:%M:%S"),
            110 + (m / 5 * 11) % 80
        ));
    }
    ("clarity.csv".into(), s.into_bytes())
}

fn read(files: Vec<(String, Vec<u8>)>) -> Batch {
    let opts = ReadOptions {
        tz: Some(TimeZone::get(ZONE).unwrap()),
        ..ReadOptions::default()
    };
    read_all(&files, &opts).unwrap()
}

fn pump() -> Batch {
    read(vec![(
        "carelink.csv".into(),
        std::fs::read(carelink()).unwrap(),
    )])
}

fn now() -> jiff::Timestamp {
    "2025-04-01T00:00:00Z".parse().unwrap()
}

fn day_1() -> Date {
    "2025-03-15".parse().unwrap()
}

/// True for a record the advisor leaves out as dated before day 1 (a
/// profile before day 1 is in force on day 1).
fn before_day_1(r: &abba_io::Record) -> bool {
    !matches!(r.kind, RecordKind::Schedule { .. })
        && TimeZone::get(ZONE).unwrap().to_datetime(r.at).date() < day_1()
}

/// A store with person `cy` (the pump's therapy, as `person new
/// --therapy-from` gives it; day 1 set by the first import).
fn store(tag: &str) -> (TempDir, Store) {
    let dir = TempDir::new(tag);
    let opts = ReadOptions {
        tz: Some(TimeZone::get(ZONE).unwrap()),
        ..ReadOptions::default()
    };
    let t = therapy_from_files(&[carelink()], &opts, &Default::default()).unwrap();
    let mut p = NewPerson::new("cy", ZONE, Mode::Cgm, t.settings());
    p.settings.basal_schedule = Some(t.basal.clone());
    p.settings.therapy_source = TherapySource::Profile;
    let mut store = dir.store();
    store.create_person(&p).unwrap();
    (dir, store)
}

/// The advice as JSON without what differs by design: the count of
/// records in the log and the notes (which say what was left out).
fn advice(s: &mut Store) -> (serde_json::Value, Vec<String>) {
    let mut v = serde_json::to_value(s.advise("cy").unwrap()).unwrap();
    let notes = serde_json::from_value(v["notes"].take()).unwrap();
    v["data"]["records"].take();
    (v, notes)
}

#[test]
fn a_pumps_earlier_export_imported_after_the_sensors_is_stored_whole_and_not_used_before_day_1() {
    let pump = pump();
    let early = pump.records.iter().filter(|r| before_day_1(r)).count();
    assert!(early > 500, "the pump's 13th and 14th: {early}");

    // The sensor's export first (day 1 = 2025-03-15), advice, the pump's.
    let (_a, mut a) = store("a");
    let first = a.import_at("cy", &read(vec![clarity()]), now()).unwrap();
    assert_eq!(first.first_day.as_deref(), Some("2025-03-15"));
    a.advise("cy").unwrap();
    let s = a.import_at("cy", &pump, now()).unwrap();
    // Every record of both files is in the store.
    assert_eq!(s.added, pump.records.len(), "{s:?}");
    assert_eq!(
        a.records("cy").unwrap().len(),
        first.added + pump.records.len()
    );
    // The pump's days before day 1 are said "stored, not used".
    assert_eq!(s.before_day_1.count, early);
    let lines = s.lines("cy");
    let said = format!(
        "{early} records dated before day 1 (2025-03-15): stored, not used by the advisor; the first: carelink.csv: line "
    );
    assert!(lines.iter().any(|l| l.starts_with(&said)), "{lines:?}");
    assert!(
        s.set_aside
            .iter()
            .all(|o| o.first_day.as_str() >= "2025-03-15"),
        "days before day 1 are not said set aside: {:?}",
        s.set_aside
    );

    // The same sequence, the pump's records before day 1 never imported.
    let (_b, mut b) = store("b");
    b.import_at("cy", &read(vec![clarity()]), now()).unwrap();
    b.advise("cy").unwrap();
    let mut later = pump.clone();
    later.records.retain(|r| !before_day_1(r));
    b.import_at("cy", &later, now()).unwrap();
    assert_eq!(b.person("cy").unwrap().first_day, Some(day_1()));
    assert_eq!(a.person("cy").unwrap().first_day, Some(day_1()));

    // The same records used, events and advice (the snapshot made between
    // the imports included).
    // (A record's place in the log differs: compared by what it is.)
    let used = |s: &Store| -> Vec<String> {
        let u = s.used_records("cy").unwrap().records;
        u.iter()
            .map(|r| format!("{} {:?} {:?} {:?}", r.at, r.source, r.id, r.kind))
            .collect()
    };
    let (ua, ub) = (used(&a), used(&b));
    assert!(
        ua == ub,
        "{} records used, {} never imported",
        ua.len(),
        ub.len()
    );
    let hash = |s: &Store| abba_store::replay::events_hash(&s.events("cy").unwrap());
    assert_eq!(hash(&a), hash(&b));
    let (va, notes_a) = advice(&mut a);
    let (vb, notes_b) = advice(&mut b);
    assert_eq!(va, vb);
    let extra: Vec<&String> = notes_a.iter().filter(|n| !notes_b.contains(n)).collect();
    assert_eq!(
        extra,
        [&format!(
            "{early} records dated before day 1 (2025-03-15) are stored, not used by the advisor."
        )]
    );
    // A rebuild from scratch agrees with the advice kept since.
    let (_c, mut c) = store("c");
    c.import_at("cy", &read(vec![clarity()]), now()).unwrap();
    c.import_at("cy", &pump, now()).unwrap();
    assert_eq!(advice(&mut c).0, va);

    // A re-import of either adds nothing.
    let n = a.records("cy").unwrap().len();
    for batch in [pump.clone(), read(vec![clarity()])] {
        let again = a.import_at("cy", &batch, now()).unwrap();
        assert_eq!((again.added, again.updated), (0, 0), "{again:?}");
        assert!(again.lines("cy")[0].starts_with("Nothing new: "));
    }
    assert_eq!(a.records("cy").unwrap().len(), n);
    assert_eq!(advice(&mut a).0, va);
}

#[test]
fn an_import_of_records_before_day_1_only_leaves_no_end_where_advice_was_shown() {
    // Import 1 brought only records of the day before day 1 (stored, not
    // used); import 2 ends on day 1 at 12:00. Only import 2's end counts:
    // the first showed no advice (a suggestion "shown" hangs on these).
    let (_d, mut s) = store("ends");
    s.import_at("cy", &read(vec![clarity()]), now()).unwrap();
    let person = s.person("cy").unwrap();
    let zone = TimeZone::get(ZONE).unwrap();
    let ms = |d: &str| {
        jiff::civil::DateTime::strptime("%Y-%m-%d %H:%M", d)
            .unwrap()
            .to_zoned(zone.clone())
            .unwrap()
            .timestamp()
            .as_millisecond()
    };
    let ends = abba_store::in_force::import_ends(
        &person,
        &[(1, ms("2025-03-14 23:55")), (2, ms("2025-03-15 12:00"))],
    );
    let clock = abba_io::clock::AdvisorClock::new(zone.clone(), day_1());
    let noon = jiff::Timestamp::from_millisecond(ms("2025-03-15 12:00")).unwrap();
    assert_eq!(ends, [clock.timestamp(noon)]);
}
