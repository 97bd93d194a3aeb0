//! What paging by time cannot reach, read by `_id` (see `src/by_id.rs`):
//! more treatments at one `created_at` than the server serves in a page,
//! and treatments without `created_at` (API v3 inserts with
//! `API3_CREATED_AT_FALLBACK_ENABLED=false`: `date` in ms and
//! `utcOffset`), on a v1-only and on a v3 site, with ObjectId and string
//! (Loop UUID) `_id`s mixed; a server that does not sort by `_id` is
//! reported, not trusted.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::{link, sync};
use common::server::Server;
use common::*;
use serde_json::{json, Value};

fn ms_of(text: &str) -> i64 {
    text.parse::<jiff::Timestamp>().unwrap().as_millisecond()
}

/// The data set with every third treatment as API v3 stores it with the
/// `created_at` fallback off: `date` (ms) and `utcOffset`, an
/// `identifier`, `srvModified` / `srvCreated`, no `created_at`; its `_id`
/// an ObjectId made a minute after its time, or (one in two of them) a
/// UUID string. Returns how many lack `created_at`.
fn without_created_at(d: &mut Data) -> usize {
    let mut n = 0;
    for (i, t) in d.treatments.iter_mut().enumerate() {
        if i % 3 != 1 {
            continue;
        }
        let at = ms_of(t["created_at"].as_str().unwrap());
        let o = t.as_object_mut().unwrap();
        o.remove("created_at");
        o.insert("date".into(), json!(at));
        o.insert("utcOffset".into(), json!(60));
        o.insert("identifier".into(), json!(uuid(0x10_0000 + i)));
        o.insert("srvCreated".into(), json!(at + 60_000));
        o.insert("srvModified".into(), json!(at + 60_000));
        let id = if n % 2 == 0 {
            object_id(at + 60_000, i)
        } else {
            uuid(0x20_0000 + i)
        };
        o.insert("_id".into(), json!(id));
        n += 1;
    }
    n
}

#[test]
fn more_treatments_at_one_created_at_than_a_page_holds_all_arrive() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let at = d.treatments[3]["created_at"].as_str().unwrap().to_string();
    d.treatments.extend(one_instant(2500, &at));
    let files = export(dir.path(), &d);
    // The server serves at most 1,000 a page.
    let srv = Server::start(site_of(&d, 1000));
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.collections[1].documents, d.treatments.len(), "{r:?}");
    let log = srv.with(|s| s.log.clone());
    assert!(
        log.iter()
            .any(|l| l.contains("sort%5B_id%5D=1") || l.contains("sort[_id]=1")),
        "the key was read by _id: {log:?}"
    );
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    // Again (the key is in the window read again): nothing new.
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
    assert!(
        again.collections[1].documents > 2500,
        "{:?}",
        again.collections[1]
    );
    assert_same_records(&synced, &imported);
}

#[test]
fn a_server_that_does_not_sort_by_id_is_read_by_ranges_of_id() {
    // 2,500 treatments at one `created_at` (UUIDs and ObjectIds), a server
    // serving at most 1,000 a page and ignoring `sort[_id]`: the pages by
    // `_id` come out of order, so the key is read by ranges of `_id`
    // instead, and everything arrives.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let at = d.treatments[3]["created_at"].as_str().unwrap().to_string();
    d.treatments.extend(one_instant(2500, &at));
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 1000);
    site.ignores_sort = true;
    let srv = Server::start(site);
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.collections[1].documents, d.treatments.len(), "{r:?}");
    let log = srv.with(|s| s.log.clone());
    assert!(
        log.iter()
            .any(|l| l.contains("find%5B_id%5D%5B%24lt%5D") || l.contains("find[_id][$lt]")),
        "the key was read by ranges of _id: {log:?}"
    );
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    assert_eq!(advice(&mut synced), advice(&mut imported));
    // Again: nothing new, nothing lost.
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
    assert_same_records(&synced, &imported);
}

