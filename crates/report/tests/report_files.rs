//! The trial report built from synthetic results with known numbers:
//! schema of summary.json, hand-computed summaries and tests, Table I with
//! the paper's values, patients.csv, SVG figures, short trials, bad input,
//! byte-identical output.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use abba_advisor::Mode;
use abba_core::metrics::GlucoseMetrics;
use abba_core::{Metric, ScenarioId};
use abba_report::html::{HtmlSection, Row};
use abba_report::results::{
    evaluation_windows, ArmKind, ArmResult, PatientResult, RunFailure, Week, WeekResult,
};
use abba_report::{
    build_report, build_report_with, patients_csv::patients_csv, summary::summary_json, table1,
    ReportDir, ReportExtras, W1Block, REPORT_FILES, W1_FILE,
};
use serde_json::{json, Value};

/// The 16 metric keys in the protocol's order.
fn metric_keys() -> Vec<&'static str> {
    Metric::ALL.map(Metric::key).to_vec()
}

/// A folder of this test run under the target's temporary folder, removed
/// first (a folder of an older build may hold an older report).
fn fresh_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The report's files when no W1 block was computed.
fn report_files_without_w1() -> Vec<&'static str> {
    REPORT_FILES.into_iter().filter(|f| *f != W1_FILE).collect()
}

/// A W1 block with recognisable content.
fn w1_block(tag: &str) -> W1Block {
    W1Block {
        markdown: format!("## W1 sensitivity {tag}\n"),
        section: HtmlSection {
            title: format!("W1 sensitivity {tag}"),
            note: "each row re-runs W1".to_string(),
            headers: vec!["Variant".to_string(), "n".to_string()],
            rows: vec![Row::of(["as configured", "3"])],
        },
    }
}

/// Builds the report and writes it into `dir` (checked first).
fn write_report(dir: &Path, arms: &[ArmResult], manifest: &Value) -> Vec<PathBuf> {
    let out = ReportDir::prepare(dir).unwrap();
    let built = build_report(arms, manifest, None).unwrap();
    out.write_report(&built).unwrap()
}

fn metrics(tir: f64, hypo: f64, lbgi: f64, mage: Option<f64>) -> GlucoseMetrics {
    GlucoseMetrics {
        tir_70_180: tir,
        hypo_50_70: hypo,
        severe_hypo_lt50: 0.5 * hypo,
        hyper_180_300: 100.0 - tir - 1.5 * hypo,
        severe_hyper_gt300: 0.0,
        lbgi,
        hbgi: 2.0 + 0.1 * lbgi,
        mage,
        mean_mg_dl: 140.0 + tir / 10.0,
        cv_pct: 30.0,
        gmi_pct: 3.31 + 0.02392 * (140.0 + tir / 10.0),
        below_54: 0.4 * hypo,
        below_70: 1.5 * hypo,
        above_180: 100.0 - tir - 1.5 * hypo,
        above_250: 1.0,
        sd_mg_dl: 42.0,
        n_readings: 2016,
    }
}

fn week(name: &str, m: GlucoseMetrics, tdi: f64) -> WeekResult {
    let (week, first_day, last_day) = evaluation_windows()
        .into_iter()
        .find(|(w, _, _)| w.name() == name)
        .unwrap();
    WeekResult {
        week,
        first_day,
        last_day,
        metrics: m,
        tdi_u_per_day: tdi,
        plasma_5min_mg_dl: Vec::new(),
    }
}

fn patient(name: &str, weeks: Vec<WeekResult>) -> PatientResult {
    PatientResult {
        patient: name.to_string(),
        weeks,
        final_basal_u_per_h: 0.85,
        final_carb_ratio_g_per_u: [9.5, 10.0, 11.25],
        start_basal_u_per_h: 0.9,
        start_carb_ratio_g_per_u: 10.0,
        pump_capped: 0,
        min_glucose_mg_dl: 61.5,
        failure: None,
        rescue_carbs_g: 0.0,
        rescue_treatments: 0,
        twin_check: None,
    }
}

/// Three patients; TIR in W1 = 80, 90, 100 and in W13 = 81, 92, 104
/// (d = 1, 2, 4); MAGE of patient 3 undefined in W13; weeks W1, W2, W13, W14.
fn small_arm(scenario: &str, advisor: &str) -> ArmResult {
    let tir_w1 = [80.0, 90.0, 100.0];
    let tir_w13 = [81.0, 92.0, 104.0];
    let patients = (0..3)
        .map(|i| {
            let k = i as f64;
            patient(
                &format!("adult#00{}", i + 1),
                vec![
                    week(
                        "W1",
                        metrics(tir_w1[i], 2.0 + k, 1.5 + k, Some(60.0 + 10.0 * k)),
                        40.0 + k,
                    ),
                    week("W2", metrics(85.0, 1.0, 1.0, Some(50.0)), 41.0 + k),
                    week(
                        "W13",
                        metrics(
                            tir_w13[i],
                            1.0,
                            0.5,
                            if i == 2 { None } else { Some(55.0 + k) },
                        ),
                        38.0 + 2.0 * k,
                    ),
                    week(
                        "W14",
                        metrics(tir_w1[i], 2.0 + k, 1.5 + k, Some(60.0)),
                        39.0 + k,
                    ),
                ],
            )
        })
        .collect();
    ArmResult {
        scenario: scenario.parse().unwrap(),
        advisor: advisor.parse().unwrap(),
        mode: if scenario == "S1" {
            Mode::Cgm
        } else {
            Mode::Smbg
        },
        patients,
    }
}

fn small_trial() -> Vec<ArmResult> {
    // Deliberately not in report order.
    vec![
        small_arm("S1", "standard"),
        small_arm("S1", "abba"),
        small_arm("S4", "abba"),
    ]
}

