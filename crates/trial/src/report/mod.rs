//! The trial's report (protocol §7-§8), computed only from the result types of
//! [`crate::results`]:
//!
//! | file | built by |
//! |---|---|
//! | `summary.json` | [`summary::summary_json`] |
//! | `table1.md`, `table1.csv` | [`table1::table1_markdown`], [`table1::table1_csv`] |
//! | `patients.csv` | [`patients_csv::patients_csv`] |
//! | `fig5_lbgi_hbgi.svg`, `fig6_mage.svg`, `fig7_tdi.svg`, `fig_arms.svg` | [`figures`] |
//! | `manifest.json` | the manifest passed in, pretty-printed |
//!
//! Every piece is a pure function of the arms (and the manifest), so it can be
//! tested in memory; [`build_report`] assembles all of them and
//! [`write_report`] writes them to a directory. The output is byte-identical
//! for identical input: JSON objects have sorted keys (serde_json's default
//! map), lists follow the protocol's order, and numbers are printed with the
//! shortest representation that round-trips.
//!
//! The input is checked before anything is computed (see [`validate_arms`]):
//! inconsistent results are an error, never silently dropped.

pub mod figures;
pub mod patients_csv;
pub mod summary;
pub mod table1;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use crate::error::TrialError;
use crate::results::{evaluation_windows, ArmResult, RunFailure, WeekResult};

/// The protocol's 16 metric keys (§8), in its order: the 15 glucose metrics
/// with `tdi_u_per_day` after `mage`.
pub const METRIC_KEYS: [&str; 16] = [
    "tir_70_180",
    "hypo_50_70",
    "severe_hypo_lt50",
    "hyper_180_300",
    "severe_hyper_gt300",
    "lbgi",
    "hbgi",
    "mage",
    "tdi_u_per_day",
    "mean_mg_dl",
    "cv_pct",
    "gmi_pct",
    "below_54",
    "below_70",
    "above_180",
    "above_250",
];

/// The seed paper's five glucose bands (Table I), in its column order.
pub const SEED_BANDS: [&str; 5] = [
    "tir_70_180",
    "hypo_50_70",
    "severe_hypo_lt50",
    "hyper_180_300",
    "severe_hyper_gt300",
];

/// The three evaluation weeks of Table I and of `summary.json`'s `weeks`.
pub const TABLE_WEEKS: [&str; 3] = ["W1", "W13", "W14"];

/// The scenario order used everywhere in the report.
pub const SCENARIOS: [&str; 4] = ["S1", "S2", "S3", "S4"];

/// The advisor order used everywhere in the report.
pub const ADVISORS: [&str; 3] = ["abba", "standard", "r2r"];

/// The value of metric `key` (one of [`METRIC_KEYS`]) in one evaluation
/// window; `None` for an undefined MAGE (or an unknown key).
pub fn metric_value(week: &WeekResult, key: &str) -> Option<f64> {
    if key == "tdi_u_per_day" {
        Some(week.tdi_u_per_day)
    } else {
        week.metrics.get(key)
    }
}

/// A short human label of a metric key, with its unit.
pub fn metric_label(key: &str) -> &'static str {
    match key {
        "tir_70_180" => "% time in target 70-180 mg/dL",
        "hypo_50_70" => "% time in hypo 50-<70 mg/dL",
        "severe_hypo_lt50" => "% time in severe hypo <50 mg/dL",
        "hyper_180_300" => "% time in hyper >180-300 mg/dL",
        "severe_hyper_gt300" => "% time in severe hyper >300 mg/dL",
        "lbgi" => "LBGI",
        "hbgi" => "HBGI",
        "mage" => "MAGE (mg/dL)",
        "tdi_u_per_day" => "TDI (U/day)",
        "mean_mg_dl" => "mean glucose (mg/dL)",
        "cv_pct" => "CV (%)",
        "gmi_pct" => "GMI (%)",
        "below_54" => "% time <54 mg/dL",
        "below_70" => "% time <70 mg/dL",
        "above_180" => "% time >180 mg/dL",
        "above_250" => "% time >250 mg/dL",
        _ => "unknown metric",
    }
}

