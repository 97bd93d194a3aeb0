//! App events (the service's log): a person is fed by imports or by the
//! app, not both; repeats and conflicts by payload hash; events before day
//! 1 refused; the live state equals a rebuild; tokens stored as given
//! hashes and revocable.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

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

/// The decisions of one advisor fed `evs` in process, with each change of
/// therapy (minute, basal, carb ratios) put in force before the first event
/// at or after its minute.
fn in_process(
    p: &abba_store::Person,
    evs: &[abba_core::Event],
    changes: &[(abba_core::Timestamp, Option<f64>, [f64; 3])],
) -> Vec<(i64, abba_advisor::Parameter, f64, f64)> {
    use abba_advisor::Advisor;
    let mut a = p.advisor().unwrap();
    let mut next = 0;
    let mut out = Vec::new();
    for e in evs {
        while let Some(c) = changes.get(next).filter(|c| c.0 <= e.at) {
            let mut s = *a.settings();
            if let Some(b) = c.1 {
                s.basal = abba_core::UnitsPerHour(b);
            }
            s.carb_ratio = c.2.map(abba_core::GramsPerUnit);
            a.set_therapy(None, s).unwrap();
            next += 1;
        }
        a.observe(e).unwrap();
        out.extend(
            a.take_decisions()
                .into_iter()
                .map(|d| (d.at.0, d.parameter, d.old, d.new)),
        );
    }
    out.sort_by_key(|d| (d.0, abba_store::answer::param_key(d.1)));
    out
}

#[test]
fn a_clinicians_change_reaches_an_app_fed_persons_advisor_at_its_time() {
    use abba_core::{Event, Timestamp};
    let dir = TempDir::new("app-therapy");
    let mut store = dir.store();
    let p = store.create_person(&person("ana")).unwrap();
    let mut evs = events(10);
    for d in 1..10 {
        evs.push(Event::new(
            Timestamp::from_day_and_minute(d, 0),
            EventKind::DayClosed,
        ));
    }
    evs.sort_by_key(|e| e.at);
    let batch = app_batch(1, &evs);
    let cut = evs
        .iter()
        .position(|e| e.at >= Timestamp::from_day_and_minute(8, 300))
        .unwrap();
    let mut live = store.live(p.id).unwrap();
    store.post_events(&mut live, &batch[..cut]).unwrap();
    // `abba therapy set` while the service holds its live advisor: in force
    // from day 9, 06:00, after the last event the app has posted.
    let at1 = Timestamp::from_day_and_minute(8, 360);
    let c = store
        .set_therapy(
            "ana",
            Some(vec![(0, 1.1)]),
            Some([9.0, 13.0, 10.5]),
            Some(clock().instant(at1).unwrap()),
        )
        .unwrap();
    assert_eq!(c.at, at1);
    // The service notices the write; the next batch starts before the
    // change, so the advisor is rebuilt with the change at its time.
    let posted = store.post_events(&mut live, &batch[cut..]).unwrap();
    assert!(posted.rebuilt);
    let changes = vec![(at1, Some(1.1), [9.0, 13.0, 10.5])];
    let got: Vec<(i64, abba_advisor::Parameter, f64, f64)> = store
        .decisions("ana")
        .unwrap()
        .iter()
        .map(|d| (d.at.0, d.parameter, d.old, d.new))
        .collect();
    let want = in_process(&p, &evs, &changes);
    assert_eq!(got, want);
    // Day 9's lunch update starts from the clinician's value.
    let lunch = got
        .iter()
        .find(|d| d.0 == Timestamp::from_day_and_minute(8, 737).0)
        .expect("a lunch decision on day 9");
    assert_eq!(lunch.2, 13.0, "{lunch:?}");
    assert_eq!(live.advisor, store.rebuild("ana").unwrap());
    // A change earlier than the last event (day 9, 20:00) rebuilds: the
    // live state, the store's decisions and the advice all show it.
    let at2 = Timestamp::from_day_and_minute(8, 1200);
    let (_, live2) = store
        .set_therapy_by_id(
            p.id,
            None,
            Some([9.5, 12.5, 10.0]),
            Some(clock().instant(at2).unwrap()),
            "a test",
        )
        .unwrap();
    let mut changes = changes;
    changes.push((at2, None, [9.5, 12.5, 10.0]));
    let want = in_process(&p, &evs, &changes);
    let got: Vec<(i64, abba_advisor::Parameter, f64, f64)> = live2
        .decisions
        .iter()
        .map(|d| (d.at.0, d.parameter, d.old, d.new))
        .collect();
    assert_eq!(got, want);
    let lunch = got
        .iter()
        .find(|d| d.0 == Timestamp::from_day_and_minute(9, 737).0)
        .expect("a lunch decision on day 10");
    assert_eq!(lunch.2, 12.5, "{lunch:?}");
    let advice = store.advise("ana").unwrap();
    assert!(
        advice
            .therapy
            .changes
            .iter()
            .any(|c| c.contains("9.5/12.5/10")),
        "{:?}",
        advice.therapy.changes
    );
    // The app's view stays the app's: no first week or delivery from records.
    assert!(advice.first_week.is_none());
    assert_eq!(live2.advisor, store.rebuild("ana").unwrap());
}

