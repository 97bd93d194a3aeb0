//! `abba serve --sync-every`'s rounds: a failed sync is recorded on the
//! link (when, why, how many in a row: what `abba link --list` and the API
//! show) and the person backs off; a later success clears it.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_nightscout::background::{round, run_with, Background, Unrecorded};
use abba_nightscout::link;
use abba_nightscout::site::credential;
use common::server::{Fault, FaultKind};
use common::*;
use std::time::Duration;

#[test]
fn a_failed_round_is_recorded_and_the_person_backs_off() {
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let srv = server(&d, 1000);
    let (db, mut store) = store_with_person(dir.path(), "bg.db", &files);
    let secret = credential(None, Some(SECRET)).unwrap();
    link(&mut store, "ana", &srv.url, secret, false, &fast_client()).unwrap();
    drop(store);
    // The site fails every read of entries: no sync ever happened.
    srv.with(|s| {
        s.faults = vec![Fault {
            path: "entries".into(),
            kind: FaultKind::Status(500),
            times: 1000,
        }]
    });
    let bg = Background {
        every: Duration::from_secs(60),
        concurrency: 2,
        sync: sync_opts(),
    };
    let mem = Unrecorded::default();
    assert_eq!(round(&db, &bg, &mem).unwrap(), 1);
    let l = abba_store::Store::open(&db)
        .unwrap()
        .link("ana")
        .unwrap()
        .unwrap();
    assert!(l.last_sync_at.is_some(), "{l:?}");
    assert!(l.last_success_at.is_none(), "{l:?}");
    assert_eq!(l.failures, 1);
    assert!(
        l.last_error.as_deref().unwrap().contains("HTTP 500"),
        "{l:?}"
    );
    // Backed off: not tried again at the next round.
    assert_eq!(round(&db, &bg, &mem).unwrap(), 0);
    // The list shows the attempt and its error, no credential.
    let view = l.view();
    let shown = serde_json::to_string(&view).unwrap();
    assert!(shown.contains("HTTP 500") && !shown.contains(l.credential.secret()));
}

#[test]
fn a_stalled_site_holds_its_own_slot_only() {
    // Three persons, two slots; the first person's site answers every
    // read slowly. The others are synced while it is still in flight: the
    // second beside it, the third as soon as the second's slot is free.
    let dir = tempfile::tempdir().unwrap();
    let d = data(1);
    let files = export(dir.path(), &d);
    let slow = server(&d, 1000);
    slow.with(|s| s.page_delay = Duration::from_millis(600));
    let quick = server(&d, 1000);
    let (db, mut store) = store_with_person(dir.path(), "bg.db", &files);
    for name in ["ben", "cy"] {
        let mut p = person(&files);
        p.name = name.to_string();
        store.create_person(&p).unwrap();
    }
    let secret = credential(None, Some(SECRET)).unwrap();
    for (name, srv) in [("ana", &slow), ("ben", &quick), ("cy", &quick)] {
        link(
            &mut store,
            name,
            &srv.url,
            secret.clone(),
            false,
            &fast_client(),
        )
        .unwrap();
    }
    drop(store);
    let bg = Background {
        every: Duration::from_secs(600),
        concurrency: 2,
        sync: sync_opts(),
    };
    let stop = std::sync::atomic::AtomicBool::new(false);
    let synced = |name: &str| {
        abba_store::Store::open(&db)
            .unwrap()
            .link(name)
            .unwrap()
            .unwrap()
            .last_success_at
            .is_some()
    };
    let (quick_first, slow_after) = std::thread::scope(|s| {
        s.spawn(|| run_with(&db, &bg, &stop, &|_| {}));
        let t0 = std::time::Instant::now();
        while !(synced("ben") && synced("cy")) && t0.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(100));
        }
        let quick_first = synced("ben") && synced("cy") && !synced("ana");
        // It ends, and is recorded.
        while !synced("ana") && t0.elapsed() < Duration::from_secs(120) {
            std::thread::sleep(Duration::from_millis(100));
        }
        let slow_after = synced("ana");
        stop.store(true, std::sync::atomic::Ordering::Relaxed);
        (quick_first, slow_after)
    });
    assert!(
        quick_first,
        "the quick persons were synced while the slow site's sync was in flight"
    );
    assert!(slow_after, "the slow site's sync ended and was recorded");
}
