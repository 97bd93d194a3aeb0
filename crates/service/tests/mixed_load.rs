//! Mixed load over real sockets: one person with a year of data whose
//! `GET .../history` pages of 1,000 two clients request in a loop (each
//! page rebuilds the person's advisor from the store: the service's cache
//! is cold and a read never fills it), while a second person's app posts events and asks
//! `GET .../sync`. Different persons never wait for each other: every light
//! request succeeds, many of them complete while the heavy ones run, and
//! the light requests' p99 stays below a heavy request's median (a light
//! request did not wait for a heavy one). The latencies are printed; the
//! figures of a quiet run are in BENCHMARKS.md, not asserted here.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_api::{
    DeviceEvent, EventBody, EventsBody, MealSlot, MinDataBody, Mode, NewPersonBody, TherapyBody,
};
use abba_client::Client;
use abba_service::ServeSettings;
use common::Server;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Days of the heavy person's data.
const DAYS: i64 = 365;
/// Heavy requests each of the two heavy clients makes (at most).
const HEAVY_EACH: usize = 20;
/// The whole test's budget for the mixed part.
const BUDGET: Duration = Duration::from_secs(60);

/// A person's events, day 1 at `day1` (UTC midnight): CGM every 5 minutes,
/// three meals with boluses, the day closed after the midnight reading and
/// the pump's basal rate then.
fn year_of_events(day1: jiff::Timestamp, days: i64) -> Vec<DeviceEvent> {
    let mut out = Vec::new();
    let mut seq = 0;
    let mut push = |minute: i64, event: EventBody| {
        let at = day1 + jiff::SignedDuration::from_mins(minute);
        out.push(DeviceEvent {
            seq,
            at: at.to_string(),
            event,
        });
        seq += 1;
    };
    for i in 0..days * 288 {
        let minute = i * 5;
        let of_day = minute % 1440;
        let g = 130.0 + 50.0 * ((i as f64) / 23.0).sin() + 10.0 * ((i as f64) / 7.0).cos();
        push(minute, EventBody::Cgm { mg_dl: g });
        if of_day == 0 && minute > 0 {
            push(minute, EventBody::DayClosed);
        }
        if of_day == 0 {
            push(
                minute,
                EventBody::BasalRate {
                    units_per_hour: 1.0,
                },
            );
        }
        for (at, slot, carbs) in [
            (420, MealSlot::Breakfast, 45.0),
            (750, MealSlot::Lunch, 60.0),
            (1140, MealSlot::Dinner, 70.0),
        ] {
            if of_day == at {
                push(
                    minute,
                    EventBody::Meal {
                        carbs_g: carbs,
                        slot,
                    },
                );
                push(
                    minute,
                    EventBody::Bolus {
                        units: carbs / 10.0,
                    },
                );
            }
        }
    }
    out
}

fn person_body(name: &str, first_day: jiff::civil::Date) -> NewPersonBody {
    NewPersonBody {
        name: name.into(),
        tz: "UTC".into(),
        mode: Mode::Cgm,
        first_day: Some(first_day.to_string()),
        start: TherapyBody {
            basal_units_per_hour: 1.0,
            carb_ratio_g_per_unit: [10.0, 12.0, 11.0],
        },
        bounds: None,
        pump_steps: None,
        continuous_values: false,
        min_data: Some(MinDataBody {
            cgm_coverage: 0.0,
            cgm_period_min: 5,
            smbg_per_day: 0,
            smbg_per_meal: 0,
        }),
        advisor: None,
        age_group: None,
    }
}

fn pct(sorted: &[Duration], p: f64) -> Duration {
    let k = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[k]
}

