//! A person's age group: its defaults in the stored advisor configuration,
//! the basal decisions' hours and words, a change later, and persons
//! stored before the field existed.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{events, nightscout, person, read, TempDir};
use abba_advisor::{AgeGroup, DecisionDetail, Parameter};
use abba_store::Store;

/// The local hours of every basal decision that learned from data.
fn basal_hours(store: &mut Store, name: &str) -> Vec<(i64, i64)> {
    store
        .decisions(name)
        .unwrap()
        .iter()
        .filter(|d| d.parameter == Parameter::Basal)
        .filter_map(|d| match &d.detail {
            DecisionDetail::Abba(x) => Some((
                x.window_start.minute_of_day(),
                x.window_end.0 - x.window_start.0,
            )),
            _ => None,
        })
        .collect()
}

#[test]
fn a_child_learns_its_basal_rate_from_02_to_07_and_is_told_so() {
    let dir = TempDir::new("age-child");
    let mut store = dir.store();
    let mut p = person("Cleo");
    p.settings.set_age_group(AgeGroup::Child);
    let stored = store.create_person(&p).unwrap();
    assert_eq!(stored.settings.age_group, AgeGroup::Child);
    let f = &store.person("Cleo").unwrap().settings.advisor.features;
    assert_eq!(f.cgm_basal_window_min, Some([120, 420]));
    assert_eq!(f.smbg_basal_window_min, Some([0, 450]));
    store
        .import("Cleo", &read(&nightscout(&events(12))).unwrap())
        .unwrap();
    let hours = basal_hours(&mut store, "Cleo");
    assert!(!hours.is_empty());
    // 02:00 for five hours.
    assert!(hours.iter().all(|&h| h == (120, 300)), "{hours:?}");
    let history = store.history("Cleo").unwrap();
    let basal = history
        .iter()
        .find(|v| v.setting == "basal" && !v.no_update)
        .expect("a basal update");
    assert!(
        basal.data.contains("from") && basal.data.contains("02:00"),
        "{}",
        basal.data
    );
    assert!(
        basal.reasons.contains(
            &"The basal rate learns from the readings from 02:00 to 07:00 only: the advisor's defaults for children."
                .to_string()
        ),
        "{:?}",
        basal.reasons
    );
    let notes = store.advise("Cleo").unwrap().notes;
    assert!(
        notes
            .iter()
            .any(|n| n.ends_with("the advisor's defaults for children.")),
        "{notes:?}"
    );
    // The carb ratios are told nothing of it.
    for v in history.iter().filter(|v| v.setting != "basal") {
        assert!(!v.reasons.iter().any(|r| r.contains("basal rate learns")));
    }

    // Made an adult later: the whole day, every decision replayed.
    let id = stored.id;
    let live = store.set_age_group_by_id(id, AgeGroup::Adult).unwrap();
    assert_eq!(live.person.settings.age_group, AgeGroup::Adult);
    let p = store.person("Cleo").unwrap();
    assert_eq!(p.settings.age_group, AgeGroup::Adult);
    assert_eq!(p.settings.advisor.features.cgm_basal_window_min, None);
    let hours = basal_hours(&mut store, "Cleo");
    assert!(hours.iter().all(|&h| h == (0, 1440)), "{hours:?}");
    assert!(!store
        .advise("Cleo")
        .unwrap()
        .notes
        .iter()
        .any(|n| n.contains("basal rate learns")));
    let history = store.history("Cleo").unwrap();
    assert!(!history
        .iter()
        .flat_map(|v| &v.reasons)
        .any(|r| r.contains("basal rate learns")));
}

#[test]
fn a_person_stored_before_age_groups_loads_as_an_adult() {
    let dir = TempDir::new("age-old");
    let db = dir.db().to_path_buf();
    if abba_store::testing::is_postgres(&db) {
        return; // reads the SQLite file directly
    }
    let mut store = dir.store();
    store.create_person(&person("Ada")).unwrap();
    drop(store);
    let c = rusqlite::Connection::open(&db).unwrap();
    let n = c
        .execute(
            "UPDATE person SET settings = json_remove(settings, '$.age_group') WHERE name = 'Ada'",
            [],
        )
        .unwrap();
    assert_eq!(n, 1);
    let doc: String = c
        .query_row("SELECT settings FROM person WHERE name = 'Ada'", [], |r| {
            r.get(0)
        })
        .unwrap();
    assert!(
        !doc.contains("age_group") && !doc.contains("therapy_notes"),
        "{doc}"
    );
    drop(c);
    let store = Store::open(&db).unwrap();
    let p = store.person("Ada").unwrap();
    assert_eq!(p.settings.age_group, AgeGroup::Adult);
    assert!(AgeGroup::Adult.holds(&p.settings.advisor.features));
    assert!(p.settings.therapy_notes.is_empty());
}
