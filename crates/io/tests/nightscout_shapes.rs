//! Nightscout's other shapes: the device status of a loop or an uploader,
//! an API v3 answer, and Nightscout's own headerless CSV and TSV of
//! entries.

use crate::common::{fixture, opts, read};
use abba_io::automation::{Delivery, Evidence};
use abba_io::record::{RecordKind, SourceId};
use abba_io::Format;

fn ignored(b: &abba_io::Batch) -> Vec<String> {
    b.records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Ignored { kind } => Some(kind.clone()),
            _ => None,
        })
        .collect()
}

#[test]
fn device_status_is_counted_and_a_loops_marks_the_closed_loop() {
    let bytes = fixture("nightscout_devicestatus_synthetic.json");
    let b = read(&[("devicestatus.json", bytes.clone())], &opts("UTC")).unwrap();
    assert_eq!(b.formats, [Format::Nightscout]);
    let mut kinds = ignored(&b);
    kinds.sort();
    assert_eq!(
        kinds,
        [
            "devicestatus",
            "devicestatus of a closed loop (loop)",
            "devicestatus of a closed loop (openaps)"
        ]
    );
    assert_eq!(b.records.len(), 3, "nothing else is read from them");
    // The loop's status is what tells the closed loop: Loop's `loop`,
    // AndroidAPS's `openaps`; the 600-series uploader's pump status alone
    // is not a loop.
    let e = Evidence::from_file(&bytes);
    assert_eq!(e.systems.get("devicestatus.loop"), Some(&1));
    assert_eq!(e.systems.get("devicestatus.openaps"), Some(&1));
    let mut with_entries = Evidence::from_records(&b.records, &jiff::tz::TimeZone::UTC);
    with_entries.add_file(&e);
    assert_eq!(with_entries.delivery(), Delivery::ClosedLoop);
    let uploader_only = br#"[{"_id":"a","created_at":"2026-03-18T17:00:12Z","device":"medtronic-600://6213-1","pump":{"reservoir":96},"uploaderBattery":38}]"#;
    let e = Evidence::from_file(uploader_only);
    assert!(e.systems.is_empty() && e.smb == 0, "{e:?}");
    assert_ne!(e.delivery(), Delivery::ClosedLoop);
}

