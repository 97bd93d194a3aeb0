//! The service's limits over real sockets: idle and slowloris connections
//! are closed (evicted past their address's share, the rest by the
//! header-read timeout) while a fresh client's `/healthz` answers
//! (`tests/connections.rs`: eviction itself); a slow body gets 408; a store held by another writer gives 503
//! with Retry-After; events dated in the future are refused and an old one
//! is removed by `remove_future`; the live-advisor cache stays bounded.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::{AppState, ServeSettings, StoreSettings};
use axum::http::{Method, StatusCode};
use common::sock::closed;
use common::{at, cgm, Server, Svc};
use serde_json::json;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

/// Sends raw bytes, reads the whole answer (the service closes after it).
fn raw(addr: SocketAddr, request: &str) -> String {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    String::from_utf8_lossy(&out).to_string()
}

#[test]
fn idle_and_slowloris_connections_are_closed_while_healthz_answers() {
    // Both ends of 5,500 connections live in this process.
    let _ = rlimit::increase_nofile_limit(u64::MAX);
    let (soft, _) = rlimit::getrlimit(rlimit::Resource::NOFILE).unwrap();
    assert!(
        soft >= 12_000,
        "this test needs 12,000 file descriptors, the limit is {soft}"
    );
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("store.db");
    let header_timeout = Duration::from_secs(3);
    let server = Server::start(
        &db,
        ServeSettings {
            header_timeout,
            ..ServeSettings::default()
        },
    );
    let t0 = Instant::now();
    let idle: Vec<TcpStream> = (0..5000)
        .map(|_| TcpStream::connect(server.addr).unwrap())
        .collect();
    let mut slow: Vec<TcpStream> = (0..500)
        .map(|_| {
            let mut s = TcpStream::connect(server.addr).unwrap();
            s.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
                .unwrap();
            s
        })
        .collect();
    let opened = t0.elapsed();
    // A header byte from each slow client every 500 ms, for longer than
    // the timeout; a fresh client's /healthz meanwhile.
    let mut worst = Duration::ZERO;
    let until = Instant::now() + header_timeout + Duration::from_secs(2);
    while Instant::now() < until {
        for s in &mut slow {
            let _ = s.write_all(b"X");
        }
        let t = Instant::now();
        let answer = raw(
            server.addr,
            "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
        );
        let took = t.elapsed();
        worst = worst.max(took);
        assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
        assert!(took < Duration::from_secs(1), "/healthz took {took:?}");
        std::thread::sleep(Duration::from_millis(500));
    }
    println!(
        "5000 idle + 500 slowloris connections opened in {opened:?}; slowest fresh /healthz {worst:?}"
    );
    // Past the header timeout (counted from each connection's opening),
    // every one is closed by the service.
    std::thread::sleep(Duration::from_secs(1));
    let idle_closed = idle.iter().filter(|s| closed(s)).count();
    let slow_closed = slow.iter().filter(|s| closed(s)).count();
    assert_eq!(idle_closed, 5000, "idle connections closed");
    assert_eq!(slow_closed, 500, "slowloris connections closed");
}

#[test]
fn a_body_that_stalls_gets_408_and_the_body_is_never_read_before_the_token() {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            body_timeout: Duration::from_millis(500),
            ..ServeSettings::default()
        },
    );
    let mut s = TcpStream::connect(server.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let head = format!(
        "POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {}\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{{\"name\":",
        svc.admin
    );
    let t = Instant::now();
    s.write_all(head.as_bytes()).unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out);
    assert!(text.starts_with("HTTP/1.1 408"), "{text}");
    assert!(text.contains("\"code\":\"timeout\""), "{text}");
    assert!(t.elapsed() < Duration::from_secs(5));
    // Without a valid token the same stalled body is not waited for: 401 at once.
    let mut s = TcpStream::connect(server.addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let t = Instant::now();
    s.write_all(
        b"POST /v1/persons HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{",
    )
    .unwrap();
    let mut b = [0u8; 12];
    s.read_exact(&mut b).unwrap();
    assert_eq!(&b, b"HTTP/1.1 401");
    assert!(
        t.elapsed() < Duration::from_millis(400),
        "{:?}",
        t.elapsed()
    );
}

