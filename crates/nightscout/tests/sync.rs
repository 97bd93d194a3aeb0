//! The sync against a Nightscout-compatible server on 127.0.0.1: one sync
//! equals a file import of the same documents; a second sync adds
//! nothing; new documents come in; the paging survives a server-side
//! maximum page size, 429 with Retry-After, 500, a connection cut
//! mid-page and a slow server; a wrong credential is a clear 401; API v3
//! deletions remove their records.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::site::credential;
use abba_nightscout::{link, sync, NsError};
use abba_store::link::Credential;
use common::server::{Fault, FaultKind};
use common::*;
use std::time::Duration;

fn linked(
    dir: &std::path::Path,
    srv: &common::server::Server,
    files: &[std::path::PathBuf],
    cred: Credential,
) -> abba_store::Store {
    let (_, mut store) = store_with_person(dir, "sync.db", files);
    link(&mut store, "ana", &srv.url, cred, false, &fast_client()).unwrap();
    store
}

#[test]
fn one_sync_equals_a_file_import_and_a_second_adds_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(2);
    let files = export(dir.path(), &d);
    // The server caps pages at 100 documents whatever the client asks:
    // the entries take many pages, each repeating the boundary document.
    let srv = server(&d, 100);
    let mut synced = linked(dir.path(), &srv, &files, secret());
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let entries = &r.collections[0];
    assert_eq!(entries.documents, d.entries.len());
    assert!(entries.pages > d.entries.len() / 100, "{entries:?}");
    assert!(
        entries.received > entries.documents,
        "pages overlap at their boundary"
    );
    let s = r.import.import.as_ref().unwrap();
    assert!(s.added > 0);

    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    let f = imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    assert_eq!(s.added, f.added);
    assert_eq!(advice(&mut synced), advice(&mut imported));

    // Again: nothing new.
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert_same_records(&synced, &imported);
    let l = synced.link("ana").unwrap().unwrap();
    assert!(l.last_success_at.is_some() && l.last_error.is_none());
}

#[test]
fn new_documents_come_in_and_the_overlap_is_not_counted_twice() {
    let dir = tempfile::tempdir().unwrap();
    let all = data(2);
    // The server first holds the older block only.
    let n_old = all.entries.len() / 2;
    let first = Data {
        entries: all.entries[n_old..].to_vec(),
        treatments: all.treatments[all.treatments.len() / 2..].to_vec(),
        profile: all.profile.clone(),
    };
    let files = export(dir.path(), &all);
    let srv = server(&first, 1000);
    let mut store = linked(dir.path(), &srv, &files, secret());
    let one = sync(&mut store, "ana", &sync_opts()).unwrap();
    let added_first = one.import.import.unwrap().added;
    srv.with(|s| {
        s.add("entries", all.entries[..n_old].to_vec());
        s.add(
            "treatments",
            all.treatments[..all.treatments.len() / 2].to_vec(),
        );
    });
    let two = sync(&mut store, "ana", &sync_opts()).unwrap();
    // Only what is at or after the mark minus the overlap was asked for.
    assert!(two.collections[0].documents < all.entries.len());
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    let f = imported.import_files("ana", &files, None).unwrap();
    assert_eq!(added_first + two.import.import.unwrap().added, f.added);
    assert_same_records(&store, &imported);
}

