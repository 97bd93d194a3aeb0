//! What loop apps upload to Nightscout, in their real layouts (fixtures
//! with made-up values, see PROVENANCE.md): AndroidAPS in open loop (its
//! running mode OPEN_LOOP, device status with `suggested` and seldom
//! `enacted`), copies of one pump event uploaded twice, primes beside a
//! real bolus, Trio's external insulin.

use crate::common;
use abba_io::automation::{Delivery, Evidence};
use abba_io::read::nightscout::{PRIME, SITE_CHANGE_PRIME};
use abba_io::record::{RecordKind, TempRate};
use common::{fixture, opts, read};

const OPEN: &str = "nightscout_treatments_aaps_open_loop_synthetic.json";
const STATUS: &str = "nightscout_devicestatus_aaps_open_loop_synthetic.json";
const COPIES: &str = "nightscout_treatments_aaps_copies_synthetic.json";
const PRIMES: &str = "nightscout_treatments_primes_synthetic.json";

/// The evidence abba counts for `files` (records and each file's own).
/// One of the evidence's words holds `text`.
fn assert_says(e: &Evidence, text: &str) {
    assert!(
        e.words().iter().any(|w| w.contains(text)),
        "{:?}",
        e.words()
    );
}

fn evidence(files: &[(&str, Vec<u8>)]) -> Evidence {
    let b = read(files, &opts("Europe/Zurich")).unwrap();
    let mut e = Evidence::from_records(&b.records, &abba_io::time::zone("Europe/Zurich").unwrap());
    for (_, bytes) in files {
        e.add_file(&Evidence::from_file(bytes));
    }
    e
}

#[test]
fn androidaps_in_open_loop_is_open_loop_pump_therapy() {
    let e = evidence(&[
        ("treatments.json", fixture(OPEN)),
        ("devicestatus.json", fixture(STATUS)),
    ]);
    // AndroidAPS is named and its device status counted, as for a loop.
    assert!(
        e.systems.contains_key("androidaps") && e.systems.contains_key("devicestatus.openaps"),
        "{e:?}"
    );
    // Its running mode says open loop; the temporary suspension says nothing.
    assert_eq!(e.open_loop_modes, 1, "{e:?}");
    // The suggestions the person accepted: 6 short temporary basals in 6 of
    // the pump's hours, far from most hours.
    assert_eq!(
        (
            e.temp_basals,
            e.hours_with_short_temp,
            e.smb,
            e.automated_basal
        ),
        (6, 6, 0, 0),
        "{e:?}"
    );
    assert_eq!(e.delivery(), Delivery::OpenLoop, "{:?}", e.words());
    assert_says(&e, "a loop app in open loop (1 record of open loop; the latest record of its mode: AndroidAPS's running mode OPEN_LOOP");
}