#[tokio::test]
async fn health_data_answers_carry_no_store_nosniff_and_a_csp() {
    let svc = Svc::new();
    let id = svc.person("alice").await;
    let req = axum::http::Request::builder()
        .uri(format!("/v1/persons/{id}/history"))
        .header("authorization", format!("Bearer {}", svc.admin))
        .body(axum::body::Body::empty())
        .unwrap();
    use tower::ServiceExt;
    let res = svc.router.clone().oneshot(req).await.unwrap();
    assert_eq!(res.status(), StatusCode::OK);
    let h = res.headers();
    assert_eq!(h["cache-control"], "no-store");
    assert_eq!(h["x-content-type-options"], "nosniff");
    assert!(h["content-security-policy"]
        .to_str()
        .unwrap()
        .contains("default-src 'none'"));
    assert!(h.contains_key("x-request-id"));
}

/// The service's state over `db` with a busy timeout of 300 ms.
fn short_busy_state(db: &std::path::Path) -> AppState {
    AppState::open(
        db,
        StoreSettings {
            busy_timeout: Duration::from_millis(300),
            ..StoreSettings::default()
        },
    )
    .unwrap()
}

#[tokio::test]
async fn a_store_held_by_another_writer_gives_503_with_retry_after() {
    let svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!("a_store_held_by_another_writer_gives_503_with_retry_after: SQLite's write lock (see the store's backends test for PostgreSQL's)");
        return;
    }
    let id = svc.person("alice").await;
    let state = short_busy_state(&svc.db);
    let router = abba_service::router(state);
    // Another connection takes the write lock and keeps it.
    let other = rusqlite::Connection::open(&svc.db).unwrap();
    other.execute_batch("BEGIN IMMEDIATE").unwrap();
    let body = json!({"events": [cgm(0, 10, 120.0)]});
    let req = axum::http::Request::builder()
        .method(Method::POST)
        .uri(format!("/v1/persons/{id}/events"))
        .header("authorization", format!("Bearer {}", svc.admin))
        .header("content-type", "application/json")
        .body(axum::body::Body::from(serde_json::to_vec(&body).unwrap()))
        .unwrap();
    use http_body_util::BodyExt;
    use tower::ServiceExt;
    let res = router.clone().oneshot(req).await.unwrap();
    assert_eq!(res.status(), StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(res.headers()["retry-after"], "1");
    let bytes = res.into_body().collect().await.unwrap().to_bytes();
    let v: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
    assert_eq!(v["code"], "busy", "{v}");
    // Reads still answer (WAL: readers do not wait for the writer).
    let req = axum::http::Request::builder()
        .uri(format!("/v1/persons/{id}/sync"))
        .header("authorization", format!("Bearer {}", svc.admin))
        .body(axum::body::Body::empty())
        .unwrap();
    assert_eq!(
        router.clone().oneshot(req).await.unwrap().status(),
        StatusCode::OK
    );
    // Once released, the same batch is stored.
    other.execute_batch("ROLLBACK").unwrap();
    let req = axum::http::Request::builder()
        .method(Method::POST)
        .uri(format!("/v1/persons/{id}/events"))
        .header("authorization", format!("Bearer {}", svc.admin))
        .header("content-type", "application/json")
        .body(axum::body::Body::from(serde_json::to_vec(&body).unwrap()))
        .unwrap();
    assert_eq!(router.oneshot(req).await.unwrap().status(), StatusCode::OK);
}

