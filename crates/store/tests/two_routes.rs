//! One sensor by two routes (a Dexcom Clarity export and the same
//! readings uploaded to Nightscout seconds apart): every record is stored,
//! each local day's glucose comes from the source that covers it more
//! fully (`abba_store::one_source`), and the log gives the same events and
//! advice whatever the order of the imports and whether the advisor ran
//! between them (its snapshot made before a fuller source took a day).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_io::Source;
use abba_store::Store;
use common::{person, read, TempDir};

const HEADER: &str = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID";

/// The sensor's reading at minute `m` after 2026-05-04 00:00 Zurich.
fn glucose(m: i64) -> i64 {
    120 + (m / 5 * 7) % 90
}

/// Clarity's export of the readings from minute `from` to `to`
/// (exclusive) after 2026-05-04 00:00 Zurich.
fn clarity(from: i64, to: i64) -> (String, Vec<u8>) {
    let mut s = format!("{HEADER}\r\n1,,Device,,,Dexcom G6 Mobile App,android G6,,,,,,,\r\n");
    let start = jiff::civil::date(2026, 5, 4).at(0, 0, 0, 0);
    for (index, m) in (2..).zip((from..to).step_by(5)) {
        let t = start + jiff::SignedDuration::from_mins(m);
        s.push_str(&format!(
            "{index},{},EGV,,,,android G6,{},,,,,{},8ABCDE\r\n",
            t.strftime("%Y-%m-%dT%H:%M:%S"),
            glucose(m),
            4_000_000 + m * 60
        ));
    }
    ("clarity.csv".into(), s.into_bytes())
}

/// Nightscout's entries of the same readings, uploaded 20 s after the
/// sensor's minute, from minute `from` to `to`.
fn nightscout(from: i64, to: i64) -> (String, Vec<u8>) {
    let start = jiff::civil::date(2026, 5, 4)
        .to_zoned(jiff::tz::TimeZone::get("Europe/Zurich").unwrap())
        .unwrap()
        .timestamp()
        .as_millisecond();
    let docs: Vec<serde_json::Value> = (from..to)
        .step_by(5)
        .map(|m| {
            let ms = start + m * 60_000 + 20_000;
            serde_json::json!({"_id": format!("{:024x}", ms), "type": "sgv", "sgv": glucose(m),
                "date": ms, "device": "share2"})
        })
        .collect();
    ("entries.json".into(), serde_json::to_vec(&docs).unwrap())
}

fn now() -> jiff::Timestamp {
    "2026-06-01T00:00:00Z".parse().unwrap()
}

const DAY: i64 = 24 * 60;

/// A store fed `imports` in turn (each one import), asked for advice after
/// each when `advise_between`.
fn fed(tag: &str, imports: &[Vec<(String, Vec<u8>)>], advise_between: bool) -> (TempDir, Store) {
    let dir = TempDir::new(tag);
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    for files in imports {
        store
            .import_at("ana", &read(files).unwrap(), now())
            .unwrap();
        if advise_between {
            store.advise("ana").unwrap();
        }
    }
    (dir, store)
}

#[test]
fn a_partial_export_beside_nightscouts_whole_days_gives_one_reading_a_minute_in_any_order() {
    // Clarity: 2026-05-04 to 2026-05-06 10:00 (exported that morning);
    // Nightscout: the whole of 2026-05-05 and 2026-05-06.
    let export = || clarity(0, 2 * DAY + 600);
    let uploads = || nightscout(DAY, 3 * DAY);
    let (_d1, mut a) = fed("a", &[vec![export()], vec![uploads()]], true);
    let (_d2, mut b) = fed("b", &[vec![uploads()], vec![export()]], true);
    let (_d3, mut c) = fed("c", &[vec![uploads(), export()]], false);
    let (_d4, alone) = fed("alone", &[vec![export()]], false);
    let (_d5, ns) = fed("ns", &[vec![uploads()]], false);
    // Every record stored.
    let stored = alone.records("ana").unwrap().len() + ns.records("ana").unwrap().len();
    for s in [&a, &b, &c] {
        assert_eq!(s.records("ana").unwrap().len(), stored);
    }
    assert_eq!(a.records("ana").unwrap(), b.records("ana").unwrap());
    // The same events and advice, whether or not the advisor ran (and kept
    // its snapshot) before the second source took a day.
    let hash = |s: &Store| abba_store::replay::events_hash(&s.events("ana").unwrap());
    assert_eq!(hash(&a), hash(&b));
    assert_eq!(hash(&a), hash(&c));
    let advice = |s: &mut Store| serde_json::to_value(s.advise("ana").unwrap()).unwrap();
    let (va, vb, vc) = (advice(&mut a), advice(&mut b), advice(&mut c));
    assert_eq!(va, vb);
    assert_eq!(va, vc);
    // One reading a minute, none left out as a second reading of its
    // minute: 2026-05-04 and 05 from Clarity (the 5th a tie in count and
    // span: the maker's export first), 2026-05-06 from Nightscout.
    assert_eq!(va["data"]["events"]["cgm"], 3 * 288, "{}", va["data"]);
    assert_eq!(va["data"]["records_not_used"], 0, "{}", va["data"]);
    let zone = jiff::tz::TimeZone::get("Europe/Zurich").unwrap();
    let mut by_day: std::collections::BTreeMap<String, std::collections::BTreeSet<Source>> =
        Default::default();
    let used = a.used_records("ana").unwrap();
    for r in &used.records {
        by_day
            .entry(zone.to_datetime(r.at).date().to_string())
            .or_default()
            .insert(r.source);
    }
    let one = |s| std::collections::BTreeSet::from([s]);
    assert_eq!(by_day["2026-05-04"], one(Source::Clarity));
    assert_eq!(by_day["2026-05-05"], one(Source::Clarity));
    assert_eq!(by_day["2026-05-06"], one(Source::Nightscout));
    // What was set aside: Nightscout's 5th, Clarity's morning of the 6th
    // (00:00 to 09:55).
    let aside: Vec<(Source, Source, usize, &str)> = used
        .set_aside
        .iter()
        .map(|o| (o.source, o.used, o.count, o.first_day.as_str()))
        .collect();
    assert_eq!(
        aside,
        [
            (Source::Nightscout, Source::Clarity, 288, "2026-05-05"),
            (Source::Clarity, Source::Nightscout, 120, "2026-05-06"),
        ]
    );
    let notes = va["notes"].to_string();
    assert!(
        notes.contains("120 CGM glucose records from clarity (2026-05-06) stored, not used"),
        "{notes}"
    );
    // Importing either again adds nothing and changes nothing.
    let again = a
        .import_at("ana", &read(&[export()]).unwrap(), now())
        .unwrap();
    assert_eq!((again.added, again.updated), (0, 0));
    assert_eq!(hash(&a), hash(&b));
}