/// Two live states of one person agree in everything the service reads.
fn assert_same_live(got: &abba_store::Live, fresh: &abba_store::Live, what: &str) {
    assert_eq!(got.stream.events, fresh.stream.events, "{what}: events");
    assert_eq!(got.stream.counts, fresh.stream.counts, "{what}: counts");
    assert_eq!(got.records, fresh.records, "{what}: records");
    assert_eq!(got.advisor, fresh.advisor, "{what}: advisor");
    assert_eq!(got.decisions, fresh.decisions, "{what}: decisions");
    assert_eq!(got.refused, fresh.refused, "{what}: refused");
    assert_eq!(got.rev, fresh.rev, "{what}: revision");
}

#[test]
fn a_cached_log_takes_only_the_events_another_connection_stored_after_it() {
    use abba_core::{Event, MgDl, Timestamp};
    let dir = TempDir::new("app-tail");
    // Two connections, as two replicas of the service (or two pooled
    // connections of one) hold them, each with its own cached logs.
    let (mut a, mut b) = (dir.store(), dir.store());
    let mut np = person("ana");
    np.first_day = Some("2026-05-04".parse().unwrap());
    let p = a.create_person(&np).unwrap();
    let evs = events(8);
    let batch = app_batch(1, &evs);
    let day = |d| {
        evs.iter()
            .position(|e| e.at >= Timestamp::from_day_and_minute(d, 0))
            .unwrap()
    };
    let post = |s: &mut abba_store::store::Store, events: &[NewAppEvent]| {
        let mut live = s.live(p.id).unwrap();
        s.post_events(&mut live, events).unwrap();
    };
    post(&mut a, &batch[..day(3)]);
    a.live(p.id).unwrap();
    let start = a.stream_loads();

    // Days 3-4 stored by the other connection: A reads only those.
    post(&mut b, &batch[day(3)..day(5)]);
    let grown = a.live(p.id).unwrap();
    let loads = a.stream_loads();
    assert_eq!((loads.whole, loads.tail), (start.whole, start.tail + 1));
    assert_same_live(&grown, &dir.store().live(p.id).unwrap(), "after days 3-4");
    // The same in a read transaction (nothing written).
    post(&mut b, &batch[day(5)..day(6)]);
    let read = a.live_read(p.id).unwrap();
    assert_eq!(a.stream_loads().tail, start.tail + 2);
    assert_same_live(&read, &dir.store().live_read(p.id).unwrap(), "read");

    // A late reading, dated before the cached log's last event: not a
    // tail, so A reads the whole log again.
    let late = Event::new(
        Timestamp::from_day_and_minute(4, 2),
        EventKind::Cgm(MgDl(101.0)),
    );
    post(&mut b, &app_batch(100_000, &[late]));
    let with_late = a.live(p.id).unwrap();
    let loads = a.stream_loads();
    assert_eq!((loads.whole, loads.tail), (start.whole + 1, start.tail + 2));
    assert_same_live(&with_late, &dir.store().live(p.id).unwrap(), "late");
    assert!(with_late.stream.events.contains(&late));

    // Then the rest, stored by B: a tail again, and the same advisor as
    // the whole log replayed from scratch.
    post(&mut b, &batch[day(6)..]);
    let last = a.live(p.id).unwrap();
    assert_eq!(a.stream_loads().tail, start.tail + 3);
    assert_same_live(&last, &dir.store().live(p.id).unwrap(), "the rest");
    assert_eq!(last.advisor, a.rebuild("ana").unwrap());
    assert_eq!(last.stream.events.len(), evs.len() + 1);
}

/// Two readings in one minute, as the service probe posted them (30 s
/// apart; a finger-stick checked again seconds later, a sensor's reading
/// from two uploaders), cannot be ordered, since the log keeps time to the
/// minute: the person report shows their mean and says so (before, the
/// report refused its own input and the service answered 500 on the
/// person's and the clinic's report pages).
#[test]
fn two_readings_in_one_minute_are_one_mean_in_the_person_report() {
    let dir = TempDir::new("same-minute");
    let mut store = dir.store();
    let mut np = person("ana");
    np.first_day = Some("2026-05-04".parse().unwrap());
    let p = store.create_person(&np).unwrap();
    let evs = events(3);
    let at = abba_core::Timestamp::from_day_and_minute(1, 600);
    let k = evs
        .iter()
        .position(|e| e.at == at && matches!(e.kind, EventKind::Cgm(_)))
        .unwrap();
    let EventKind::Cgm(first) = evs[k].kind else {
        unreachable!()
    };
    let mut batch = app_batch(1, &evs);
    let mut again = batch[k].clone();
    again.seq = batch.len() as u64 + 1;
    again.at += jiff::SignedDuration::from_secs(30);
    again.kind = EventKind::Cgm(abba_core::MgDl(first.0 + 10.0));
    again.hash[0] ^= 0xff;
    batch.push(again);
    let mut live = store.live(p.id).unwrap();
    store.post_events(&mut live, &batch).unwrap();
    let input = abba_store::report::person_input(&mut store, "ana", 14, abba_io::GlucoseUnit::MgDl)
        .unwrap();
    abba_report::html::person::person_report_html(&input).unwrap();
    let at_minute: Vec<f64> = input.days[1]
        .readings
        .iter()
        .filter(|r| r.minute_of_day == 600)
        .map(|r| r.mg_dl)
        .collect();
    assert_eq!(at_minute, vec![first.0 + 5.0]);
    assert!(
        input
            .notes
            .iter()
            .any(|n| n.starts_with("1 readings were taken in the same minute")),
        "{:?}",
        input.notes
    );
}