/// A person whose earlier request still holds their lock past the busy
/// timeout gets 503 with `Retry-After` (a service probe queued seven long
/// reports of one person: the last ones waited until the request
/// timeout's 408, a blocking thread parked each), and the next request
/// after it is served.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_person_busy_past_the_busy_timeout_gives_503_with_retry_after() {
    let svc = Svc::new();
    let id = svc.person("alice").await as i64;
    let state = short_busy_state(&svc.db);
    let long = {
        let state = state.clone();
        tokio::spawn(async move {
            state
                .person(id, false, |_, _| {
                    std::thread::sleep(Duration::from_millis(1500));
                    Ok(())
                })
                .await
        })
    };
    tokio::time::sleep(Duration::from_millis(200)).await;
    let t = Instant::now();
    let e = state.person(id, false, |_, _| Ok(())).await.unwrap_err();
    assert_eq!(e.status, StatusCode::SERVICE_UNAVAILABLE, "{e:?}");
    assert!(
        t.elapsed() < Duration::from_millis(1000),
        "{:?}",
        t.elapsed()
    );
    long.await.unwrap().unwrap();
    state.person(id, false, |_, _| Ok(())).await.unwrap();
}

/// A body that never comes (a client that stalls after its head).
struct Stalled;

impl http_body::Body for Stalled {
    type Data = axum::body::Bytes;
    type Error = std::convert::Infallible;
    fn poll_frame(
        self: std::pin::Pin<&mut Self>,
        _: &mut std::task::Context<'_>,
    ) -> std::task::Poll<Option<Result<http_body::Frame<Self::Data>, Self::Error>>> {
        std::task::Poll::Pending
    }
}

/// One client address holds at most its share of the requests in flight
/// (a probe held every slot with one token's 270 slow bodies, and another
/// person's events got 503 while it went on): past it, that client gets
/// 503 with `Retry-After` while another client is served, and its slots
/// come back when its requests end.
#[tokio::test]
async fn one_client_cannot_hold_every_slot_in_flight() {
    use axum::extract::ConnectInfo;
    use std::net::SocketAddr;
    use tower::ServiceExt;
    let svc = Svc::new();
    let state = AppState::open(&svc.db, StoreSettings::default()).unwrap();
    let router = abba_service::server::router_with(
        state,
        &ServeSettings {
            max_in_flight_per_client: 2,
            ..ServeSettings::default()
        },
    );
    let from = |ip: [u8; 4], mut req: axum::http::Request<axum::body::Body>| {
        req.extensions_mut()
            .insert(ConnectInfo(SocketAddr::from((ip, 40_000))));
        req
    };
    let stalled = || {
        axum::http::Request::builder()
            .method(Method::POST)
            .uri("/v1/persons")
            .header("authorization", format!("Bearer {}", svc.admin))
            .header("content-type", "application/json")
            .header("content-length", "100")
            .body(axum::body::Body::new(Stalled))
            .unwrap()
    };
    let health = || {
        axum::http::Request::builder()
            .uri("/healthz")
            .body(axum::body::Body::empty())
            .unwrap()
    };
    let held: Vec<_> = (0..2)
        .map(|_| tokio::spawn(router.clone().oneshot(from([203, 0, 113, 7], stalled()))))
        .collect();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let r = router
        .clone()
        .oneshot(from([203, 0, 113, 7], health()))
        .await
        .unwrap();
    assert_eq!(r.status(), StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(r.headers()["retry-after"], "1");
    let other = router
        .clone()
        .oneshot(from([198, 51, 100, 9], health()))
        .await
        .unwrap();
    assert_eq!(other.status(), StatusCode::OK);
    for h in held {
        h.abort();
        let _ = h.await;
    }
    let again = router
        .oneshot(from([203, 0, 113, 7], health()))
        .await
        .unwrap();
    assert_eq!(again.status(), StatusCode::OK);
}

#[test]
fn the_service_refuses_a_read_only_store() {
    use std::os::unix::fs::PermissionsExt;
    let svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!("the_service_refuses_a_read_only_store: a read-only SQLite file");
        return;
    }
    let db = svc.db.clone();
    let mut p = std::fs::metadata(&db).unwrap().permissions();
    p.set_mode(0o444);
    std::fs::set_permissions(&db, p).unwrap();
    let e = match AppState::open(&db, StoreSettings::default()) {
        Ok(_) => panic!("a read-only store was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("cannot be written"), "{e}");
}

#[tokio::test]
async fn an_event_dated_in_the_future_is_refused_and_an_old_one_removed() {
    let svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!("an_event_dated_in_the_future_is_refused_and_an_old_one_removed: writes the SQLite file directly");
        return;
    }
    let id = svc.person("alice").await;
    let now = jiff::Timestamp::now();
    let future = now + jiff::SignedDuration::from_mins(abba_core::limits::FUTURE_SKEW_MINUTES + 5);
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&svc.admin),
            Some(&json!({"events": [
                cgm(0, 10, 120.0),
                {"seq": 1, "at": future.to_string(), "event": {"type": "day_closed"}}
            ]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert_eq!(r.json["path"], "events[1].at");
    let msg = r.json["message"].as_str().unwrap();
    assert!(msg.contains("seq 1") && msg.contains("day_closed"), "{msg}");
    assert!(msg.contains("server's clock"), "{msg}");
    // Nothing of the batch was stored.
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/sync"),
            Some(&svc.admin),
            None,
        )
        .await;
    assert_eq!(r.json["last_seq"], serde_json::Value::Null, "{}", r.text);
    // An older abba stored one: the check lists it, remove_future deletes
    // exactly it, and the service sees the change.
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&svc.admin),
            Some(&json!({"events": [cgm(0, 10, 120.0), cgm(1, 15, 121.0)]})),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    // (Written with SQLite itself: no abba writes such a row any more.)
    rusqlite::Connection::open(&svc.db)
        .unwrap()
        .execute(
            "INSERT INTO app_event (person_id, seq, at_ms, at_min, tag, kind, hash, received_at) VALUES (?1, 7, ?2, 9999999, 'day_closed', '\"DayClosed\"', x'00', 'old')",
            rusqlite::params![id as i64, future.as_millisecond()],
        )
        .unwrap();
    let mut store = abba_store::Store::open(&svc.db).unwrap();
    let report = store.check(now).unwrap();
    assert_eq!(report.future.len(), 1, "{report:?}");
    assert_eq!(report.future[0].id, "seq 7");
    assert!(!report.ok());
    let gone = store.remove_future(now).unwrap();
    assert_eq!(gone, report.future);
    assert!(store.check(now).unwrap().ok());
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/sync"),
            Some(&svc.admin),
            None,
        )
        .await;
    assert_eq!(
        r.json["held"],
        json!([{"first": 0, "last": 1}]),
        "{}",
        r.text
    );
    let _ = at(0);
}

