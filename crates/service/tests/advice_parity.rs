//! The advice over HTTP says what `abba advise` says: for an import-fed
//! person with a basal schedule and a trip in the data, `GET .../advice` carries the therapy in force (its schedule,
//! the pump's steps, the changes), the delivery, the first week and the
//! notes of the store's advice, and each suggestion's schedule.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::{Mode, PumpSteps};
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_store::person::TherapySource;
use abba_store::{NewPerson, Store};
use axum::http::{Method, StatusCode};
use common::Svc;
use serde_json::{json, Value};

/// 00:00 of 2026-05-04 in Zurich (UTC+2), in ms.
const DAY1_MS: i64 = 1_777_845_600_000;

fn iso(ms: i64) -> String {
    jiff::Timestamp::from_millisecond(ms).unwrap().to_string()
}

/// Nightscout files: `days` days of CGM around a high level, three meal
/// boluses a day, carbohydrate alone on day 3 (a snack), the last
/// two days' readings from a device at UTC-05:00 (a trip), and a profile
/// with a two-segment basal schedule.
pub(crate) fn export(dir: &std::path::Path, days: i64) -> Vec<std::path::PathBuf> {
    let mut entries = Vec::new();
    let mut treatments = Vec::new();
    for day in 0..days {
        let base = DAY1_MS + day * 86_400_000;
        let offset = if day >= days - 2 { -300 } else { 120 };
        for k in 0..288i64 {
            let ms = base + k * 300_000;
            let g = 240.0 + 40.0 * ((k * 5) as f64 / 240.0 + day as f64).sin();
            entries.push(json!({"_id": format!("e{day:03}{k:04}"), "type": "sgv",
                "sgv": g.round(), "date": ms, "dateString": iso(ms), "utcOffset": offset}));
        }
        for (minute, carbs) in [
            (7 * 60 + 2, 45.0),
            (12 * 60 + 17, 60.0),
            (18 * 60 + 32, 70.0),
        ] {
            let ms = base + minute * 60_000;
            treatments.push(json!({"_id": format!("m{day:03}{minute:04}"),
                "eventType": "Meal Bolus", "carbs": carbs, "insulin": carbs / 10.0,
                "created_at": iso(ms), "enteredBy": "pump"}));
        }
        if day == 3 {
            let ms = base + (10 * 60 + 32) * 60_000;
            treatments.push(
                json!({"_id": "hypo", "eventType": "Carb Correction", "carbs": 16,
                "created_at": iso(ms), "enteredBy": "pump"}),
            );
        }
    }
    let seg = |t: &str, s: i64, v: f64| json!({"time": t, "timeAsSeconds": s, "value": v});
    let start = DAY1_MS - 86_400_000;
    let profile = json!([{"_id": "p1", "defaultProfile": "Default", "startDate": iso(start),
        "mills": start, "units": "mg/dl", "store": {"Default": {
            "basal": [seg("00:00", 0, 0.9), seg("06:00", 21_600, 1.1)],
            "carbratio": [seg("00:00", 0, 10.0)], "sens": [seg("00:00", 0, 50.0)],
            "target_low": [seg("00:00", 0, 100.0)], "target_high": [seg("00:00", 0, 120.0)],
            "timezone": "Europe/Zurich", "units": "mg/dl", "dia": 5}}}]);
    let mut paths = Vec::new();
    for (name, v) in [
        ("entries.json", Value::Array(entries)),
        ("treatments.json", Value::Array(treatments)),
        ("profile.json", profile),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
        paths.push(p);
    }
    paths
}

fn minutes(hhmm: &str) -> u64 {
    let (h, m) = hhmm.split_once(':').unwrap();
    h.parse::<u64>().unwrap() * 60 + m.parse::<u64>().unwrap()
}

/// A store's schedule (`[["HH:MM", rate], ...]`) on the wire's terms.
fn wire_schedule(v: &Value) -> Value {
    match v.as_array() {
        None => Value::Null,
        Some(s) => s
            .iter()
            .map(|x| {
                json!({"start_minute": minutes(x[0].as_str().unwrap()),
                "units_per_hour": x[1]})
            })
            .collect(),
    }
}

