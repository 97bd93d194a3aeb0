//! Tidepool's JSON and Excel export of the same data, imported one after
//! the other (either order) or together: the log holds each datum once,
//! nothing added, updated or lost the second time.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{person, read, TempDir};
use crate::tidepool_workbook::{person_data, workbook, Options};

fn json() -> (String, Vec<u8>) {
    (
        "TidepoolExport.json".into(),
        serde_json::to_vec(&person_data()).unwrap(),
    )
}

fn xlsx(bg_units: &'static str) -> (String, Vec<u8>) {
    (
        "TidepoolExport.xlsx".into(),
        workbook(
            &person_data(),
            &Options {
                bg_units,
                ..Options::default()
            },
        ),
    )
}

#[test]
fn the_workbook_after_the_json_adds_nothing() {
    for bg_units in ["mg/dL", "mmol/L"] {
        let dir = TempDir::new("tp-xlsx");
        let mut store = dir.store();
        store.create_person(&person("ana")).unwrap();
        let first = store.import("ana", &read(&[json()]).unwrap()).unwrap();
        assert!(first.added > 860, "{first:?}");
        let rows = dir.rows("record");
        let again = store.import("ana", &read(&[xlsx(bg_units)]).unwrap()).unwrap();
        assert_eq!(
            (again.added, again.updated, again.known),
            (0, 0, first.added),
            "{bg_units}: {again:?}"
        );
        assert_eq!(dir.rows("record"), rows, "{bg_units}");
    }
}

#[test]
fn the_json_after_the_workbook_adds_nothing_and_both_at_once_are_one() {
    let dir = TempDir::new("tp-xlsx-rev");
    let mut store = dir.store();
    store.create_person(&person("ana")).unwrap();
    let first = store.import("ana", &read(&[xlsx("mg/dL")]).unwrap()).unwrap();
    let again = store.import("ana", &read(&[json()]).unwrap()).unwrap();
    assert_eq!((again.added, again.updated), (0, 0), "{again:?}");
    // Both files in one import: each datum once.
    let dir2 = TempDir::new("tp-xlsx-both");
    let mut store2 = dir2.store();
    store2.create_person(&person("ana")).unwrap();
    let both = store2
        .import("ana", &read(&[json(), xlsx("mmol/L")]).unwrap())
        .unwrap();
    assert_eq!(both.added, first.added, "{both:?}");
    assert_eq!(dir2.rows("record"), dir.rows("record"));
}