#[test]
fn a_server_that_cannot_be_paged_by_id_fails_the_sync_and_imports_nothing() {
    // The same, on a server that also ignores the bounds on `_id`: what it
    // serves cannot be proven to be all, so the sync fails naming the key,
    // and nothing of it is imported (no advice on a day that may lack
    // records); the store and its marks stay as they were.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    let at = d.treatments[3]["created_at"].as_str().unwrap().to_string();
    d.treatments.extend(one_instant(2500, &at));
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 1000);
    site.ignores_sort = true;
    site.ignores_id_bounds = true;
    let srv = Server::start(site);
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let e = sync(&mut synced, "ana", &sync_opts()).unwrap_err();
    assert!(
        matches!(e, abba_nightscout::NsError::Incomplete { .. }),
        "{e}"
    );
    let text = e.to_string();
    assert!(
        text.contains(&at) && text.contains("find[_id]") && text.contains("imported nothing"),
        "{text}"
    );
    assert!(synced.records("ana").unwrap().is_empty());
    assert!(synced.link_marks("ana").unwrap().is_empty());
    let link = synced.link("ana").unwrap().unwrap();
    assert!(
        link.view()
            .last_error
            .is_some_and(|l| l.contains("cannot prove")),
        "the failure is on the link"
    );
}

#[test]
fn a_server_that_does_not_sort_by_time_is_read_by_id() {
    // Treatments stored out of time order on a server that sorts nothing
    // (neither by `created_at` nor by `_id`) and serves 5 a page: pages by
    // time would skip what the server did not put first; the sync sees the
    // disorder and reads the window by ranges of `_id`, which need no
    // order. Everything arrives, once.
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(2);
    let n = d.treatments.len();
    let mut shuffled: Vec<(usize, serde_json::Value)> = d
        .treatments
        .drain(..)
        .enumerate()
        .map(|(i, t)| ((i * 7919) % n, t))
        .collect();
    shuffled.sort_by_key(|(k, _)| *k);
    d.treatments = shuffled.into_iter().map(|(_, t)| t).collect();
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 5);
    site.unsorted = true;
    let srv = Server::start(site);
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.collections[1].documents, n, "{r:?}");
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    assert_eq!(advice(&mut synced), advice(&mut imported));
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
}

