//! The quirks of real exports (issue 21), each on a file written in the
//! format's real layout: a CareLink export with both sections, decimal
//! commas and a repeated row; a Nightscout profile at the epoch; a Clarity
//! phone clock change (with and without transmitter times); Nightscout
//! `_id` repeats; Tidepool cross-upload duplicates; MongoDB extended JSON;
//! a German Clarity header; a header-only export; a split date/time CSV in
//! mmol/L; future records refused.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::record::{Censor, RecordKind, TempRate, SINCE_ALWAYS};
use abba_io::{Format, GlucoseUnit, ReadOptions};
use common::{fixture, opts, read};

fn kinds(b: &abba_io::Batch, name: &str) -> usize {
    b.count(name)
}

fn ignored(b: &abba_io::Batch, what: &str) -> usize {
    b.records
        .iter()
        .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == what))
        .count()
}

#[test]
fn a_carelink_export_reads_both_sections_with_decimal_commas() {
    let b = read(
        &[("carelink.csv", fixture("carelink_780g_synthetic.csv"))],
        &opts("Europe/Amsterdam"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::CareLink]);
    // Two days of sensor glucose every 5 min, one row exported twice.
    assert_eq!(kinds(&b, "cgm"), 576);
    assert_eq!(b.duplicates.get("cgm"), Some(&1));
    // The repeated normal bolus row is one bolus too.
    assert_eq!(b.duplicates.get("bolus"), Some(&1));
    assert_eq!(kinds(&b, "smbg"), 1);
    let bolus: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Bolus { units } => Some(units.0),
            _ => None,
        })
        .collect();
    assert_eq!(bolus, vec![4.5, 3.0], "decimal commas, dual normal part");
    let ext: Vec<(f64, u32)> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::ExtendedBolus {
                extended,
                duration_min,
                ..
            } => Some((extended.0, duration_min)),
            _ => None,
        })
        .collect();
    assert_eq!(
        ext,
        vec![(1.5, 30), (2.0, 120)],
        "square and dual square part"
    );
    let carbs: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Carbs { grams } => Some(grams.0),
            _ => None,
        })
        .collect();
    assert_eq!(
        carbs,
        vec![54.0, 60.0, 60.0],
        "BWZ carb input and a Meal marker"
    );
    let temps: Vec<TempRate> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::TempBasal { rate, .. } => Some(rate),
            _ => None,
        })
        .collect();
    assert!(matches!(temps[0], TempRate::Absolute(r) if r.0 == 0.4));
    assert!(matches!(temps[1], TempRate::Percent(p) if p == 50.0));
    assert_eq!(kinds(&b, "basal_schedule"), 2);
    assert_eq!((kinds(&b, "suspend"), kinds(&b, "resume")), (1, 1));
    assert_eq!(ignored(&b, "daily auto insulin total (not a dose)"), 2);
    assert_eq!(ignored(&b, "SmartGuard auto basal micro-bolus"), 1);
    assert_eq!(
        ignored(&b, "event marker insulin (acting type not given)"),
        1
    );
    assert_eq!(ignored(&b, "alarm"), 1);
    // Newest first in the file, oldest first here; wall times in the zone.
    assert_eq!(b.records[0].at.to_string(), "2025-11-02T23:00:00Z");
    // Every row is accounted for: the file's data rows = records + duplicates.
    let rows = 20 + 2 + 577;
    let merged: usize = b.duplicates.values().sum();
    let per_row_extra = 0; // no row here carries two records
    assert_eq!(b.records.len() + merged, rows + per_row_extra);
}

#[test]
fn carelink_rows_without_their_duration_are_errors_naming_line_and_field() {
    let text = String::from_utf8(fixture("carelink_780g_synthetic.csv")).unwrap();
    let bad = text.replace(";1:00:00;", ";;");
    let (_, e) = common::read_in_part(&[("c.csv", bad.into_bytes())], &opts("Europe/Amsterdam"));
    assert!(
        e.starts_with("c.csv: line 13, field \"Temp Basal Duration (h:mm:ss)\""),
        "{e}"
    );
}

