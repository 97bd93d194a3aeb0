//! The sync against servers that are Nightscout-compatible but not
//! Nightscout's code, each quirk on its own: answers 404 where there is
//! nothing to serve, a profile served as an object, pages oldest first,
//! pages of 10 whatever `count` asks, bounds on `_id` or `sort[_id]`
//! ignored, 503 with Retry-After, a redirect echoing the token.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::site::credential;
use abba_nightscout::{link, sync, NsError};
use common::server::{Fault, FaultKind, Server, Site};
use common::*;
use std::time::Duration;

/// Links and syncs twice `site` holding `d`: the store holds what a file
/// import of `d` holds, and the second sync adds nothing; the second
/// sync's report.
fn syncs_as_files_import(d: &Data, site: Site) -> abba_nightscout::SyncReport {
    let dir = tempfile::tempdir().unwrap();
    let files = export(dir.path(), d);
    let srv = Server::start(site);
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.collections[0].documents, d.entries.len());
    assert_eq!(r.collections[1].documents, d.treatments.len());
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.as_ref().unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
    assert_same_records(&synced, &imported);
    // What the sync could not look for is on the link (`abba link
    // --list`, the service's link), until a sync without.
    let link = synced.link("ana").unwrap().unwrap();
    assert_eq!(link.warnings, again.warnings);
    again
}

#[test]
fn a_server_answering_404_for_nothing_to_serve() {
    let d = data(2);
    let mut site = site_of(&d, 1000);
    site.empty_is_404 = true;
    site.v3 = false;
    let again = syncs_as_files_import(&d, site);
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
}

#[test]
fn a_profile_served_as_an_object() {
    // The site's one profile document (no record at the epoch).
    let mut d = data(1);
    d.profile.truncate(1);
    let mut site = site_of(&d, 1000);
    site.profile_as_object = true;
    let again = syncs_as_files_import(&d, site);
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
}

#[test]
fn pages_served_oldest_first() {
    let d = data(2);
    let mut site = site_of(&d, 100);
    site.ascending = true;
    let again = syncs_as_files_import(&d, site);
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
}

#[test]
fn count_ignored_pages_of_ten() {
    let d = data(1);
    let again = syncs_as_files_import(&d, site_of(&d, 10));
    assert!(again.warnings.is_empty(), "{:?}", again.warnings);
}

#[test]
fn a_server_ignoring_bounds_on_id() {
    let d = data(1);
    let mut site = site_of(&d, 1000);
    site.ignores_id_bounds = true;
    // What was read by time is complete and imported; the late uploads
    // abba looks for by `_id` cannot be, which the report says (each
    // collection's).
    let again = syncs_as_files_import(&d, site);
    assert_eq!(again.warnings.len(), 2, "{:?}", again.warnings);
    for (w, c) in again.warnings.iter().zip(["entries", "treatments"]) {
        assert!(
            w.contains("late uploads") && w.contains(c) && w.contains("find[_id]"),
            "{w}"
        );
    }
}

/// nightscout/nocturne (Nightscout's API in C#) leaves out of a v1 query
/// what it cannot map: conditions on `_id`, the operators `$type` and
/// `$not`, `sort[...]`. What is read by time is whole and imported; what
/// abba asks by `_id` (late uploads, treatments without a `created_at`
/// string) cannot be, which the report says.
#[test]
fn a_server_leaving_out_id_type_and_not_as_nocturne_does() {
    let d = data(1);
    let mut site = site_of(&d, 1000);
    site.nocturne_query = true;
    let again = syncs_as_files_import(&d, site);
    assert!(
        again
            .warnings
            .iter()
            .any(|w| w.contains("without a created_at string")
                && w.contains("find[created_at][$not][$type]=string")
                && w.contains("leaves that filter out")),
        "{:?}",
        again.warnings
    );
    for c in ["entries", "treatments"] {
        assert!(
            again
                .warnings
                .iter()
                .any(|w| w.contains("late uploads") && w.contains(c)),
            "{c}: {:?}",
            again.warnings
        );
    }
}