#[test]
fn faults_are_retried_and_a_failed_sync_leaves_the_store_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 200);
    let mut store = linked(dir.path(), &srv, &files, secret());
    let fault = |path: &str, kind: FaultKind, times: usize| Fault {
        path: path.into(),
        kind,
        times,
    };
    srv.with(|s| {
        s.faults = vec![
            fault("entries", FaultKind::TooMany(1), 1),
            fault("entries", FaultKind::Status(500), 1),
            fault("entries", FaultKind::Cut, 1),
            fault("treatments", FaultKind::Slow(Duration::from_secs(7)), 1),
            fault("treatments", FaultKind::Status(503), 1),
        ];
        s.log.clear();
    });
    let t0 = std::time::Instant::now();
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    // The 429's Retry-After of 1 s was waited for.
    assert!(t0.elapsed() >= Duration::from_secs(1));
    assert!(srv.with(|s| s.faults.is_empty()), "every fault was met");
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&store, &imported);
    assert!(r.import.import.unwrap().added > 0);

    // A server failing for longer than the retries: the sync fails, the
    // store and its marks are unchanged, the link says why; the next sync
    // completes.
    let dir2 = tempfile::tempdir().unwrap();
    let mut fresh = linked(dir2.path(), &srv, &files, secret());
    srv.with(|s| s.faults = vec![fault("treatments", FaultKind::Status(500), 4)]);
    let e = sync(&mut fresh, "ana", &sync_opts()).unwrap_err();
    assert!(matches!(e, NsError::GaveUp { .. }), "{e}");
    assert!(e.to_string().contains("HTTP 500"), "{e}");
    assert!(fresh.records("ana").unwrap().is_empty());
    assert!(fresh.link_marks("ana").unwrap().is_empty());
    let l = fresh.link("ana").unwrap().unwrap();
    assert_eq!(l.failures, 1);
    assert!(l.last_error.unwrap().contains("HTTP 500"));
    sync(&mut fresh, "ana", &sync_opts()).unwrap();
    assert_same_records(&fresh, &imported);
    assert_eq!(fresh.link("ana").unwrap().unwrap().failures, 0);
}

#[test]
fn credentials_are_checked_and_never_in_messages() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (_, mut store) = store_with_person(dir.path(), "auth.db", &files);
    let wrong = credential(None, Some("not-the-secret-at-all")).unwrap();
    let e = link(
        &mut store,
        "ana",
        &srv.url,
        wrong.clone(),
        false,
        &fast_client(),
    )
    .unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, NsError::Unauthorized { .. }), "{text}");
    assert!(
        text.contains("401") && text.contains("API secret"),
        "{text}"
    );
    assert!(!text.contains(wrong.secret()), "{text}");
    assert!(
        store.link("ana").unwrap().is_none(),
        "a refused link is not stored"
    );
    // The API secret goes as its SHA-1 in a header, never in the URL.
    assert!(srv.with(|s| s.log.iter().all(|l| !l.contains(&sha1_of(SECRET)))));

    // A denied token is refused; a readable one works through a JWT,
    // renewed when it expires.
    let denied = credential(Some("denied-0123456789abcdef"), None).unwrap();
    let e = link(&mut store, "ana", &srv.url, denied, false, &fast_client()).unwrap_err();
    assert!(matches!(e, NsError::Unauthorized { .. }), "{e}");
    assert!(!e.to_string().contains("denied-0123456789abcdef"));
    srv.with(|s| s.jwt_uses = Some(2));
    let reader = credential(Some("reader-0123456789abcdef"), None).unwrap();
    link(&mut store, "ana", &srv.url, reader, false, &fast_client()).unwrap();
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(r.v3);
    assert!(srv.with(|s| s.jwts.len()) >= 2, "the JWT was renewed");
    assert!(srv.with(|s| s.log.iter().all(|l| !l.contains("reader-0123456789abcdef"))));

    // Plain http to another host is refused before any call.
    let e = link(
        &mut store,
        "ana",
        "http://example.org",
        secret(),
        false,
        &fast_client(),
    )
    .unwrap_err();
    assert!(matches!(e, NsError::Url { .. }), "{e}");
}

fn sha1_of(s: &str) -> String {
    common::server::sha1_hex(s)
}

