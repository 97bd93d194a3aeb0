//! LibreView's date orders as real exports write them: day-first dates
//! with a 12-hour clock (`13-12-2019 12:05 AM`, a layout listed in
//! tidepool-org/uploader#1461), where AM/PM says nothing about the order
//! of day and month; and the older FreeStyle Libre software's "Patient
//! report" with `M/D/YY H:MM` times (no leading zeros, two-digit years).
//! Fixtures: synthetic values in the real layouts (see PROVENANCE.md).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{fixture, opts, read};
use abba_io::time::DateOrder;
use abba_io::{ReadOptions, RecordKind};

const DAY_FIRST_12H: &str = "libreview_day_first_12h_synthetic.csv";
const PATIENT_REPORT: &str = "libreview_patient_report_mdyy_synthetic.csv";
const STOCKHOLM: &str = "Europe/Stockholm";
const DENVER: &str = "America/Denver";

fn with_order(tz: &str, order: Option<DateOrder>) -> ReadOptions {
    ReadOptions {
        date_order: order,
        ..opts(tz)
    }
}

/// The instants of the CGM records, in UTC.
fn cgm_times(b: &abba_io::Batch) -> Vec<String> {
    b.records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Cgm { .. }))
        .map(|r| r.at.to_string())
        .collect()
}

/// The fixture's first `rows` data rows (after the metadata line and the
/// header), as a shorter export of the same account would have them.
fn first_rows(name: &str, rows: usize) -> Vec<u8> {
    let text = String::from_utf8(fixture(name)).unwrap();
    text.split_inclusive('\n')
        .take(2 + rows)
        .collect::<String>()
        .into_bytes()
}

#[test]
fn day_first_dates_with_am_pm_are_read_day_first_when_a_day_tells() {
    // Line 12 (13-12-2019) can only be day-first; AM/PM is no evidence of
    // month-first (it was taken for it, and the file refused at line 12).
    for order in [None, Some(DateOrder::DayFirst)] {
        let b = read(
            &[("eu12.csv", fixture(DAY_FIRST_12H))],
            &with_order(STOCKHOLM, order),
        )
        .unwrap();
        let cgm = cgm_times(&b);
        assert_eq!(cgm.len(), 10, "{order:?}");
        // 11 December 22:50 and 12 December 00:05 in Stockholm (UTC+1);
        // 12:05 AM is just after midnight.
        assert_eq!(cgm[0], "2019-12-11T21:50:00Z", "{order:?}");
        assert_eq!(cgm[5], "2019-12-11T23:05:00Z", "{order:?}");
        assert_eq!(cgm[7], "2019-12-12T23:05:00Z", "{order:?}");
        assert_eq!(b.count("carbs"), 1);
    }
    // --date-order is honoured: one that the file contradicts is an error
    // naming the line, the field and the date that tells.
    let err = read(
        &[("eu12.csv", fixture(DAY_FIRST_12H))],
        &with_order(STOCKHOLM, Some(DateOrder::MonthFirst)),
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.starts_with("eu12.csv: line 12, field \"Device Timestamp\"")
            && err.contains("\"13-12-2019 12:05 AM\" can only be day-first")
            && err.contains("--date-order says month-first"),
        "{err}"
    );
}

#[test]
fn twelve_hour_dates_that_cannot_tell_their_order_are_not_guessed() {
    // The first 9 rows (11 and 12 December, every day <= 12): with AM/PM
    // they were read month-first without a word (November 12 and
    // December 11, a month apart).
    let short = first_rows(DAY_FIRST_12H, 9);
    let err = read(&[("eu12.csv", short.clone())], &opts(STOCKHOLM))
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("eu12.csv: line 3, field \"Device Timestamp\"")
            && err.contains(
                "\"11-12-2019 10:50 PM\" and every date after it could be day-first or month-first"
            )
            && err.contains("give --date-order day-first or month-first"),
        "{err}"
    );
    let b = read(
        &[("eu12.csv", short.clone())],
        &with_order(STOCKHOLM, Some(DateOrder::DayFirst)),
    )
    .unwrap();
    let cgm = cgm_times(&b);
    assert_eq!(cgm.first().unwrap(), "2019-12-11T21:50:00Z");
    assert_eq!(cgm.last().unwrap(), "2019-12-11T23:20:00Z");
    // Month-first when the user says so (a US account's 12-hour dates).
    let b = read(
        &[("us12.csv", short)],
        &with_order(STOCKHOLM, Some(DateOrder::MonthFirst)),
    )
    .unwrap();
    assert_eq!(cgm_times(&b)[0], "2019-11-12T21:50:00Z");
}

