//! The log: idempotent imports, overlapping exports (property test), many
//! persons per file, hostile input (never a panic, never a partial import,
//! errors naming file, line or path and field), the snapshot as a shortcut.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_store::{AnswerRequest, StoreError};
use common::{events, nightscout, person, read, TempDir};
use proptest::prelude::*;

#[test]
fn importing_twice_adds_nothing_and_says_so() {
    let dir = TempDir::new("twice");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let batch = read(&nightscout(&events(3))).unwrap();
    let first = store.import("ana", &batch).unwrap();
    assert!(first.added > 800 && first.known == 0, "{first:?}");
    let again = store.import("ana", &batch).unwrap();
    assert_eq!(
        (again.added, again.known, again.import_id),
        (0, first.added, None)
    );
    assert_eq!(dir.rows("import"), 1, "a no-op import leaves no import row");
}

#[test]
fn one_file_holds_many_persons() {
    let dir = TempDir::new("many");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    store.create_person(&person("ben")).unwrap();
    assert!(matches!(
        store.create_person(&person("ben")),
        Err(StoreError::PersonExists(_))
    ));
    store
        .import("ana", &read(&nightscout(&events(2))).unwrap())
        .unwrap();
    store
        .import("ben", &read(&nightscout(&events(3))).unwrap())
        .unwrap();
    assert!(store.records("ana").unwrap().len() < store.records("ben").unwrap().len());
    assert_eq!(
        store.persons().unwrap(),
        vec!["ana".to_string(), "ben".to_string()]
    );
    assert!(matches!(store.advise("cleo"), Err(StoreError::NoPerson(_))));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// Any sequence of imports of overlapping slices of one export gives
    /// the log one import of the whole gives.
    #[test]
    fn overlapping_slices_give_the_whole_log(
        cuts in prop::collection::vec(0usize..2000, 1..6),
        overlap in 0usize..400,
        order_seed in any::<u64>(),
    ) {
        let all = events(2);
        let n = all.len();
        // Exports cover time ranges: a cut never splits one minute's events.
        let at_minute_start = |mut c: usize| {
            while c > 0 && c < n && all[c - 1].at == all[c].at {
                c -= 1;
            }
            c
        };
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| at_minute_start(c % n)).collect();
        cuts.push(0);
        cuts.push(n);
        cuts.sort_unstable();
        cuts.dedup();
        let mut slices: Vec<(usize, usize)> = cuts
            .windows(2)
            .map(|w| (at_minute_start(w[0].saturating_sub(overlap)), at_minute_start((w[1] + overlap).min(n))))
            .collect();
        // A random order of the slices.
        let mut s = order_seed;
        for i in (1..slices.len()).rev() {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            slices.swap(i, (s >> 33) as usize % (i + 1));
        }
        let dir = TempDir::new("slices");
        let mut store = dir.store();
        store.create_person(&person("whole")).unwrap();
        store.create_person(&person("sliced")).unwrap();
        store.import("whole", &read(&nightscout(&all)).unwrap()).unwrap();
        let mut added = 0;
        for (a, b) in slices {
            added += store.import("sliced", &read(&nightscout(&all[a..b])).unwrap()).unwrap().added;
        }
        let whole = store.records("whole").unwrap();
        prop_assert_eq!(added, whole.len(), "each record added exactly once");
        let sliced = store.records("sliced").unwrap();
        prop_assert_eq!(serde_json::to_string(&sliced).unwrap(), serde_json::to_string(&whole).unwrap());
        prop_assert_eq!(store.events("sliced").unwrap(), store.events("whole").unwrap());
    }
}

#[test]
fn hostile_input_is_refused_whole_with_its_place_named() {
    let dir = TempDir::new("hostile");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let good = nightscout(&events(1));
    store.import("ana", &read(&good).unwrap()).unwrap();
    let before = (dir.rows("record"), dir.rows("import"));
    let entries = String::from_utf8(good[0].1.clone()).unwrap();
    let cut = entries.len() / 2;
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "truncated",
            entries[..cut].to_string(),
            vec!["entries.json"],
        ),
        ("not json", "{{{ not json".into(), vec!["entries.json"]),
        (
            "absurd glucose",
            r#"[{"_id":"a1","type":"sgv","sgv":40000,"date":1777860000000}]"#.into(),
            vec!["entries.json", "sgv"],
        ),
        (
            "negative glucose",
            r#"[{"_id":"a2","type":"sgv","sgv":-5,"date":1777860000000}]"#.into(),
            vec!["entries.json", "sgv"],
        ),
        (
            "text glucose",
            r#"[{"_id":"a3","type":"sgv","sgv":"high","date":1777860000000}]"#.into(),
            vec!["entries.json", "sgv"],
        ),
        (
            "no time",
            r#"[{"_id":"a4","type":"sgv","sgv":120}]"#.into(),
            vec!["entries.json"],
        ),
        (
            "year 99999",
            r#"[{"_id":"a5","type":"sgv","sgv":120,"date":3000000000000000}]"#.into(),
            vec!["entries.json"],
        ),
        ("empty", String::new(), vec!["entries.json"]),
        (
            "binary",
            "\u{0}\u{1}\u{2}\u{fffd}".into(),
            vec!["entries.json"],
        ),
    ];
    for (what, text, names) in cases {
        // A good treatments file next to the bad entries: nothing at all is imported.
        let inputs = vec![
            ("entries.json".to_string(), text.into_bytes()),
            good[1].clone(),
        ];
        let err = match read(&inputs) {
            Err(e) => StoreError::from(e),
            Ok(batch) => match store.import("ana", &batch) {
                Err(e) => e,
                Ok(s) => panic!("{what}: imported {s:?}"),
            },
        };
        let msg = err.to_string();
        for n in names {
            assert!(msg.contains(n), "{what}: the error names {n}: {msg}");
        }
        assert_eq!(
            (dir.rows("record"), dir.rows("import")),
            before,
            "{what}: nothing imported"
        );
    }
}

