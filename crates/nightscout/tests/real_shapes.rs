//! The sync against the shapes real Nightscout sites serve (read in
//! cgm-remote-monitor's code, see the crate's README): `created_at`
//! stored in several forms and compared as a string; entries of every
//! type; a site behind a path, readable without a credential, with
//! `DE_NORMALIZE_DATES` and without API v2 authorization (`?token=`); API
//! v3 identifiers that are not the `_id` and a lower `API3_MAX_LIMIT`;
//! documents deleted through API v1 (gone without a trace).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::site::credential;
use abba_nightscout::{link, sync, NsError};
use common::server::{iso, Server};
use common::*;
use serde_json::{json, Value};

fn ms(doc: &Value, field: &str) -> i64 {
    doc[field]
        .as_str()
        .unwrap()
        .parse::<jiff::Timestamp>()
        .unwrap()
        .as_millisecond()
}

/// `ms` written as `2026-01-14T22:54:00+01:00` style at `offset_min`,
/// with or without milliseconds.
fn with_offset(ms: i64, offset_min: i32, millis: bool) -> String {
    let t = jiff::Timestamp::from_millisecond(ms).unwrap();
    let z = t.to_zoned(jiff::tz::TimeZone::fixed(
        jiff::tz::Offset::from_seconds(offset_min * 60).unwrap(),
    ));
    let sign = if offset_min < 0 { '-' } else { '+' };
    let frac = if millis { "%.3f" } else { "" };
    format!(
        "{}{sign}{:02}:{:02}",
        z.strftime(&format!("%Y-%m-%dT%H:%M:%S{frac}")),
        offset_min.abs() / 60,
        offset_min.abs() % 60
    )
}

/// The data set with `created_at` in the forms real sites hold (as
/// uploaders sent them before Nightscout normalised on insert, or written
/// to MongoDB directly): `toISOString()`, without milliseconds, with a
/// positive and a negative offset; and entries of type `mbg` and `cal`
/// beside `sgv`, some with `dateString` in local time.
fn real_shapes(blocks: i64) -> Data {
    let mut d = data(blocks);
    for (i, t) in d.treatments.iter_mut().enumerate() {
        let at = ms(t, "created_at");
        let (text, offset) = match i % 4 {
            0 => (iso(at), 0),
            1 => (
                jiff::Timestamp::from_millisecond(at)
                    .unwrap()
                    .strftime("%Y-%m-%dT%H:%M:%SZ")
                    .to_string(),
                0,
            ),
            2 => (with_offset(at, 60, false), 60),
            _ => (with_offset(at, -300, true), -300),
        };
        t["created_at"] = Value::String(text);
        t["utcOffset"] = json!(offset);
    }
    let mut extra = Vec::new();
    for (i, e) in d.entries.iter().enumerate().filter(|(i, _)| i % 97 == 0) {
        let at = e["date"].as_i64().unwrap() + 1000;
        let id = format!("{:024x}", 0xe0_0000 + i);
        extra.push(if i % 2 == 0 {
            json!({"_id": id, "type": "mbg", "mbg": 104 + (i % 50), "date": at,
                   "dateString": with_offset(at, 60, true), "utcOffset": 60,
                   "sysTime": with_offset(at, 60, true), "device": "Contour"})
        } else {
            json!({"_id": id, "type": "cal", "slope": 1000.0, "intercept": 30000.0,
                   "scale": 1, "date": at, "dateString": iso(at), "device": "xDrip-DexcomG6"})
        });
    }
    d.entries.extend(extra);
    d.entries
        .sort_by_key(|e| std::cmp::Reverse(e["date"].as_i64().unwrap()));
    d
}

#[test]
fn treatments_in_every_stored_form_and_entries_of_every_type_sync_as_files_import() {
    let dir = tempfile::tempdir().unwrap();
    let d = real_shapes(3);
    let files = export(dir.path(), &d);
    // Small pages: their boundaries fall between documents of every form.
    let srv = Server::start(site_of(&d, 12));
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.collections[0].documents, d.entries.len());
    assert_eq!(r.collections[1].documents, d.treatments.len());
    assert!(r.gone.is_empty(), "{:?}", r.gone);
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    assert_eq!(advice(&mut synced), advice(&mut imported));
    // Again: nothing new, nothing taken as gone in the window read again
    // (where offsets move strings away from the times they stand for).
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
    assert_same_records(&synced, &imported);
}

#[test]
fn a_site_behind_a_path_readable_without_credential_with_denormalized_dates_and_no_api_v2() {
    let dir = tempfile::tempdir().unwrap();
    let d = real_shapes(2);
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 50);
    site.default_readable = true;
    site.v2_auth = false;
    site.v3 = false;
    site.denormalize = true;
    let srv = Server::start_at(site, "/ns");
    assert!(srv.url.ends_with("/ns"));
    let (_, mut store) = store_with_person(dir.path(), "sync.db", &files);
    // Readable without a credential, yet a wrong one is refused (as
    // `authorization.resolve` does).
    let wrong = credential(None, Some("not-the-secret-at-all")).unwrap();
    let e = link(
        &mut store,
        "ana",
        &format!("{}/", srv.url),
        wrong,
        false,
        &fast_client(),
    )
    .unwrap_err();
    assert!(matches!(e, NsError::Unauthorized { .. }), "{e}");
    // The URL with a trailing slash; the token goes as `?token=` (no JWT).
    let (l, check) = link(
        &mut store,
        "ana",
        &format!("{}/", srv.url),
        reader(),
        false,
        &fast_client(),
    )
    .unwrap();
    assert_eq!(l.url, srv.url);
    assert!(!check.v3);
    srv.with(|s| s.log.clear());
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(!r.v3);
    let log = srv.with(|s| s.log.clone());
    assert!(
        log.iter()
            .filter(|l| l.contains("/ns/api/v1/"))
            .all(|l| l.contains("token=reader-0123456789abcdef")),
        "{log:?}"
    );
    // `created_at` and `dateString` came in the documents' offsets.
    let served = srv.with(|s| s.denormalize);
    assert!(served);
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&store, &imported);
    let again = sync(&mut store, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
}

