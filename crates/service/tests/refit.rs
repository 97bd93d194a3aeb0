//! The twin refitted in the background when a person's log changes
//! (issue 27, item 1), through the service's interface: a stand-in
//! refitter here whose refits wait at a gate the test opens, so that what
//! happens while a refit runs is seen, not timed. (The real refitter,
//! abba-twin's rule on the stored twin, is wired in by the `abba` binary
//! and tested in crates/cli/tests/twin_refit_cli.rs.)
//!
//! A person without a twin is never queued; a burst of 20 imports for one
//! person costs at most two refits (the one running and one more on the
//! data as it is then); requests are answered while a refit runs.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::refit::{RefitQueue, Scheduled};
use abba_store::effect::{RefitOutcome, TwinRefitter};
use axum::http::{Method, StatusCode};
use common::{cgm, ev, Svc};
use serde_json::json;
use std::collections::HashSet;
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// Refits wait at `gate` until it is opened; each refit records the person
/// and how many events their log held.
struct Gated {
    twins: HashSet<String>,
    gate: Mutex<bool>,
    opened: Condvar,
    calls: Mutex<Vec<(String, usize)>>,
}

impl Gated {
    fn new(twins: &[&str]) -> Arc<Self> {
        Arc::new(Self {
            twins: twins.iter().map(|s| s.to_string()).collect(),
            gate: Mutex::new(false),
            opened: Condvar::new(),
            calls: Mutex::new(Vec::new()),
        })
    }

    fn open(&self) {
        *self.gate.lock().unwrap() = true;
        self.opened.notify_all();
    }
}

impl TwinRefitter for Gated {
    fn has_twin(&self, person: &str) -> bool {
        self.twins.contains(person)
    }

    fn refit(&self, store: &abba_store::Store, person: &str) -> Result<RefitOutcome, String> {
        let mut open = self.gate.lock().unwrap();
        while !*open {
            open = self.opened.wait(open).unwrap();
        }
        drop(open);
        let n = store.events(person).map_err(|e| e.to_string())?.len();
        let mut calls = self.calls.lock().unwrap();
        calls.push((person.to_string(), n));
        Ok(RefitOutcome::Refitted {
            revision: calls.len() as u32 + 1,
            grade: "fair".into(),
        })
    }
}

fn service(refitter: Arc<Gated>) -> (Svc, RefitQueue) {
    let mut queue = None;
    let svc = Svc::with_setup(|state| {
        let q = RefitQueue::start(state.db(), refitter).unwrap();
        state.set_refits(q.clone()).unwrap();
        queue = Some(q);
    });
    (svc, queue.unwrap())
}

/// Polls `done` until it holds or `limit` passes (then fails with `what`).
fn wait_until(limit: Duration, what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < limit, "timed out waiting until {what}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Posts batch `k` (12 CGM readings an hour apart on day `k + 1`, and the
/// day's closing) for person `id`; returns how many events it held.
async fn post_day(svc: &Svc, id: u64, token: &str, k: u64) -> usize {
    let mut events = Vec::new();
    for h in 0..12u64 {
        let m = (k * 1440 + h * 60) as i64;
        events.push(cgm(k * 100 + h + 1, m, 120.0 + h as f64));
    }
    events.push(ev(
        k * 100 + 99,
        ((k + 1) * 1440) as i64,
        json!({"type": "day_closed"}),
    ));
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(token),
            Some(&json!({ "events": events })),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    events.len()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_burst_of_imports_costs_at_most_two_refits_and_requests_are_answered_meanwhile() {
    let refitter = Gated::new(&["ann"]);
    let (svc, queue) = service(Arc::clone(&refitter));
    let id = svc.person("ann").await;
    let (_, token) = svc.token(id).await;

    // The first import starts a refit (held at the gate).
    let mut posted = post_day(&svc, id, &token, 0).await;
    wait_until(Duration::from_secs(30), "the first refit runs", || {
        queue.counts().running
    });
    // 19 more imports while it runs: each answered, one refit queued.
    for k in 1..20 {
        posted += post_day(&svc, id, &token, k).await;
    }
    let c = queue.counts();
    assert!(c.running, "{c:?}");
    assert_eq!(c.waiting, 1, "coalesced into one waiting refit: {c:?}");
    // Requests are answered while the refit runs.
    let health = svc.call(Method::GET, "/healthz", None, None).await;
    assert_eq!(health.status, StatusCode::OK, "{}", health.text);
    let advice = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/advice"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(advice.status, StatusCode::OK, "{}", advice.text);
    assert!(queue.counts().running, "the refit was still running");

    refitter.open();
    wait_until(Duration::from_secs(30), "the refits are done", || {
        let c = queue.counts();
        !c.running && c.waiting == 0 && c.refitted == 2
    });
    let calls = refitter.calls.lock().unwrap().clone();
    assert_eq!(calls.len(), 2, "{calls:?}");
    // The second refit saw the whole burst.
    assert_eq!(calls[1], ("ann".to_string(), posted), "{calls:?}");
    assert_eq!(queue.counts().failed, 0);
    queue.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_person_without_a_twin_gets_no_refit() {
    let refitter = Gated::new(&["ann"]);
    let (svc, queue) = service(Arc::clone(&refitter));
    let id = svc.person("bob").await;
    let (_, token) = svc.token(id).await;
    post_day(&svc, id, &token, 0).await;
    post_day(&svc, id, &token, 1).await;
    // Scheduling is done inside the request: had bob been queued, he would
    // be waiting now or running (held at the closed gate).
    let c = queue.counts();
    assert_eq!((c.waiting, c.running), (0, false), "{c:?}");
    assert_eq!(queue.schedule("bob"), Scheduled::NoTwin);
    assert!(refitter.calls.lock().unwrap().is_empty());
    // A person with a twin is queued once, then coalesced.
    assert_eq!(queue.schedule("ann"), Scheduled::Queued);
    wait_until(Duration::from_secs(30), "ann's refit runs", || {
        queue.counts().running
    });
    assert_eq!(queue.schedule("ann"), Scheduled::Queued);
    assert_eq!(queue.schedule("ann"), Scheduled::Coalesced);
    refitter.open();
    wait_until(Duration::from_secs(30), "the refits are done", || {
        let c = queue.counts();
        !c.running && c.waiting == 0
    });
    // ann is not a person of this store: both refits failed, and said so.
    assert_eq!(queue.counts().failed, 2, "{:?}", queue.counts());
    queue.stop();
}
