//! App events (the service's log): a person is fed by imports or by the
//! app, not both; repeats and conflicts by payload hash; events before day
//! 1 refused; the live state equals a rebuild; tokens stored as given
//! hashes and revocable.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use abba_core::EventKind;
use abba_store::app::NewAppEvent;
use abba_store::token::Role;
use abba_store::StoreError;
use common::{clock, events, nightscout, person, read, TempDir};

fn app_batch(from_seq: u64, evs: &[abba_core::Event]) -> Vec<NewAppEvent> {
    let c = clock();
    evs.iter()
        .enumerate()
        .map(|(i, e)| {
            let mut hash = [0u8; 32];
            hash[..8].copy_from_slice(&(i as u64 + from_seq).to_le_bytes());
            hash[8..16].copy_from_slice(&e.at.0.to_le_bytes());
            NewAppEvent {
                seq: from_seq + i as u64,
                at: c.instant(e.at).unwrap(),
                kind: e.kind,
                hash,
            }
        })
        .collect()
}

#[test]
fn imports_and_app_events_do_not_mix() {
    let dir = TempDir::new("mix");
    let mut store = dir.store();
    let mut np = person("imp");
    np.first_day = Some("2026-05-04".parse().unwrap());
    store.create_person(&np).unwrap();
    let mut np2 = person("app");
    np2.first_day = Some("2026-05-04".parse().unwrap());
    let app = store.create_person(&np2).unwrap();
    let evs = events(2);
    store
        .import("imp", &read(&nightscout(&evs)).unwrap())
        .unwrap();
    let imp = store.person("imp").unwrap();
    let mut live = store.live(imp.id).unwrap();
    let err = store
        .post_events(&mut live, &app_batch(1, &evs[..5]))
        .unwrap_err();
    assert!(matches!(err, StoreError::Feed(_)), "{err}");
    let mut live = store.live(app.id).unwrap();
    store
        .post_events(&mut live, &app_batch(1, &evs[..5]))
        .unwrap();
    let err = store
        .import("app", &read(&nightscout(&evs)).unwrap())
        .unwrap_err();
    assert!(matches!(err, StoreError::Feed(_)), "{err}");
}

#[test]
fn repeats_conflicts_day_one_and_the_live_state() {
    let dir = TempDir::new("app");
    let mut store = dir.store();
    let mut np = person("ana");
    np.first_day = Some("2026-05-04".parse().unwrap());
    let p = store.create_person(&np).unwrap();
    let evs = events(10);
    let mut live = store.live(p.id).unwrap();
    let batch = app_batch(1, &evs);
    let posted = store.post_events(&mut live, &batch[..1000]).unwrap();
    assert_eq!(posted.stored.len(), 1000);
    assert!(!posted.rebuilt);
    let again = store.post_events(&mut live, &batch[990..1010]).unwrap();
    assert_eq!(again.repeated.len(), 10);
    assert_eq!(again.stored.len(), 10);
    let mut other = batch[5].clone();
    other.hash[31] ^= 1;
    let err = store.post_events(&mut live, &[other]).unwrap_err();
    assert!(
        matches!(err, StoreError::SeqConflict { seq: 6, .. }),
        "{err}"
    );
    // The caller drops `live` after an error.
    let mut live = store.live(p.id).unwrap();
    let mut early = batch[1010].clone();
    early.seq = 99_999;
    early.at = "2026-05-03T12:00:00Z".parse().unwrap();
    let err = store.post_events(&mut live, &[early]).unwrap_err();
    assert!(matches!(err, StoreError::Invalid { .. }), "{err}");
    let mut live = store.live(p.id).unwrap();
    store.post_events(&mut live, &batch[1010..]).unwrap();
    // Events as posted (no day closes invented): the CLI's events are the
    // posted ones, in order.
    assert_eq!(store.events("ana").unwrap(), evs);
    assert!(!evs.iter().any(|e| e.kind == EventKind::DayClosed));
    // The live advisor is what a rebuild from scratch gives.
    let rebuilt = store.rebuild("ana").unwrap();
    assert_eq!(live.advisor, rebuilt);
    assert_eq!(live.stream.events, evs);
}

#[test]
fn tokens_are_found_by_hash_and_revoked() {
    let dir = TempDir::new("tokens");
    let mut store = dir.store();
    let p = store.create_person(&person("ana")).unwrap();
    let h1 = [7u8; 32];
    let mut h2 = [7u8; 32];
    h2[31] = 8; // same 8-byte prefix, another hash
    let a = store.insert_token(&h1, Role::Admin).unwrap();
    let b = store.insert_token(&h2, Role::Person(p.id)).unwrap();
    let found = store.token_candidates(&h1).unwrap();
    assert_eq!(
        found.len(),
        2,
        "both share the prefix; the caller compares whole hashes"
    );
    assert!(found
        .iter()
        .any(|t| t.id == a && t.role == Role::Admin && !t.revoked));
    store.revoke_token(b).unwrap();
    store.revoke_token(b).unwrap();
    let t = store
        .token_candidates(&h2)
        .unwrap()
        .into_iter()
        .find(|t| t.id == b)
        .unwrap();
    assert!(t.revoked);
    assert_eq!(t.role, Role::Person(p.id));
    assert!(matches!(
        store.revoke_token(999),
        Err(StoreError::NoToken(999))
    ));
    assert!(matches!(
        store.insert_token(&[1u8; 32], Role::Person(999)),
        Err(StoreError::NoPersonId(999))
    ));
}
