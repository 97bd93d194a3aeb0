//! `abba metrics` run as a user would: the built binary on real files.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::{Command, Output};

const CORE_DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../core/tests/data");

/// Runs abba; `metrics` on a plain CSV gets `--units mg/dL` unless the
/// test gives units itself (plain CSV does not say its unit).
fn abba(args: &[&str]) -> Output {
    let mut args: Vec<&str> = args.to_vec();
    if args[0] == "metrics" && !args.contains(&"--units") && !args.contains(&"--no-units") {
        args.extend(["--units", "mg/dL"]);
    }
    args.retain(|a| *a != "--no-units");
    Command::new(env!("CARGO_BIN_EXE_abba"))
        .args(&args)
        .env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE")
        .output()
        .expect("run abba")
}

/// Writes `content` to a file of its own in the temp dir.
fn temp_csv(name: &str, content: &str) -> PathBuf {
    let path = std::env::temp_dir().join(format!(
        "abba_metrics_cli_{}_{name}.csv",
        std::process::id()
    ));
    std::fs::write(&path, content).unwrap();
    path
}

fn json_of(out: &Output) -> serde_json::Map<String, serde_json::Value> {
    assert!(
        out.status.success(),
        "abba failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v.as_object().unwrap().clone()
}

const KEYS: [&str; 15] = [
    "tir_70_180",
    "hypo_50_70",
    "severe_hypo_lt50",
    "hyper_180_300",
    "severe_hyper_gt300",
    "lbgi",
    "hbgi",
    "mage",
    "mean_mg_dl",
    "cv_pct",
    "gmi_pct",
    "below_54",
    "below_70",
    "above_180",
    "above_250",
];

#[test]
fn json_has_exactly_the_fifteen_keys_and_the_fixture_values() {
    let input = format!("{CORE_DATA}/synthetic_2day_5min.csv");
    // The fixture's glucose column is iglu's `gl`, found without --glucose-column.
    let out = abba(&["metrics", "--input", &input, "--json"]);
    let obj = json_of(&out);
    let mut got: Vec<&str> = obj.keys().map(|k| k.as_str()).collect();
    got.sort_unstable();
    let mut want = KEYS.to_vec();
    want.sort_unstable();
    assert_eq!(got, want);
    let fixture: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(format!("{CORE_DATA}/synthetic_2day_5min.metrics.json")).unwrap(),
    )
    .unwrap();
    for (key, fixture_key) in [
        ("tir_70_180", "in_range_percent_70_180"),
        ("mage", "mage_default"),
        ("mean_mg_dl", "mean_glu"),
        ("lbgi", "lbgi"),
        ("hbgi", "hbgi"),
    ] {
        let expected = fixture["iglu"][fixture_key].as_f64().unwrap();
        let got = obj[key].as_f64().unwrap();
        println!("{key}: expected {expected}, got {got}");
        assert!(
            (expected - got).abs() < 1e-6,
            "{key}: expected {expected}, got {got}"
        );
    }
}

#[test]
fn table_names_the_metrics() {
    let input = format!("{CORE_DATA}/iglu_example_data_1_subject.csv");
    let out = abba(&["metrics", "--input", &input]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("2915 readings"), "{text}");
    for key in KEYS {
        assert!(text.contains(key), "table lacks {key}:\n{text}");
    }
}

#[test]
fn mmol_per_litre_is_converted() {
    // 3.0 mmol/L = 54.05 mg/dL (not below 54), 10.0 mmol/L = 180.16 (above 180).
    let mmol = [3.0, 5.5, 10.0, 15.0, 20.0];
    let mut csv = String::from("time,glucose\n");
    for (i, v) in mmol.iter().enumerate() {
        csv.push_str(&format!("2024-01-01T00:{:02}:00Z,{v}\n", 5 * i));
    }
    let path = temp_csv("mmol", &csv);
    let out = abba(&[
        "metrics",
        "--input",
        path.to_str().unwrap(),
        "--units",
        "mmol/L",
        "--json",
    ]);
    std::fs::remove_file(&path).ok();
    let obj = json_of(&out);
    let expected_mean = 18.0156 * mmol.iter().sum::<f64>() / 5.0;
    let got = obj["mean_mg_dl"].as_f64().unwrap();
    println!("mean_mg_dl: expected {expected_mean}, got {got}");
    assert!((got - expected_mean).abs() < 1e-9);
    assert_eq!(obj["below_54"].as_f64(), Some(0.0));
    assert_eq!(obj["above_180"].as_f64(), Some(60.0));
    assert_eq!(obj["tir_70_180"].as_f64(), Some(20.0));
    assert!(obj["mage"].is_null(), "5 readings hold no MAGE");
}

#[test]
fn a_bad_row_names_file_line_column_and_value() {
    let path = temp_csv(
        "bad_row",
        "id,time,glucose\np,2024-01-01 00:00:00,100\np,2024-01-01 00:05:00,110\np,2024-01-01 00:10:00,12O\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    // The row is left out and reported; the other two are read.
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("note: ") && err.contains("1 row or item could not be read"),
        "{err}"
    );
    for part in [path.to_str().unwrap(), "line 4", "\"glucose\"", "\"12O\""] {
        assert!(err.contains(part), "error lacks {part}: {err}");
    }
}

#[test]
fn a_bad_time_or_a_non_positive_glucose_is_rejected() {
    let path = temp_csv(
        "bad_time",
        "time,glucose\n2024-01-01 00:00,100\n2024-02-30 00:05,110\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("line 3") && err.contains("2024-02-30 00:05"),
        "{err}"
    );

    let path = temp_csv(
        "zero",
        "time,glucose\n2024-01-01 00:00,100\n2024-01-01 00:05,0\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("line 3") && err.contains("plausible range 10..1000"),
        "{err}"
    );
}

