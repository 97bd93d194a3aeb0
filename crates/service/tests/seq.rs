//! Sequence numbers: a repeat is acknowledged again and stores nothing, a
//! different payload under a used number is 409 and stores nothing of its
//! batch, sync reports held ranges with gaps; and durability: what was
//! acknowledged is in the store after it is reopened.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use axum::http::{Method, StatusCode};
use common::{cgm, ev, Svc};
use serde_json::{json, Value};

async fn post(svc: &Svc, id: u64, token: &str, events: Vec<Value>) -> common::Resp {
    svc.call(
        Method::POST,
        &format!("/v1/persons/{id}/events"),
        Some(token),
        Some(&json!({ "events": events })),
    )
    .await
}

async fn held(svc: &Svc, id: u64, token: &str, from: &str) -> Value {
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/sync{from}"),
            Some(token),
            None,
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    r.json
}

fn events_in_store(svc: &Svc, name: &str) -> usize {
    let store = abba_store::Store::open(&svc.db).unwrap();
    store.events(name).unwrap().len()
}

#[tokio::test]
async fn repeats_conflicts_and_gaps() {
    let svc = Svc::new();
    let id = svc.person("ann").await;
    let (_, t) = svc.token(id).await;
    let batch = vec![cgm(1, 0, 100.0), cgm(2, 5, 110.0), cgm(3, 10, 120.0)];
    let r = post(&svc, id, &t, batch.clone()).await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["acked"], json!([1, 2, 3]));
    assert_eq!(r.json["stored"], 3);
    assert_eq!(r.json["notice"], abba_api::NOTICE, "{}", r.text);
    assert_eq!(r.json["repeated"], json!([]));
    // The same batch again: acknowledged, nothing stored.
    let r = post(&svc, id, &t, batch.clone()).await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["acked"], json!([1, 2, 3]));
    assert_eq!(r.json["stored"], 0);
    assert_eq!(r.json["repeated"], json!([1, 2, 3]));
    assert_eq!(events_in_store(&svc, "ann"), 3);
    // The same instant written with another offset and 120 as an integer
    // is the same payload.
    let same = json!({"seq": 3, "at": "2026-01-01T01:10:00+01:00", "event": {"type": "cgm", "mg_dl": 120}});
    let r = post(&svc, id, &t, vec![same, cgm(4, 15, 130.0)]).await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["stored"], 1);
    assert_eq!(r.json["repeated"], json!([3]));
    // Another payload under seq 2: 409 naming it; seq 5 of the same batch
    // is not stored either.
    let r = post(&svc, id, &t, vec![cgm(5, 20, 140.0), cgm(2, 5, 111.0)]).await;
    assert_eq!(r.status, StatusCode::CONFLICT, "{}", r.text);
    assert_eq!(r.json["code"], "conflict");
    assert_eq!(r.json["path"], "events[1].seq");
    let r = post(
        &svc,
        id,
        &t,
        vec![
            cgm(5, 20, 140.0),
            ev(2, 6, json!({"type": "cgm", "mg_dl": 110.0})),
        ],
    )
    .await;
    assert_eq!(
        r.status,
        StatusCode::CONFLICT,
        "another instant is another payload: {}",
        r.text
    );
    assert_eq!(events_in_store(&svc, "ann"), 4);
    // A seq twice in one batch: 422.
    let r = post(&svc, id, &t, vec![cgm(6, 25, 140.0), cgm(6, 25, 140.0)]).await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert_eq!(r.json["path"], "events[1].seq");
    // Gaps: 10-12 and 20, sent out of order.
    let r = post(
        &svc,
        id,
        &t,
        vec![
            cgm(20, 100, 100.0),
            cgm(12, 60, 100.0),
            cgm(10, 50, 100.0),
            cgm(11, 55, 100.0),
        ],
    )
    .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["acked"], json!([10, 11, 12, 20]));
    let h = held(&svc, id, &t, "?from=0").await;
    assert_eq!(
        h["held"],
        json!([{"first": 1, "last": 4}, {"first": 10, "last": 12}, {"first": 20, "last": 20}])
    );
    assert_eq!(h["last_seq"], 20);
    assert_eq!(h["truncated"], false);
    let h = held(&svc, id, &t, "?from=11").await;
    assert_eq!(
        h["held"],
        json!([{"first": 11, "last": 12}, {"first": 20, "last": 20}])
    );
    assert_eq!(held(&svc, id, &t, "?from=21").await["held"], json!([]));
    assert_eq!(held(&svc, id, &t, "").await["from"], 0);
    // The missing ones are re-sent; the app's view is then complete.
    let r = post(
        &svc,
        id,
        &t,
        (5..10)
            .map(|s| cgm(s, 20 + 5 * (s as i64 - 5), 100.0))
            .collect(),
    )
    .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["stored"], 5);
    let h = held(&svc, id, &t, "?from=0").await;
    assert_eq!(
        h["held"],
        json!([{"first": 1, "last": 12}, {"first": 20, "last": 20}])
    );
    assert_eq!(events_in_store(&svc, "ann"), 13);
    // Bad queries name the parameter.
    for (q, path) in [
        ("?from=abc", "from"),
        ("?from=-1", "from"),
        ("?since=3", "since"),
        ("?from=1&from=2", "from"),
    ] {
        let r = svc
            .call(
                Method::GET,
                &format!("/v1/persons/{id}/sync{q}"),
                Some(&t),
                None,
            )
            .await;
        assert_eq!(r.status, StatusCode::BAD_REQUEST, "{q}: {}", r.text);
        assert_eq!(r.json["path"], path, "{q}");
    }
}

