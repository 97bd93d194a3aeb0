//! `abba import` and `abba answer` on the store a running `abba serve`
//! writes to while four apps post to it: the CLI's write transactions and
//! the service's begin IMMEDIATE and wait for each other (busy timeout), so
//! every CLI command succeeds, no app gets a 500 and nobody sees "database
//! is locked". A 503 (the store stayed busy past the wait) is counted and
//! retried after its `Retry-After`, as the reference client does; the test
//! prints how many there were. Bounded: four apps, until the CLI work is
//! done or 120 s.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common;
use crate::service_common;

use abba_api::{DeviceEvent, EventBody, EventsBody, MealSlot};
use abba_client::{Client, ClientError};
use cli_common::abba;
use service_common::{admin_token, Server, TempDir};
use std::process::Output;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

const APPS: usize = 4;
const BUDGET: Duration = Duration::from_secs(120);

/// A CLI run that must succeed without a word about a locked or busy store.
fn cli_ok(args: &[&str]) -> String {
    let t = Instant::now();
    let out: Output = abba(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "abba {} failed after {:?}: {text}{err}",
        args[0],
        t.elapsed()
    );
    for bad in ["database is locked", "busy"] {
        assert!(
            !err.contains(bad) && !text.contains(bad),
            "abba {}: {err}",
            args[0]
        );
    }
    println!("abba {} took {:?}", args[0], t.elapsed());
    text
}

/// What an app saw.
#[derive(Default)]
struct AppLog {
    posts: u64,
    events: u64,
    busy: u64,
}

fn app(c: Client, person: u64, stop: Arc<AtomicBool>, day1: jiff::Timestamp) -> AppLog {
    let mut log = AppLog::default();
    let mut seq = 0u64;
    let started = Instant::now();
    while !stop.load(Ordering::Relaxed) && started.elapsed() < BUDGET {
        // 1 to 12 events: CGM every 5 minutes, a meal with its bolus at noon.
        let n = 1 + (seq % 12);
        let mut events = Vec::new();
        for _ in 0..n {
            let minute = 5 * seq as i64;
            let at = (day1 + jiff::SignedDuration::from_mins(minute)).to_string();
            let event = if minute % 1440 == 720 {
                EventBody::Meal {
                    carbs_g: 60.0,
                    slot: MealSlot::Lunch,
                }
            } else {
                EventBody::Cgm {
                    mg_dl: 110.0 + (seq % 40) as f64,
                }
            };
            events.push(DeviceEvent { seq, at, event });
            seq += 1;
        }
        let body = EventsBody { events };
        loop {
            match c.post_events(person, &body) {
                Ok(ack) => {
                    assert_eq!(ack.acked.len(), body.events.len());
                    log.posts += 1;
                    log.events += body.events.len() as u64;
                    break;
                }
                Err(e @ ClientError::Status { .. }) if e.status() == Some(503) => {
                    log.busy += 1;
                    std::thread::sleep(e.retry_after().unwrap_or(Duration::from_secs(1)));
                }
                Err(e) => panic!("person {person}: {e}"),
            }
        }
    }
    log
}

#[test]
fn import_and_answer_succeed_while_four_apps_post() {
    let dir = TempDir::new("cli-beside-service");
    let db = dir.0.join("store.db");
    let dbs = db.to_str().unwrap();
    let ns = dir.0.join("ns");
    cli_ok(&[
        "export",
        "--patient",
        "adult#002",
        "--days",
        "20",
        "--tz",
        "Europe/Zurich",
        "--out",
        ns.to_str().unwrap(),
    ]);
    let files: Vec<String> = ["entries.json", "treatments.json", "profile.json"]
        .iter()
        .map(|f| ns.join(f).display().to_string())
        .collect();
    let admin = admin_token(&db);
    cli_ok(&[
        "person",
        "new",
        "--db",
        dbs,
        "--name",
        "ana",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--basal",
        "1.0",
        "--carb-ratio",
        "10,12,11",
        "--basal-range",
        "0.8-1.2",
        "--carb-ratio-range",
        "8-14",
    ]);
    let server = Server::start(&db);
    let c = Client::new(&server.url(), Some(&admin)).unwrap();
    let day1 = jiff::Timestamp::now() - jiff::SignedDuration::from_hours(24 * 20);
    let stop = Arc::new(AtomicBool::new(false));
    let apps: Vec<_> = (0..APPS)
        .map(|k| {
            let (id, token) = service_common::new_cgm_person(&c, &format!("app-{k}"), None);
            let client = Client::new(&server.url(), Some(&token)).unwrap();
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || app(client, id, stop, day1))
        })
        .collect();
    // Let the apps get going, then the CLI writes beside them.
    std::thread::sleep(Duration::from_millis(300));
    let base = ["--db", dbs, "--person", "ana"];
    let mut import: Vec<&str> = vec!["import"];
    import.extend(base);
    import.extend(files.iter().map(String::as_str));
    import.push("--keep-therapy");
    let text = cli_ok(&import);
    assert!(text.contains("new records"), "{text}");
    let json = cli_ok(&[&["advise"][..], &base, &["--json"]].concat());
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(v["phase"]["phase"], "adapting", "{json}");
    let open = v["settings"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["latest"]["status"] == "open")
        .count();
    assert!(open > 0, "no open suggestion to answer: {json}");
    let text = cli_ok(&[&["answer"][..], &base, &["--accept"]].concat());
    assert!(text.contains("accepted"), "{text}");
    // The same files again, a few times (nothing new, still one write
    // transaction each).
    for _ in 0..5 {
        let text = cli_ok(&import);
        assert!(text.contains("Nothing new"), "{text}");
    }
    let text = cli_ok(&[&["history"][..], &base].concat());
    assert!(text.contains("accepted"), "{text}");
    stop.store(true, Ordering::Relaxed);
    let logs: Vec<AppLog> = apps.into_iter().map(|h| h.join().unwrap()).collect();
    let posts: u64 = logs.iter().map(|l| l.posts).sum();
    let events: u64 = logs.iter().map(|l| l.events).sum();
    let busy: u64 = logs.iter().map(|l| l.busy).sum();
    println!("{APPS} apps meanwhile: {posts} posts, {events} events acknowledged, {busy} answers 503 (retried)");
    assert!(logs.iter().all(|l| l.posts > 0), "an app posted nothing");
    // Every acknowledged event is held.
    for (k, l) in logs.iter().enumerate() {
        let id = (k + 2) as u64;
        let s = c.sync(id, 0).unwrap();
        assert_eq!(s.last_seq, Some(l.events - 1), "app {k}");
        assert_eq!(s.held.len(), 1, "app {k}: {:?}", s.held);
    }
}