#[tokio::test]
async fn the_live_advisor_cache_stays_bounded_and_reads_never_fill_it() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("store.db");
    // Far more persons than the cap (31 times; 10,000 took 16 s of the
    // suite for the same assertion).
    let persons = 2_000;
    let cap = 64;
    {
        let mut store = abba_store::Store::open(&db).unwrap();
        let start = abba_core::TherapySettings {
            basal: abba_core::UnitsPerHour(1.0),
            carb_ratio: [abba_core::GramsPerUnit(10.0); 3],
        };
        for i in 0..persons {
            let mut p =
                abba_store::NewPerson::new(&format!("p{i}"), "UTC", abba_advisor::Mode::Cgm, start);
            p.first_day = Some(jiff::civil::date(2026, 1, 1));
            store.create_person(&p).unwrap();
        }
    }
    let (_, admin) = abba_service::new_admin_token(&db).unwrap();
    let state = AppState::open(
        &db,
        StoreSettings {
            cache_persons: cap,
            ..StoreSettings::default()
        },
    )
    .unwrap();
    let router = abba_service::router(state.clone());
    use tower::ServiceExt;
    let call = |method: Method, uri: String, body: Option<serde_json::Value>| {
        let mut req = axum::http::Request::builder()
            .method(method)
            .uri(uri)
            .header("authorization", format!("Bearer {admin}"));
        let body = match body {
            Some(b) => {
                req = req.header("content-type", "application/json");
                axum::body::Body::from(serde_json::to_vec(&b).unwrap())
            }
            None => axum::body::Body::empty(),
        };
        router.clone().oneshot(req.body(body).unwrap())
    };
    // Reads create nothing.
    for id in 1..=100 {
        let r = call(Method::GET, format!("/v1/persons/{id}/advice"), None)
            .await
            .unwrap();
        assert_eq!(r.status(), StatusCode::OK);
    }
    assert_eq!(state.cached_persons(), 0);
    let mut most = 0;
    for id in 1..=persons {
        let r = call(
            Method::POST,
            format!("/v1/persons/{id}/events"),
            Some(json!({"events": [cgm(0, 10, 120.0)]})),
        )
        .await
        .unwrap();
        assert_eq!(r.status(), StatusCode::OK);
        if id % 100 == 0 {
            most = most.max(state.cached_persons());
        }
    }
    most = most.max(state.cached_persons());
    println!("{persons} persons posted, at most {most} live advisors cached (cap {cap})");
    assert!(most <= cap, "{most} cached, cap {cap}");
    assert!(state.is_cached(persons as i64), "the latest one is kept");
}

