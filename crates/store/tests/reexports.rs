//! Identity that survives re-exports: Clarity numbers its rows from 1 in
//! every export, so two overlapping exports must import to exactly their
//! union; a row repeated inside one export is one record, counted; a store
//! keyed by the old identity (the row's `Index`) is re-keyed by a
//! migration without losing a record; data from the future and before day
//! 1 is refused or not used, with the count and the first line.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_io::read::{read_all, Batch, ReadOptions};
use abba_store::Store;
use common::{person, TempDir};
use jiff::tz::TimeZone;

const HEADER: &str = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID";

/// A Clarity export of the EGVs from minute `from` to `to` (exclusive)
/// after 2026-05-04 00:00 Zurich, rows numbered from 1 as Clarity does,
/// with or without the transmitter's clock.
fn clarity(from: i64, to: i64, transmitter: bool) -> Vec<u8> {
    let mut s = format!(
        "{HEADER}\r\n1,,FirstName,,Test,,,,,,,,,\r\n2,,Device,,,Dexcom G6 Mobile App,android G6,,,,,,,\r\n"
    );
    let start = jiff::civil::date(2026, 5, 4).at(0, 0, 0, 0);
    for (index, m) in (3..).zip((from..to).step_by(5)) {
        let t = start + jiff::SignedDuration::from_mins(m);
        let g = 120 + (m / 5 * 7) % 90;
        let tx = if transmitter {
            format!("{},8ABCDE", 4_000_000 + m * 60)
        } else {
            ",".to_string()
        };
        s.push_str(&format!(
            "{index},{},EGV,,,,android G6,{g},,,,,{tx}\r\n",
            t.strftime("%Y-%m-%dT%H:%M:%S")
        ));
    }
    s.into_bytes()
}

fn read(files: &[(&str, Vec<u8>)]) -> Batch {
    let opts = ReadOptions {
        tz: Some(TimeZone::get("Europe/Zurich").unwrap()),
        ..ReadOptions::default()
    };
    let inputs: Vec<(String, Vec<u8>)> = files
        .iter()
        .map(|(n, b)| (n.to_string(), b.clone()))
        .collect();
    read_all(&inputs, &opts).unwrap()
}

/// The time of import in these tests (the data are from May 2026).
fn now() -> jiff::Timestamp {
    "2026-06-01T00:00:00Z".parse().unwrap()
}

fn contents(store: &Store, name: &str) -> Vec<(jiff::Timestamp, String)> {
    let mut v: Vec<_> = store
        .records(name)
        .unwrap()
        .into_iter()
        .map(|r| (r.at, serde_json::to_string(&r.kind).unwrap()))
        .collect();
    v.sort();
    v
}

#[test]
fn two_overlapping_clarity_exports_each_numbered_from_1_import_to_the_union() {
    for transmitter in [true, false] {
        let dir = TempDir::new("union");
        let mut store = dir.store();
        store.create_person(&person("ana")).unwrap();
        // 400 readings, then 400 of which the first 200 are the same ones.
        let a = store
            .import_at(
                "ana",
                &read(&[("a.csv", clarity(0, 2000, transmitter))]),
                now(),
            )
            .unwrap();
        assert_eq!(a.added, 400, "{a:?}");
        let b = store
            .import_at(
                "ana",
                &read(&[("b.csv", clarity(1000, 3000, transmitter))]),
                now(),
            )
            .unwrap();
        assert_eq!(
            (b.added, b.known),
            (200, 200),
            "transmitter {transmitter}: {b:?}"
        );
        // Exactly the union: what one export of the whole span gives.
        let dir2 = TempDir::new("whole");
        let mut whole = dir2.store();
        whole.create_person(&person("ana")).unwrap();
        whole
            .import_at(
                "ana",
                &read(&[("all.csv", clarity(0, 3000, transmitter))]),
                now(),
            )
            .unwrap();
        assert_eq!(contents(&store, "ana"), contents(&whole, "ana"));
        assert_eq!(contents(&store, "ana").len(), 600);
    }
}

#[test]
fn a_row_repeated_inside_one_export_is_one_record_and_counted() {
    let mut bytes = clarity(0, 100, false);
    // The last row again under the next Index (as a real export did), and
    // another reading under a repeated Index.
    let text = String::from_utf8(bytes.clone()).unwrap();
    let last = text.lines().last().unwrap().to_string();
    let (_, rest) = last.split_once(',').unwrap();
    bytes.extend(format!("23,{rest}\r\n").bytes());
    bytes.extend(b"23,2026-05-04T01:42:00,EGV,,,,android G6,150,,,,,,\r\n");
    let batch = read(&[("r.csv", bytes)]);
    assert_eq!(batch.duplicates.get("cgm"), Some(&1));
    let dir = TempDir::new("repeat");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let s = store.import_at("ana", &batch, now()).unwrap();
    assert_eq!((s.added, s.duplicates_in_files), (21, 1), "{s:?}");
}

