//! The trial report as one page (`report.html`): the run's facts, Table I
//! beside the paper's, the figures, the arms side by side, the stopped
//! runs, any extra section the trial adds (the W1 sensitivity block), and
//! an AGP-style page per arm: the cohort's pooled glucose percentiles by
//! time of day at W1, W13 and W14.

use abba_core::metrics::range_percentages;
use abba_core::Metric;
use rayon::prelude::*;
use serde::Serialize;
use serde_json::Value;

use crate::error::ReportError;
use crate::figures;
use crate::html::profile::{time_of_day_profile, ProfileBin};
use crate::html::svg::{accessible_svg, profile_svg, tir_bar_svg, HALF_WIDTH};
use crate::html::{render_page, HtmlSection, Row};
use crate::results::{ArmResult, Week};
use crate::select::{
    failure_time, metric_column, ordered_arms, stopped_runs, table_weeks, validate_arms, weeks_note,
};
use crate::stats::{summarize_present, wilcoxon_signed_rank_present};
use crate::summary::REPORT_WILCOXON;
use crate::table1::{format_p, table1_rows, TABLE1_METRICS};
use abba_advisor::ArmKind;
use abba_core::units::GlucoseUnit;

/// Minutes between the plasma glucose samples kept in [`crate::WeekResult`].
pub const SAMPLE_MIN: u32 = 5;
/// Width of the cohort profile's time-of-day bins (minutes).
pub const COHORT_BIN_MIN: u32 = 15;

/// The cohort profile of one arm in one week.
#[derive(Debug, Clone, PartialEq)]
pub struct CohortWeekProfile {
    /// The week.
    pub week: Week,
    /// Patients whose samples are pooled.
    pub n_patients: usize,
    /// All samples pooled (mg/dL).
    pub n_samples: usize,
    /// The percentiles by time of day.
    pub profile: Vec<ProfileBin>,
    /// The five consensus ranges of the pooled samples (%), lowest first.
    pub ranges_pct: [f64; 5],
}

/// The pooled profile of `arm` in `week`, from the 5-min plasma glucose the
/// results keep for the Table I weeks (`None` if no patient has them).
pub fn cohort_profile(
    arm: &ArmResult,
    week: Week,
) -> Result<Option<CohortWeekProfile>, ReportError> {
    let series: Vec<&[f32]> = arm
        .patients
        .iter()
        .filter_map(|p| p.week(week))
        .map(|w| w.plasma_5min_mg_dl.as_slice())
        .filter(|s| !s.is_empty())
        .collect();
    if series.is_empty() {
        return Ok(None);
    }
    let pooled: Vec<(u32, f64)> = series
        .iter()
        .flat_map(|s| {
            s.iter()
                .enumerate()
                .map(|(i, g)| ((i as u32 * SAMPLE_MIN) % 1440, f64::from(*g)))
        })
        .collect();
    let values: Vec<f64> = pooled.iter().map(|p| p.1).collect();
    // Only the ranges are drawn: no risk indices or MAGE over the pool.
    let [below_54, below_70, tir, above_180, above_250] =
        range_percentages(&values).map_err(|source| ReportError::Stats {
            what: format!("arm {}, week {week}: pooled glucose", arm.key()),
            source,
        })?;
    Ok(Some(CohortWeekProfile {
        week,
        n_patients: series.len(),
        n_samples: values.len(),
        profile: time_of_day_profile(pooled, COHORT_BIN_MIN),
        ranges_pct: [
            below_54,
            below_70 - below_54,
            tir,
            above_180 - above_250,
            above_250,
        ],
    }))
}

fn mean_sd(s: &crate::stats::Summary, decimals: usize) -> String {
    match s.sd {
        Some(sd) => format!("{:.decimals$} ± {:.decimals$}", s.mean, sd),
        None => format!("{:.decimals$}", s.mean),
    }
}

fn decimals(metric: Metric) -> usize {
    match metric {
        Metric::Lbgi | Metric::Hbgi => 2,
        _ => 1,
    }
}

#[derive(Serialize)]
struct Figure {
    svg: String,
    caption: String,
}

#[derive(Serialize)]
struct ArmAgp {
    key: String,
    heading: String,
    weeks: Vec<Figure>,
}