#[test]
fn a_document_deleted_through_api_v3_leaves_the_store() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let token = credential(Some("reader-0123456789abcdef"), None).unwrap();
    let mut store = linked(dir.path(), &srv, &files, token);
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let before = store.records("ana").unwrap().len();
    let meal = d
        .treatments
        .iter()
        .find(|t| t["eventType"] == "Meal Bolus")
        .unwrap();
    let id = meal["_id"].as_str().unwrap().to_string();
    srv.with(|s| s.soft_delete("treatments", &id));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    // A meal bolus is two records (carbs, insulin): both go.
    assert_eq!(r.import.deleted, 2, "{r:?}");
    let after = store.records("ana").unwrap();
    assert_eq!(after.len(), before - 2);
    assert!(after.iter().all(|r| !format!("{:?}", r.id).contains(&id)));
    // And a third sync deletes nothing more.
    assert_eq!(
        sync(&mut store, "ana", &sync_opts())
            .unwrap()
            .import
            .deleted,
        0
    );
}

/// API v3's `lastModified` is the newest `srvModified` or, when later,
/// the newest `created_at` (the test server as Nightscout's
/// `lib/api3/specific/lastModified.js`): a treatment dated a year ahead
/// (an uploader's clock wrong) puts it past the server's clock. History
/// starts at the server's clock (`srvDate`): an old treatment deleted
/// after the first sync, outside the window v1 reads again, leaves the
/// store all the same.
#[test]
fn a_treatment_dated_ahead_does_not_hide_later_deletions_from_api_v3() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let ms = |t: &serde_json::Value| {
        t["created_at"]
            .as_str()
            .and_then(|s| s.parse::<jiff::Timestamp>().ok())
            .map(|t| t.as_millisecond())
    };
    let newest = d.treatments.iter().filter_map(ms).max().unwrap();
    let ahead = newest + 365 * 86_400_000;
    srv.with(|s| {
        s.set_clock(newest + 3_600_000);
        s.add(
            "treatments",
            vec![serde_json::json!({
                "_id": object_id(newest, 99),
                "eventType": "Note",
                "created_at": common::server::iso(ahead),
                "notes": "entered with the phone's clock a year ahead",
            })],
        );
    });
    let token = credential(Some("reader-0123456789abcdef"), None).unwrap();
    let mut store = linked(dir.path(), &srv, &files, token);
    let first = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(first.v3, "{first:?}");
    // The oldest meal bolus: a day and more before the newest document,
    // so v1 does not read it again; only v3's history tells.
    let oldest = d
        .treatments
        .iter()
        .filter(|t| t["eventType"] == "Meal Bolus")
        .min_by_key(|t| ms(t))
        .unwrap();
    assert!(ms(oldest).unwrap() < newest - 2 * 86_400_000);
    let id = oldest["_id"].as_str().unwrap().to_string();
    srv.with(|s| s.soft_delete("treatments", &id));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_eq!(r.import.deleted, 2, "{r:?}");
    assert!(store
        .records("ana")
        .unwrap()
        .iter()
        .all(|r| !format!("{:?}", r.id).contains(&id)));
}

/// A collection the site holds nothing of at the first sync (no profile
/// yet): API v3's `lastModified` names none, and Nightscout refuses
/// `history/0` (400: a time before 2000 is no Last-Modified to it,
/// `parseToMoment` in `lib/api3/shared/dateTools.js`). The next syncs
/// read that collection's history all the same.
#[test]
fn a_collection_empty_at_the_first_sync_is_read_by_api_v3_after() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let profiles = srv.with(|s| s.docs.remove("profile")).unwrap();
    let token = credential(Some("reader-0123456789abcdef"), None).unwrap();
    let mut store = linked(dir.path(), &srv, &files, token);
    assert!(sync(&mut store, "ana", &sync_opts()).unwrap().v3);
    // The person sets up a profile through API v3 (as AndroidAPS does).
    srv.with(|s| s.add_v3("profile", profiles.iter().map(|p| p.doc.clone()).collect()));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(r.v3, "{r:?}");
    assert_eq!(r.collections[3].documents, profiles.len(), "{r:?}");
    assert!(sync(&mut store, "ana", &sync_opts()).is_ok());
}

