//! Hostile request bodies: wrong types, huge numbers, NaN-like strings,
//! deep nesting, oversized bodies, bad timestamps. Never a panic or a 5xx;
//! a refused body gets 400, 413, 415 or 422, and 400/422 name a path.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use axum::http::{Method, StatusCode};
use common::Svc;
use proptest::prelude::*;
use serde_json::{json, Value};

struct World {
    rt: tokio::runtime::Runtime,
    svc: Svc,
    person: u64,
    token: String,
}

fn world() -> World {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap();
    let svc = Svc::new();
    let person = rt.block_on(svc.person("ann"));
    let (_, token) = rt.block_on(svc.token(person));
    World {
        rt,
        svc,
        person,
        token,
    }
}

/// Every endpoint that takes a body, with the token that may call it.
fn targets(w: &World) -> Vec<(Method, String, String)> {
    let p = w.person;
    vec![
        (
            Method::POST,
            format!("/v1/persons/{p}/events"),
            w.token.clone(),
        ),
        (
            Method::POST,
            format!("/v1/persons/{p}/answers"),
            w.token.clone(),
        ),
        (Method::POST, "/v1/persons".into(), w.svc.admin.clone()),
        (
            Method::PUT,
            format!("/v1/persons/{p}/bounds"),
            w.svc.admin.clone(),
        ),
    ]
}

/// Checks one response to a hostile body.
fn check(status: StatusCode, text: &str, body: &Value) {
    assert!(
        status.as_u16() < 500,
        "{status} for a client's body: {text}"
    );
    if status.is_client_error() {
        assert_eq!(
            body["status"].as_u64(),
            Some(u64::from(status.as_u16())),
            "{text}"
        );
        assert!(
            body["message"].as_str().is_some_and(|m| !m.is_empty()),
            "{text}"
        );
        if status == StatusCode::BAD_REQUEST || status == StatusCode::UNPROCESSABLE_ENTITY {
            assert!(body["path"].is_string(), "no path: {text}");
        }
    }
}

fn send(
    w: &World,
    method: &Method,
    uri: &str,
    token: &str,
    bytes: Vec<u8>,
) -> (StatusCode, String, Value) {
    let r = w.rt.block_on(w.svc.raw(
        method.clone(),
        uri,
        Some(format!("Bearer {token}")),
        Some(bytes),
    ));
    (r.status, r.text, r.json)
}