#[derive(Serialize)]
struct ScenarioTable {
    scenario: String,
    headers: Vec<String>,
    rows: Vec<Row>,
}

/// What ran (from the manifest), and which weeks the results have.
fn facts(manifest: &Value, arms: &[ArmResult]) -> Vec<Row> {
    let get = |path: &str| {
        manifest.pointer(path).map(|v| match v {
            Value::String(s) => s.clone(),
            other => other.to_string(),
        })
    };
    [
        ("Version", "/version"),
        ("Git revision", "/git_revision"),
        ("Seed", "/seed"),
        ("Patients", "/cohort/patients"),
        ("Population", "/cohort/population"),
        ("Days", "/protocol/days"),
        ("Scenarios", "/protocol/scenarios"),
        ("Arms", "/protocol/arms"),
    ]
    .into_iter()
    .filter_map(|(k, p)| get(p).map(|v| Row::of([k, &v])))
    .chain(std::iter::once(Row::of(["Weeks", &weeks_note(arms)])))
    .collect()
}

/// `abba − other` of `metric` in `week`: the mean of the paired
/// differences over the patients both arms have, and the two-sided
/// Wilcoxon signed-rank p of those pairs ("—" without pairs).
fn paired_difference(
    abba: &ArmResult,
    other: &ArmResult,
    week: Week,
    metric: Metric,
) -> Result<String, ReportError> {
    let a = metric_column(abba, week, metric);
    let b = metric_column(other, week, metric);
    let pairs: Vec<f64> = a
        .iter()
        .zip(&b)
        .filter_map(|(x, y)| Some((*x)? - (*y)?))
        .collect();
    if pairs.is_empty() || a.len() != b.len() {
        return Ok("—".into());
    }
    let mean = pairs.iter().sum::<f64>() / pairs.len() as f64;
    let test = wilcoxon_signed_rank_present(&b, &a, REPORT_WILCOXON).map_err(|source| {
        ReportError::Stats {
            what: format!(
                "{} against {}, week {week}, metric {metric}",
                abba.key(),
                other.key()
            ),
            source,
        }
    })?;
    let d = decimals(metric);
    Ok(format!(
        "{mean:+.d$} ({})",
        test.p
            .map_or_else(|| "p —".into(), |p| format!("p {}", format_p(p)))
    ))
}

/// The trial report page. `manifest` is the run's manifest (what ran);
/// `extra` sections are placed after the stopped runs. The page is built in
/// named steps, each a function of the results: [`table1_cells`],
/// [`figure_list`], [`side_by_side_tables`], [`stopped_rows`] and
/// [`agp_sections`].
pub fn trial_report_html(
    arms: &[ArmResult],
    manifest: &Value,
    extra: &[HtmlSection],
) -> Result<String, ReportError> {
    validate_arms(arms)?;
    let table1 = table1_cells(arms)?;
    let figures = figure_list(arms)?;
    let ordered = ordered_arms(arms);
    let shown = table_weeks(arms);
    let scenarios = side_by_side_tables(&ordered, &shown)?;
    let stopped = stopped_rows(&ordered);
    let agp = agp_sections(&ordered, &shown)?;
    let ctx = minijinja::context! {
        title => "abba in-silico trial report",
        facts => facts(manifest, arms),
        table1 => table1,
        figures => figures,
        scenarios => scenarios,
        stopped => stopped,
        extra => extra,
        agp => agp,
    };
    render_page("trial.html", "trial report", ctx)
}

/// Table I as the page shows it: one row per arm, week and metric, ours
/// (mean ± SD, median [Q1, Q3]) beside the paper's, p against W1 and the
/// paper's statement.
fn table1_cells(arms: &[ArmResult]) -> Result<Vec<Row>, ReportError> {
    Ok(table1_rows(arms)?
        .iter()
        .map(|r| {
            let d = decimals(r.metric);
            Row::of([
                &format!("{}/{} ({})", r.scenario, r.advisor, r.mode.name()),
                r.week.name(),
                r.metric.label(),
                &mean_sd(&r.ours, d),
                &format!(
                    "{:.d$} [{:.d$}, {:.d$}]",
                    r.ours.median, r.ours.q1, r.ours.q3
                ),
                &r.paper
                    .as_ref()
                    .map_or_else(|| "—".into(), |p| format!("{:.d$} ± {:.d$}", p.mean, p.sd)),
                &r.p_vs_w1.map_or_else(|| "—".into(), format_p),
                &r.anchor.map_or_else(
                    || "—".into(),
                    |a| {
                        format!(
                            "{} ({})",
                            a.text,
                            if a.holds(r.ours.mean) {
                                "holds"
                            } else {
                                "does not hold"
                            }
                        )
                    },
                ),
            ])
        })
        .collect())
}

