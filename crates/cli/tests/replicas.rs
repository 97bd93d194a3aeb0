//! Replicas: two `abba serve` processes on one PostgreSQL database behind
//! a round-robin balancer (this test's own: each request goes to the next
//! replica, on a connection of its own) answer as one service.
//!
//! 1. The reference client (the CLI's `remote`) plays the pump app of one
//!    simulated patient for 98 days through the balancer: the decisions
//!    are exactly the in-process trial's ABBA arm's, in order, and every
//!    event is held once. Each replica serves about half of the requests,
//!    so each one's live advisor is repeatedly found stale (the person's
//!    revision in the database) and rebuilt.
//! 2. One replica is killed with SIGKILL 20 times under four concurrent
//!    clients while the other keeps serving: every acknowledged event is
//!    stored exactly once, as sent.
//!
//! Needs `ABBA_TEST_POSTGRES` (started by `.ci/run`); skipped with a
//! notice without it, an error under CI=true.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::remote;
use crate::service_common;

use abba_api::EventsBody;
use abba_client::{Client, Outbox, Retry};
use abba_core::{EventKind, MgDl};
use abba_sim::person::SuggestionResponse;
use abba_sim::scenario::ScenarioId;
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::{ArmKind, RawTrialConfig};
use abba_trial::runner::build_cohort;
use abba_trial::TrialConfig;
use remote::{wire_event, RemoteApp};
use service_common::{admin_token, Server};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// A balancer on a loopback port: each request (read whole: head and
/// `Content-Length` body) goes to the next backend with `Connection:
/// close`, and its response goes back; the client's connection is closed
/// after it, so the next request is the next backend's. A backend that
/// does not answer closes the client's connection unanswered (the client
/// retries).
struct Balancer {
    addr: String,
    /// Requests each backend answered.
    served: Arc<Vec<AtomicUsize>>,
    stop: Arc<AtomicBool>,
}

fn read_request(c: &mut TcpStream) -> Option<Vec<u8>> {
    let mut buf = Vec::new();
    let mut chunk = [0u8; 8192];
    let head_end = loop {
        if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
            break i + 4;
        }
        let n = c.read(&mut chunk).ok()?;
        if n == 0 {
            return None;
        }
        buf.extend_from_slice(&chunk[..n]);
    };
    let head = String::from_utf8_lossy(&buf[..head_end]).to_string();
    let len = head
        .lines()
        .find_map(|l| {
            let (k, v) = l.split_once(':')?;
            k.eq_ignore_ascii_case("content-length")
                .then(|| v.trim().parse::<usize>().ok())?
        })
        .unwrap_or(0);
    while buf.len() < head_end + len {
        let n = c.read(&mut chunk).ok()?;
        if n == 0 {
            return None;
        }
        buf.extend_from_slice(&chunk[..n]);
    }
    // The same request, asking the backend to close after answering.
    let mut out = Vec::with_capacity(buf.len() + 20);
    for line in head.split("\r\n").filter(|l| !l.is_empty()) {
        if !line.to_ascii_lowercase().starts_with("connection:") {
            out.extend_from_slice(line.as_bytes());
            out.extend_from_slice(b"\r\n");
        }
    }
    out.extend_from_slice(b"Connection: close\r\n\r\n");
    out.extend_from_slice(&buf[head_end..]);
    Some(out)
}

impl Balancer {
    fn start(backends: Arc<Mutex<Vec<String>>>) -> Self {
        let l = TcpListener::bind("127.0.0.1:0").unwrap();
        l.set_nonblocking(true).unwrap();
        let addr = l.local_addr().unwrap().to_string();
        let n = backends.lock().unwrap().len();
        let served: Arc<Vec<AtomicUsize>> = Arc::new((0..n).map(|_| AtomicUsize::new(0)).collect());
        let stop = Arc::new(AtomicBool::new(false));
        let (s2, st2) = (served.clone(), stop.clone());
        std::thread::spawn(move || {
            let next = Arc::new(AtomicUsize::new(0));
            while !st2.load(Ordering::Relaxed) {
                let Ok((mut c, _)) = l.accept() else {
                    std::thread::sleep(Duration::from_millis(1));
                    continue;
                };
                let (backends, served, next) = (backends.clone(), s2.clone(), next.clone());
                std::thread::spawn(move || {
                    c.set_nonblocking(false).unwrap();
                    c.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
                    let Some(req) = read_request(&mut c) else {
                        return;
                    };
                    let k = next.fetch_add(1, Ordering::Relaxed) % served.len();
                    let to = backends.lock().unwrap()[k].clone();
                    let Ok(mut b) = TcpStream::connect(&to) else {
                        return;
                    };
                    b.set_read_timeout(Some(Duration::from_secs(60))).unwrap();
                    if b.write_all(&req).is_err() {
                        return;
                    }
                    let mut resp = Vec::new();
                    if b.read_to_end(&mut resp).is_err() || resp.is_empty() {
                        return;
                    }
                    if c.write_all(&resp).is_ok() {
                        served[k].fetch_add(1, Ordering::Relaxed);
                    }
                });
            }
        });
        Balancer { addr, served, stop }
    }

    fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    fn served(&self) -> Vec<usize> {
        self.served
            .iter()
            .map(|a| a.load(Ordering::Relaxed))
            .collect()
    }
}

impl Drop for Balancer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// A fresh PostgreSQL store, or `None` (skipped) without a server.
fn database(test: &str) -> Option<PathBuf> {
    let base = crate::store_common::postgres_or_skip(test)?;
    Some(PathBuf::from(abba_store::testing::fresh_schema(&base)))
}

#[test]
fn two_replicas_on_one_postgres_make_the_in_process_trials_decisions() {
    let Some(db) = database("two_replicas_on_one_postgres_make_the_in_process_trials_decisions")
    else {
        return;
    };
    let (scenario, patient_no, days) = (ScenarioId::S1, 3u64, 98u32);
    let config = TrialConfig::try_from(RawTrialConfig {
        patients: patient_no as u32,
        days,
        calibrate_te_ref: false,
        scenarios: vec![scenario],
        arms: vec![ArmKind::Abba],
        suggestions: SuggestionResponse::AcceptAll,
        ..RawTrialConfig::default()
    })
    .unwrap();
    let cohort = build_cohort(&config).unwrap();
    let vp = &cohort.patients[patient_no as usize - 1];
    let planned = config.planned_scenario(scenario).unwrap().clone();
    let mut trace = Trace {
        decisions: Some(Vec::new()),
        ..Default::default()
    };
    let reference =
        run_patient_with(&config, vp, patient_no, &planned, ArmKind::Abba, &mut trace).unwrap();
    let decisions = trace.decisions.unwrap();
    assert!(decisions.len() as u32 > 3 * (days - 9));

    let token = admin_token(&db);
    let (a, b) = (Server::start(&db), Server::start(&db));
    let lb = Balancer::start(Arc::new(Mutex::new(vec![a.addr.clone(), b.addr.clone()])));
    let admin = Client::new(&lb.url(), Some(&token)).unwrap();
    let first_day: jiff::civil::Date = "2026-03-02".parse().unwrap();
    let name = format!("{}-replicas", vp.params.name);
    let body = remote::person_body(&config, vp, patient_no, &planned, first_day, &name).unwrap();
    let created = admin.create_person(&body).unwrap();
    let issued = admin.issue_token(created.id).unwrap();
    let app = RemoteApp {
        client: admin.with_token(&issued.token),
        person: created.id,
        first_day,
        retry: Retry::never(),
    };
    let run = remote::run_remote(&config, vp, patient_no, &planned, &app).unwrap();
    let served = lb.served();
    eprintln!(
        "{days} days through two replicas: requests served {served:?}, {} posts, {} events",
        run.outbox.posts, run.outbox.acked
    );
    assert!(
        served.iter().all(|&n| n > 100),
        "both replicas served: {served:?}"
    );
    assert_eq!(
        run.suggestions.len(),
        decisions.len(),
        "number of suggestions"
    );
    for (k, (d, s)) in decisions.iter().zip(&run.suggestions).enumerate() {
        let (minute, setting) = abba_api::Setting::from_suggestion_id(s.id);
        assert_eq!(
            (minute as i64, Some(setting), s.previous, s.value),
            (d.at.0, remote::setting(d.parameter), d.old, d.new),
            "suggestion {k} (in process: {d})"
        );
    }
    assert_eq!(run.final_settings.basal.0, reference.final_basal_u_per_h);
    assert_eq!(
        run.final_settings.carb_ratio.map(|c| c.0),
        reference.final_carb_ratio_g_per_u
    );
    let o = run.outbox;
    assert_eq!((o.failures, o.acked, o.stored), (0, o.pushed, o.pushed));
    let sync = app.client.sync(created.id, 0).unwrap();
    assert_eq!(
        sync.held
            .iter()
            .map(|h| (h.first, h.last))
            .collect::<Vec<_>>(),
        [(0, o.pushed - 1)]
    );
}