/// A site holding treatments without `created_at`: one sync equals a
/// file import of the same documents, a second adds nothing, new ones
/// (ObjectId and UUID) come in; on a v3 site one deleted through v3 goes.
fn treatments_without_created_at(v3: bool) {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(2);
    let undated = without_created_at(&mut d);
    assert!(undated >= 6);
    let files = export(dir.path(), &d);
    let mut site = site_of(&d, 5);
    site.v3 = v3;
    let srv = Server::start(site);
    let (_, mut synced) = store_with_person(dir.path(), "sync.db", &files);
    let cred = if v3 { reader() } else { secret() };
    link(&mut synced, "ana", &srv.url, cred, false, &fast_client()).unwrap();
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.v3, v3);
    assert_eq!(r.collections[1].documents, d.treatments.len(), "{r:?}");
    assert_eq!(r.collections[1].without_created_at, undated);
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    assert_eq!(advice(&mut synced), advice(&mut imported));

    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty(), "{:?}", again.gone);
    // Only what was inserted since the window read again is asked for.
    assert!(
        again.collections[1].without_created_at < undated,
        "{:?}",
        again.collections[1]
    );

    // New ones, as v3 would insert them: an ObjectId made now-ish, and a
    // UUID `_id` (a string, outside any ObjectId bound).
    let newest = d
        .treatments
        .iter()
        .filter_map(|t| {
            t.get("date")
                .and_then(Value::as_i64)
                .or_else(|| t.get("created_at")?.as_str().map(ms_of))
        })
        .max()
        .unwrap();
    let new: Vec<Value> = [(1, object_id(newest + 3_660_000, 1)), (2, uuid(0x30_0000))]
        .into_iter()
        .map(|(h, id)| {
            let at = newest + h * 3_600_000;
            json!({"_id": id, "eventType": "Correction Bolus", "insulin": 0.5 + h as f64 / 10.0,
                "date": at, "utcOffset": 60, "enteredBy": "AndroidAPS",
                "identifier": uuid(0x40_0000 + h as usize),
                "srvCreated": at + 60_000, "srvModified": at + 60_000})
        })
        .collect();
    srv.with(|s| s.add("treatments", new.clone()));
    d.treatments.extend(new);
    let files = export(dir.path(), &d);
    let third = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(third.import.import.unwrap().added, 2);
    let (_, mut imported) = store_with_person(dir.path(), "files2.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);

    if v3 {
        // The two oldest with an ObjectId (outside what v1 is asked again,
        // by time or by `_id`): only v3's history says they changed.
        let mut old: Vec<Value> = d
            .treatments
            .iter()
            .filter(|t| {
                t.get("created_at").is_none()
                    && t.get("insulin").is_some_and(Value::is_number)
                    && abba_nightscout::fetch::is_object_id(t["_id"].as_str().unwrap())
            })
            .cloned()
            .collect();
        old.sort_by_key(|t| t["date"].as_i64().unwrap());
        assert!(old.len() >= 2, "{old:?}");
        // One changed through v3 (its dose): the store holds the new
        // version, as a file import of the changed documents does.
        let (changed, gone) = (&old[0], &old[1]);
        let identifier = changed["identifier"].as_str().unwrap().to_string();
        let dose = changed["insulin"].as_f64().unwrap() + 0.25;
        srv.with(|s| s.change("treatments", &identifier, |t| t["insulin"] = json!(dose)));
        for t in d.treatments.iter_mut() {
            if t["identifier"] == changed["identifier"] {
                t["insulin"] = json!(dose);
            }
        }
        let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
        assert_eq!(r.import.import.unwrap().updated, 1);
        let files = export(dir.path(), &d);
        let (_, mut imported) = store_with_person(dir.path(), "files3.db", &files);
        imported.import_files("ana", &files, None).unwrap();
        assert_same_records(&synced, &imported);
        // One deleted through v3 (by its identifier): v1
        // (`find[identifier]`, no date bound) gives the `_id` its records
        // are keyed by. Its records go.
        let kinds = store_kinds(&synced, gone["_id"].as_str().unwrap());
        assert!(kinds > 0);
        let identifier = gone["identifier"].as_str().unwrap().to_string();
        srv.with(|s| s.soft_delete("treatments", &identifier));
        let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
        assert_eq!(r.import.deleted, kinds, "{r:?}");
        assert_eq!(store_kinds(&synced, gone["_id"].as_str().unwrap()), 0);
    }
}

/// How many records the store holds of document `id`.
fn store_kinds(store: &abba_store::Store, id: &str) -> usize {
    store
        .records("ana")
        .unwrap()
        .iter()
        .filter(|r| format!("{:?}", r.id).contains(id))
        .count()
}

#[test]
fn treatments_without_created_at_on_a_v1_only_site_sync_as_files_import() {
    treatments_without_created_at(false);
}

#[test]
fn treatments_without_created_at_on_a_v3_site_sync_as_files_import() {
    treatments_without_created_at(true);
}