#[test]
fn the_snapshot_is_only_a_shortcut() {
    let dir = TempDir::new("snapshot");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let all = events(12);
    for day in 1..=12usize {
        let to = all
            .iter()
            .position(|e| e.at.day_index() >= day as i64)
            .unwrap_or(all.len());
        let from = all
            .iter()
            .position(|e| e.at.day_index() + 2 >= day as i64)
            .unwrap();
        store
            .import("ana", &read(&nightscout(&all[from..to])).unwrap())
            .unwrap();
        let advice = store.advise("ana").unwrap();
        if advice
            .settings
            .iter()
            .any(|s| s.latest.as_ref().is_some_and(|v| v.status == "open"))
        {
            let req = if day % 2 == 0 {
                AnswerRequest::Accept
            } else {
                AnswerRequest::Reject
            };
            store.answer("ana", &req).unwrap();
        }
        let cached = store.advisor("ana").unwrap();
        let rebuilt = store.rebuild("ana").unwrap();
        assert_eq!(cached, rebuilt, "day {day}");
    }
    let h = store.history("ana").unwrap();
    assert!(
        h.iter().any(|v| v.status == "accepted") && h.iter().any(|v| v.status == "rejected"),
        "{h:?}"
    );
}

#[test]
fn first_week_countdown_and_a_day_with_too_little_data() {
    use abba_core::EventKind;
    use abba_store::advise::Phase;
    let dir = TempDir::new("thin");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    // A sensor gap: day index 9 has CGM only from 14:00 on (42 % coverage).
    let all: Vec<_> = events(12)
        .into_iter()
        .filter(|e| {
            !(matches!(e.kind, EventKind::Cgm(_))
                && e.at.day_index() == 9
                && e.at.minute_of_day() < 14 * 60)
        })
        .collect();
    let upto = |day: i64| {
        all.iter()
            .filter(|e| e.at.day_index() < day)
            .copied()
            .collect::<Vec<_>>()
    };
    store
        .import("ana", &read(&nightscout(&upto(3))).unwrap())
        .unwrap();
    match store.advise("ana").unwrap().phase {
        Phase::FirstWeek {
            days_done,
            days_left,
            ..
        } => assert_eq!((days_done, days_left), (2, 5)),
        other => panic!("{other:?}"),
    }
    store
        .import("ana", &read(&nightscout(&all)).unwrap())
        .unwrap();
    let h = store.history("ana").unwrap();
    let gap = h
        .iter()
        .find(|v| v.setting == "basal" && v.day == 11)
        .unwrap();
    assert!(gap.no_update, "{gap:?}");
    let why = gap.no_update_reason.as_deref().unwrap();
    assert!(
        why.contains("too little data") && why.contains("201"),
        "{why}"
    );
    let full = h
        .iter()
        .find(|v| v.setting == "basal" && v.day == 10)
        .unwrap();
    assert!(!full.no_update, "{full:?}");
}

#[test]
fn records_of_one_instant_are_listed_in_their_key_order() {
    // A meal's carbohydrate and its bolus share an instant: the list is
    // ordered by instant, then by the stored (source, id) text, as the
    // store's columns sort (the list is read row by row and sorted after).
    let dir = TempDir::new("ties");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    store
        .import("ana", &read(&nightscout(&events(3))).unwrap())
        .unwrap();
    let records = store.records("ana").unwrap();
    let keys: Vec<_> = records
        .iter()
        .map(|r| (r.at, abba_store::log::key(r).unwrap()))
        .collect();
    let ties = keys.windows(2).filter(|w| w[0].0 == w[1].0).count();
    assert!(
        ties >= 9,
        "{ties} records share an instant with the one before"
    );
    assert!(
        keys.windows(2).all(|w| w[0] < w[1]),
        "not in (instant, source, id) order"
    );
    for (i, r) in records.iter().enumerate() {
        assert_eq!(r.origin.at, abba_io::record::OriginAt::Item(i as u32));
    }
}