fn manifest() -> Value {
    json!({"tool": "abba", "version": "test", "seed": 7, "knobs": {"days": 98}})
}

fn keys(v: &Value) -> Vec<String> {
    let mut k: Vec<String> = v.as_object().unwrap().keys().cloned().collect();
    k.sort();
    k
}

fn sorted(list: &[&str]) -> Vec<String> {
    let mut k: Vec<String> = list.iter().map(|s| s.to_string()).collect();
    k.sort();
    k
}

fn close(what: &str, expected: f64, got: &Value) {
    let got = got
        .as_f64()
        .unwrap_or_else(|| panic!("{what}: not a number: {got}"));
    assert!(
        (expected - got).abs() <= 1e-12 * expected.abs().max(1.0),
        "{what}: expected {expected}, got {got}"
    );
}

fn check_m(m: &Value, what: &str) {
    assert_eq!(keys(m), sorted(&metric_keys()), "{what}: metric keys");
    for k in metric_keys() {
        assert_eq!(
            keys(&m[k]),
            sorted(&["mean", "sd", "median", "q1", "q3"]),
            "{what}.{k}"
        );
    }
}

#[test]
fn summary_json_has_the_protocol_schema() {
    let s = summary_json(&small_trial(), &manifest()).unwrap();
    assert_eq!(keys(&s), sorted(&["manifest", "arms", "notes"]));
    assert_eq!(s["manifest"], manifest());
    assert_eq!(
        keys(&s["arms"]),
        sorted(&["S1/abba", "S1/standard", "S4/abba"])
    );
    for (key, arm) in s["arms"].as_object().unwrap() {
        assert_eq!(
            keys(arm),
            sorted(&["scenario", "advisor", "weeks", "weekly", "wilcoxon"]),
            "{key}"
        );
        assert_eq!(
            format!(
                "{}/{}",
                arm["scenario"].as_str().unwrap(),
                arm["advisor"].as_str().unwrap()
            ),
            *key
        );
        assert_eq!(keys(&arm["weeks"]), sorted(&["W1", "W13", "W14"]));
        for w in ["W1", "W13", "W14"] {
            check_m(&arm["weeks"][w], &format!("{key} {w}"));
        }
        let weekly = arm["weekly"].as_array().unwrap();
        let names: Vec<&str> = weekly.iter().map(|w| w["week"].as_str().unwrap()).collect();
        assert_eq!(names, ["W1", "W2", "W13", "W14"]);
        for w in weekly {
            let mut m = w.clone();
            m.as_object_mut().unwrap().remove("week");
            check_m(&m, &format!("{key} weekly"));
        }
        assert_eq!(keys(&arm["wilcoxon"]), sorted(&["W1_vs_W13", "W1_vs_W14"]));
        for c in ["W1_vs_W13", "W1_vs_W14"] {
            assert_eq!(
                keys(&arm["wilcoxon"][c]),
                sorted(&metric_keys()),
                "{key} {c}"
            );
            for k in metric_keys() {
                assert_eq!(
                    keys(&arm["wilcoxon"][c][k]),
                    sorted(&["statistic", "p"]),
                    "{key} {c} {k}"
                );
            }
        }
    }
}

#[test]
fn summary_numbers_match_hand_computation() {
    let s = summary_json(&small_trial(), &manifest()).unwrap();
    let arm = &s["arms"]["S1/abba"];
    // TIR W1 = 80, 90, 100: mean 90, SD 10, type-7 quartiles 85, 90, 95.
    let tir = &arm["weeks"]["W1"]["tir_70_180"];
    println!("W1 tir: {tir}");
    close("mean", 90.0, &tir["mean"]);
    close("sd", 10.0, &tir["sd"]);
    close("median", 90.0, &tir["median"]);
    close("q1", 85.0, &tir["q1"]);
    close("q3", 95.0, &tir["q3"]);
    // TDI W13 = 38, 40, 42.
    let tdi = &arm["weeks"]["W13"]["tdi_u_per_day"];
    close("tdi mean", 40.0, &tdi["mean"]);
    close("tdi sd", 2.0, &tdi["sd"]);
    // MAGE W13 defined for two patients only: 55, 56.
    let mage = &arm["weeks"]["W13"]["mage"];
    close("mage mean", 55.5, &mage["mean"]);
    close("mage sd", 0.5f64.sqrt(), &mage["sd"]);
    assert_eq!(
        s["notes"]["arms"]["S1/abba"]["mage_undefined"]["W13"],
        json!(1)
    );
    assert_eq!(
        s["notes"]["arms"]["S1/abba"]["mage_undefined"]["W1"],
        json!(0)
    );
    // weekly W2: every patient at TIR 85 -> SD 0.
    let w2 = &arm["weekly"][1];
    assert_eq!(w2["week"], "W2");
    close("W2 tir mean", 85.0, &w2["tir_70_180"]["mean"]);
    close("W2 tir sd", 0.0, &w2["tir_70_180"]["sd"]);
    // Wilcoxon W13 - W1 of TIR: d = 1, 2, 4; W+ = 6, W- = 0, statistic 0;
    // three pairs are too few for a p-value (stats::MIN_PAIRS_FOR_P): null.
    let t = &arm["wilcoxon"]["W1_vs_W13"]["tir_70_180"];
    println!("W1 vs W13 tir: {t}");
    close("statistic", 0.0, &t["statistic"]);
    assert!(t["p"].is_null(), "{t}");
    // W14 equals W1 in TIR: all differences zero -> statistic 0, no p (3 pairs).
    let t = &arm["wilcoxon"]["W1_vs_W14"]["tir_70_180"];
    close("statistic all zero", 0.0, &t["statistic"]);
    assert!(t["p"].is_null(), "{t}");
    // MAGE W1 vs W13: patient 3 incomplete.
    assert_eq!(
        s["notes"]["arms"]["S1/abba"]["wilcoxon"]["W1_vs_W13"]["mage"]["n_incomplete"],
        json!(1)
    );
}

