//! The report's figures, data first: [`weekly_series`] (an arm's weekly
//! summaries of a metric: the data of a line) and [`tdi_boxes`] (Tukey
//! boxes of weekly TDI) are computed from the results and can be rendered
//! by anything (the HTML report to come); the functions below draw them as
//! SVG through [`crate::chart`]:
//!
//! - [`fig5_lbgi_hbgi`]: the paper's Fig. 5. Weekly LBGI (left) and HBGI
//!   (right) of the `abba` arm, one row per scenario: mean over
//!   patients (line) and mean ± 1 SD (shaded, cut at 0), with the paper's
//!   risk limits dashed (LBGI 1.1 and 2.5, HBGI 5).
//! - [`fig6_mage`]: the paper's Fig. 6. Weekly mean MAGE of the `abba` arm,
//!   one line per scenario, ± 1 SD as error bars (scenarios dodged
//!   sideways so the bars do not overlap). Means over the patients whose
//!   MAGE is defined; the number of undefined patient-weeks is printed.
//! - [`fig7_tdi`]: the paper's Fig. 7. Weekly total daily insulin of the
//!   `abba` arm, box plots grouped by week, one box per scenario: box = Q1
//!   to Q3 (type-7 quartiles), bar = median, whiskers (Tukey) = the most
//!   extreme values within 1.5 IQR of the box, dots = values beyond them.
//! - [`fig_arms`]: ABBA against the baselines. Columns: % time in range
//!   70-180, % time < 70, % time > 180 mg/dL and total daily insulin; one
//!   row per scenario; weekly mean over patients of every arm that ran
//!   (abba, standard, r2r, autotune).
//!
//! Every figure is [`crate::chart::FIGURE_WIDTH`] wide with its text sized
//! so that it prints at 9 pt or more at A4 width (the report page's 186 mm
//! of text width); long footer notes and legends wrap.
//!
//! Weeks on the x axis are numbered 1..14: Wk = D(7k−5)-D(7k+1) for
//! k = 1..12 (W1 is standard therapy), 13 = D84-D90 and 14 = D92-D98, the
//! paper's evaluation weeks. Only weeks that were simulated are drawn, and
//! the footer names them (a 30-day run: weeks 1-4); a figure with nothing
//! to draw says so in its body.

use std::fmt::Write as _;

use abba_core::{Metric, ScenarioId};
use plotters::prelude::*;
use serde::Serialize;

use crate::chart::{
    axis_of, draw_message, draw_weekly_panel, nice_range, plot_err, render_svg, week_chart, week_x,
    Area, Footer, Key, Line, Panel, Spread, NEUTRAL, REF_COLOR, Y_LABEL_AREA,
};
use crate::error::ReportError;
use crate::results::{ArmKind, ArmResult, Week};
use crate::select::{arm_weeks, metric_column, ordered_arms, stopped_runs, validate_arms};
use crate::stats::{quantile_sorted, summarize_present, Summary};

/// Okabe-Ito colours of the scenarios S1..S4 (colour-blind safe).
fn scenario_color(scenario: ScenarioId) -> RGBColor {
    match scenario {
        ScenarioId::S1 => RGBColor(0, 114, 178),
        ScenarioId::S2 => RGBColor(230, 159, 0),
        ScenarioId::S3 => RGBColor(0, 158, 115),
        ScenarioId::S4 => RGBColor(204, 121, 167),
        ScenarioId::S5 => RGBColor(86, 180, 233),
        // Okabe-Ito vermillion.
        ScenarioId::S6 => RGBColor(213, 94, 0),
    }
}

/// Colours of the arms.
fn arm_color(advisor: ArmKind) -> RGBColor {
    let (r, g, b) = advisor.colour_rgb();
    RGBColor(r, g, b)
}

/// The weeks simulated in any of `arms`, in protocol order.
fn week_axis(arms: &[&ArmResult]) -> Vec<Week> {
    Week::ALL
        .into_iter()
        .filter(|w| arms.iter().any(|a| arm_weeks(a).contains(w)))
        .collect()
}

/// One arm's weekly summaries of one metric over its patients: the data of
/// one line of a weekly figure (weeks where no patient has a value are
/// left out).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeeklySeries {
    /// The arm's scenario.
    pub scenario: ScenarioId,
    /// The arm.
    pub advisor: ArmKind,
    /// The metric.
    pub metric: Metric,
    /// Each week with a value, and the summary over patients.
    pub points: Vec<(Week, Summary)>,
}

