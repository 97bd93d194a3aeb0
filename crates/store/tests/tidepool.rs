//! Tidepool exports in the store: the JSON and the Excel export of the
//! same data, imported one after the other (either order) or together, hold
//! each datum once, nothing added, updated or lost the second time; pump
//! settings changed mid-export put the new therapy in force from their
//! time, and the advice after it is judged against it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{person, read, TempDir};
use crate::tidepool_workbook::{person_data, workbook, Options};
use abba_advisor::{Mode, Parameter, PumpSteps};
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_store::person::TherapySource;
use abba_store::NewPerson;
use serde_json::{json, Value};

fn json() -> (String, Vec<u8>) {
    (
        "TidepoolExport.json".into(),
        serde_json::to_vec(&person_data()).unwrap(),
    )
}

fn xlsx(bg_units: &'static str) -> (String, Vec<u8>) {
    (
        "TidepoolExport.xlsx".into(),
        workbook(
            &person_data(),
            &Options {
                bg_units,
                ..Options::default()
            },
        ),
    )
}

#[test]
fn the_workbook_after_the_json_adds_nothing() {
    for bg_units in ["mg/dL", "mmol/L"] {
        let dir = TempDir::new("tp-xlsx");
        let mut store = dir.store();
        store.create_person(&person("ana")).unwrap();
        let first = store.import("ana", &read(&[json()]).unwrap()).unwrap();
        assert!(first.added > 860, "{first:?}");
        let rows = dir.rows("record");
        let again = store
            .import("ana", &read(&[xlsx(bg_units)]).unwrap())
            .unwrap();
        assert_eq!(
            (again.added, again.updated, again.known),
            (0, 0, first.added),
            "{bg_units}: {again:?}"
        );
        assert_eq!(dir.rows("record"), rows, "{bg_units}");
    }
}

#[test]
fn the_json_after_the_workbook_adds_nothing_and_both_at_once_are_one() {
    let dir = TempDir::new("tp-xlsx-rev");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let first = store
        .import("ana", &read(&[xlsx("mg/dL")]).unwrap())
        .unwrap();
    let again = store.import("ana", &read(&[json()]).unwrap()).unwrap();
    assert_eq!((again.added, again.updated), (0, 0), "{again:?}");
    // Both files in one import: each datum once.
    let dir2 = TempDir::new("tp-xlsx-both");
    let mut store2 = dir2.store();
    store2.create_person(&person("ana")).unwrap();
    let both = store2
        .import("ana", &read(&[json(), xlsx("mmol/L")]).unwrap())
        .unwrap();
    assert_eq!(both.added, first.added, "{both:?}");
    assert_eq!(dir2.rows("record"), dir.rows("record"));
}

const TZ: &str = "Europe/Zurich";
/// 2026-05-04T00:00 in Zurich (UTC+2).
const DAY1_MS: i64 = 1_777_845_600_000;

fn iso(ms: i64) -> String {
    jiff::Timestamp::from_millisecond(ms).unwrap().to_string()
}

/// Pump settings: basal (start minute, U/h) and one carb ratio, in
/// Tidepool's data model (ms from midnight).
fn settings(id: &str, ms: i64, basal: &[(i64, f64)], cr: f64) -> Value {
    let segs: Vec<Value> = basal
        .iter()
        .map(|&(m, r)| json!({"start": m * 60_000, "rate": r}))
        .collect();
    json!({"type": "pumpSettings", "id": id, "time": iso(ms), "timezoneOffset": 120,
        "activeSchedule": "Standard", "basalSchedules": {"Standard": segs},
        "carbRatio": [{"start": 0, "amount": cr}], "units": {"carb": "grams", "bg": "mg/dL"}})
}

const A: [(i64, f64); 2] = [(0, 0.8), (360, 1.0)];
const B: [(i64, f64); 2] = [(0, 1.0), (360, 1.3)];

