//! What cannot be true is refused where it enters the store, record by
//! record, with its place: a record dated before 1990-01-01 (no sensor or
//! pump logged data then) never sets day 1 nor drives day closings; a day
//! 1 outside 1990-01-01..tomorrow is refused at creation; an override off
//! the pump's step is refused with the two nearest values on it, never
//! rounded; a CGM-mode app closes its days at local midnight only.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::{Parameter, PumpSteps};
use abba_core::EventKind;
use abba_store::app::NewAppEvent;
use abba_store::{AnswerRequest, StoreError};
use common::{clock, events, nightscout, person, read, TempDir};

/// The probe's file: one CGM reading at -99999999999999 ms (year -1199),
/// beside two true ones.
fn entries_with_an_absurd_date() -> Vec<(String, Vec<u8>)> {
    let body = r#"[
{"_id":"a0","sgv":120,"date":-99999999999999,"type":"sgv"},
{"_id":"a1","sgv":130,"date":1777888800000,"type":"sgv"},
{"_id":"a2","sgv":140,"date":1777889100000,"type":"sgv"}
]"#;
    vec![("entries.json".into(), body.as_bytes().to_vec())]
}

fn import_now() -> jiff::Timestamp {
    "2026-06-01T00:00:00Z".parse().unwrap()
}

#[test]
fn a_record_before_1990_is_refused_with_its_place_and_never_sets_day_1() {
    let dir = TempDir::new("too-old");
    let mut store = dir.store();
    // No day 1 yet: the import sets it from its first true reading.
    let mut np = person("ana");
    np.first_day = None;
    store.create_person(&np).unwrap();
    let batch = read(&entries_with_an_absurd_date()).unwrap();
    // The reader keeps it (simulated output starts at the epoch); the
    // store's rule takes it out, counted, with its place.
    assert_eq!(batch.records.len(), 3);
    let mut taken = batch.clone();
    let refused = taken.refuse_too_old().clone();
    assert_eq!((taken.records.len(), refused.count), (2, 1));
    assert_eq!(refused.first.as_deref(), Some("entries.json: $[0]"));
    let s = store.import_at("ana", &batch, import_now()).unwrap();
    assert_eq!(s.too_old.first.as_deref(), Some("entries.json: $[0]"));
    assert_eq!((s.added, s.too_old.count), (2, 1), "{s:?}");
    // 1777888800000 ms is 2026-05-04T10:00:00Z.
    assert_eq!(s.first_day.as_deref(), Some("2026-05-04"));
    let p = store.person("ana").unwrap();
    assert_eq!(p.first_day, Some("2026-05-04".parse().unwrap()));
    let lines = s.lines("ana").join("\n");
    assert!(
        lines.contains("1 record dated before 1990-01-01")
            && lines.contains("entries.json: $[0]")
            && lines.contains("expected a time from 1990-01-01T00:00:00Z on"),
        "{lines}"
    );
    // No day closing from the year -1199: the log holds two readings.
    let evs = store.events("ana").unwrap();
    assert!(evs.len() <= 3, "{evs:?}");
}

#[test]
fn a_batch_made_by_hand_is_checked_by_the_import_too() {
    // A batch not read by `read_all` (a program's own) still cannot carry
    // such a record in: the import applies the same rule.
    let dir = TempDir::new("too-old-hand");
    let mut store = dir.store();
    let mut np = person("ana");
    np.first_day = None;
    store.create_person(&np).unwrap();
    let mut batch = read(&entries_with_an_absurd_date()).unwrap();
    batch.refuse_too_old();
    let mut old = batch.records[0].clone();
    old.at = jiff::Timestamp::from_millisecond(-99_999_999_999_999).unwrap();
    old.id = abba_io::SourceId::Id("old".into());
    batch.records.insert(0, old);
    batch.too_old = Default::default();
    let s = store.import_at("ana", &batch, import_now()).unwrap();
    assert_eq!((s.added, s.too_old.count), (2, 1), "{s:?}");
    assert_eq!(s.first_day.as_deref(), Some("2026-05-04"));
}

#[test]
fn a_file_wholly_before_1990_is_an_error_and_imports_nothing() {
    let dir = TempDir::new("too-old-all");
    let mut store = dir.store();
    let mut np = person("ana");
    np.first_day = None;
    store.create_person(&np).unwrap();
    let body = br#"[{"sgv":120,"date":-99999999999999,"type":"sgv"}]"#;
    let batch = read(&[("e.json".into(), body.to_vec())]).unwrap();
    let e = store
        .import_at("ana", &batch, import_now())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("every record of e.json is dated before 1990-01-01")
            && e.contains("the first e.json: $[0]")
            && e.ends_with("Nothing was imported"),
        "{e}"
    );
    assert_eq!(store.person("ana").unwrap().first_day, None);
}