/// The [`WeeklySeries`] of `metric` for `arm` over `weeks`.
pub fn weekly_series(
    arm: &ArmResult,
    weeks: &[Week],
    metric: Metric,
) -> Result<WeeklySeries, ReportError> {
    let mut points = Vec::new();
    for &week in weeks {
        let summary = summarize_present(&metric_column(arm, week, metric)).map_err(|source| {
            ReportError::Stats {
                what: format!("arm {}, week {week}, metric {metric}", arm.key()),
                source,
            }
        })?;
        if let Some(summary) = summary {
            points.push((week, summary));
        }
    }
    Ok(WeeklySeries {
        scenario: arm.scenario,
        advisor: arm.advisor,
        metric,
        points,
    })
}

/// How a series is drawn: means only, or means with ± 1 SD.
fn line_of(series: &WeeklySeries, color: RGBColor, with_sd: bool) -> Line {
    let points = series
        .points
        .iter()
        .map(|(w, s)| {
            let sd = s.sd.unwrap_or(0.0);
            let spread = with_sd.then_some((s.mean - sd, s.mean + sd));
            (week_x(*w), s.mean, spread)
        })
        .collect();
    Line { color, points }
}

/// The ABBA arms (report order) and the weeks any of them has, after
/// checking the results.
fn abba_arms(arms: &[ArmResult]) -> Result<(Vec<&ArmResult>, Vec<Week>), ReportError> {
    validate_arms(arms)?;
    let abba: Vec<&ArmResult> = ordered_arms(arms)
        .into_iter()
        .filter(|a| a.advisor == ArmKind::Abba)
        .collect();
    let weeks = week_axis(&abba);
    Ok((abba, weeks))
}

/// Mean ± SD line of `key` for one ABBA arm, in its scenario's colour.
fn mean_sd_line(arm: &ArmResult, weeks: &[Week], key: Metric) -> Result<Line, ReportError> {
    Ok(line_of(
        &weekly_series(arm, weeks, key)?,
        scenario_color(arm.scenario),
        true,
    ))
}

fn max_of(lines: &[Line]) -> f64 {
    lines
        .iter()
        .flat_map(|l| {
            l.points
                .iter()
                .map(|(_, m, s)| s.map_or(*m, |(_, h)| h.max(*m)))
        })
        .fold(0.0, f64::max)
}

/// `n = 20` or, with stopped runs, `n = 20, 3 stopped`.
fn n_text(arm: &ArmResult) -> String {
    let stopped = stopped_runs(arm).len();
    if stopped == 0 {
        format!("n = {}", arm.patients.len())
    } else {
        format!("n = {}, {stopped} stopped", arm.patients.len())
    }
}

/// The footer notes of a figure: `first` (if any), the weeks, and the runs
/// stopped early among `arms` (if any).
fn footer_notes(first: Option<String>, arms: &[&ArmResult]) -> Vec<String> {
    let stopped: usize = arms.iter().map(|a| stopped_runs(a).len()).sum();
    let total: usize = arms.iter().map(|a| a.patients.len()).sum();
    let stopped_note = (stopped > 0).then(|| {
        format!(
            "{stopped} of {total} runs stopped early (plasma glucose below the failure threshold); \
             weeks after a stop are summarised over the remaining patients."
        )
    });
    let weeks = weeks_footer(&week_axis(arms));
    [first, Some(weeks), stopped_note]
        .into_iter()
        .flatten()
        .collect()
}

/// The footer's sentence on the weeks: how a week is numbered, and of the
/// paper's weeks 13 and 14 only those the run has (a shorter run names
/// the weeks it has instead).
fn weeks_footer(weeks: &[Week]) -> String {
    let mut s = String::from(
        "Week k = days 7k-5 to 7k+1 (week 1 = D2-D8, standard therapy before any adaptation)",
    );
    match (weeks.contains(&Week::W13), weeks.contains(&Week::W14)) {
        (true, true) => s.push_str(
            "; week 13 = D84-D90 (with insulin-sensitivity variability), week 14 = D92-D98 (without).",
        ),
        (true, false) => s.push_str(
            "; week 13 = D84-D90 (with insulin-sensitivity variability); week 14 not simulated.",
        ),
        (false, _) => {
            let last = weeks.last().map_or(0, |w| w.number());
            let _ = write!(
                s,
                "; this run has weeks 1-{last} (the paper's weeks 13 and 14 need 98 days)."
            );
        }
    }
    s
}

