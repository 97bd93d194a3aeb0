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

/// `site` served, and person "ana" (CGM, 0.85 U/h, `carb_ratio` g/U)
/// linked to it and synced once; the directory holds the store.
fn linked_and_synced(site: Site, carb_ratio: f64) -> (tempfile::TempDir, Server, Store) {
    let dir = tempfile::tempdir().unwrap();
    let srv = Server::start(site);
    let mut store = Store::open(&dir.path().join("link.db")).unwrap();
    let start = TherapySettings::new(UnitsPerHour(0.85), GramsPerUnit(carb_ratio)).unwrap();
    store
        .create_person(&NewPerson::new("ana", TZ, Mode::Cgm, start))
        .unwrap();
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