#[test]
fn the_migration_rekeys_index_identities_without_losing_a_record() {
    let dir = TempDir::new("rekey");
    let path = dir.0.join("abba.db");
    {
        let mut store = Store::open(&path).unwrap();
        store.create_person(&person("ana")).unwrap();
        store
            .import_at("ana", &read(&[("a.csv", clarity(0, 2000, false))]), now())
            .unwrap();
        // What the previous schema stored: each Clarity row keyed by its
        // Index, and a second import of the same readings under other
        // Index values (a re-export) kept as if new.
        drop(store);
        let conn = rusqlite::Connection::open(&path).unwrap();
        conn.execute_batch(
            "CREATE TEMP TABLE old AS SELECT * FROM record;
             DELETE FROM record;
             INSERT INTO record SELECT person_id, source, '{\"index\":' || (row_number() OVER (ORDER BY at_ms) + 2) || '}', at_ms, kind, origin, import_id FROM old;
             INSERT INTO record SELECT person_id, source, '{\"index\":' || (row_number() OVER (ORDER BY at_ms) + 1000) || '}', at_ms, kind, origin, import_id FROM old WHERE at_ms < (SELECT min(at_ms) + 3600000 FROM old);
             DROP TABLE old;",
        )
        .unwrap();
        // The later migrations' objects go too: the file is as the
        // previous schema left it (the person revision of migration 4, the
        // therapy changes and file evidence of migration 5, the Nightscout
        // link of migration 7, the sign-in links and sessions of 8, the
        // name skeletons of 9, the web forms' submissions of 10, the
        // Nightscout link's kept first sync of 11).
        let later: Vec<String> = conn
            .prepare("SELECT 'DROP TRIGGER ' || name FROM sqlite_master WHERE type = 'trigger' AND name LIKE 'rev\\_%' ESCAPE '\\'")
            .unwrap()
            .query_map([], |r| r.get(0))
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        for drop in later {
            conn.execute_batch(&drop).unwrap();
        }
        conn.execute_batch(
            "DROP TABLE IF EXISTS nightscout_staged; DROP TABLE IF EXISTS person_rev; DROP TABLE IF EXISTS therapy_change; DROP TABLE IF EXISTS file_evidence; DROP TABLE IF EXISTS nightscout_written; DROP TABLE IF EXISTS nightscout_mark; DROP TABLE IF EXISTS nightscout_link; DROP TABLE IF EXISTS signin_link; DROP TABLE IF EXISTS web_session; DROP TABLE IF EXISTS web_submission; DROP INDEX person_by_skeleton_folded; DROP INDEX person_by_skeleton_cased; ALTER TABLE person DROP COLUMN skeleton_folded; ALTER TABLE person DROP COLUMN skeleton_cased;",
        )
        .unwrap();
        let before = abba_store::schema::version_of(abba_store::schema::Step::Rekey) - 1;
        conn.pragma_update(None, "user_version", before).unwrap();
    }
    let count = |_: &Store, sql: &str| -> i64 {
        rusqlite::Connection::open(&path)
            .unwrap()
            .query_row(sql, [], |r| r.get(0))
            .unwrap()
    };
    let mut store = Store::open(&path).unwrap();
    assert_eq!(
        count(&store, "SELECT count(*) FROM record"),
        400,
        "the 12 re-exported rows are one record each"
    );
    assert_eq!(
        count(
            &store,
            "SELECT count(*) FROM record WHERE source_id LIKE '{\"index\"%'"
        ),
        0
    );
    let dir2 = TempDir::new("rekey-fresh");
    let mut fresh = dir2.store();
    fresh.create_person(&person("ana")).unwrap();
    fresh
        .import_at("ana", &read(&[("a.csv", clarity(0, 2000, false))]), now())
        .unwrap();
    assert_eq!(contents(&store, "ana"), contents(&fresh, "ana"));
    // Re-importing adds nothing; with transmitter times (other ids) neither.
    for transmitter in [false, true] {
        let again = store
            .import_at(
                "ana",
                &read(&[("a.csv", clarity(0, 2000, transmitter))]),
                now(),
            )
            .unwrap();
        assert_eq!((again.added, again.known), (0, 400), "{again:?}");
    }
}