/// Arbitrary JSON, a few levels deep.
fn any_json() -> impl Strategy<Value = Value> {
    let leaf = prop_oneof![
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        any::<i64>().prop_map(|v| json!(v)),
        any::<u64>().prop_map(|v| json!(v)),
        any::<f64>()
            .prop_filter("finite", |v| v.is_finite())
            .prop_map(|v| json!(v)),
        prop_oneof![
            Just("NaN".to_string()),
            Just("Infinity".to_string()),
            Just("-0".to_string()),
            Just("2026-13-45T99:99:99Z".to_string()),
            "\\PC{0,20}",
        ]
        .prop_map(Value::String),
    ];
    leaf.prop_recursive(4, 64, 8, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..6).prop_map(Value::Array),
            prop::collection::btree_map(
                prop_oneof![
                    Just("events".to_string()),
                    Just("seq".to_string()),
                    Just("at".to_string()),
                    Just("event".to_string()),
                    Just("type".to_string()),
                    Just("mg_dl".to_string()),
                    Just("answers".to_string()),
                    Just("bounds".to_string()),
                    Just("name".to_string()),
                    "[a-z_]{1,8}",
                ],
                inner,
                0..5
            )
            .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

/// A well-formed event batch with one field made hostile.
fn hostile_event() -> impl Strategy<Value = Value> {
    let at = prop_oneof![
        Just(json!("2026-01-01T00:00:00Z")),
        Just(json!("2026-01-01T00:00:00")),
        Just(json!("2026-02-30T00:00:00Z")),
        Just(json!("1900-01-01T00:00:00Z")),
        Just(json!("9999-12-31T23:59:59Z")),
        Just(json!("yesterday")),
        Just(json!(1_767_225_600)),
        "\\PC{0,30}".prop_map(Value::String),
    ];
    let number = prop_oneof![
        Just(json!(-1.0)),
        Just(json!(0.0)),
        Just(json!(1e300)),
        Just(json!(-1e300)),
        Just(json!("NaN")),
        Just(json!("120")),
        Just(json!(null)),
        Just(json!(u64::MAX)),
        any::<f64>()
            .prop_filter("finite", |v| v.is_finite())
            .prop_map(|v| json!(v)),
    ];
    let seq = prop_oneof![
        Just(json!(-1)),
        Just(json!(1.5)),
        Just(json!(u64::MAX)),
        Just(json!(1u64 << 60)),
        Just(json!("7")),
        (0u64..1000).prop_map(|v| json!(v)),
    ];
    let kind = prop_oneof![
        Just("cgm"),
        Just("smbg"),
        Just("meal"),
        Just("bolus"),
        Just("basal_rate"),
        Just("temp_basal"),
        Just("day_closed"),
        Just("ketones"),
    ];
    (seq, at, kind, number).prop_map(|(seq, at, kind, v)| {
        let event = match kind {
            "cgm" | "smbg" => json!({"type": kind, "mg_dl": v}),
            "meal" => json!({"type": kind, "carbs_g": v, "slot": "lunch"}),
            "bolus" => json!({"type": kind, "units": v}),
            "basal_rate" => json!({"type": kind, "units_per_hour": v}),
            "temp_basal" => json!({"type": kind, "rate": {"percent": v}, "duration_min": 30}),
            _ => json!({"type": kind, "value": v}),
        };
        json!({"events": [{"seq": seq, "at": at, "event": event}]})
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_json_never_gets_a_5xx(body in any_json()) {
        let w = world_once();
        for (m, uri, token) in targets(w) {
            let (status, text, json) = send(w, &m, &uri, &token, serde_json::to_vec(&body).unwrap());
            check(status, &text, &json);
        }
    }

    #[test]
    fn hostile_events_are_refused_with_the_field(body in hostile_event()) {
        let w = world_once();
        let uri = format!("/v1/persons/{}/events", w.person);
        let (status, text, json) = send(w, &Method::POST, &uri, &w.token, serde_json::to_vec(&body).unwrap());
        check(status, &text, &json);
        if status.is_client_error() && status != StatusCode::CONFLICT {
            let path = json["path"].as_str().unwrap_or("");
            prop_assert!(path.starts_with("events"), "{}", text);
        }
    }

    #[test]
    fn arbitrary_bytes_never_get_a_5xx(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let w = world_once();
        for (m, uri, token) in targets(w) {
            let (status, text, json) = send(w, &m, &uri, &token, bytes.clone());
            check(status, &text, &json);
        }
    }
}

fn world_once() -> &'static World {
    static W: std::sync::OnceLock<World> = std::sync::OnceLock::new();
    W.get_or_init(world)
}

#[test]
fn deep_nesting_oversized_bodies_and_big_numbers() {
    let w = world_once();
    for (m, uri, token) in targets(w) {
        // 10,000 nested arrays and objects.
        let deep = format!("{}{}", "[".repeat(10_000), "]".repeat(10_000));
        let (s, text, json) = send(w, &m, &uri, &token, deep.into_bytes());
        assert_eq!(s, StatusCode::BAD_REQUEST, "{text}");
        check(s, &text, &json);
        let deep = format!("{}1{}", "{\"events\":".repeat(10_000), "}".repeat(10_000));
        let (s, text, json) = send(w, &m, &uri, &token, deep.into_bytes());
        assert_eq!(s, StatusCode::BAD_REQUEST, "{text}");
        check(s, &text, &json);
        // Just over the limit, and far over it.
        for n in [abba_api::MAX_BODY_BYTES + 1, 8 * abba_api::MAX_BODY_BYTES] {
            let mut big = b"{\"events\":[\"".to_vec();
            big.resize(n - 3, b'x');
            big.extend_from_slice(b"\"]}");
            let (s, text, json) = send(w, &m, &uri, &token, big);
            assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{text}");
            check(s, &text, &json);
        }
        // Numbers beyond f64 and u64.
        let (s, text, json) = send(
            w,
            &m,
            &uri,
            &token,
            b"{\"events\":[{\"seq\":1e400}]}".to_vec(),
        );
        check(s, &text, &json);
        assert_eq!(s, StatusCode::BAD_REQUEST, "{text}");
        // Trailing garbage after a valid value.
        let (s, text, json) = send(w, &m, &uri, &token, b"{} {}".to_vec());
        check(s, &text, &json);
    }
    // Not JSON: 415.
    let r = w.rt.block_on(async {
        let req = axum::http::Request::builder()
            .method(Method::POST)
            .uri(format!("/v1/persons/{}/events", w.person))
            .header("authorization", format!("Bearer {}", w.token))
            .header("content-type", "text/plain")
            .body(axum::body::Body::from("{}"))
            .unwrap();
        use tower::ServiceExt;
        w.svc.router.clone().oneshot(req).await.unwrap()
    });
    assert_eq!(r.status(), StatusCode::UNSUPPORTED_MEDIA_TYPE);
    // A compressed body: 415 naming the encoding, not "bad JSON".
    let r = w.rt.block_on(async {
        let req = axum::http::Request::builder()
            .method(Method::POST)
            .uri(format!("/v1/persons/{}/events", w.person))
            .header("authorization", format!("Bearer {}", w.token))
            .header("content-type", "application/json")
            .header("content-encoding", "gzip")
            .body(axum::body::Body::from(vec![0x1f_u8, 0x8b, 8, 0, 0, 0]))
            .unwrap();
        use tower::ServiceExt;
        w.svc.router.clone().oneshot(req).await.unwrap()
    });
    assert_eq!(r.status(), StatusCode::UNSUPPORTED_MEDIA_TYPE);
    let body =
        w.rt.block_on(axum::body::to_bytes(r.into_body(), 1 << 16))
            .unwrap();
    let text = String::from_utf8_lossy(&body);
    assert!(
        text.contains("Content-Encoding \\\"gzip\\\" is not accepted"),
        "{text}"
    );
}

#[test]
fn each_refused_value_names_its_field() {
    let w = world_once();
    let uri = format!("/v1/persons/{}/events", w.person);
    let cases = [
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00", "event": {"type": "cgm", "mg_dl": 100}}]}),
            422,
            "events[0].at",
        ),
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": {"type": "cgm", "mg_dl": 5}}]}),
            422,
            "events[0].event.mg_dl",
        ),
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": {"type": "bolus", "units": -1}}]}),
            422,
            "events[0].event.units",
        ),
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": {"type": "meal", "carbs_g": 9000, "slot": "lunch"}}]}),
            422,
            "events[0].event.carbs_g",
        ),
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": {"type": "meal", "carbs_g": 90, "slot": "brunch"}}]}),
            400,
            "events[0].event.slot",
        ),
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": {"type": "cgm", "mg_dl": "NaN"}}]}),
            400,
            "events[0].event.mg_dl",
        ),
        (
            json!({"events": [{"seq": 9_007_199_254_740_992u64, "at": "2026-01-01T00:00:00Z", "event": {"type": "cgm", "mg_dl": 100}}]}),
            422,
            "events[0].seq",
        ),
        (
            json!({"events": [{"seq": 1, "at": "2025-12-31T23:00:00Z", "event": {"type": "cgm", "mg_dl": 100}}]}),
            422,
            "events[0].at",
        ),
        (json!({"events": []}), 422, "events"),
        (
            json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": {"type": "cgm", "mg_dl": 100}, "extra": 1}]}),
            400,
            "events[0].extra",
        ),
    ];
    // (Inside an event the path goes down to the field: the advisor's
    // check names the quantity, the wire reader the field, see
    // `a_wrong_type_inside_an_event_names_the_field`.)
    for (body, status, path) in cases {
        let (s, text, json) = send(
            w,
            &Method::POST,
            &uri,
            &w.token,
            serde_json::to_vec(&body).unwrap(),
        );
        assert_eq!(s.as_u16(), status, "{body}: {text}");
        assert_eq!(json["path"], path, "{body}: {text}");
        // The event's real time, never the check's placeholder minute.
        let message = json["message"].as_str().unwrap_or_default();
        assert!(!message.contains("D1 00:00"), "{body}: {text}");
        if status == 422 && path.starts_with("events[0].event.") {
            assert!(
                message.contains("event seq 1 (") && message.contains("at 2026-01-01T00:00:00Z"),
                "{body}: {text}"
            );
        }
    }
}

