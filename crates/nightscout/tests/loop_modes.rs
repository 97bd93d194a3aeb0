//! The live link on AndroidAPS's uploads (fixture
//! `nightscout_treatments_aaps_open_loop_synthetic.json` of abba-io, see
//! its PROVENANCE.md): an AndroidAPS in open loop (its running mode
//! OPEN_LOOP) gets advice; when it closes the loop, the running mode the
//! next sync brings holds the basal advice.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::Mode;
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_nightscout::site::credential;
use abba_nightscout::{link, sync};
use abba_store::{NewPerson, Store};
use common::server::{Server, Site};
use common::*;
use serde_json::{json, Value};

/// CGM entries every 5 min from 2026-11-15 20:00 to 2026-11-18 22:55 UTC,
/// newest first, as xDrip+ uploads them.
fn entries() -> Vec<Value> {
    let start: i64 = 1_794_772_800_000; // 2026-11-15T20:00:00Z
    (0..(3 * 288 + 36))
        .rev()
        .map(|i: i64| {
            let ms = start + i * 300_000;
            json!({
                "_id": format!("6736e0a1f2c3b4a5d6{i:06x}"),
                "device": "xDrip-DexcomG6",
                "date": ms,
                "dateString": jiff::Timestamp::from_millisecond(ms).unwrap().to_string(),
                "sgv": 110 + (i % 36) * 2,
                "direction": "Flat",
                "type": "sgv",
                "utcOffset": 60,
            })
        })
        .collect()
}

fn treatments() -> Vec<Value> {
    let p = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../io/tests/data/nightscout_treatments_aaps_open_loop_synthetic.json"
    );
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// A store at `path` with person "ana" (CGM, 0.85 U/h, `carb_ratio` g/U).
fn person_store(path: &std::path::Path, carb_ratio: f64) -> Store {
    let mut store = Store::open(path).unwrap();
    let start = TherapySettings::new(UnitsPerHour(0.85), GramsPerUnit(carb_ratio)).unwrap();
    store
        .create_person(&NewPerson::new("ana", TZ, Mode::Cgm, start))
        .unwrap();
    store
}

/// `site` served, and person "ana" (CGM, 0.85 U/h, `carb_ratio` g/U)
/// linked to it and synced once; the directory holds the store.
fn linked_and_synced(site: Site, carb_ratio: f64) -> (tempfile::TempDir, Server, Store) {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(site);
    let mut store = person_store(&dir.path().join("link.db"), carb_ratio);
    let secret = credential(None, Some(SECRET)).unwrap();
    link(&mut store, "ana", &srv.url, secret, false, &fast_client()).unwrap();
    sync(&mut store, "ana", &sync_opts()).unwrap();
    (dir, srv, store)
}

/// The person's delivery as today's advice tells it: its kind, and
/// whether a basal is suggested.
fn assert_delivery(store: &mut Store, kind: &str, basal: bool) -> Value {
    let a = advice(store);
    assert_eq!(a["delivery"]["kind"], kind, "{}", a["delivery"]);
    assert_eq!(
        a["delivery"]["basal_suggestions"], basal,
        "{}",
        a["delivery"]
    );
    a["delivery"].clone()
}

#[test]
fn a_linked_androidaps_in_open_loop_gets_advice_until_it_closes_the_loop() {
    let mut site = Site::new(SECRET);
    site.add("entries", entries());
    site.add("treatments", treatments());
    let (_dir, srv, mut store) = linked_and_synced(site, 10.0);
    assert_delivery(&mut store, "open_loop", true);
    // AndroidAPS closes the loop: the running mode it uploads reaches the
    // store with the next sync.
    srv.with(|s| {
        s.add(
            "treatments",
            vec![json!({
                "_id": "6735c1a2e4b0f81d9cffff01",
                "created_at": "2026-11-18T21:00:00.000Z",
                "enteredBy": "openaps://AAPS",
                "eventType": "OpenAPS Offline",
                "isValid": true,
                "duration": 0,
                "durationInMilliseconds": 0,
                "originalDuration": 0,
                "mode": "CLOSED_LOOP",
                "utcOffset": 0
            })],
        )
    });
    sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_delivery(&mut store, "closed_loop", false);
}

/// Loop's settings (a Nightscout profile, `loopSettings.dosingEnabled`)
/// as the fixture `nightscout_profile_loop_open_loop_synthetic.json`
/// holds them, from `at`, closed loop on or off.
fn loop_settings(at: &str, dosing_enabled: bool) -> Value {
    let p = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../io/tests/data/nightscout_profile_loop_open_loop_synthetic.json"
    );
    let docs: Vec<Value> = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
    let mut d = docs[0].clone();
    let t: jiff::Timestamp = at.parse().unwrap();
    d["startDate"] = at.into();
    d["created_at"] = at.into();
    d["mills"] = t.as_millisecond().to_string().into();
    d["loopSettings"]["dosingEnabled"] = dosing_enabled.into();
    d["_id"] = format!("6740{:020x}", t.as_second()).into();
    d
}

