//! The OpenAPI document: it parses as OpenAPI 3.x, every endpoint of the
//! router is in it with its parameters, every reference resolves, every
//! schema is a valid JSON Schema (2020-12, what OpenAPI 3.1 uses), and the
//! responses of a session that calls every endpoint (successes and errors)
//! each have their status documented and validate against its schema.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use axum::http::{Method, StatusCode};
use common::{cgm, ev, Svc};
use serde_json::{json, Value};

const ENDPOINTS: [(&str, &str); 13] = [
    ("get", "/healthz"),
    ("get", "/v1/openapi.json"),
    ("post", "/v1/persons"),
    ("put", "/v1/persons/{id}/bounds"),
    ("post", "/v1/persons/{id}/therapy"),
    ("post", "/v1/persons/{id}/tokens"),
    ("delete", "/v1/tokens/{token_id}"),
    ("post", "/v1/persons/{id}/events"),
    ("post", "/v1/persons/{id}/answers"),
    ("get", "/v1/persons/{id}/sync"),
    ("get", "/v1/persons/{id}/suggestions"),
    ("get", "/v1/persons/{id}/advice"),
    ("get", "/v1/persons/{id}/history"),
];

fn refs(v: &Value, out: &mut Vec<String>) {
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                if k == "$ref" {
                    out.push(x.as_str().unwrap().to_string());
                } else {
                    refs(x, out);
                }
            }
        }
        Value::Array(a) => a.iter().for_each(|x| refs(x, out)),
        _ => {}
    }
}

async fn document(svc: &Svc) -> Value {
    let r = svc
        .call(Method::GET, "/v1/openapi.json", Some(&svc.admin), None)
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    r.json
}

#[tokio::test]
async fn the_document_is_valid_openapi() {
    let svc = Svc::new();
    let doc = document(&svc).await;
    assert!(
        doc["openapi"].as_str().unwrap().starts_with("3."),
        "{}",
        doc["openapi"]
    );
    assert!(doc["info"]["description"]
        .as_str()
        .unwrap()
        .contains("not a medical device"));
    // It reads back as an OpenAPI model.
    let model: utoipa::openapi::OpenApi = serde_json::from_value(doc.clone()).unwrap();
    assert_eq!(model.paths.paths.len(), ENDPOINTS.len());
    for (method, path) in ENDPOINTS {
        let op = &doc["paths"][path][method];
        assert!(op.is_object(), "{method} {path} is not in the document");
        assert!(!op["responses"].as_object().unwrap().is_empty());
        // Every path parameter is declared.
        for name in path
            .split('{')
            .skip(1)
            .map(|s| s.split('}').next().unwrap())
        {
            let declared = op["parameters"]
                .as_array()
                .map(|ps| {
                    ps.iter()
                        .any(|p| p["name"] == name && p["in"] == "path" && p["required"] == true)
                })
                .unwrap_or(false);
            assert!(
                declared,
                "{method} {path}: path parameter {name} not declared"
            );
        }
        // Every endpoint but /healthz needs the bearer token.
        if path != "/healthz" {
            assert_eq!(op["security"][0]["bearer"], json!([]), "{method} {path}");
        }
    }
    assert_eq!(
        doc["components"]["securitySchemes"]["bearer"]["scheme"],
        "bearer"
    );
    let mut all = Vec::new();
    refs(&doc, &mut all);
    assert!(!all.is_empty());
    for r in &all {
        let name = r.strip_prefix("#/components/schemas/").unwrap();
        assert!(
            doc["components"]["schemas"][name].is_object(),
            "{r} does not resolve"
        );
    }
    for (name, schema) in doc["components"]["schemas"].as_object().unwrap() {
        let mut s = schema.clone();
        s["$schema"] = json!("https://json-schema.org/draft/2020-12/schema");
        assert!(
            jsonschema::meta::is_valid(&s),
            "{name} is not a valid JSON Schema: {schema}"
        );
    }
}

/// Validates a response against the document.
fn conforms(doc: &Value, method: &str, path: &str, status: StatusCode, body: &Value, text: &str) {
    let code = status.as_u16().to_string();
    let resp = &doc["paths"][path][method]["responses"][&code];
    assert!(
        resp.is_object(),
        "{method} {path}: status {code} is not documented ({text})"
    );
    let schema = &resp["content"]["application/json"]["schema"];
    assert!(schema.is_object(), "{method} {path} {code}: no JSON schema");
    let root = json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "components": doc["components"],
        "allOf": [schema],
    });
    let v = jsonschema::validator_for(&root).unwrap();
    let errors: Vec<String> = v
        .iter_errors(body)
        .map(|e| format!("{} at {}", e, e.instance_path))
        .collect();
    assert!(
        errors.is_empty(),
        "{method} {path} {code}: {errors:?}\n{text}"
    );
}

