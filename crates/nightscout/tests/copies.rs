//! AndroidAPS's pump events uploaded again under other documents (an
//! NSClient reset, NSClientV3 after NSClient) reaching the store by two
//! syncs of the live link: each dose is stored once, and the second
//! sync says how many copies it found; a CareLink export beside the same
//! pump's doses synced from Nightscout, in either order, stores both and
//! counts each dose once (fixtures in `crates/io/tests/data`, see its
//! PROVENANCE.md); a second identical bolus 30 s after the first, with
//! its own pump id, is a second dose.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::sync;
use common::server::{Server, Site};
use common::*;
use serde_json::Value;

fn io_fixture(name: &str) -> Vec<Value> {
    let path = format!("{}/../io/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// `entries` and `profile` written as `entries.json` and `profile.json`
/// in `dir`: the files a person is linked with.
fn entries_and_profile(
    dir: &std::path::Path,
    entries: &[Value],
    profile: &[Value],
) -> Vec<std::path::PathBuf> {
    [("entries.json", entries), ("profile.json", profile)]
        .into_iter()
        .map(|(name, docs)| {
            let p = dir.join(name);
            std::fs::write(&p, serde_json::to_vec(docs).unwrap()).unwrap();
            p
        })
        .collect()
}

/// CGM entries every 5 min over 2026-11-20 to 22 UTC.
fn entries() -> Vec<Value> {
    let start: i64 = 1_795_132_800_000; // 2026-11-20T00:00:00Z
    (0..3 * 288)
        .map(|i| {
            let t = start + i * 300_000;
            serde_json::json!({"_id": object_id(t, i as usize), "type": "sgv",
                "sgv": 110 + (i % 36) * 2, "date": t, "dateString": common::server::iso(t),
                "device": "xDrip-DexcomG6"})
        })
        .collect()
}

fn boluses(store: &abba_store::Store) -> Vec<(jiff::Timestamp, f64)> {
    store
        .records("ana")
        .unwrap()
        .into_iter()
        .filter_map(|r| match r.kind {
            abba_io::RecordKind::Bolus { units } => Some((r.at, units.0)),
            _ => None,
        })
        .collect()
}

#[test]
fn androidaps_events_uploaded_again_reach_the_store_once_over_two_syncs() {
    let dir = tempfile::tempdir().unwrap();
    let profile = io_fixture("nightscout_profile_synthetic.json");
    let entries = entries();
    let before = io_fixture("nightscout_treatments_aaps_before_reset_synthetic.json");
    let after = io_fixture("nightscout_treatments_aaps_after_reset_synthetic.json");
    let files = entries_and_profile(dir.path(), &entries, &profile);
    let mut site = Site::new(SECRET);
    site.add("entries", entries.clone());
    site.add("treatments", before.clone());
    site.add("profile", profile.clone());
    let srv = Server::start(site);
    let mut store = linked(dir.path(), "s.db", &files, &srv.url);
    let first = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(first.import.import.is_some());
    assert_eq!(boluses(&store).len(), before.len());
    // NSClientV3 uploads the same pump events again, and one new.
    srv.with(|s| s.add("treatments", after.clone()));
    let second = sync(&mut store, "ana", &sync_opts()).unwrap();
    let summary = second.import.import.unwrap();
    assert_eq!(summary.added, 1, "{summary:?}");
    // The copies were found, whichever way: against the log (the store's
    // window) or beside the first uploads the sync read again (the
    // reader's pump events), and said.
    let in_batch = summary
        .notes
        .iter()
        .any(|n| n.contains(&format!("{} documents repeat a pump event", before.len())));
    assert!(
        summary.copies_of_stored_doses == before.len() || in_batch,
        "{summary:?}"
    );
    let stored = boluses(&store);
    assert_eq!(stored.len(), after.len(), "{stored:?}");
    let total: f64 = stored.iter().map(|b| b.1).sum();
    let uploaded: f64 = after.iter().map(|d| d["insulin"].as_f64().unwrap()).sum();
    assert!((total - uploaded).abs() < 1e-9, "{total} {uploaded}");
    let events = store.events("ana").unwrap();
    let bolus_events = events
        .iter()
        .filter(|e| matches!(e.kind, abba_core::EventKind::Bolus(_)))
        .count();
    assert_eq!(bolus_events, after.len());
}

/// Person `ana` in Chicago (the CareLink fixture's zone) in a new store
/// `file`, linked to the site at `url`.
fn linked_in_chicago(
    dir: &std::path::Path,
    file: &str,
    profile: &std::path::Path,
    url: &str,
) -> abba_store::Store {
    let mut store = abba_store::Store::open(&dir.join(file)).unwrap();
    let mut p = common::person(&[profile.to_path_buf()]);
    p.tz = "America/Chicago".into();
    store.create_person(&p).unwrap();
    abba_nightscout::link(&mut store, "ana", url, secret(), false, &fast_client()).unwrap();
    store
}

/// The CareLink export of the pump whose doses the 600-series uploader
/// sent to Nightscout, imported into `store` (the store's therapy kept).
fn import_carelink(store: &mut abba_store::Store) -> abba_store::ImportSummary {
    let file = format!(
        "{}/../io/tests/data/carelink_630g_us_synthetic.csv",
        env!("CARGO_MANIFEST_DIR")
    );
    store
        .import_files_with(
            "ana",
            &[file.into()],
            None,
            abba_store::ProfileResolution::Keep,
            None,
        )
        .unwrap()
}

#[test]
fn a_carelink_export_and_a_sync_of_the_same_pump_count_each_dose_once_in_either_order() {
    let dir = tempfile::tempdir().unwrap();
    let profile = io_fixture("nightscout_profile_synthetic.json");
    let treatments = io_fixture("nightscout_treatments_600series_synthetic.json");
    let profile_file = dir.path().join("profile.json");
    std::fs::write(&profile_file, serde_json::to_vec(&profile).unwrap()).unwrap();
    let mut site = Site::new(SECRET);
    site.add("entries", Vec::new());
    site.add("treatments", treatments.clone());
    site.add("profile", profile);
    let srv = Server::start(site);

    let mut alone = linked_in_chicago(dir.path(), "alone.db", &profile_file, &srv.url);
    import_carelink(&mut alone);
    let pump = boluses(&alone);
    // The export first, then the sync.
    let mut a = linked_in_chicago(dir.path(), "a.db", &profile_file, &srv.url);
    import_carelink(&mut a);
    let synced = sync(&mut a, "ana", &sync_opts()).unwrap();
    let said = synced.import.import.unwrap().lines("ana").join("\n");
    // The sync first, then the export.
    let mut b = linked_in_chicago(dir.path(), "b.db", &profile_file, &srv.url);
    sync(&mut b, "ana", &sync_opts()).unwrap();
    let imported = import_carelink(&mut b).lines("ana").join("\n");

    // Every document and every row stored, whichever came first.
    assert_same_records(&a, &b);
    assert_eq!(boluses(&a).len(), pump.len() + treatments.len());
    let events = |s: &abba_store::Store| s.events("ana").unwrap();
    assert_eq!(
        abba_store::replay::events_hash(&events(&a)),
        abba_store::replay::events_hash(&events(&b))
    );
    assert_eq!(advice(&mut a), advice(&mut b));
    // Each dose once: the pump's, and the one bolus Nightscout has of a
    // day the export does not reach (2025-03-17, Chicago).
    let units = |s: &abba_store::Store| -> f64 {
        events(s)
            .iter()
            .map(|e| match e.kind {
                abba_core::EventKind::Bolus(u) => u.0,
                _ => 0.0,
            })
            .sum()
    };
    let later: f64 = treatments
        .iter()
        .filter(|d| d["created_at"].as_str().unwrap() >= "2025-03-17T05:00:00Z")
        .map(|d| d["insulin"].as_f64().unwrap())
        .sum();
    assert!(later > 0.0);
    let pump_units: f64 = pump.iter().map(|b| b.1).sum();
    assert!(
        (units(&a) - (pump_units + later)).abs() < 1e-9,
        "{}",
        units(&a)
    );
    // The second route's records, stored and not used, said either way.
    for text in [&said, &imported] {
        assert!(
            text.contains("6 insulin records from nightscout (2 days, 2025-03-15 to 2025-03-16) stored, not used"),
            "{text}"
        );
    }
}

/// A second bolus of the same units 30 s after the first, with the pump's
/// next event number, synced after it: two doses, both stored and both in
/// the advisor's insulin (the pump ids tell it from a copy uploaded
/// again; without them the 60-s window would take it as one).
#[test]
fn a_second_identical_bolus_30_s_later_with_its_own_pump_id_is_a_second_dose_over_two_syncs() {
    let dir = tempfile::tempdir().unwrap();
    let profile = io_fixture("nightscout_profile_synthetic.json");
    let entries = entries();
    let before = io_fixture("nightscout_treatments_aaps_before_reset_synthetic.json");
    let first = before
        .iter()
        .find(|d| d["pumpId"] == 41012)
        .unwrap()
        .clone();
    let mut second = first.clone();
    let date = first["date"].as_i64().unwrap() + 30_000;
    second["_id"] = "673f7c10a9c4e21b7f0b0099".into();
    second["date"] = date.into();
    second["created_at"] = common::server::iso(date).into();
    second["pumpId"] = 41013.into();
    let files = entries_and_profile(dir.path(), &entries, &profile);
    let mut site = Site::new(SECRET);
    site.add("entries", entries.clone());
    site.add("treatments", vec![first.clone()]);
    site.add("profile", profile.clone());
    let srv = Server::start(site);
    let mut store = linked(dir.path(), "s.db", &files, &srv.url);
    sync(&mut store, "ana", &sync_opts()).unwrap();
    srv.with(|s| s.add("treatments", vec![second]));
    let summary = sync(&mut store, "ana", &sync_opts())
        .unwrap()
        .import
        .import
        .unwrap();
    assert_eq!(
        (summary.added, summary.copies_of_stored_doses),
        (1, 0),
        "{summary:?}"
    );
    let given = 2.0 * first["insulin"].as_f64().unwrap();
    assert_eq!(boluses(&store).len(), 2);
    let insulin: f64 = store
        .events("ana")
        .unwrap()
        .iter()
        .filter_map(|e| match &e.kind {
            abba_core::EventKind::Bolus(u) => Some(u.0),
            _ => None,
        })
        .sum();
    assert!(
        (insulin - given).abs() < 1e-9,
        "{insulin} U, given {given} U"
    );
}
