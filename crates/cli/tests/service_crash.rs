//! Crash safety under load: the real `abba serve` binary, [`CLIENTS`]
//! concurrent clients (threads) each posting a person's device events
//! (CGM readings every 5 minutes, meals with their boluses, day closings)
//! with their own sequence numbers in batches of 1 to 40, while the server
//! is killed with SIGKILL [`KILLS`] times at seeded random moments (10 to
//! 250 ms apart) and started again on the same store and port. The
//! clients retry, sync (`GET .../sync`) and re-send only what the service
//! does not hold (abba-client's outbox). A run posts some tens of
//! thousands of events (the test prints the counts; one run on the 2-core
//! machine: 40 kills, 69,075 events in 3,361 posts, 122 posts cut off by a
//! kill, 859 events committed whose acknowledgement was lost, in 8 s), and
//! the test requires both kinds of interruption to have happened: posts
//! without an answer, and events committed whose acknowledgement was lost.
//!
//! At the end: every event a client numbered was acknowledged exactly once
//! (by a post or found held by sync), the service holds exactly the
//! numbers 0..n of each person (one range), re-posting held events stores
//! nothing, and the store file has exactly one row per (person, seq) with
//! the instant and content the client sent, and nothing else.
//!
//! SIGKILL ends the process, not the machine: this checks that nothing is
//! acknowledged before COMMIT and that a re-sent batch is never stored
//! twice, not the disk's behaviour on power loss (which
//! `synchronous=FULL` is for).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod service_common;

/// The CLI's reference app (`abba app`), compiled as this test's own module.
#[path = "../src/remote.rs"]
#[allow(dead_code)]
mod remote;

use abba_api::EventsBody;
use abba_client::{Client, Outbox, Retry};
use abba_core::{EventKind, Grams, MealSlot, MgDl, Units};
use remote::wire_event;
use service_common::{admin_token, Server, TempDir};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Concurrent clients, one person each.
const CLIENTS: usize = 4;
/// SIGKILLs of the server.
const KILLS: u32 = 40;
/// Seed of the kill moments and batch sizes.
const SEED: u64 = 20_261_201;

/// SplitMix64: a small seeded generator (enough for test timings).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn range(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }
}

/// The device events of a person's 5-minute step `i` (minutes since day 1).
fn step_events(i: u64, rng: &mut Rng) -> Vec<(i64, EventKind)> {
    let minute = (i * 5) as i64;
    let mut out = vec![(
        minute,
        EventKind::Cgm(MgDl(70.0 + (rng.next() % 2000) as f64 / 10.0)),
    )];
    let of_day = minute % 1440;
    if of_day == 0 && minute > 0 {
        out.push((minute, EventKind::DayClosed));
    }
    for (at, slot) in [
        (420, MealSlot::Breakfast),
        (720, MealSlot::Lunch),
        (1140, MealSlot::Dinner),
    ] {
        if of_day == at {
            let carbs = 30.0 + (rng.next() % 60) as f64;
            out.push((
                minute,
                EventKind::MealAnnounced {
                    carbs: Grams(carbs),
                    slot,
                },
            ));
            out.push((minute, EventKind::Bolus(Units(carbs / 10.0))));
        }
    }
    out
}

/// What a client did.
struct ClientLog {
    person: u64,
    /// Every event it numbered: index = seq, (instant in ms, content).
    sent: Vec<(i64, EventKind)>,
    /// Every number learnt held, in the order learnt.
    acked: Vec<u64>,
    stats: abba_client::OutboxStats,
    suggestions: usize,
}

fn run_client(
    client: Client,
    person: u64,
    seed: u64,
    stop: Arc<AtomicBool>,
    day1_ms: i64,
) -> ClientLog {
    let mut rng = Rng(seed);
    let mut outbox = Outbox::new(person);
    let retry = Retry {
        first_wait: Duration::from_millis(5),
        max_wait: Duration::from_millis(100),
        give_up_after: Duration::from_secs(60),
    };
    let mut log = ClientLog {
        person,
        sent: Vec::new(),
        acked: Vec::new(),
        stats: Default::default(),
        suggestions: 0,
    };
    let mut step = 0;
    while !stop.load(Ordering::Relaxed) {
        let batch = rng.range(1, 40);
        for _ in 0..batch {
            for (minute, kind) in step_events(step, &mut rng) {
                let ms = day1_ms + minute * 60_000;
                let at = jiff::Timestamp::from_millisecond(ms).unwrap().to_string();
                outbox.push(at, wire_event(&kind).unwrap().unwrap());
                log.sent.push((ms, kind));
            }
            step += 1;
        }
        let flushed = outbox
            .flush(&client, &retry)
            .unwrap_or_else(|e| panic!("person {person}: {e}"));
        log.acked.extend(flushed.held);
        log.suggestions += flushed.answers.len();
    }
    assert!(outbox.pending().is_empty());
    log.stats = outbox.stats();
    log
}