#[tokio::test]
async fn an_acknowledged_batch_is_in_the_store_after_reopening() {
    let svc = Svc::new();
    let id = svc.person("ann").await;
    let (_, t) = svc.token(id).await;
    let batch: Vec<Value> = (0..50)
        .map(|i| cgm(i, 5 * i as i64, 100.0 + i as f64))
        .collect();
    let r = post(&svc, id, &t, batch.clone()).await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let db = svc.db.clone();
    let admin = svc.admin.clone();
    let dir = svc.dir;
    drop(svc.router);
    // Another process' view: the CLI's store API on the same file.
    let store = abba_store::Store::open(&db).unwrap();
    let events = store.events("ann").unwrap();
    assert_eq!(events.len(), 50);
    assert!(events
        .iter()
        .enumerate()
        .all(|(i, e)| e.kind == abba_core::EventKind::Cgm(abba_core::MgDl(100.0 + i as f64))));
    drop(store);
    // A new service over the same file: the batch is held, a re-send
    // stores nothing.
    let svc2 = Svc {
        dir,
        db: db.clone(),
        router: abba_service::router(
            abba_service::AppState::open(&db, Default::default()).unwrap(),
        ),
        admin,
    };
    let h = held(&svc2, id, &t, "?from=0").await;
    assert_eq!(h["held"], json!([{"first": 0, "last": 49}]));
    let r = post(&svc2, id, &t, batch).await;
    assert_eq!(r.json["stored"], 0);
    assert_eq!(r.json["repeated"].as_array().unwrap().len(), 50);
    let synchronous = abba_service::open_store(&db)
        .unwrap()
        .synchronous()
        .unwrap();
    assert_eq!(synchronous, 2, "the service commits with synchronous=FULL");
}

#[tokio::test]
async fn an_event_the_advisor_refuses_is_stored_and_counted() {
    let svc = Svc::new();
    let id = svc.person("ann").await;
    let (_, t) = svc.token(id).await;
    // Two CGM readings in one minute: both stored (distinct seqs), the
    // advisor takes the first only.
    let r = post(
        &svc,
        id,
        &t,
        vec![cgm(1, 0, 100.0), cgm(2, 0, 101.0), cgm(3, 5, 102.0)],
    )
    .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    assert_eq!(r.json["stored"], 3);
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/advice"),
            Some(&t),
            None,
        )
        .await;
    assert_eq!(r.json["data"]["events_refused"], 1, "{}", r.text);
    assert_eq!(r.json["data"]["records"], 3, "{}", r.text);
    let mut cli = abba_store::Store::open(&svc.db).unwrap();
    let a = cli.advise("ann").unwrap();
    assert_eq!(a.data.events_refused, 1);
    assert_eq!(a.data.records, 3);
}