#[test]
fn nightscouts_profile_in_force_since_always_is_kept() {
    // The profile dated at the epoch is not "too old": it is in force
    // since always (the one exception).
    let dir = TempDir::new("since-always");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let mut files = nightscout(&events(1));
    let profile = br#"[{"_id":"p1","defaultProfile":"Default","startDate":"1970-01-01T00:00:00.000Z","mills":0,
       "store":{"Default":{"basal":[{"time":"00:00","value":0.8}],"timezone":"Europe/Zurich"}}}]"#;
    files.retain(|(n, _)| n != "profile.json");
    files.push(("profile.json".into(), profile.to_vec()));
    let mut batch = read(&files).unwrap();
    assert_eq!(batch.refuse_too_old().count, 0);
    assert!(batch
        .records
        .iter()
        .any(|r| r.at == abba_io::record::SINCE_ALWAYS));
}

#[test]
fn day_1_outside_1990_to_tomorrow_is_refused_at_creation() {
    let dir = TempDir::new("first-day");
    let mut store = dir.store();
    for (name, day) in [
        ("a", "9999-12-31"),
        ("b", "0001-01-01"),
        ("c", "1989-12-31"),
    ] {
        let mut np = person(name);
        np.first_day = Some(day.parse().unwrap());
        match store.create_person(&np) {
            Err(StoreError::Invalid { field, problem }) => {
                assert_eq!(field, "--first-day");
                assert!(
                    problem.contains("expected a date from 1990-01-01")
                        && problem.contains(&format!("got {day}")),
                    "{problem}"
                );
            }
            other => panic!("{day}: {other:?}"),
        }
    }
    let tz = jiff::tz::TimeZone::get("Europe/Zurich").unwrap();
    let today = tz.to_datetime(jiff::Timestamp::now()).date();
    for (name, day) in [
        ("d", "1990-01-01".parse().unwrap()),
        ("e", today),
        ("f", today.tomorrow().unwrap()),
    ] {
        let mut np = person(name);
        np.first_day = Some(day);
        store.create_person(&np).unwrap();
    }
    let mut np = person("g");
    np.first_day = Some(today.tomorrow().unwrap().tomorrow().unwrap());
    assert!(store.create_person(&np).is_err());
}

#[test]
fn an_override_must_be_on_the_pumps_step() {
    let dir = TempDir::new("step");
    let mut store = dir.store();
    let mut np = person("ana");
    np.settings.pump_steps = Some(PumpSteps::default());
    store.create_person(&np).unwrap();
    store
        .import_at(
            "ana",
            &read(&nightscout(&events(10))).unwrap(),
            import_now(),
        )
        .unwrap();
    let advice = store.advise("ana").unwrap();
    let open: Vec<String> = advice
        .settings
        .iter()
        .filter_map(|x| x.latest.as_ref().filter(|v| v.status == "open"))
        .map(|v| v.setting.to_string())
        .collect();
    let p = abba_store::answer::parse_param(open.iter().find(|s| *s != "basal").unwrap()).unwrap();
    assert!(matches!(p, Parameter::CarbRatio(_)));
    let e = store
        .answer("ana", &AnswerRequest::Set(vec![(p, 9.25)]))
        .unwrap_err();
    match e {
        StoreError::Invalid { field, problem } => {
            assert!(field.starts_with("--set "), "{field}");
            assert!(
                problem.contains("not on the pump's carb-ratio step (0.1 g/U)")
                    && problem.contains("9.2 and 9.3 g/U"),
                "{problem}"
            );
        }
        other => panic!("{other:?}"),
    }
    // The same for the basal rate (step 0.05).
    let e = store
        .answer(
            "ana",
            &AnswerRequest::Set(vec![(Parameter::Basal, 0.8883639681743214)]),
        )
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no open suggestion") || e.contains("0.85 and 0.9 U/h"),
        "{e}"
    );
    // On the step: stored as given.
    let a = store
        .answer("ana", &AnswerRequest::Set(vec![(p, 9.3)]))
        .unwrap();
    assert_eq!(a[0].in_force, 9.3);
}

fn app_event(seq: u64, at: &str, kind: EventKind) -> NewAppEvent {
    let mut hash = [0u8; 32];
    hash[..8].copy_from_slice(&seq.to_le_bytes());
    NewAppEvent {
        seq,
        at: at.parse().unwrap(),
        kind,
        hash,
    }
}