/// A client posting CGM readings (batches of 1 to 30) through the
/// balancer until `stop`; every number it learnt held.
fn post_until(
    client: Client,
    person: u64,
    stop: Arc<AtomicBool>,
    day1_ms: i64,
) -> (Vec<(i64, EventKind)>, Vec<u64>) {
    let mut outbox = Outbox::new(person);
    let retry = Retry {
        first_wait: Duration::from_millis(5),
        max_wait: Duration::from_millis(100),
        give_up_after: Duration::from_secs(60),
    };
    let (mut sent, mut acked) = (Vec::new(), Vec::new());
    let mut i: i64 = 0;
    while !stop.load(Ordering::Relaxed) {
        for _ in 0..(1 + (i * 7919 + person as i64) % 30) {
            let ms = day1_ms + i * 300_000;
            let kind = EventKind::Cgm(MgDl(80.0 + (i % 150) as f64));
            let at = jiff::Timestamp::from_millisecond(ms).unwrap().to_string();
            outbox.push(at, wire_event(&kind).unwrap().unwrap());
            sent.push((ms, kind));
            i += 1;
        }
        let f = outbox
            .flush(&client, &retry)
            .unwrap_or_else(|e| panic!("person {person}: {e}"));
        acked.extend(f.held);
    }
    assert!(outbox.pending().is_empty());
    (sent, acked)
}

#[test]
fn a_replica_killed_twenty_times_loses_no_acknowledged_event_and_stores_none_twice() {
    let Some(db) =
        database("a_replica_killed_twenty_times_loses_no_acknowledged_event_and_stores_none_twice")
    else {
        return;
    };
    let token = admin_token(&db);
    let mut a = Server::start(&db);
    let b = Server::start(&db);
    let backends = Arc::new(Mutex::new(vec![a.addr.clone(), b.addr.clone()]));
    let lb = Balancer::start(backends.clone());
    let admin = Client::new(&lb.url(), Some(&token)).unwrap();
    let day1_ms = jiff::civil::date(2026, 3, 2)
        .to_zoned(jiff::tz::TimeZone::UTC)
        .unwrap()
        .timestamp()
        .as_millisecond();
    let mut persons = Vec::new();
    for c in 0..4 {
        persons.push(service_common::new_cgm_person(
            &admin,
            &format!("replica-{c}"),
            Some("2026-03-02"),
        ));
    }
    let stop = Arc::new(AtomicBool::new(false));
    let handles: Vec<_> = persons
        .iter()
        .map(|(id, tok)| {
            let (client, id, stop) = (admin.with_token(tok), *id, stop.clone());
            std::thread::spawn(move || post_until(client, id, stop, day1_ms))
        })
        .collect();
    let mut rng = 20_261_203u64;
    for _ in 0..20 {
        rng = rng.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        std::thread::sleep(Duration::from_millis(20 + (rng >> 33) % 200));
        a.restart();
        // The balancer follows the replica to its new port.
        backends.lock().unwrap()[0] = a.addr.clone();
    }
    stop.store(true, Ordering::Relaxed);
    let logs: Vec<_> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    drop(b);
    a.kill();
    let total: usize = logs.iter().map(|l| l.0.len()).sum();
    eprintln!(
        "20 kills of one replica: {total} events by 4 clients, served {:?}",
        lb.served()
    );
    assert_eq!(a.starts, 21);
    assert!(total > 1_000, "only {total} events");
    let store = abba_store::Store::open(&db).unwrap();
    for ((sent, acked), (id, _)) in logs.iter().zip(&persons) {
        let n = sent.len() as u64;
        let mut acked = acked.clone();
        acked.sort_unstable();
        assert_eq!(
            acked,
            (0..n).collect::<Vec<_>>(),
            "person {id}: each acknowledged once"
        );
        assert_eq!(
            store.app_event_count(*id as i64).unwrap(),
            n as i64,
            "person {id}"
        );
        for (seq, (ms, kind)) in sent.iter().enumerate() {
            let e = store.app_event(*id as i64, seq as u64).unwrap().unwrap();
            assert_eq!(e.event.kind, *kind, "person {id} seq {seq}");
            let minute = (ms - day1_ms) / 60_000;
            assert_eq!(e.event.at.0, minute, "person {id} seq {seq}");
        }
    }
    // Re-posting held events stores nothing.
    let (id, tok) = &persons[0];
    let again = EventsBody {
        events: (0..5u64)
            .map(|s| {
                let (ms, kind) = &logs[0].0[s as usize];
                abba_api::DeviceEvent {
                    seq: s,
                    at: jiff::Timestamp::from_millisecond(*ms).unwrap().to_string(),
                    event: wire_event(kind).unwrap().unwrap(),
                }
            })
            .collect(),
    };
    let b2 = Server::start(&db);
    let ack = Client::new(&b2.url(), Some(tok))
        .unwrap()
        .post_events(*id, &again)
        .unwrap();
    assert_eq!(ack.stored, 0);
}
