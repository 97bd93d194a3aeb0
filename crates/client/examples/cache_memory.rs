//! Memory per cached person of a running `abba serve` (not a test): creates
//! N persons, posts D days of app events for each (CGM every 5 minutes,
//! three meals with boluses, the day closed at midnight; each post keeps
//! the person's live advisor in the service's cache), and prints the
//! server's resident memory (`VmRSS` of `/proc/PID/status`, Linux) before
//! and after, per person.
//!
//! ```text
//! abba token --db /tmp/mem.db --admin > /tmp/mem.token
//! abba serve --db /tmp/mem.db --listen 127.0.0.1:8091 & echo $! > /tmp/mem.pid
//! cargo run --release -p abba-client --example cache_memory -- \
//!     --url http://127.0.0.1:8091 --token "$(cat /tmp/mem.token)" \
//!     --pid "$(cat /tmp/mem.pid)" --persons 500 --days 7
//! ```
//!
//! Only loopback addresses are accepted. abba is research software, not a
//! medical device.

use abba_api::{DeviceEvent, EventBody, EventsBody, MealSlot, Mode, NewPersonBody, TherapyBody};
use abba_client::Client;

struct Opts {
    url: String,
    token: String,
    pid: u32,
    persons: usize,
    days: u64,
}

fn parse() -> Result<Opts, String> {
    let mut o = Opts {
        url: "http://127.0.0.1:8091".into(),
        token: String::new(),
        pid: 0,
        persons: 500,
        days: 7,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut v = || args.next().ok_or(format!("{a}: value missing"));
        match a.as_str() {
            "--url" => o.url = v()?,
            "--token" => o.token = v()?,
            "--pid" => o.pid = v()?.parse().map_err(|e| format!("--pid: {e}"))?,
            "--persons" => o.persons = v()?.parse().map_err(|e| format!("--persons: {e}"))?,
            "--days" => o.days = v()?.parse().map_err(|e| format!("--days: {e}"))?,
            other => return Err(format!("unknown argument {other}")),
        }
    }
    let host = o.url.strip_prefix("http://").unwrap_or("");
    if !(host.starts_with("127.") || host.starts_with("localhost") || host.starts_with("[::1]")) {
        return Err(format!("--url {}: only loopback addresses", o.url));
    }
    if o.token.is_empty() || o.pid == 0 || o.persons == 0 || o.days == 0 || o.days > 400 {
        return Err("need --token ADMIN, --pid PID, --persons ≥ 1, 1 ≤ --days ≤ 400".into());
    }
    Ok(o)
}

fn rss_kb(pid: u32) -> Result<u64, String> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status"))
        .map_err(|e| format!("/proc/{pid}/status: {e}"))?;
    s.lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next())
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| format!("/proc/{pid}/status has no VmRSS"))
}

/// D days of events from `day1` (UTC midnight, as Unix seconds).
fn events(day1: i64, days: u64) -> Vec<DeviceEvent> {
    let mut out = Vec::new();
    let mut seq = 0;
    let mut push = |minute: u64, event: EventBody| {
        let t = day1 + 60 * minute as i64;
        out.push(DeviceEvent {
            seq,
            at: rfc3339(t),
            event,
        });
        seq += 1;
    };
    for i in 0..days * 288 {
        let minute = i * 5;
        let of_day = minute % 1440;
        push(
            minute,
            EventBody::Cgm {
                mg_dl: 120.0 + 40.0 * ((i as f64) / 20.0).sin(),
            },
        );
        if of_day == 0 && minute > 0 {
            push(minute, EventBody::DayClosed);
        }
        for (at, slot) in [
            (420, MealSlot::Breakfast),
            (720, MealSlot::Lunch),
            (1140, MealSlot::Dinner),
        ] {
            if of_day == at {
                push(
                    minute,
                    EventBody::Meal {
                        carbs_g: 50.0,
                        slot,
                    },
                );
                push(minute, EventBody::Bolus { units: 5.0 });
            }
        }
    }
    out
}

fn main() -> Result<(), String> {
    let o = parse()?;
    let admin = Client::new(&o.url, Some(&o.token)).map_err(|e| e.to_string())?;
    admin
        .health()
        .map_err(|e| format!("is abba serve running at {}? {e}", o.url))?;
    println!("{}", abba_api::NOTICE);
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_err(|e| e.to_string())?
        .as_secs() as i64;
    // Day 1: D + 1 days ago at UTC midnight (nothing in the future).
    let day1 = (now / 86_400 - o.days as i64 - 1) * 86_400;
    let first_day = rfc3339(day1)[..10].to_string();
    let evs = events(day1, o.days);
    let before = rss_kb(o.pid)?;
    let tag = std::process::id();
    for k in 0..o.persons {
        let p = admin
            .create_person(&NewPersonBody {
                name: format!("mem-{tag}-{k}"),
                tz: "UTC".into(),
                mode: Mode::Cgm,
                first_day: Some(first_day.clone()),
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
        for chunk in evs.chunks(abba_api::MAX_EVENTS_PER_BATCH) {
            admin
                .post_events(
                    p.id,
                    &EventsBody {
                        events: chunk.to_vec(),
                    },
                )
                .map_err(|e| e.to_string())?;
        }
    }
    let after = rss_kb(o.pid)?;
    println!(
        "{} persons, {} days ({} events) each: server RSS {before} kB -> {after} kB, {:.1} kB per person",
        o.persons,
        o.days,
        evs.len(),
        (after as f64 - before as f64) / o.persons as f64
    );
    Ok(())
}

/// Unix seconds as an RFC 3339 instant in UTC (civil date by Howard
/// Hinnant's algorithm).
fn rfc3339(t: i64) -> String {
    let (days, rem) = (t.div_euclid(86_400), t.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}