/// Timings for BENCHMARKS.md (not a test of speed):
/// `cargo test --release -p abba-nightscout --test integration sync:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn measure_a_first_and_a_second_sync() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(10); // 30 days
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let mut store = linked(dir.path(), &srv, &files, secret());
    let t = std::time::Instant::now();
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let first = t.elapsed();
    let t = std::time::Instant::now();
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let second = t.elapsed();
    let t = std::time::Instant::now();
    store.advise("ana").unwrap();
    let advise = t.elapsed();
    println!(
        "30 days ({} entries, {} treatments, {} pages): first sync {first:?}, second {second:?}, advice after {advise:?}",
        d.entries.len(),
        d.treatments.len(),
        r.collections.iter().map(|c| c.pages).sum::<usize>()
    );
}

/// Documents uploaded after the sync that read past their time (an
/// uploader catching up after days offline, a meal entered afterwards):
/// dated 36 h and more before the newest treatment, outside the window a
/// sync reads again by time. They come in, once.
fn late_uploads_come_in(v3: bool) {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let srv = server(&d, 1000);
    let cred = if v3 {
        credential(Some("reader-0123456789abcdef"), None).unwrap()
    } else {
        secret()
    };
    let files = export(dir.path(), &d);
    let mut store = linked(dir.path(), &srv, &files, cred);
    let first = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_eq!(first.v3, v3);
    // Inserted now (the server makes the ObjectId): the newest treatment
    // is at 2026-01-14T21:54Z, the newest entry at 22:55:07Z.
    let now = jiff::Timestamp::now().as_millisecond();
    let mut late_t = vec![serde_json::json!({"_id": object_id(now, 1),
        "eventType": "Correction Bolus", "created_at": "2026-01-13T09:54:00.000Z",
        "insulin": 1.5, "enteredBy": "Careportal", "utcOffset": 60})];
    let at: jiff::Timestamp = "2026-01-13T10:57:30Z".parse().unwrap();
    let late_e = vec![serde_json::json!({"_id": object_id(now, 2),
        "device": "xDrip-DexcomG6", "date": at.as_millisecond(),
        "dateString": "2026-01-13T10:57:30.000Z", "sgv": 141, "direction": "Flat",
        "type": "sgv", "utcOffset": 60})];
    // AndroidAPS uploads through API v3: its own `identifier`, the
    // ObjectId made at insertion, in v3's history. (A document uploaded
    // through v1 is not in history: a Loop-style UUID `_id` uploaded late
    // says nothing of when it came, and is not found; README, Known
    // limits.)
    let late_v3 = vec![
        serde_json::json!({"_id": object_id(now, 3), "identifier": uuid(7),
        "eventType": "Correction Bolus", "created_at": "2026-01-12T08:00:00.000Z",
        "insulin": 1.2, "enteredBy": "openaps://AndroidAPS", "utcOffset": 60}),
    ];
    if v3 {
        late_t.extend(late_v3.clone());
    }
    srv.with(|s| {
        s.add("treatments", late_t[..1].to_vec());
        if v3 {
            s.add_v3("treatments", late_v3);
        }
        s.add("entries", late_e.clone());
    });
    let two = sync(&mut store, "ana", &sync_opts()).unwrap();
    // (The fixture's ObjectIds are random, not made at their time: some
    // read as inserted since, and are counted too.)
    assert!(
        two.collections[0].late >= late_e.len(),
        "{:?}",
        two.collections
    );
    // On v3, history's AndroidAPS document takes the read by time back
    // past the Careportal one, which then comes by time (not counted).
    let counted = if v3 { 1 } else { late_t.len() };
    assert!(two.collections[1].late >= counted, "{:?}", two.collections);
    let mut all = d;
    all.treatments.extend(late_t);
    all.entries.extend(late_e);
    let dir2 = tempfile::tempdir().unwrap();
    let all_files = export(dir2.path(), &all);
    let (_, mut imported) = store_with_person(dir2.path(), "files.db", &all_files);
    imported.import_files("ana", &all_files, None).unwrap();
    assert_same_records(&store, &imported);
    // Once: a sync after adds nothing.
    let again = sync(&mut store, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert_same_records(&store, &imported);
}

#[test]
fn late_uploads_come_in_by_their_object_id_on_a_v1_only_link() {
    late_uploads_come_in(false);
}

#[test]
fn late_uploads_come_in_by_api_v3_history() {
    late_uploads_come_in(true);
}

/// A proxy that compresses whatever the client asked for: the link is
/// refused at once, naming the encoding (not after 5 tries as a body that
/// is "not valid UTF-8").
#[test]
fn a_gzip_answer_nobody_asked_for_is_read_and_another_coding_named() {
    // A proxy that compresses every answer with gzip, whatever abba asked
    // (identity): the link is made and the sync reads everything.
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (_, mut store) = store_with_person(dir.path(), "gz.db", &files);
    let gzip = |path: &str| Fault {
        path: path.into(),
        kind: FaultKind::Gzip,
        times: 1000,
    };
    srv.with(|s| {
        s.faults = vec![
            gzip("status"),
            gzip("entries"),
            gzip("treatments"),
            gzip("profile"),
        ]
    });
    link(&mut store, "ana", &srv.url, secret(), false, &fast_client()).unwrap();
    sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(
        srv.with(|s| s.faults.iter().all(|f| f.times < 1000)),
        "every answer was gzip"
    );
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&store, &imported);
    // A coding abba does not read is named at once, not retried.
    let (_, mut other) = store_with_person(dir.path(), "br.db", &files);
    srv.with(|s| {
        s.faults = vec![Fault {
            path: "status".into(),
            kind: FaultKind::Encoded("br"),
            times: 10,
        }];
        s.log.clear();
    });
    let e = link(&mut other, "ana", &srv.url, secret(), false, &fast_client()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, NsError::Protocol { .. }), "{text}");
    assert!(text.contains("Content-Encoding: br"), "{text}");
    assert_eq!(srv.with(|s| s.log.len()), 1, "not retried");
    assert!(other.link("ana").unwrap().is_none());
}