#[test]
fn a_missing_column_names_the_columns_found() {
    let path = temp_csv(
        "missing_col",
        "when,bg\n2024-01-01 00:00,100\n2024-01-01 00:05,110\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("\"time\"") && err.contains("\"when\", \"bg\""),
        "{err}"
    );

    let out = abba(&[
        "metrics",
        "--input",
        path.to_str().unwrap(),
        "--time-column",
        "when",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("glucose") && err.contains("\"when\", \"bg\""),
        "{err}"
    );

    let out = abba(&[
        "metrics",
        "--input",
        path.to_str().unwrap(),
        "--time-column",
        "when",
        "--glucose-column",
        "bg",
        "--json",
    ]);
    std::fs::remove_file(&path).ok();
    assert_eq!(json_of(&out)["mean_mg_dl"].as_f64(), Some(105.0));
}

#[test]
fn readings_in_any_order_are_sorted_and_a_second_value_at_the_same_time_is_an_error() {
    // Exports come newest first (Nightscout) or interleaved: order is not an error.
    let csv = "time,glucose\n2024-01-01 00:10,120\n2024-01-01 00:00,100\n2024-01-01 00:05,110\n";
    let path = temp_csv("order", csv);
    let out = abba(&["metrics", "--input", path.to_str().unwrap(), "--json"]);
    std::fs::remove_file(&path).ok();
    assert_eq!(json_of(&out)["mean_mg_dl"].as_f64(), Some(110.0));

    let path = temp_csv(
        "dup",
        "time,glucose\n2024-01-01 00:00,100\n2024-01-01T00:00:00,101\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("line 3") && err.contains("line 2") && err.contains("same time"),
        "{err}"
    );
}

#[test]
fn plain_csv_needs_units() {
    let path = temp_csv(
        "nounits",
        "time,glucose\n2024-01-01 00:00,100\n2024-01-01 00:05,110\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap(), "--no-units"]);
    std::fs::remove_file(&path).ok();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("does not say its unit") && err.contains("--units"),
        "{err}"
    );
}

#[test]
fn implausible_values_are_refused_with_the_limit_named() {
    // Issue 8 item 7: 1e308 and 0.0001 mg/dL were accepted without a word.
    for v in ["1e308", "0.0001"] {
        let path = temp_csv(
            "implausible",
            &format!("time,glucose\n2024-01-01 00:00,100\n2024-01-01 00:05,{v}\n"),
        );
        let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
        std::fs::remove_file(&path).ok();
        assert!(!out.status.success(), "{v} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("line 3") && err.contains("\"glucose\"") && err.contains("10..1000 mg/dL"),
            "{err}"
        );
    }
}

#[test]
fn a_one_year_gap_is_reported_and_warned_about() {
    let mut csv = String::from("time,glucose\n");
    for day in ["2023-01-01", "2024-01-01"] {
        for i in 0..12 {
            csv.push_str(&format!("{day} 00:{:02},{}\n", 5 * i, 100 + i));
        }
    }
    let path = temp_csv("gap", &csv);
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        err.contains("warning: CGM coverage") && err.contains("70 %"),
        "{err}"
    );
    // 365 days minus the 55 minutes of the first hour.
    let gap = 365.0 * 1440.0 - 55.0;
    assert!(
        text.contains(&format!("longest gap {gap:.0} min")),
        "{text}"
    );
}

#[test]
fn crlf_files_name_the_right_line() {
    let path = temp_csv(
        "crlf",
        "time,glucose\r\n2024-01-01 00:00,100\r\n2024-01-01 00:05,110\r\n2024-01-01 00:10,x\r\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 4,") && err.contains("\"x\""), "{err}");
}

#[test]
fn mixing_times_with_and_without_offset_is_rejected() {
    let path = temp_csv(
        "mixed",
        "time,glucose\n2024-01-01 00:00,100\n2024-01-01T00:05:00+01:00,110\n",
    );
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    std::fs::remove_file(&path).ok();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("line 3") && err.contains("mix"), "{err}");
}

#[test]
fn several_subjects_need_a_choice() {
    let csv = "id,time,gl\na,2024-01-01 00:00,100\na,2024-01-01 00:05,120\nb,2024-01-01 00:00,200\nb,2024-01-01 00:05,220\n";
    let path = temp_csv("subjects", csv);
    let out = abba(&["metrics", "--input", path.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("line 4") && err.contains("--subject"), "{err}");
    let out = abba(&[
        "metrics",
        "--input",
        path.to_str().unwrap(),
        "--subject",
        "b",
        "--json",
    ]);
    assert_eq!(json_of(&out)["mean_mg_dl"].as_f64(), Some(210.0));
    let out = abba(&[
        "metrics",
        "--input",
        path.to_str().unwrap(),
        "--subject",
        "c",
    ]);
    std::fs::remove_file(&path).ok();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("no rows with id \"c\""));
}

#[test]
fn too_few_cgm_readings_says_what_the_file_held_and_why() {
    // A FreeStyle Libre "Patient report" writes every row as record type
    // 1 (scan): no CGM reading. The error counts the rows by kind and the
    // note says why they are not CGM (abba-io's fixture, in the layout of
    // cgmanalysis' Libre.csv).
    let file = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../io/tests/data/libreview_patient_report_mdyy_synthetic.csv"
    );
    let out = abba(&[
        "metrics",
        "--input",
        file,
        "--tz",
        "America/Denver",
        "--no-units",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("need at least 2 CGM readings in the chosen days, found 0; the records read: 8 scan glucose (counted, not read) (see the notes above)")
            && err.contains("the 8 rows of record type 1 (scan glucose) are counted, not read as CGM"),
        "{err}"
    );
}