#[tokio::test]
async fn every_response_conforms() {
    let svc = Svc::new();
    let doc = document(&svc).await;
    let a = svc.admin.clone();
    let mut seen: Vec<(String, String, u16)> = Vec::new();
    macro_rules! check {
        ($m:expr, $tpl:expr, $uri:expr, $tok:expr, $body:expr) => {{
            let method: Method = $m;
            let uri = String::from($uri);
            let r = svc.call(method.clone(), &uri, $tok, $body).await;
            let m = method.as_str().to_ascii_lowercase();
            conforms(&doc, &m, $tpl, r.status, &r.json, &r.text);
            seen.push((m, $tpl.to_string(), r.status.as_u16()));
            r
        }};
    }
    let person = json!({"name": "ann", "tz": "UTC", "mode": "cgm", "first_day": "2026-01-01",
        "continuous_values": true,
        "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]},
        "min_data": {"cgm_coverage": 0.0, "cgm_period_min": 5, "smbg_per_day": 0, "smbg_per_meal": 0}});
    check!(Method::GET, "/healthz", "/healthz", None, None);
    check!(
        Method::GET,
        "/v1/openapi.json",
        "/v1/openapi.json",
        None,
        None
    );
    let r = check!(
        Method::POST,
        "/v1/persons",
        "/v1/persons",
        Some(&a),
        Some(&person)
    );
    let id = r.json["id"].as_u64().unwrap();
    check!(
        Method::POST,
        "/v1/persons",
        "/v1/persons",
        Some(&a),
        Some(&person)
    ); // 409
    check!(
        Method::POST,
        "/v1/persons",
        "/v1/persons",
        Some(&a),
        Some(&json!({"name": 3}))
    ); // 400
    let mut bad = person.clone();
    bad["name"] = json!("bo");
    bad["tz"] = json!("Mars/Olympus");
    check!(
        Method::POST,
        "/v1/persons",
        "/v1/persons",
        Some(&a),
        Some(&bad)
    ); // 422
    let r = check!(
        Method::POST,
        "/v1/persons/{id}/tokens",
        format!("/v1/persons/{id}/tokens"),
        Some(&a),
        None
    );
    let t = r.json["token"].as_str().unwrap().to_string();
    let tid = r.json["token_id"].as_u64().unwrap();
    check!(
        Method::POST,
        "/v1/persons",
        "/v1/persons",
        Some(&t),
        Some(&person)
    ); // 403
    check!(
        Method::POST,
        "/v1/persons/{id}/tokens",
        "/v1/persons/77/tokens",
        Some(&a),
        None
    ); // 404
    let bounds =
        json!({"bounds": {"basal": {"min": 0.5, "max": 2.0}, "lunch": {"min": 5.0, "max": 30.0}}});
    check!(
        Method::PUT,
        "/v1/persons/{id}/bounds",
        format!("/v1/persons/{id}/bounds"),
        Some(&a),
        Some(&bounds)
    );
    let tight = json!({"bounds": {"basal": {"min": 1.5, "max": 2.0}}});
    check!(
        Method::PUT,
        "/v1/persons/{id}/bounds",
        format!("/v1/persons/{id}/bounds"),
        Some(&a),
        Some(&tight)
    ); // 422
       // Eight days of readings, meals and day closes: suggestions exist.
    let mut events = Vec::new();
    let mut seq = 0;
    for day in 0..9i64 {
        for m in (0..1440).step_by(5) {
            seq += 1;
            let g = 120.0 + 40.0 * ((m as f64) / 200.0).sin();
            events.push(cgm(seq, day * 1440 + m, g));
            if m == 0 && day > 0 {
                seq += 1;
                events.push(ev(seq, day * 1440, json!({"type": "day_closed"})));
            }
            if m == 750 {
                seq += 1;
                events.push(ev(
                    seq,
                    day * 1440 + m,
                    json!({"type": "meal", "carbs_g": 60, "slot": "lunch"}),
                ));
            }
        }
    }
    let uri = format!("/v1/persons/{id}/events");
    let r = check!(
        Method::POST,
        "/v1/persons/{id}/events",
        uri.clone(),
        Some(&t),
        Some(&json!({"events": events}))
    );
    assert!(
        !r.json["answers"].as_array().unwrap().is_empty(),
        "{}",
        r.text
    );
    check!(
        Method::POST,
        "/v1/persons/{id}/events",
        uri.clone(),
        Some(&t),
        Some(&json!({"events": [cgm(1, 0, 99.0)]}))
    ); // 409
    check!(
        Method::POST,
        "/v1/persons/{id}/events",
        uri.clone(),
        Some(&t),
        Some(&json!({"events": [cgm(1, 0, 1.0)]}))
    ); // 422
    check!(
        Method::POST,
        "/v1/persons/{id}/events",
        uri.clone(),
        Some(&t),
        Some(&json!({"events": "all"}))
    ); // 400
    let huge = json!({"events": [{"seq": 1, "at": "x".repeat(abba_api::MAX_BODY_BYTES), "event": {"type": "resume"}}]});
    check!(
        Method::POST,
        "/v1/persons/{id}/events",
        uri.clone(),
        Some(&t),
        Some(&huge)
    ); // 413
    let r = svc
        .raw(Method::POST, &uri, Some(format!("Bearer {t}")), None)
        .await; // 415: no body, no type
    conforms(
        &doc,
        "post",
        "/v1/persons/{id}/events",
        r.status,
        &r.json,
        &r.text,
    );
    check!(
        Method::POST,
        "/v1/persons/{id}/events",
        uri.clone(),
        None,
        Some(&json!({"events": []}))
    ); // 401
    check!(
        Method::GET,
        "/v1/persons/{id}/sync",
        format!("/v1/persons/{id}/sync?from=5"),
        Some(&t),
        None
    );
    check!(
        Method::GET,
        "/v1/persons/{id}/sync",
        format!("/v1/persons/{id}/sync?from=x"),
        Some(&t),
        None
    ); // 400
    check!(
        Method::GET,
        "/v1/persons/{id}/sync",
        "/v1/persons/99/sync",
        Some(&t),
        None
    ); // 404
    let r = check!(
        Method::GET,
        "/v1/persons/{id}/suggestions",
        format!("/v1/persons/{id}/suggestions?after=0"),
        Some(&t),
        None
    );
    let open = r.json["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .rev()
        .find(|s| s["status"] == "open")
        .cloned()
        .unwrap();
    check!(
        Method::GET,
        "/v1/persons/{id}/advice",
        format!("/v1/persons/{id}/advice"),
        Some(&t),
        None
    );
    check!(
        Method::GET,
        "/v1/persons/{id}/history",
        format!("/v1/persons/{id}/history"),
        Some(&a),
        None
    );
    let answers = format!("/v1/persons/{id}/answers");
    check!(
        Method::POST,
        "/v1/persons/{id}/answers",
        answers.clone(),
        Some(&t),
        Some(&json!({"answers": [{"suggestion_id": open["id"], "answer": "override"}]}))
    ); // 422
    check!(
        Method::POST,
        "/v1/persons/{id}/answers",
        answers.clone(),
        Some(&t),
        Some(&json!({"answers": [{"suggestion_id": open["id"], "answer": "accept"}]}))
    );
    check!(
        Method::POST,
        "/v1/persons/{id}/answers",
        answers.clone(),
        Some(&t),
        Some(&json!({"answers": [{"suggestion_id": open["id"], "answer": "accept"}]}))
    ); // 409
    check!(
        Method::POST,
        "/v1/persons/{id}/answers",
        answers.clone(),
        Some(&t),
        Some(&json!({"answers": [{"suggestion_id": 3, "answer": "reject"}]}))
    ); // 404
    let therapy = format!("/v1/persons/{id}/therapy");
    let change = json!({"basal_schedule": [{"start_minute": 0, "units_per_hour": 0.9},
        {"start_minute": 360, "units_per_hour": 1.1}],
        "carb_ratios": {"breakfast": 10.0, "lunch": 12.0, "dinner": 11.0}});
    check!(
        Method::POST,
        "/v1/persons/{id}/therapy",
        therapy.clone(),
        Some(&a),
        Some(&change)
    );
    check!(
        Method::POST,
        "/v1/persons/{id}/therapy",
        therapy.clone(),
        Some(&t),
        Some(&change)
    ); // 403
    check!(
        Method::POST,
        "/v1/persons/{id}/therapy",
        therapy.clone(),
        Some(&a),
        Some(&json!({"carb_ratios": {"breakfast": 10.0, "lunch": 40.0, "dinner": 11.0}}))
    ); // 422: outside the lunch bounds
    check!(
        Method::POST,
        "/v1/persons/{id}/therapy",
        "/v1/persons/99/therapy",
        Some(&a),
        Some(&change)
    ); // 404
    check!(
        Method::DELETE,
        "/v1/tokens/{token_id}",
        format!("/v1/tokens/{tid}"),
        Some(&t),
        None
    ); // 403
    check!(
        Method::DELETE,
        "/v1/tokens/{token_id}",
        format!("/v1/tokens/{tid}"),
        Some(&a),
        None
    );
    check!(
        Method::DELETE,
        "/v1/tokens/{token_id}",
        "/v1/tokens/4242",
        Some(&a),
        None
    ); // 404
    check!(
        Method::GET,
        "/v1/persons/{id}/advice",
        format!("/v1/persons/{id}/advice"),
        Some(&t),
        None
    ); // 401 (revoked)
       // Every endpoint was called, and successes and errors were seen.
    for (m, p) in ENDPOINTS {
        assert!(
            seen.iter().any(|(sm, sp, _)| sm == m && sp == p),
            "{m} {p} not called"
        );
    }
    for code in [200, 201, 400, 401, 403, 404, 409, 413, 422] {
        assert!(seen.iter().any(|s| s.2 == code), "no response with {code}");
    }
    // The check can fail: bodies that do not match are caught.
    for wrong in [
        json!({"acked": [1], "stored": 1, "repeated": []}),
        json!({"acked": ["1"], "stored": 1, "repeated": [], "answers": []}),
        json!({"acked": [], "stored": 0, "repeated": [], "answers": [], "extra": 1}),
    ] {
        let caught = std::panic::catch_unwind(|| {
            conforms(
                &doc,
                "post",
                "/v1/persons/{id}/events",
                StatusCode::OK,
                &wrong,
                "",
            )
        });
        assert!(caught.is_err(), "{wrong} passed the schema");
    }
}