#[test]
fn a_short_trial_reports_the_weeks_it_has() {
    let mut arm = small_arm("S2", "abba");
    for p in &mut arm.patients {
        p.weeks.truncate(2); // W1, W2
    }
    let arms = vec![arm];
    let s = summary_json(&arms, &manifest()).unwrap();
    let a = &s["arms"]["S2/abba"];
    assert_eq!(a["weeks"]["W13"], Value::Null);
    assert_eq!(a["weeks"]["W14"], Value::Null);
    check_m(&a["weeks"]["W1"], "W1");
    assert_eq!(a["weekly"].as_array().unwrap().len(), 2);
    assert_eq!(a["wilcoxon"]["W1_vs_W13"], Value::Null);
    assert_eq!(a["wilcoxon"]["W1_vs_W14"], Value::Null);
    let md = table1::table1_markdown(&arms).unwrap();
    assert!(md.contains("W1 ours") && !md.contains("W13 ours"), "{md}");
    let files = build_report(&arms, &manifest(), None).unwrap();
    for f in &files {
        assert!(!f.bytes.is_empty(), "{}", f.name);
    }
}

#[test]
fn table1_puts_the_papers_values_beside_ours() {
    let arms = small_trial();
    let md = table1::table1_markdown(&arms).unwrap();
    println!("{md}");
    // Paper W1 (S1-S3) beside S1 arms, W13/W14 beside the ABBA arm only.
    assert!(
        md.contains("| 90.0 ± 10.0 | 89.9 ± 8.7 |"),
        "W1 TIR ours vs paper"
    );
    assert!(md.contains("85.9 ± 12.9"), "S1 W13 TIR");
    assert!(md.contains("89.8 ± 7.9"), "S1 W14 TIR");
    assert!(md.contains("78.4 ± 15.2"), "S4 W13 TIR");
    assert!(md.contains("IEEE J Biomed Health Inform"));
    assert!(md.contains("text: minimal range < 1.1"));
    // No p-value of TIR W1 vs W13 with three patients (it would be 0.109).
    assert!(!md.contains("0.109"), "p");

    let csv_text = table1::table1_csv(&arms).unwrap();
    let mut r = csv::Reader::from_reader(csv_text.as_bytes());
    let h = r.headers().unwrap().clone();
    let col = |name: &str| h.iter().position(|x| x == name).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    // 3 arms x 3 weeks x 7 metrics.
    assert_eq!(rows.len(), 3 * 3 * 7);
    let find = |s: &str, a: &str, w: &str, m: &str| {
        rows.iter()
            .find(|r| r[0] == *s && r[1] == *a && r[col("week")] == *w && r[col("metric")] == *m)
            .unwrap()
            .clone()
    };
    let r = find("S1", "abba", "W13", "tir_70_180");
    assert_eq!(
        (&r[col("paper_mean")], &r[col("paper_sd")]),
        ("85.9", "12.9")
    );
    assert_eq!(&r[col("ours_mean")], "92.33333333333333");
    assert_eq!(&r[col("wilcoxon_p_vs_w1")], "");
    let r = find("S1", "standard", "W13", "tir_70_180");
    assert_eq!(
        &r[col("paper_mean")],
        "",
        "the paper has no standard-therapy W13"
    );
    let r = find("S1", "standard", "W1", "hypo_50_70");
    assert_eq!(
        (&r[col("paper_scenarios")], &r[col("paper_mean")]),
        ("S1-S3", "2.5")
    );
    let r = find("S4", "abba", "W1", "tir_70_180");
    assert_eq!(&r[col("paper_mean")], "", "the paper has no W1 for S4");
    // LBGI W1 = 1.5, 2.5, 3.5: mean 2.5 is outside the paper's 1.1-2.5.
    let r = find("S1", "abba", "W1", "lbgi");
    assert_eq!(&r[col("paper_statement")], "low range 1.1-2.5");
    assert_eq!(&r[col("ours_mean_within_statement")], "no");
    let r = find("S1", "abba", "W13", "lbgi");
    assert_eq!(&r[col("ours_mean_within_statement")], "yes");
}