/// One legend entry per ABBA arm: its scenario and patients, in its colour.
fn scenario_legend(abba: &[&ArmResult], key: Key) -> Vec<(String, RGBColor, Key)> {
    abba.iter()
        .map(|a| {
            (
                format!("{} ({})", a.scenario, n_text(a)),
                scenario_color(a.scenario),
                key,
            )
        })
        .collect()
}

const NO_ABBA: &str = "No ABBA arm in this trial.";

/// `fig5_lbgi_hbgi.svg`: weekly LBGI and HBGI of the `abba` arms (see the module docs).
pub fn fig5_lbgi_hbgi(arms: &[ArmResult]) -> Result<String, ReportError> {
    const FIG: &str = "fig5_lbgi_hbgi.svg";
    let (abba, weeks) = abba_arms(arms)?;
    let title = "Fig. 5 - Weekly LBGI and HBGI, ABBA (mean ± SD over patients)";
    let items = [
        ("mean".to_string(), NEUTRAL, Key::Line),
        ("mean ± 1 SD (cut at 0)".to_string(), NEUTRAL, Key::Band),
        (
            "paper's risk limits: LBGI minimal < 1.1, low 1.1-2.5; HBGI minimal < 5".to_string(),
            REF_COLOR,
            Key::Dashed,
        ),
    ];
    let notes = footer_notes(None, &abba);
    let footer = Footer {
        items: &items,
        notes: &notes,
    };
    // One row per scenario (LBGI left, HBGI right), so that a panel keeps
    // half the page's width at any number of scenarios.
    let rows = abba.len().max(1) as u32;
    render_svg(PANEL_HEIGHT * rows, title, &footer, FIG, |main| {
        if abba.is_empty() {
            return draw_message(main, NO_ABBA, FIG);
        }
        let mut lbgi = Vec::new();
        let mut hbgi = Vec::new();
        for arm in &abba {
            lbgi.push(mean_sd_line(arm, &weeks, Metric::Lbgi)?);
            hbgi.push(mean_sd_line(arm, &weeks, Metric::Hbgi)?);
        }
        let lbgi_max = nice_range(0.0, max_of(&lbgi).max(3.0)).1;
        let hbgi_max = nice_range(0.0, max_of(&hbgi).max(6.0)).1;
        let panels = main.split_evenly((abba.len(), 2));
        for (i, arm) in abba.iter().enumerate() {
            let n = n_text(arm);
            let panel = |metric: Metric, y_max: f64, refs| Panel {
                caption: format!("{} · {} ({n})", arm.scenario, metric.label()),
                y_desc: metric.label(),
                y_range: (0.0, y_max),
                refs,
                spread: Spread::Shaded,
            };
            let cells: [(usize, Panel, &Line); 2] = [
                (
                    2 * i,
                    panel(Metric::Lbgi, lbgi_max, &[(1.1, "1.1"), (2.5, "2.5")]),
                    &lbgi[i],
                ),
                (
                    2 * i + 1,
                    panel(Metric::Hbgi, hbgi_max, &[(5.0, "5")]),
                    &hbgi[i],
                ),
            ];
            for (at, panel, line) in cells {
                draw_weekly_panel(&panels[at], &weeks, &panel, std::slice::from_ref(line), FIG)?;
            }
        }
        Ok(())
    })
}

/// The height of one row of weekly panels (SVG units).
const PANEL_HEIGHT: u32 = 210;

/// The height of a figure's single weekly panel (SVG units).
const SINGLE_PANEL_HEIGHT: u32 = 420;