#[test]
fn late_entries_on_a_server_that_ignores_sort_by_id_all_arrive() {
    // A server that serves every page newest first by `date`, whatever
    // `sort[_id]` asks; an uploader catching up after days offline sends
    // more entries than a page holds, dated days before the window read
    // again (after the person's first day), their ObjectIds made at insertion (rising with their dates).
    // Paging those by `_id` from the last of a page would skip the rest.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(2);
    let oldest = d.entries.last().unwrap()["date"].as_i64().unwrap();
    // The uploader's stretch: no other reading in it.
    let (from, to) = (oldest + 86_400_000, oldest + 86_400_000 + 1500 * 30_000);
    d.entries.retain(|e| {
        let t = e["date"].as_i64().unwrap();
        t < from - 600_000 || t > to + 600_000
    });
    let mut site = site_of(&d, 1000);
    site.ignores_sort = true;
    site.v3 = false;
    let now = jiff::Timestamp::now().as_millisecond();
    let late: Vec<serde_json::Value> = (0..1500)
        .map(|i| {
            let at = from + i as i64 * 30_000;
            serde_json::json!({"_id": object_id(now, i), "type": "sgv", "sgv": 100 + i % 50,
                "date": at, "dateString": common::server::iso(at), "device": "xDrip-DexcomG6"})
        })
        .collect();
    let mut all = Data {
        entries: d.entries.clone(),
        treatments: d.treatments.clone(),
        profile: d.profile.clone(),
    };
    all.entries.extend(late.iter().cloned());
    let files = export(dir.path(), &all);
    let srv = Server::start(site);
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    sync(&mut synced, "ana", &sync_opts()).unwrap();
    srv.with(|s| s.add("entries", late));
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    assert!(r.collections[0].late >= 1500, "{:?}", r.collections[0]);
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
}

#[test]
fn a_503_with_retry_after_is_waited_for_and_a_longer_one_ends_the_sync() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = Server::start(site_of(&d, 1000));
    let mut store = linked(dir.path(), "sync.db", &files, &srv.url);
    let fault = |kind: FaultKind| Fault {
        path: "entries".into(),
        kind,
        times: 1,
    };
    // Retry-After 2 s is longer than the client's whole backoff (20 ms,
    // doubled per try): only waiting for it passes the time checked.
    srv.with(|s| s.faults = vec![fault(FaultKind::Unavailable(2))]);
    let t0 = std::time::Instant::now();
    sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(t0.elapsed() >= Duration::from_secs(2), "{:?}", t0.elapsed());
    // Longer than abba waits (5 s here): said at once, not slept.
    srv.with(|s| s.faults = vec![fault(FaultKind::Unavailable(3600))]);
    let t0 = std::time::Instant::now();
    let e = sync(&mut store, "ana", &sync_opts()).unwrap_err();
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
    let text = e.to_string();
    assert!(
        matches!(e, NsError::GaveUp { .. }) && text.contains("503") && text.contains("3600"),
        "{text}"
    );
}

#[test]
fn a_redirect_that_carries_the_token_back_does_not_show_it() {
    // A site without API v2 authorization takes the token in the query;
    // its redirect (moved, or http to https) echoes the query back.
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 1000);
    site.v2_auth = false;
    let token = "reader-0123456789abcdef";
    site.faults = vec![Fault {
        path: "status".into(),
        kind: FaultKind::Redirect(format!(
            "https://moved.example/api/v1/status.json?token={token}"
        )),
        times: 1,
    }];
    let srv = Server::start(site);
    let (_, mut store) = store_with_person(dir.path(), "sync.db", &files);
    let reader = credential(Some(token), None).unwrap();
    let e = link(&mut store, "ana", &srv.url, reader, false, &fast_client()).unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, NsError::Redirect { status: 301, .. }), "{text}");
    assert!(
        text.contains("https://moved.example/api/v1/status.json"),
        "{text}"
    );
    assert!(!text.contains(token), "{text}");
}

/// The site's BG Checks' glucose (mg/dL) in the store after a sync, by
/// the status's `settings.units`.
fn bg_checks_by_status_units(units: Option<&'static str>) -> (Vec<f64>, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let at = d.treatments[0]["created_at"].as_str().unwrap().to_string();
    // Careportal's BG Check as a server that is not Nightscout's code may
    // hold it: the glucose without its unit beside it.
    d.treatments
        .push(serde_json::json!({"_id": "c0ffee00c0ffee00c0ffee01",
        "eventType": "BG Check", "created_at": at, "glucose": 6.5,
        "glucoseType": "Finger", "enteredBy": "careportal"}));
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 1000);
    site.status_units = units;
    let srv = Server::start(site);
    let mut store = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let glucose = store
        .records("ana")
        .unwrap()
        .iter()
        .filter(|r| matches!(&r.id, abba_io::record::SourceId::Id(id) if id.as_ref() == "c0ffee00c0ffee00c0ffee01"))
        .map(|r| match &r.kind {
            abba_io::record::RecordKind::Smbg { glucose } => glucose.mg_dl.0,
            other => panic!("{other:?}"),
        })
        .collect();
    (glucose, r.import.import.unwrap().notes)
}

