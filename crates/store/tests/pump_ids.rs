//! AndroidAPS's pump identity (`pumpType`, `pumpSerial`, `pumpId`) tells a
//! dose uploaded again from a second dose across imports: two identical
//! boluses 30 s apart with other pump ids are two doses; the same bolus
//! uploaded by NSClient and again by NSClientV3 seconds apart is one; doses
//! without pump ids keep the 60-s window. The documents are the AndroidAPS
//! fixtures of `crates/io/tests/data` (see its PROVENANCE.md), varied here.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_store::Store;
use common::{person, read, TempDir};
use serde_json::Value;

fn fixture(name: &str) -> Vec<Value> {
    let path = format!("{}/../io/tests/data/{name}", env!("CARGO_MANIFEST_DIR"));
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// NSClient's (API v1) upload of the 1.5 U correction bolus, pumpId 41012.
fn v1_bolus() -> Value {
    let docs = fixture("nightscout_treatments_aaps_before_reset_synthetic.json");
    docs.into_iter().find(|d| d["pumpId"] == 41012).unwrap()
}

/// NSClientV3's upload of the same bolus after a reset (3 s earlier).
fn v3_copy() -> Value {
    let docs = fixture("nightscout_treatments_aaps_after_reset_synthetic.json");
    docs.into_iter().find(|d| d["pumpId"] == 41012).unwrap()
}

/// `doc` under another `_id`, `secs` later, with the pump's event `pump_id`
/// (none: without AndroidAPS's pump fields).
fn moved(doc: &Value, id: &str, secs: i64, pump_id: Option<i64>) -> Value {
    let mut d = doc.clone();
    let date = d["date"].as_i64().unwrap() + secs * 1000;
    d["_id"] = id.into();
    d["date"] = date.into();
    d["created_at"] = jiff::Timestamp::from_millisecond(date)
        .unwrap()
        .strftime("%Y-%m-%dT%H:%M:%S%.3fZ")
        .to_string()
        .into();
    let o = d.as_object_mut().unwrap();
    match pump_id {
        Some(p) => {
            o.insert("pumpId".into(), p.into());
        }
        None => {
            for k in ["pumpId", "pumpType", "pumpSerial"] {
                o.remove(k);
            }
        }
    }
    d
}

/// Imports `docs` as one treatments file (the time of import: after them).
fn import(store: &mut Store, docs: &[Value]) -> abba_store::ImportSummary {
    let batch = read(&[("treatments.json".into(), serde_json::to_vec(docs).unwrap())]).unwrap();
    let now = "2026-12-01T00:00:00Z".parse().unwrap();
    store.import_at("ana", &batch, now).unwrap()
}

/// The boluses stored (units).
fn stored_boluses(store: &Store) -> Vec<f64> {
    store
        .records("ana")
        .unwrap()
        .into_iter()
        .filter_map(|r| match r.kind {
            abba_io::RecordKind::Bolus { units } => Some(units.0),
            _ => None,
        })
        .collect()
}

/// The insulin of the boluses the advisor is given (its events; doses of
/// one minute are one event).
fn advised_insulin(store: &Store) -> f64 {
    store
        .events("ana")
        .unwrap()
        .iter()
        .filter_map(|e| match &e.kind {
            abba_core::EventKind::Bolus(u) => Some(u.0),
            _ => None,
        })
        .sum()
}

fn new_store(dir: &TempDir) -> Store {
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    store
}

#[test]
fn two_identical_boluses_30_s_apart_with_other_pump_ids_in_two_imports_are_two_doses() {
    let dir = TempDir::new("pump-ids-two");
    let mut store = new_store(&dir);
    let first = v1_bolus();
    let second = moved(&first, "673f7c10a9c4e21b7f0b0099", 30, Some(41013));
    import(&mut store, std::slice::from_ref(&first));
    let summary = import(&mut store, &[second]);
    assert_eq!(
        (summary.added, summary.copies_of_stored_doses),
        (1, 0),
        "{summary:?}"
    );
    let given = 2.0 * first["insulin"].as_f64().unwrap();
    assert_eq!(stored_boluses(&store).len(), 2);
    let insulin = advised_insulin(&store);
    assert!(
        (insulin - given).abs() < 1e-9,
        "{insulin} U, given {given} U"
    );
}

#[test]
fn the_same_bolus_uploaded_by_nsclient_and_nsclientv3_in_two_imports_is_one_dose() {
    let dir = TempDir::new("pump-ids-copy");
    let mut store = new_store(&dir);
    let v1 = v1_bolus();
    let v3 = v3_copy();
    assert_ne!(v1["_id"], v3["_id"]);
    assert_ne!(v1["date"], v3["date"]);
    import(&mut store, std::slice::from_ref(&v1));
    let summary = import(&mut store, &[v3]);
    assert_eq!(
        (summary.added, summary.copies_of_stored_doses),
        (0, 1),
        "{summary:?}"
    );
    let given = v1["insulin"].as_f64().unwrap();
    assert_eq!(stored_boluses(&store), vec![given]);
    let insulin = advised_insulin(&store);
    assert!(
        (insulin - given).abs() < 1e-9,
        "{insulin} U, given {given} U"
    );
}

#[test]
fn a_copy_without_pump_ids_keeps_the_60_s_window() {
    let dir = TempDir::new("pump-ids-none");
    let mut store = new_store(&dir);
    let first = moved(&v1_bolus(), "673f7c10a9c4e21b7f0b0098", 0, None);
    // Within 60 s: a copy, as before pump ids were kept; past it: a dose.
    let near = moved(&first, "673f7c10a9c4e21b7f0b0097", 30, None);
    let far = moved(&first, "673f7c10a9c4e21b7f0b0096", 61, None);
    import(&mut store, std::slice::from_ref(&first));
    let summary = import(&mut store, &[near]);
    assert_eq!(summary.copies_of_stored_doses, 1, "{summary:?}");
    let summary = import(&mut store, &[far]);
    assert_eq!(summary.added, 1, "{summary:?}");
    assert_eq!(stored_boluses(&store).len(), 2);
}

#[test]
fn a_dose_stored_without_a_pump_id_and_one_with_keep_the_60_s_window() {
    let dir = TempDir::new("pump-ids-one");
    let mut store = new_store(&dir);
    let with = v1_bolus();
    let without = moved(&with, "673f7c10a9c4e21b7f0b0095", 30, None);
    import(&mut store, &[without]);
    let summary = import(&mut store, &[with]);
    assert_eq!(summary.copies_of_stored_doses, 1, "{summary:?}");
    assert_eq!(stored_boluses(&store).len(), 1);
}

#[test]
fn two_identical_boluses_30_s_apart_with_other_pump_ids_in_one_file_are_two_doses() {
    let dir = TempDir::new("pump-ids-file");
    let mut store = new_store(&dir);
    let first = v1_bolus();
    let second = moved(&first, "673f7c10a9c4e21b7f0b0094", 30, Some(41013));
    let summary = import(&mut store, &[first, second]);
    assert_eq!(summary.added, 2, "{summary:?}");
    assert_eq!(stored_boluses(&store).len(), 2);
}