/// `fig6_mage.svg`: weekly MAGE of the `abba` arms (see the module docs).
pub fn fig6_mage(arms: &[ArmResult]) -> Result<String, ReportError> {
    const FIG: &str = "fig6_mage.svg";
    let (abba, weeks) = abba_arms(arms)?;
    let title = "Fig. 6 - Weekly MAGE, ABBA (mean ± SD over patients)";
    let (mut undefined, mut total) = (0usize, 0usize);
    for wk in abba
        .iter()
        .flat_map(|a| a.patients.iter().flat_map(|p| &p.weeks))
    {
        total += 1;
        undefined += usize::from(wk.metrics.mage.is_none());
    }
    let first = format!(
        "Bars: ± 1 SD. MAGE: iglu's moving-average algorithm; undefined (no countable excursion) \
         for {undefined} of {total} patient-weeks, left out of the means."
    );
    let items = scenario_legend(&abba, Key::Line);
    let notes = footer_notes(Some(first), &abba);
    let footer = Footer {
        items: &items,
        notes: &notes,
    };
    render_svg(SINGLE_PANEL_HEIGHT, title, &footer, FIG, |main| {
        if abba.is_empty() {
            return draw_message(main, NO_ABBA, FIG);
        }
        let mut lines = Vec::new();
        for arm in &abba {
            lines.push(mean_sd_line(arm, &weeks, Metric::Mage)?);
        }
        // From 0 mg/dL, as a reader expects.
        let y_range = nice_range(0.0, max_of(&lines));
        draw_weekly_panel(
            main,
            &weeks,
            &Panel {
                caption: String::new(),
                y_desc: Metric::Mage.label(),
                y_range,
                refs: &[],
                spread: Spread::ErrorBars { dodge: 0.12 },
            },
            &lines,
            FIG,
        )
    })
}

/// A Tukey box: quartiles, whiskers and outliers of some values (the data
/// of one box of Fig. 7).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TukeyBox {
    /// First quartile (type 7).
    pub q1: f64,
    /// Median.
    pub median: f64,
    /// Third quartile (type 7).
    pub q3: f64,
    /// Lower whisker: the smallest value within 1.5 IQR below Q1.
    pub low: f64,
    /// Upper whisker: the largest value within 1.5 IQR above Q3.
    pub high: f64,
    /// Values beyond the whiskers, ascending.
    pub outliers: Vec<f64>,
}

/// Tukey box of `values` (not empty).
pub fn tukey_box(values: &[f64]) -> TukeyBox {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let q1 = quantile_sorted(&v, 0.25);
    let median = quantile_sorted(&v, 0.5);
    let q3 = quantile_sorted(&v, 0.75);
    let iqr = q3 - q1;
    let (lo_fence, hi_fence) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
    let inside = |x: &f64| *x >= lo_fence && *x <= hi_fence;
    TukeyBox {
        q1,
        median,
        q3,
        low: v.iter().copied().find(inside).unwrap_or(q1),
        high: v.iter().copied().rev().find(inside).unwrap_or(q3),
        outliers: v.iter().copied().filter(|x| !inside(x)).collect(),
    }
}

/// Draws one box at `xc`, half width `half`.
fn draw_box(
    chart: &mut crate::chart::WeekChart,
    xc: f64,
    half: f64,
    color: RGBColor,
    b: &TukeyBox,
    figure: &'static str,
) -> Result<(), ReportError> {
    let pe = plot_err(figure);
    let stroke = color.stroke_width(1);
    let (q1, q3) = (b.q1, b.q3);
    chart
        .draw_series([
            Rectangle::new([(xc - half, q1), (xc + half, q3)], color.mix(0.35).filled()),
            Rectangle::new([(xc - half, q1), (xc + half, q3)], stroke),
        ])
        .map_err(&pe)?;
    let whisker =
        |y: f64| PathElement::new(vec![(xc - half / 2.0, y), (xc + half / 2.0, y)], stroke);
    chart
        .draw_series([
            PathElement::new(
                vec![(xc - half, b.median), (xc + half, b.median)],
                color.stroke_width(3),
            ),
            PathElement::new(vec![(xc, q3), (xc, b.high)], stroke),
            PathElement::new(vec![(xc, q1), (xc, b.low)], stroke),
            whisker(b.high),
            whisker(b.low),
        ])
        .map_err(&pe)?;
    chart
        .draw_series(b.outliers.iter().map(|&y| Circle::new((xc, y), 2, stroke)))
        .map_err(&pe)?;
    Ok(())
}

/// `fig7_tdi.svg`: weekly TDI box plots of the `abba` arms (see the module docs).
pub fn fig7_tdi(arms: &[ArmResult]) -> Result<String, ReportError> {
    const FIG: &str = "fig7_tdi.svg";
    let (abba, weeks) = abba_arms(arms)?;
    let title = "Fig. 7 - Weekly total daily insulin (TDI), ABBA";
    let first = "Box: Q1-Q3 of the patients' weekly mean TDI; thick bar: median; whiskers: most extreme values \
                 within 1.5 IQR of the box (Tukey); dots: values beyond."
        .to_string();
    let items = scenario_legend(&abba, Key::Box);
    let notes = footer_notes(Some(first), &abba);
    let footer = Footer {
        items: &items,
        notes: &notes,
    };
    render_svg(SINGLE_PANEL_HEIGHT, title, &footer, FIG, |main| {
        if abba.is_empty() {
            draw_message(main, NO_ABBA, FIG)
        } else {
            draw_tdi_boxes(main, &abba, &weeks, FIG)
        }
    })
}