#[test]
fn a_bg_check_without_units_is_in_the_sites_unit_and_else_reported() {
    let (mmol, _) = bg_checks_by_status_units(Some("mmol"));
    assert_eq!(mmol.len(), 1);
    assert!(
        (mmol[0] - 6.5 * abba_core::units::MG_DL_PER_MMOL_L).abs() < 1e-9,
        "{mmol:?}"
    );
    let (mg, _) = bg_checks_by_status_units(Some("mg/dl"));
    // 6.5 mg/dL is no glucose a meter reads: refused, not converted.
    assert!(mg.is_empty(), "{mg:?}");
    let (none, notes) = bg_checks_by_status_units(None);
    assert!(none.is_empty(), "{none:?}");
    assert!(
        notes.iter().any(|n| n.contains("units")),
        "the BG Check is reported: {notes:?}"
    );
}

#[test]
fn ninety_days_back_filled_interrupted_then_resumed_every_reading_once() {
    // 91 days of 5-minute entries on a server capping pages at 1,000; the
    // first sync fails half-way (the site errs longer than the retries):
    // the whole days it read are imported and the next sync reads only
    // the rest; a later sync reads only what is new.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let newest = d.entries[0]["date"].as_i64().unwrap();
    let n = 91 * 288;
    d.entries = (0..n)
        .map(|i| {
            let at = newest - i as i64 * 300_000;
            serde_json::json!({"_id": object_id(at, i), "type": "sgv", "sgv": 80 + (i * 13) % 120,
                "date": at, "dateString": common::server::iso(at), "device": "xDrip-DexcomG6"})
        })
        .collect();
    let profile_start = newest - (n as i64 + 288) * 300_000;
    d.profile[0]["mills"] = serde_json::json!(profile_start);
    d.profile[0]["startDate"] = serde_json::json!(common::server::iso(profile_start));
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 1000);
    site.v3 = false;
    let srv = Server::start(site);
    let entries_read = || srv.with(|s| s.log.iter().filter(|l| l.contains("entries")).count());
    // A single clean sync, for comparison.
    let mut clean = linked(dir.path(), "clean.db", &files, &srv.url);
    srv.with(|s| s.log.clear());
    sync(&mut clean, "ana", &sync_opts()).unwrap();
    let clean_reads = entries_read();
    let mut store = linked(dir.path(), "sync.db", &files, &srv.url);
    // 12 pages through, then every try of the next fails.
    srv.with(|s| {
        s.faults = vec![Fault {
            path: "entries".into(),
            kind: FaultKind::After(12, Box::new(FaultKind::Status(500))),
            times: 4,
        }];
        s.log.clear();
    });
    let e = sync(&mut store, "ana", &sync_opts()).unwrap_err();
    let NsError::Resumable { error, from, .. } = &e else {
        panic!("{e}")
    };
    assert!(matches!(**error, NsError::GaveUp { .. }), "{e}");
    let failed_at = entries_read();
    assert!(failed_at >= 16, "it failed half-way: {failed_at} reads");
    // The whole days read are kept, from a local midnight, each reading
    // of them; nothing is imported (no advice on a history read in part).
    let from: jiff::Timestamp = from.parse().unwrap();
    let midnight = from.to_zoned(jiff::tz::TimeZone::get(TZ).unwrap());
    assert_eq!(midnight.start_of_day().unwrap(), midnight, "{from}");
    let cgm = |store: &abba_store::Store| {
        store
            .records("ana")
            .unwrap()
            .iter()
            .filter(|r| matches!(r.kind, abba_io::record::RecordKind::Cgm { .. }))
            .map(|r| r.at)
            .collect::<Vec<_>>()
    };
    assert!(store.records("ana").unwrap().is_empty());
    let read_whole: Vec<&str> = d
        .entries
        .iter()
        .filter(|e| e["date"].as_i64().unwrap() >= from.as_millisecond())
        .map(|e| e["_id"].as_str().unwrap())
        .collect();
    assert!(read_whole.len() > 12 * 288 && read_whole.len() < n - 288);
    let staged = store.staged("ana").unwrap();
    let (_, entries) = staged.iter().find(|(c, _)| c == "entries").unwrap();
    let kept: Vec<serde_json::Value> = serde_json::from_slice(entries).unwrap();
    let kept: Vec<&str> = kept.iter().map(|e| e["_id"].as_str().unwrap()).collect();
    assert_eq!(kept, read_whole);
    // The next sync reads what is new and the rest below that midnight:
    // not the 12 pages again.
    srv.with(|s| s.log.clear());
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    let resumed_reads = entries_read();
    assert!(
        resumed_reads + 12 <= clean_reads + 3,
        "{resumed_reads} reads resumed, {clean_reads} in a clean sync"
    );
    assert_eq!(r.collections[0].documents, n);
    assert_same_records(&store, &clean);
    assert!(store.staged("ana").unwrap().is_empty());
    let mut at = cgm(&store);
    assert_eq!(at.len(), n);
    at.sort();
    at.dedup();
    assert_eq!(at.len(), n, "each reading once");
    assert_eq!(store.link_marks("ana").unwrap()["backfill"], 0);
    // A day later: 288 new readings; the sync reads them and the window
    // read again, not the months.
    let new: Vec<serde_json::Value> = (1..=288)
        .map(|i| {
            let t = newest + i as i64 * 300_000;
            serde_json::json!({"_id": object_id(t, n + i), "type": "sgv", "sgv": 100,
                "date": t, "dateString": common::server::iso(t), "device": "xDrip-DexcomG6"})
        })
        .collect();
    srv.with(|s| s.add("entries", new));
    let r = sync(&mut store, "ana", &sync_opts()).unwrap();
    assert!(
        r.collections[0].received < 3 * 288 + 10,
        "{:?}",
        r.collections[0]
    );
    assert_eq!(r.import.import.unwrap().added, 288);
    assert_eq!(cgm(&store).len(), n + 288);
}