#[test]
fn a_wrong_time_names_the_row_the_order_was_learnt_from() {
    // A month-first date after line 12 showed day-first: the error says
    // which line showed the order (not "the file's first row").
    let text = String::from_utf8(fixture(DAY_FIRST_12H))
        .unwrap()
        .replace("13-12-2019 12:35 AM", "12-13-2019 12:35 AM");
    let (_, err) =
        crate::common::read_in_part(&[("eu12.csv", text.into_bytes())], &opts(STOCKHOLM));
    assert!(
        err.starts_with("eu12.csv: line 14, field \"Device Timestamp\"")
            && err.contains("like \"13-12-2019 12:05 AM\" (day first, as line 12 shows)")
            && err.contains("got \"12-13-2019 12:35 AM\""),
        "{err}"
    );
}

#[test]
fn the_patient_report_with_m_d_yy_dates_is_read_month_first() {
    // `3/12/19 23:15`: no leading zeros, a two-digit year (20YY); `3/13/19`
    // (line 7) tells month-first. It was taken for year-first ("3/12/" has
    // a separator where a four-digit year ends) and refused at line 4.
    let padded = String::from_utf8(fixture(PATIENT_REPORT))
        .unwrap()
        .replace("3/12/19 ", "03/12/19 ")
        .replace("3/13/19 ", "03/13/19 ");
    let four_digits = String::from_utf8(fixture(PATIENT_REPORT))
        .unwrap()
        .replace("/19 ", "/2019 ");
    for (name, bytes) in [
        ("report.csv", fixture(PATIENT_REPORT)),
        ("padded.csv", padded.into_bytes()),
        ("four.csv", four_digits.into_bytes()),
    ] {
        let b = read(&[(name, bytes)], &opts(DENVER)).unwrap();
        // Every row is record type 1 (scan): counted, not CGM, and a note
        // says so (with where their values are).
        assert_eq!(b.records.len(), 8, "{name}");
        assert_eq!(b.count("cgm"), 0, "{name}");
        let times: Vec<String> = b.records.iter().map(|r| r.at.to_string()).collect();
        // 12 March 2019 23:15 in Denver (MDT, UTC-6 since 10 March).
        assert_eq!(times[0], "2019-03-13T05:15:00Z", "{name}");
        assert_eq!(times[3], "2019-03-13T06:00:00Z", "{name}");
        assert_eq!(b.notes.len(), 1, "{name}: {:?}", b.notes);
        assert!(
            b.notes[0].starts_with(name)
                && b.notes[0].contains(
                    "the 8 rows of record type 1 (scan glucose) are counted, not read as CGM"
                )
                && b.notes[0].contains(
                    "8 of them have their value in the column \"Historic Glucose(mg/dL)\""
                ),
            "{}",
            b.notes[0]
        );
    }
}

#[test]
fn patient_report_dates_that_cannot_tell_their_order_name_the_real_first_row() {
    // The first 3 rows (3/12/19 only): day or month first cannot be told.
    let short = first_rows(PATIENT_REPORT, 3);
    let err = read(&[("report.csv", short.clone())], &opts(DENVER))
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("report.csv: line 4, field \"Meter Timestamp\"")
            && err.contains("\"3/12/19 23:15\" and every date after it")
            && err.contains("--date-order"),
        "{err}"
    );
    let b = read(
        &[("report.csv", short)],
        &with_order(DENVER, Some(DateOrder::MonthFirst)),
    )
    .unwrap();
    assert_eq!(b.records[0].at.to_string(), "2019-03-13T05:15:00Z");
    // Day-first with a day above 12 tells by itself.
    let day_first = String::from_utf8(fixture(PATIENT_REPORT))
        .unwrap()
        .replace("3/12/19 ", "12/3/19 ")
        .replace("3/13/19 ", "13/3/19 ");
    let b = read(&[("dmy.csv", day_first.into_bytes())], &opts(DENVER)).unwrap();
    assert_eq!(b.records[0].at.to_string(), "2019-03-13T05:15:00Z");
}
