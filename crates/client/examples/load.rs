//! Load benchmark of a running `abba serve` (not a test): N concurrent
//! clients, one person each, post CGM readings every 5 simulated minutes
//! (with meals, boluses and day closings, so the live advisor decides),
//! B events per request, each client sending its next request when the
//! previous one is acknowledged, for S seconds. Prints events accepted per
//! second and the request latency percentiles.
//!
//! ```text
//! abba token --db /tmp/load.db --admin > /tmp/load.token
//! abba serve --db /tmp/load.db --listen 127.0.0.1:8090 &
//! cargo run --release -p abba-client --example load -- \
//!     --url http://127.0.0.1:8090 --token "$(cat /tmp/load.token)" \
//!     --clients 50 --batch 1 --seconds 30
//! ```
//!
//! `--url` given twice or more (replicas of one service on one PostgreSQL
//! database): client `i` talks to the `i`-th URL in turn, as a balancer
//! spreading apps over replicas would.
//!
//! Only loopback addresses are accepted: this is a benchmark of a local
//! server. abba is research software, not a medical device.

use abba_api::{EventBody, MealSlot, Mode, NewPersonBody, TherapyBody};
use abba_client::{Client, Outbox, Retry};
use std::time::{Duration, Instant};

struct Opts {
    url: String,
    /// Every `--url`, in order (client `i` uses `urls[i % len]`).
    urls: Vec<String>,
    token: String,
    clients: usize,
    batch: usize,
    seconds: f64,
}