#[test]
fn androidaps_closed_or_without_a_running_mode_is_a_closed_loop() {
    let open = String::from_utf8(fixture(OPEN)).unwrap();
    let status = fixture(STATUS);
    // Closed: its running mode CLOSED_LOOP (or CLOSED_LOOP_LGS).
    for mode in ["CLOSED_LOOP", "CLOSED_LOOP_LGS"] {
        let closed = open.replace("\"mode\":\"OPEN_LOOP\"", &format!("\"mode\":\"{mode}\""));
        let e = evidence(&[("t.json", closed.into_bytes()), ("d.json", status.clone())]);
        assert_eq!(
            e.delivery(),
            Delivery::ClosedLoop,
            "{mode}: {:?}",
            e.words()
        );
        assert_eq!(
            e.systems.get(&format!("AndroidAPS's running mode {mode}")),
            Some(&1)
        );
    }
    // Open, but after it closed: the closed mode holds.
    let both = open.replacen(
        "[\n",
        "[\n  {\"_id\":\"6735c1a2e4b0f81d9cffff01\",\"created_at\":\"2026-11-18T21:00:00.000Z\",\"enteredBy\":\"openaps://AAPS\",\"eventType\":\"OpenAPS Offline\",\"isValid\":true,\"duration\":0,\"durationInMilliseconds\":0,\"originalDuration\":0,\"mode\":\"CLOSED_LOOP\",\"utcOffset\":0},\n",
        1,
    );
    let e = evidence(&[("t.json", both.into_bytes()), ("d.json", status.clone())]);
    assert_eq!(e.delivery(), Delivery::ClosedLoop, "{:?}", e.words());
    assert_says(&e, "latest mode is closed loop (AndroidAPS's running mode CLOSED_LOOP at 2026-11-18T21:00:00Z)");
    // An OPEN_LOOP AndroidAPS forced for a while (originalDuration) says
    // nothing of the mode after it.
    let forced = open.replace(
        "\"originalDuration\":0,\"mode\":\"OPEN_LOOP\"",
        "\"originalDuration\":3600000,\"mode\":\"OPEN_LOOP\"",
    );
    let e = evidence(&[("t.json", forced.into_bytes()), ("d.json", status.clone())]);
    assert_eq!(
        (e.open_loop_modes, e.delivery()),
        (0, Delivery::ClosedLoop),
        "{:?}",
        e.words()
    );
    // No running mode (AndroidAPS before 3.4): the safe side, said so.
    let mut docs: Vec<serde_json::Value> = serde_json::from_str(&open).unwrap();
    docs.retain(|d| d["mode"] != "OPEN_LOOP");
    let none = serde_json::to_vec(&docs).unwrap();
    let e = evidence(&[("t.json", none), ("d.json", status.clone())]);
    assert_eq!(e.delivery(), Delivery::ClosedLoop, "{:?}", e.words());
    assert_says(&e, "no record of its running mode");
    // In open loop, an SMB still closes it (AndroidAPS gives SMBs only closed).
    let smb = open.replacen(
        "[\n",
        "[\n  {\"_id\":\"6735c1a2e4b0f81d9cffff02\",\"eventType\":\"Correction Bolus\",\"insulin\":0.3,\"created_at\":\"2026-11-18T21:05:00.000Z\",\"date\":1795035900000,\"type\":\"SMB\",\"notes\":\"\",\"isValid\":true,\"isSMB\":true,\"pumpId\":99001,\"pumpType\":\"DANA_RS\",\"pumpSerial\":\"SYNTHDRS07\",\"utcOffset\":0},\n",
        1,
    );
    let e = evidence(&[("t.json", smb.into_bytes()), ("d.json", status)]);
    assert_eq!(e.delivery(), Delivery::ClosedLoop, "{:?}", e.words());
}

/// The non-CGM records of a batch as (UTC time, kind).
fn kinds(b: &abba_io::Batch) -> Vec<(String, RecordKind)> {
    b.records
        .iter()
        .filter(|r| r.kind.name() != "cgm")
        .map(|r| (r.at.to_string(), r.kind.clone()))
        .collect()
}

fn bolus(u: f64) -> RecordKind {
    RecordKind::Bolus {
        units: abba_core::Units(u),
    }
}

#[test]
fn copies_of_one_pump_event_are_one_event() {
    let b = read(
        &[("treatments.json", fixture(COPIES))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    let k = kinds(&b);
    // The meal bolus uploaded by API v1 and again by v3, 4 s apart: once.
    let meal: Vec<_> = k
        .iter()
        .filter(|(t, _)| t.starts_with("2026-11-20T06:12"))
        .collect();
    assert_eq!(meal.len(), 1, "{k:?}");
    assert_eq!(meal[0].1, bolus(3.5));
    // The temporary basal cut short: the version AndroidAPS rewrote last.
    let temp: Vec<_> = k
        .iter()
        .filter(|(t, _)| t.starts_with("2026-11-20T14:40"))
        .collect();
    assert_eq!(
        temp.iter().map(|(_, k)| k.clone()).collect::<Vec<_>>(),
        vec![RecordKind::TempBasal {
            rate: TempRate::Absolute(abba_core::UnitsPerHour(0.45)),
            duration_min: 12
        }],
        "{k:?}"
    );
    // Two v1 copies that differ and no stamp: neither read, both reported.
    assert!(
        !k.iter().any(|(t, _)| t.starts_with("2026-11-20T16:05")),
        "{k:?}"
    );
    assert_eq!(b.unread.count, 2, "{:?}", b.unread);
    let first = b.unread.first[0].to_string();
    assert!(
        first.contains("treatments.json")
            && first.contains("pumpId")
            && first.contains("4.0")
            && first.contains("no srvModified"),
        "{first}"
    );
    // The same pumpId on another pump is another event.
    assert!(
        k.iter()
            .any(|(t, kind)| t.starts_with("2026-11-20T18:30") && *kind == bolus(5.1)),
        "{k:?}"
    );
    let total: f64 = k
        .iter()
        .filter_map(|(_, kind)| match kind {
            RecordKind::Bolus { units } => Some(units.0),
            _ => None,
        })
        .sum();
    assert!((total - 8.6).abs() < 1e-9, "{total}: {k:?}");
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("2 documents repeat a pump event")),
        "{:?}",
        b.notes
    );
}