#[test]
fn a_first_sync_failing_at_the_device_status_keeps_every_page_it_read() {
    // The entries and treatments are read whole, then the site errs
    // longer than the retries: all of it is kept (nothing imported), and
    // the next sync reads only what is new since, not the history again.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(2);
    // Six days of 5-minute entries, each ObjectId made at its time (as a
    // server inserting it as it comes makes it).
    let newest = d.entries[0]["date"].as_i64().unwrap();
    d.entries = (0..6 * 288)
        .map(|i| {
            let at = newest - i as i64 * 300_000;
            serde_json::json!({"_id": object_id(at, i), "type": "sgv", "sgv": 80 + (i * 13) % 120,
                "date": at, "dateString": common::server::iso(at), "device": "xDrip-DexcomG6"})
        })
        .collect();
    let files = export(dir.path(), &d);
    let srv = Server::start(site_of(&d, 100));
    let entries_read = || srv.with(|s| s.log.iter().filter(|l| l.contains("entries")).count());
    let mut clean = linked(dir.path(), "clean.db", &files, &srv.url);
    srv.with(|s| s.log.clear());
    sync(&mut clean, "ana", &sync_opts()).unwrap();
    let clean_reads = entries_read();
    let mut store = linked(dir.path(), "sync.db", &files, &srv.url);
    srv.with(|s| {
        s.faults = vec![Fault {
            path: "devicestatus".into(),
            kind: FaultKind::Status(500),
            times: 4,
        }];
        s.log.clear();
    });
    let e = sync(&mut store, "ana", &sync_opts()).unwrap_err();
    assert!(matches!(e, NsError::Resumable { .. }), "{e}");
    assert!(store.records("ana").unwrap().is_empty());
    let staged = store.staged("ana").unwrap();
    let kept = |c: &str| {
        let (_, docs) = staged.iter().find(|(x, _)| x == c).unwrap();
        serde_json::from_slice::<Vec<serde_json::Value>>(docs)
            .unwrap()
            .len()
    };
    assert_eq!(kept("entries"), d.entries.len());
    assert_eq!(kept("treatments"), d.treatments.len());
    srv.with(|s| s.log.clear());
    sync(&mut store, "ana", &sync_opts()).unwrap();
    let resumed_reads = entries_read();
    assert!(
        resumed_reads * 3 < clean_reads,
        "{resumed_reads} reads resumed, {clean_reads} in a clean sync"
    );
    assert_same_records(&store, &clean);
    assert!(store.staged("ana").unwrap().is_empty());
}
