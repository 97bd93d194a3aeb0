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

/// A file's bytes with its last line cut short: no line end, the line
/// ending `keep` bytes into its cell `cell` (0-based).
fn cut_in_cell(bytes: &[u8], cell: usize, keep: usize) -> (Vec<u8>, Vec<u8>) {
    let text = std::str::from_utf8(bytes).unwrap();
    let body = text.trim_end_matches(['\r', '\n']);
    let start = body.rfind('\n').unwrap() + 1;
    let last = &body[start..];
    let delimiter = [',', ';', '\t']
        .into_iter()
        .max_by_key(|&d| last.matches(d).count())
        .unwrap();
    let at: usize = last.split(delimiter).take(cell).map(|c| c.len() + 1).sum();
    let whole_but_last = body.as_bytes()[..start].to_vec();
    let cut = body.as_bytes()[..start + at + keep].to_vec();
    (whole_but_last, cut)
}

#[test]
fn a_csv_file_cut_within_its_last_line_leaves_that_line_out_and_says_so() {
    // Each export cut two characters into its last row's glucose (or, for
    // CareLink, the sensor value's) cell: `145` would be read as `14`.
    let cases = [
        ("libreview_libre3_synthetic.csv", 4, "Europe/London"),
        ("clarity_export_synthetic.csv", 7, "America/Chicago"),
        ("carelink_780g_synthetic.csv", 30, "Europe/Zurich"),
        ("carelink_630g_us_synthetic.csv", 30, "America/Chicago"),
    ];
    for (name, cell, tz) in cases {
        let (whole, cut) = cut_in_cell(&fixture(name), cell, 2);
        let want = read(&[(name, whole.clone())], &opts(tz)).unwrap();
        let (got, first) = read_in_part(&[(name, cut)], &opts(tz));
        assert_eq!(got.records, want.records, "{name}");
        assert_eq!(got.unread.count, 1, "{name}");
        let line = whole.iter().filter(|&&b| b == b'\n').count() + 1;
        assert!(
            first.starts_with(&format!("{name}: line {line}, field \"row\""))
                && first.contains("the file ends within this line"),
            "{name}: {first}"
        );
    }
    // A whole last line without its line end is read.
    let csv = "time,glucose_mg_dl\n2024-01-01 00:00,150\n2024-01-01 00:05,145";
    let b = read(&[("p.csv", csv.into())], &ReadOptions::default()).unwrap();
    assert_eq!((b.count("cgm"), b.unread.count), (2, 0));
    // A plain CSV cut within its last line: 145 cut to 14 is not read as
    // a severe low.
    let csv = "time,glucose_mg_dl,bolus\n2024-01-01 00:00,150,\n2024-01-01 00:05,14";
    let (b, first) = read_in_part(&[("p.csv", csv.into())], &ReadOptions::default());
    assert_eq!(b.count("cgm"), 1);
    assert!(first.starts_with("p.csv: line 3, field \"row\""), "{first}");
    // A quote left open is cut too, whatever the cells.
    let csv =
        "time,glucose_mg_dl,note\n2024-01-01 00:00,150,\"a\"\n2024-01-01 00:05,145,\"lunch, la";
    let (b, _) = read_in_part(&[("p.csv", csv.into())], &ReadOptions::default());
    assert_eq!(b.count("cgm"), 1);
}
