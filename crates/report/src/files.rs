//! The report's files in memory: [`build_report`] builds every one of them
//! (nothing is written unless all could be built); [`crate::ReportDir`]
//! writes them.

use crate::error::ReportError;
use crate::manifest::{with_run, RunInfo};
use crate::results::ArmResult;
use crate::select::validate_arms;
use crate::{figures, patients_csv, summary, table1};

/// One file of the report, in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportFile {
    /// File name inside the report directory (e.g. `summary.json`).
    pub name: &'static str,
    /// Its exact content.
    pub bytes: Vec<u8>,
}

/// File names of the report, in the order [`build_report`] produces them.
pub const REPORT_FILES: [&str; 12] = [
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
    "report.html",
];

/// Builds every file of the report in memory (names as in [`REPORT_FILES`]).
/// `manifest` (what ran) is copied into `summary.json`; `manifest.json`
/// also records `run` (how the run went: wall time, threads), when given,
/// so that `summary.json` is identical across reruns.
pub fn build_report(
    arms: &[ArmResult],
    manifest: &serde_json::Value,
    run: Option<&RunInfo>,
) -> Result<Vec<ReportFile>, ReportError> {
    validate_arms(arms)?;
    let mut summary = summary::summary_json(arms, manifest)?;
    // summary.json keeps exactly the protocol's schema (§8); the method
    // statements, counts and stops go to summary_notes.json.
    let notes = summary
        .as_object_mut()
        .and_then(|o| o.remove("notes"))
        .unwrap_or(serde_json::Value::Null);
    let files: [(&'static str, Vec<u8>); 12] = [
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
        (
            "manifest.json",
            pretty_json(&with_run(manifest, run), "manifest.json")?,
        ),
        ("README.md", readme().into_bytes()),
        (
            "report.html",
            crate::html::trial_page::trial_report_html(arms, manifest, &[])?.into_bytes(),
        ),
    ];
    Ok(files
        .into_iter()
        .map(|(name, bytes)| ReportFile { name, bytes })
        .collect())
}

/// Pretty JSON with a final newline.
pub(crate) fn pretty_json(
    value: &serde_json::Value,
    what: &'static str,
) -> Result<Vec<u8>, ReportError> {
    let mut bytes =
        serde_json::to_vec_pretty(value).map_err(|source| ReportError::Json { what, source })?;
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
         - `report.html`: all of the above as one page (opens in any browser, prints on A4/Letter), with the cohort's glucose profile per arm at W1, W13 and W14.\n\
         - `manifest.json`: version, revision, seed, cohort, protocol, every knob, wall time.\n\n",
    );
    s.push_str(
        "Evaluation weeks: W1 = D2-D8 (standard therapy), Wk = D(7k-5)-D(7k+1) for k = 1..12, \
         W13 = D84-D90 (with insulin-sensitivity variability), W14 = D92-D98 (without); D91 is not evaluated. \
         Metrics are computed on plasma glucose every 5 min.\n",
    );
    s
}
