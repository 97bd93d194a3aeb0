//! What the probe found the service accepting, refused with 422 naming
//! the field: a day 1 no data can reach (before 1990-01-01, after
//! tomorrow), a pump step no pump has, an override off the person's pump
//! step (with the two nearest values on it), a CGM app's day closed at
//! any time but local midnight; persons made by `POST /v1/persons` get
//! `abba person new`'s pump steps; a 409 to an answer names its path.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use axum::http::{Method, StatusCode};
use common::{ev, Svc};
use serde_json::{json, Value};

fn body(name: &str) -> Value {
    json!({
        "name": name, "tz": "Europe/Zurich", "mode": "cgm",
        "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
    })
}

async fn create(svc: &Svc, b: &Value) -> common::Resp {
    svc.call(Method::POST, "/v1/persons", Some(&svc.admin), Some(b))
        .await
}

#[tokio::test]
async fn a_day_1_no_data_can_reach_is_refused() {
    let svc = Svc::new();
    for (i, day) in ["9999-12-31", "0001-01-01", "1989-12-31"]
        .iter()
        .enumerate()
    {
        let mut b = body(&format!("p{i}"));
        b["first_day"] = json!(day);
        let r = create(&svc, &b).await;
        assert_eq!(
            r.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{day}: {}",
            r.text
        );
        assert_eq!(r.json["path"], "first_day", "{}", r.text);
        let m = r.json["message"].as_str().unwrap();
        assert!(
            m.contains("expected a date from 1990-01-01")
                && m.contains("(tomorrow in Europe/Zurich)")
                && m.contains(&format!("got {day}")),
            "{m}"
        );
    }
    let mut b = body("ok");
    b["first_day"] = json!("2026-01-01");
    assert_eq!(create(&svc, &b).await.status, StatusCode::CREATED);
}

fn steps_of(svc: &Svc, id: u64) -> Option<abba_advisor::PumpSteps> {
    let store = abba_store::Store::open(&svc.db).unwrap();
    store.person_by_id(id as i64).unwrap().settings.pump_steps
}

/// Creates a person from `b` (201 asserted) and returns the pump steps stored for them.
async fn created_steps(svc: &Svc, b: &Value) -> Option<abba_advisor::PumpSteps> {
    let r = create(svc, b).await;
    assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    steps_of(svc, r.json["id"].as_u64().unwrap())
}

#[tokio::test]
async fn api_persons_get_the_clis_pump_steps_or_the_ones_given() {
    let svc = Svc::new();
    assert_eq!(
        created_steps(&svc, &body("ana")).await,
        Some(abba_advisor::PumpSteps {
            basal_u_per_h: 0.05,
            carb_ratio_g_per_u: 0.1
        })
    );
    let mut b = body("bo");
    b["pump_steps"] = json!({"basal_units_per_hour": 0.025, "carb_ratio_g_per_unit": 1.0});
    assert_eq!(
        created_steps(&svc, &b).await,
        Some(abba_advisor::PumpSteps {
            basal_u_per_h: 0.025,
            carb_ratio_g_per_u: 1.0
        })
    );
    // Research: no steps, only when asked.
    let mut b = body("cy");
    b["continuous_values"] = json!(true);
    assert_eq!(created_steps(&svc, &b).await, None);
    // Steps no pump has, as the CLI refuses them.
    for (steps, path, expected) in [
        (
            json!({"basal_units_per_hour": 0.07, "carb_ratio_g_per_unit": 0.1}),
            "pump_steps.basal_units_per_hour",
            "expected 0.05, 0.025 or 0.01, got 0.07",
        ),
        (
            json!({"basal_units_per_hour": 0.05, "carb_ratio_g_per_unit": 0.5}),
            "pump_steps.carb_ratio_g_per_unit",
            "expected 0.1 or 1, got 0.5",
        ),
    ] {
        let mut b = body("di");
        b["pump_steps"] = steps;
        let r = create(&svc, &b).await;
        assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
        assert_eq!(r.json["path"], path, "{}", r.text);
        assert!(
            r.json["message"].as_str().unwrap().contains(expected),
            "{}",
            r.text
        );
    }
    let mut b = body("di");
    b["continuous_values"] = json!(true);
    b["pump_steps"] = json!({"basal_units_per_hour": 0.05, "carb_ratio_g_per_unit": 0.1});
    let r = create(&svc, &b).await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert_eq!(r.json["path"], "continuous_values", "{}", r.text);
}