/// 14 days of a pump and CGM in Tidepool's data model: readings every 5
/// minutes (mmol/L), three meals a day through the wizard with their
/// boluses, the scheduled basal delivered; the pump's settings read at
/// three uploads, A on days 0 and 3, then B (a new basal schedule and carb
/// ratio) from day 7 at 12:00 local.
fn changed_mid_export() -> Vec<Value> {
    let change = DAY1_MS + 7 * 86_400_000 + 12 * 3_600_000;
    let mut v = vec![
        settings("ps-a0", DAY1_MS, &A, 10.0),
        settings("ps-a3", DAY1_MS + 3 * 86_400_000, &A, 10.0),
        settings("ps-b7", change, &B, 12.0),
    ];
    let mut n = 0;
    let mut id = |p: &str| {
        n += 1;
        format!("{p}{n}")
    };
    for day in 0..14 {
        let base = DAY1_MS + day * 86_400_000;
        for k in 0..288i64 {
            let ms = base + k * 300_000;
            let m = (k * 5) as f64;
            let mg = 140.0 + 40.0 * (m / 240.0 + day as f64).sin();
            v.push(
                json!({"type": "cbg", "id": id("c"), "time": iso(ms), "timezoneOffset": 120,
                "value": mg / 18.01559, "units": "mmol/L"}),
            );
        }
        for (minute, carbs) in [
            (7 * 60 + 2, 45.0),
            (12 * 60 + 17, 60.0),
            (18 * 60 + 32, 70.0),
        ] {
            let ms = base + minute * 60_000;
            let bolus = id("bo");
            v.push(
                json!({"type": "wizard", "id": id("w"), "time": iso(ms), "timezoneOffset": 120,
                "carbInput": carbs, "bolus": bolus, "units": "mmol/L"}),
            );
            v.push(
                json!({"type": "bolus", "subType": "normal", "id": bolus, "time": iso(ms + 2_000),
                "timezoneOffset": 120, "normal": carbs / 10.0}),
            );
        }
        for (i, &(start, _)) in A.iter().enumerate() {
            let from = base + start * 60_000;
            let to = base + A.get(i + 1).map_or(1440, |s| s.0) * 60_000;
            let after = from >= change;
            let sched = if after { &B } else { &A };
            v.push(
                json!({"type": "basal", "deliveryType": "scheduled", "id": id("b"),
                "time": iso(from), "timezoneOffset": 120, "duration": to - from,
                "rate": sched[i].1, "scheduleName": "Standard"}),
            );
        }
    }
    v
}

/// A person whose therapy follows the pump's profile, created with A.
fn person_a() -> NewPerson {
    let mut s = TherapySettings::new(UnitsPerHour(0.95), GramsPerUnit(10.0)).unwrap();
    s.carb_ratio = [GramsPerUnit(10.0); 3];
    let mut p = NewPerson::new("tia", TZ, Mode::Cgm, s);
    p.first_day = Some("2026-05-04".parse().unwrap());
    p.settings.basal_schedule = Some(A.iter().map(|&(m, r)| (m as u32, r)).collect());
    p.settings.therapy_source = TherapySource::Profile;
    p.settings.pump_steps = Some(PumpSteps::default());
    p
}

#[test]
fn pump_settings_changed_mid_export_are_a_change_of_therapy_from_their_time() {
    let data = changed_mid_export();
    for (name, bytes) in [
        ("TidepoolExport.json", serde_json::to_vec(&data).unwrap()),
        (
            "TidepoolExport.xlsx",
            workbook(
                &data,
                &Options {
                    bg_units: "mg/dL",
                    ..Options::default()
                },
            ),
        ),
    ] {
        let dir = TempDir::new("tp-change");
        let mut store = dir.store();
        store.create_person(&person_a()).unwrap();
        let batch = read(&[(name.to_string(), bytes)]).unwrap();
        assert_eq!(batch.count("basal_schedule"), 3 + 14 * 2, "{name}");
        store.import("tia", &batch).unwrap();
        let a = store.advise("tia").unwrap();
        // One change: B from day 7 at 12:00 local; A again on day 3 is no change.
        assert_eq!(
            a.therapy.changes.len(),
            1,
            "{name}: {:?}",
            a.therapy.changes
        );
        assert!(
            a.therapy.changes[0].starts_with("from 2026-05-11 12:00 "),
            "{name}: {:?}",
            a.therapy.changes
        );
        // The schedule in force has B's shape (the advisor may have scaled it).
        let sched = a.therapy.basal_schedule.clone().expect("a schedule");
        let shape = sched[1].1 / sched[0].1;
        assert!((shape - 1.3).abs() < 0.03, "{name}: {sched:?}");
        // Decisions after the change start from B's carb ratio, not A's.
        let change = abba_io::clock::AdvisorClock::new(
            jiff::tz::TimeZone::get(TZ).unwrap(),
            "2026-05-04".parse().unwrap(),
        )
        .timestamp(
            jiff::Timestamp::from_millisecond(DAY1_MS + 7 * 86_400_000 + 12 * 3_600_000).unwrap(),
        );
        let decisions = store.decisions("tia").unwrap();
        let after: Vec<_> = decisions
            .iter()
            .filter(|d| d.at >= change && matches!(d.parameter, Parameter::CarbRatio(_)))
            .collect();
        assert!(
            !after.is_empty(),
            "{name}: no carb-ratio decision after the change"
        );
        assert_eq!(after[0].old, 12.0, "{name}: {}", after[0]);
        let before: Vec<_> = decisions
            .iter()
            .filter(|d| d.at < change && matches!(d.parameter, Parameter::CarbRatio(_)))
            .collect();
        assert!(before.iter().all(|d| d.old < 11.5), "{name}");
    }
}