#[test]
fn a_nightscout_profile_at_the_epoch_is_in_force_since_always() {
    let profile = br#"[
      {"_id":"p2","defaultProfile":"Default","startDate":"2024-03-01T00:00:00.000Z","mills":1709251200000,
       "store":{"Default":{"basal":[{"time":"00:00","value":0.9}],"timezone":"Europe/Zurich"}}},
      {"_id":"p1","defaultProfile":"Default","startDate":"1970-01-01T00:00:00.000Z","mills":0,
       "store":{"Default":{"basal":[{"time":"00:00","value":0.8}],"timezone":"Europe/Zurich"}}}
    ]"#;
    let b = read(
        &[("profile.json", profile.to_vec())],
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(b.records.len(), 2);
    assert_eq!(b.records[0].at, SINCE_ALWAYS);
    assert_eq!(b.records[1].at.to_string(), "2024-03-01T00:00:00Z");
    // A `mills` of 0 anywhere else is still "seconds", refused.
    let entry = br#"[{"_id":"e","type":"sgv","sgv":120,"date":0}]"#;
    let e = read(&[("e.json", entry.to_vec())], &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("looks like seconds"), "{e}");
}

#[test]
fn a_temp_basal_with_only_a_rate_above_any_basal_rate_is_counted_not_fatal() {
    // The shape of Nightscout's captured AndroidAPS treatments: `rate`
    // alone, 0-340 (percentages by their look). The file was refused whole
    // at the first 140; now those are counted and the rest read.
    let t = br#"[
      {"_id":"a","eventType":"Temp Basal","created_at":"2026-05-08T23:55:17.000Z","device":"openaps://AndroidAPS","duration":30,"rate":140},
      {"_id":"b","eventType":"Temp Basal","created_at":"2026-05-08T23:35:29.000Z","device":"openaps://AndroidAPS","duration":30,"rate":0},
      {"_id":"c","eventType":"Temp Basal","created_at":"2026-05-08T23:25:16.000Z","device":"openaps://AndroidAPS","duration":30,"rate":300},
      {"_id":"d","eventType":"Correction Bolus","created_at":"2026-05-08T23:20:00.000Z","insulin":0.5}
    ]"#;
    let b = read(&[("treatments.json", t.to_vec())], &ReadOptions::default()).unwrap();
    let what = "Temp Basal with only a rate above any basal rate (U/h or a percentage?)";
    assert_eq!(ignored(&b, what), 2);
    assert_eq!(b.records.len(), 4);
    // With `absolute` the same value is an error naming the field.
    let bad = br#"[{"_id":"e","eventType":"Temp Basal","created_at":"2026-05-08T23:55:17.000Z","duration":30,"absolute":140}]"#;
    let e = read(&[("t.json", bad.to_vec())], &ReadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("absolute"), "{e}");
}

#[test]
fn a_nightscout_profile_is_in_force_from_its_start_date_not_its_upload() {
    // openaps' test profile (oref0's ns-profile shape: values as strings):
    // in force from 2015-08-17, uploaded on 2015-11-08.
    let profile = br#"[{"_id":"5637c1eb76ec4a3f0d2f0e8e","defaultProfile":"Default",
      "startDate":"2015-08-17T00:00:00.000Z","created_at":"2015-11-08T19:58:03.579Z",
      "store":{"Default":{"dia":"3","timezone":"America/Los_Angeles","units":"mg/dl",
        "carbratio":[{"time":"00:00","value":"15","timeAsSeconds":"0"}],
        "basal":[{"time":"00:00","value":"1.0","timeAsSeconds":"0"}]}}}]"#;
    let b = read(
        &[("profile.json", profile.to_vec())],
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(b.records.len(), 1);
    assert_eq!(b.records[0].at.to_string(), "2015-08-17T00:00:00Z");
}

/// A Clarity export around a phone clock change: from `change` on the
/// written times are an hour early, the transmitter's clock goes on.
fn clarity_clock_change(transmitter: bool) -> Vec<u8> {
    clarity_clock_moved(transmitter, -1)
}