#[test]
fn more_entries_at_one_date_than_a_page_holds_all_arrive() {
    let dir = tempfile::tempdir().unwrap();
    let mut d = data(1);
    // 1,200 readings at one millisecond (written to MongoDB directly by
    // many uploaders: Nightscout's own insert would merge them by
    // sysTime and type), ObjectIds and UUIDs, on a server serving 500.
    let t = d.entries[40]["date"].as_i64().unwrap() + 1;
    let n = 1200;
    let mut tie: Vec<(usize, Value)> = (0..n)
        .map(|i| {
            let id = if i % 2 == 0 {
                object_id(t + 1000, i)
            } else {
                uuid(0x50_0000 + i)
            };
            let e = json!({"_id": id, "type": "mbg", "mbg": 70 + (i % 120), "date": t,
                "dateString": common::server::iso(t), "device": format!("meter-{i}")});
            ((i * 7919) % n, e)
        })
        .collect();
    tie.sort_by_key(|(k, _)| *k);
    d.entries.extend(tie.into_iter().map(|(_, e)| e));
    d.entries
        .sort_by_key(|e| std::cmp::Reverse(e["date"].as_i64().unwrap()));
    let files = export(dir.path(), &d);
    let srv = Server::start(site_of(&d, 500));
    let mut synced = linked(dir.path(), "sync.db", &files, &srv.url);
    let r = sync(&mut synced, "ana", &sync_opts()).unwrap();
    assert_eq!(r.collections[0].documents, d.entries.len(), "{r:?}");
    let (_, mut imported) = store_with_person(dir.path(), "files.db", &files);
    imported.import_files("ana", &files, None).unwrap();
    assert_same_records(&synced, &imported);
    let again = sync(&mut synced, "ana", &sync_opts()).unwrap();
    let a = again.import.import.unwrap();
    assert_eq!((a.added, a.updated), (0, 0), "{a:?}");
    assert!(again.gone.is_empty());
}

#[test]
fn the_test_server_types_and_compares_as_nightscout_and_mongodb_do() {
    use common::mongo::{sort, sort_of, Find};
    let q = |pairs: &[(&str, &str)]| -> Vec<(String, String)> {
        pairs
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let oid = "602d22d89e9fc2456f934373";
    let docs = [
        json!({"_id": oid, "created_at": "2026-01-14T21:54:00Z"}),
        json!({"_id": uuid(1), "date": 1_768_427_640_000_i64}),
        json!({"_id": "602d22d89e9fc2456f934374", "date": 1_768_427_640_000_i64}),
    ];
    let ids = |pairs: &[(&str, &str)]| -> Vec<String> {
        let f = Find::parse("treatments", &q(pairs)).unwrap();
        docs.iter()
            .filter(|d| f.matches(d).unwrap())
            .map(|d| d["_id"].as_str().unwrap().to_string())
            .collect()
    };
    // `$gt` an ObjectId never matches a string `_id`; `$ne` matches all.
    assert_eq!(
        ids(&[("find[_id][$gt]", "000000000000000000000000")]),
        [oid, "602d22d89e9fc2456f934374"]
    );
    assert_eq!(
        ids(&[("find[_id][$ne]", "000000000000000000000000")]).len(),
        3
    );
    assert_eq!(ids(&[("find[_id][$type]", "string")]), [uuid(1)]);
    // "missing or not a string", valid only beside `_id`.
    let undated = [
        ("find[_id][$ne]", "000000000000000000000000"),
        ("find[created_at][$not][$type]", "string"),
    ];
    assert_eq!(ids(&undated).len(), 2);
    assert!(Find::parse("treatments", &q(&undated[1..])).is_err());
    // Without `_id` a bound is rewritten to toISOString() form (which
    // sorts below the stored `...:00Z`); with it, compared as given.
    let b = "2026-01-14T21:54:00Z";
    assert!(ids(&[("find[created_at][$lte]", b)]).is_empty());
    assert_eq!(
        ids(&[
            ("find[created_at][$lte]", b),
            ("find[_id][$type]", "objectId")
        ]),
        [oid]
    );
    // `sort[_id]=1`: strings before ObjectIds.
    let mut sorted = docs.to_vec();
    sort(
        &mut sorted,
        &sort_of(&q(&[("sort[_id]", "1")]), ("created_at", -1)).unwrap(),
    );
    assert_eq!(sorted[0]["_id"], json!(uuid(1)));
    assert!(sort_of(&q(&[("sort[_id]", "up")]), ("created_at", -1)).is_err());
}
