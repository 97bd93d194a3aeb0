//! Access control: every endpoint × {no token, malformed token, revoked
//! token, another person's token, the person's token, admin token} against
//! the expected status table; no forbidden response carries the person's
//! data.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use axum::http::{Method, StatusCode};
use common::{cgm, Svc};
use serde_json::{json, Value};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Who {
    None,
    Malformed,
    Revoked,
    Other,
    Own,
    Admin,
}

const WHO: [Who; 6] = [
    Who::None,
    Who::Malformed,
    Who::Revoked,
    Who::Other,
    Who::Own,
    Who::Admin,
];

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Open,
    AnyToken,
    Admin,
    Person,
}

/// The expected status of an endpoint of `kind` for a caller, when the
/// request itself is right (`ok`).
fn expected(kind: Kind, who: Who, ok: u16) -> u16 {
    match (kind, who) {
        (Kind::Open, _) => ok,
        (_, Who::None | Who::Malformed | Who::Revoked) => 401,
        (Kind::AnyToken, _) => ok,
        (Kind::Admin, Who::Other | Who::Own) => 403,
        (Kind::Admin, Who::Admin) => ok,
        (Kind::Person, Who::Other) => 404,
        (Kind::Person, Who::Own | Who::Admin) => ok,
    }
}

#[tokio::test]
async fn every_endpoint_by_every_caller() {
    let svc = Svc::new();
    // Alice is the person whose data is guarded; Bob is the other person.
    let alice = svc.person("alice-private-name").await;
    let bob = svc.person("bob").await;
    let (_, alice_token) = svc.token(alice).await;
    let (_, bob_token) = svc.token(bob).await;
    let (revoked_id, revoked) = svc.token(alice).await;
    let r = svc
        .call(
            Method::DELETE,
            &format!("/v1/tokens/{revoked_id}"),
            Some(&svc.admin),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    // Alice's data: a distinctive reading under a distinctive seq.
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{alice}/events"),
            Some(&alice_token),
            Some(&json!({"events": [cgm(424_242, 60, 187.25)]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let secrets = ["alice-private-name", "187.25", "424242"];

    let mut seq = 1_000u64;
    let mut names = 0u32;
    let mut rows = Vec::new();
    let endpoints: [(&str, Method, Kind, u16); 13] = [
        ("healthz", Method::GET, Kind::Open, 200),
        ("openapi", Method::GET, Kind::AnyToken, 200),
        ("create person", Method::POST, Kind::Admin, 201),
        ("bounds", Method::PUT, Kind::Admin, 200),
        ("therapy", Method::POST, Kind::Admin, 200),
        ("issue token", Method::POST, Kind::Admin, 201),
        ("revoke token", Method::DELETE, Kind::Admin, 200),
        ("events", Method::POST, Kind::Person, 200),
        // No suggestion exists yet: the right caller gets "no such
        // suggestion" (404 with the field named), see below.
        ("answers", Method::POST, Kind::Person, 404),
        ("sync", Method::GET, Kind::Person, 200),
        ("suggestions", Method::GET, Kind::Person, 200),
        ("advice", Method::GET, Kind::Person, 200),
        ("history", Method::GET, Kind::Person, 200),
    ];
    for (name, method, kind, ok) in endpoints {
        for who in WHO {
            seq += 1;
            names += 1;
            // A fresh token to revoke for each call of the revoke endpoint.
            let (victim, _) = svc.token(bob).await;
            let (uri, body): (String, Option<Value>) = match name {
                "healthz" => ("/healthz".into(), None),
                "openapi" => ("/v1/openapi.json".into(), None),
                "create person" => (
                    "/v1/persons".into(),
                    Some(
                        json!({"name": format!("p{names}"), "tz": "UTC", "mode": "smbg",
                        "start": {"basal_units_per_hour": 0.8, "carb_ratio_g_per_unit": [9.0, 9.0, 9.0]}}),
                    ),
                ),
                "bounds" => (
                    format!("/v1/persons/{alice}/bounds"),
                    Some(json!({"bounds": {"basal": {"min": 0.5, "max": 2.0}}})),
                ),
                "therapy" => (
                    format!("/v1/persons/{alice}/therapy"),
                    Some(
                        json!({"carb_ratios": {"breakfast": 10.0, "lunch": 11.0, "dinner": 12.0}}),
                    ),
                ),
                "issue token" => (format!("/v1/persons/{alice}/tokens"), None),
                "revoke token" => (format!("/v1/tokens/{victim}"), None),
                "events" => (
                    format!("/v1/persons/{alice}/events"),
                    Some(json!({"events": [cgm(seq, 60 + seq as i64, 120.0)]})),
                ),
                "answers" => (
                    format!("/v1/persons/{alice}/answers"),
                    Some(json!({"answers": [{"suggestion_id": 8, "answer": "accept"}]})),
                ),
                "sync" => (format!("/v1/persons/{alice}/sync?from=0"), None),
                "suggestions" => (format!("/v1/persons/{alice}/suggestions?after=0"), None),
                "advice" => (format!("/v1/persons/{alice}/advice"), None),
                "history" => (format!("/v1/persons/{alice}/history"), None),
                _ => unreachable!(),
            };
            let auth = match who {
                Who::None => None,
                Who::Malformed => Some("Bearer not-a-token".to_string()),
                Who::Revoked => Some(format!("Bearer {revoked}")),
                Who::Other => Some(format!("Bearer {bob_token}")),
                Who::Own => Some(format!("Bearer {alice_token}")),
                Who::Admin => Some(format!("Bearer {}", svc.admin)),
            };
            let bytes = body.map(|b| serde_json::to_vec(&b).unwrap());
            let r = svc.raw(method.clone(), &uri, auth, bytes).await;
            let want = expected(kind, who, ok);
            rows.push(format!(
                "{name:>13} {who:?}: {} (want {want})",
                r.status.as_u16()
            ));
            assert_eq!(r.status.as_u16(), want, "{name} by {who:?}: {}", r.text);
            if r.status.as_u16() >= 400 {
                // Every error has the error body.
                assert_eq!(
                    r.json["status"].as_u64(),
                    Some(u64::from(want)),
                    "{}",
                    r.text
                );
                if name != "answers" || !matches!(who, Who::Own | Who::Admin) {
                    for s in secrets {
                        assert!(
                            !r.text.contains(s),
                            "{name} by {who:?} leaks {s}: {}",
                            r.text
                        );
                    }
                }
            }
            if name == "answers" && matches!(who, Who::Own | Who::Admin) {
                assert_eq!(r.json["path"], "answers[0].suggestion_id", "{}", r.text);
            }
            if want == 401 {
                assert!(r.json["message"].is_string());
            }
        }
    }
    println!("{}", rows.join("\n"));
    // The person's token sees the person's own data.
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{alice}/advice"),
            Some(&alice_token),
            None,
        )
        .await;
    assert!(r.text.contains("alice-private-name"));
}

#[tokio::test]
async fn a_revoked_admin_token_stops_working_and_ids_that_are_not_numbers_are_404() {
    let svc = Svc::new();
    let alice = svc.person("alice").await;
    let (_, alice_token) = svc.token(alice).await;
    for uri in [
        "/v1/persons/abc/advice",
        "/v1/persons/-1/advice",
        "/v1/persons/99999/advice",
        "/v1/persons/%FF%FE/advice",
    ] {
        let r = svc.call(Method::GET, uri, Some(&svc.admin), None).await;
        assert_eq!(r.status, StatusCode::NOT_FOUND, "{uri}: {}", r.text);
        let r = svc.call(Method::GET, uri, Some(&alice_token), None).await;
        assert_eq!(r.status, StatusCode::NOT_FOUND, "{uri}: {}", r.text);
        let r = svc.call(Method::GET, uri, None, None).await;
        assert_eq!(r.status, StatusCode::UNAUTHORIZED, "{uri}: {}", r.text);
    }
    // The last admin token cannot be revoked (nobody could administer the
    // store any more): 409, and it still works.
    let r = svc
        .call(Method::DELETE, "/v1/tokens/1", Some(&svc.admin), None)
        .await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    assert!(
        r.json["message"]
            .as_str()
            .unwrap()
            .contains("last admin token"),
        "{}",
        r.text
    );
    // With a second admin token, the admin revokes its own (id 1).
    let (second_id, second) = abba_service::new_admin_token(&svc.db).unwrap();
    let r = svc
        .call(Method::DELETE, "/v1/tokens/1", Some(&svc.admin), None)
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let r = svc
        .call(
            Method::DELETE,
            &format!("/v1/tokens/{second_id}"),
            Some(&second),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    let r = svc
        .call(Method::GET, "/v1/openapi.json", Some(&svc.admin), None)
        .await;
    assert_eq!(r.status, StatusCode::UNAUTHORIZED, "{}", r.text);
    assert_eq!(r.json["code"], "unauthorized");
    // Unknown paths and methods get the error body too.
    let r = svc
        .call(Method::GET, "/v2/nothing", Some(&alice_token), None)
        .await;
    assert_eq!(r.status, StatusCode::NOT_FOUND);
    assert_eq!(r.json["code"], "not_found");
    let r = svc
        .call(Method::DELETE, "/v1/persons", Some(&alice_token), None)
        .await;
    assert_eq!(r.status, StatusCode::METHOD_NOT_ALLOWED);
    assert_eq!(r.json["code"], "method_not_allowed");
}

/// A query parameter an endpoint does not take is refused (400 naming
/// it) before anything is done, never ignored: a probe's
/// `POST .../events?dry_run=1` stored its events and
/// `POST .../tokens?role=admin` issued a person's token, each with 2xx.
/// A stranger still gets 401 first.
#[tokio::test]
async fn a_query_parameter_an_endpoint_does_not_take_is_refused_and_changes_nothing() {
    let svc = Svc::new();
    let alice = svc.person("alice").await;
    let (token_id, alice_token) = svc.token(alice).await;
    let events = json!({"events": [cgm(7, 60, 150.0)]});
    // (method, URI, token, body, the parameter named)
    type Case<'a> = (Method, String, Option<&'a str>, Option<&'a Value>, &'a str);
    let cases: [Case; 8] = [
        (
            Method::POST,
            format!("/v1/persons/{alice}/events?dry_run=1"),
            Some(&alice_token),
            Some(&events),
            "dry_run",
        ),
        (
            Method::POST,
            format!("/v1/persons/{alice}/answers?validate_only"),
            Some(&alice_token),
            Some(&json!({"answers": []})),
            "validate_only",
        ),
        (
            Method::GET,
            format!("/v1/persons/{alice}/advice?at=2026-01-02"),
            Some(&alice_token),
            None,
            "at",
        ),
        (
            Method::POST,
            format!("/v1/persons/{alice}/tokens?role=admin"),
            Some(&svc.admin),
            None,
            "role",
        ),
        (
            Method::DELETE,
            format!("/v1/tokens/{token_id}?&undo=1"),
            Some(&svc.admin),
            None,
            "undo",
        ),
        (
            Method::PUT,
            format!("/v1/persons/{alice}/bounds?x"),
            Some(&svc.admin),
            Some(&json!({})),
            "x",
        ),
        (
            Method::POST,
            format!("/v1/persons/{alice}/therapy?x=1"),
            Some(&svc.admin),
            Some(&json!({})),
            "x",
        ),
        (
            Method::POST,
            "/v1/persons?x=1".into(),
            Some(&svc.admin),
            Some(&json!({})),
            "x",
        ),
    ];
    for (method, uri, token, body, key) in cases {
        let r = svc.call(method.clone(), &uri, None, body).await;
        assert_eq!(r.status, StatusCode::UNAUTHORIZED, "{uri}: {}", r.text);
        let r = svc.call(method, &uri, token, body).await;
        assert_eq!(r.status, StatusCode::BAD_REQUEST, "{uri}: {}", r.text);
        assert_eq!(r.json["code"], "bad_query", "{uri}: {}", r.text);
        assert_eq!(r.json["path"], key, "{uri}: {}", r.text);
    }
    // Nothing was stored, issued or revoked.
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{alice}/sync"),
            Some(&alice_token),
            None,
        )
        .await;
    assert_eq!(
        r.status,
        StatusCode::OK,
        "the token still works: {}",
        r.text
    );
    assert_eq!(r.json["held"], json!([]), "{}", r.text);
    let store = abba_store::Store::open(&svc.db).unwrap();
    let tokens = store
        .tokens_of(abba_store::token::Role::Person(alice as i64))
        .unwrap();
    assert_eq!(tokens.len(), 1, "{tokens:?}");
    // An empty query is no parameter.
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{alice}/advice?"),
            Some(&alice_token),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
}

/// A body an endpoint does not take is refused (400 naming `body`),
/// never ignored: a probe's `POST .../tokens` with `{"role": "admin"}`
/// got 201 and a person's token, the body unread. No body, white space
/// and `{}` are none. A stranger still gets 401 first.
#[tokio::test]
async fn a_body_an_endpoint_does_not_take_is_refused_and_changes_nothing() {
    let svc = Svc::new();
    let alice = svc.person("alice").await;
    let (token_id, _) = svc.token(alice).await;
    let issue = format!("/v1/persons/{alice}/tokens");
    let revoke = format!("/v1/tokens/{token_id}");
    let bodies: [&[u8]; 4] = [br#"{"role": "admin"}"#, b"[]", b"null", &[b'x'; 200]];
    for (method, uri) in [(Method::POST, &issue), (Method::DELETE, &revoke)] {
        for body in bodies {
            let r = svc
                .raw(method.clone(), uri, None, Some(body.to_vec()))
                .await;
            assert_eq!(r.status, StatusCode::UNAUTHORIZED, "{uri}: {}", r.text);
            let bearer = Some(format!("Bearer {}", svc.admin));
            let r = svc
                .raw(method.clone(), uri, bearer, Some(body.to_vec()))
                .await;
            assert_eq!(r.status, StatusCode::BAD_REQUEST, "{uri}: {}", r.text);
            assert_eq!(r.json["path"], "body", "{uri}: {}", r.text);
        }
    }
    // Nothing was issued or revoked.
    let store = abba_store::Store::open(&svc.db).unwrap();
    let tokens = store
        .tokens_of(abba_store::token::Role::Person(alice as i64))
        .unwrap();
    assert_eq!(tokens.len(), 1, "{tokens:?}");
    drop(store);
    // None, white space and `{}` are no body.
    let bearer = || Some(format!("Bearer {}", svc.admin));
    for body in [None, Some(b" \r\n".to_vec()), Some(b"{ }".to_vec())] {
        let r = svc.raw(Method::POST, &issue, bearer(), body).await;
        assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
    }
    let r = svc
        .raw(Method::DELETE, &revoke, bearer(), Some(b"{}".to_vec()))
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
}

/// Each character of `id` percent-encoded (`1` is `%31`).
fn percent_encoded(id: u64) -> String {
    id.to_string()
        .bytes()
        .map(|b| format!("%{b:02X}"))
        .collect()
}

/// An id is read only as the service writes it: `+1`, `01`, `1 ` or its
/// digits percent-encoded (`%31`) reach no person and no token (404, as an
/// id nothing has), so that one person is not under many paths (past a
/// proxy's rule on `/v1/persons/1/`).
#[tokio::test]
async fn an_id_not_written_as_the_service_writes_it_reaches_nothing() {
    let svc = Svc::new();
    let alice = svc.person("alice").await;
    let (token_id, alice_token) = svc.token(alice).await;
    for id in [
        format!("+{alice}"),
        format!("0{alice}"),
        format!("{alice}%20"),
        format!("%2B{alice}"),
        percent_encoded(alice),
    ] {
        let uri = format!("/v1/persons/{id}/advice");
        for token in [&svc.admin, &alice_token] {
            let r = svc.call(Method::GET, &uri, Some(token), None).await;
            assert_eq!(r.status, StatusCode::NOT_FOUND, "{uri}: {}", r.text);
        }
        let r = svc
            .call(
                Method::POST,
                &format!("/v1/persons/{id}/events"),
                Some(&alice_token),
                Some(&json!({"events": [cgm(1, 60, 150.0)]})),
            )
            .await;
        assert_eq!(r.status, StatusCode::NOT_FOUND, "{id}: {}", r.text);
    }
    for id in [
        format!("+{token_id}"),
        format!("0{token_id}"),
        percent_encoded(token_id),
    ] {
        let r = svc
            .call(
                Method::DELETE,
                &format!("/v1/tokens/{id}"),
                Some(&svc.admin),
                None,
            )
            .await;
        assert_eq!(r.status, StatusCode::NOT_FOUND, "{id}: {}", r.text);
    }
    // Nothing was stored or revoked; the id as written still works.
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{alice}/sync"),
            Some(&alice_token),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["held"], json!([]), "{}", r.text);
}
