//! CareLink exports in the layouts real exports show and the shared
//! samples did not: a Paradigm Revel 723's US export (GluGo, MIT; see
//! tests/data/PROVENANCE.md) with a second header without its divider and
//! a trailing Sensor section without rows.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use common::{fixture, opts, read};
use jiff::civil::datetime;

const REVEL: &str = "carelink_paradigm723_glugo.csv";
const NEW_YORK: &str = "America/New_York";

fn at_ny(y: i16, mo: i8, d: i8, h: i8, mi: i8, s: i8) -> jiff::Timestamp {
    datetime(y, mo, d, h, mi, s, 0)
        .to_zoned(abba_io::time::zone(NEW_YORK).unwrap())
        .unwrap()
        .timestamp()
}

#[test]
fn a_section_without_rows_is_skipped_and_year_first_dates_need_no_date_order() {
    // The export ends with the Sensor section's divider and header and no
    // row (a Paradigm without a sensor): the whole file was refused with
    // "every date could be day-first or month-first", its dates all
    // 2018/MM/DD.
    let b = read(&[(REVEL, fixture(REVEL))], &opts(NEW_YORK)).unwrap();
    assert_eq!(b.formats, vec![abba_io::Format::CareLink]);
    // Every pump row of both headers is read (35 rows).
    assert_eq!(
        b.records.first().unwrap().at,
        at_ny(2018, 9, 22, 11, 59, 51)
    );
    assert_eq!(
        b.records.last().unwrap().at,
        at_ny(2018, 10, 11, 18, 14, 22)
    );
    assert_eq!(b.count("bolus"), 6);
    assert_eq!(b.count("smbg"), 2);
    assert_eq!(b.count("suspend"), 2);
    assert_eq!(b.count("resume"), 1);
    // The empty section is named in a note, with its line.
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("line 47") && n.contains("Sensor") && n.contains("no rows")),
        "{:?}",
        b.notes
    );
}

/// A MiniMed 780G in SmartGuard (auto mode), European layout (synthetic
/// values in the columns of a real 780G export; see PROVENANCE.md).
const SMARTGUARD: &str = "carelink_780g_smartguard_synthetic.csv";
const BERLIN: &str = "Europe/Berlin";

#[test]
fn smartguard_auto_mode_is_loop_evidence_and_a_780g_in_manual_mode_is_not() {
    use abba_io::automation::{Delivery, Evidence};
    let tz = abba_io::time::zone(BERLIN).unwrap();
    let bytes = fixture(SMARTGUARD);
    let e = Evidence::from_file(&bytes);
    // The auto correction (CLOSED_LOOP_AUTO_BOLUS) and the auto basal
    // micro-bolus (CLOSED_LOOP_AUTO_BASAL) are automatic doses.
    assert_eq!(e.smb, 2, "{e:?}");
    // Three boluses delivered in auto mode (CLOSED_LOOP_BG_CORRECTION_AND_
    // FOOD_BOLUS) and one daily total of auto insulin, named with the pump.
    let words = e.words().join("; ");
    assert!(
        words.contains("3 records from or naming SmartGuard auto mode")
            && words.contains("1 records from or naming SmartGuard auto mode")
            && words.contains("MiniMed 780G MMT-1886"),
        "{words}"
    );
    assert_eq!(e.delivery(), Delivery::ClosedLoop);
    // With the records' own counts (pump days, no short temp basals) the
    // file's evidence still makes it a loop: abba advises no basal.
    let b = read(&[(SMARTGUARD, bytes.clone())], &opts(BERLIN)).unwrap();
    let mut all = Evidence::from_records(&b.records, &tz);
    all.add_file(&e);
    assert_eq!(all.delivery(), Delivery::ClosedLoop);

    // A 780G in manual mode (its name in every divider, boluses from
    // BOLUS_WIZARD): the name alone is no loop, the pump runs open loop.
    let manual = fixture("carelink_780g_mmol_synthetic.csv");
    let m = Evidence::from_file(&manual);
    assert_eq!((m.smb, m.systems.len()), (0, 0), "{m:?}");
    let b = read(&[("manual.csv", manual)], &opts("Europe/Zurich")).unwrap();
    let mut all =
        Evidence::from_records(&b.records, &abba_io::time::zone("Europe/Zurich").unwrap());
    all.add_file(&m);
    assert_eq!(all.delivery(), Delivery::OpenLoop);
}