#[test]
fn future_rows_are_refused_and_rows_before_day_1_stored_not_used() {
    let dir = TempDir::new("future");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap(); // day 1 = 2026-05-04
                                                  // 2026-05-03 20:00 .. 2026-05-05 04:00 Zurich, imported at 2026-05-04
                                                  // 12:00 UTC: the evening before day 1 is stored, not used; the future refused.
    let bytes = clarity(-240, 1680, false);
    let at: jiff::Timestamp = "2026-05-04T12:00:00Z".parse().unwrap();
    let s = store
        .import_at("ana", &read(&[("f.csv", bytes)]), at)
        .unwrap();
    // Zurich is UTC+2: 12:00 UTC is 14:00 local, +10 min skew: 14:10.
    assert_eq!(s.before_day_1.count, 48, "{s:?}");
    assert_eq!(s.before_day_1.first.as_deref(), Some("f.csv: line 4"));
    assert_eq!(
        s.added,
        48 + 14 * 12 + 3,
        "20:00 the day before to 14:10 inclusive"
    );
    assert_eq!(s.future.count, 384 - s.added);
    assert!(s
        .future
        .first
        .as_deref()
        .unwrap()
        .starts_with("f.csv: line "));
    let total = s.added + s.future.count;
    assert_eq!(total, 384, "every reading accounted for");
    assert_eq!(store.records("ana").unwrap().len(), s.added);
    // The advisor uses those from day 1 only.
    let used = store.used_records("ana").unwrap();
    assert_eq!(used.records.len(), s.added - 48);
    assert_eq!(used.before_day_1.map(|b| b.0), Some(48));
}

#[test]
fn an_export_wholly_before_day_1_is_stored_and_said_not_used() {
    let dir = TempDir::new("before-day-1");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap(); // day 1 = 2026-05-04
    let at: jiff::Timestamp = "2026-05-04T12:00:00Z".parse().unwrap();
    let s = store
        .import_at("ana", &read(&[("old.csv", clarity(-240, 0, false))]), at)
        .unwrap();
    assert_eq!(
        (s.added, s.known, s.before_day_1.count),
        (48, 0, 48),
        "{s:?}"
    );
    let lines = s.lines("ana");
    assert!(
        lines[0].starts_with("Imported 48 new records for ana"),
        "{lines:?}"
    );
    assert!(
        lines.iter().any(|l| l.starts_with(
            "48 records dated before day 1 (2026-05-04): stored, not used by the advisor; the first: old.csv: line 4"
        )),
        "{lines:?}"
    );
    assert_eq!(store.records("ana").unwrap().len(), 48);
    assert!(store.used_records("ana").unwrap().records.is_empty());
    // One record is one record.
    let one = store
        .import_at("ana", &read(&[("one.csv", clarity(0, 5, false))]), at)
        .unwrap();
    assert_eq!(one.added, 1, "{one:?}");
    let again = store
        .import_at("ana", &read(&[("one.csv", clarity(0, 5, false))]), at)
        .unwrap();
    assert_eq!(
        again.lines("ana")[0],
        "Nothing new: 1 record of one.csv is already in ana's log."
    );
}

#[test]
fn an_export_wholly_in_the_future_is_an_error_and_imports_nothing() {
    // A device clock a year ahead, or an export read in the wrong zone: not
    // "nothing new" with a count, but an error naming the first record.
    let dir = TempDir::new("all-future");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let bytes = clarity(0, 1440, false);
    let before: jiff::Timestamp = "2026-05-03T12:00:00Z".parse().unwrap();
    let e = store
        .import_at("ana", &read(&[("late.csv", bytes.clone())]), before)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("every record of late.csv that abba would keep is dated after the time of import (2026-05-03T12:00:00Z): 288 records, the first late.csv: line "),
        "{e}"
    );
    assert!(e.ends_with("Nothing was imported"), "{e}");
    assert!(store.history("ana").unwrap().is_empty());
    // The same file once its days have come: imported whole.
    let s = store
        .import_at("ana", &read(&[("late.csv", bytes)]), now())
        .unwrap();
    assert_eq!((s.added, s.future.count), (288, 0));
}

#[test]
fn a_header_only_export_says_no_readings() {
    let dir = TempDir::new("empty");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let e = store
        .import_at("ana", &read(&[("empty.csv", clarity(0, 0, false))]), now())
        .unwrap_err();
    assert_eq!(e.to_string(), "no readings in empty.csv");
}

