//! Our Table I beside the paper's.
//!
//! The paper's values come from `data/paper-table1.csv`, compiled in: Sun Q,
//! Jankovic MV, Budzinski J, Moore B, Diem P, Stettler C, Mougiakakou SG,
//! "A dual mode adaptive basal-bolus advisor based on reinforcement
//! learning", IEEE Journal of Biomedical and Health Informatics, 2019,
//! Table I (mean ± SD over 100 virtual adults of the commercial UVA/Padova
//! simulator). The paper reports the ABBA arms only. Its W1 (D2-D8, standard
//! treatment before any adaptation) is printed once and applies to S1-S3;
//! S4 has no W1 entry. Because W1 is standard therapy in every arm, the
//! paper's W1 is shown beside the W1 of every arm of S1-S3; its W13 and W14
//! only beside the `abba` arms.
//!
//! The paper gives LBGI and HBGI only in Fig. 5 and in words (section IV):
//! LBGI fell from the low-risk range (1.1-2.5) in W1 to the minimal range
//! (< 1.1) in W13, and HBGI stayed in the minimal range (< 5) throughout.
//! These statements are the anchors of our LBGI/HBGI rows: W1 LBGI in every
//! arm of S1-S3, W13 LBGI in the `abba` arms, HBGI in W1 of every arm and in
//! every week of the `abba` arms (all four scenarios).
//!
//! The p-values are our paired Wilcoxon signed-rank tests (see
//! [`super::summary`]) of W13 and W14 against W1.

use std::fmt::Write as _;

use abba_advisor::Mode;
use abba_core::{Metric, ScenarioId};

use crate::error::ReportError;
use crate::results::{ArmKind, ArmResult, Week};
use crate::select::{
    arm_weeks, failure_time, metric_column, ordered_arms, patients_with_week, stopped_runs,
    validate_arms,
};
use crate::stats::{summarize_present, Summary};
use crate::summary::wilcoxon_vs_w1;

/// The paper's Table I as compiled in (CSV: scenario,week,metric,mean,sd).
pub const PAPER_TABLE1_CSV: &str = include_str!("../../../data/paper-table1.csv");

const PAPER_FILE: &str = "data/paper-table1.csv";

/// The scenario column of the paper's Table I.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PaperScenarios {
    /// `S1-S3`: the W1 row printed once for S1, S2 and S3.
    S1ToS3,
    /// One scenario.
    One(ScenarioId),
}

impl std::fmt::Display for PaperScenarios {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PaperScenarios::S1ToS3 => f.write_str("S1-S3"),
            PaperScenarios::One(id) => write!(f, "{id}"),
        }
    }
}

/// One mean ± SD of the paper's Table I.
#[derive(Debug, Clone, PartialEq)]
pub struct PaperValue {
    /// The scenario column as printed: `S1`..`S4`, or `S1-S3` for the shared W1.
    pub scenarios: PaperScenarios,
    /// `W1`, `W13` or `W14`.
    pub week: Week,
    /// One of [`Metric::SEED_BANDS`].
    pub metric: Metric,
    /// Mean over patients (% of time).
    pub mean: f64,
    /// SD over patients (% of time).
    pub sd: f64,
}

impl PaperValue {
    /// Whether this entry applies to `scenario` (`S1-S3` covers S1, S2, S3).
    pub fn covers(&self, scenario: ScenarioId) -> bool {
        match self.scenarios {
            PaperScenarios::S1ToS3 => {
                matches!(scenario, ScenarioId::S1 | ScenarioId::S2 | ScenarioId::S3)
            }
            PaperScenarios::One(id) => id == scenario,
        }
    }
}

/// Parses the compiled-in paper table, checking every field; an error names
/// the line and what was expected.
pub fn paper_table1() -> Result<Vec<PaperValue>, ReportError> {
    parse_paper_table(PAPER_TABLE1_CSV)
}