/// One box of Fig. 7: the weekly mean TDI of an arm's patients in one week.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WeekBox {
    /// The arm's scenario.
    pub scenario: ScenarioId,
    /// The week.
    pub week: Week,
    /// The box over the patients that have the week.
    pub tukey: TukeyBox,
}

/// The boxes of Fig. 7, arm by arm, week by week (weeks without values left
/// out). A TDI that is not finite is an error.
pub fn tdi_boxes(abba: &[&ArmResult], weeks: &[Week]) -> Result<Vec<WeekBox>, ReportError> {
    let mut boxes = Vec::new();
    for arm in abba {
        for &week in weeks {
            let values: Vec<f64> = metric_column(arm, week, Metric::TdiUPerDay)
                .into_iter()
                .flatten()
                .collect();
            if values.is_empty() {
                continue;
            }
            if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                return Err(ReportError::InconsistentResults(format!(
                    "arm {}, week {week}: tdi_u_per_day is {bad}, expected a finite number",
                    arm.key()
                )));
            }
            boxes.push(WeekBox {
                scenario: arm.scenario,
                week,
                tukey: tukey_box(&values),
            });
        }
    }
    Ok(boxes)
}

/// The body of Fig. 7: one box per ABBA arm and week, dodged sideways.
fn draw_tdi_boxes(
    main: &Area,
    abba: &[&ArmResult],
    weeks: &[Week],
    figure: &'static str,
) -> Result<(), ReportError> {
    let boxes = tdi_boxes(abba, weeks)?;
    let (mut y_min, mut y_max) = (f64::INFINITY, 0.0f64);
    for b in &boxes {
        let t = &b.tukey;
        y_min = y_min.min(t.outliers.first().map_or(t.low, |o| o.min(t.low)));
        y_max = y_max.max(t.outliers.last().map_or(t.high, |o| o.max(t.high)));
    }
    // From 0 U/day, as a reader expects.
    let y_range = if y_min.is_finite() {
        nice_range(0.0, y_max)
    } else {
        (0.0, 1.0)
    };
    let axis = axis_of(weeks);
    let mut chart = week_chart(
        main,
        &axis,
        y_range,
        None,
        Metric::TdiUPerDay.label(),
        Y_LABEL_AREA,
        figure,
    )?;
    let k = abba.len() as f64;
    let slot = 0.8 / k;
    let half = (slot * 0.36).min(0.15);
    for b in &boxes {
        let j = abba
            .iter()
            .position(|a| a.scenario == b.scenario)
            .unwrap_or(0);
        let xc = week_x(b.week) + (j as f64 - (k - 1.0) / 2.0) * slot;
        draw_box(
            &mut chart,
            xc,
            half,
            scenario_color(b.scenario),
            &b.tukey,
            figure,
        )?;
    }
    Ok(())
}