#[test]
fn primes_are_counted_never_read_as_boluses() {
    let b = read(
        &[("treatments.json", fixture(PRIMES))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    let k = kinds(&b);
    let boluses: Vec<_> = k
        .iter()
        .filter(|(_, k)| matches!(k, RecordKind::Bolus { .. }))
        .collect();
    assert_eq!(boluses.len(), 1, "{k:?}");
    assert_eq!(boluses[0].1, bolus(4.2));
    for kind in [PRIME, SITE_CHANGE_PRIME] {
        assert!(
            k.iter()
                .any(|(_, k)| matches!(k, RecordKind::Ignored { kind: i } if i == kind)),
            "{kind}: {k:?}"
        );
    }
}

#[test]
fn trios_external_insulin_is_a_dose() {
    let json = br#"[{"_id":"673f9c10c4e5f6a7b8c9d001","eventType":"External Insulin","created_at":"2026-11-21T12:30:00.000Z","enteredBy":"Trio","insulin":3,"utcOffset":0},
        {"_id":"673f9c10c4e5f6a7b8c9d002","eventType":"SMB","created_at":"2026-11-21T12:45:00.000Z","enteredBy":"Trio","insulin":0.2,"isSMB":true,"utcOffset":0}]"#;
    let b = read(
        &[("treatments.json", json.to_vec())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    let k = kinds(&b);
    assert_eq!(
        k,
        vec![
            ("2026-11-21T12:30:00Z".to_string(), bolus(3.0)),
            ("2026-11-21T12:45:00Z".to_string(), bolus(0.2)),
        ]
    );
}

/// Loop's boluses in NightscoutKit's layout (`created_at` and `timestamp`,
/// `type` normal or square, `insulin`, `programmed`, `unabsorbed`,
/// `duration` in minutes, `automatic`, `syncIdentifier`, `insulinType`):
/// a square bolus runs over its duration, nothing given at once.
#[test]
fn loops_square_bolus_is_an_extended_bolus() {
    let json = br#"[{"created_at":"2026-11-21T18:10:00Z","timestamp":"2026-11-21T18:10:00Z","enteredBy":"loop://iPhone","eventType":"Correction Bolus","insulinType":"Fiasp","syncIdentifier":"5a4e1c0b9d8f7e6a","type":"square","insulin":2.4,"programmed":2.4,"unabsorbed":0,"duration":90,"automatic":false,"utcOffset":0,"_id":"673fa0d1e2f3a4b5c6d7e801"},
        {"created_at":"2026-11-21T12:05:00Z","timestamp":"2026-11-21T12:05:00Z","enteredBy":"loop://iPhone","eventType":"Correction Bolus","insulinType":"Fiasp","syncIdentifier":"1f2e3d4c5b6a7988","type":"normal","insulin":3.1,"programmed":3.1,"unabsorbed":0,"duration":0.03,"automatic":false,"utcOffset":0,"_id":"673fa0d1e2f3a4b5c6d7e802"}]"#;
    let b = read(
        &[("treatments.json", json.to_vec())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(
        kinds(&b),
        vec![
            ("2026-11-21T12:05:00Z".to_string(), bolus(3.1)),
            (
                "2026-11-21T18:10:00Z".to_string(),
                RecordKind::ExtendedBolus {
                    now: abba_core::Units(0.0),
                    extended: abba_core::Units(2.4),
                    duration_min: 90
                }
            ),
        ]
    );
}

/// Trio writes the pump's suspensions and resumes as Notes named after the
/// history event; they are the pump stopping and starting, not notes.
#[test]
fn trios_suspend_and_resume_notes_are_the_pump_stopping_and_starting() {
    let json = br#"[{"eventType":"Note","created_at":"2026-11-21T16:20:41.000Z","enteredBy":"Trio","notes":"PumpResume","utcOffset":0,"_id":"673fb1e2f3a4b5c6d7e8f902"},
        {"eventType":"Note","created_at":"2026-11-21T15:52:03.000Z","enteredBy":"Trio","notes":"PumpSuspend","utcOffset":0,"_id":"673fb1e2f3a4b5c6d7e8f901"},
        {"eventType":"Note","created_at":"2026-11-21T15:00:00.000Z","enteredBy":"Trio","notes":"PumpSuspend at lunch?","utcOffset":0,"_id":"673fb1e2f3a4b5c6d7e8f900"}]"#;
    let b = read(
        &[("treatments.json", json.to_vec())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(
        kinds(&b),
        vec![
            (
                "2026-11-21T15:00:00Z".to_string(),
                RecordKind::Ignored {
                    kind: "Note".into()
                }
            ),
            (
                "2026-11-21T15:52:03Z".to_string(),
                RecordKind::Suspend { duration_min: None }
            ),
            ("2026-11-21T16:20:41Z".to_string(), RecordKind::Resume),
        ]
    );
}

/// AndroidAPS's NSClientV3 names itself in `app`, not `enteredBy`.
#[test]
fn androidaps_v3_documents_name_it_in_app() {
    let json = br#"[{"identifier":"5d2e8c1a-0b7f-4e3d-9c6a-1f0e2d3c4b5a","date":1795268400000,"utcOffset":60,"app":"AAPS","eventType":"Temp Basal","isValid":true,"duration":30,"durationInMilliseconds":1800000,"type":"NORMAL","rate":0.6,"absolute":0.6,"pumpId":61001,"pumpType":"OMNIPOD_DASH","pumpSerial":"SYNTH0D44","srvModified":1795268401000,"srvCreated":1795268401000}]"#;
    let e = Evidence::from_file(json);
    assert_eq!(e.systems.get("aaps"), Some(&1), "{e:?}");
}

/// A document rewritten under its own `_id` (AndroidAPS's NSClient updates
/// a temporary basal it cut short) is one document in two versions, not
/// two copies: the last in the file is kept, as for any `_id`.
#[test]
fn a_document_rewritten_under_its_own_id_is_not_refused_as_copies() {
    let json = br#"[{"_id":"673fc0a1b2c3d4e5f6a7b801","created_at":"2026-11-21T10:00:00.000Z","enteredBy":"openaps://AndroidAPS","eventType":"Temp Basal","isValid":true,"duration":30,"durationInMilliseconds":1800000,"type":"NORMAL","rate":0.5,"absolute":0.5,"pumpId":70001,"pumpType":"DANA_RS","pumpSerial":"SYNTHDRS07","utcOffset":0},
        {"_id":"673fc0a1b2c3d4e5f6a7b801","created_at":"2026-11-21T10:00:00.000Z","enteredBy":"openaps://AndroidAPS","eventType":"Temp Basal","isValid":true,"duration":9,"durationInMilliseconds":540000,"type":"NORMAL","rate":0.5,"absolute":0.5,"pumpId":70001,"endId":70002,"pumpType":"DANA_RS","pumpSerial":"SYNTHDRS07","utcOffset":0}]"#;
    let b = read(
        &[("treatments.json", json.to_vec())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(b.unread.count, 0, "{:?}", b.unread);
    assert_eq!(
        kinds(&b),
        vec![(
            "2026-11-21T10:00:00Z".to_string(),
            RecordKind::TempBasal {
                rate: TempRate::Absolute(abba_core::UnitsPerHour(0.5)),
                duration_min: 9
            }
        )]
    );
}

/// An automatic document is an automatic bolus only when it carries a dose:
/// Nightscout's v1 API serves `insulin` on every treatment, `null` where
/// the uploader wrote none, so the key alone counts nothing.
#[test]
fn an_automatic_document_without_a_dose_is_no_automatic_bolus() {
    let dose = br#"[{"_id":"673fd0a1b2c3d4e5f6a7b901","created_at":"2026-11-21T07:35:00.000Z","enteredBy":"loop://iPhone","eventType":"Correction Bolus","type":"normal","insulin":0.35,"programmed":0.35,"duration":0.05,"automatic":true,"carbs":null,"utcOffset":0}]"#;
    assert_eq!(Evidence::from_file(dose).smb, 1);
    let no_dose = br#"[{"_id":"673fd0a1b2c3d4e5f6a7b902","created_at":"2026-11-21T07:40:00.000Z","enteredBy":"loop://iPhone","eventType":"Correction Bolus","type":"normal","insulin":null,"automatic":true,"carbs":null,"utcOffset":0}]"#;
    let e = Evidence::from_file(no_dose);
    assert_eq!((e.smb, e.automated_basal), (0, 0), "{e:?}");
}