fn parse() -> Result<Opts, String> {
    let mut o = Opts {
        url: "http://127.0.0.1:8090".into(),
        urls: Vec::new(),
        token: String::new(),
        clients: 50,
        batch: 1,
        seconds: 30.0,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut v = || args.next().ok_or(format!("{a}: value missing"));
        match a.as_str() {
            "--url" => o.urls.push(v()?),
            "--token" => o.token = v()?,
            "--clients" => o.clients = v()?.parse().map_err(|e| format!("--clients: {e}"))?,
            "--batch" => o.batch = v()?.parse().map_err(|e| format!("--batch: {e}"))?,
            "--seconds" => o.seconds = v()?.parse().map_err(|e| format!("--seconds: {e}"))?,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    if o.urls.is_empty() {
        o.urls.push(o.url.clone());
    }
    o.url = o.urls[0].clone();
    for url in &o.urls {
        let host = url
            .strip_prefix("http://")
            .and_then(|r| r.split(['/']).next())
            .unwrap_or("");
        let loopback =
            host.starts_with("127.") || host.starts_with("localhost") || host.starts_with("[::1]");
        if !loopback {
            return Err(format!(
                "--url {url}: only loopback addresses (127.0.0.0/8, localhost, [::1])"
            ));
        }
    }
    if o.token.is_empty()
        || o.clients == 0
        || o.batch == 0
        || !(o.seconds > 0.0 && o.seconds <= 600.0)
    {
        return Err("need --token ADMIN, --clients ≥ 1, --batch ≥ 1, 0 < --seconds ≤ 600".into());
    }
    Ok(o)
}

/// The events of 5-minute step `i` (minutes since day 1, body).
fn step(i: u64) -> Vec<(u64, EventBody)> {
    let minute = i * 5;
    let g = 100.0 + 60.0 * ((i as f64) / 20.0).sin();
    let mut out = vec![(minute, EventBody::Cgm { mg_dl: g })];
    let of_day = minute % 1440;
    if of_day == 0 && minute > 0 {
        out.push((minute, EventBody::DayClosed));
    }
    for (at, slot) in [
        (420, MealSlot::Breakfast),
        (720, MealSlot::Lunch),
        (1140, MealSlot::Dinner),
    ] {
        if of_day == at {
            out.push((
                minute,
                EventBody::Meal {
                    carbs_g: 50.0,
                    slot,
                },
            ));
            out.push((minute, EventBody::Bolus { units: 5.0 }));
        }
    }
    out
}

fn instant(minute: u64) -> String {
    // Day 1 = 2026-03-02 00:00Z.
    const DAY1: u64 = 1_772_409_600;
    let t = DAY1 + minute * 60;
    let (days, rem) = (t / 86_400, t % 86_400);
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:00Z",
        rem / 3600,
        rem % 3600 / 60
    )
}

struct Result1 {
    latencies_us: Vec<u64>,
    events: u64,
    failures: u64,
}

fn client_loop(
    client: Client,
    person: u64,
    batch: usize,
    until: Instant,
) -> Result<Result1, String> {
    let mut outbox = Outbox::new(person);
    let retry = Retry::default();
    let mut r = Result1 {
        latencies_us: Vec::new(),
        events: 0,
        failures: 0,
    };
    let mut i = 0;
    while Instant::now() < until {
        let mut n = 0;
        while n < batch {
            for (minute, e) in step(i) {
                outbox.push(instant(minute), e);
                n += 1;
            }
            i += 1;
        }
        let t = Instant::now();
        let f = outbox.flush(&client, &retry).map_err(|e| e.to_string())?;
        r.latencies_us.push(t.elapsed().as_micros() as u64);
        r.events += f.held.len() as u64;
        r.failures += u64::from(f.failures);
    }
    Ok(r)
}

fn pct(sorted: &[u64], p: f64) -> f64 {
    let k = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[k] as f64 / 1000.0
}

fn main() -> Result<(), String> {
    let o = parse()?;
    let admin = Client::new(&o.url, Some(&o.token)).map_err(|e| e.to_string())?;
    admin
        .health()
        .map_err(|e| format!("is abba serve running at {}? {e}", o.url))?;
    let tag = std::process::id();
    let mut persons = Vec::new();
    for c in 0..o.clients {
        let p = admin
            .create_person(&NewPersonBody {
                name: format!("load-{tag}-{c}"),
                tz: "UTC".into(),
                mode: Mode::Cgm,
                first_day: Some("2026-03-02".into()),
                start: TherapyBody {
                    basal_units_per_hour: 1.0,
                    carb_ratio_g_per_unit: [10.0; 3],
                },
                bounds: None,
                pump_steps: None,
                continuous_values: false,
                min_data: None,
                advisor: None,
                age_group: None,
            })
            .map_err(|e| e.to_string())?;
        let t = admin.issue_token(p.id).map_err(|e| e.to_string())?;
        persons.push((p.id, t.token));
    }
    println!("{}", abba_api::NOTICE);
    let start = Instant::now();
    let until = start + Duration::from_secs_f64(o.seconds);
    let handles: Vec<_> = persons
        .into_iter()
        .enumerate()
        .map(|(i, (id, tok))| {
            // One connection (agent) per client, as separate apps would have.
            let c = Client::new(&o.urls[i % o.urls.len()], Some(&tok));
            let batch = o.batch;
            std::thread::spawn(move || client_loop(c.map_err(|e| e.to_string())?, id, batch, until))
        })
        .collect();
    let mut lat = Vec::new();
    let (mut events, mut failures) = (0, 0);
    for h in handles {
        let r = h
            .join()
            .map_err(|_| "a client thread panicked".to_string())??;
        lat.extend(r.latencies_us);
        events += r.events;
        failures += r.failures;
    }
    let secs = start.elapsed().as_secs_f64();
    lat.sort_unstable();
    if lat.is_empty() {
        return Err("no request completed".into());
    }
    println!(
        "{} clients, {} events/request, {secs:.1} s: {} requests, {events} events accepted, {failures} failed attempts",
        o.clients,
        o.batch,
        lat.len()
    );
    println!(
        "throughput: {:.0} events/s, {:.0} requests/s; latency ms: p50 {:.1}, p90 {:.1}, p99 {:.1}, max {:.1}",
        events as f64 / secs,
        lat.len() as f64 / secs,
        pct(&lat, 0.5),
        pct(&lat, 0.9),
        pct(&lat, 0.99),
        pct(&lat, 1.0)
    );
    Ok(())
}