/// The same with the phone's clock moved by `hours` from the 81st reading.
fn clarity_clock_moved(transmitter: bool, hours: i64) -> Vec<u8> {
    let mut s = String::from("Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID\r\n");
    let start = jiff::civil::date(2024, 6, 10).at(8, 0, 0, 0);
    for i in 0..120i64 {
        let true_t = start + jiff::SignedDuration::from_mins(5 * i);
        let written = if i >= 80 {
            true_t + jiff::SignedDuration::from_hours(hours)
        } else {
            true_t
        };
        let tx = if transmitter {
            format!("{},8XYZAB", 1_000_000 + 300 * i)
        } else {
            ",".into()
        };
        s.push_str(&format!(
            "{},{},EGV,,,,android G6,{},,,,,{tx}\r\n",
            i + 1,
            written.strftime("%Y-%m-%dT%H:%M:%S"),
            100 + i % 50
        ));
    }
    s.into_bytes()
}

#[test]
fn a_clarity_phone_clock_change_is_placed_by_the_transmitter_clock() {
    let b = read(
        &[("c.csv", clarity_clock_change(true))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(kinds(&b, "cgm"), 120);
    // Placed at their true instants: strictly 5 minutes apart.
    assert!(b
        .records
        .windows(2)
        .all(|w| w[1].at.duration_since(w[0].at).as_secs() == 300));
    assert_eq!(b.notes.len(), 1, "{:?}", b.notes);
    assert!(
        b.notes[0].contains("lines 82-121: 40 readings"),
        "{}",
        b.notes[0]
    );
    // Which way the clock moved, in words (it said "differed by 1h ago").
    assert!(
        b.notes[0]
            .contains("the phone's clock was 1h behind its clock in the file's longest stretch"),
        "{}",
        b.notes[0]
    );
    assert!(!b.notes[0].contains("  "), "{}", b.notes[0]);
    // An hour ahead instead: the other word.
    let b = read(
        &[("c.csv", clarity_clock_moved(true, 1))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert!(
        b.notes[0]
            .contains("the phone's clock was 1h ahead of its clock in the file's longest stretch"),
        "{}",
        b.notes[0]
    );
}

#[test]
fn without_transmitter_times_the_conflicting_stretch_is_reported_and_the_rest_kept() {
    let b = read(
        &[("c.csv", clarity_clock_change(false))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    // The first 12 readings after the change fall on times already
    // covered; the 28 after them are new times and kept.
    assert_eq!(kinds(&b, "cgm"), 120 - 12);
    assert_eq!(b.notes.len(), 1);
    assert!(
        b.notes[0].contains("lines 82-93: 12 readings"),
        "{}",
        b.notes[0]
    );
    assert!(!b.notes[0].contains("  "), "{}", b.notes[0]);
}

#[test]
fn nightscout_id_repeats_keep_the_latest_version() {
    let t = br#"[
      {"_id":"t1","eventType":"Temp Basal","created_at":"2024-06-10T10:00:00Z","absolute":0.5,"duration":60,"srvModified":1718013600000},
      {"_id":"t1","eventType":"Temp Basal","created_at":"2024-06-10T10:00:00Z","absolute":0.5,"duration":35,"srvModified":1718015700000},
      {"_id":"t2","eventType":"Temp Basal","created_at":"2024-06-10T11:00:00Z","absolute":0.7,"duration":30},
      {"_id":"t2","eventType":"Temp Basal","created_at":"2024-06-10T11:05:00Z","absolute":0.7,"duration":25}
    ]"#;
    let b = read(&[("t.json", t.to_vec())], &ReadOptions::default()).unwrap();
    let d: Vec<u32> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::TempBasal { duration_min, .. } => Some(duration_min),
            _ => None,
        })
        .collect();
    assert_eq!(d, vec![35, 25]);
    assert!(
        b.notes[0].contains("2 records repeat an _id"),
        "{:?}",
        b.notes
    );
}

#[test]
fn tidepool_data_of_two_uploads_seconds_apart_are_one_record() {
    let t = br#"[
      {"id":"a1","type":"bolus","subType":"normal","normal":2.5,"time":"2024-06-10T12:00:00.000Z","uploadId":"pump"},
      {"id":"h1","type":"bolus","subType":"normal","normal":2.5,"time":"2024-06-10T12:00:07.000Z","uploadId":"healthkit"},
      {"id":"a2","type":"cbg","value":6.5,"units":"mmol/L","time":"2024-06-10T12:05:00.000Z","uploadId":"pump"},
      {"id":"h2","type":"cbg","value":6.5,"units":"mmol/L","time":"2024-06-10T12:05:03.000Z","uploadId":"healthkit"},
      {"id":"a3","type":"cbg","value":6.5,"units":"mmol/L","time":"2024-06-10T12:10:00.000Z","uploadId":"pump"}
    ]"#;
    let b = read(&[("tp.json", t.to_vec())], &ReadOptions::default()).unwrap();
    assert_eq!((kinds(&b, "bolus"), kinds(&b, "cgm")), (1, 2));
    assert_eq!(b.cross_upload.values().sum::<usize>(), 2);
}

#[test]
fn mongodb_extended_json_one_document_a_line_unsorted_reads() {
    let dump = concat!(
        r#"{"type":"sgv","sgv":{"$numberInt":"131"},"date":{"$date":"2024-06-10T12:10:00.000Z"}}"#,
        "\n",
        r#"{"_id":{"$oid":"65f0c0ffee0000000000002"},"type":"sgv","sgv":120,"date":{"$date":{"$numberLong":"1718020800000"}}}"#,
        "\n",
        r#"{"_id":{"$oid":"65f0c0ffee0000000000003"},"type":"sgv","sgv":125,"date":{"$date":1718021100000}}"#,
        "\n"
    );
    let b = read(
        &[("xdrip.json", dump.as_bytes().to_vec())],
        &ReadOptions::default(),
    )
    .unwrap();
    let v: Vec<(String, f64)> = b
        .records
        .iter()
        .map(|r| match r.kind {
            RecordKind::Cgm { glucose } => (r.at.to_string(), glucose.mg_dl.0),
            _ => unreachable!(),
        })
        .collect();
    assert_eq!(
        v,
        vec![
            ("2024-06-10T12:00:00Z".into(), 120.0),
            ("2024-06-10T12:05:00Z".into(), 125.0),
            ("2024-06-10T12:10:00Z".into(), 131.0)
        ]
    );
}

#[test]
fn a_clarity_export_with_german_headers_is_recognised_by_its_structure() {
    let text = "Index,Zeitstempel (JJJJ-MM-TTThh:mm:ss),Ereignistyp,Ereignis-Subtyp,Patienteninfo,Geräteinfo,Quellgeräte-ID,Glukosewert (mg/dl),Insulinwert (IE),Kohlenhydratwert (Gramm),Dauer (hh:mm:ss),Glukose-Änderungsrate (mg/dl/min),Transmitterzeit (lange Ganzzahl),Transmitter-ID\n\
        1,,Vorname,,Test,,,,,,,,,\n\
        2,2024-06-10T08:00:00,EGV,,,,android G6,110,,,,,1000000,8XYZAB\n\
        3,2024-06-10T08:05:00,EGV,,,,android G6,Niedrig,,,,,1000300,8XYZAB\n\
        4,2024-06-10T08:07:00,Kohlenhydrate,,,,android G6,,,30,,,,\n";
    // "Niedrig" is not a number: the row is left out, its error names line
    // and field, and the other rows are read.
    let (b, e) = common::read_in_part(
        &[("de.csv", text.as_bytes().to_vec())],
        &opts("Europe/Berlin"),
    );
    assert!(
        e.starts_with("de.csv: line 4, field \"Glukosewert (mg/dl)\""),
        "{e}"
    );
    assert_eq!((b.count("cgm"), b.count("carbs")), (1, 1));
    let ok = text.replace("Niedrig", "Low");
    let b = read(&[("de.csv", ok.into_bytes())], &opts("Europe/Berlin")).unwrap();
    assert_eq!(b.formats, vec![Format::Clarity]);
    assert_eq!((kinds(&b, "cgm"), kinds(&b, "carbs")), (2, 1));
    assert!(
        matches!(b.records[1].kind, RecordKind::Cgm { glucose } if glucose.censor == Censor::Below)
    );
}

#[test]
fn a_header_only_export_has_no_readings() {
    let text = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID\n";
    let b = read(
        &[("h.csv", text.as_bytes().to_vec())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert!(b.records.is_empty());
    assert_eq!(b.empty_files(), vec!["h.csv"]);
}

#[test]
fn a_split_date_and_time_csv_in_mmol_reads_with_its_date_order_checked() {
    let text = "id,date,time,glucose,type\n\
        7,13/06/2024,08:00:00,6.1,cgm\n\
        7,13/06/2024,08:05:00,6.4,cgm\n\
        7,13/06/2024,08:07:00,7.0,manual\n\
        7,14/06/2024,00:00,5.5,cgm\n";
    let mut o = opts("Europe/London");
    o.units = Some(GlucoseUnit::MmolL);
    let b = read(&[("r.csv", text.as_bytes().to_vec())], &o).unwrap();
    assert_eq!((kinds(&b, "cgm"), kinds(&b, "smbg")), (3, 1));
    assert_eq!(b.records[0].at.to_string(), "2024-06-13T07:00:00Z");
    let RecordKind::Cgm { glucose } = b.records[0].kind else {
        panic!()
    };
    assert!((glucose.mg_dl.0 - 6.1 * 18.0156).abs() < 0.01);
    // Dates that could be either order need --date-order.
    let ambiguous = text.replace("13/06", "03/06").replace("14/06", "04/06");
    let e = read(&[("r.csv", ambiguous.clone().into_bytes())], &o).unwrap_err();
    assert!(e.to_string().contains("--date-order"), "{e}");
    o.date_order = Some(abba_io::time::DateOrder::MonthFirst);
    let b = read(&[("r.csv", ambiguous.into_bytes())], &o).unwrap();
    assert_eq!(b.records[0].at.to_string(), "2024-03-06T08:00:00Z");
    // Contradicting dates are an error naming both lines.
    let mixed = text.replace("14/06/2024", "06/14/2024");
    let e = read(&[("r.csv", mixed.into_bytes())], &opts("Europe/London")).unwrap_err();
    assert!(
        e.to_string().contains("line 5") && e.to_string().contains("line 2"),
        "{e}"
    );
}

#[test]
fn records_dated_after_the_time_of_import_are_refused_with_count_and_first_line() {
    let text = "time,glucose_mg_dl\n\
        2024-06-10T12:00:00Z,120\n\
        2024-06-10T12:09:00Z,121\n\
        2024-06-10T12:15:00Z,122\n\
        2024-06-10T12:11:00Z,123\n";
    let mut b = read(
        &[("f.csv", text.as_bytes().to_vec())],
        &ReadOptions::default(),
    )
    .unwrap();
    let now: jiff::Timestamp = "2024-06-10T12:00:00Z".parse().unwrap();
    let refused = b.refuse_future(now);
    assert_eq!(refused.count, 2);
    assert_eq!(refused.first.as_deref(), Some("f.csv: line 4"));
    assert_eq!(b.records.len(), 2);
}

fn carelink_therapy(
    name: &str,
    bytes: &[u8],
    tz: &str,
) -> Result<abba_io::therapy::CareLinkTherapy, String> {
    let meals = abba_io::meals::MealWindows::default();
    abba_io::therapy::carelink_settings(name, bytes, &opts(tz), &meals).unwrap()
}

#[test]
fn a_us_carelink_export_reads_with_commas_points_and_month_first_dates() {
    let b = read(
        &[("us.csv", fixture("carelink_630g_us_synthetic.csv"))],
        &opts("America/Chicago"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::CareLink]);
    // 3.5 days of sensor glucose every 5 minutes.
    assert_eq!(kinds(&b, "cgm"), 3 * 288 + 144);
    // Eleven wizard boluses with carbohydrate and one correction.
    assert_eq!(kinds(&b, "carbs"), 11);
    assert_eq!(kinds(&b, "bolus"), 12);
    // The first reading is 2025-03-13 00:00 in Chicago (UTC-5 after the
    // spring change of 9 March): month-first dates, two-digit years.
    let first = b
        .records
        .iter()
        .find(|r| matches!(r.kind, RecordKind::Cgm { .. }))
        .unwrap();
    assert_eq!(first.at.to_string(), "2025-03-13T05:00:00Z");
}

#[test]
fn carelink_therapy_is_the_last_full_days_basal_rows_and_the_latest_wizard_ratio_per_meal() {
    let t = carelink_therapy(
        "us.csv",
        &fixture("carelink_630g_us_synthetic.csv"),
        "America/Chicago",
    )
    .unwrap();
    // The export ends on 2025-03-16 at noon: the last full day is the
    // 15th, whose 04:00 rate (1.05) differs from the days before (1.0).
    assert_eq!(t.day.to_string(), "2025-03-15");
    assert_eq!(
        t.basal,
        vec![
            (0, 0.8),
            (240, 1.05),
            (540, 0.85),
            (1020, 0.95),
            (1320, 0.75)
        ]
    );
    assert_eq!(t.at.to_string(), "2025-03-15T05:00:00Z");
    // Breakfast and lunch: the 16th's wizards (the correction with ratio 0
    // at 11:55 is not a ratio); dinner: the 15th's.
    assert_eq!(t.carb_ratio, [Some(9.0), Some(11.5), Some(13.5)]);
    let meals = abba_io::meals::MealWindows::default();
    let p = t.complete(&meals, None).unwrap();
    assert_eq!(p.carb_ratio, [9.0, 11.5, 13.5]);
    // The same through `person new --therapy-from`'s reader.
    let path = std::path::PathBuf::from(format!("{}/carelink_630g_us_synthetic.csv", common::DATA));
    let f =
        abba_io::therapy::therapy_from_files(&[path], &opts("America/Chicago"), &meals).unwrap();
    assert_eq!(f.basal, t.basal);
    assert_eq!(f.carb_ratio, [9.0, 11.5, 13.5]);
}

#[test]
fn a_decimal_comma_mmol_carelink_export_names_the_meal_without_a_wizard_event() {
    let bytes = fixture("carelink_780g_mmol_synthetic.csv");
    let b = read(&[("eu.csv", bytes.clone())], &opts("Europe/Zurich")).unwrap();
    // mmol/L from the headers, converted: the readings lie around 130 mg/dL.
    let cgm: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Cgm { glucose } => Some(glucose.mg_dl.0),
            _ => None,
        })
        .collect();
    assert_eq!(cgm.len(), 3 * 288 + 9 * 12);
    assert!(cgm.iter().all(|&g| (70.0..200.0).contains(&g)), "{cgm:?}");
    let t = carelink_therapy("eu.csv", &bytes, "Europe/Zurich").unwrap();
    assert_eq!(t.day.to_string(), "2025-11-05");
    assert_eq!(
        t.basal,
        vec![(0, 0.7), (360, 0.95), (720, 0.8), (1260, 0.65)]
    );
    assert_eq!(t.carb_ratio, [Some(8.5), Some(10.0), None]);
    let meals = abba_io::meals::MealWindows::default();
    let e = t.complete(&meals, None).unwrap_err().to_string();
    assert!(
        e.contains("dinner") && e.contains("15:30-22:00") && e.contains("--carb-ratio"),
        "{e}"
    );
    // Given carb ratios replace the export's.
    let p = t.complete(&meals, Some([8.0, 10.0, 12.0])).unwrap();
    assert_eq!(p.carb_ratio, [8.0, 10.0, 12.0]);
    assert_eq!(p.basal, t.basal);
}

#[test]
fn a_carelink_export_without_a_full_day_or_with_exchanges_says_what_it_lacks() {
    let text = String::from_utf8(fixture("carelink_630g_us_synthetic.csv")).unwrap();
    // Only the last (partial) day and the day before from 06:00: the rate in
    // force at the last full day's midnight is not known.
    let short: String = text
        .split_inclusive('\n')
        .filter(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            match cells.get(1) {
                Some(d) if d.len() == 8 && d.contains('/') => {
                    *d == "03/16/25" || (*d == "03/15/25" && cells[2] >= "06:00:00")
                }
                _ => true,
            }
        })
        .collect();
    let why = carelink_therapy("short.csv", short.as_bytes(), "America/Chicago").unwrap_err();
    assert!(
        why.contains("2025-03-15") && why.contains("longer period"),
        "{why}"
    );
    // A wizard counting in exchanges: its ratios are not read as g/U.
    let ex = text.replace("BWZ Carb Ratio (g/U)", "BWZ Carb Ratio (Exchanges)");
    let t = carelink_therapy("ex.csv", ex.as_bytes(), "America/Chicago").unwrap();
    assert_eq!(t.carb_ratio, [None; 3]);
    let meals = abba_io::meals::MealWindows::default();
    let e = t.complete(&meals, None).unwrap_err().to_string();
    assert!(e.contains("not in g/U") && e.contains("breakfast"), "{e}");
    // An implausible wizard ratio is an error naming the line and column.
    let bad = text.replacen(",11.5,50,65,", ",0.2,50,65,", 1);
    let meals = abba_io::meals::MealWindows::default();
    let e = abba_io::therapy::carelink_settings(
        "bad.csv",
        bad.as_bytes(),
        &opts("America/Chicago"),
        &meals,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("bad.csv") && e.contains("BWZ Carb Ratio (g/U)"),
        "{e}"
    );
}

#[test]
fn tidepool_pump_settings_follow_the_active_schedule_and_refuse_exchanges() {
    let meals = abba_io::meals::MealWindows::default();
    let read = |v: serde_json::Value| {
        abba_io::therapy::tidepool_pump_settings(
            "tp.json",
            &serde_json::to_vec(&v).unwrap(),
            &meals,
        )
    };
    // Tandem-style: every setting named like the basal schedules.
    let named = serde_json::json!([{"type": "pumpSettings", "time": "2026-05-10T08:00:00Z",
        "activeSchedule": "Weekend",
        "basalSchedules": {"Work": [{"start": 0, "rate": 1.0}],
            "Weekend": [{"start": 0, "rate": 0.8}, {"start": 21_600_000, "rate": 0.9}]},
        "carbRatios": {"Work": [{"start": 0, "amount": 10}], "Weekend": [{"start": 0, "amount": 14}]},
        "bgTargets": {"Work": [{"start": 0, "target": 5.5}], "Weekend": [{"start": 0, "target": 6.0}]},
        "insulinSensitivities": {"Work": [{"start": 0, "amount": 2.5}], "Weekend": [{"start": 0, "amount": 3.0}]},
        "units": {"carb": "grams", "bg": "mmol/L"}}]);
    let t = read(named.clone()).unwrap();
    assert_eq!(t.len(), 1);
    assert_eq!(t[0].basal, vec![(0, 0.8), (360, 0.9)]);
    assert_eq!(t[0].carb_ratio, [14.0; 3]);
    // Another active schedule, another therapy.
    let mut work = named.clone();
    work[0]["activeSchedule"] = "Work".into();
    assert_eq!(read(work).unwrap()[0].basal, vec![(0, 1.0)]);
    // Two schedules and none active: which one the pump runs is not known.
    let mut none = named.clone();
    none[0].as_object_mut().unwrap().remove("activeSchedule");
    let e = read(none).unwrap_err().to_string();
    assert!(e.contains("basalSchedules") && e.contains("$[0]"), "{e}");
    // Carb ratios in exchanges are refused, the field named.
    let mut ex = named;
    ex[0]["units"]["carb"] = "exchanges".into();
    let e = read(ex).unwrap_err().to_string();
    assert!(e.contains("units.carb") && e.contains("exchanges"), "{e}");
}
