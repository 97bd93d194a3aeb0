//! The shared format samples load, with their counts, and every format's
//! quirks are handled.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::record::{Censor, RecordKind, Source};
use abba_io::{Format, GlucoseUnit, IoError, ReadOptions};
use common::{fixture, opts, read};

#[test]
fn clarity_fixture_loads_with_its_counts_and_censored_values() {
    let b = read(
        &[("clarity.csv", fixture("clarity_export_synthetic.csv"))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::Clarity]);
    // 3922 EGV rows (5 of them Low/High), 47 insulin rows (33 fast-, 14
    // long-acting); the 10 preamble rows have no timestamp.
    assert_eq!(b.count("cgm"), 3922);
    assert_eq!(b.count("bolus"), 33);
    assert_eq!(b.count("long_acting"), 14);
    assert_eq!(b.records.len(), 3922 + 47);
    let censored: Vec<_> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Cgm { glucose } if glucose.censor != Censor::Exact => Some(glucose),
            _ => None,
        })
        .collect();
    assert_eq!(censored.len(), 5);
    for g in censored {
        match g.censor {
            Censor::Below => assert_eq!(g.mg_dl.0, 40.0),
            Censor::Above => assert_eq!(g.mg_dl.0, 400.0),
            Censor::Exact => unreachable!(),
        }
    }
    assert!(b.records.iter().all(|r| r.source == Source::Clarity));
    // Identity is the transmitter's own clock, never the row's Index.
    assert_eq!(
        b.records[0].id,
        abba_io::SourceId::Id("HBRPOI:4240874:EGV".into())
    );
    // The preamble's rows have no time, so no record: counted in a note
    // by their event type instead of passed over in silence.
    assert_eq!(b.notes.len(), 1, "{:?}", b.notes);
    assert!(
        b.notes[0].contains("10 rows without a time")
            && b.notes[0].contains("Alert 7")
            && b.notes[0].contains("FirstName 1"),
        "{}",
        b.notes[0]
    );
}

#[test]
fn libreview_fixture_loads_with_its_counts() {
    let b = read(
        &[("libre.csv", fixture("libreview_libre3_synthetic.csv"))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::LibreView]);
    assert_eq!(b.count("cgm"), 4305);
    let ignored = |k: &str| {
        b.records
            .iter()
            .filter(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == k))
            .count()
    };
    assert_eq!(ignored("scan glucose"), 316);
    // 936 note rows, 3 of them exact repeats of another row (same content
    // hash), counted as duplicates.
    assert_eq!(ignored("note or time change"), 933);
    assert_eq!(b.duplicates.get("ignored"), Some(&3));
    // Day-first times: 12-04-1961 22:30 is 12 April.
    let first = b
        .records
        .iter()
        .find(|r| r.origin.at == abba_io::record::OriginAt::Line(3))
        .unwrap();
    assert_eq!(first.at.to_string(), "1961-04-12T21:30:00Z");
}