/// A server that ignores `find[date]` (it answers its newest documents
/// whatever the bound) cannot be read by time, and abba has no other way
/// to read it whole: the link is refused at once, naming the filter,
/// before anything is stored; a link made before that check fails its
/// sync with the same words and imports nothing.
#[test]
fn a_server_that_ignores_the_time_filter_is_refused_when_linked() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 100);
    srv.with(|s| s.ignores_time_filter = true);
    let (_, mut store) = store_with_person(dir.path(), "nofilter.db", &files);
    let e = link(&mut store, "ana", &srv.url, secret(), false, &fast_client()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, NsError::Protocol { .. }), "{text}");
    assert!(
        text.contains("ignores find[date]") && text.contains("cannot read it completely"),
        "{text}"
    );
    assert!(store.link("ana").unwrap().is_none());
    // Linked before the check existed: the sync fails, nothing imported.
    store.set_link("ana", &srv.url, &secret(), false).unwrap();
    let e = sync(&mut store, "ana", &sync_opts()).unwrap_err();
    assert!(e.to_string().contains("ignores find[date]"), "{e}");
    assert!(store.records("ana").unwrap().is_empty());
}

/// A treatment deleted through API v3 and uploaded again under another
/// `_id` with the same content (an uploader re-sending it, a person
/// entering it again) is one bolus the site holds: the sync keeps it.
/// Before, the new document's records were taken as known (the old
/// document's, still in the log) and then removed with the old: the
/// bolus and its carbs were lost from the store while valid on the site.
#[test]
fn a_document_deleted_and_uploaded_again_under_another_id_stays() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let token = credential(Some("reader-0123456789abcdef"), None).unwrap();
    let mut store = linked(dir.path(), &srv, &files, token);
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let before = records(&store).len();
    let meal = d
        .treatments
        .iter()
        .find(|t| t["eventType"] == "Meal Bolus")
        .unwrap()
        .clone();
    let id = meal["_id"].as_str().unwrap().to_string();
    let mut again = meal.clone();
    let now = jiff::Timestamp::now().as_millisecond();
    again["_id"] = serde_json::Value::String(object_id(now, 9));
    srv.with(|s| {
        s.soft_delete("treatments", &id);
        s.add("treatments", vec![again.clone()]);
    });
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_eq!(r.import.deleted, 2, "{r:?}");
    // The same records as a file import of what the site holds valid.
    let mut valid = d;
    valid.treatments.retain(|t| t["_id"].as_str() != Some(&id));
    valid.treatments.push(again);
    let dir2 = tempfile::tempdir().unwrap();
    let valid_files = export(dir2.path(), &valid);
    let (_, mut imported) = store_with_person(dir2.path(), "files.db", &valid_files);
    imported.import_files("ana", &valid_files, None).unwrap();
    assert_same_records(&store, &imported);
    assert_eq!(records(&store).len(), before);
    // Once: a sync after changes nothing.
    let a = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert_eq!(a.import.deleted, 0);
    assert_same_records(&store, &imported);
}

