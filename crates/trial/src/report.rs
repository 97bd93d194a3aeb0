//! From a trial to its report folder. [`ReportPlan::check`] checks the
//! folder and the patients to trace before the run (so a long run never
//! ends in "cannot write"); [`ReportPlan::write`] builds the manifest,
//! writes the report (abba-report) and re-runs the traced patients into
//! `traces/`. The report itself (tables, figures, files) is abba-report's;
//! this module only knows what a trial ran.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use abba_report::trace::{decisions_jsonl, trace_csv, trace_stem, TraceMinute};
use abba_report::{build_report_with, ReportDir, ReportExtras, ReportFile};
pub use abba_report::{RunInfo, REPORT_FILES};
use serde_json::{json, Value};

use crate::closed_loop::MinuteRecord;
use crate::error::TrialError;
use crate::protocol::TrialConfig;
use crate::runner::{build_cohort, trace_patient, TrialOutput};

/// The program that ran the trial, for the manifest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ToolInfo {
    /// Its version.
    pub version: &'static str,
    /// The git revision it was built from.
    pub git_revision: &'static str,
}

/// A report folder and the patients to trace, checked before the run.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportPlan {
    dir: ReportDir,
    trace: Vec<String>,
}

/// What [`ReportPlan::write`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct WrittenReport {
    /// The report folder.
    pub dir: PathBuf,
    /// The report's files, in the order of [`abba_report::REPORT_FILES`]
    /// (`w1_sensitivity.md` among them).
    pub files: Vec<PathBuf>,
    /// The trace files (CSV and decisions of every traced run).
    pub traces: Vec<PathBuf>,
}

impl ReportPlan {
    /// Checks, before anything is simulated, that every patient of `trace`
    /// is in the cohort of `config` (each named once) and that `out` can
    /// take the report (see [`abba_report::out_dir`]; the folder is created
    /// if missing).
    pub fn check(config: &TrialConfig, out: &Path, trace: &[String]) -> Result<Self, TrialError> {
        if !trace.is_empty() {
            let cohort = build_cohort(config)?;
            let names: Vec<&str> = cohort
                .patients
                .iter()
                .map(|p| p.params.name.as_str())
                .collect();
            for (i, patient) in trace.iter().enumerate() {
                if !names.contains(&patient.as_str()) {
                    return Err(TrialError::Config(format!(
                        "--trace: no patient '{patient}' in the cohort of {} ({} .. {})",
                        names.len(),
                        names.first().unwrap_or(&""),
                        names.last().unwrap_or(&""),
                    )));
                }
                if trace[..i].contains(patient) {
                    return Err(TrialError::Config(format!(
                        "--trace: patient '{patient}' is listed twice"
                    )));
                }
            }
        }
        Ok(ReportPlan {
            dir: ReportDir::prepare(out)?,
            trace: trace.to_vec(),
        })
    }

    /// The checked folder.
    pub fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// Writes the report of `output` (replacing the files of an earlier
    /// abba report there), then the traces asked for.
    pub fn write(
        &self,
        output: &TrialOutput,
        tool: &ToolInfo,
        run: &RunInfo,
    ) -> Result<WrittenReport, TrialError> {
        let built = trial_report_files(output, tool, Some(run))?;
        let files = self.dir.write_report(&built)?;
        let mut traces = Vec::new();
        for patient in &self.trace {
            for scenario in &output.config.scenarios {
                for arm in &output.config.arms {
                    let (_, trace) =
                        trace_patient(&output.config, &output.cohort, patient, *scenario, *arm)?;
                    let minutes = trace.minutes.unwrap_or_default();
                    let csv = trace_csv(minutes.iter().map(trace_minute));
                    let decisions = decisions_jsonl(&trace.decisions.unwrap_or_default())?;
                    let stem = trace_stem(patient, *scenario, *arm);
                    traces.extend(self.dir.write_trace(&stem, &csv, &decisions)?);
                }
            }
        }
        Ok(WrittenReport {
            dir: self.dir.path().to_path_buf(),
            files,
            traces,
        })
    }
}