/// A linked Loop with closed loop off: its settings, which the site's
/// profile store holds, reach the store with the sync (they are read
/// whole at every sync), so it gets advice as by file import; when Loop
/// uploads its settings with closed loop on, the next sync holds the
/// basal advice.
#[test]
fn a_linked_loop_in_open_loop_gets_advice_until_its_settings_close_the_loop() {
    let mut site = Site::new(SECRET);
    site.add("entries", entries());
    let p = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../io/tests/data/nightscout_treatments_loop_open_loop_synthetic.json"
    );
    let treatments: Vec<Value> = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
    site.add("treatments", treatments);
    site.add(
        "profile",
        vec![loop_settings("2026-11-14T18:02:00Z", false)],
    );
    let (_dir, srv, mut store) = linked_and_synced(site, 11.0);
    let first = assert_delivery(&mut store, "open_loop", true);
    // A second sync reads the same settings again: still one record of
    // open loop, not two.
    sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_eq!(assert_delivery(&mut store, "open_loop", true), first);
    // Loop's settings with closed loop on, uploaded at the end of the data.
    srv.with(|s| s.add("profile", vec![loop_settings("2026-11-18T20:00:00Z", true)]));
    sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_delivery(&mut store, "closed_loop", false);
}

/// A fixture of abba-io's test data (see its PROVENANCE.md).
fn io_fixture(name: &str) -> Vec<Value> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../io/tests/data")
        .join(name);
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// The person's delivery (today's advice) when the CGM `entries()` and
/// `docs` (collection, documents) come through the link, and when the
/// same documents are imported as export files.
fn linked_and_imported(docs: &[(&'static str, Vec<Value>)]) -> (Value, Value) {
    let mut site = Site::new(SECRET);
    site.add("entries", entries());
    for (c, d) in docs {
        site.add(c, d.clone());
    }
    let (dir, _srv, mut linked) = linked_and_synced(site, 10.0);
    let mut files = Vec::new();
    for (c, d) in [("entries", entries())]
        .into_iter()
        .chain(docs.iter().cloned())
    {
        let f = dir.path().join(format!("{c}.json"));
        std::fs::write(&f, serde_json::to_vec(&d).unwrap()).unwrap();
        files.push(f);
    }
    let mut imported = person_store(&dir.path().join("files.db"), 10.0);
    imported.import_files("ana", &files, None).unwrap();
    (
        advice(&mut linked)["delivery"].clone(),
        advice(&mut imported)["delivery"].clone(),
    )
}

/// Asserts that `delivery`'s evidence says `line`.
fn assert_evidence(delivery: &Value, line: &str) {
    let evidence = delivery["evidence"].as_array().unwrap();
    assert!(evidence.iter().any(|e| e == line), "{delivery:#}");
}

/// Trio tells its mode only in its device status (`enacted` only with
/// closed loop on): through the link as by a file import, an open loop
/// gets advice and a closed one none, though no treatment marks a loop.
#[test]
fn a_linked_trio_tells_its_loop_mode_by_its_device_status_as_files_do() {
    let open = io_fixture("nightscout_devicestatus_trio_open_loop_synthetic.json");
    let (linked, imported) = linked_and_imported(&[("devicestatus", open.clone())]);
    assert_eq!(linked, imported);
    assert_eq!(linked["kind"], "open_loop", "{linked}");
    assert_eq!(linked["basal_suggestions"], true, "{linked}");
    // Closed loop on for the last loop cycle: it enacted.
    let mut closed = open;
    closed[0]["openaps"]["enacted"] = closed[0]["openaps"]["suggested"].clone();
    let (linked, imported) = linked_and_imported(&[("devicestatus", closed)]);
    assert_eq!(linked, imported);
    assert_eq!(linked["kind"], "closed_loop", "{linked}");
    assert_eq!(linked["basal_suggestions"], false, "{linked}");
}

/// AndroidAPS's device status (`openaps` with `suggested`, `enacted`
/// where the person accepted), and Loop's, OpenAPS' and the 600-series
/// uploader's (one of them with a `created_at` carrying an offset), are
/// counted through the link as by a file import of the same documents.
#[test]
fn the_link_counts_androidaps_and_loops_device_status_as_files_do() {
    let (linked, imported) = linked_and_imported(&[
        ("treatments", treatments()),
        (
            "devicestatus",
            io_fixture("nightscout_devicestatus_aaps_open_loop_synthetic.json"),
        ),
    ]);
    assert_eq!(linked, imported);
    assert_eq!(linked["kind"], "open_loop", "{linked}");
    assert_evidence(&linked, "18 records from or naming devicestatus.openaps");
    // Loop, OpenAPS and a pump's status of 2026-03-18, moved to the last
    // day of the CGM data in the forms they have.
    let text = serde_json::to_string(&io_fixture("nightscout_devicestatus_synthetic.json"))
        .unwrap()
        .replace("2026-03-18", "2026-11-18");
    let status: Vec<Value> = serde_json::from_str(&text).unwrap();
    let (linked, imported) = linked_and_imported(&[("devicestatus", status)]);
    assert_eq!(linked, imported);
    assert_evidence(&linked, "1 record from or naming devicestatus.loop");
    assert_eq!(linked["kind"], "closed_loop", "{linked}");
}

/// Each sync reads the device status from its mark: a sync with nothing
/// new asks for one day's (one page) and counts nothing twice; a loop
/// cycle that enacted, uploaded since, closes the loop.
#[test]
fn each_sync_reads_and_counts_only_the_new_device_status() {
    let mut site = Site::new(SECRET);
    site.add("entries", entries());
    let open = io_fixture("nightscout_devicestatus_trio_open_loop_synthetic.json");
    site.add("devicestatus", open.clone());
    let (_dir, srv, mut store) = linked_and_synced(site, 10.0);
    let first = assert_delivery(&mut store, "open_loop", true);
    srv.with(|s| s.log.clear());
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let status = r
        .collections
        .iter()
        .find(|c| c.name == "devicestatus")
        .unwrap();
    assert_eq!((status.documents, status.pages), (0, 1), "{status:?}");
    let asked = srv.with(|s| {
        s.log
            .iter()
            .filter(|l| l.contains("devicestatus"))
            .cloned()
            .collect::<Vec<_>>()
    });
    assert_eq!(asked.len(), 1, "{asked:?}");
    assert_eq!(assert_delivery(&mut store, "open_loop", true), first);
    // The next loop cycle, with closed loop turned on.
    let mut next = open[0].clone();
    next["_id"] = "674000000000000000000bbe".into();
    next["created_at"] = "2026-11-18T23:00:00.000Z".into();
    next["openaps"]["enacted"] = next["openaps"]["suggested"].clone();
    srv.with(|s| s.add("devicestatus", vec![next]));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let status = r
        .collections
        .iter()
        .find(|c| c.name == "devicestatus")
        .unwrap();
    assert_eq!(status.documents, 1, "{status:?}");
    assert_delivery(&mut store, "closed_loop", false);
}

/// Trio's device status every 5 minutes over the three days of the CGM
/// data (864 loop cycles, in closed loop from `closed_from` on), newest
/// first, from the fixture's first document.
fn trio_cycles(closed_from: usize) -> Vec<Value> {
    let open = io_fixture("nightscout_devicestatus_trio_open_loop_synthetic.json");
    let end: i64 = 1_795_042_500_000; // 2026-11-18T22:55:00Z
    (0..864)
        .rev()
        .map(|i: usize| {
            let mut d = open[0].clone();
            let t = end - (863 - i as i64) * 300_000;
            d["_id"] = format!("6740{i:020x}").into();
            d["created_at"] = jiff::Timestamp::from_millisecond(t)
                .unwrap()
                .strftime("%Y-%m-%dT%H:%M:%S%.3fZ")
                .to_string()
                .into();
            if i >= closed_from {
                d["openaps"]["enacted"] = d["openaps"]["suggested"].clone();
            }
            d
        })
        .collect()
}

/// More device status than a page holds (the site serves 100 at most) is
/// read a UTC day at a time, no read reaching over more than a day, and
/// counted as the file import counts it.
#[test]
fn a_first_sync_reads_the_device_status_a_day_at_a_time() {
    let status = trio_cycles(800);
    let mut site = Site::new(SECRET);
    site.max_count = 100;
    site.add("entries", entries());
    site.add("devicestatus", status.clone());
    let (dir, srv, mut linked) = linked_and_synced(site, 10.0);
    let mut files = Vec::new();
    for (c, d) in [("entries", entries()), ("devicestatus", status)] {
        let f = dir.path().join(format!("{c}.json"));
        std::fs::write(&f, serde_json::to_vec(&d).unwrap()).unwrap();
        files.push(f);
    }
    let mut imported = person_store(&dir.path().join("files.db"), 10.0);
    imported.import_files("ana", &files, None).unwrap();
    let delivery = assert_delivery(&mut linked, "closed_loop", false);
    assert_eq!(delivery, advice(&mut imported)["delivery"]);
    assert_evidence(&delivery, "864 records from or naming devicestatus.openaps");
    // Every read of a range names its bounds, a day apart at most.
    let asked: Vec<String> = srv.with(|s| s.log.clone());
    let ranges: Vec<(i64, i64)> = asked
        .iter()
        .filter(|l| l.contains("devicestatus"))
        .filter_map(|l| {
            let bound = |op: &str| {
                let key = format!("find%5Bcreated_at%5D%5B%24{op}%5D=");
                let at = l.find(&key)? + key.len();
                let v = l[at..].split('&').next()?.replace("%3A", ":");
                Some(v.parse::<jiff::Timestamp>().ok()?.as_millisecond())
            };
            Some((bound("gte")?, bound("lt").or_else(|| bound("lte"))?))
        })
        .collect();
    assert!(ranges.len() >= 3, "{asked:?}");
    assert!(
        ranges.iter().all(|(lo, hi)| hi - lo <= 86_400_000),
        "{ranges:?}"
    );
}
