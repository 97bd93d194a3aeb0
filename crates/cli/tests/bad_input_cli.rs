//! Bad input to `simulate`, `cohort` and `trial` is refused up front with a
//! clear reason, and a failed command leaves no partial output.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::process::{Command, Output};

fn abba() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_abba"));
    c.env("RUST_BACKTRACE", "0");
    c
}

/// A fresh directory, removed when the test ends (it used to stay in the
/// temporary directory after every run).
struct Dir(tempfile::TempDir);

impl std::ops::Deref for Dir {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for Dir {
    fn as_ref(&self) -> &Path {
        self.0.path()
    }
}

fn dir(tag: &str) -> Dir {
    Dir(tempfile::Builder::new()
        .prefix(&format!("abba-bad-input-{tag}-"))
        .tempdir()
        .unwrap())
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `minutes` rows of basal, with `row` at minute 1.
fn inputs(row: &str, minutes: usize) -> String {
    let mut t = String::from("minute,cho_g_per_min,insulin_u_per_min\n0,0,0.02\n");
    t.push_str(&format!("1,{row}\n"));
    for m in 2..minutes {
        t.push_str(&format!("{m},0,0.02\n"));
    }
    t
}

fn simulate(input: &Path, out: &Path, extra: &[&str]) -> Output {
    abba()
        .args(["simulate", "--patient", "adult#001", "--inputs"])
        .arg(input)
        .arg("--out")
        .arg(out)
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn a_hundred_units_in_one_minute_is_refused_with_the_limit_named() {
    let d = dir("insulin");
    std::fs::write(d.join("in.csv"), inputs("0,100", 300)).unwrap();
    let o = simulate(&d.join("in.csv"), &d.join("out.csv"), &[]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("line 3") && e.contains("100 U/min") && e.contains("limit of 30.5 U/min"),
        "{e}"
    );
    assert!(!d.join("out.csv").exists());
}

#[test]
fn a_million_grams_is_refused_with_the_limit_named() {
    let d = dir("cho");
    std::fs::write(d.join("in.csv"), inputs("1000000,0", 10)).unwrap();
    let o = simulate(&d.join("in.csv"), &d.join("out.csv"), &[]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("cho_g_per_min") && e.contains("limit of 5 g/min"),
        "{e}"
    );
}

#[test]
fn an_overdose_that_drives_glucose_below_zero_writes_no_result() {
    // 30 U at once is a dose a pump can give, but for a child it drives the
    // model's glucose below 0 mg/dL.
    let d = dir("overdose");
    std::fs::write(d.join("in.csv"), inputs("0,30", 1440)).unwrap();
    let o = abba()
        .args(["simulate", "--patient", "child#001", "--inputs"])
        .arg(d.join("in.csv"))
        .arg("--out")
        .arg(d.join("out.csv"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("below 0") && e.contains("child#001, minute"),
        "{e}"
    );
    assert!(!d.join("out.csv").exists());
}

#[test]
fn a_failure_mid_run_leaves_no_partial_file_and_keeps_the_old_one() {
    let d = dir("solver");
    std::fs::write(d.join("in.csv"), inputs("0,0.02", 60)).unwrap();
    std::fs::write(d.join("out.csv"), "old result\n").unwrap();
    // A sensitivity of 1e300 wrecks the solution in the first minutes (the
    // glucose turns hugely negative, then the state non-finite), after the
    // header and the first rows were written.
    let o = simulate(
        &d.join("in.csv"),
        &d.join("out.csv"),
        &["--sensitivity", "1e300"],
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("minute 1"), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(d.join("out.csv")).unwrap(),
        "old result\n"
    );
    let left: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n != "in.csv" && n != "out.csv")
        .collect();
    assert!(left.is_empty(), "files left behind: {left:?}");
}

#[test]
fn out_equal_to_inputs_is_refused_and_the_input_kept() {
    let d = dir("same");
    let text = inputs("5,1", 30);
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(d.join("in.csv"), &text).unwrap();
    let o = simulate(&d.join("in.csv"), &d.join("sub/../in.csv"), &[]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("--out") && e.contains("--inputs") && e.contains("same file"),
        "{e}"
    );
    assert_eq!(std::fs::read_to_string(d.join("in.csv")).unwrap(), text);
}

#[test]
fn a_negative_sensitivity_is_read_as_a_value_and_refused_with_the_reason() {
    let d = dir("sensitivity");
    std::fs::write(d.join("in.csv"), inputs("0,0.02", 10)).unwrap();
    let o = simulate(
        &d.join("in.csv"),
        &d.join("out.csv"),
        &["--sensitivity", "-1"],
    );
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(!e.contains("unexpected argument"), "{e}");
    assert!(
        e.contains("--sensitivity must be a finite number > 0") && e.contains("got -1"),
        "{e}"
    );
}

#[test]
fn an_unknown_patient_lists_the_names_and_how_to_use_cohort_members() {
    let d = dir("names");
    let o = abba()
        .args([
            "simulate",
            "--patient",
            "adult#011",
            "--day",
            "standard",
            "--out",
        ])
        .arg(d.join("out.csv"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("adolescent#001..#010, adult#001..#010, child#001..#010")
            && e.contains("abba cohort")
            && e.contains("--cohort"),
        "{e}"
    );
}

#[test]
fn a_generated_cohort_member_is_simulated_from_the_cohort_table() {
    let d = dir("member");
    let table = d.join("cohort.csv");
    let o = abba()
        .args([
            "cohort",
            "--population",
            "children",
            "--size",
            "11",
            "--quiet",
            "--out",
        ])
        .arg(&table)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = abba()
        .args([
            "simulate",
            "--patient",
            "child#011",
            "--day",
            "standard",
            "--cohort",
        ])
        .arg(&table)
        .arg("--out")
        .arg(d.join("out.csv"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(d.join("out.csv"))
            .unwrap()
            .lines()
            .count(),
        1442
    );
}

#[test]
fn a_cohort_of_one_reports_no_standard_deviation_instead_of_nan() {
    let o = abba()
        .args(["cohort", "--size", "1", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(!text.contains("NaN"));
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(v["titration_vs_quest"]["sd_log_ratio"].is_null());
    let d = dir("one");
    let o = abba()
        .args(["cohort", "--size", "1", "--out"])
        .arg(d.join("c.csv"))
        .output()
        .unwrap();
    let line = String::from_utf8(o.stdout).unwrap();
    assert!(
        !line.contains("NaN") && line.contains("SD of log undefined"),
        "{line}"
    );
}

#[test]
fn an_impossible_cohort_size_is_refused_up_front() {
    let o = abba()
        .args(["cohort", "--size", "100000000", "--json"])
        .output()
        .unwrap();
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("100000000") && e.contains("between 1 and 100000"),
        "{e}"
    );
}

#[test]
fn a_trial_longer_than_the_advisors_clock_is_refused_up_front() {
    let d = dir("days");
    let o = abba()
        .args(["trial", "--days", "100000", "--quiet", "--out"])
        .arg(d.join("report"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.contains("days: 100000")
            && e.contains("limit of 36500 days")
            && e.contains("max_timestamp_min"),
        "{e}"
    );
    assert!(!d.join("report").exists());
    let o = abba()
        .args(["trial", "--patients", "200000", "--print-config"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("limit of 100000"), "{}", stderr(&o));
}

#[test]
fn an_error_cause_is_printed_once() {
    let d = dir("twice");
    let file = d.join("afile");
    std::fs::write(&file, "").unwrap();
    let o = abba()
        .args([
            "trial",
            "--patients",
            "1",
            "--days",
            "9",
            "--scenarios",
            "S1",
            "--arms",
            "standard",
            "--quiet",
            "--out",
        ])
        .arg(file.join("sub"))
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    // No folder can be made below a file: the report folder is checked
    // before the run, and the I/O error is its cause.
    assert!(e.contains("cannot create it"), "{e}");
    assert_eq!(e.matches("Not a directory").count(), 1, "{e}");
}

#[test]
fn a_one_patient_trial_reports_no_wilcoxon_p_value() {
    let d = dir("wilcoxon");
    let out = d.join("report");
    let o = abba()
        .args([
            "trial",
            "--patients",
            "1",
            "--scenarios",
            "S1",
            "--arms",
            "standard",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let tests = &summary["arms"]["S1/standard"]["wilcoxon"]["W1_vs_W13"];
    let tir = &tests["tir_70_180"];
    assert!(
        tir["statistic"].is_number() && tir["p"].is_null(),
        "{tests}"
    );
    let table = std::fs::read_to_string(out.join("table1.csv")).unwrap();
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "wilcoxon_p_vs_w1")
        .unwrap();
    for line in table.lines().skip(1) {
        assert_eq!(line.split(',').nth(col), Some(""), "{line}");
    }
}

#[test]
fn negative_counts_are_values_refused_with_the_flag_named() {
    let o = abba()
        .args(["cohort", "--size", "-3", "--json"])
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(!e.contains("unexpected argument"), "{e}");
    assert!(
        e.contains("--size must be between 1 and 100000, got -3"),
        "{e}"
    );
    let o = abba()
        .args(["trial", "--days", "-5", "--print-config"])
        .output()
        .unwrap();
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(!e.contains("unexpected argument"), "{e}");
    assert!(e.contains("'-5'") && e.contains("--days"), "{e}");
}
