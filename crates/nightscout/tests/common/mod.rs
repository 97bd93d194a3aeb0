//! Shared by the tests: the data set (the repository's Nightscout
//! fixtures and copies shifted by whole 3-day blocks, newest first, with a
//! profile record at the epoch), export files of it, a person created
//! from it, and the store compared as records.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod mongo;
pub mod server;

use abba_advisor::Mode;
use abba_io::ReadOptions;
use abba_store::person::TherapySource;
use abba_store::{NewPerson, Store};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

pub const TZ: &str = "Europe/Zurich";
pub const SECRET: &str = "a-test-api-secret-of-some-length";
const DAY_MS: i64 = 86_400_000;

fn fixture(name: &str) -> Vec<Value> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        // From this crate or from the CLI's tests, which share this file.
        .join("../nightscout/tests/data")
        .join(name);
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// `doc` moved `blocks` 3-day blocks earlier, with a new `_id`.
fn shifted(doc: &Value, blocks: i64) -> Value {
    let mut d = doc.clone();
    if blocks == 0 {
        return d;
    }
    let shift = blocks * 3 * DAY_MS;
    if let Some(id) = d.get("_id").and_then(Value::as_str) {
        let h = abba_io::record::content_hash([id.as_bytes(), &blocks.to_le_bytes()]);
        d["_id"] = Value::String(format!("{h:016x}{blocks:08x}"));
    }
    for f in ["date", "mills"] {
        if let Some(ms) = d.get(f).and_then(Value::as_i64) {
            d[f] = json!(ms - shift);
        }
    }
    for f in ["dateString", "sysTime", "created_at"] {
        if let Some(t) = d.get(f).and_then(Value::as_str) {
            let t: jiff::Timestamp = t.parse().unwrap();
            let t = jiff::Timestamp::from_millisecond(t.as_millisecond() - shift).unwrap();
            d[f] = Value::String(t.strftime("%Y-%m-%dT%H:%M:%S%.3fZ").to_string());
        }
    }
    d
}

/// The data set: `blocks` 3-day blocks of entries and treatments (newest
/// first), the fixture's profile dated before the first block, and a
/// default profile record at the epoch.
pub struct Data {
    pub entries: Vec<Value>,
    pub treatments: Vec<Value>,
    pub profile: Vec<Value>,
}

pub fn data(blocks: i64) -> Data {
    let e = fixture("nightscout_entries_synthetic.json");
    let t = fixture("nightscout_treatments_synthetic.json");
    let mut p = fixture("nightscout_profile_synthetic.json");
    let mut entries = Vec::new();
    let mut treatments = Vec::new();
    for b in 0..blocks {
        entries.extend(e.iter().map(|d| shifted(d, b)));
        treatments.extend(t.iter().map(|d| shifted(d, b)));
    }
    // The profile in force from before the first block.
    let start =
        jiff::Timestamp::from_millisecond(p[0]["mills"].as_i64().unwrap() - blocks * 3 * DAY_MS)
            .unwrap();
    p[0]["mills"] = json!(start.as_millisecond());
    p[0]["startDate"] = Value::String(start.strftime("%Y-%m-%dT%H:%M:%S%.3fZ").to_string());
    p[0]["created_at"] = p[0]["startDate"].clone();
    // Nightscout's default record of a fresh site, at the epoch.
    let mut epoch = p[0].clone();
    epoch["_id"] = Value::String("000000000000000000000001".into());
    epoch["mills"] = json!(0);
    epoch["startDate"] = Value::String("1970-01-01T00:00:00.000Z".into());
    epoch["created_at"] = epoch["startDate"].clone();
    p.push(epoch);
    let distinct = |docs: &[Value]| {
        let mut ids: Vec<&str> = docs.iter().filter_map(|d| d["_id"].as_str()).collect();
        ids.sort();
        ids.dedup();
        ids.len()
    };
    assert_eq!(
        distinct(&entries) + distinct(&treatments),
        (distinct(&e) + distinct(&t)) * blocks as usize,
        "the shifted copies have ids of their own"
    );
    Data {
        entries,
        treatments,
        profile: p,
    }
}

/// Writes the data set as the three export files.
pub fn export(dir: &Path, d: &Data) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for (name, docs) in [
        ("entries.json", &d.entries),
        ("treatments.json", &d.treatments),
        ("profile.json", &d.profile),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_vec_pretty(docs).unwrap()).unwrap();
        out.push(p);
    }
    out
}

/// A test server holding the data set.
pub fn server(d: &Data, max_count: usize) -> server::Server {
    let mut site = server::Site::new(SECRET);
    site.max_count = max_count;
    site.add("entries", d.entries.clone());
    site.add("treatments", d.treatments.clone());
    site.add("profile", d.profile.clone());
    server::Server::start(site)
}

/// A new store with person `ana` created from the export's pump profile.
pub fn store_with_person(dir: &Path, file: &str, files: &[PathBuf]) -> (PathBuf, Store) {
    let db = dir.join(file);
    let mut store = Store::open(&db).unwrap();
    store.create_person(&person(files)).unwrap();
    (db, store)
}