#[test]
fn nightscout_fixtures_load_newest_first_with_their_counts() {
    let b = read(
        &[
            ("entries.json", fixture("nightscout_entries_synthetic.json")),
            (
                "treatments.json",
                fixture("nightscout_treatments_synthetic.json"),
            ),
            ("profile.json", fixture("nightscout_profile_synthetic.json")),
        ],
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(b.count("cgm"), 859);
    assert_eq!(b.count("smbg"), 3);
    assert_eq!(b.count("carbs"), 11);
    assert_eq!(b.count("bolus"), 11);
    assert_eq!(b.count("temp_basal"), 3);
    assert_eq!(b.count("basal_schedule"), 1);
    let profile = b
        .records
        .iter()
        .find_map(|r| match &r.kind {
            RecordKind::Schedule { profile } => Some(profile),
            _ => None,
        })
        .unwrap();
    let basal: Vec<(u32, f64)> = profile
        .basal
        .segments
        .iter()
        .map(|&(m, r)| (m, r.0))
        .collect();
    assert_eq!(basal, vec![(0, 0.8), (240, 0.95), (540, 0.8)]);
    assert_eq!(
        profile.carb_ratio.first().map(|&(m, r)| (m, r.0)),
        Some((0, 11.0))
    );
    assert_eq!(
        profile.carb_ratio.get(1).map(|&(m, r)| (m, r.0)),
        Some((360, 10.0))
    );
    assert_eq!(profile.timezone.as_deref(), Some("Europe/Zurich"));
    // Sensor Start, Site Change.
    assert_eq!(b.count("ignored"), 2);
    // The file is newest first; the stream is oldest first.
    assert!(b.records.windows(2).all(|w| w[0].at <= w[1].at));
    let temp = b
        .records
        .iter()
        .find(|r| r.kind.name() == "temp_basal")
        .unwrap();
    assert!(
        matches!(temp.kind, RecordKind::TempBasal { rate: abba_io::record::TempRate::Absolute(r), duration_min: 60 } if r.0 == 0.4)
    );
}

#[test]
fn duplicates_across_two_overlapping_exports_are_counted_once() {
    let all: Vec<serde_json::Value> =
        serde_json::from_slice(&fixture("nightscout_entries_synthetic.json")).unwrap();
    // Two exports: items 0..600 and 400..end (200 shared).
    let a = serde_json::to_vec(&all[..600]).unwrap();
    let b = serde_json::to_vec(&all[400..]).unwrap();
    let merged = read(&[("a.json", a), ("b.json", b)], &ReadOptions::default()).unwrap();
    let single = read(
        &[("all.json", fixture("nightscout_entries_synthetic.json"))],
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(merged.records.len(), single.records.len());
    assert_eq!(merged.duplicates.values().sum::<usize>(), 200);
    let kinds = |b: &abba_io::Batch| {
        b.records
            .iter()
            .map(|r| (r.at, r.kind.clone()))
            .collect::<Vec<_>>()
    };
    assert_eq!(kinds(&merged), kinds(&single));
}

/// The Clarity fixture with CRLF line ends and a bad value on line `line`.
fn clarity_crlf_with_bad_line(line: usize) -> Vec<u8> {
    let text = String::from_utf8(fixture("clarity_export_synthetic.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let mut cells: Vec<String> = lines[line - 1].split(',').map(str::to_string).collect();
    assert_eq!(cells[2], "EGV", "line {line} is not an EGV row");
    cells[7] = format!("x{}", cells[7]);
    lines[line - 1] = cells.join(",");
    (lines.join("\r\n") + "\r\n").into_bytes()
}

#[test]
fn crlf_files_report_the_right_line() {
    for line in [12, 500, 3001] {
        let (_, msg) = common::read_in_part(
            &[("c.csv", clarity_crlf_with_bad_line(line))],
            &opts("Europe/Zurich"),
        );
        assert!(
            msg.contains(&format!(
                "c.csv: line {line}, field \"Glucose Value (mg/dL)\""
            )),
            "{msg}"
        );
    }
    // The same with LF.
    let lf = String::from_utf8(clarity_crlf_with_bad_line(700))
        .unwrap()
        .replace("\r\n", "\n");
    let (_, msg) = common::read_in_part(&[("c.csv", lf.into_bytes())], &opts("Europe/Zurich"));
    assert!(msg.contains("line 700,"), "{msg}");
}

/// A LibreView export as a German-locale account writes it: semicolons,
/// decimal commas, mmol/L, day-first dates with dots.
fn libreview_semicolon_mmol() -> Vec<u8> {
    let mut s =
        String::from("Glukose-Daten;Erstellt am;01.02.2024 10:00 UTC;Erstellt von;Test\r\n");
    s.push_str("Device;Serial Number;Device Timestamp;Record Type;Historic Glucose mmol/L;Scan Glucose mmol/L;Rapid-Acting Insulin (units);Carbohydrates (grams)\r\n");
    for i in 0..12 {
        s.push_str(&format!(
            "FreeStyle Libre 2;X;01.02.2024 08:{:02};0;{},{};;;\r\n",
            i * 5,
            5 + i / 4,
            i % 10
        ));
    }
    s.push_str("FreeStyle Libre 2;X;01.02.2024 09:00;4;;;3,5;\r\n");
    s.push_str("FreeStyle Libre 2;X;01.02.2024 09:00;5;;;;45\r\n");
    s.into_bytes()
}

#[test]
fn libreview_with_semicolons_decimal_commas_and_mmol() {
    // Every date is 01.02.2024: day-first or month-first cannot be told
    // from the file, so it is an error unless the user says.
    let err = read(
        &[("de.csv", libreview_semicolon_mmol())],
        &opts("Europe/Berlin"),
    )
    .unwrap_err();
    assert!(err.to_string().contains("--date-order"), "{err}");
    let mut o = opts("Europe/Berlin");
    o.date_order = Some(abba_io::time::DateOrder::DayFirst);
    let b = read(&[("de.csv", libreview_semicolon_mmol())], &o).unwrap();
    assert_eq!(b.count("cgm"), 12);
    let first = match b.records[0].kind {
        RecordKind::Cgm { glucose } => glucose.mg_dl.0,
        _ => panic!(),
    };
    assert!(
        (first - 5.0 * abba_core::units::MG_DL_PER_MMOL_L).abs() < 1e-9,
        "{first}"
    );
    assert!(b
        .records
        .iter()
        .any(|r| matches!(r.kind, RecordKind::Bolus { units } if units.0 == 3.5)));
    assert!(b
        .records
        .iter()
        .any(|r| matches!(r.kind, RecordKind::Carbs { grams } if grams.0 == 45.0)));
    assert_eq!(b.records[0].at.to_string(), "2024-02-01T07:00:00Z");
}

#[test]
fn libreview_us_times_with_am_pm() {
    let mut s =
        String::from("Glucose Data,Generated on,05-02-2024 10:00 AM UTC,Generated by,Test\n");
    s.push_str("Device,Serial Number,Device Timestamp,Record Type,Historic Glucose mg/dL,Scan Glucose mg/dL\n");
    s.push_str("FreeStyle Libre 3,X,05-01-2024 12:03 AM,0,100,\n");
    s.push_str("FreeStyle Libre 3,X,05-01-2024 12:08 PM,1,,120\n");
    // AM/PM does not tell the order (LibreView writes `20-12-2021 11:15
    // PM` too) and no day is above 12: --date-order is needed.
    let err = read(
        &[("us.csv", s.clone().into_bytes())],
        &opts("America/New_York"),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("--date-order"), "{err}");
    let o = ReadOptions {
        date_order: Some(abba_io::time::DateOrder::MonthFirst),
        ..opts("America/New_York")
    };
    let b = read(&[("us.csv", s.into_bytes())], &o).unwrap();
    assert_eq!(b.records[0].at.to_string(), "2024-05-01T04:03:00Z");
    assert_eq!(b.records[1].at.to_string(), "2024-05-01T16:08:00Z");
}

const TIDEPOOL: &str = r#"[
 {"id":"a3","type":"cbg","time":"2024-03-04T08:10:00.000Z","units":"mmol/L","value":7.3},
 {"id":"a1","type":"cbg","time":"2024-03-04T08:00:00.000Z","units":"mmol/L","value":5.55062},
 {"id":"a2","type":"smbg","time":"2024-03-04T08:05:00.000Z","units":"mg/dL","value":101},
 {"id":"b1","type":"bolus","subType":"normal","time":"2024-03-04T08:06:00.000Z","normal":4.5},
 {"id":"b2","type":"bolus","subType":"dual/square","time":"2024-03-04T18:00:00.000Z","normal":2,"extended":3,"duration":7200000},
 {"id":"c1","type":"basal","deliveryType":"scheduled","time":"2024-03-04T00:00:00.000Z","rate":0.8,"duration":86400000},
 {"id":"c2","type":"basal","deliveryType":"temp","time":"2024-03-04T03:00:00.000Z","rate":0.4,"duration":3600000},
 {"id":"c3","type":"basal","deliveryType":"suspend","time":"2024-03-04T05:00:00.000Z","duration":1800000},
 {"id":"d1","type":"food","time":"2024-03-04T08:06:00.000Z","nutrition":{"carbohydrate":{"net":45,"units":"grams"}}},
 {"id":"e1","type":"deviceEvent","subType":"reservoirChange","time":"2024-03-04T12:00:00.000Z"},
 {"id":"f1","type":"upload","time":"2024-03-05T00:00:00.000Z"}
]"#;

#[test]
fn tidepool_mmol_uses_tidepools_factor() {
    let b = read(
        &[("tp.json", TIDEPOOL.as_bytes().to_vec())],
        &ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(b.formats, vec![abba_io::Format::Tidepool]);
    assert_eq!(b.count("cgm"), 2);
    assert_eq!(b.count("smbg"), 1);
    assert_eq!(b.count("bolus"), 1);
    assert_eq!(b.count("extended_bolus"), 1);
    assert_eq!(b.count("temp_basal"), 1);
    assert_eq!(b.count("suspend"), 1);
    assert_eq!(b.count("carbs"), 1);
    assert_eq!(b.count("ignored"), 2);
    let cgm = b.records.iter().find(|r| r.kind.name() == "cgm").unwrap();
    match cgm.kind {
        RecordKind::Cgm { glucose } => assert!((glucose.mg_dl.0 - 5.55062 * 18.01559).abs() < 1e-9),
        _ => unreachable!(),
    }
    assert_eq!(cgm.id, abba_io::SourceId::Id("a1".into()));
}

#[test]
fn plain_csv_needs_units_and_catches_mmol_read_as_mg() {
    let csv = "time,glucose\n2024-01-01 00:00,5.5\n2024-01-01 00:05,6.1\n2024-01-01 00:10,6.0\n";
    let err = read(&[("p.csv", csv.into())], &ReadOptions::default()).unwrap_err();
    assert!(
        matches!(err, IoError::Units { .. }) && err.to_string().contains("--units"),
        "{err}"
    );
    let o = ReadOptions {
        units: Some(GlucoseUnit::MgDl),
        ..ReadOptions::default()
    };
    let err = read(&[("p.csv", csv.into())], &o).unwrap_err().to_string();
    assert!(err.contains("line 2") && err.contains("mmol/L"), "{err}");
    let o = ReadOptions {
        units: Some(GlucoseUnit::MmolL),
        ..ReadOptions::default()
    };
    assert_eq!(read(&[("p.csv", csv.into())], &o).unwrap().count("cgm"), 3);
    // Values all plausible in mg/dL range but a median of 20: looks like mmol/L.
    let csv = "time,glucose\n2024-01-01 00:00,18\n2024-01-01 00:05,20\n2024-01-01 00:10,22\n";
    let o = ReadOptions {
        units: Some(GlucoseUnit::MgDl),
        ..ReadOptions::default()
    };
    let err = read(&[("p.csv", csv.into())], &o).unwrap_err().to_string();
    assert!(err.contains("median") && err.contains("mmol/L"), "{err}");
    // A unit in the column name is read from the file.
    let csv = "time,glucose_mmol_l\n2024-01-01 00:00,5.5\n2024-01-01 00:05,6.1\n";
    assert_eq!(
        read(&[("p.csv", csv.into())], &ReadOptions::default())
            .unwrap()
            .count("cgm"),
        2
    );
}

#[test]
fn implausible_values_name_file_line_and_field() {
    for (value, fragment) in [
        ("1e308", "plausible"),
        ("0.0001", "plausible"),
        ("abc", "expected a glucose number"),
    ] {
        let csv = format!("time,glucose_mg_dl\n2024-01-01 00:00,100\n2024-01-01 00:05,{value}\n");
        // Line 3 is left out and reported; line 2 is read.
        let (b, err) = common::read_in_part(&[("p.csv", csv.into())], &ReadOptions::default());
        assert_eq!(b.count("cgm"), 1);
        assert!(
            err.contains("p.csv: line 3, field \"glucose_mg_dl\"") && err.contains(fragment),
            "{err}"
        );
    }
    let bad = r#"[{"_id":"x","type":"sgv","date":1700000000000},{"_id":"y","type":"sgv","date":1700000300000,"sgv":5000}]"#;
    let err = read(&[("e.json", bad.into())], &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("e.json: $[0], field \"sgv\""), "{err}");
    let bad = r#"[{"_id":"y","eventType":"Correction Bolus","created_at":"2024-01-01T00:00:00Z","insulin":100}]"#;
    let err = read(&[("t.json", bad.into())], &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("t.json: $[0].insulin, field \"insulin\"") && err.contains("0..50"),
        "{err}"
    );
}

#[test]
fn clarity_needs_a_zone_and_a_unit_that_agrees() {
    let err = read(
        &[("c.csv", fixture("clarity_export_synthetic.csv"))],
        &ReadOptions::default(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("--tz"), "{err}");
    let mut o = opts("Europe/Zurich");
    o.units = Some(GlucoseUnit::MmolL);
    let err = read(&[("c.csv", fixture("clarity_export_synthetic.csv"))], &o).unwrap_err();
    assert!(err.to_string().contains("--units"), "{err}");
}