#[tokio::test]
async fn the_cache_is_bounded_by_the_events_its_advisors_hold() {
    let svc = Svc::new();
    let budget = 3_000;
    let state = AppState::open(
        &svc.db,
        StoreSettings {
            cache_persons: 1000,
            cache_events: budget,
            ..StoreSettings::default()
        },
    )
    .unwrap();
    let router = abba_service::router(state.clone());
    use tower::ServiceExt;
    let post = |id: u64, events: Vec<serde_json::Value>| {
        let req = axum::http::Request::builder()
            .method(Method::POST)
            .uri(format!("/v1/persons/{id}/events"))
            .header("authorization", format!("Bearer {}", svc.admin))
            .header("content-type", "application/json")
            .body(axum::body::Body::from(
                serde_json::to_vec(&json!({ "events": events })).unwrap(),
            ))
            .unwrap();
        router.clone().oneshot(req)
    };
    let mut ids = Vec::new();
    for k in 0..40 {
        let id = svc.person(&format!("p{k}")).await;
        // 400 CGM readings each: at most 7 such persons fit in the budget.
        let events: Vec<_> = (0..400).map(|i| cgm(i, 5 * i as i64, 120.0)).collect();
        assert_eq!(post(id, events).await.unwrap().status(), StatusCode::OK);
        ids.push(id);
        assert!(
            state.cached_events() <= budget,
            "{} events cached, budget {budget}",
            state.cached_events()
        );
    }
    let (n, events) = (state.cached_persons(), state.cached_events());
    println!("40 persons of 400 events posted: {n} live advisors holding {events} events cached (budget {budget})");
    assert!((1..=7).contains(&n), "{n} cached");
    assert!(
        state.is_cached(*ids.last().unwrap() as i64),
        "the latest one is kept"
    );
    // A person with more events than the whole budget is not kept, and
    // still answers (rebuilt from the store on each use).
    let big = svc.person("big").await;
    for chunk in 0..2 {
        let events: Vec<_> = (0..2000)
            .map(|i| {
                let seq = chunk * 2000 + i;
                cgm(seq, 5 * seq as i64, 120.0)
            })
            .collect();
        assert_eq!(post(big, events).await.unwrap().status(), StatusCode::OK);
    }
    assert!(!state.is_cached(big as i64));
    assert!(state.cached_events() <= budget);
    let r = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{big}/sync"),
            Some(&svc.admin),
            None,
        )
        .await;
    assert_eq!(r.json["last_seq"], 3999, "{}", r.text);
}