#[test]
fn a_wrong_type_inside_an_event_names_the_field() {
    let w = world_once();
    let uri = format!("/v1/persons/{}/events", w.person);
    let cases = [
        (
            json!({"type": "cgm", "mg_dl": "x"}),
            "mg_dl",
            "mg_dl: invalid type",
        ),
        (
            json!({"type": "meal", "carbs_g": 90, "slot": "brunch"}),
            "slot",
            "slot: unknown variant `brunch`",
        ),
        (
            json!({"type": "temp_basal", "rate": {"percent": true}, "duration_min": 30}),
            "rate.percent",
            "rate.percent: invalid type",
        ),
        (
            json!({"type": "extended_bolus", "total_units": 4, "immediate_units": 1, "duration_min": -5}),
            "duration_min",
            "duration_min: invalid value",
        ),
        (
            json!({"type": "coffee"}),
            "type",
            "type: unknown kind `coffee`",
        ),
    ];
    for (event, field, message) in cases {
        let body = json!({"events": [{"seq": 1, "at": "2026-01-01T00:00:00Z", "event": event}]});
        let (s, text, json) = send(
            w,
            &Method::POST,
            &uri,
            &w.token,
            serde_json::to_vec(&body).unwrap(),
        );
        assert_eq!(s.as_u16(), 400, "{body}: {text}");
        assert_eq!(
            json["path"],
            format!("events[0].event.{field}"),
            "{body}: {text}"
        );
        let got = json["message"].as_str().unwrap_or_default();
        assert!(got.contains(message), "{body}: {text}");
        // Which event: its seq and its time as sent.
        assert!(
            got.contains("(event seq 1 at 2026-01-01T00:00:00Z)"),
            "{body}: {text}"
        );
    }
}
