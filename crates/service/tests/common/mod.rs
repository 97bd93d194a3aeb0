//! Shared by the service's tests: a store in a temporary folder, the
//! router called in-process, an admin token, persons with their tokens.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod sock;

use abba_service::{auth, AppState, ServeSettings};
use abba_store::token::Role;
use axum::body::Body;
use axum::http::{Method, Request, StatusCode};
use axum::Router;
use http_body_util::BodyExt;
use serde_json::{json, Value};
use std::net::SocketAddr;
use std::path::PathBuf;
use tower::ServiceExt;

/// A service over a fresh store.
pub struct Svc {
    pub dir: tempfile::TempDir,
    pub db: PathBuf,
    pub router: Router,
    pub admin: String,
}

/// A response.
#[derive(Debug)]
pub struct Resp {
    pub status: StatusCode,
    pub text: String,
    pub json: Value,
}

impl Svc {
    pub fn new() -> Self {
        Self::with_effects(None)
    }

    /// A service whose advice has each suggestion's predicted effect from
    /// `effects`.
    pub fn with_effects(effects: Option<abba_service::EffectSource>) -> Self {
        Self::with_setup(|state| {
            if let Some(e) = effects {
                state.set_effects(e).unwrap();
            }
        })
    }

    /// A service whose state `setup` completes before the router is built
    /// (it gets the store file through [`AppState::db`]).
    pub fn with_setup(setup: impl FnOnce(&AppState)) -> Self {
        let dir = tempfile::tempdir().unwrap();
        // An SQLite file, or a fresh PostgreSQL schema when the run asks
        // (ABBA_TEST_BACKEND=postgres).
        let db = abba_store::testing::store_location(dir.path(), "store.db");
        let mut store = abba_service::open_store(&db).unwrap();
        let (_, admin) = auth::issue(&mut store, Role::Admin).unwrap();
        drop(store);
        let state = AppState::open(&db, Default::default()).unwrap();
        setup(&state);
        let router = abba_service::router(state);
        Self {
            dir,
            db,
            router,
            admin,
        }
    }

    /// Sends a request; `token` None sends no Authorization header.
    pub async fn call(
        &self,
        method: Method,
        uri: &str,
        token: Option<&str>,
        body: Option<&Value>,
    ) -> Resp {
        let bytes = body.map(|b| serde_json::to_vec(b).unwrap());
        self.raw(method, uri, token.map(|t| format!("Bearer {t}")), bytes)
            .await
    }

    /// Sends raw bytes with a raw Authorization header value.
    pub async fn raw(
        &self,
        method: Method,
        uri: &str,
        authorization: Option<String>,
        body: Option<Vec<u8>>,
    ) -> Resp {
        let mut req = Request::builder().method(method).uri(uri);
        if let Some(a) = authorization {
            req = req.header("authorization", a);
        }
        let req = match body {
            Some(b) => req
                .header("content-type", "application/json")
                .body(Body::from(b))
                .unwrap(),
            None => req.body(Body::empty()).unwrap(),
        };
        let res = self.router.clone().oneshot(req).await.unwrap();
        let status = res.status();
        let bytes = res.into_body().collect().await.unwrap().to_bytes();
        let text = String::from_utf8_lossy(&bytes).to_string();
        let json = serde_json::from_slice(&bytes).unwrap_or(Value::Null);
        Resp { status, text, json }
    }

    /// Creates a person (CGM, UTC, day 1 = 2026-01-01; values unrounded as
    /// in the trial, `continuous_values`: the short synthetic streams'
    /// small updates stay updates, not a pump step's "no change"); returns
    /// the id.
    pub async fn person(&self, name: &str) -> u64 {
        self.person_with(json!({
            "name": name, "tz": "UTC", "mode": "cgm", "first_day": "2026-01-01",
            "continuous_values": true,
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await
    }

    /// Creates a person from a body; returns the id.
    pub async fn person_with(&self, body: Value) -> u64 {
        let r = self
            .call(Method::POST, "/v1/persons", Some(&self.admin), Some(&body))
            .await;
        assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
        r.json["id"].as_u64().unwrap()
    }

    /// Issues a person's token: (token id, token).
    pub async fn token(&self, person: u64) -> (u64, String) {
        let r = self
            .call(
                Method::POST,
                &format!("/v1/persons/{person}/tokens"),
                Some(&self.admin),
                None,
            )
            .await;
        assert_eq!(r.status, StatusCode::CREATED, "{}", r.text);
        (
            r.json["token_id"].as_u64().unwrap(),
            r.json["token"].as_str().unwrap().to_string(),
        )
    }
}

/// The RFC 3339 instant of advisor minute `m` for a person in UTC with day 1
/// = 2026-01-01.
pub fn at(m: i64) -> String {
    let t = jiff::Timestamp::from_second(1_767_225_600 + 60 * m).unwrap();
    t.to_string()
}

/// A wire event.
pub fn ev(seq: u64, minute: i64, event: Value) -> Value {
    json!({"seq": seq, "at": at(minute), "event": event})
}

/// A CGM reading.
pub fn cgm(seq: u64, minute: i64, mg_dl: f64) -> Value {
    ev(seq, minute, json!({"type": "cgm", "mg_dl": mg_dl}))
}

/// A service on a loopback port, in its own runtime thread; stopped on drop.
pub struct Server {
    pub addr: SocketAddr,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Server {
    /// The base URL.
    pub fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    /// Serves `db` with `set` on a free loopback port.
    pub fn start(db: &std::path::Path, set: ServeSettings) -> Self {
        let state = AppState::open(db, set.store.clone()).unwrap();
        let router = abba_service::router_with(state, &set);
        Self::start_router(router, set)
    }

    /// Serves `router` (the service's or a test's own) with the
    /// connection loop of `set` on a free loopback port.
    pub fn start_router(router: Router, set: ServeSettings) -> Self {
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let (bound, addr) = std::sync::mpsc::channel();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_multi_thread()
                .worker_threads(2)
                .enable_all()
                .build()
                .unwrap();
            rt.block_on(async move {
                // The socket `abba serve` has (its listen queue: a flood
                // of connects waits there, not in SYN retries).
                let listener = abba_service::server::bind("127.0.0.1:0").await.unwrap();
                bound.send(listener.local_addr().unwrap()).unwrap();
                abba_service::server::run_until(listener, router, &set, async {
                    let _ = rx.await;
                })
                .await;
            });
        });
        Self {
            addr: addr.recv().unwrap(),
            stop: Some(tx),
            thread: Some(thread),
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