/// The figures (5, 6, 7 and the arms), each made accessible (title, desc).
fn figure_list(arms: &[ArmResult]) -> Result<Vec<Figure>, ReportError> {
    let figs = [
        (
            "fig5",
            figures::fig5_lbgi_hbgi(arms)?,
            "Figure 5: weekly LBGI and HBGI, ABBA arms",
            "Weekly low and high blood glucose indices of the ABBA arms, mean over patients, by scenario (paper Fig. 5).",
        ),
        (
            "fig6",
            figures::fig6_mage(arms)?,
            "Figure 6: weekly MAGE, ABBA arms",
            "Weekly mean amplitude of glycaemic excursions (mg/dL) of the ABBA arms, mean over patients (paper Fig. 6).",
        ),
        (
            "fig7",
            figures::fig7_tdi(arms)?,
            "Figure 7: weekly total daily insulin, ABBA arms",
            "Box plots over patients of the weekly mean total daily insulin (U/day) of the ABBA arms (paper Fig. 7).",
        ),
        (
            "figarms",
            figures::fig_arms(arms)?,
            "ABBA against the baselines",
            "Weekly time in 70-180 mg/dL and insulin, mean over patients, for every arm in each scenario.",
        ),
    ];
    Ok(figs
        .into_iter()
        .map(|(id, svg, title, desc)| Figure {
            svg: accessible_svg(&svg, id, title, desc),
            caption: desc.to_string(),
        })
        .collect())
}

/// The metrics of the side-by-side tables: Table I's, then mean glucose,
/// CV and total daily insulin.
fn side_by_side_metrics() -> impl Iterator<Item = Metric> {
    TABLE1_METRICS
        .into_iter()
        .chain([Metric::MeanMgDl, Metric::CvPct, Metric::TdiUPerDay])
}

/// One table per scenario: every arm's mean ± SD in each shown week, and
/// ABBA's paired difference against every other arm.
fn side_by_side_tables(
    ordered: &[&ArmResult],
    shown: &[Week],
) -> Result<Vec<ScenarioTable>, ReportError> {
    let mut scenarios: Vec<ScenarioTable> = Vec::new();
    for scenario in abba_core::ScenarioId::ALL {
        let group: Vec<&ArmResult> = ordered
            .iter()
            .copied()
            .filter(|a| a.scenario == scenario)
            .collect();
        if group.is_empty() {
            continue;
        }
        scenarios.push(scenario_table(scenario, &group, shown)?);
    }
    Ok(scenarios)
}

/// The side-by-side table of one scenario's arms (`group`, report order).
fn scenario_table(
    scenario: abba_core::ScenarioId,
    group: &[&ArmResult],
    shown: &[Week],
) -> Result<ScenarioTable, ReportError> {
    let mut headers = vec!["Metric".to_string(), "Week".to_string()];
    headers.extend(group.iter().map(|a| format!("{} (mean ± SD)", a.advisor)));
    // ABBA against each other arm: the mean paired difference over the
    // patients both have, and its Wilcoxon signed-rank p.
    let abba = group.iter().copied().find(|a| a.advisor == ArmKind::Abba);
    let others: Vec<&ArmResult> = group
        .iter()
        .copied()
        .filter(|a| a.advisor != ArmKind::Abba)
        .collect();
    if abba.is_some() {
        headers.extend(others.iter().map(|a| format!("abba − {} (p)", a.advisor)));
    }
    let mut rows = Vec::new();
    for metric in side_by_side_metrics() {
        for &week in shown {
            if let Some(row) = side_by_side_row(group, abba, &others, week, metric)? {
                rows.push(row);
            }
        }
    }
    Ok(ScenarioTable {
        scenario: scenario.to_string(),
        headers,
        rows,
    })
}

