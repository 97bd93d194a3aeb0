//! `abba` on Tidepool's Excel export: detected from its sheets, its pump
//! settings a therapy for `person new --therapy-from`, imported, and the
//! JSON of the same data imported after it adds nothing; `--format
//! tidepool-xlsx` named; another workbook refused with its sheets.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::cli_common::{abba, ok};
use crate::tidepool_workbook::{person_data, workbook, Options};

/// A fresh directory for `tag`, removed when dropped.
fn tmp(tag: &str) -> crate::cli_common::TmpPath {
    crate::cli_common::tmp_path(&format!("abba-tidepool-cli-{tag}-"), "")
}

#[test]
fn a_tidepool_workbook_through_the_cli() {
    let dir = tmp("xlsx");
    let xlsx = dir.join("TidepoolExport.xlsx");
    let json = dir.join("TidepoolExport.json");
    let data = person_data();
    let bytes = workbook(
        &data,
        &Options {
            bg_units: "mg/dL",
            ..Options::default()
        },
    );
    std::fs::write(&xlsx, &bytes).unwrap();
    std::fs::write(&json, serde_json::to_vec(&data).unwrap()).unwrap();
    let (x, j) = (xlsx.to_str().unwrap(), json.to_str().unwrap());
    let db = dir.join("abba.db");
    let db = db.to_str().unwrap();
    let text = ok(&abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "tia",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--therapy-from",
        x,
    ]));
    // The Standard schedule's two rates and the carb ratios 10/12.
    assert!(text.contains("0.8") && text.contains("12"), "{text}");
    let first = ok(&abba(&["import", "--db", db, "--person", "tia", x]));
    assert!(first.contains("Imported"), "{first}");
    let again = ok(&abba(&["import", "--db", db, "--person", "tia", j]));
    assert!(again.contains("Nothing new"), "{again}");
    // Named as a format; another format for a workbook is refused.
    let events = ok(&abba(&[
        "events",
        "--input",
        x,
        "--tz",
        "Europe/Zurich",
        "--format",
        "tidepool-xlsx",
    ]));
    assert!(events.contains("cgm"), "{events}");
    let out = abba(&[
        "events",
        "--input",
        x,
        "--tz",
        "Europe/Zurich",
        "--format",
        "clarity",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("Excel workbook"),
        "{err}"
    );
}

#[test]
fn a_tidepool_workbook_of_a_pump_counting_exchanges_is_not_read_as_grams() {
    // The workbook writes a wizard's Carb Input without its unit; the
    // pump settings it holds say the pump counts exchanges.
    let dir = tmp("xlsx-exchanges");
    let xlsx = dir.join("TidepoolExport.xlsx");
    let mut data = person_data();
    let w = data.iter().position(|d| d["type"] == "wizard").unwrap();
    data[w]["carbInput"] = 4.into();
    let s = data
        .iter()
        .position(|d| d["type"] == "pumpSettings")
        .unwrap();
    data[s]["units"]["carb"] = "exchanges".into();
    std::fs::write(&xlsx, workbook(&data, &Options::default())).unwrap();
    let x = xlsx.to_str().unwrap();
    let db = dir.join("abba.db");
    let db = db.to_str().unwrap();
    ok(&abba(&[
        "person",
        "new",
        "--db",
        db,
        "--name",
        "tia",
        "--tz",
        "Europe/Zurich",
        "--mode",
        "cgm",
        "--basal",
        "0.8",
        "--carb-ratio",
        "10,12,12",
    ]));
    let text = ok(&abba(&["import", "--db", db, "--person", "tia", x]));
    assert!(
        text.contains("1 bolus wizard record (`wizard`) in exchanges")
            && text.contains("--grams-per-exchange"),
        "{text}"
    );
    let wizard_grams = |extra: &[&str]| -> Vec<f64> {
        let mut args = vec!["events", "--input", x, "--tz", "Europe/Zurich", "--json"];
        args.extend_from_slice(extra);
        let v: serde_json::Value = serde_json::from_str(&ok(&abba(&args))).unwrap();
        v["records"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|r| r["kind"]["type"] == "carbs" && r["at"] == "2026-05-04T05:30:00Z")
            .map(|r| r["kind"]["grams"].as_f64().unwrap())
            .collect()
    };
    assert!(wizard_grams(&[]).is_empty());
    assert_eq!(wizard_grams(&["--grams-per-exchange", "12"]), vec![48.0]);
}