fn parse_paper_table(text: &str) -> Result<Vec<PaperValue>, ReportError> {
    let err = |line: usize, reason: String| ReportError::PaperTable {
        file: PAPER_FILE,
        line,
        reason,
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, "scenario,week,metric,mean,sd")) => {}
        other => {
            return Err(err(
                1,
                format!(
                    "header {:?}, expected \"scenario,week,metric,mean,sd\"",
                    other.map(|(_, l)| l).unwrap_or("")
                ),
            ))
        }
    }
    let mut out: Vec<PaperValue> = Vec::new();
    for (i, line) in lines {
        let n = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 5 {
            return Err(err(n, format!("{} fields, expected 5", f.len())));
        }
        let scenarios = if f[0] == "S1-S3" {
            PaperScenarios::S1ToS3
        } else {
            let id = ScenarioId::ALL.into_iter().find(|id| id.name() == f[0]);
            PaperScenarios::One(
                id.ok_or_else(|| err(n, format!("scenario {:?}, expected S1..S4 or S1-S3", f[0])))?,
            )
        };
        let week = Week::TABLE
            .into_iter()
            .find(|w| w.name() == f[1])
            .ok_or_else(|| err(n, format!("week {:?}, expected W1, W13 or W14", f[1])))?;
        let metric = Metric::SEED_BANDS
            .into_iter()
            .find(|m| m.key() == f[2])
            .ok_or_else(|| {
                let keys: Vec<&str> = Metric::SEED_BANDS.map(Metric::key).to_vec();
                err(
                    n,
                    format!("metric {:?}, expected one of {}", f[2], keys.join(", ")),
                )
            })?;
        let number = |s: &str, what: &str| -> Result<f64, ReportError> {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| err(n, format!("{what} {s:?}, expected a number >= 0")))
        };
        let value = PaperValue {
            scenarios,
            week,
            metric,
            mean: number(f[3], "mean")?,
            sd: number(f[4], "sd")?,
        };
        if out.iter().any(|o| {
            o.week == value.week
                && o.metric == value.metric
                && ScenarioId::ALL
                    .into_iter()
                    .any(|s| o.covers(s) && value.covers(s))
        }) {
            return Err(err(
                n,
                format!(
                    "{} {} {} given twice",
                    value.scenarios, value.week, value.metric
                ),
            ));
        }
        out.push(value);
    }
    Ok(out)
}

/// The paper's value for one scenario, week and band of an arm, if the
/// paper reports it for that arm (W1: any arm of S1-S3; W13/W14: `abba`).
pub fn paper_value(
    paper: &[PaperValue],
    scenario: ScenarioId,
    advisor: ArmKind,
    week: Week,
    metric: Metric,
) -> Option<&PaperValue> {
    if week != Week::W1 && advisor != ArmKind::Abba {
        return None;
    }
    paper
        .iter()
        .find(|p| p.week == week && p.metric == metric && p.covers(scenario))
}

/// A range the paper's text states for LBGI or HBGI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// Lower bound (inclusive), if any.
    pub low: Option<f64>,
    /// Upper bound (exclusive).
    pub high: f64,
    /// The statement, as text.
    pub text: &'static str,
}

impl Anchor {
    /// Whether a mean lies in the stated range.
    pub fn holds(&self, mean: f64) -> bool {
        self.low.is_none_or(|l| mean >= l) && mean < self.high
    }
}

/// The paper's textual LBGI/HBGI statement that applies to an arm's week and
/// metric (see the module docs), if any.
pub fn anchor(
    scenario: ScenarioId,
    advisor: ArmKind,
    week: Week,
    metric: Metric,
) -> Option<Anchor> {
    let shared_w1 =
        week == Week::W1 && matches!(scenario, ScenarioId::S1 | ScenarioId::S2 | ScenarioId::S3);
    let abba = advisor == ArmKind::Abba;
    match metric {
        Metric::Lbgi if shared_w1 => Some(Anchor {
            low: Some(1.1),
            high: 2.5,
            text: "low range 1.1-2.5",
        }),
        Metric::Lbgi if week == Week::W13 && abba => Some(Anchor {
            low: None,
            high: 1.1,
            text: "minimal range < 1.1",
        }),
        Metric::Hbgi if week == Week::W1 || abba => Some(Anchor {
            low: None,
            high: 5.0,
            text: "minimal range < 5",
        }),
        _ => None,
    }
}

/// The metrics of our Table I: the five bands, then LBGI and HBGI.
pub const TABLE1_METRICS: [Metric; 7] = {
    let b = Metric::SEED_BANDS;
    [b[0], b[1], b[2], b[3], b[4], Metric::Lbgi, Metric::Hbgi]
};