/// A person with the CLI's steps fed the live-advisor stream (UTC, day 1
/// 2026-01-01, days closed at midnight) until the first suggestions.
async fn fed_person(svc: &Svc) -> (u64, Vec<Value>) {
    let id = svc
        .person_with(json!({
            "name": "ana", "tz": "UTC", "mode": "cgm", "first_day": "2026-01-01",
            // (large enough that the stream's daily changes, some below a
            // pump step, add up to steps within its days: open suggestions)
            "start": {"basal_units_per_hour": 5.0, "carb_ratio_g_per_unit": [40.0, 45.0, 42.0]},
            "min_data": {"cgm_coverage": 0.0, "cgm_period_min": 5, "smbg_per_day": 0, "smbg_per_meal": 0}
        }))
        .await;
    let events: Vec<Value> = crate::live_advisor::stream()
        .into_iter()
        .map(|(_, _, w)| w)
        .collect();
    let mut answers = Vec::new();
    for chunk in events.chunks(5000) {
        let r = svc
            .call(
                Method::POST,
                &format!("/v1/persons/{id}/events"),
                Some(&svc.admin),
                Some(&json!({ "events": chunk })),
            )
            .await;
        assert_eq!(r.status, StatusCode::OK, "{}", r.text);
        answers.extend(r.json["answers"].as_array().unwrap().iter().cloned());
    }
    (id, answers)
}