/// `fig_arms.svg`: ABBA against the baselines (see the module docs).
pub fn fig_arms(arms: &[ArmResult]) -> Result<String, ReportError> {
    const FIG: &str = "fig_arms.svg";
    validate_arms(arms)?;
    let ordered = ordered_arms(arms);
    let mut scenarios: Vec<ScenarioId> = ordered.iter().map(|a| a.scenario).collect();
    scenarios.dedup();
    let mut advisors: Vec<ArmKind> = ordered.iter().map(|a| a.advisor).collect();
    advisors.sort();
    advisors.dedup();
    let weeks = week_axis(&ordered);
    // (metric, least y top); every y axis starts at 0
    let rows: [(Metric, f64); 4] = [
        (Metric::Tir70To180, 100.0),
        (Metric::Below70, 2.0),
        (Metric::Above180, 10.0),
        (Metric::TdiUPerDay, 10.0),
    ];
    let title = "ABBA vs baselines - weekly time in ranges and insulin (mean over patients)";
    let items: Vec<(String, RGBColor, Key)> = advisors
        .iter()
        .map(|a| (a.label().to_string(), arm_color(*a), Key::Line))
        .collect();
    let notes = footer_notes(None, &ordered);
    let footer = Footer {
        items: &items,
        notes: &notes,
    };
    // One row per scenario, one column per metric (the page's width holds
    // four panels at any number of scenarios).
    let n_rows = scenarios.len().max(1) as u32;
    render_svg(PANEL_HEIGHT * n_rows, title, &footer, FIG, |main| {
        let panels = main.split_evenly((scenarios.len(), rows.len()));
        for (c, (metric, hi_floor)) in rows.iter().enumerate() {
            let label = metric.short_label();
            let mut per_scenario = Vec::new();
            for s in &scenarios {
                let mut lines = Vec::new();
                for a in ordered.iter().filter(|a| a.scenario == *s) {
                    let series = weekly_series(a, &weeks, *metric)?;
                    lines.push(line_of(&series, arm_color(a.advisor), false));
                }
                per_scenario.push(lines);
            }
            let all: Vec<f64> = per_scenario
                .iter()
                .flatten()
                .flat_map(|l| l.points.iter().map(|p| p.1))
                .collect();
            // Every axis from 0, as a reader expects (TIR 0-100 %); the
            // others up to at least `hi_floor`.
            let hi = all.iter().copied().fold(0.0, f64::max);
            let y_range = if *metric == Metric::Tir70To180 {
                (0.0, 100.0)
            } else {
                nice_range(0.0, hi.max(*hi_floor))
            };
            for (r, s) in scenarios.iter().enumerate() {
                draw_weekly_panel(
                    &panels[r * rows.len() + c],
                    &weeks,
                    &Panel {
                        // The unit is on the y axis; the caption must
                        // fit a quarter of the page's width.
                        caption: format!("{s} · {}", label.trim_end_matches(" mg/dL")),
                        y_desc: label,
                        y_range,
                        refs: &[],
                        spread: Spread::Hidden,
                    },
                    &per_scenario[r],
                    FIG,
                )?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::{nice_range, nice_step, tidy, week_tick, week_x};

    #[test]
    fn nice_ranges_and_labels() {
        for (lo, hi, want) in [
            (0.0, 3.0, (0.0, 3.0)),
            (0.0, 2.3, (0.0, 2.5)),
            (0.0, 6.5, (0.0, 8.0)),
            (38.4, 57.7, (35.0, 60.0)),
            (75.2, 100.0, (75.0, 100.0)),
        ] {
            let got = nice_range(lo, hi);
            assert_eq!(
                got, want,
                "nice_range({lo}, {hi}): expected {want:?}, got {got:?}"
            );
        }
        // A flat series still gets a range around it.
        let (a, b) = nice_range(40.0, 40.0);
        assert!(a < 40.0 && b > 40.0, "nice_range(40, 40) = ({a}, {b})");
        assert_eq!(nice_step(0.4), 0.5);
        assert_eq!(nice_step(1.08), 2.0);
        assert_eq!(
            (tidy(&40.0), tidy(&2.5), tidy(&0.25), tidy(&-0.0)),
            ("40".into(), "2.5".into(), "0.25".into(), "0".into())
        );
    }

    #[test]
    fn tukey_whiskers_stop_at_the_fences() {
        // Sorted 1..=9 and 30: Q1 = 3.25, Q3 = 7.75, IQR 4.5, fences −3.5 and 14.5.
        let mut v: Vec<f64> = (1..=9).map(f64::from).collect();
        v.push(30.0);
        let b = tukey_box(&v);
        assert_eq!(
            (b.q1, b.median, b.q3, b.low, b.high),
            (3.25, 5.5, 7.75, 1.0, 9.0)
        );
        assert_eq!(b.outliers, vec![30.0]);
    }

    #[test]
    fn week_ticks_label_integers_only() {
        assert_eq!(week_tick(&13.0), "13");
        assert_eq!(week_tick(&0.5), "");
        assert_eq!(week_tick(&15.0), "");
        assert_eq!(week_x(Week::W14), 14.0);
        // A narrow panel labels every third week, counted back from the last.
        let labels: Vec<String> = (1..=14)
            .map(|k| crate::chart::week_tick_every(&f64::from(k), 3, 14))
            .filter(|l| !l.is_empty())
            .collect();
        assert_eq!(labels, ["2", "5", "8", "11", "14"]);
    }
}