/// The store of `db` with a heavy person (a year of events posted by an
/// app) and a light one: their ids and tokens, day 1 of both.
fn heavy_and_light(db: &std::path::Path) -> (u64, u64, String, String, jiff::Timestamp) {
    // Day 1 a year and a day ago: no event is in the future.
    let today = jiff::Timestamp::now()
        .to_zoned(jiff::tz::TimeZone::UTC)
        .date();
    let first_day = today - jiff::Span::new().days(DAYS + 1);
    let day1 = first_day
        .to_zoned(jiff::tz::TimeZone::UTC)
        .unwrap()
        .timestamp();
    let (_, admin) = abba_service::new_admin_token(db).unwrap();
    let (heavy, light, heavy_token, light_token) = {
        let server = Server::start(db, ServeSettings::default());
        let c = Client::new(&server.url(), Some(&admin)).unwrap();
        let heavy = c
            .create_person(&person_body("heavy", first_day))
            .unwrap()
            .id;
        let light = c
            .create_person(&person_body("light", first_day))
            .unwrap()
            .id;
        let t0 = Instant::now();
        let events = year_of_events(day1, DAYS);
        let n = events.len();
        let mut produced = 0;
        for chunk in events.chunks(abba_api::MAX_EVENTS_PER_BATCH) {
            let ack = c
                .post_events(
                    heavy,
                    &EventsBody {
                        events: chunk.to_vec(),
                    },
                )
                .unwrap();
            assert_eq!(ack.stored as usize, chunk.len());
            produced += ack.answers.len();
        }
        println!(
            "heavy person: {n} events ({DAYS} days) posted in {:?}, {produced} suggestions",
            t0.elapsed()
        );
        let h = c.history_page(heavy, None, Some(1000)).unwrap();
        assert_eq!(
            h.suggestions.len(),
            produced.min(1000),
            "{:?}",
            h.next_after
        );
        let ht = c.issue_token(heavy).unwrap().token;
        let lt = c.issue_token(light).unwrap().token;
        (heavy, light, ht, lt)
    };
    (heavy, light, heavy_token, light_token, day1)
}

#[test]
fn a_heavy_history_does_not_hold_up_another_persons_sync() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("store.db");
    let (heavy, light, heavy_token, light_token, day1) = heavy_and_light(&db);
    // A fresh service: nobody's advisor is cached.
    let server = Server::start(&db, ServeSettings::default());
    let url = server.url();
    let heavy_done = Arc::new(AtomicBool::new(false));
    let started = Instant::now();
    let heavy_clients: Vec<_> = (0..2)
        .map(|k| {
            let c = Client::new(&url, Some(&heavy_token)).unwrap();
            std::thread::spawn(move || {
                let mut took = Vec::new();
                let mut after = None;
                for _ in 0..HEAVY_EACH {
                    if started.elapsed() > BUDGET {
                        break;
                    }
                    let t = Instant::now();
                    let page = c.history_page(heavy, after, Some(1000)).unwrap();
                    took.push(t.elapsed());
                    assert!(!page.suggestions.is_empty(), "client {k}: an empty page");
                    // Walk the pages, then start again.
                    after = page.next_after;
                }
                took
            })
        })
        .collect();
    let light_client = {
        let c = Client::new(&url, Some(&light_token)).unwrap();
        let done = Arc::clone(&heavy_done);
        std::thread::spawn(move || {
            let mut took = Vec::new();
            let mut seq = 0u64;
            while !done.load(Ordering::Relaxed) && took.len() < 20_000 {
                let at = day1 + jiff::SignedDuration::from_mins(5 * seq as i64);
                let body = EventsBody {
                    events: vec![DeviceEvent {
                        seq,
                        at: at.to_string(),
                        event: EventBody::Cgm { mg_dl: 120.0 },
                    }],
                };
                let t = Instant::now();
                c.post_events(light, &body).unwrap();
                took.push(t.elapsed());
                let t = Instant::now();
                let s = c.sync(light, 0).unwrap();
                took.push(t.elapsed());
                assert_eq!(s.last_seq, Some(seq));
                seq += 1;
            }
            took
        })
    };
    let mut heavy_took: Vec<Duration> = heavy_clients
        .into_iter()
        .flat_map(|h| h.join().unwrap())
        .collect();
    heavy_done.store(true, Ordering::Relaxed);
    let mut light_took = light_client.join().unwrap();
    heavy_took.sort_unstable();
    light_took.sort_unstable();
    let heavy_median = pct(&heavy_took, 0.5);
    println!(
        "heavy history pages (1000 suggestions, advisor rebuilt from a year): {} requests, p50 {:?}, max {:?}",
        heavy_took.len(),
        heavy_median,
        pct(&heavy_took, 1.0)
    );
    println!(
        "light person meanwhile: {} requests (post 1 event, sync), p50 {:?}, p99 {:?}, max {:?}",
        light_took.len(),
        pct(&light_took, 0.5),
        pct(&light_took, 0.99),
        pct(&light_took, 1.0)
    );
    assert!(heavy_took.len() >= 2, "the heavy clients made no request");
    // Under one lock the light person would get about one request in per
    // heavy request, each waiting a heavy request's time (the two heavy
    // clients keep one almost always running).
    assert!(
        light_took.len() >= 3 * heavy_took.len(),
        "{} light requests beside {} heavy ones",
        light_took.len(),
        heavy_took.len()
    );
    assert!(
        pct(&light_took, 0.99) < heavy_median,
        "light p99 {:?} is not below the heavy median {heavy_median:?}: the light person waited",
        pct(&light_took, 0.99)
    );
}