async fn open_suggestions(svc: &Svc, id: u64) -> Vec<Value> {
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/suggestions?after=0&limit=1000"),
            Some(&svc.admin),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    r.json["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["status"] == "open")
        .cloned()
        .collect()
}

#[tokio::test]
async fn an_override_off_the_pumps_step_is_refused_with_the_nearest_values() {
    let svc = Svc::new();
    let (id, _) = fed_person(&svc).await;
    let open = open_suggestions(&svc, id).await;
    if open.is_empty() {
        let r = svc
            .call(
                Method::GET,
                &format!("/v1/persons/{id}/suggestions?after=0&limit=1000"),
                Some(&svc.admin),
                None,
            )
            .await;
        panic!("no open suggestion: {}", r.text);
    }
    let answer = |sid: &Value, value: f64| json!({"answers": [{"suggestion_id": sid, "answer": "override", "value": value}]});
    let path = format!("/v1/persons/{id}/answers");
    // Off the steps as the probe's values were (9.25 g/U against a step
    // of 0.1, 0.8883639681743214 U/h against 0.05), near these settings.
    for s in &open {
        let (value, said) = if s["parameter"] == "basal" {
            (
                4.888_363_968_174_321,
                "4.888363968174321 U/h is not on the pump's basal step (0.05 U/h): the nearest values the pump can be set to are 4.85 and 4.9 U/h",
            )
        } else {
            (
                40.25,
                "40.25 g/U is not on the pump's carb-ratio step (0.1 g/U): the nearest values the pump can be set to are 40.2 and 40.3 g/U",
            )
        };
        let r = svc
            .call(
                Method::POST,
                &path,
                Some(&svc.admin),
                Some(&answer(&s["id"], value)),
            )
            .await;
        assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
        assert_eq!(r.json["path"], "answers[0].value", "{}", r.text);
        let m = r.json["message"].as_str().unwrap();
        assert!(m.contains(said), "{m}");
    }
    // On the step: in force as given.
    let s = &open[0];
    let value = if s["parameter"] == "basal" { 4.9 } else { 40.3 };
    let r = svc
        .call(
            Method::POST,
            &path,
            Some(&svc.admin),
            Some(&answer(&s["id"], value)),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["answered"][0]["in_force"], value);
    // The same again (a retry): the same acknowledgement.
    let r = svc
        .call(
            Method::POST,
            &path,
            Some(&svc.admin),
            Some(&answer(&s["id"], value)),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["answered"][0]["in_force"], value);
    // Another value: 409, and the path is the field the message names.
    let r = svc
        .call(
            Method::POST,
            &path,
            Some(&svc.admin),
            Some(&answer(&s["id"], value + 0.1)),
        )
        .await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    assert_eq!(r.json["path"], "answers[0].suggestion_id", "{}", r.text);
}

#[tokio::test]
async fn a_cgm_apps_day_closed_off_midnight_is_refused() {
    let svc = Svc::new();
    let (id, _) = fed_person(&svc).await;
    let path = format!("/v1/persons/{id}/events");
    let basal_decisions = |svc: &Svc| {
        let mut store = abba_store::Store::open(&svc.db).unwrap();
        store
            .decisions("ana")
            .unwrap()
            .iter()
            .filter(|d| d.parameter == abba_advisor::Parameter::Basal)
            .count()
    };
    let before = basal_decisions(&svc);
    // The stream ends at 23:55 of its last day; 13:17 of the next day.
    let minute = 12 * 1440 + 13 * 60 + 17;
    let r = svc
        .call(
            Method::POST,
            &path,
            Some(&svc.admin),
            Some(&json!({"events": [
                common::cgm(1_000_000, minute, 120.0),
                ev(1_000_001, minute, json!({"type": "day_closed"}))
            ]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert_eq!(r.json["path"], "events[1].at", "{}", r.text);
    let m = r.json["message"].as_str().unwrap();
    assert!(
        m.contains("a CGM-mode person's day closes at local midnight") && m.contains("13:17 local"),
        "{m}"
    );
    assert_eq!(basal_decisions(&svc), before, "no decision from it");
    // At midnight: the day closes (one basal decision more).
    let r = svc
        .call(
            Method::POST,
            &path,
            Some(&svc.admin),
            Some(&json!({"events": [
                ev(1_000_002, 12 * 1440, json!({"type": "day_closed"}))
            ]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(basal_decisions(&svc), before + 1);
}

/// An offset no clock shows (beyond -12:00 to +14:00; jiff alone reads up
/// to ±25:59) is refused at the field, as is one with 60 minutes or more.
#[tokio::test]
async fn an_offset_beyond_any_zones_is_refused() {
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": "ana", "tz": "UTC", "mode": "cgm", "first_day": "2026-01-01",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 10.0, 10.0]}
        }))
        .await;
    let path = format!("/v1/persons/{id}/events");
    for (i, (at, ok)) in [
        ("2026-01-02T08:00:00+25:00", false),
        ("2026-01-02T08:00:00+14:30", false),
        ("2026-01-02T08:00:00-13:00", false),
        ("2026-01-02T08:00:00+05:75", false),
        ("2026-01-02T08:00:00+14:00", true),
        ("2026-01-02T08:00:00-12:00", true),
        ("2026-01-02T08:00:00.250+05:45", true),
    ]
    .into_iter()
    .enumerate()
    {
        let seq = i as u64 + 1;
        let body =
            json!({"events": [{"seq": seq, "at": at, "event": {"type": "cgm", "mg_dl": 120.0}}]});
        let r = svc
            .call(Method::POST, &path, Some(&svc.admin), Some(&body))
            .await;
        if ok {
            assert_eq!(r.status, StatusCode::OK, "{at}: {}", r.text);
        } else {
            assert_eq!(
                r.status,
                StatusCode::UNPROCESSABLE_ENTITY,
                "{at}: {}",
                r.text
            );
            assert_eq!(r.json["path"], "events[0].at", "{}", r.text);
        }
    }
}