/// The failed-token limit slows a guesser down without locking anybody
/// out: behind a proxy or a carrier's NAT every client shares one address,
/// so a valid token from an address over its limit still gets in (an
/// attacker's probe: 30 bad tokens a minute locked every app out).
#[test]
fn a_valid_token_gets_in_from_an_address_over_its_failed_tokens() {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            store: StoreSettings {
                auth_failures: 3,
                ..StoreSettings::default()
            },
            ..ServeSettings::default()
        },
    );
    let get = |auth: &str| {
        raw(
            server.addr,
            &format!(
                "GET /v1/openapi.json HTTP/1.1\r\nHost: x\r\nAuthorization: {auth}\r\nConnection: close\r\n\r\n"
            ),
        )
    };
    let unknown = format!("Bearer abba_{}", "0".repeat(64));
    for _ in 0..3 {
        let r = get(&unknown);
        assert!(r.starts_with("HTTP/1.1 401"), "{r}");
    }
    for auth in [unknown.as_str(), "Bearer nonsense", "Basic abc"] {
        let r = get(auth);
        assert!(r.starts_with("HTTP/1.1 429"), "{auth}: {r}");
        assert!(r.to_ascii_lowercase().contains("retry-after:"), "{r}");
    }
    let valid = format!("Bearer {}", svc.admin);
    let r = get(&valid);
    assert!(
        r.starts_with("HTTP/1.1 200"),
        "the valid token from the same address: {r}"
    );
    let r = get(&unknown);
    assert!(
        r.starts_with("HTTP/1.1 429"),
        "still limited for bad tokens: {r}"
    );
}

/// A page's POST from a client without a live session is refused before
/// its body is read (an attacker's probe held every request slot of
/// `/log/reading` and `/signin`'s neighbours with bodies sent a byte every
/// few seconds, so real persons' readings got 503).
#[test]
fn a_page_post_without_a_live_session_is_refused_before_its_body() {
    let svc = Svc::new();
    let server = Server::start(&svc.db, ServeSettings::default());
    let addr = server.addr;
    let zeros = "0".repeat(64);
    for (path, cookie) in [
        ("/log/reading", String::new()),
        ("/log/meal", format!("Cookie: abba_session={zeros}\r\n")),
        ("/answer", String::new()),
        (
            "/clinic/persons/1/bounds",
            format!("Cookie: abba_session={zeros}\r\n"),
        ),
        ("/clinic/persons/1/import", String::new()),
        ("/signout", String::new()),
    ] {
        let mut s = TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        let t = Instant::now();
        s.write_all(
            format!(
                "POST {path} HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\n{cookie}Content-Type: application/x-www-form-urlencoded\r\nContent-Length: 60000\r\n\r\ncsrf="
            )
            .as_bytes(),
        )
        .unwrap();
        let mut head = Vec::new();
        let mut b = [0u8; 1024];
        while !head.windows(4).any(|w| w == b"\r\n\r\n") {
            match s.read(&mut b) {
                Ok(0) | Err(_) => break,
                Ok(n) => head.extend_from_slice(&b[..n]),
            }
        }
        let head = String::from_utf8_lossy(&head);
        assert!(head.starts_with("HTTP/1.1 403"), "{path}: {head}");
        assert!(
            t.elapsed() < Duration::from_secs(3),
            "{path}: answered after {:?}, not before the body",
            t.elapsed()
        );
    }
}

/// A client's `X-Request-Id` comes back only when it is a plain token (a
/// proxy's, for log correlation); markup or an overlong one is replaced by
/// the service's own.
#[tokio::test]
async fn a_request_id_is_echoed_only_when_it_is_a_plain_token() {
    let svc = Svc::new();
    let id_for = |sent: &'static str| {
        let router = svc.router.clone();
        async move {
            let req = axum::http::Request::builder()
                .uri("/healthz")
                .header("x-request-id", sent)
                .body(axum::body::Body::empty())
                .unwrap();
            use tower::ServiceExt;
            let res = router.oneshot(req).await.unwrap();
            res.headers()["x-request-id"].to_str().unwrap().to_string()
        }
    };
    assert_eq!(id_for("proxy-7f3a.12_b").await, "proxy-7f3a.12_b");
    for bad in ["<script>abc", "a b", "x/../y"] {
        let got = id_for(bad).await;
        assert_ne!(got, bad);
        assert!(
            got.bytes().all(|c| c.is_ascii_hexdigit() || c == b'-'),
            "{got}"
        );
    }
    let long: &'static str = Box::leak("a".repeat(65).into_boxed_str());
    assert_ne!(id_for(long).await, long);
}

