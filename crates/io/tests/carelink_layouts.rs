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