#[test]
fn an_api_v3_answer_is_read_as_its_result_named_by_identifier() {
    let b = read(
        &[("v3.json", fixture("nightscout_entries_v3_synthetic.json"))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!((b.count("cgm"), b.count("smbg")), (2, 1));
    // API v3 names a document created through v1 by its `_id` as
    // `identifier`: the same id as the v1 document's, so a later import of
    // the v1 file finds them known.
    let ids: Vec<String> = b
        .records
        .iter()
        .map(|r| match &r.id {
            SourceId::Id(s) => s.to_string(),
            SourceId::Hash(h) => format!("hash {h}"),
        })
        .collect();
    assert_eq!(
        ids,
        [
            "0f6a2b7e-3c2d-4d55-9e1f-1b2c3d4e5f60",
            "67d9a7c4c2a1b30012a4e29f",
            "67d9a8f0c2a1b30012a4e2a0"
        ]
    );
    let v1 = br#"[{"_id":"67d9a8f0c2a1b30012a4e2a0","date":1773854400000,"sgv":141,"type":"sgv"}]"#;
    let one = read(&[("v1.json", v1.to_vec())], &opts("UTC")).unwrap();
    assert_eq!(one.records[0].id, b.records[2].id);
    assert_eq!(one.records[0].kind, b.records[2].kind);
    // A single document's answer: its result is one object.
    let single = br#"{"status":200,"result":{"identifier":"x1","date":1773854400000,"sgv":150,"type":"sgv"}}"#;
    let b = read(&[("one.json", single.to_vec())], &opts("UTC")).unwrap();
    assert_eq!(b.count("cgm"), 1);
}

#[test]
fn nightscouts_own_csv_and_tsv_of_entries_are_read_by_their_date() {
    for (name, tz) in [
        ("nightscout_entries_synthetic.csv", "Europe/Zurich"),
        ("nightscout_entries_synthetic.tsv", "America/New_York"),
    ] {
        let b = read(&[(name, fixture(name))], &opts(tz)).unwrap();
        assert_eq!(b.formats, [Format::Nightscout], "{name}");
        let cgm: Vec<(String, f64)> = b
            .records
            .iter()
            .filter_map(|r| match r.kind {
                RecordKind::Cgm { glucose } => Some((r.at.to_string(), glucose.mg_dl.0)),
                _ => None,
            })
            .collect();
        // Times from `date` (ms), whatever the zone and the dateString's
        // wording; Dexcom's error code 5 counted, not read.
        assert_eq!(cgm.len(), 3, "{name}: {cgm:?}");
        assert_eq!(cgm[cgm.len() - 1], ("2026-03-18T17:20:00Z".into(), 141.0));
        assert!(
            b.notes.iter().any(|n| n.contains("error codes")),
            "{name}: {:?}",
            b.notes
        );
    }
    // The CSV's line without an sgv (a meter reading) is counted, with a note.
    let b = read(
        &[("e.csv", fixture("nightscout_entries_synthetic.csv"))],
        &opts("UTC"),
    )
    .unwrap();
    assert!(
        b.notes.iter().any(|n| n.contains("1 lines without an sgv")),
        "{:?}",
        b.notes
    );
    // A bad cell names its line.
    let bad = "\"2026-03-18T17:20:00.000Z\",1773854400000,141,\"Flat\",\"x\"\n\"2026-03-18T17:15:00.000Z\",1773854100000,9999,\"Flat\",\"x\"\n";
    let (b, e) = crate::common::read_in_part(&[("e.csv", bad.into())], &opts("UTC"));
    assert_eq!(b.count("cgm"), 1);
    assert!(
        e.starts_with("e.csv: line 2, field \"sgv (the third cell)\""),
        "{e}"
    );
}

/// A Profile Switch that only names its profile (Nightscout's Careportal
/// writes `profile` and `duration`, no `profileJson`) is not applied, and
/// the file's note says so, naming where the first one is: the person is
/// not left believing the switch was followed.
#[test]
fn a_profile_switch_that_only_names_its_profile_is_said_not_applied() {
    let t = br#"[
      {"_id": "t1", "eventType": "Correction Bolus", "created_at": "2026-12-01T10:00:00.000Z", "insulin": 1.0},
      {"_id": "t2", "eventType": "Profile Switch", "created_at": "2026-12-01T11:00:00.000Z",
       "profile": "Sport", "duration": 0, "enteredBy": "careportal"}
    ]"#;
    let b = read(&[("treatments.json", t.to_vec())], &opts("UTC")).unwrap();
    assert_eq!(ignored(&b), ["Profile Switch (profile not embedded)"]);
    let note = b
        .notes
        .iter()
        .find(|n| n.contains("without embedding"))
        .unwrap_or_else(|| panic!("{:?}", b.notes));
    assert!(
        note.contains("1 Profile Switches")
            && note.contains("$[1]")
            && note.contains("not applied"),
        "{note}"
    );
}

/// One sensor's readings uploaded by two uploaders (xDrip+ and Juggluco,
/// each with its own clock and layout: xDrip+'s `dateString` and `sysTime`
/// with a `+0100` offset, `filtered`, `unfiltered`, `noise`, `utcOffset`;
/// Juggluco's in UTC) a few seconds apart, each its own document: every
/// reading is read once, the copies counted. Readings a minute apart (a
/// FreeStyle Libre 3) stay two, even of one value.
#[test]
fn one_reading_uploaded_by_two_uploaders_seconds_apart_is_read_once() {
    let start = 1_795_856_400_000_i64; // 2026-11-28T06:20:00Z
    let mut docs = Vec::new();
    for i in 0..6_i64 {
        let ms = start + i * 300_000 + 123;
        let t = jiff::Timestamp::from_millisecond(ms).unwrap();
        let local = t
            .to_zoned(jiff::tz::TimeZone::get("Europe/Zurich").unwrap())
            .strftime("%Y-%m-%dT%H:%M:%S%.3f%z")
            .to_string();
        let sgv = 120 + i * 3;
        docs.push(serde_json::json!({"_id": format!("x{i}"), "device": "xDrip-DexcomG6",
            "date": ms, "dateString": local, "sysTime": local, "sgv": sgv, "delta": 3.0,
            "direction": "FortyFiveUp", "type": "sgv", "filtered": 151000 + i, "unfiltered": 150000 + i,
            "rssi": 100, "noise": 1, "utcOffset": 60}));
        let j = ms + 4_000;
        docs.push(
            serde_json::json!({"_id": format!("j{i}"), "device": "Juggluco",
            "date": j, "dateString": jiff::Timestamp::from_millisecond(j).unwrap().to_string(),
            "sgv": sgv, "direction": "FortyFiveUp", "type": "sgv"}),
        );
    }
    // A Libre 3 read every minute: one value twice, 60 s apart.
    for (n, ms) in [(0, start - 120_000), (1, start - 60_000)] {
        docs.push(
            serde_json::json!({"_id": format!("l{n}"), "device": "Juggluco",
            "date": ms, "sgv": 118, "type": "sgv"}),
        );
    }
    docs.sort_by_key(|d| -d["date"].as_i64().unwrap());
    let b = read(
        &[("entries.json", serde_json::to_vec(&docs).unwrap())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(b.count("cgm"), 8, "{:?}", b.cross_upload);
    assert_eq!(b.cross_upload.get("cgm"), Some(&6));
    // The copy kept is the earlier one (xDrip+'s).
    let first = b
        .records
        .iter()
        .find(|r| r.at.as_millisecond() == start + 123);
    assert!(first.is_some_and(|r| r.id == SourceId::Id("x0".into())));
}