/// A person "ana" fed by `days` days of [`export`], created as `person
/// new --therapy-from` would: their id and `abba advise`'s advice.
pub(crate) fn imported_person(svc: &Svc, days: i64) -> (u64, abba_store::advise::Advice) {
    let files = export(svc.dir.path(), days);
    person_from(svc, &files)
}

/// The person "ana" of [`imported_person`] fed by `files`.
pub(crate) fn person_from(
    svc: &Svc,
    files: &[std::path::PathBuf],
) -> (u64, abba_store::advise::Advice) {
    let mut store = Store::open(&svc.db).unwrap();
    let start = TherapySettings::new(UnitsPerHour(1.05), GramsPerUnit(10.0)).unwrap();
    let mut p = NewPerson::new("ana", "Europe/Zurich", Mode::Cgm, start);
    p.settings.basal_schedule = Some(vec![(0, 0.9), (360, 1.1)]);
    p.settings.therapy_source = TherapySource::Profile;
    p.settings.pump_steps = Some(PumpSteps::default());
    let id = store.create_person(&p).unwrap().id as u64;
    store.import_files("ana", files, None).unwrap();
    (id, store.advise("ana").unwrap())
}

async fn parity(days: i64) {
    let svc = Svc::new();
    let (id, advice) = imported_person(&svc, days);
    let cli = serde_json::to_value(advice).unwrap();
    let (_, token) = svc.token(id).await;
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/advice"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let api = &r.json;
    assert!(
        !cli["notes"].as_array().unwrap().is_empty(),
        "the data hold a trip: {:#}",
        cli["notes"]
    );
    assert_eq!(api["notes"], cli["notes"]);
    for k in ["source", "basal_schedule_mean", "changes"] {
        assert_eq!(api["therapy"][k], cli["therapy"][k], "therapy.{k}");
    }
    assert_eq!(
        api["therapy"]["basal_schedule"],
        wire_schedule(&cli["therapy"]["basal_schedule"])
    );
    assert_eq!(
        api["therapy"]["pump_steps"],
        json!({"basal_units_per_hour": cli["therapy"]["pump_steps"]["basal_u_per_h"],
            "carb_ratio_g_per_unit": cli["therapy"]["pump_steps"]["carb_ratio_g_per_u"]})
    );
    for k in ["kind", "words", "evidence", "basal_suggestions", "note"] {
        assert_eq!(api["delivery"][k], cli["delivery"][k], "delivery.{k}");
    }
    assert_eq!(
        api.get("first_week").unwrap_or(&Value::Null),
        cli.get("first_week").unwrap_or(&Value::Null)
    );
    let mut schedules = 0;
    for (a, c) in api["settings"]
        .as_array()
        .unwrap()
        .iter()
        .zip(cli["settings"].as_array().unwrap())
    {
        // The same local time, at the person's offset (Zurich in May).
        if let Some(local) = c["latest"]["decided_at"].as_str() {
            assert_eq!(
                a["latest"]["decided_at"].as_str().unwrap(),
                format!("{}:00+02:00", local.replace(' ', "T")),
                "{}",
                c["setting"]
            );
        }
        let want = wire_schedule(&c["latest"]["schedule"]);
        schedules += usize::from(!want.is_null());
        assert_eq!(
            a["latest"].get("schedule").unwrap_or(&Value::Null),
            &want,
            "{}",
            c["setting"]
        );
    }
    if days > 8 {
        assert!(schedules > 0, "a basal suggestion for the schedule");
    }
}

#[tokio::test]
async fn the_advice_over_http_carries_the_therapy_delivery_and_notes_of_abba_advise() {
    parity(12).await;
}

#[tokio::test]
async fn the_first_weeks_advice_over_http_names_its_days_as_abba_advise() {
    parity(4).await;
}