/// The evaluation weeks of `arm`: those any of its patients has, in
/// protocol order (W1..W12, W13, W14). Patients whose run stopped early
/// (see [`validate_arms`]) may lack the later ones.
pub fn arm_weeks(arm: &ArmResult) -> Vec<String> {
    evaluation_windows()
        .into_iter()
        .map(|(w, _, _)| w)
        .filter(|w| arm.patients.iter().any(|p| p.week(w).is_some()))
        .collect()
}

/// How many patients of `arm` have week `week`.
pub fn patients_with_week(arm: &ArmResult, week: &str) -> usize {
    arm.patients
        .iter()
        .filter(|p| p.week(week).is_some())
        .count()
}

/// The patients of `arm` whose run stopped early (plasma glucose below the
/// trial's failure threshold).
pub fn stopped_runs(arm: &ArmResult) -> Vec<(&str, RunFailure)> {
    arm.patients
        .iter()
        .filter_map(|p| p.failure.map(|f| (p.patient.as_str(), f)))
        .collect()
}

/// `D45 03:20` style time of a stopped run.
pub fn failure_time(f: &RunFailure) -> String {
    format!(
        "D{} {:02}:{:02}",
        f.day,
        f.minute_of_day / 60,
        f.minute_of_day % 60
    )
}

/// The values of metric `key` in week `week` for every patient of `arm`, in
/// patient order (`None` for an undefined MAGE or a week the patient lacks).
pub fn metric_column(arm: &ArmResult, week: &str, key: &str) -> Vec<Option<f64>> {
    arm.patients
        .iter()
        .map(|p| p.week(week).and_then(|w| metric_value(w, key)))
        .collect()
}

/// The arms in report order (scenario S1..S4, then advisor abba, standard,
/// r2r; unknown names after the known ones, alphabetically).
pub fn ordered_arms(arms: &[ArmResult]) -> Vec<&ArmResult> {
    fn rank(list: &[&str], name: &str) -> usize {
        list.iter().position(|s| *s == name).unwrap_or(list.len())
    }
    let mut v: Vec<&ArmResult> = arms.iter().collect();
    v.sort_by(|a, b| {
        (
            rank(&SCENARIOS, &a.scenario),
            &a.scenario,
            rank(&ADVISORS, &a.advisor),
            &a.advisor,
        )
            .cmp(&(
                rank(&SCENARIOS, &b.scenario),
                &b.scenario,
                rank(&ADVISORS, &b.advisor),
                &b.advisor,
            ))
    });
    v
}