/// One cell group of our Table I: an arm, week and metric.
#[derive(Debug, Clone, PartialEq)]
pub struct Table1Row {
    /// The scenario.
    pub scenario: ScenarioId,
    /// The arm.
    pub advisor: ArmKind,
    /// The advisor's mode.
    pub mode: Mode,
    /// Patients in the arm.
    pub n_patients: usize,
    /// `W1`, `W13` or `W14`.
    pub week: Week,
    /// One of [`TABLE1_METRICS`].
    pub metric: Metric,
    /// Our summary over patients.
    pub ours: Summary,
    /// The paper's mean ± SD, where it reports this cell.
    pub paper: Option<PaperValue>,
    /// Our two-sided Wilcoxon p of this week against W1 (W13, W14 only).
    pub p_vs_w1: Option<f64>,
    /// The paper's textual statement for LBGI/HBGI, where it makes one.
    pub anchor: Option<Anchor>,
}

/// Every row of our Table I, arm by arm (report order), week by week (W1,
/// W13, W14 as simulated), metric by metric ([`TABLE1_METRICS`]).
pub fn table1_rows(arms: &[ArmResult]) -> Result<Vec<Table1Row>, ReportError> {
    validate_arms(arms)?;
    let paper = paper_table1()?;
    let mut rows = Vec::new();
    let shown = crate::select::table_weeks(arms);
    for arm in ordered_arms(arms) {
        let weeks = arm_weeks(arm);
        for &week in &shown {
            if !weeks.contains(&week) {
                continue;
            }
            for metric in TABLE1_METRICS {
                let values = metric_column(arm, week, metric);
                let ours = summarize_present(&values)
                    .map_err(|source| ReportError::Stats {
                        what: format!("arm {}, week {week}, metric {metric}", arm.key()),
                        source,
                    })?
                    .ok_or_else(|| {
                        ReportError::InconsistentResults(format!(
                            "arm {}, week {week}: no patient has a value of {metric}",
                            arm.key()
                        ))
                    })?;
                let p_vs_w1 = if week != Week::W1 && weeks.contains(&Week::W1) {
                    wilcoxon_vs_w1(arm, week, metric)?.and_then(|w| w.p)
                } else {
                    None
                };
                rows.push(Table1Row {
                    scenario: arm.scenario,
                    advisor: arm.advisor,
                    mode: arm.mode,
                    n_patients: arm.patients.len(),
                    week,
                    metric,
                    ours,
                    paper: paper_value(&paper, arm.scenario, arm.advisor, week, metric).cloned(),
                    p_vs_w1,
                    anchor: anchor(arm.scenario, arm.advisor, week, metric),
                });
            }
        }
    }
    Ok(rows)
}

/// `table1.csv`: one row per arm, week and metric (see [`Table1Row`]); full
/// precision; empty cells where a value does not exist.
pub fn table1_csv(arms: &[ArmResult]) -> Result<String, ReportError> {
    let rows = table1_rows(arms)?;
    let mut w = csv::Writer::from_writer(Vec::new());
    let csv_err = |e: csv::Error| ReportError::Csv {
        what: "table1.csv",
        reason: e.to_string(),
    };
    w.write_record([
        "scenario",
        "advisor",
        "mode",
        "n_patients",
        "week",
        "metric",
        "n_values",
        "ours_mean",
        "ours_sd",
        "ours_median",
        "ours_q1",
        "ours_q3",
        "paper_scenarios",
        "paper_mean",
        "paper_sd",
        "wilcoxon_p_vs_w1",
        "paper_statement",
        "ours_mean_within_statement",
    ])
    .map_err(csv_err)?;
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    for r in &rows {
        w.write_record([
            r.scenario.to_string(),
            r.advisor.to_string(),
            r.mode.name().to_string(),
            r.n_patients.to_string(),
            r.week.to_string(),
            r.metric.to_string(),
            r.ours.n.to_string(),
            r.ours.mean.to_string(),
            opt(r.ours.sd),
            r.ours.median.to_string(),
            r.ours.q1.to_string(),
            r.ours.q3.to_string(),
            r.paper
                .as_ref()
                .map(|p| p.scenarios.to_string())
                .unwrap_or_default(),
            opt(r.paper.as_ref().map(|p| p.mean)),
            opt(r.paper.as_ref().map(|p| p.sd)),
            opt(r.p_vs_w1),
            r.anchor.map(|a| a.text.to_string()).unwrap_or_default(),
            r.anchor
                .map(|a| if a.holds(r.ours.mean) { "yes" } else { "no" }.to_string())
                .unwrap_or_default(),
        ])
        .map_err(csv_err)?;
    }
    let bytes = w.into_inner().map_err(|e| ReportError::Csv {
        what: "table1.csv",
        reason: e.to_string(),
    })?;
    String::from_utf8(bytes).map_err(|e| ReportError::Csv {
        what: "table1.csv",
        reason: e.to_string(),
    })
}