/// A Profile Switch that only names its profile (Careportal's: `profile`,
/// no `profileJson`) runs that profile of the site's profile store, which
/// the link reads at `/api/v1/profile.json`: the synced records hold its
/// basal schedule from the switch on, as a file import of the same
/// documents does; a name the store does not hold is counted, not applied.
#[test]
fn a_switch_naming_a_profile_of_the_sites_store_is_applied_by_the_sync() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let mut weekend = d.profile[0]["store"]["Default"].clone();
    weekend["basal"] = serde_json::json!([
        {"time": "00:00", "value": 0.6, "timeAsSeconds": 0},
        {"time": "07:00", "value": 0.7, "timeAsSeconds": 25200}
    ]);
    for p in &mut d.profile {
        p["store"]["Weekend"] = weekend.clone();
    }
    let switch = |id: &str, at: &str, name: &str| {
        serde_json::json!({"_id": id, "enteredBy": "Ana", "eventType": "Profile Switch",
            "created_at": at, "profile": name, "units": "mmol", "utcOffset": 0})
    };
    d.treatments.insert(
        0,
        switch(
            "6551aaaaaaaaaaaaaaaaaaa1",
            "2026-01-14T06:00:00.000Z",
            "Weekend",
        ),
    );
    d.treatments.insert(
        0,
        switch(
            "6551aaaaaaaaaaaaaaaaaaa2",
            "2026-01-14T20:00:00.000Z",
            "Holiday",
        ),
    );
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let mut synced = linked(dir.path(), &srv, &files, secret());
    sync(&mut synced, "ana", &sync_opts()).unwrap();
    let at: jiff::Timestamp = "2026-01-14T06:00:00Z".parse().unwrap();
    let records = synced.records("ana").unwrap();
    let basal: Vec<Vec<(u32, f64)>> = records
        .iter()
        .filter(|r| r.at == at)
        .filter_map(|r| match &r.kind {
            abba_io::RecordKind::Schedule { profile } => Some(
                profile
                    .basal
                    .segments
                    .iter()
                    .map(|s| (s.0, s.1 .0))
                    .collect(),
            ),
            _ => None,
        })
        .collect();
    assert_eq!(basal, [vec![(0, 0.6), (420, 0.7)]]);
    let holiday: jiff::Timestamp = "2026-01-14T20:00:00Z".parse().unwrap();
    assert!(records.iter().any(|r| r.at == holiday
        && matches!(&r.kind, abba_io::RecordKind::Ignored { kind } if kind.contains("does not hold"))));
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
}