/// Checks that the results can be reported without dropping or guessing
/// anything:
/// - at least one arm, and no two arms with the same `scenario/advisor` key;
/// - every arm has at least one patient, and no patient name twice;
/// - every patient's weeks are evaluation windows of the protocol (name and
///   days as in [`evaluation_windows`]), in protocol order, each once;
/// - all patients of one arm whose run completed have the same weeks (paired
///   statistics need them); a patient whose run stopped early (`failure`)
///   has a leading part of them, and none that ends after the stop day.
///
/// Stopped runs are reported, not hidden: each summary is over the patients
/// that have the week, and the counts are in the report.
pub fn validate_arms(arms: &[ArmResult]) -> Result<(), TrialError> {
    let bad = |msg: String| Err(TrialError::InconsistentResults(msg));
    if arms.is_empty() {
        return bad("no arms to report".to_string());
    }
    let windows = evaluation_windows();
    let mut keys = BTreeSet::new();
    for arm in arms {
        let key = arm.key();
        if !keys.insert(key.clone()) {
            return bad(format!("arm {key} appears more than once"));
        }
        if arm.patients.is_empty() {
            return bad(format!("arm {key} has no patients"));
        }
        let mut names = BTreeSet::new();
        for p in &arm.patients {
            if !names.insert(p.patient.as_str()) {
                return bad(format!(
                    "arm {key}: patient {} appears more than once",
                    p.patient
                ));
            }
            let mut last_index: Option<usize> = None;
            for w in &p.weeks {
                let Some(index) = windows.iter().position(|(n, _, _)| *n == w.week) else {
                    return bad(format!(
                        "arm {key}, patient {}: unknown evaluation week {:?} (expected W1..W14)",
                        p.patient, w.week
                    ));
                };
                let (_, first_day, last_day) = &windows[index];
                if (w.first_day, w.last_day) != (*first_day, *last_day) {
                    return bad(format!(
                        "arm {key}, patient {}, week {}: days D{}-D{}, expected D{first_day}-D{last_day}",
                        p.patient, w.week, w.first_day, w.last_day
                    ));
                }
                if last_index.is_some_and(|l| index <= l) {
                    return bad(format!(
                        "arm {key}, patient {}: week {} is repeated or out of order (expected W1..W12, W13, W14)",
                        p.patient, w.week
                    ));
                }
                if let Some(f) = p.failure {
                    if w.last_day > f.day {
                        return bad(format!(
                            "arm {key}, patient {}: week {} ends on D{} but the run stopped on D{}",
                            p.patient, w.week, w.last_day, f.day
                        ));
                    }
                }
                last_index = Some(index);
            }
        }
        let names_of = |p: &crate::results::PatientResult| -> Vec<String> {
            p.weeks.iter().map(|w| w.week.clone()).collect()
        };
        if let Some(full) = arm.patients.iter().find(|p| p.failure.is_none()) {
            let theirs = names_of(full);
            for p in &arm.patients {
                let mine = names_of(p);
                let ok = if p.failure.is_none() {
                    mine == theirs
                } else {
                    theirs.starts_with(&mine)
                };
                if !ok {
                    return bad(format!(
                        "arm {key}: patient {} has weeks [{}] but patient {} has [{}]{}",
                        p.patient,
                        mine.join(", "),
                        full.patient,
                        theirs.join(", "),
                        if p.failure.is_some() {
                            " (a stopped run must have a leading part of them)"
                        } else {
                            ""
                        }
                    ));
                }
            }
        }
    }
    Ok(())
}

/// One file of the report, in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportFile {
    /// File name inside the report directory (e.g. `summary.json`).
    pub name: &'static str,
    /// Its exact content.
    pub bytes: Vec<u8>,
}

/// File names of the report, in the order [`build_report`] produces them.
pub const REPORT_FILES: [&str; 11] = [
    "summary.json",
    "summary_notes.json",
    "table1.md",
    "table1.csv",
    "patients.csv",
    "fig5_lbgi_hbgi.svg",
    "fig6_mage.svg",
    "fig7_tdi.svg",
    "fig_arms.svg",
    "manifest.json",
    "README.md",
];

/// Builds every file of the report in memory (names as in [`REPORT_FILES`]).
pub fn build_report(
    arms: &[ArmResult],
    manifest: &serde_json::Value,
) -> Result<Vec<ReportFile>, TrialError> {
    validate_arms(arms)?;
    let mut summary = summary::summary_json(arms, manifest)?;
    // summary.json keeps exactly the protocol's schema (§8); the method
    // statements, counts and stops go to summary_notes.json.
    let notes = summary
        .as_object_mut()
        .and_then(|o| o.remove("notes"))
        .unwrap_or(serde_json::Value::Null);
    let files: [(&'static str, Vec<u8>); 11] = [
        ("summary.json", pretty_json(&summary, "summary.json")?),
        (
            "summary_notes.json",
            pretty_json(&notes, "summary_notes.json")?,
        ),
        ("table1.md", table1::table1_markdown(arms)?.into_bytes()),
        ("table1.csv", table1::table1_csv(arms)?.into_bytes()),
        (
            "patients.csv",
            patients_csv::patients_csv(arms)?.into_bytes(),
        ),
        (
            "fig5_lbgi_hbgi.svg",
            figures::fig5_lbgi_hbgi(arms)?.into_bytes(),
        ),
        ("fig6_mage.svg", figures::fig6_mage(arms)?.into_bytes()),
        ("fig7_tdi.svg", figures::fig7_tdi(arms)?.into_bytes()),
        ("fig_arms.svg", figures::fig_arms(arms)?.into_bytes()),
        ("manifest.json", pretty_json(manifest, "manifest.json")?),
        ("README.md", readme().into_bytes()),
    ];
    Ok(files
        .into_iter()
        .map(|(name, bytes)| ReportFile { name, bytes })
        .collect())
}

/// The paths [`write_report`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportFiles {
    /// The report directory.
    pub dir: PathBuf,
    /// Every file written, in the order of [`REPORT_FILES`].
    pub files: Vec<PathBuf>,
}