/// Past the connection limit, with a request in flight on every
/// connection (nothing to evict: `tests/connections.rs`), a new client is
/// told 503 with Retry-After (the probe's clients got a reset), and once a
/// held connection goes the next is served.
#[test]
fn a_connection_past_the_limit_gets_503_not_a_reset() {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            max_connections: 4,
            ..ServeSettings::default()
        },
    );
    // A valid token's body that never comes: a request in flight each.
    let held = common::sock::held_posts(server.addr, &svc.admin, 4, |_| String::new());
    std::thread::sleep(Duration::from_millis(200));
    let r = raw(
        server.addr,
        "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
    );
    assert!(r.starts_with("HTTP/1.1 503"), "{r}");
    assert!(r.contains("retry-after: 1"), "{r}");
    assert!(r.contains("\"code\":\"busy\""), "{r}");
    drop(held);
    std::thread::sleep(Duration::from_millis(200));
    let r = raw(
        server.addr,
        "GET /healthz HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
    );
    assert!(r.starts_with("HTTP/1.1 200"), "{r}");
}

/// Sends `head`, then one byte of body every 300 ms until the service
/// answers (`done` says the answer is whole) or 10 s pass; the answer and
/// the time it took.
fn trickle(addr: SocketAddr, head: &str, done: impl Fn(&str) -> bool) -> (String, Duration) {
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    let t = Instant::now();
    s.write_all(head.as_bytes()).unwrap();
    let mut out = Vec::new();
    let mut b = [0u8; 4096];
    while t.elapsed() < Duration::from_secs(10) {
        let _ = s.write_all(b" ");
        match s.read(&mut b) {
            Ok(0) => break,
            Ok(n) => out.extend_from_slice(&b[..n]),
            Err(_) => {}
        }
        if done(&String::from_utf8_lossy(&out)) {
            break;
        }
    }
    (String::from_utf8_lossy(&out).to_string(), t.elapsed())
}

/// A body sent a byte at a time gets 408 once the body timeout is over
/// counted from its head, not from its last byte (tower-http's timeout
/// restarts with every frame: the probe's client, a byte every 5 s, held
/// `/signin` until the 60 s request timeout), whatever length it declares
/// (a later probe held every sign-in slot with 270 bodies declared at 1 MB,
/// a byte every 3 s, when only bodies of 64 KiB or less had the deadline);
/// and a form of the pages declaring more than a form holds gets 413 at
/// once (the sign-in form took 1 MiB).
#[test]
fn a_body_sent_a_byte_at_a_time_gets_408_at_the_body_timeout_and_a_large_form_413() {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            body_timeout: Duration::from_secs(2),
            ..ServeSettings::default()
        },
    );
    let addr = server.addr;
    for head in [
        format!(
            "POST /signin HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\nContent-Type: application/x-www-form-urlencoded\r\nContent-Length: 200\r\n\r\n"
        ),
        format!(
            "POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {}\r\nContent-Type: application/json\r\nContent-Length: 1000000\r\n\r\n",
            svc.admin
        ),
    ] {
        let (text, took) = trickle(addr, &head, |t| t.contains("\r\n\r\n"));
        assert!(text.starts_with("HTTP/1.1 408"), "{text}");
        assert!(took < Duration::from_secs(4), "answered after {took:?}");
    }
    let mut s = TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let t = Instant::now();
    s.write_all(
        format!(
            "POST /signin HTTP/1.1\r\nHost: {addr}\r\nOrigin: http://{addr}\r\nContent-Type: application/x-www-form-urlencoded\r\nContent-Length: 1000000\r\n\r\n"
        )
        .as_bytes(),
    )
    .unwrap();
    let mut out = Vec::new();
    let _ = s.read_to_end(&mut out);
    let text = String::from_utf8_lossy(&out);
    assert!(text.starts_with("HTTP/1.1 413"), "{text}");
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
}