/// One row of a side-by-side table (`None` when no arm has the week).
fn side_by_side_row(
    group: &[&ArmResult],
    abba: Option<&ArmResult>,
    others: &[&ArmResult],
    week: Week,
    metric: Metric,
) -> Result<Option<Row>, ReportError> {
    let mut cells = vec![
        format!("{} ({})", metric.label(), metric.unit().symbol()),
        week.name().to_string(),
    ];
    let mut any = false;
    for arm in group {
        let s = summarize_present(&metric_column(arm, week, metric)).map_err(|source| {
            ReportError::Stats {
                what: format!("arm {}, week {week}, metric {metric}", arm.key()),
                source,
            }
        })?;
        any |= s.is_some();
        cells.push(s.map_or_else(|| "—".into(), |s| mean_sd(&s, decimals(metric))));
    }
    if let Some(a) = abba {
        for o in others {
            cells.push(paired_difference(a, o, week, metric)?);
        }
    }
    Ok(any.then_some(Row { cells }))
}

/// One row per stopped run: arm, patient, when, plasma glucose.
fn stopped_rows(ordered: &[&ArmResult]) -> Vec<Row> {
    ordered
        .iter()
        .flat_map(|arm| {
            stopped_runs(arm).into_iter().map(move |(patient, f)| {
                Row::of([
                    &arm.key(),
                    patient,
                    &failure_time(&f),
                    &format!("{:.1} mg/dL", f.glucose_mg_dl),
                ])
            })
        })
        .collect()
}

/// Per arm, the cohort's glucose profile and time in ranges in each shown
/// week (arms without any kept samples are left out).
fn agp_sections(ordered: &[&ArmResult], shown: &[Week]) -> Result<Vec<ArmAgp>, ReportError> {
    // The pooled profiles (each sorts some 200,000 readings into bins) are
    // independent: computed in parallel, drawn in order.
    let profiles: Vec<Vec<Option<CohortWeekProfile>>> = ordered
        .par_iter()
        .map(|arm| {
            shown
                .iter()
                .map(|&week| cohort_profile(arm, week))
                .collect::<Result<_, _>>()
        })
        .collect::<Result<_, ReportError>>()?;
    let mut agp = Vec::new();
    for (i, (arm, arm_profiles)) in ordered.iter().zip(profiles).enumerate() {
        let weeks: Vec<Figure> = shown
            .iter()
            .zip(arm_profiles)
            .filter_map(|(&week, c)| c.map(|c| (week, c)))
            .flat_map(|(week, c)| agp_week_figures(i, arm, week, &c))
            .collect();
        if !weeks.is_empty() {
            agp.push(ArmAgp {
                key: arm.key(),
                heading: format!(
                    "{} ({} mode): cohort glucose profile",
                    arm.key(),
                    arm.mode.name()
                ),
                weeks,
            });
        }
    }
    Ok(agp)
}

/// The two figures of arm number `i` in one week: the percentile profile
/// and the time-in-ranges bar.
fn agp_week_figures(i: usize, arm: &ArmResult, week: Week, c: &CohortWeekProfile) -> [Figure; 2] {
    let (a, b) = week.days();
    let title = format!(
        "{} {} (D{a}-D{b}), {} patients",
        arm.key(),
        week,
        c.n_patients
    );
    [
        Figure {
            svg: profile_svg(
                &format!("agp{i}{week}"),
                &c.profile,
                GlucoseUnit::MgDl,
                &title,
                HALF_WIDTH,
            ),
            caption: format!(
                "{week}: pooled percentiles of plasma glucose every 5 min over {} samples.",
                c.n_samples
            ),
        },
        Figure {
            svg: tir_bar_svg(
                &format!("tir{i}{week}"),
                c.ranges_pct,
                &format!("{} {week}: time in ranges", arm.key()),
                GlucoseUnit::MgDl,
            ),
            caption: format!("{week}: % of pooled samples in the consensus ranges."),
        },
    ]
}