/// Mean ± SD with `decimals` decimals (SD "n/a" for one patient).
fn pm(mean: f64, sd: Option<f64>, decimals: usize) -> String {
    match sd {
        Some(sd) => format!("{mean:.decimals$} ± {sd:.decimals$}"),
        None => format!("{mean:.decimals$} (SD n/a)"),
    }
}

/// A p-value for reading: three decimals, `<0.001` below that.
pub fn format_p(p: f64) -> String {
    if p < 0.001 {
        "<0.001".to_string()
    } else {
        format!("{p:.3}")
    }
}

fn scenario_title(scenario: ScenarioId) -> &'static str {
    match scenario {
        ScenarioId::S1 => "CGM throughout",
        ScenarioId::S2 => "SMBG 4/day after the CGM week",
        ScenarioId::S3 => "SMBG with ±10 min timing uncertainty",
        ScenarioId::S4 => "as S3, plus 2 of 21 main meals skipped per week",
        ScenarioId::S5 => "not in the paper: S1 with hypoglycaemia treatment (15 g below 70 mg/dL)",
        ScenarioId::S6 => {
            "not in the paper: S1 with insulin sensitivity drifting ±30 % over 6 weeks"
        }
    }
}

/// For one scenario with more than one arm: the arms' means ± SD side by
/// side in W13 and W14 (the weeks after adaptation; a shorter run: its
/// last two weeks), one row per metric,
/// over the patients every arm still has in that week (a run that stopped
/// early drops out of every arm here, so the columns compare the same
/// people; the per-arm tables below keep each arm's own patients).
fn arms_side_by_side(s: &mut String, arms: &[ArmResult], scenario: ScenarioId) {
    let in_scenario: Vec<&ArmResult> = arms.iter().filter(|a| a.scenario == scenario).collect();
    // The report's weeks after W1: W13 and W14, or a shorter run's last two.
    let weeks: Vec<Week> = crate::select::table_weeks(arms)
        .into_iter()
        .filter(|w| {
            *w != Week::W1
                && in_scenario
                    .iter()
                    .any(|a| a.patients.iter().any(|p| p.week(*w).is_some()))
        })
        .collect();
    if in_scenario.len() < 2 || weeks.is_empty() {
        return;
    }
    // Patients (by cohort position) present in a week in every arm.
    let common = |week: Week| -> Vec<usize> {
        let n = in_scenario
            .iter()
            .map(|a| a.patients.len())
            .min()
            .unwrap_or(0);
        (0..n)
            .filter(|&i| {
                in_scenario
                    .iter()
                    .all(|a| a.patients[i].week(week).is_some())
            })
            .collect()
    };
    let counts: Vec<String> = weeks
        .iter()
        .map(|w| format!("{w}: n = {}", common(*w).len()))
        .collect();
    let _ = writeln!(
        s,
        "Arms side by side after adaptation (mean ± SD over the patients every arm still has in that week, {}; same scenario realisation in every arm):\n",
        counts.join(", ")
    );
    let mut header = String::from("| Metric |");
    let mut rule = String::from("|---|");
    for w in &weeks {
        for a in &in_scenario {
            let _ = write!(header, " {w} {} |", a.advisor.short_label());
            rule.push_str("---:|");
        }
    }
    let _ = writeln!(s, "{header}\n{rule}");
    for metric in TABLE1_METRICS {
        let decimals = if metric.is_seed_band() { 1 } else { 2 };
        let mut line = format!("| {} |", metric.label());
        for &w in &weeks {
            let patients = common(w);
            for a in &in_scenario {
                let values: Vec<Option<f64>> = patients
                    .iter()
                    .map(|&i| a.patients[i].week(w).and_then(|r| r.value(metric)))
                    .collect();
                let cell = match summarize_present(&values) {
                    Ok(Some(sum)) => pm(sum.mean, sum.sd, decimals),
                    _ => "—".to_string(),
                };
                let _ = write!(line, " {cell} |");
            }
        }
        let _ = writeln!(s, "{line}");
    }
    let _ = writeln!(s);
}