/// Nightscout entries of `n` readings every 5 min from 2026-05-04 06:00
/// UTC, by `device`, `offset_ms` after the sensor's time, ids `prefix`N.
fn nightscout_entries(n: i64, device: &str, offset_ms: i64, prefix: &str) -> Vec<u8> {
    let start = 1_777_874_400_000_i64; // 2026-05-04T06:00:00Z
    let docs: Vec<serde_json::Value> = (0..n)
        .rev()
        .map(|i| {
            let ms = start + i * 300_000 + offset_ms;
            serde_json::json!({"_id": format!("{prefix}{i}"), "device": device, "date": ms,
                "dateString": jiff::Timestamp::from_millisecond(ms).unwrap().to_string(),
                "sgv": 110 + (i * 7) % 60, "direction": "Flat", "type": "sgv"})
        })
        .collect();
    serde_json::to_vec(&docs).unwrap()
}

/// One sensor's readings uploaded by two Nightscout uploaders seconds
/// apart, the second's copies coming in a later import (the next sync):
/// known, not added again.
#[test]
fn a_nightscout_reading_uploaded_again_by_a_second_uploader_seconds_later_is_known() {
    let dir = TempDir::new("two_uploaders");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let a = store
        .import_at(
            "ana",
            &read(&[("a.json", nightscout_entries(24, "xDrip-DexcomG6", 0, "x"))]),
            now(),
        )
        .unwrap();
    assert_eq!(a.added, 24);
    let b = store
        .import_at(
            "ana",
            &read(&[("b.json", nightscout_entries(30, "share2", 9_000, "s"))]),
            now(),
        )
        .unwrap();
    assert_eq!((b.added, b.known), (6, 24), "{b:?}");
    assert_eq!(contents(&store, "ana").len(), 30);
}

/// A LibreView export (the Libre 3 layout of
/// crates/io/tests/data/libreview_libre3_synthetic.csv) of the readings
/// every 5 minutes of days `from` to `to` (exclusive) after 2026-05-04,
/// in mg/dL or in mmol/L with one decimal as the app writes them, and a
/// strip reading at 07:00 of each day.
fn libreview(from: i64, to: i64, mmol: bool) -> Vec<u8> {
    let unit = if mmol { "mmol/L" } else { "mg/dL" };
    let mut s = format!(
        "Glucose Data,Generated on,01-06-2026 09:40 UTC,Generated by,Test\r\nDevice,Serial Number,Device Timestamp,Record Type,Historic Glucose {unit},Scan Glucose {unit},Non-numeric Rapid-Acting Insulin,Rapid-Acting Insulin (units),Non-numeric Food,Carbohydrates (grams),Carbohydrates (servings),Non-numeric Long-Acting Insulin,Long-Acting Insulin Value (units),Notes,Strip Glucose {unit},Ketone mmol/L,Meal Insulin (units),Correction Insulin (units),User Change Insulin (units)\r\n"
    );
    let value = |mg: i64| {
        if mmol {
            format!("{:.1}", mg as f64 / 18.0)
        } else {
            mg.to_string()
        }
    };
    let start = jiff::civil::date(2026, 5, 4).at(0, 0, 0, 0);
    for m in (from * 1440..to * 1440).step_by(5) {
        let t = (start + jiff::SignedDuration::from_mins(m)).strftime("%d-%m-%Y %H:%M");
        let g = value(70 + (m / 5 * 7) % 200);
        s.push_str(&format!(
            "FreeStyle Libre 3,7F354325-542B-43DB-8E4C-F8FAF6F31CAC,{t},0,{g},,,,,,,,,,,,,,\r\n"
        ));
        if m % 1440 == 7 * 60 {
            let strip = value(95 + m / 1440);
            s.push_str(&format!(
                "FreeStyle Libre 3,7F354325-542B-43DB-8E4C-F8FAF6F31CAC,{t},2,,,,,,,,,,,{strip},,,,\r\n"
            ));
        }
    }
    s.into_bytes()
}

