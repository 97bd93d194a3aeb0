//! A MiniMed 670G's Nightscout export (600SeriesAndroidUploader with
//! AndroidAPS's NSClient, mongoexport's one document a line) imported end
//! to end: its resumes (Temp Basals of duration 0 without a rate) and its
//! Profile Switches to the pump's auto mode (a 0.000001 U/h placeholder)
//! no longer refuse the import; the auto mode is loop evidence; a second
//! import adds nothing. The treatments are abba-io's fixture
//! `nightscout_treatments_600series_mongoexport_synthetic.json`.

use crate::common;

use abba_advisor::Mode;
use abba_io::automation::Delivery;
use abba_io::ReadOptions;
use abba_store::NewPerson;
use common::TempDir;
use jiff::tz::TimeZone;

const TZ: &str = "Europe/Madrid";
const TREATMENTS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../io/tests/data/nightscout_treatments_600series_mongoexport_synthetic.json"
);

/// CGM entries in the uploader's layout, every 5 min from 2026-05-04 00:30
/// to 2026-05-06 12:00 in Madrid.
fn entries() -> String {
    let start: i64 = 1_777_847_400_000;
    let mut out = String::new();
    for i in 0..(59 * 12 + 6) {
        let ms = start + i * 300_000;
        out.push_str(&format!(
            "{{\"_id\":{{\"$oid\":\"6a1f3c20b7e4d91a2e{i:06x}\"}},\"date\":{},\"direction\":\"Flat\",\"key600\":\"CGM9A2B{i:04X}\",\"sgv\":{},\"type\":\"sgv\"}}\n",
            format!("{:.12e}", ms as f64).replace('e', "e+"),
            110 + (i % 24) * 2
        ));
    }
    out
}

#[test]
fn a_670g_export_with_auto_mode_and_resumes_imports_once_as_a_closed_loop() {
    let dir = TempDir::new("minimed-670g");
    let e = dir.0.join("entries.json");
    let t = dir.0.join("treatments.json");
    std::fs::write(&e, entries()).unwrap();
    std::fs::copy(TREATMENTS, &t).unwrap();
    let files = vec![e, t];
    let opts = ReadOptions {
        tz: Some(TimeZone::get(TZ).unwrap()),
        ..ReadOptions::default()
    };
    let meals = abba_io::meals::MealWindows::default();
    // `person new --therapy-from`: the manual profile, not the placeholder.
    let therapy = abba_io::therapy::therapy_from_files(&files, &opts, &meals).unwrap();
    assert_eq!(
        therapy.basal,
        vec![(0, 0.9), (360, 1.1), (720, 0.7), (1320, 0.85)]
    );
    // Given with the same values: the import compares the export's
    // profiles with them (where the placeholder refused the import).
    let mut p = NewPerson::new("mia", TZ, Mode::Cgm, therapy.settings());
    p.settings.basal_schedule = Some(therapy.basal.clone());
    let mut store = dir.store();
    store.create_person(&p).unwrap();
    let first = store.import_files("mia", &files, None).unwrap();
    assert!(first.added > 700, "{first:?}");
    for part in [
        "2 Profile Switches put the pump in its auto mode",
        "2 Temp Basals of duration 0",
    ] {
        assert!(
            first.notes.iter().any(|n| n.contains(part)),
            "{part}: {:?}",
            first.notes
        );
    }
    let again = store.import_files("mia", &files, None).unwrap();
    assert_eq!((again.added, again.updated), (0, 0), "{again:?}");
    assert_eq!(again.known, first.added, "{again:?}");
    let a = store.advise("mia").unwrap();
    assert_eq!(a.delivery.kind, Delivery::ClosedLoop, "{:?}", a.delivery);
}