#[test]
fn patients_csv_has_one_row_per_patient_arm_and_week() {
    let arms = small_trial();
    let text = patients_csv(&arms).unwrap();
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    let mut want: Vec<String> = [
        "scenario",
        "advisor",
        "mode",
        "patient",
        "week",
        "first_day",
        "last_day",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    want.extend(metric_keys().iter().map(|s| s.to_string()));
    want.extend(
        [
            "start_basal_u_per_h",
            "start_carb_ratio_g_per_u",
            "final_basal_u_per_h",
            "final_carb_ratio_breakfast_g_per_u",
            "final_carb_ratio_lunch_g_per_u",
            "final_carb_ratio_dinner_g_per_u",
            "pump_capped",
            "min_glucose_mg_dl",
            "stopped_day",
            "stopped_minute_of_day",
            "stopped_glucose_mg_dl",
        ]
        .iter()
        .map(|s| s.to_string()),
    );
    assert_eq!(header, want);
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(rows.len(), 3 * 3 * 4, "arms x patients x weeks");
    let col = |name: &str| header.iter().position(|x| x == name).unwrap();
    // Report order: S1/abba first.
    assert_eq!(
        (&rows[0][0], &rows[0][1], &rows[0][3], &rows[0][4]),
        ("S1", "abba", "adult#001", "W1")
    );
    let p3_w13 = rows
        .iter()
        .find(|r| &r[0] == "S1" && &r[1] == "abba" && &r[3] == "adult#003" && &r[4] == "W13")
        .unwrap();
    assert_eq!(&p3_w13[col("mage")], "", "undefined MAGE is an empty cell");
    assert_eq!(&p3_w13[col("tir_70_180")], "104");
    assert_eq!(&p3_w13[col("tdi_u_per_day")], "42");
    assert_eq!(
        (&p3_w13[col("first_day")], &p3_w13[col("last_day")]),
        ("84", "90")
    );
    assert_eq!(&p3_w13[col("final_carb_ratio_dinner_g_per_u")], "11.25");
}

#[test]
fn figures_are_svg_with_their_titles() {
    let files = build_report(&small_trial(), &manifest(), None).unwrap();
    let names: Vec<&str> = files.iter().map(|f| f.name).collect();
    assert_eq!(names, report_files_without_w1());
    for (name, title) in [
        ("fig5_lbgi_hbgi.svg", "Fig. 5 - Weekly LBGI and HBGI"),
        ("fig6_mage.svg", "Fig. 6 - Weekly MAGE"),
        ("fig7_tdi.svg", "Fig. 7 - Weekly total daily insulin"),
        ("fig_arms.svg", "ABBA vs baselines"),
    ] {
        let f = files.iter().find(|f| f.name == name).unwrap();
        let text = std::str::from_utf8(&f.bytes).unwrap();
        assert!(
            text.starts_with("<svg"),
            "{name}: starts with {:?}",
            &text[..20]
        );
        assert!(text.trim_end().ends_with("</svg>"), "{name}: not closed");
        assert!(text.contains(title), "{name}: no title {title:?}");
        assert_eq!(
            text.matches("<text").count(),
            text.matches("</text>").count(),
            "{name}"
        );
    }
    let f = files.iter().find(|f| f.name == "fig6_mage.svg").unwrap();
    let text = std::str::from_utf8(&f.bytes).unwrap();
    // Two ABBA arms x 4 weeks, one MAGE undefined in each W13 (the note
    // may be wrapped over lines).
    assert!(
        svg_words(text).contains("for 2 of 24 patient-weeks"),
        "MAGE note"
    );
}

#[test]
fn inconsistent_results_are_errors_that_say_where() {
    let mut arms = small_trial();
    arms[0].patients[1].weeks.pop();
    let e = summary_json(&arms, &manifest()).unwrap_err().to_string();
    assert!(e.contains("S1/standard") && e.contains("adult#002"), "{e}");

    let mut arms = small_trial();
    arms.push(small_arm("S1", "abba"));
    let e = build_report(&arms, &manifest(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("S1/abba appears more than once"), "{e}");

    let mut arms = small_trial();
    arms[1].patients[0].weeks[1].first_day = 10;
    let e = build_report(&arms, &manifest(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("week W2: days D10-D15, expected D9-D15"), "{e}");

    let mut arms = small_trial();
    arms[2].patients[0].weeks[0].metrics.lbgi = f64::NAN;
    let e = build_report(&arms, &manifest(), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("S4/abba") && e.contains("lbgi"), "{e}");

    assert!(build_report(&[], &manifest(), None).is_err());
}

#[test]
fn write_report_is_byte_identical_across_runs() {
    let base = fresh_dir("report_files_determinism");
    let arms = small_trial();
    let a = write_report(&base.join("a"), &arms, &manifest());
    let b = write_report(&base.join("b"), &arms, &manifest());
    assert_eq!(a.len(), REPORT_FILES.len() - 1, "all but {W1_FILE}");
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.file_name(), y.file_name());
        let (bx, by) = (std::fs::read(x).unwrap(), std::fs::read(y).unwrap());
        assert!(!bx.is_empty(), "{}", x.display());
        assert_eq!(bx, by, "{} differs between runs", x.display());
    }
    let m: Value =
        serde_json::from_slice(&std::fs::read(base.join("a/manifest.json")).unwrap()).unwrap();
    let mut listed = manifest();
    listed["files"] = json!(report_files_without_w1());
    assert_eq!(m, listed);
    // summary.json holds exactly the protocol's keys; the notes have their own file.
    let s: Value =
        serde_json::from_slice(&std::fs::read(base.join("a/summary.json")).unwrap()).unwrap();
    let mut full = summary_json(&arms, &manifest()).unwrap();
    let notes = full.as_object_mut().unwrap().remove("notes").unwrap();
    assert_eq!(keys(&s), sorted(&["manifest", "arms"]));
    assert_eq!(s, full);
    let n: Value =
        serde_json::from_slice(&std::fs::read(base.join("a/summary_notes.json")).unwrap()).unwrap();
    assert_eq!(n, notes);
}

/// splitmix64: a tiny deterministic generator for plausible synthetic data.
struct Mix(u64);

impl Mix {
    fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A full-size synthetic trial: 4 scenarios x 3 arms x 20 patients x 14
/// weeks, numbers shaped like the paper's (hypoglycaemia falling under ABBA).
fn full_trial() -> Vec<ArmResult> {
    let mut rng = Mix(42);
    let mut arms = Vec::new();
    for (si, scenario) in ScenarioId::ALL.into_iter().enumerate() {
        for advisor in ArmKind::DEFAULT {
            let patients = (1..=20)
                .map(|p| {
                    let base_hypo = 1.0 + 4.0 * rng.uniform();
                    let weeks = evaluation_windows()
                        .into_iter()
                        .map(|(w, _, _)| {
                            let k = f64::from(w.number());
                            let learn = if advisor == ArmKind::Standard || k < 2.0 {
                                0.0
                            } else {
                                (1.0 - (-(k - 1.0) / 2.0).exp())
                                    * if advisor == ArmKind::Abba { 0.8 } else { 0.5 }
                            };
                            let hypo = base_hypo * (1.0 - learn) * (0.7 + 0.6 * rng.uniform());
                            let hyper =
                                6.0 + 8.0 * learn + 3.0 * si as f64 * learn + 6.0 * rng.uniform();
                            let tir = 100.0 - 1.5 * hypo - hyper;
                            let mage = (rng.uniform() > 0.03)
                                .then(|| 70.0 + 10.0 * si as f64 + 25.0 * rng.uniform());
                            let mut m = metrics(tir, hypo, 0.4 + 0.45 * hypo, mage);
                            m.hbgi = 2.0 + 0.2 * hyper;
                            let tdi = 45.0 - 3.0 * learn - 4.0 * (si == 3) as u8 as f64
                                + 10.0 * rng.uniform();
                            week(w.name(), m, tdi)
                        })
                        .collect();
                    patient(&format!("adult#{p:03}"), weeks)
                })
                .collect();
            arms.push(ArmResult {
                scenario,
                advisor,
                mode: if si == 0 { Mode::Cgm } else { Mode::Smbg },
                patients,
            });
        }
    }
    arms
}

#[test]
fn a_full_size_synthetic_trial_reports_every_arm() {
    let arms = full_trial();
    let dir = fresh_dir("report_demo");
    write_report(&dir, &arms, &manifest());
    println!("report written to {}", dir.display());
    let s = summary_json(&arms, &manifest()).unwrap();
    assert_eq!(s["arms"].as_object().unwrap().len(), 12);
    let text = std::fs::read_to_string(dir.join("patients.csv")).unwrap();
    assert_eq!(text.lines().count(), 1 + 12 * 20 * 14);
    let md = std::fs::read_to_string(dir.join("table1.md")).unwrap();
    for s in ["S1", "S2", "S3", "S4"] {
        for a in ["ABBA", "standard therapy", "run-to-run"] {
            assert!(md.contains(&format!("### {s} · {a}")), "{s} {a}");
        }
    }
}

#[test]
fn a_short_one_scenario_trial_still_draws_every_figure() {
    // S1 only, three arms, weeks W1..W3 (a 22-day run).
    let arms: Vec<ArmResult> = full_trial()
        .into_iter()
        .filter(|a| a.scenario == ScenarioId::S1)
        .map(|mut a| {
            for p in &mut a.patients {
                p.weeks.truncate(3);
            }
            a
        })
        .collect();
    let dir = fresh_dir("report_short");
    write_report(&dir, &arms, &manifest());
    let s = summary_json(&arms, &manifest()).unwrap();
    assert_eq!(s["arms"]["S1/abba"]["weekly"].as_array().unwrap().len(), 3);
    let md = std::fs::read_to_string(dir.join("table1.md")).unwrap();
    assert!(!md.contains("W13 ours"), "{md}");
    assert!(md.contains("W13, W14: not simulated in this run"), "{md}");
    for f in [
        "fig5_lbgi_hbgi.svg",
        "fig6_mage.svg",
        "fig7_tdi.svg",
        "fig_arms.svg",
    ] {
        let svg = std::fs::read_to_string(dir.join(f)).unwrap();
        assert!(svg.contains("<svg") && svg.contains("</svg>"), "{f}");
    }
}

#[test]
fn one_patient_has_no_sd() {
    let mut arm = small_arm("S3", "abba");
    arm.patients.truncate(1);
    let arms = vec![arm];
    let s = summary_json(&arms, &manifest()).unwrap();
    let tir = &s["arms"]["S3/abba"]["weeks"]["W1"]["tir_70_180"];
    assert_eq!(tir["sd"], Value::Null, "{tir}");
    close("mean", 80.0, &tir["mean"]);
    let md = table1::table1_markdown(&arms).unwrap();
    assert!(md.contains("80.0 (SD n/a)"), "{md}");
    // One pair: W+ or W- is the only rank; p from the normal approximation.
    let t = &s["arms"]["S3/abba"]["wilcoxon"]["W1_vs_W13"]["tir_70_180"];
    close("statistic", 0.0, &t["statistic"]);
    build_report(&arms, &manifest(), None).unwrap();
}

#[test]
fn a_stopped_run_counts_only_in_the_weeks_before_the_stop() {
    let mut arms: Vec<ArmResult> = full_trial()
        .into_iter()
        .filter(|a| a.scenario == ScenarioId::S1)
        .collect();
    // adult#005 of S1/abba stops on D50 at 03:20: W1..W6 end before (W6 = D37-D43, W7 = D44-D50).
    let abba = arms
        .iter_mut()
        .find(|a| a.advisor == ArmKind::Abba)
        .unwrap();
    let p = &mut abba.patients[4];
    p.failure = Some(RunFailure {
        day: 50,
        minute_of_day: 200,
        glucose_mg_dl: 9.5,
    });
    p.weeks.retain(|w| w.last_day < 50);
    assert_eq!(p.weeks.len(), 6);
    let abba = arms
        .iter()
        .find(|a| a.advisor == ArmKind::Abba)
        .unwrap()
        .clone();

    let s = summary_json(&arms, &manifest()).unwrap();
    let notes = &s["notes"]["arms"]["S1/abba"];
    assert_eq!(notes["n_patients_per_week"]["W1"], json!(20));
    assert_eq!(notes["n_patients_per_week"]["W13"], json!(19));
    assert_eq!(
        notes["stopped_runs"],
        json!([{"patient": "adult#005", "day": 50, "minute_of_day": 200, "glucose_mg_dl": 9.5}])
    );
    // W13 TIR is the mean over the 19 others.
    let others: Vec<f64> = abba
        .patients
        .iter()
        .filter_map(|p| p.week(Week::W13))
        .map(|w| w.metrics.tir_70_180)
        .collect();
    assert_eq!(others.len(), 19);
    let mean = others.iter().sum::<f64>() / 19.0;
    close(
        "W13 tir mean",
        mean,
        &s["arms"]["S1/abba"]["weeks"]["W13"]["tir_70_180"]["mean"],
    );
    assert_eq!(
        notes["wilcoxon"]["W1_vs_W13"]["tir_70_180"]["n_incomplete"],
        json!(1)
    );
    assert_eq!(s["notes"]["arms"]["S1/standard"]["stopped_runs"], json!([]));

    let md = table1::table1_markdown(&arms).unwrap();
    assert!(
        md.contains("| patients evaluated | 20 | 100 | 19 | 100 | | 19 | 100 | |"),
        "{md}"
    );
    assert!(
        md.contains("- adult#005: D50 03:20, plasma glucose 9.5 mg/dL"),
        "{md}"
    );

    let text = patients_csv(&arms).unwrap();
    assert_eq!(text.lines().count(), 1 + 3 * 20 * 14 - 8);
    let line = text
        .lines()
        .find(|l| l.starts_with("S1,abba,cgm,adult#005,W6,"))
        .unwrap();
    assert!(line.ends_with(",50,200,9.5"), "{line}");

    let files = build_report(&arms, &manifest(), None).unwrap();
    let svg = |name: &str| {
        String::from_utf8(files.iter().find(|f| f.name == name).unwrap().bytes.clone()).unwrap()
    };
    assert!(svg("fig5_lbgi_hbgi.svg").contains("1 of 20 runs stopped early"));
    assert!(svg("fig5_lbgi_hbgi.svg").contains("S1 · LBGI (n = 20, 1 stopped)"));
    assert!(svg("fig_arms.svg").contains("1 of 60 runs stopped early"));

    // A stopped run may not have a week that ends after the stop.
    let mut bad = arms.clone();
    bad[0].patients[4].failure = Some(RunFailure {
        day: 40,
        minute_of_day: 0,
        glucose_mg_dl: 9.0,
    });
    let e = build_report(&bad, &manifest(), None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("adult#005: week W6 ends on D43 but the run stopped on D40"),
        "{e}"
    );
}

#[test]
fn arms_side_by_side_compare_the_same_patients() {
    let mut arms: Vec<ArmResult> = full_trial()
        .into_iter()
        .filter(|a| a.scenario == ScenarioId::S1)
        .collect();
    let n = arms[0].patients.len();
    // The standard arm loses its first patient on D60: that patient leaves
    // the side-by-side block of every arm in W13 and W14.
    let standard = arms
        .iter_mut()
        .find(|a| a.advisor == ArmKind::Standard)
        .unwrap();
    let p = &mut standard.patients[0];
    p.failure = Some(RunFailure {
        day: 60,
        minute_of_day: 0,
        glucose_mg_dl: 9.0,
    });
    p.weeks.retain(|w| w.last_day < 60);
    let md = table1::table1_markdown(&arms).unwrap();
    let expected_n = format!("W13: n = {}, W14: n = {}", n - 1, n - 1);
    assert!(md.contains(&expected_n), "expected '{expected_n}' in\n{md}");
    // The ABBA W13 TIR cell of the block is the mean over patients 2..n.
    let abba = arms.iter().find(|a| a.advisor == ArmKind::Abba).unwrap();
    let tir: Vec<f64> = abba.patients[1..]
        .iter()
        .map(|p| p.week(Week::W13).unwrap().metrics.tir_70_180)
        .collect();
    let mean = tir.iter().sum::<f64>() / tir.len() as f64;
    let block = md.split("### ").next().unwrap();
    let row = block
        .lines()
        .find(|l| l.starts_with("| % time in target"))
        .unwrap();
    let first_cell = row.split('|').nth(2).unwrap().trim();
    assert!(
        first_cell.starts_with(&format!("{mean:.1} ±")),
        "expected mean {mean:.1} over the common patients, got '{first_cell}'"
    );
}

#[test]
fn figure_data_comes_before_drawing() {
    let arms = small_trial();
    let abba = arms
        .iter()
        .find(|a| a.scenario == ScenarioId::S1 && a.advisor == ArmKind::Abba)
        .unwrap();
    let weeks = [Week::W1, Week::W13];
    // TIR W1 = 80, 90, 100.
    let tir = abba_report::figures::weekly_series(abba, &weeks, Metric::Tir70To180).unwrap();
    assert_eq!(tir.points.len(), 2);
    assert_eq!((tir.points[0].0, tir.points[0].1.mean), (Week::W1, 90.0));
    let json = serde_json::to_value(&tir).unwrap();
    assert_eq!(json["metric"], "tir_70_180");
    assert_eq!(json["points"][1][0], "W13");
    // TDI W13 = 38, 40, 42: one box a week.
    let boxes = abba_report::figures::tdi_boxes(&[abba], &weeks).unwrap();
    assert_eq!(boxes.len(), 2);
    let b = &boxes[1].tukey;
    assert_eq!(
        (boxes[1].week, b.q1, b.median, b.q3),
        (Week::W13, 39.0, 40.0, 41.0)
    );
    assert_eq!((b.low, b.high, b.outliers.len()), (38.0, 42.0, 0));
}

#[test]
fn the_w1_block_is_a_report_file_listed_in_the_manifest() {
    let arms = small_trial();
    let extras = ReportExtras {
        w1: Some(w1_block("tag-one")),
    };
    let files = build_report_with(&arms, &manifest(), None, &extras).unwrap();
    let names: Vec<&str> = files.iter().map(|f| f.name).collect();
    assert_eq!(names, REPORT_FILES);
    let file = |name: &str| {
        let f = files.iter().find(|f| f.name == name).unwrap();
        String::from_utf8(f.bytes.clone()).unwrap()
    };
    assert_eq!(file(W1_FILE), "## W1 sensitivity tag-one\n");
    assert!(file("report.html").contains("W1 sensitivity tag-one"));
    assert!(file("README.md").contains("`w1_sensitivity.md`"));
    let m: Value = serde_json::from_str(&file("manifest.json")).unwrap();
    assert_eq!(m["files"], json!(REPORT_FILES));
    // summary.json keeps the manifest as given (identical across reruns).
    let s: Value = serde_json::from_str(&file("summary.json")).unwrap();
    assert_eq!(s["manifest"], manifest());
    // Without the block: neither the file nor its mention.
    let plain = build_report(&arms, &manifest(), None).unwrap();
    let readme = plain.iter().find(|f| f.name == "README.md").unwrap();
    assert!(!String::from_utf8_lossy(&readme.bytes).contains(W1_FILE));
    let html = plain.iter().find(|f| f.name == "report.html").unwrap();
    assert!(!String::from_utf8_lossy(&html.bytes).contains("W1 sensitivity tag-one"));
}

#[test]
fn a_rerun_replaces_or_removes_w1_sensitivity_md() {
    let dir = fresh_dir("report_files_w1_rerun");
    let arms = small_trial();
    let write = |tag: Option<&str>| {
        let extras = ReportExtras {
            w1: tag.map(w1_block),
        };
        let built = build_report_with(&arms, &manifest(), None, &extras).unwrap();
        ReportDir::prepare(&dir)
            .unwrap()
            .write_report(&built)
            .unwrap()
    };
    let read_w1 = || std::fs::read_to_string(dir.join(W1_FILE)).unwrap();
    let listed = || -> Value {
        let m: Value =
            serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
        m["files"].clone()
    };
    let written = write(Some("first"));
    assert!(written.contains(&dir.join(W1_FILE)));
    assert!(read_w1().contains("first"));
    // A rerun into the same folder replaces it ...
    write(Some("second"));
    assert!(read_w1().contains("second"));
    assert_eq!(listed(), json!(REPORT_FILES));
    // ... and one without the block removes it, like any stale abba file.
    let written = write(None);
    assert!(!dir.join(W1_FILE).exists());
    assert!(!written.contains(&dir.join(W1_FILE)));
    assert_eq!(listed(), json!(report_files_without_w1()));
}

/// report.html opens with the arms side by side, ABBA's paired difference
/// against each other arm with its p, then Table I; a short run shows the
/// weeks it has (here W1, W2), not rows of W1 alone.
#[test]
fn report_html_opens_with_the_arms_and_shows_a_short_runs_weeks() {
    let mut arms = vec![
        small_arm("S1", "abba"),
        small_arm("S1", "standard"),
        small_arm("S1", "autotune"),
    ];
    // Standard therapy 1 point lower in time in range every patient.
    for p in &mut arms[1].patients {
        for w in &mut p.weeks {
            w.metrics.tir_70_180 -= 1.0;
        }
    }
    let files = build_report(&arms, &manifest(), None).unwrap();
    let html = String::from_utf8(
        files
            .iter()
            .find(|f| f.name == "report.html")
            .unwrap()
            .bytes
            .clone(),
    )
    .unwrap();
    let at = |s: &str| html.find(s).unwrap_or_else(|| panic!("no {s}"));
    assert!(at("id=\"h-arms\"") < at("id=\"h-table1\""));
    assert!(html.contains("abba − standard (p)") && html.contains("abba − autotune (p)"));
    // The paired difference abba − standard is +1.0 in every pair; three
    // pairs are too few for a p.
    assert!(html.contains(">+1.0 (p —)<"), "no +1.0 difference");
    assert!(html.contains(">+0.0 (p —)<"), "abba − autotune is zero");
    for p in &mut arms.iter_mut().flat_map(|a| a.patients.iter_mut()) {
        p.weeks.truncate(2); // a short run: W1, W2
    }
    let files = build_report(&arms, &manifest(), None).unwrap();
    let html = String::from_utf8(
        files
            .iter()
            .find(|f| f.name == "report.html")
            .unwrap()
            .bytes
            .clone(),
    )
    .unwrap();
    assert!(
        html.contains("<td>W2</td>"),
        "the short run's W2 is not shown"
    );
    assert!(!html.contains("<td>W13</td>"));
}

/// The four arms of a full-size synthetic trial in every scenario, the
/// autotune arm a copy of run-to-run with its own name.
fn full_trial_with_autotune() -> Vec<ArmResult> {
    let mut arms = full_trial();
    let autotune: Vec<ArmResult> = arms
        .iter()
        .filter(|a| a.advisor == ArmKind::R2r)
        .map(|a| ArmResult {
            advisor: ArmKind::Autotune,
            ..a.clone()
        })
        .collect();
    arms.extend(autotune);
    arms
}

/// The text of an SVG's `<text>` content with its five entities resolved.
fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&#39;", "'")
        .replace("&amp;", "&")
}

/// All `<text>` contents of an SVG joined by spaces (wrapped notes read
/// as one text).
fn svg_words(svg: &str) -> String {
    svg_texts(svg)
        .into_iter()
        .map(|t| t.4)
        .collect::<Vec<_>>()
        .join(" ")
}

/// Every `<text>` of a plotters SVG: (x, anchor, font size, rotated, content).
fn svg_texts(svg: &str) -> Vec<(f64, String, f64, bool, String)> {
    let attr = |tag: &str, name: &str| -> Option<String> {
        let at = tag.find(&format!(" {name}=\""))? + name.len() + 3;
        Some(tag[at..].split('"').next()?.to_string())
    };
    svg.split("<text")
        .skip(1)
        .map(|rest| {
            let (tag, body) = rest.split_once('>').unwrap();
            let content = unescape(body.split("</text>").next().unwrap().trim());
            (
                attr(tag, "x").unwrap().parse().unwrap(),
                attr(tag, "text-anchor").unwrap_or_else(|| "start".into()),
                attr(tag, "font-size").unwrap().parse().unwrap(),
                tag.contains("transform="),
                content,
            )
        })
        .collect()
}

/// At A4 width (the page's 186 mm of text width) every figure's text is
/// at least 9 pt, and no horizontal text runs past the figure's edges (by a
/// generous estimate of its width), in a full four-arm trial, a one-scenario
/// trial and a 30-day one.
#[test]
fn figure_text_is_at_least_9_pt_at_a4_width_and_stays_inside() {
    use abba_report::chart::{text_width, A4_FIGURE_WIDTH_PX, MIN_TEXT_PT};
    assert!(
        (A4_FIGURE_WIDTH_PX - 703.0).abs() < 0.1,
        "{A4_FIGURE_WIDTH_PX}"
    );
    let full = full_trial_with_autotune();
    let one: Vec<ArmResult> = full
        .iter()
        .filter(|a| a.scenario == ScenarioId::S4)
        .cloned()
        .collect();
    let mut short = full.clone();
    for p in short.iter_mut().flat_map(|a| a.patients.iter_mut()) {
        p.weeks.truncate(4);
    }
    for (what, arms) in [("full", &full), ("S4 only", &one), ("30 days", &short)] {
        let files = build_report(arms, &manifest(), None).unwrap();
        for f in files.iter().filter(|f| f.name.ends_with(".svg")) {
            let svg = String::from_utf8(f.bytes.clone()).unwrap();
            let width: f64 = svg
                .split("width=\"")
                .nth(1)
                .and_then(|r| r.split('"').next())
                .unwrap()
                .parse()
                .unwrap();
            let texts = svg_texts(&svg);
            assert!(texts.len() > 10, "{what} {}", f.name);
            for (x, anchor, size, rotated, content) in texts {
                let printed_pt = size * A4_FIGURE_WIDTH_PX / width * 0.75;
                assert!(
                    printed_pt >= MIN_TEXT_PT,
                    "{what} {}: {content:?} prints at {printed_pt:.2} pt",
                    f.name
                );
                if rotated {
                    continue;
                }
                let w = text_width(&content, size);
                let (left, right) = match anchor.as_str() {
                    "middle" => (x - w / 2.0, x + w / 2.0),
                    "end" => (x - w, x),
                    _ => (x, x + w),
                };
                assert!(
                    left >= -1.0 && right <= width + 1.0,
                    "{what} {}: {content:?} spans {left:.0}..{right:.0} of {width}",
                    f.name
                );
            }
        }
    }
}

/// A 30-day run (weeks W1-W4) shows W1 and its last two weeks in every
/// table, says which weeks exist, draws weeks 1-4 without claiming W13/W14,
/// and has the autotune arm in every table and in the arms' figure.
#[test]
fn a_30_day_run_shows_the_weeks_it_has_with_every_arm() {
    let mut arms: Vec<ArmResult> = full_trial_with_autotune()
        .into_iter()
        .filter(|a| a.scenario == ScenarioId::S1)
        .collect();
    for p in arms.iter_mut().flat_map(|a| a.patients.iter_mut()) {
        p.weeks.truncate(4);
    }
    let files = build_report(&arms, &manifest(), None).unwrap();
    let text = |name: &str| {
        String::from_utf8(files.iter().find(|f| f.name == name).unwrap().bytes.clone()).unwrap()
    };
    let md = text("table1.md");
    for want in [
        "| Metric | W1 ours | W1 paper | W3 ours | W3 paper | p W3 vs W1 | W4 ours | W4 paper | p W4 vs W1 |",
        "W13, W14: not simulated in this run (weeks present: W1, W2, W3, W4; shown: W1, W3, W4).",
        "### S1 · autotune (oref0)",
        "| W3 ABBA | W3 standard | W3 run-to-run | W3 autotune | W4 ABBA |",
    ] {
        assert!(md.contains(want), "table1.md lacks {want:?}:\n{md}");
    }
    assert!(!md.contains("W13 ours") && !md.contains("W2 ours"), "{md}");
    let html = text("report.html");
    for want in [
        "Weeks simulated: W1-W4 (the paper&#39;s W13 = D84-D90 and W14 = D92-D98 need 98 days); the tables show W1, W3, W4.",
        "<td>W4</td>",
        "abba − autotune (p)",
        "S1/autotune (cgm)",
    ] {
        assert!(html.contains(want), "report.html lacks {want:?}");
    }
    assert!(!html.contains("<td>W13</td>") && !html.contains("<td>W2</td>"));
    for f in [
        "fig5_lbgi_hbgi.svg",
        "fig6_mage.svg",
        "fig7_tdi.svg",
        "fig_arms.svg",
    ] {
        let words = svg_words(&text(f));
        assert!(words.contains("this run has weeks 1-4"), "{f}: {words}");
        assert!(!words.contains("D84-D90"), "{f} names W13");
    }
    assert!(svg_words(&text("fig_arms.svg")).contains("autotune (oref0)"));
}
