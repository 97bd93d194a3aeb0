//! Tidepool's Excel export: the same records as the JSON of the same data
//! (identities included), whichever glucose unit was chosen at export;
//! errors naming the sheet, the row and the column; units never guessed;
//! a workbook that is not Tidepool's refused by name; an export Tidepool
//! cut short noted.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{opts, read};
use crate::tidepool_workbook::{person_data, workbook, Options, MG_DL_PER_MMOL_L};
use abba_io::record::{OriginAt, Record};
use abba_io::{Format, ReadOptions, RecordKind};
use rust_xlsxwriter::Workbook;
use serde_json::Value;

fn json_bytes(data: &[Value]) -> Vec<u8> {
    serde_json::to_vec(data).unwrap()
}

/// The records without where they were read, in a stable order.
fn content(records: &[Record]) -> Vec<String> {
    let mut v: Vec<String> = records
        .iter()
        .map(|r| {
            format!(
                "{} {:?} {}",
                r.at,
                r.id,
                serde_json::to_string(&r.kind).unwrap()
            )
        })
        .collect();
    v.sort();
    v
}

/// Both read the same records (content and identity); a failure lists the
/// records only one of them has.
fn same(a: &[Record], b: &[Record], what: &str) {
    let (a, b) = (content(a), content(b));
    let only_a: Vec<&String> = a.iter().filter(|x| !b.contains(x)).collect();
    let only_b: Vec<&String> = b.iter().filter(|x| !a.contains(x)).collect();
    assert!(
        only_a.is_empty() && only_b.is_empty() && a.len() == b.len(),
        "{what}: only in the first {only_a:#?}, only in the second {only_b:#?}"
    );
}

fn xlsx(o: Options) -> Vec<u8> {
    workbook(&person_data(), &o)
}