/// A person's app posting late events to a year of data (each one
/// rebuilds the person's advisor from the whole log: a replay of the
/// year) does not hold up another person's writes: the replay runs in a
/// read transaction, and only what it decided is stored under the write
/// lock. (Every replay held SQLite's one writer: with three years of
/// data the other person's posts waited 2 s and one in three got 503.)
#[test]
fn late_events_on_a_long_log_do_not_hold_up_another_persons_writes() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("store.db");
    let (heavy, light, heavy_token, light_token, day1) = heavy_and_light(&db);
    let server = Server::start(&db, ServeSettings::default());
    let url = server.url();
    let heavy_done = Arc::new(AtomicBool::new(false));
    let started = Instant::now();
    let heavy_client = {
        let c = Client::new(&url, Some(&heavy_token)).unwrap();
        std::thread::spawn(move || {
            let mut took = Vec::new();
            for k in 0..HEAVY_EACH as u64 {
                if started.elapsed() > BUDGET {
                    break;
                }
                // Day 2, 00:02:30 plus k seconds: earlier than the last
                // event held, so the advisor is rebuilt from the log.
                let at = day1 + jiff::SignedDuration::from_secs(86_400 + 150 + k as i64);
                let body = EventsBody {
                    events: vec![DeviceEvent {
                        seq: 10_000_000 + k,
                        at: at.to_string(),
                        event: EventBody::Smbg { mg_dl: 150.0 },
                    }],
                };
                let t = Instant::now();
                c.post_events(heavy, &body).unwrap();
                took.push(t.elapsed());
            }
            took
        })
    };
    let light_client = {
        let c = Client::new(&url, Some(&light_token)).unwrap();
        let done = Arc::clone(&heavy_done);
        std::thread::spawn(move || {
            let mut took = Vec::new();
            let mut seq = 0u64;
            while !done.load(Ordering::Relaxed) && took.len() < 20_000 {
                let at = day1 + jiff::SignedDuration::from_mins(5 * seq as i64);
                let body = EventsBody {
                    events: vec![DeviceEvent {
                        seq,
                        at: at.to_string(),
                        event: EventBody::Cgm { mg_dl: 120.0 },
                    }],
                };
                let t = Instant::now();
                c.post_events(light, &body).unwrap();
                took.push(t.elapsed());
                seq += 1;
            }
            took
        })
    };
    let mut heavy_took = heavy_client.join().unwrap();
    heavy_done.store(true, Ordering::Relaxed);
    let mut light_took = light_client.join().unwrap();
    heavy_took.sort_unstable();
    light_took.sort_unstable();
    let heavy_median = pct(&heavy_took, 0.5);
    println!(
        "late events on a year (each a rebuild): {} posts, p50 {:?}, max {:?}",
        heavy_took.len(),
        heavy_median,
        pct(&heavy_took, 1.0)
    );
    println!(
        "another person's posts meanwhile: {}, p50 {:?}, p99 {:?}, max {:?}",
        light_took.len(),
        pct(&light_took, 0.5),
        pct(&light_took, 0.99),
        pct(&light_took, 1.0)
    );
    assert!(heavy_took.len() >= 2, "the heavy client made no request");
    assert!(
        light_took.len() >= 3 * heavy_took.len(),
        "{} light posts beside {} late ones",
        light_took.len(),
        heavy_took.len()
    );
    assert!(
        pct(&light_took, 0.99) < heavy_median,
        "light p99 {:?} is not below the late posts' median {heavy_median:?}: the light person's writes waited for the replays",
        pct(&light_took, 0.99)
    );
}