/// `table1.md`: for each scenario and arm, a table of the five bands, LBGI
/// and HBGI in W1, W13 and W14 (ours and the paper's mean ± SD) with our
/// Wilcoxon p-values against W1, then the paper's LBGI/HBGI statements
/// checked against our means. Built in named steps: [`write_intro`], per
/// scenario its heading and [`arms_side_by_side`], per arm
/// [`write_arm_block`], then [`write_unsimulated_arms`].
pub fn table1_markdown(arms: &[ArmResult]) -> Result<String, ReportError> {
    let rows = table1_rows(arms)?;
    let mut s = String::new();
    write_intro(&mut s);
    let mut last_scenario = None;
    for arm_rows in rows.chunk_by(|a, b| a.scenario == b.scenario && a.advisor == b.advisor) {
        let scenario = arm_rows[0].scenario;
        if last_scenario != Some(scenario) {
            let _ = writeln!(s, "## {scenario}: {}\n", scenario_title(scenario));
            arms_side_by_side(&mut s, arms, scenario);
            last_scenario = Some(scenario);
        }
        write_arm_block(&mut s, arms, arm_rows);
    }
    write_unsimulated_arms(&mut s, arms, &rows);
    Ok(s)
}

/// The title and the notes on method, the paper, stopped runs and p.
fn write_intro(s: &mut String) {
    let _ = writeln!(s, "# Table I: glucose outcomes, ours beside the paper's\n");
    let _ = writeln!(
        s,
        "Mean ± SD over the patients of each arm, plasma glucose every 5 min. \
         W1 = D2-D8 (standard therapy in every arm), W13 = D84-D90 (with day-to-day \
         insulin-sensitivity variability), W14 = D92-D98 (without).\n"
    );
    let _ = writeln!(
        s,
        "**Paper**: Sun Q, Jankovic MV, Budzinski J, Moore B, Diem P, Stettler C, Mougiakakou SG. \
         A dual mode adaptive basal-bolus advisor based on reinforcement learning. \
         IEEE J Biomed Health Inform, 2019; Table I (100 adults of the commercial UVA/Padova simulator; \
         ABBA arms only). Its W1 row is printed once and applies to S1-S3; it has no W1 for S4, \
         and no LBGI/HBGI values (only the statements of section IV, shown as \"text:\"). \
         \"—\" means the paper reports nothing for that cell.\n"
    );
    let _ = writeln!(
        s,
        "**Stopped runs**: a run stops when plasma glucose falls below the trial's failure threshold; \
         the patient then counts only in the weeks that ended before the stop (\"patients evaluated\" \
         gives the number per week, and each stop is listed under its arm). The paper's n is 100 adults.\n"
    );
    let _ = writeln!(
        s,
        "**p**: our paired two-sided Wilcoxon signed-rank test of the week against W1 \
         (normal approximation, tie correction, Pratt's zero correction).\n"
    );
}

/// The weeks of an arm's table: those its rows have, which are the
/// report's [`crate::select::table_weeks`] (W1, W13, W14; in a shorter run
/// W1 and its last two weeks).
fn arm_table_weeks(arm_rows: &[Table1Row]) -> Vec<Week> {
    Week::ALL
        .into_iter()
        .filter(|w| arm_rows.iter().any(|r| r.week == *w))
        .collect()
}

/// One arm's block: heading, the weeks not simulated, its table, rescue
/// carbohydrate and stopped runs, the paper's statements checked.
fn write_arm_block(s: &mut String, arms: &[ArmResult], arm_rows: &[Table1Row]) {
    let (scenario, advisor) = (arm_rows[0].scenario, arm_rows[0].advisor);
    let _ = writeln!(
        s,
        "### {scenario} · {} · n = {} patients\n",
        advisor.title(arm_rows[0].mode),
        arm_rows[0].n_patients
    );
    let arm = arms
        .iter()
        .find(|a| a.scenario == scenario && a.advisor == advisor);
    let weeks = arm_table_weeks(arm_rows);
    write_missing_weeks(s, arm, &weeks);
    write_week_table(s, arm, arm_rows, &weeks);
    if let Some(arm) = arm {
        write_rescue_and_stops(s, arm);
    }
    write_anchors(s, arm_rows);
    let _ = writeln!(s);
}