#[test]
fn the_workbook_gives_the_records_of_the_json_in_either_unit() {
    let data = person_data();
    let o = opts("Europe/Zurich");
    let json = read(&[("TidepoolExport.json", json_bytes(&data))], &o).unwrap();
    assert_eq!(json.formats, vec![Format::Tidepool]);
    for bg_units in ["mmol/L", "mg/dL"] {
        let bytes = xlsx(Options {
            bg_units,
            ..Options::default()
        });
        let book = read(&[("TidepoolExport.xlsx", bytes)], &o).unwrap();
        assert_eq!(book.formats, vec![Format::TidepoolXlsx], "{bg_units}");
        assert_eq!(book.records.len(), json.records.len(), "{bg_units}");
        same(&book.records, &json.records, bg_units);
        assert_eq!(
            (&book.duplicates, &book.cross_upload),
            (&json.duplicates, &json.cross_upload),
            "{bg_units}"
        );
        assert!(book.notes.is_empty(), "{:?}", book.notes);
    }
    // What the records say (not only that both agree): 864 readings and the
    // high one, one carried twice; mmol/L times Tidepool's factor.
    assert_eq!(json.count("cgm"), 3 * 288 + 1);
    assert_eq!(json.cross_upload.get("cgm"), Some(&1));
    let high = json
        .records
        .iter()
        .find(|r| r.id == abba_io::SourceId::Id("cbg-high".into()))
        .unwrap();
    match &high.kind {
        RecordKind::Cgm { glucose } => {
            assert_eq!(glucose.mg_dl.0, 22.2 * MG_DL_PER_MMOL_L);
            assert_eq!(glucose.censor, abba_io::record::Censor::Above);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn durations_in_minutes_settings_and_food_are_read_as_the_data_model_says() {
    let b = read(
        &[("TidepoolExport.xlsx", xlsx(Options::default()))],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    let kind = |id: &str| {
        b.records
            .iter()
            .find(|r| r.id == abba_io::SourceId::Id(id.into()))
            .unwrap_or_else(|| panic!("{id}"))
            .kind
            .clone()
    };
    assert_eq!(
        kind("b2"),
        RecordKind::TempBasal {
            rate: abba_io::record::TempRate::Absolute(abba_core::UnitsPerHour(0.4)),
            duration_min: 30
        }
    );
    assert_eq!(
        kind("b4"),
        RecordKind::TempBasal {
            rate: abba_io::record::TempRate::Percent(50.0),
            duration_min: 60
        }
    );
    assert_eq!(
        kind("b5"),
        RecordKind::Suspend {
            duration_min: Some(15)
        }
    );
    assert_eq!(
        kind("bo2"),
        RecordKind::ExtendedBolus {
            now: abba_core::Units(2.0),
            extended: abba_core::Units(3.0),
            duration_min: 90
        }
    );
    assert_eq!(
        kind("w1"),
        RecordKind::Carbs {
            grams: abba_core::Grams(45.0)
        }
    );
    assert_eq!(
        kind("f1"),
        RecordKind::Carbs {
            grams: abba_core::Grams(20.0)
        }
    );
    // The settings' rows (3 basal segments, 2 carb ratios, a target) are
    // one datum again, named by its first row.
    let ps: Vec<&Record> = b
        .records
        .iter()
        .filter(|r| r.id == abba_io::SourceId::Id("ps1".into()))
        .collect();
    assert_eq!(ps.len(), 1);
    assert_eq!(
        b.origin(ps[0]),
        "TidepoolExport.xlsx: sheet \"Basal Schedules\", row 2"
    );
    let first_cgm = b.records.iter().find(|r| r.kind.name() == "cgm").unwrap();
    assert!(matches!(first_cgm.origin.at, OriginAt::Row { row: 2, .. }));
    assert_eq!(
        b.origin(first_cgm),
        "TidepoolExport.xlsx: sheet \"CGM\", row 2"
    );
}

/// A workbook of one sheet: `headers`, then `rows` of cells (a number, or
/// text), the first column a date serial.
/// File `name` read, and the record of the test's pump settings (`ps1`).
fn settings_record(name: &str, bytes: Vec<u8>, o: &ReadOptions) -> (abba_io::Batch, Record) {
    let b = read(&[(name, bytes)], o).unwrap();
    let ps = b
        .records
        .iter()
        .find(|r| r.id == abba_io::SourceId::Id("ps1".into()))
        .unwrap()
        .clone();
    (b, ps)
}

fn sheet(name: &str, headers: &[&str], rows: &[Vec<Value>]) -> Vec<u8> {
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    ws.set_name(name).unwrap();
    for (c, h) in headers.iter().enumerate() {
        ws.write_string(0, c as u16, *h).unwrap();
    }
    let date = rust_xlsxwriter::Format::new().set_num_format("yyyy-mm-dd hh:mm:ss");
    for (r, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let (r, c) = (r as u32 + 1, c as u16);
            match v {
                Value::Number(n) if c == 0 => {
                    ws.write_number_with_format(r, c, n.as_f64().unwrap(), &date)
                        .unwrap();
                }
                Value::Number(n) => {
                    ws.write_number(r, c, n.as_f64().unwrap()).unwrap();
                }
                Value::String(s) => {
                    ws.write_string(r, c, s).unwrap();
                }
                _ => {}
            }
        }
    }
    wb.save_to_buffer().unwrap()
}

const CGM: [&str; 5] = ["Zulu Time", "Tidepool Data Type", "Value", "Units", "Id"];

/// What reading refused: the workbook's error when none of it could be
/// read, else the first row left out (the other rows read, the row
/// reported in a note).
fn error(bytes: Vec<u8>, o: &ReadOptions) -> String {
    match read(&[("export.xlsx", bytes.clone())], o) {
        Err(e) => e.to_string(),
        Ok(_) => crate::common::read_in_part(&[("export.xlsx", bytes)], o).1,
    }
}

#[test]
fn a_reading_without_its_unit_is_refused_naming_sheet_row_and_column() {
    let t = crate::tidepool_workbook::serial(1_777_900_000_000);
    let ok = serde_json::json!([t, "cbg", 6.5, "mmol/L", "a"]);
    let bytes = sheet(
        "CGM",
        &CGM,
        &[
            ok.as_array().unwrap().clone(),
            serde_json::json!([t + 0.003, "cbg", 117, "", "b"])
                .as_array()
                .unwrap()
                .clone(),
        ],
    );
    let e = error(bytes, &opts("UTC"));
    assert!(e.contains("export.xlsx: sheet \"CGM\", row 3"), "{e}");
    assert!(e.contains("field \"Units\""), "{e}");
    assert!(e.contains("expected mmol/L or mg/dL"), "{e}");
    // Nor does --units stand in for the row's own unit.
    let given = ReadOptions {
        units: Some(abba_io::GlucoseUnit::MgDl),
        ..opts("UTC")
    };
    let bytes = sheet(
        "CGM",
        &CGM,
        &[serde_json::json!([t, "cbg", 117, "", "b"])
            .as_array()
            .unwrap()
            .clone()],
    );
    assert!(error(bytes, &given).contains("field \"Units\""));
}

#[test]
fn bad_cells_are_refused_naming_sheet_row_and_column() {
    let t = crate::tidepool_workbook::serial(1_777_900_000_000);
    let basal = [
        "Zulu Time",
        "Tidepool Data Type",
        "Delivery Type",
        "Duration (mins)",
        "Rate",
        "Id",
    ];
    let row = |cells: Value| cells.as_array().unwrap().clone();
    let e = error(
        sheet(
            "Basal",
            &basal,
            &[
                row(serde_json::json!([t, "basal", "scheduled", 60, 0.8, "a"])),
                row(serde_json::json!([
                    t,
                    "basal",
                    "temp",
                    "half an hour",
                    0.4,
                    "b"
                ])),
            ],
        ),
        &opts("UTC"),
    );
    assert!(e.contains("sheet \"Basal\", row 3"), "{e}");
    assert!(e.contains("field \"Duration (mins)\""), "{e}");
    // A rate beyond the plausible: the column is named.
    let e = error(
        sheet(
            "Basal",
            &basal,
            &[row(serde_json::json!([t, "basal", "temp", 30, 80, "b"]))],
        ),
        &opts("UTC"),
    );
    assert!(e.contains("sheet \"Basal\", row 2, field \"Rate\""), "{e}");
    // A time that is not a date.
    let e = error(
        sheet(
            "CGM",
            &CGM,
            &[row(serde_json::json!([
                "yesterday",
                "cbg",
                6.5,
                "mmol/L",
                "a"
            ]))],
        ),
        &opts("UTC"),
    );
    assert!(
        e.contains("sheet \"CGM\", row 2, field \"Zulu Time\"") && e.contains("yesterday"),
        "{e}"
    );
    // A row of another type on the CGM sheet.
    let e = error(
        sheet(
            "CGM",
            &CGM,
            &[row(serde_json::json!([t, "smbg", 6.5, "mmol/L", "a"]))],
        ),
        &opts("UTC"),
    );
    assert!(e.contains("field \"Tidepool Data Type\""), "{e}");
}

#[test]
fn a_workbook_that_is_not_tidepools_is_refused_by_name() {
    // CareLink's columns saved as a workbook.
    let carelink = sheet(
        "Sheet1",
        &["Index", "Date", "Time", "Sensor Glucose (mg/dL)"],
        &[serde_json::json!([1, "2026/05/04", "08:00:00", 120])
            .as_array()
            .unwrap()
            .clone()],
    );
    for format in [None, Some(Format::Tidepool)] {
        let o = ReadOptions {
            format,
            ..opts("UTC")
        };
        let e = error(carelink.clone(), &o);
        assert!(
            e.contains("sheets \"Sheet1\"") && e.contains("not Tidepool's export"),
            "{e}"
        );
        assert!(e.contains("CSV"), "{e}");
    }
    // Given as another format: refused, not read as text.
    let o = ReadOptions {
        format: Some(Format::CareLink),
        ..opts("UTC")
    };
    let e = error(carelink, &o);
    assert!(
        e.contains("Excel workbook") && e.contains("carelink"),
        "{e}"
    );
    // A sheet named as Tidepool's without Tidepool's header.
    let e = error(
        sheet(
            "CGM",
            &["Date", "Glucose"],
            &[vec![Value::from(1), Value::from(2)]],
        ),
        &opts("UTC"),
    );
    assert!(
        e.contains("sheet \"CGM\" has no \"Zulu Time\" column"),
        "{e}"
    );
    // A zip that is not a workbook.
    let e = error(b"PK\x03\x04not a workbook".to_vec(), &opts("UTC"));
    assert!(e.contains("not a readable Excel workbook"), "{e}");
}

#[test]
fn an_export_tidepool_cut_short_is_read_and_noted() {
    let whole = read(
        &[("TidepoolExport.xlsx", xlsx(Options::default()))],
        &opts("UTC"),
    )
    .unwrap();
    assert!(whole.notes.is_empty(), "{:?}", whole.notes);
    let cut = read(
        &[(
            "TidepoolExport.xlsx",
            xlsx(Options {
                cut_short: true,
                ..Options::default()
            }),
        )],
        &opts("UTC"),
    )
    .unwrap();
    assert_eq!(cut.records.len(), whole.records.len());
    assert_eq!(cut.notes.len(), 1, "{:?}", cut.notes);
    assert!(cut.notes[0].contains("EXPORT ERROR"), "{:?}", cut.notes);
    // No data at all: a NO DATA sheet, noted; the file reads as empty.
    let empty = read(
        &[("e.xlsx", workbook(&[], &Options::default()))],
        &opts("UTC"),
    )
    .unwrap();
    assert_eq!(empty.empty_files(), vec!["e.xlsx"]);
    assert!(empty.notes[0].contains("NO DATA"), "{:?}", empty.notes);
}

#[test]
fn a_truncated_or_damaged_workbook_is_an_error_never_a_panic() {
    let bytes = xlsx(Options::default());
    for cut in (4..bytes.len()).step_by(bytes.len() / 40) {
        let r = read(&[("t.xlsx", bytes[..cut].to_vec())], &opts("UTC"));
        assert!(r.is_err(), "cut at {cut} of {}", bytes.len());
    }
    let mut flipped = bytes.clone();
    for i in (100..flipped.len()).step_by(997) {
        flipped[i] ^= 0x5a;
    }
    let _ = read(&[("f.xlsx", flipped)], &opts("UTC"));
}

#[test]
fn pump_settings_are_the_active_profile_and_unreadable_ones_are_noted_not_fatal() {
    let data = person_data();
    let o = opts("Europe/Zurich");
    let expected = RecordKind::Schedule {
        profile: Box::new(abba_io::record::Profile {
            basal: abba_io::record::BasalSchedule {
                segments: vec![
                    (0, abba_core::UnitsPerHour(0.8)),
                    (360, abba_core::UnitsPerHour(1.0)),
                ],
            },
            carb_ratio: vec![
                (0, abba_core::GramsPerUnit(10.0)),
                (660, abba_core::GramsPerUnit(12.0)),
            ],
            timezone: None,
            temporary_min: None,
        }),
    };
    for (name, bytes) in [
        ("TidepoolExport.json", json_bytes(&data)),
        ("TidepoolExport.xlsx", workbook(&data, &Options::default())),
    ] {
        let (_, ps) = settings_record(name, bytes, &o);
        assert_eq!(ps.kind, expected, "{name}");
        assert_eq!(ps.at.to_string(), "2026-05-04T00:00:00Z");
    }
    // Carb ratios in exchanges: counted with a note naming the field, the
    // rest of the file read.
    let mut ex = data.clone();
    let i = ex.iter().position(|d| d["type"] == "pumpSettings").unwrap();
    ex[i]["units"]["carb"] = "exchanges".into();
    for (name, bytes) in [
        ("TidepoolExport.json", json_bytes(&ex)),
        ("TidepoolExport.xlsx", workbook(&ex, &Options::default())),
    ] {
        let (b, ps) = settings_record(name, bytes, &o);
        assert_eq!(
            ps.kind,
            RecordKind::Ignored {
                kind: "pumpSettings".into()
            },
            "{name}"
        );
        assert_eq!(b.count("cgm"), 3 * 288 + 1, "{name}");
        assert!(
            b.notes[0].contains("exchanges")
                && b.notes[0].contains("not read as a change of therapy"),
            "{name}: {:?}",
            b.notes
        );
        // The workbook writes the wizard's Carb Input without its unit:
        // the settings' exchanges are its unit (see the test below); the
        // data model's wizard, without `carbUnits`, is in grams.
        let wizard_notes = b
            .notes
            .iter()
            .filter(|n| n.contains("bolus wizard"))
            .count();
        let from_export = usize::from(name.ends_with(".xlsx"));
        assert_eq!(b.notes.len(), 1 + from_export, "{name}: {:?}", b.notes);
        assert_eq!(wizard_notes, from_export, "{name}: {:?}", b.notes);
    }
    // The workbook's note names the sheet, the row and the column.
    let b = read(
        &[("TidepoolExport.xlsx", workbook(&ex, &Options::default()))],
        &o,
    )
    .unwrap();
    assert!(
        b.notes[0].contains("sheet \"Basal Schedules\", row 2")
            && b.notes[0].contains("Carb Units"),
        "{:?}",
        b.notes
    );
}

#[test]
fn tidepool_webs_json_export_is_read_as_the_data_model_it_was_made_from() {
    let data = person_data();
    let o = opts("Europe/Zurich");
    let model = read(&[("api.json", json_bytes(&data))], &o).unwrap();
    for bg_units in ["mmol/L", "mg/dL"] {
        let bytes = crate::tidepool_workbook::export_json(&data, bg_units);
        let text = String::from_utf8(bytes.clone()).unwrap();
        // The export's form indeed: minutes, JSON text, split settings.
        assert!(text.contains("\"duration\":30") && text.contains("\"nutrition\":\"{"));
        assert!(text.contains("pumpSettings.basalSchedules"));
        let export = read(&[("TidepoolExport.json", bytes)], &o).unwrap();
        assert_eq!(export.formats, vec![Format::Tidepool]);
        assert_eq!(
            content(&export.records),
            content(&model.records),
            "{bg_units}"
        );
        assert!(export.notes.is_empty(), "{:?}", export.notes);
    }
    // A pen dose: the export leaves out its dose. Counted with a note, not
    // an error for the whole file; an export cut short is noted.
    let mut with_pen: Vec<Value> =
        serde_json::from_slice(&crate::tidepool_workbook::export_json(&data, "mmol/L")).unwrap();
    with_pen.push(serde_json::json!({"type": "insulin", "id": "pen1",
        "time": "2026-05-05T20:00:00.000Z", "timezoneOffset": 120}));
    with_pen.push(serde_json::json!({"exportError": "Due to the size of your export, ..."}));
    let b = read(&[("TidepoolExport.json", json_bytes(&with_pen))], &o).unwrap();
    assert_eq!(b.records.len(), model.records.len() + 1);
    assert_eq!(b.notes.len(), 2, "{:?}", b.notes);
    assert!(
        b.notes.iter().any(|n| n.contains("cut short")),
        "{:?}",
        b.notes
    );
    assert!(
        b.notes.iter().any(|n| n.contains("1 pen insulin")),
        "{:?}",
        b.notes
    );
}

/// A sheet with a value at A1 and one at XFD1048576 is two cells, not a
/// range of 17 billion: the reader once asked calamine for the dense
/// range (512 GiB) and the allocation failure aborted the process (`abba
/// serve` with it, from a clinic's upload of a 6 kB file).
#[test]
fn a_sheet_with_a_far_corner_cell_is_read_cell_by_cell() {
    let t = crate::tidepool_workbook::serial(1_777_900_000_000);
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    ws.set_name("CGM").unwrap();
    for (c, h) in CGM.iter().enumerate() {
        ws.write_string(0, c as u16, *h).unwrap();
    }
    let date = rust_xlsxwriter::Format::new().set_num_format("yyyy-mm-dd hh:mm:ss");
    ws.write_number_with_format(1, 0, t, &date).unwrap();
    ws.write_string(1, 1, "cbg").unwrap();
    ws.write_number(1, 2, 6.5).unwrap();
    ws.write_string(1, 3, "mmol/L").unwrap();
    ws.write_string(1, 4, "a").unwrap();
    // Column XFD of Excel's last row: under no header.
    ws.write_number(1_048_575, 16_383, 1.0).unwrap();
    let bytes = wb.save_to_buffer().unwrap();
    let e = error(bytes, &opts("UTC"));
    assert!(
        e.contains("row 1048576") && e.contains("CGM"),
        "the far row is named: {e}"
    );
}

/// A workbook whose parts hold more than abba reads once inflated (a zip
/// bomb: a few megabytes that inflate to gigabytes) is refused by
/// name from its declared sizes, before a part is inflated.
#[test]
fn a_workbook_inflating_past_the_limit_is_refused_before_it_is_inflated() {
    use std::io::Write;
    let t = crate::tidepool_workbook::serial(1_777_900_000_000);
    let ok = serde_json::json!([t, "cbg", 6.5, "mmol/L", "a"]);
    let small = sheet("CGM", &CGM, &[ok.as_array().unwrap().clone()]);
    // The same workbook with one more part of zeros past the limit.
    let mut zip = zip::ZipWriter::new_append(std::io::Cursor::new(small.clone())).unwrap();
    let options = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .compression_level(Some(1))
        .large_file(true);
    zip.start_file("xl/media/padding.bin", options).unwrap();
    let chunk = vec![0u8; 1 << 20];
    let limit = abba_io::read::tidepool_xlsx::MAX_INFLATED_BYTES;
    for _ in 0..=limit / (1 << 20) {
        zip.write_all(&chunk).unwrap();
    }
    let bomb = zip.finish().unwrap().into_inner();
    assert!(
        (bomb.len() as u64) * 64 < limit,
        "a small file: {} bytes",
        bomb.len()
    );
    // Without the padding the workbook is read.
    read(&[("export.xlsx", small)], &opts("UTC")).unwrap();
    let e = read(&[("export.xlsx", bomb)], &opts("UTC"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("export.xlsx")
            && e.contains("256 MiB")
            && e.contains("once uncompressed")
            && e.contains("shorter date range"),
        "{e}"
    );
}

/// The wizards' carbohydrate (its `Ignored` kinds counted and the grams
/// read) of `bytes` read with `grams_per_exchange`.
fn wizard_carbs(
    name: &str,
    bytes: Vec<u8>,
    grams_per_exchange: Option<f64>,
) -> (Vec<String>, Vec<f64>, Vec<String>) {
    let o = ReadOptions {
        grams_per_exchange,
        ..opts("Europe/Zurich")
    };
    let b = read(&[(name, bytes)], &o).unwrap();
    let wizard_at = "2026-05-04T05:30:00Z";
    let ignored = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Ignored { kind } if kind.starts_with("wizard") => Some(kind.clone()),
            _ => None,
        })
        .collect();
    let grams = b
        .records
        .iter()
        .filter(|r| r.at.to_string() == wizard_at)
        .filter_map(|r| match r.kind {
            RecordKind::Carbs { grams } => Some(grams.0),
            _ => None,
        })
        .collect();
    (ignored, grams, b.notes)
}

#[test]
fn a_wizards_carbohydrate_in_the_export_takes_its_unit_from_the_pump_settings() {
    // Tidepool's export writes a wizard's Carb Input without `carbUnits`:
    // a Medtronic pump counting exchanges would have its 4 exchanges read
    // as 4 g. Its pump settings' Carb Units say which.
    let mut data = person_data();
    let w = data.iter().position(|d| d["type"] == "wizard").unwrap();
    data[w]["carbInput"] = 4.into();
    let mut ex = data.clone();
    let s = ex.iter().position(|d| d["type"] == "pumpSettings").unwrap();
    ex[s]["units"]["carb"] = "exchanges".into();
    let exports = |d: &[Value]| {
        vec![
            ("TidepoolExport.xlsx", workbook(d, &Options::default())),
            (
                "TidepoolExport.json",
                crate::tidepool_workbook::export_json(d, "mmol/L"),
            ),
        ]
    };
    for (name, bytes) in exports(&ex) {
        let (ignored, grams, notes) = wizard_carbs(name, bytes.clone(), None);
        assert_eq!(
            ignored,
            ["wizard carbohydrate in exchanges (no --grams-per-exchange)"],
            "{name}"
        );
        assert!(grams.is_empty(), "{name}: {grams:?}");
        assert!(
            notes
                .iter()
                .any(|n| n.contains("1 bolus wizard record") && n.contains("exchanges")),
            "{name}: {notes:?}"
        );
        let (_, grams, _) = wizard_carbs(name, bytes, Some(12.0));
        assert_eq!(grams, [48.0], "{name}");
    }
    // Settings in grams: grams, as before.
    for (name, bytes) in exports(&data) {
        let (ignored, grams, _) = wizard_carbs(name, bytes, None);
        assert!(ignored.is_empty(), "{name}: {ignored:?}");
        assert_eq!(grams, [4.0], "{name}");
    }
    // No settings in the export, a Medtronic pump's upload: the unit is
    // not stated anywhere, so the carbohydrate is counted, not read.
    let mut none = data.clone();
    none.retain(|d| d["type"] != "pumpSettings");
    for (name, bytes) in exports(&none) {
        let (ignored, grams, notes) = wizard_carbs(name, bytes, Some(12.0));
        assert_eq!(
            ignored,
            ["wizard carbohydrate of unstated unit (Tidepool export)"],
            "{name}"
        );
        assert!(grams.is_empty(), "{name}: {grams:?}");
        assert!(
            notes.iter().any(|n| n.contains("1 bolus wizard record")
                && n.contains("Medtronic")
                && n.contains("grams are not assumed")),
            "{name}: {notes:?}"
        );
    }
    // Another maker's pump: grams, the data model's unit.
    let mut tandem = none.clone();
    for d in tandem.iter_mut().filter(|d| d["type"] == "upload") {
        d["deviceManufacturers"] = serde_json::json!(["Tandem"]);
    }
    for (name, bytes) in exports(&tandem) {
        let (ignored, grams, _) = wizard_carbs(name, bytes, None);
        assert!(ignored.is_empty(), "{name}: {ignored:?}");
        assert_eq!(grams, [4.0], "{name}");
    }
    // The API's data model carries `carbUnits` where it matters: without
    // it, grams.
    let (ignored, grams, _) = wizard_carbs("api.json", json_bytes(&none), None);
    assert!(ignored.is_empty(), "{ignored:?}");
    assert_eq!(grams, [4.0]);
}