/// A large body trickled past the request timeout gets the service's 408
/// body (`code: timeout`), not an empty one (the probe saw `content-length:
/// 0`).
#[test]
fn the_request_timeout_answers_with_the_services_408_body() {
    let svc = Svc::new();
    let server = Server::start(
        &svc.db,
        ServeSettings {
            request_timeout: Duration::from_secs(2),
            ..ServeSettings::default()
        },
    );
    let (text, _) = trickle(
        server.addr,
        &format!(
            "POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {}\r\nContent-Type: application/json\r\nContent-Length: 100000\r\n\r\n",
            svc.admin
        ),
        |t| t.contains("\"code\""),
    );
    assert!(text.starts_with("HTTP/1.1 408"), "{text}");
    assert!(text.contains("\"code\":\"timeout\""), "{text}");
}

/// A request declaring a body over the limit is refused at once (413, the
/// connection closed), its body never read: no `100 Continue` to a client
/// that asked, no wait for a body that never comes. A clinic's upload
/// keeps its larger limit.
#[test]
fn a_declared_body_over_the_limit_gets_413_at_once() {
    let svc = Svc::new();
    let server = Server::start(&svc.db, ServeSettings::default());
    let admin = svc.admin.clone();
    for (what, head) in [
        (
            "expect 100-continue",
            format!("POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {admin}\r\nContent-Type: application/json\r\nContent-Length: 5000000\r\nExpect: 100-continue\r\n\r\n"),
        ),
        (
            "no body",
            format!("POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {admin}\r\nContent-Type: application/json\r\nContent-Length: 99999999999\r\n\r\n"),
        ),
        (
            "a page",
            "POST /log/meal HTTP/1.1\r\nHost: x\r\nContent-Type: application/x-www-form-urlencoded\r\nContent-Length: 5000000\r\nExpect: 100-continue\r\n\r\n".to_string(),
        ),
    ] {
        let mut s = TcpStream::connect(server.addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        let t = Instant::now();
        s.write_all(head.as_bytes()).unwrap();
        let mut out = Vec::new();
        let _ = s.read_to_end(&mut out);
        let took = t.elapsed();
        let text = String::from_utf8_lossy(&out);
        assert!(text.starts_with("HTTP/1.1 413"), "{what}: {text}");
        assert!(!text.contains("100 Continue"), "{what}: {text}");
        assert!(took < Duration::from_secs(2), "{what}: after {took:?}");
    }
    let json = raw(
        server.addr,
        &format!("POST /v1/persons HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {admin}\r\nContent-Type: application/json\r\nContent-Length: 99999999999\r\n\r\n"),
    );
    assert!(json.contains("\"code\":\"too_large\""), "{json}");
    // An upload of 5 MB is within the clinic's limit: not refused for its
    // length (here 403: no session, before its body).
    let upload = raw(
        server.addr,
        &format!("POST /clinic/persons/1/import HTTP/1.1\r\nHost: {0}\r\nOrigin: http://{0}\r\nContent-Type: multipart/form-data; boundary=x\r\nContent-Length: 5000000\r\nExpect: 100-continue\r\n\r\n", server.addr),
    );
    assert!(upload.starts_with("HTTP/1.1 403"), "{upload}");
}

#[test]
fn the_service_binds_a_name_or_an_address_and_a_taken_port_is_an_error() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        use abba_service::server::bind;
        let by_name = bind("localhost:0").await.unwrap();
        assert!(by_name.local_addr().unwrap().ip().is_loopback());
        let first = bind("127.0.0.1:0").await.unwrap();
        let taken = first.local_addr().unwrap();
        let e = bind(&taken.to_string()).await.unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::AddrInUse, "{e}");
        // No port: refused before anything is bound.
        assert!(bind("127.0.0.1").await.is_err());
    });
}