/// Which of W1, W13, W14 this run did not simulate (and which it did).
fn write_missing_weeks(s: &mut String, arm: Option<&ArmResult>, weeks: &[Week]) {
    let missing: Vec<String> = Week::TABLE
        .into_iter()
        .filter(|w| !weeks.contains(w))
        .map(|w| w.to_string())
        .collect();
    if !missing.is_empty() {
        let present = arm.map(arm_weeks).unwrap_or_default();
        let _ = writeln!(
            s,
            "{}: not simulated in this run (weeks present: {}; shown: {}).\n",
            missing.join(", "),
            week_list(&present),
            week_list(weeks)
        );
    }
}

/// The table of one arm: a header per week (ours, the paper's, p against
/// W1), the patients evaluated, one line per metric.
fn write_week_table(
    s: &mut String,
    arm: Option<&ArmResult>,
    arm_rows: &[Table1Row],
    weeks: &[Week],
) {
    let mut header = String::from("| Metric |");
    let mut rule = String::from("|---|");
    for w in weeks {
        let _ = write!(header, " {w} ours | {w} paper |");
        rule.push_str("---:|---:|");
        if *w != Week::W1 {
            let _ = write!(header, " p {w} vs W1 |");
            rule.push_str("---:|");
        }
    }
    let _ = writeln!(s, "{header}\n{rule}");
    let mut n_line = String::from("| patients evaluated |");
    for w in weeks {
        let n = arm.map_or(0, |a| patients_with_week(a, *w));
        let paper_n = if arm_rows.iter().any(|r| r.week == *w && r.paper.is_some()) {
            "100"
        } else {
            "—"
        };
        let _ = write!(n_line, " {n} | {paper_n} |");
        if *w != Week::W1 {
            n_line.push_str(" |");
        }
    }
    let _ = writeln!(s, "{n_line}");
    for metric in TABLE1_METRICS {
        let _ = writeln!(s, "{}", metric_line(arm_rows, weeks, metric));
    }
}

/// One metric's line of an arm's table.
fn metric_line(arm_rows: &[Table1Row], weeks: &[Week], metric: Metric) -> String {
    let mut line = format!("| {} |", metric.label());
    for w in weeks {
        let Some(r) = arm_rows.iter().find(|r| r.week == *w && r.metric == metric) else {
            continue;
        };
        let decimals = if metric.is_seed_band() { 1 } else { 2 };
        let paper = match (&r.paper, r.anchor) {
            (Some(p), _) => format!("{:.1} ± {:.1}", p.mean, p.sd),
            (None, Some(a)) => format!("text: {}", a.text),
            (None, None) => "—".to_string(),
        };
        let _ = write!(
            line,
            " {} | {paper} |",
            pm(r.ours.mean, r.ours.sd, decimals)
        );
        if *w != Week::W1 {
            let p = r.p_vs_w1.map_or("—".to_string(), format_p);
            let _ = write!(line, " {p} |");
        }
    }
    line
}

/// Rescue carbohydrate (if the person treated lows) and the stopped runs.
fn write_rescue_and_stops(s: &mut String, arm: &ArmResult) {
    let treatments: u32 = arm.patients.iter().map(|p| p.rescue_treatments).sum();
    if treatments > 0 {
        let grams: f64 = arm.patients.iter().map(|p| p.rescue_carbs_g).sum();
        let _ = writeln!(
            s,
            "\nRescue carbohydrate (hypoglycaemia treatment by the person): {treatments} treatments, {grams:.0} g in all, {:.1} g per patient over the run.",
            grams / arm.patients.len().max(1) as f64
        );
    }
    let stops = stopped_runs(arm);
    if !stops.is_empty() {
        let _ = writeln!(
            s,
            "\nRuns stopped early ({} of {}; plasma glucose below the failure threshold; \
             these patients count only in the weeks that ended before the stop):\n",
            stops.len(),
            arm.patients.len()
        );
        for (patient, f) in stops {
            let _ = writeln!(
                s,
                "- {patient}: {}, plasma glucose {:.1} mg/dL",
                failure_time(&f),
                f.glucose_mg_dl
            );
        }
    }
}