#[test]
fn sigkill_under_load_loses_no_acknowledged_event_and_stores_none_twice() {
    let dir = TempDir::new("service-crash");
    let db = dir.0.join("abba.db");
    let token = admin_token(&db);
    let mut server = Server::start(&db);
    let admin = Client::new(&server.url(), Some(&token)).unwrap();
    let first_day = "2026-03-02";
    let day1_ms = jiff::civil::date(2026, 3, 2)
        .to_zoned(jiff::tz::TimeZone::UTC)
        .unwrap()
        .timestamp()
        .as_millisecond();
    let mut persons = Vec::new();
    for c in 0..CLIENTS {
        persons.push(service_common::new_cgm_person(
            &admin,
            &format!("crash-{c}"),
            Some(first_day),
        ));
    }

    let started = Instant::now();
    let stop = Arc::new(AtomicBool::new(false));
    let handles: Vec<_> = persons
        .iter()
        .enumerate()
        .map(|(c, (id, tok))| {
            let client = admin.with_token(tok);
            let (id, stop) = (*id, stop.clone());
            std::thread::spawn(move || run_client(client, id, SEED + 1 + c as u64, stop, day1_ms))
        })
        .collect();
    let mut rng = Rng(SEED);
    for _ in 0..KILLS {
        std::thread::sleep(Duration::from_millis(rng.range(10, 250)));
        server.kill();
        std::thread::sleep(Duration::from_millis(rng.range(0, 50)));
        server.restart();
    }
    stop.store(true, Ordering::Relaxed);
    let logs: Vec<ClientLog> = handles.into_iter().map(|h| h.join().unwrap()).collect();
    let secs = started.elapsed().as_secs_f64();

    let total: usize = logs.iter().map(|l| l.sent.len()).sum();
    let failures: u64 = logs.iter().map(|l| l.stats.failures).sum();
    let lost_acks: u64 = logs.iter().map(|l| l.stats.held_on_sync).sum();
    let posts: u64 = logs.iter().map(|l| l.stats.posts).sum();
    eprintln!(
        "{KILLS} kills, {} server starts in {secs:.1} s: {total} events in {posts} posts by {CLIENTS} clients; \
         {failures} posts without an answer, {lost_acks} events committed with the acknowledgement lost (found by sync), \
         {} suggestions",
        server.starts,
        logs.iter().map(|l| l.suggestions).sum::<usize>()
    );
    assert_eq!(server.starts, KILLS + 1);
    assert!(
        failures > 0,
        "no post was interrupted by a kill: the test did not test anything"
    );
    assert!(
        lost_acks > 0,
        "no kill fell between COMMIT and the acknowledgement: re-sending was not tested"
    );
    assert!(total > 5_000, "only {total} events posted");

    for (log, (_, tok)) in logs.iter().zip(&persons) {
        let n = log.sent.len() as u64;
        // Each number acknowledged exactly once, none unknown.
        let mut acked = log.acked.clone();
        acked.sort_unstable();
        assert_eq!(acked, (0..n).collect::<Vec<_>>(), "person {}", log.person);
        // The service holds exactly 0..n, one range.
        let client = admin.with_token(tok);
        let sync = client.sync(log.person, 0).unwrap();
        assert_eq!(sync.held.len(), 1, "person {}: {:?}", log.person, sync.held);
        assert_eq!((sync.held[0].first, sync.held[0].last), (0, n - 1));
        assert!(!sync.truncated);
        assert_eq!(client.advice(log.person).unwrap().data.records, n);
        // An app starting again goes on after the highest number held.
        let resumed = Outbox::resume(&client, log.person, &Retry::never()).unwrap();
        assert_eq!(resumed.next_seq(), n);
        assert_eq!(resumed.last_suggestion_id(), sync.last_suggestion_id);
        // Re-posting held events stores nothing and is acknowledged.
        let tail = n.saturating_sub(300);
        let again = EventsBody {
            events: (tail..n)
                .map(|s| {
                    let (ms, kind) = &log.sent[s as usize];
                    abba_api::DeviceEvent {
                        seq: s,
                        at: jiff::Timestamp::from_millisecond(*ms).unwrap().to_string(),
                        event: wire_event(kind).unwrap().unwrap(),
                    }
                })
                .collect(),
        };
        let ack = client.post_events(log.person, &again).unwrap();
        assert_eq!(ack.stored, 0, "person {}", log.person);
        assert_eq!(ack.repeated, (tail..n).collect::<Vec<_>>());
        assert!(ack.answers.is_empty());
    }

    // The store file itself: one row per (person, seq), as sent.
    server.kill();
    let conn = rusqlite::Connection::open(&db).unwrap();
    for log in &logs {
        let n = log.sent.len() as i64;
        let (rows, distinct, lo, hi): (i64, i64, i64, i64) = conn
            .query_row(
                "SELECT count(*), count(DISTINCT seq), min(seq), max(seq) FROM app_event WHERE person_id = ?1",
                [log.person as i64],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
            )
            .unwrap();
        assert_eq!(
            (rows, distinct, lo, hi),
            (n, n, 0, n - 1),
            "person {}",
            log.person
        );
        let mut st = conn
            .prepare("SELECT seq, at_ms, kind FROM app_event WHERE person_id = ?1 ORDER BY seq")
            .unwrap();
        let stored: Vec<(i64, i64, String)> = st
            .query_map([log.person as i64], |r| {
                Ok((r.get(0)?, r.get(1)?, r.get(2)?))
            })
            .unwrap()
            .map(Result::unwrap)
            .collect();
        for (seq, ms, kind) in stored {
            let (want_ms, want_kind) = &log.sent[seq as usize];
            let kind: EventKind = serde_json::from_str(&kind).unwrap();
            assert_eq!(
                (ms, kind),
                (*want_ms, *want_kind),
                "person {} seq {seq}",
                log.person
            );
        }
    }
    let others: i64 = conn
        .query_row("SELECT count(*) FROM record", [], |r| r.get(0))
        .unwrap();
    assert_eq!(others, 0, "no imported records");
}