#[test]
fn a_reexport_in_mmol_after_one_in_mg_dl_adds_only_its_new_days() {
    // The person switched LibreView from mg/dL to mmol/L between two
    // exports: the week both cover is every reading of it again, 120 mg/dL
    // now 6.7 mmol/L (120.7 mg/dL), and must not be stored twice.
    let dir = TempDir::new("units");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let a = store
        .import_at("ana", &read(&[("a.csv", libreview(0, 14, false))]), now())
        .unwrap();
    assert_eq!(a.added, 14 * 289, "{a:?}");
    let first = contents(&store, "ana");
    let b = store
        .import_at("ana", &read(&[("b.csv", libreview(7, 21, true))]), now())
        .unwrap();
    assert_eq!(
        (b.added, b.known, b.other_unit),
        (7 * 289, 7 * 289, 7 * 289),
        "{b:?}"
    );
    assert!(
        b.lines("ana").iter().any(|l| l.contains("in another unit")),
        "{:?}",
        b.lines("ana")
    );
    // The stored readings of the overlap keep the first export's values.
    let after = contents(&store, "ana");
    assert_eq!(after.len(), 21 * 289);
    assert!(first.iter().all(|r| after.contains(r)));
    // The same export again: nothing new.
    let c = store
        .import_at("ana", &read(&[("b.csv", libreview(7, 21, true))]), now())
        .unwrap();
    assert_eq!((c.added, c.known), (0, 14 * 289), "{c:?}");
}

/// `clarity`'s export as the app writes it set to mmol/L: the units in the
/// header, each glucose value with one decimal.
fn in_mmol(mg_dl_export: Vec<u8>) -> Vec<u8> {
    let text = String::from_utf8(mg_dl_export).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        if let Ok(mg) = cells[7].parse::<f64>() {
            cells[7] = format!("{:.1}", mg / 18.0);
        }
        out.push_str(&cells.join(",").replace("(mg/dL", "(mmol/L"));
        out.push_str("\r\n");
    }
    out.into_bytes()
}

#[test]
fn a_clarity_reexport_in_mmol_is_neither_added_nor_a_newer_version() {
    for transmitter in [true, false] {
        let dir = TempDir::new("clarity-units");
        let mut store = dir.store();
        store.create_person(&person("ana")).unwrap();
        store
            .import_at(
                "ana",
                &read(&[("a.csv", clarity(0, 2000, transmitter))]),
                now(),
            )
            .unwrap();
        let first = contents(&store, "ana");
        let b = store
            .import_at(
                "ana",
                &read(&[("b.csv", in_mmol(clarity(1000, 3000, transmitter)))]),
                now(),
            )
            .unwrap();
        assert_eq!(
            (b.added, b.known, b.updated, b.other_unit),
            (200, 200, 0, 200),
            "transmitter {transmitter}: {b:?}"
        );
        let after = contents(&store, "ana");
        assert_eq!(after.len(), 600);
        assert!(first.iter().all(|r| after.contains(r)));
    }
}

/// Nightscout's `sgv` is always mg/dL: an entry rewritten 1 mg/dL higher
/// (an uploader's recalibration) is a newer version, not the same reading
/// in another unit.
#[test]
fn a_nightscout_entry_rewritten_by_1_mg_dl_is_a_newer_version() {
    let dir = TempDir::new("ns_rewrite");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let entries = nightscout_entries(24, "xDrip-DexcomG6", 0, "x");
    store
        .import_at("ana", &read(&[("a.json", entries.clone())]), now())
        .unwrap();
    let mut docs: Vec<serde_json::Value> = serde_json::from_slice(&entries).unwrap();
    docs[0]["sgv"] = (docs[0]["sgv"].as_i64().unwrap() + 1).into();
    let b = store
        .import_at(
            "ana",
            &read(&[("b.json", serde_json::to_vec(&docs).unwrap())]),
            now(),
        )
        .unwrap();
    assert_eq!((b.updated, b.known, b.other_unit), (1, 23, 0), "{b:?}");
}

/// Both exports given to one import, the first in mg/dL and the second in
/// mmol/L: the week they share is read once (the first file's values).
#[test]
fn two_exports_in_two_units_imported_together_give_their_union() {
    let batch = read(&[
        ("a.csv", libreview(0, 14, false)),
        ("b.csv", libreview(7, 21, true)),
    ]);
    assert_eq!(batch.duplicates.values().sum::<usize>(), 7 * 289);
    let dir = TempDir::new("units-together");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let s = store.import_at("ana", &batch, now()).unwrap();
    assert_eq!(
        (s.added, s.duplicates_in_files),
        (21 * 289, 7 * 289),
        "{s:?}"
    );
    let dir2 = TempDir::new("units-apart");
    let mut apart = dir2.store();
    apart.create_person(&person("ana")).unwrap();
    for (name, bytes) in [
        ("a.csv", libreview(0, 14, false)),
        ("b.csv", libreview(7, 21, true)),
    ] {
        apart
            .import_at("ana", &read(&[(name, bytes)]), now())
            .unwrap();
    }
    assert_eq!(contents(&store, "ana"), contents(&apart, "ana"));
}