/// Builds the report ([`build_report`]) and writes it into `dir` (created if
/// missing; existing files of the same names are replaced). Nothing is
/// written unless every piece could be built.
pub fn write_report(
    dir: &Path,
    arms: &[ArmResult],
    manifest: &serde_json::Value,
) -> Result<ReportFiles, TrialError> {
    let built = build_report(arms, manifest)?;
    std::fs::create_dir_all(dir).map_err(|source| TrialError::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files = Vec::with_capacity(built.len());
    for f in built {
        let path = dir.join(f.name);
        std::fs::write(&path, &f.bytes).map_err(|source| TrialError::Io {
            path: path.clone(),
            source,
        })?;
        files.push(path);
    }
    Ok(ReportFiles {
        dir: dir.to_path_buf(),
        files,
    })
}

/// Pretty JSON with a final newline.
fn pretty_json(value: &serde_json::Value, what: &'static str) -> Result<Vec<u8>, TrialError> {
    let mut bytes =
        serde_json::to_vec_pretty(value).map_err(|source| TrialError::Json { what, source })?;
    bytes.push(b'\n');
    Ok(bytes)
}

/// A short guide to the files of the report.
fn readme() -> String {
    let mut s = String::from("# Trial report\n\n");
    s.push_str(
        "Files (protocol section 8):\n\n\
         - `summary.json`: per arm (`S1/abba` ...), the summary over patients (mean, SD, median, Q1, Q3) of every metric in W1, W13, W14 (`weeks`) and in every evaluation week (`weekly`), and the paired Wilcoxon signed-rank tests W1 vs W13 and W1 vs W14 (`wilcoxon`). `summary_notes.json` holds the method statements, the number of patients per week, every stopped run and the counts of undefined values (MAGE without a countable excursion), so that `summary.json` has exactly the protocol's schema.\n\
         - `table1.md`, `table1.csv`: our Table I beside the paper's (Sun et al., IEEE JBHI 2019, Table I).\n\
         - `patients.csv`: one row per patient, arm and evaluation week, with the final therapy settings.\n\
         - `fig5_lbgi_hbgi.svg`: weekly LBGI and HBGI, ABBA arms (paper Fig. 5).\n\
         - `fig6_mage.svg`: weekly MAGE, ABBA arms (paper Fig. 6).\n\
         - `fig7_tdi.svg`: weekly total daily insulin, ABBA arms, box plots (paper Fig. 7).\n\
         - `fig_arms.svg`: ABBA against the standard-therapy and run-to-run baselines.\n\
         - `manifest.json`: version, revision, seed, cohort, protocol, every knob, wall time.\n\n",
    );
    s.push_str(
        "Evaluation weeks: W1 = D2-D8 (standard therapy), Wk = D(7k-5)-D(7k+1) for k = 1..12, \
         W13 = D84-D90 (with insulin-sensitivity variability), W14 = D92-D98 (without); D91 is not evaluated. \
         Metrics are computed on plasma glucose every 5 min.\n",
    );
    s
}
