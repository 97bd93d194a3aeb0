//! `abba simulate` end to end: the reference day, and clear errors.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

fn abba() -> Command {
    Command::new(env!("CARGO_BIN_EXE_abba"))
}

fn tmp(name: &str) -> crate::cli_common::TmpPath {
    crate::cli_common::tmp_path("abba-sim-cli-", name)
}

const REFERENCE: &str = include_str!("../../sim/tests/data/reference-adult001.csv");

#[test]
fn replays_the_reference_day_within_0_05_mg_dl() {
    let input = tmp("ref.csv");
    std::fs::write(&input, REFERENCE).unwrap();
    let out = tmp("ref-out.csv");
    let st = abba()
        .args(["simulate", "--patient", "adult#001", "--inputs"])
        .arg(&input)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let got = std::fs::read_to_string(&out).unwrap();
    let mut lines = got.lines();
    assert!(lines.next().unwrap().starts_with("minute,bg_mg_dl"));
    let expected: Vec<f64> = REFERENCE
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let ours: Vec<f64> = lines
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    // The reference has 1441 input rows (minute 1440 carries inputs too), so
    // the output has rows for minutes 0..=1441.
    assert_eq!(ours.len(), expected.len() + 1);
    for (m, (a, b)) in expected.iter().zip(&ours).enumerate() {
        assert!((a - b).abs() < 0.05, "minute {m}: expected {a}, got {b}");
    }
}

fn error_of(tag: &str, input: &str) -> String {
    let path = tmp(&format!("bad-{tag}.csv"));
    std::fs::write(&path, input).unwrap();
    let out = abba()
        .args(["simulate", "--patient", "adult#001", "--inputs"])
        .arg(&path)
        .arg("--out")
        .arg(tmp(&format!("bad-out-{tag}.csv")))
        .output()
        .unwrap();
    assert!(!out.status.success(), "expected failure for {input:?}");
    String::from_utf8(out.stderr).unwrap()
}

#[test]
fn a_final_glucose_row_without_inputs_is_accepted_only_at_the_end() {
    // The reference layout: the last row holds only the final glucose.
    let mut text: String = REFERENCE.lines().take(1441).collect::<Vec<_>>().join("\n");
    text.push_str("\n1440,125.17,,\n");
    let input = tmp("final-row.csv");
    std::fs::write(&input, &text).unwrap();
    let out = tmp("final-row-out.csv");
    let st = abba()
        .args(["simulate", "--patient", "adult#001", "--inputs"])
        .arg(&input)
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let got = std::fs::read_to_string(&out).unwrap();
    // Minutes 0..=1440 plus the header.
    assert_eq!(got.lines().count(), 1442);
    let last: f64 = got
        .lines()
        .last()
        .unwrap()
        .split(',')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    assert!((last - 125.167610798).abs() < 0.05, "final glucose {last}");
    // An empty row in the middle is an error naming both lines.
    let e = error_of(
        "mid",
        "minute,cho_g_per_min,insulin_u_per_min\n0,0,0.02\n1,,\n2,0,0.02\n",
    );
    assert!(
        e.contains("line 3") && e.contains("line 4") && e.contains("last row"),
        "{e}"
    );
    // One empty cell is an error.
    let e = error_of(
        "one",
        "minute,cho_g_per_min,insulin_u_per_min\n0,0,0.02\n1,,0.02\n",
    );
    assert!(e.contains("line 3") && e.contains("cho_g_per_min"), "{e}");
}

#[test]
fn bad_inputs_give_clear_errors() {
    let e = error_of(
        "a",
        "minute,cho_g_per_min,insulin_u_per_min\n0,0,0.02\n1,x,0.02\n",
    );
    assert!(
        e.contains("line 3") && e.contains("cho_g_per_min") && e.contains("'x'"),
        "{e}"
    );
    let e = error_of("b", "minute,cho_g_per_min,insulin_u_per_min\n0,0,-0.02\n");
    assert!(
        e.contains("line 2") && e.contains("insulin_u_per_min") && e.contains(">= 0"),
        "{e}"
    );
    let e = error_of("c", "minute,cho,insulin_u_per_min\n0,0,0.02\n");
    assert!(
        e.contains("missing column 'cho_g_per_min'") && e.contains("found minute,cho"),
        "{e}"
    );
    let e = error_of(
        "d",
        "minute,cho_g_per_min,insulin_u_per_min\n0,0,0.02\n2,0,0.02\n",
    );
    assert!(
        e.contains("line 3") && e.contains("expected minute 1"),
        "{e}"
    );
    let e = error_of("e", "minute,cho_g_per_min,insulin_u_per_min\n");
    assert!(e.contains("no input rows"), "{e}");
}

#[test]
fn unknown_patient_and_missing_file_are_errors() {
    let out = abba()
        .args([
            "simulate",
            "--patient",
            "adult#042",
            "--day",
            "standard",
            "--out",
        ])
        .arg(tmp("x.csv"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("adult#042"));
    let out = abba()
        .args([
            "simulate",
            "--patient",
            "adult#001",
            "--inputs",
            "/nonexistent/in.csv",
            "--out",
        ])
        .arg(tmp("y.csv"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/in.csv"));
}

#[test]
fn built_in_day_runs() {
    let out = tmp("day.csv");
    let st = abba()
        .args([
            "simulate",
            "--patient",
            "child#003",
            "--day",
            "overlapping-meals",
            "--states",
        ])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().count(), 1442);
    assert!(text.lines().next().unwrap().ends_with(",gs,dbar_mg"));
}

#[test]
fn inputs_out_replays_to_the_same_glucose() {
    let (day_out, inputs, replay) = (
        tmp("io-day.csv"),
        tmp("io-inputs.csv"),
        tmp("io-replay.csv"),
    );
    let st = abba()
        .args([
            "simulate",
            "--patient",
            "adolescent#004",
            "--day",
            "missed-boluses",
            "--out",
        ])
        .arg(&day_out)
        .arg("--inputs-out")
        .arg(&inputs)
        .status()
        .unwrap();
    assert!(st.success());
    let text = std::fs::read_to_string(&inputs).unwrap();
    assert_eq!(
        text.lines().next().unwrap(),
        "minute,cho_g_per_min,insulin_u_per_min"
    );
    assert_eq!(text.lines().count(), 1 + 1440);
    let st = abba()
        .args(["simulate", "--patient", "adolescent#004", "--inputs"])
        .arg(&inputs)
        .arg("--out")
        .arg(&replay)
        .status()
        .unwrap();
    assert!(st.success());
    assert_eq!(
        std::fs::read(&day_out).unwrap(),
        std::fs::read(&replay).unwrap()
    );
}
