//! One odd row or item does not cost the rest of its file: it is left out
//! and reported (file, line or JSON path, field, what was expected), the
//! rest is read; a file of which nothing can be read is refused with its
//! first error; a layout abba does not read is refused by name.

use crate::common::{fixture, opts, read, read_in_part};
use abba_io::ReadOptions;

#[test]
fn a_nightscout_item_that_cannot_be_read_is_left_out_and_reported() {
    let entries = r#"[
 {"_id":"a","type":"sgv","sgv":120,"date":1709557200000},
 {"_id":"b","type":"sgv","sgv":999999,"date":1709557500000},
 {"_id":"c","type":"sgv","sgv":125},
 "not an object",
 {"_id":"e","type":"sgv","sgv":130,"date":1709558100000}
]"#;
    let (b, first) = read_in_part(&[("e.json", entries.into())], &opts("UTC"));
    assert_eq!(b.count("cgm"), 2);
    assert_eq!(b.unread.count, 3);
    assert!(first.starts_with("e.json: $[1], field \"sgv\""), "{first}");
    let note = b
        .notes
        .iter()
        .find(|n| n.contains("could not be read"))
        .unwrap();
    assert!(
        note.starts_with("e.json: 3 rows or items could not be read")
            && note.contains("e.json: $[2], field \"date\"")
            && note.contains("e.json: $[3], field \"record\""),
        "{note}"
    );
    // Nothing readable: the file is refused with its first error.
    let none = r#"[{"_id":"b","type":"sgv","sgv":999999,"date":1709557500000}]"#;
    let e = read(&[("n.json", none.into())], &opts("UTC")).unwrap_err();
    assert!(
        e.to_string().starts_with("n.json: $[0], field \"sgv\""),
        "{e}"
    );
}

#[test]
fn a_number_in_created_at_that_is_seconds_is_left_out_as_seconds() {
    let t = r#"[{"eventType":"Correction Bolus","insulin":2,"created_at":1705579200},
               {"eventType":"Correction Bolus","insulin":1,"created_at":"2024-01-18T13:00:00Z"}]"#;
    let (b, e) = read_in_part(&[("t.json", t.into())], &opts("UTC"));
    assert_eq!(b.count("bolus"), 1);
    assert!(
        e.starts_with("t.json: $[0], field \"created_at\"") && e.contains("looks like seconds"),
        "{e}"
    );
}

#[test]
fn a_plain_csv_row_is_read_whole_or_left_out_whole() {
    let csv = "time,glucose_mg_dl,bolus\n2024-01-01 00:00,100,\n2024-01-01 00:05,110,-3\n2024-01-01 00:10,120,1.5\n";
    let (b, e) = read_in_part(&[("p.csv", csv.into())], &ReadOptions::default());
    // Line 3's glucose is not kept without its refused bolus.
    assert_eq!((b.count("cgm"), b.count("bolus")), (2, 1));
    assert!(e.starts_with("p.csv: line 3, field \"bolus\""), "{e}");
}

#[test]
fn a_csv_without_a_header_row_is_refused_as_such() {
    let csv = "2024-01-01 00:00,100\n2024-01-01 00:05,110\n";
    let e = read(&[("p.csv", csv.into())], &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(
            "p.csv: line 1 looks like data, not a header (\"2024-01-01 00:00\", \"100\")"
        ),
        "{e}"
    );
}

#[test]
fn a_plain_csv_says_its_missing_glucose_column_before_its_dates() {
    // Neither a glucose column nor dates that tell their order: the
    // column comes first (the dates would be the second error in turn).
    let csv = "time,sensorglucose\n01/02/2024 00:00,100\n";
    let e = read(&[("p.csv", csv.into())], &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no glucose column"), "{e}");
}

#[test]
fn a_carelink_export_in_another_language_is_named_not_read_as_plain_csv() {
    let e = read(
        &[("da.csv", fixture("carelink_guardian_danish_synthetic.csv"))],
        &opts("Europe/Copenhagen"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.starts_with("da.csv: a Medtronic CareLink export whose columns are not in English")
            && e.contains("Sensorglukose (mmol/l)")
            && e.contains("set CareLink's language to English"),
        "{e}"
    );
}

#[test]
fn a_tidepool_datum_that_cannot_be_read_is_left_out_and_reported() {
    // JSON text that is not JSON in one datum of Tidepool Web's export form.
    let t = r#"[
 {"type":"cbg","time":"2024-03-01T08:00:00.000Z","value":6.5,"units":"mmol/L","localTime":"2024-03-01T09:00:00","id":"a"},
 {"type":"basal","time":"2024-03-01T08:00:00.000Z","deliveryType":"scheduled","duration":3600000,"rate":0.65,"annotations":"[{'code': 'final-basal/fabricated-from-schedule'}]","id":"b"},
 {"type":"cbg","time":"2024-03-01T08:05:00.000Z","value":6.7,"units":"mmol/L","localTime":"2024-03-01T09:05:00","id":"c"}
]"#;
    let (b, e) = read_in_part(&[("tp.json", t.into())], &opts("Europe/Zurich"));
    assert_eq!(b.count("cgm"), 2);
    assert!(e.starts_with("tp.json: $[1], field \"annotations\""), "{e}");
}