pub fn person(files: &[PathBuf]) -> NewPerson {
    let opts = ReadOptions {
        tz: Some(jiff::tz::TimeZone::get(TZ).unwrap()),
        ..ReadOptions::default()
    };
    let meals = abba_io::meals::MealWindows::default();
    let t = abba_io::therapy::therapy_from_files(files, &opts, &meals).unwrap();
    let mut p = NewPerson::new("ana", TZ, Mode::Cgm, t.settings());
    p.settings.basal_schedule = (t.basal.len() > 1).then(|| t.basal.clone());
    p.settings.therapy_source = TherapySource::Profile;
    p
}

/// The person's records as (source, id, instant, kind): what the store
/// holds whatever file or page each came from.
pub fn records(store: &Store) -> Vec<String> {
    store
        .records("ana")
        .unwrap()
        .iter()
        .map(|r| {
            format!(
                "{:?} {:?} {} {}",
                r.source,
                r.id,
                r.at,
                serde_json::to_string(&r.kind).unwrap()
            )
        })
        .collect()
}

/// Today's advice as JSON.
pub fn advice(store: &mut Store) -> Value {
    serde_json::to_value(store.advise("ana").unwrap()).unwrap()
}

/// Fast retries for tests.
pub fn fast_client() -> abba_nightscout::ClientOptions {
    abba_nightscout::ClientOptions {
        connect_timeout: std::time::Duration::from_secs(5),
        call_timeout: std::time::Duration::from_secs(5),
        attempts: 4,
        backoff: std::time::Duration::from_millis(20),
        max_retry_after: std::time::Duration::from_secs(5),
        max_body: 64 << 20,
    }
}

pub fn sync_opts() -> abba_nightscout::SyncOptions {
    abba_nightscout::SyncOptions {
        client: fast_client(),
        ..Default::default()
    }
}

/// Asserts two stores hold the same records, naming the differences.
pub fn assert_same_records(a: &Store, b: &Store) {
    let (ra, rb) = (records(a), records(b));
    let only_a: Vec<&String> = ra.iter().filter(|r| !rb.contains(r)).take(5).collect();
    let only_b: Vec<&String> = rb.iter().filter(|r| !ra.contains(r)).take(5).collect();
    assert!(
        ra == rb,
        "{} vs {} records; only in the first: {only_a:?}; only in the second: {only_b:?}",
        ra.len(),
        rb.len()
    );
}

/// An ObjectId made at `ms` (by the server inserting it), the `n`-th.
pub fn object_id(ms: i64, n: usize) -> String {
    format!("{:08x}{:016x}", ms / 1000, 0x5eed_0000_0000_u64 + n as u64)
}

/// A Loop-style UUID `_id` (a string to MongoDB).
pub fn uuid(n: usize) -> String {
    format!("7d6bcbb3-9c4d-4e5e-8d7e-{n:012x}")
}

/// `n` BG Checks at one `created_at`, their `_id`s ObjectIds and UUIDs in
/// turn, stored in an order that is not their `_id` order.
pub fn one_instant(n: usize, at: &str) -> Vec<Value> {
    let t = at.parse::<jiff::Timestamp>().unwrap().as_millisecond();
    let mut docs: Vec<(usize, Value)> = (0..n)
        .map(|i| {
            let id = if i % 2 == 0 {
                object_id(t + 60_000, i)
            } else {
                uuid(i)
            };
            let d = json!({"_id": id, "eventType": "BG Check", "created_at": at,
                "glucose": 80 + (i % 90), "glucoseType": "Finger", "units": "mg/dl",
                "enteredBy": "xDrip", "utcOffset": 60});
            ((i * 7919) % n, d)
        })
        .collect();
    docs.sort_by_key(|(k, _)| *k);
    docs.into_iter().map(|(_, d)| d).collect()
}

/// The site's API secret as a link's credential.
pub fn secret() -> abba_store::link::Credential {
    abba_nightscout::site::credential(None, Some(SECRET)).unwrap()
}

/// A reader's token as a link's credential.
pub fn reader() -> abba_store::link::Credential {
    abba_nightscout::site::credential(Some("reader-0123456789abcdef"), None).unwrap()
}

/// A site serving `d`, at most `max_count` documents a page.
pub fn site_of(d: &Data, max_count: usize) -> server::Site {
    let mut site = server::Site::new(SECRET);
    site.max_count = max_count;
    site.add("entries", d.entries.clone());
    site.add("treatments", d.treatments.clone());
    site.add("profile", d.profile.clone());
    site
}

/// A store in `dir/file` holding the person "ana" made from `files`,
/// linked to the site at `url` with its secret.
pub fn linked(dir: &Path, file: &str, files: &[PathBuf], url: &str) -> Store {
    let (_, mut store) = store_with_person(dir, file, files);
    abba_nightscout::link(&mut store, "ana", url, secret(), false, &fast_client()).unwrap();
    store
}