/// The paper's LBGI/HBGI statements against our means.
fn write_anchors(s: &mut String, arm_rows: &[Table1Row]) {
    let anchored: Vec<&Table1Row> = arm_rows.iter().filter(|r| r.anchor.is_some()).collect();
    if anchored.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\nPaper's statements on LBGI/HBGI (section IV) against our means:\n"
    );
    for r in anchored {
        if let Some(a) = r.anchor {
            let _ = writeln!(
                s,
                "- {} {}: paper \"{}\"; ours {:.2} — {}",
                r.metric.key().to_uppercase(),
                r.week,
                a.text,
                r.ours.mean,
                if a.holds(r.ours.mean) {
                    "consistent"
                } else {
                    "NOT consistent"
                }
            );
        }
    }
}

/// Arms that have no W1/W13/W14 at all (a very short trial).
fn write_unsimulated_arms(s: &mut String, arms: &[ArmResult], rows: &[Table1Row]) {
    for arm in ordered_arms(arms) {
        if !rows
            .iter()
            .any(|r| r.scenario == arm.scenario && r.advisor == arm.advisor)
        {
            let _ = writeln!(
                s,
                "{} · {}: none of W1, W13, W14 was simulated (weeks present: {}).\n",
                arm.scenario,
                arm.advisor,
                week_list(&arm_weeks(arm))
            );
        }
    }
}

/// `W1, W2, W13` style list.
fn week_list(weeks: &[Week]) -> String {
    weeks
        .iter()
        .map(|w| w.name())
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_compiled_in_paper_table_parses() {
        let t = paper_table1().unwrap();
        // W1 (5 bands, shared) + W13 and W14 for four scenarios.
        assert_eq!(t.len(), 5 + 2 * 4 * 5);
        use ArmKind::{Abba, R2r};
        use ScenarioId::{S1, S2, S4};
        let tir = Metric::Tir70To180;
        let v = paper_value(&t, S2, Abba, Week::W1, tir).unwrap();
        assert_eq!(
            (v.scenarios.to_string().as_str(), v.mean, v.sd),
            ("S1-S3", 89.9, 8.7)
        );
        assert!(paper_value(&t, S4, Abba, Week::W1, tir).is_none());
        assert!(paper_value(&t, S1, R2r, Week::W13, tir).is_none());
        let v = paper_value(&t, S4, Abba, Week::W13, Metric::Hyper180To300).unwrap();
        assert_eq!((v.mean, v.sd), (21.5, 15.0));
    }

    #[test]
    fn bad_paper_rows_name_the_line() {
        let e = parse_paper_table("scenario,week,metric,mean,sd\nS1,W13,tir_70_180,x,1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("mean \"x\""), "{e}");
        let e = parse_paper_table("scenario,week,metric,mean,sd\nS1,W13,tir,1,1\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("metric \"tir\""), "{e}");
        let e = parse_paper_table(
            "scenario,week,metric,mean,sd\nS1-S3,W1,tir_70_180,1,1\nS2,W1,tir_70_180,1,1\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 3") && e.contains("twice"), "{e}");
        assert!(parse_paper_table("a,b\n").is_err());
    }

    #[test]
    fn anchors_follow_the_papers_statements() {
        use ArmKind::{Abba, R2r, Standard};
        use Metric::{Hbgi, Lbgi};
        use ScenarioId::{S1, S3, S4};
        let a = anchor(S1, Standard, Week::W1, Lbgi).unwrap();
        assert!(a.holds(1.1) && a.holds(2.49) && !a.holds(1.0) && !a.holds(2.5));
        assert!(anchor(S4, Abba, Week::W1, Lbgi).is_none());
        assert!(anchor(S4, Abba, Week::W13, Lbgi).unwrap().holds(1.0));
        assert!(anchor(S4, R2r, Week::W13, Lbgi).is_none());
        assert!(anchor(S3, Abba, Week::W14, Hbgi).is_some());
        assert!(anchor(S3, Standard, Week::W14, Hbgi).is_none());
        assert!(anchor(S3, Abba, Week::W14, Lbgi).is_none());
        assert_eq!(format_p(0.0004), "<0.001");
        assert_eq!(format_p(0.04088), "0.041");
    }
}