/// Every file of the report of `output` in memory, as [`ReportPlan::write`]
/// writes them: abba-report's files with the W1 sensitivity block (which
/// re-runs the standard arm's first week, see [`crate::w1_sensitivity`]).
/// `run` goes into `manifest.json` when given.
pub fn trial_report_files(
    output: &TrialOutput,
    tool: &ToolInfo,
    run: Option<&RunInfo>,
) -> Result<Vec<ReportFile>, TrialError> {
    let manifest = trial_manifest(output, tool);
    let extras = ReportExtras {
        w1: crate::w1_sensitivity::w1_block(output)?,
    };
    Ok(build_report_with(&output.arms, &manifest, run, &extras)?)
}

/// One minute of the closed loop as the report's trace row.
fn trace_minute(r: &MinuteRecord) -> TraceMinute {
    TraceMinute {
        minute: r.minute,
        plasma_mg_dl: r.plasma_mg_dl,
        subcutaneous_mg_dl: r.subcutaneous_mg_dl,
        cgm_mg_dl: r.cgm_mg_dl,
        smbg_mg_dl: r.smbg_mg_dl,
        cho_g_per_min: r.cho_g_per_min,
        insulin_u_per_min: r.insulin_u_per_min,
        sensitivity: r.sensitivity,
        basal_u_per_h: r.basal_u_per_h,
        carb_ratio_g_per_u: r.carb_ratio_g_per_u,
    }
}

/// Patient-runs of a configuration: patients × scenarios × arms.
pub fn patient_runs(config: &TrialConfig) -> usize {
    config.patients as usize * config.scenarios.len() * config.arms.len()
}

/// The worker threads a run with `threads` uses (0 = one per core).
pub fn effective_threads(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

/// What ran: version, revision, seed, cohort, protocol, TE calibration and
/// every knob (the configuration actually used). Copied into
/// `summary.json`; `manifest.json` adds how the run went.
pub fn trial_manifest(output: &TrialOutput, tool: &ToolInfo) -> Value {
    let used = &output.config;
    let modes: BTreeMap<&str, &str> = used
        .planned()
        .iter()
        .map(|s| (s.id.name(), s.mode.name()))
        .collect();
    json!({
        "tool": "abba",
        "version": tool.version,
        "git_revision": tool.git_revision,
        "seed": used.seed,
        "cohort": {
            "population": used.population,
            "patients": output.cohort.patients.len(),
            "seed": used.cohort_seed,
            "rejected_candidates": output.cohort.rejections,
        },
        "protocol": {
            "days": used.days,
            "warm_up_days": 1,
            "init_days": used.init_days,
            "scenarios": used.scenarios,
            "arms": used.arms,
            "modes": modes,
            "advisors_run": advisors_run(used),
            "evaluation": "plasma glucose G = Gp/Vg every 5 min; W1 = D2-D8, W13 = D84-D90, W14 = D92-D98; weekly Wk = D(7k-5)..D(7k+1)",
        },
        "te_calibration": {
            "calibrated": used.calibrate_te_ref && used.runs_abba(),
            "te_ref_bits_cgm": used.abba.te.te_ref_bits,
            "te_ref_bits_smbg": used.te_ref_bits_smbg.unwrap_or(used.abba.te.te_ref_bits),
            "how": "median over the cohort of ABBA's own first-week TE estimate in each mode (spec §7.3)",
            "first_week_te_bits": output.first_week_te_bits,
        },
        "knobs": used,
    })
}

/// What each arm ran in each mode, with the knobs the trial set (ABBA's
/// exploration seed is derived per patient).
fn advisors_run(used: &TrialConfig) -> Value {
    let mut out = serde_json::Map::new();
    for p in used.planned() {
        let mode = p.mode.name().to_string();
        if out.contains_key(&mode) {
            continue;
        }
        let arms: serde_json::Map<_, _> = used
            .arms
            .iter()
            .map(|a| (a.name().to_string(), json!(used.advisor_spec(*a, p.mode))))
            .collect();
        out.insert(mode, Value::Object(arms));
    }
    out.insert(
        "exploration_seed".into(),
        json!("derive_seed(seed, patient number, scenario random_key, exploration), per patient"),
    );
    Value::Object(out)
}