/// A `pumpSettings` as Diabeloop's Tidepool data (tide-whisperer's
/// `usecase/converter_test.json`, used as a layout reference) carries it:
/// a long `payload.history` before its `type`, and an active schedule
/// whose basal rows the item does not hold. The export's first item.
fn unreadable_settings(ms: i64) -> Value {
    let history: Vec<Value> = (0..120)
        .map(|k| {
            json!({"changeDate": iso(ms - k * 86_400_000), "parameters": [
                {"changeType": "changed", "effectiveDate": iso(ms - k * 86_400_000),
                 "level": 1, "name": "MEAL_RATIO_BREAKFAST_FACTOR", "unit": "%", "value": "100"}]})
        })
        .collect();
    json!({"payload": {"history": history}, "activeSchedule": "Normal",
        "basalSchedules": {}, "carbRatio": [{"start": 0, "amount": 10.0}],
        "units": {"carb": "grams", "bg": "mg/dL"}, "deviceId": "DBLG1-0001",
        "id": "ps-unreadable", "time": iso(ms), "timezoneOffset": 120, "type": "pumpSettings"})
}

/// An export that opens with settings abba cannot read (their history
/// runs past the first 4 KB) is told from its items' own keys, read as
/// Tidepool without `--format`, and imported whole: the settings counted
/// with a note, the readings kept (before, it was read as Nightscout and
/// refused, or with `--format tidepool` refused whole by the profile
/// check).
#[test]
fn an_export_opening_with_unreadable_settings_is_told_and_imported_with_a_note() {
    let mut data = vec![unreadable_settings(DAY1_MS)];
    data.extend(
        changed_mid_export()
            .into_iter()
            .filter(|v| v["type"] != "pumpSettings"),
    );
    let bytes = serde_json::to_vec(&data).unwrap();
    assert!(
        bytes
            .windows(21)
            .position(|w| w == b"\"type\":\"pumpSettings\"")
            .unwrap()
            > 4096,
        "the first item's type comes after the first 4 KB"
    );
    assert_eq!(
        abba_io::read::detect("export.json", &bytes).unwrap(),
        abba_io::Format::Tidepool
    );
    let dir = TempDir::new("tp-unreadable");
    let mut store = dir.store();
    let mut p = person_a();
    p.settings.therapy_source = TherapySource::Given;
    store.create_person(&p).unwrap();
    let summary = store
        .import_contents_with(
            "tia",
            &[("export.json".into(), bytes)],
            None,
            abba_store::ProfileResolution::Stop,
            jiff::Timestamp::now(),
            true,
            &mut |_| Ok(()),
        )
        .unwrap();
    assert!(
        summary
            .notes
            .iter()
            .any(|n| n.contains("$[0], field \"basalSchedules\"")
                && n.contains("active schedule \"Normal\"")
                && n.contains("counted, not read")),
        "{:?}",
        summary.notes
    );
    assert_eq!(
        store
            .records("tia")
            .unwrap()
            .iter()
            .filter(|r| r.kind.name() == "cgm")
            .count(),
        14 * 288
    );
}
