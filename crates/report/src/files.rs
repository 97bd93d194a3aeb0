//! The report's files in memory: [`build_report`] builds every one of them
//! (nothing is written unless all could be built); [`crate::ReportDir`]
//! writes them.

use crate::error::ReportError;
use crate::html::HtmlSection;
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

/// The file of the W1 sensitivity block (see [`W1Block`]).
pub const W1_FILE: &str = "w1_sensitivity.md";

/// File names of the report, in the order [`build_report_with`] produces
/// them: every file abba writes into a report folder (and replaces or
/// removes there on a rerun, see [`crate::ReportDir`]). `w1_sensitivity.md`
/// is written only when the trial computed the W1 block.
pub const REPORT_FILES: [&str; 13] = [
    "summary.json",
    "summary_notes.json",
    "table1.md",
    "table1.csv",
    "patients.csv",
    "fig5_lbgi_hbgi.svg",
    "fig6_mage.svg",
    "fig7_tdi.svg",
    "fig_arms.svg",
    W1_FILE,
    "manifest.json",
    "README.md",
    "report.html",
];

/// The W1 sensitivity block (the standard arm's first week re-run with each
/// source of variability switched off), computed by the trial, which can
/// re-run the simulator: its Markdown file and its section of `report.html`.
#[derive(Debug, Clone, PartialEq)]
pub struct W1Block {
    /// The content of `w1_sensitivity.md`.
    pub markdown: String,
    /// The same table as a section of `report.html`.
    pub section: HtmlSection,
}

/// What a report has beyond its arms' results.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportExtras {
    /// The W1 sensitivity block, when the trial computed it.
    pub w1: Option<W1Block>,
}

/// Builds every file of the report in memory without extras (see
/// [`build_report_with`]).
pub fn build_report(
    arms: &[ArmResult],
    manifest: &serde_json::Value,
    run: Option<&RunInfo>,
) -> Result<Vec<ReportFile>, ReportError> {
    build_report_with(arms, manifest, run, &ReportExtras::default())
}

/// Builds every file of the report in memory, in the order of
/// [`REPORT_FILES`] (`w1_sensitivity.md` only with a W1 block in `extras`).
/// `manifest` (what ran) is copied into `summary.json`; `manifest.json`
/// also records `run` (how the run went: wall time, threads), when given,
/// so that `summary.json` is identical across reruns, and `files`, the
/// names of the report's files.
pub fn build_report_with(
    arms: &[ArmResult],
    manifest: &serde_json::Value,
    run: Option<&RunInfo>,
    extras: &ReportExtras,
) -> Result<Vec<ReportFile>, ReportError> {
    validate_arms(arms)?;
    let mut summary = summary::summary_json(arms, manifest)?;
    // summary.json keeps exactly the protocol's schema (§8); the method
    // statements, counts and stops go to summary_notes.json.
    let notes = summary
        .as_object_mut()
        .and_then(|o| o.remove("notes"))
        .unwrap_or(serde_json::Value::Null);
    let w1 = extras.w1.as_ref();
    let names: Vec<&'static str> = REPORT_FILES
        .into_iter()
        .filter(|&name| name != W1_FILE || w1.is_some())
        .collect();
    let sections: Vec<HtmlSection> = w1.map(|b| b.section.clone()).into_iter().collect();
    let mut manifest_json = with_run(manifest, run);
    if let Some(obj) = manifest_json.as_object_mut() {
        obj.insert("files".to_string(), serde_json::json!(names));
    }
    // In the order of REPORT_FILES (a test holds them equal); `None`: not
    // part of this report.
    let files: [(&'static str, Option<Vec<u8>>); 13] = [
        ("summary.json", Some(pretty_json(&summary, "summary.json")?)),
        (
            "summary_notes.json",
            Some(pretty_json(&notes, "summary_notes.json")?),
        ),
        (
            "table1.md",
            Some(table1::table1_markdown(arms)?.into_bytes()),
        ),
        ("table1.csv", Some(table1::table1_csv(arms)?.into_bytes())),
        (
            "patients.csv",
            Some(patients_csv::patients_csv(arms)?.into_bytes()),
        ),
        (
            "fig5_lbgi_hbgi.svg",
            Some(figures::fig5_lbgi_hbgi(arms)?.into_bytes()),
        ),
        (
            "fig6_mage.svg",
            Some(figures::fig6_mage(arms)?.into_bytes()),
        ),
        ("fig7_tdi.svg", Some(figures::fig7_tdi(arms)?.into_bytes())),
        ("fig_arms.svg", Some(figures::fig_arms(arms)?.into_bytes())),
        (W1_FILE, w1.map(|b| b.markdown.clone().into_bytes())),
        (
            "manifest.json",
            Some(pretty_json(&manifest_json, "manifest.json")?),
        ),
        ("README.md", Some(readme(w1.is_some()).into_bytes())),
        (
            "report.html",
            Some(
                crate::html::trial_page::trial_report_html(arms, manifest, &sections)?.into_bytes(),
            ),
        ),
    ];
    Ok(files
        .into_iter()
        .filter_map(|(name, bytes)| bytes.map(|bytes| ReportFile { name, bytes }))
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
fn readme(with_w1: bool) -> String {
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
         - `manifest.json`: version, revision, seed, cohort, protocol, every knob, wall time, the report's files.\n",
    );
    if with_w1 {
        s.push_str(
            "- `w1_sensitivity.md`: the standard-therapy week W1 re-run with each source of variability switched off, and with s(t) on Vmx only (also a section of `report.html`).\n",
        );
    }
    s.push('\n');
    s.push_str(
        "Evaluation weeks: W1 = D2-D8 (standard therapy), Wk = D(7k-5)-D(7k+1) for k = 1..12, \
         W13 = D84-D90 (with insulin-sensitivity variability), W14 = D92-D98 (without); D91 is not evaluated. \
         Metrics are computed on plasma glucose every 5 min.\n",
    );
    s
}