#[test]
fn api_v3_identifiers_that_are_not_the_id_and_a_lower_v3_limit() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(2);
    // Documents created through API v3 (AndroidAPS): an identifier of
    // their own beside the `_id` MongoDB gave them.
    for (i, t) in d.treatments.iter_mut().enumerate() {
        t["identifier"] = Value::String(format!("7d6bcbb3-9c4d-4e5e-8d7e-{i:012x}"));
    }
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 1000);
    site.v3_max_limit = 40;
    let srv = Server::start(site);
    let (_, mut store) = store_with_person(dir.path(), "sync.db", &files);
    link(&mut store, "ana", &srv.url, reader(), false, &fast_client()).unwrap();
    let first = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(first.v3);
    let before = store.records("ana").unwrap();
    // A meal bolus of the older block: outside the window read again, so
    // only v3's history says it is gone, by its identifier.
    let newest = d
        .treatments
        .iter()
        .map(|t| ms(t, "created_at"))
        .max()
        .unwrap();
    let old = d
        .treatments
        .iter()
        .find(|t| t["eventType"] == "Meal Bolus" && ms(t, "created_at") < newest - 3 * 86_400_000)
        .unwrap();
    let (id, identifier) = (
        old["_id"].as_str().unwrap().to_string(),
        old["identifier"].as_str().unwrap().to_string(),
    );
    srv.with(|s| s.soft_delete("treatments", &identifier));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    // A meal bolus is two records (carbs, insulin): both go.
    assert_eq!(r.import.deleted, 2, "{r:?}");
    assert!(r.gone.is_empty(), "{:?}", r.gone);
    let after = store.records("ana").unwrap();
    assert_eq!(after.len(), before.len() - 2);
    assert!(after.iter().all(|r| !format!("{:?}", r.id).contains(&id)));
    // The history was read in pages the site accepts.
    let log = srv.with(|s| s.log.clone());
    assert!(log
        .iter()
        .any(|l| l.contains("/api/v3/treatments/history/")));
    assert_eq!(
        sync(&mut store, "ana", &sync_opts())
            .unwrap()
            .import
            .deleted,
        0
    );
}

#[test]
fn documents_deleted_through_api_v1_are_kept_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = Server::start(site_of(&d, 1000));
    let mut store = linked(dir.path(), "sync.db", &files, &srv.url);
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let before = records(&store);
    // The newest meal bolus and the newest entry: inside the window a sync
    // reads again.
    let meal = d
        .treatments
        .iter()
        .filter(|t| t["eventType"] == "Meal Bolus")
        .max_by_key(|t| ms(t, "created_at"))
        .unwrap()["_id"]
        .as_str()
        .unwrap()
        .to_string();
    let entry = d.entries[0]["_id"].as_str().unwrap().to_string();
    srv.with(|s| {
        s.hard_delete("treatments", &meal);
        s.hard_delete("entries", &entry);
    });
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let mut want = vec![meal.clone(), entry.clone()];
    want.sort();
    let mut gone = r.gone.clone();
    gone.sort();
    assert_eq!(gone, want);
    assert_eq!(r.import.deleted, 0);
    // Nothing the person gave is lost: the records stay.
    assert_eq!(records(&store), before);
    // Still gone, still said; a document the site serves again is not.
    srv.with(|s| s.add("entries", vec![d.entries[0].clone()]));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_eq!(r.gone, vec![meal]);
    assert_eq!(records(&store), before);
}

#[test]
fn documents_deleted_through_api_v1_early_in_the_window_are_reported_too() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    // The newest treatment is at 2026-01-14T21:54Z: the window read again
    // starts 24 h before. A bolus 1 h into it written at -05:00 (its string
    // reads 5 h earlier, before the window's bound) is still served and
    // not taken as gone.
    let start = ms(&d.treatments[0], "created_at") - 24 * 3_600_000;
    let early = json!({"_id": object_id(start, 9), "eventType": "Correction Bolus",
        "created_at": with_offset(start + 3_600_000, -300, false),
        "insulin": 0.3, "enteredBy": "Careportal", "utcOffset": -300});
    d.treatments.push(early.clone());
    let files = export(dir.path(), &d);
    let srv = Server::start(site_of(&d, 1000));
    let mut store = linked(dir.path(), "sync.db", &files, &srv.url);
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let before = records(&store);
    // Deleted through v1: the temporary basal 3.6 h and the meal bolus
    // 8 h into the window.
    let id_at = |at: &str| {
        d.treatments.iter().find(|t| t["created_at"] == at).unwrap()["_id"]
            .as_str()
            .unwrap()
            .to_string()
    };
    let basal = id_at("2026-01-14T01:30:00.000Z");
    let meal = id_at("2026-01-14T06:02:00.000Z");
    srv.with(|s| {
        s.hard_delete("treatments", &basal);
        s.hard_delete("treatments", &meal);
    });
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let mut want = vec![basal, meal];
    want.sort();
    let mut gone = r.gone.clone();
    gone.sort();
    assert_eq!(gone, want);
    assert_eq!(r.import.deleted, 0);
    assert_eq!(records(&store), before);
}