#[test]
fn a_cgm_apps_day_closes_at_local_midnight_only() {
    let dir = TempDir::new("cgm-close");
    let mut store = dir.store();
    let p = store.create_person(&person("ana")).unwrap();
    let c = clock();
    let evs = events(2);
    let mut batch: Vec<NewAppEvent> = evs[..100]
        .iter()
        .enumerate()
        .map(|(i, e)| NewAppEvent {
            seq: i as u64,
            at: c.instant(e.at).unwrap(),
            kind: e.kind,
            hash: [i as u8; 32],
        })
        .collect();
    let mut live = store.live(p.id).unwrap();
    store.post_events(&mut live, &batch).unwrap();
    // 2026-05-04 13:17 in Zurich: refused, saying how CGM days close.
    let e = store
        .post_events(
            &mut live,
            &[app_event(
                1000,
                "2026-05-04T13:17:00+02:00",
                EventKind::DayClosed,
            )],
        )
        .unwrap_err();
    match e {
        StoreError::Invalid { field, problem } => {
            assert_eq!(field, "events[0].at");
            assert!(
                problem.contains("closes at local midnight")
                    && problem.contains("2026-05-05T00:00 in Europe/Zurich")
                    && problem.contains("13:17 local"),
                "{problem}"
            );
        }
        other => panic!("{other:?}"),
    }
    // At local midnight: accepted.
    let mut live = store.live(p.id).unwrap();
    batch.clear();
    batch.push(app_event(
        1001,
        "2026-05-05T00:00:00+02:00",
        EventKind::DayClosed,
    ));
    store.post_events(&mut live, &batch).unwrap();
}

#[test]
fn an_app_event_before_1990_is_refused_and_sets_no_day_1() {
    let dir = TempDir::new("app-old");
    let mut store = dir.store();
    let mut np = person("ana");
    np.first_day = None;
    let p = store.create_person(&np).unwrap();
    let mut live = store.live(p.id).unwrap();
    let e = store
        .post_events(
            &mut live,
            &[
                app_event(
                    1,
                    "2026-05-04T10:00:00Z",
                    EventKind::Cgm(abba_core::MgDl(120.0)),
                ),
                app_event(
                    2,
                    "-001199-02-15T10:00:00Z",
                    EventKind::Cgm(abba_core::MgDl(120.0)),
                ),
            ],
        )
        .unwrap_err();
    match e {
        StoreError::Invalid { field, problem } => {
            assert_eq!(field, "events[1].at");
            assert!(problem.contains("dated before 1990-01-01"), "{problem}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(store.person("ana").unwrap().first_day, None);
}

/// An import of a loop's files says at once that abba suggests no basal
/// rate (before, only `advise` said so); an open-loop import says nothing
/// of the kind.
#[test]
fn an_import_of_a_closed_loops_files_says_abba_holds_the_basal() {
    let dir = TempDir::new("loop-import");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let data = |f: &str| {
        std::fs::read(format!(
            "{}/../io/tests/data/{f}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap()
    };
    let entries = br#"[{"_id":"e1","type":"sgv","sgv":131,"date":1778486400000},
                       {"_id":"e2","type":"sgv","sgv":135,"date":1778486700000}]"#;
    let import = |store: &mut abba_store::Store, files: Vec<(String, Vec<u8>)>| {
        store
            .import_contents_with(
                "ana",
                &files,
                None,
                abba_store::ProfileResolution::Stop,
                "2026-06-01T00:00:00Z".parse().unwrap(),
                true,
                &mut |_| Ok(()),
            )
            .unwrap()
    };
    let open = import(&mut store, vec![("entries.json".into(), entries.to_vec())]);
    assert_eq!(open.delivery, None);
    assert!(!open
        .lines("ana")
        .join("\n")
        .contains("open-loop pump therapy"));
    let s = import(
        &mut store,
        vec![(
            "devicestatus.json".into(),
            data("nightscout_devicestatus_synthetic.json"),
        )],
    );
    let lines = s.lines("ana").join("\n");
    assert!(
        lines.contains("These files show automated insulin delivery (a closed loop)")
            && lines.contains("abba suggests no basal rate for ana"),
        "{lines}"
    );
}

/// A zone is stored as tzdata spells it, and tzdata's "Factory" (a
/// machine whose zone is not set) is no person's zone.
#[test]
fn a_zone_is_stored_as_tzdata_spells_it_and_factory_is_refused() {
    let dir = TempDir::new("zones");
    let mut store = dir.store();
    let mut p = person("ana");
    p.tz = "europe/zurich".into();
    store.create_person(&p).unwrap();
    assert_eq!(
        store.person("ana").unwrap().tz.iana_name(),
        Some("Europe/Zurich")
    );
    let mut f = person("ben");
    f.tz = "Factory".into();
    let e = store.create_person(&f).unwrap_err().to_string();
    assert!(e.contains("Factory") && e.contains("--tz"), "{e}");
}
