//! The report's SVG figures (plotters, SVG backend; text is SVG `<text>`
//! in the generic `sans-serif` family, so no font files are needed):
//!
//! - [`fig5_lbgi_hbgi`]: the paper's Fig. 5. Weekly LBGI (top row) and HBGI
//!   (bottom row) of the `abba` arm, one column per scenario: mean over
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
//! - [`fig_arms`]: ABBA against the baselines. Rows: % time in range
//!   70-180, % time < 70, % time > 180 mg/dL and total daily insulin; one
//!   column per scenario; weekly mean over patients of each arm (abba,
//!   standard, r2r).
//!
//! Weeks on the x axis are numbered 1..14: Wk = D(7k−5)-D(7k+1) for
//! k = 1..12 (W1 is standard therapy), 13 = D84-D90 and 14 = D92-D98, the
//! paper's evaluation weeks. Only weeks that were simulated are drawn; a
//! figure with nothing to draw says so in its body.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{arm_weeks, metric_column, ordered_arms, stopped_runs, validate_arms};
use crate::error::TrialError;
use crate::results::{evaluation_windows, ArmResult};
use crate::stats::{quantile_sorted, summarize_present, Summary};

/// Okabe-Ito colours of the scenarios S1..S4 (colour-blind safe).
const SCENARIO_COLORS: [RGBColor; 4] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
];
/// Colours of the arms abba, standard, r2r.
const ARM_COLORS: [(&str, RGBColor); 3] = [
    ("abba", RGBColor(0, 114, 178)),
    ("standard", RGBColor(90, 90, 90)),
    ("r2r", RGBColor(213, 94, 0)),
];
const FONT: &str = "sans-serif";
const REF_COLOR: RGBColor = RGBColor(150, 30, 30);
const NEUTRAL: RGBColor = RGBColor(90, 90, 90);

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

fn plot_err<E: std::fmt::Display>(figure: &'static str) -> impl Fn(E) -> TrialError {
    move |e| TrialError::Plot {
        figure,
        reason: e.to_string(),
    }
}

fn scenario_color(scenario: &str) -> RGBColor {
    match scenario {
        "S1" => SCENARIO_COLORS[0],
        "S2" => SCENARIO_COLORS[1],
        "S3" => SCENARIO_COLORS[2],
        "S4" => SCENARIO_COLORS[3],
        _ => BLACK,
    }
}

fn arm_color(advisor: &str) -> RGBColor {
    ARM_COLORS
        .iter()
        .find(|(a, _)| *a == advisor)
        .map_or(BLACK, |(_, c)| *c)
}

fn arm_label(advisor: &str) -> String {
    match advisor {
        "abba" => "ABBA".to_string(),
        "standard" => "standard therapy".to_string(),
        "r2r" => "run-to-run".to_string(),
        other => other.to_string(),
    }
}

/// The weeks simulated in any of `arms`, in protocol order.
fn week_axis(arms: &[&ArmResult]) -> Vec<String> {
    evaluation_windows()
        .into_iter()
        .map(|(w, _, _)| w)
        .filter(|w| arms.iter().any(|a| arm_weeks(a).contains(w)))
        .collect()
}

/// The x position (1-based) of a week on the axis; W13/W14 are 13 and 14.
fn week_number(week: &str) -> f64 {
    week.trim_start_matches('W').parse::<f64>().unwrap_or(0.0)
}

fn summary_of(arm: &ArmResult, week: &str, key: &str) -> Result<Option<Summary>, TrialError> {
    summarize_present(&metric_column(arm, week, key)).map_err(|source| TrialError::Stats {
        what: format!("arm {}, week {week}, metric {key}", arm.key()),
        source,
    })
}

/// A round step (1, 2, 2.5 or 5 × 10^k) of at least `raw`.
fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-12))
        .unwrap_or(10.0 * mag)
}

/// A y range from `lo` to `hi` widened to multiples of a round step (about
/// six intervals).
fn nice_range(lo: f64, hi: f64) -> (f64, f64) {
    let (lo, hi) = if hi > lo {
        (lo, hi)
    } else {
        (lo - 0.5, lo + 0.5)
    };
    let step = nice_step((hi - lo) / 6.0);
    let a = (lo / step + 1e-9).floor() * step;
    let b = (hi / step - 1e-9).ceil() * step;
    (a, b)
}

/// A tick label without needless decimals (`40`, `2.5`, `0.25`).
fn tidy(v: &f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// x range and label settings shared by the weekly panels.
struct WeekAxis {
    lo: f64,
    hi: f64,
    labels: usize,
}

fn axis_of(weeks: &[String]) -> WeekAxis {
    let nums: Vec<f64> = weeks.iter().map(|w| week_number(w)).collect();
    let lo = nums.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = nums.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (1.0, 1.0) };
    WeekAxis {
        lo: lo - 0.6,
        hi: hi + 0.6,
        labels: (hi - lo) as usize + 3,
    }
}

fn week_tick(x: &f64) -> String {
    let r = x.round();
    if (x - r).abs() < 1e-6 && (1.0..=14.0).contains(&r) {
        format!("{r}")
    } else {
        String::new()
    }
}

/// (low, high) spread around a point.
type Span = Option<(f64, f64)>;

/// One line of a weekly panel: points (week number, mean, optional spread).
struct Line {
    color: RGBColor,
    points: Vec<(f64, f64, Span)>,
}

#[derive(Clone, Copy, PartialEq)]
enum Spread {
    Shaded,
    ErrorBars { dodge: f64 },
    Hidden,
}

struct Panel<'a> {
    caption: String,
    y_desc: &'a str,
    y_range: (f64, f64),
    refs: &'a [(f64, &'a str)],
    spread: Spread,
}

fn draw_weekly_panel(
    area: &Area,
    weeks: &[String],
    panel: &Panel,
    lines: &[Line],
    figure: &'static str,
) -> Result<(), TrialError> {
    let pe = plot_err(figure);
    let axis = axis_of(weeks);
    let (y0, y1) = panel.y_range;
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.caption, (FONT, 19))
        .margin(8)
        .x_label_area_size(42)
        .y_label_area_size(58)
        .build_cartesian_2d(axis.lo..axis.hi, y0..y1)
        .map_err(&pe)?;
    chart
        .configure_mesh()
        .x_labels(axis.labels)
        .x_label_formatter(&week_tick)
        .y_labels(8)
        .y_label_formatter(&tidy)
        .y_max_light_lines(1)
        .disable_x_mesh()
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_desc("week")
        .y_desc(panel.y_desc)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()
        .map_err(&pe)?;
    for (y, label) in panel.refs {
        if *y > y1 {
            continue;
        }
        chart
            .draw_series(DashedLineSeries::new(
                vec![(axis.lo, *y), (axis.hi, *y)],
                6,
                4,
                REF_COLOR.stroke_width(1),
            ))
            .map_err(&pe)?;
        chart
            .draw_series(std::iter::once(Text::new(
                label.to_string(),
                (axis.hi - 0.05, *y),
                (FONT, 12)
                    .into_font()
                    .color(&REF_COLOR)
                    .pos(Pos::new(HPos::Right, VPos::Bottom)),
            )))
            .map_err(&pe)?;
    }
    let clamp = |v: f64| v.clamp(y0, y1);
    let n_lines = lines.len() as f64;
    for (i, line) in lines.iter().enumerate() {
        let shift = match panel.spread {
            Spread::ErrorBars { dodge } => (i as f64 - (n_lines - 1.0) / 2.0) * dodge,
            _ => 0.0,
        };
        match panel.spread {
            Spread::Shaded => {
                let upper: Vec<(f64, f64)> = line
                    .points
                    .iter()
                    .filter_map(|(x, _, s)| s.map(|(_, h)| (*x, clamp(h))))
                    .collect();
                let lower: Vec<(f64, f64)> = line
                    .points
                    .iter()
                    .rev()
                    .filter_map(|(x, _, s)| s.map(|(l, _)| (*x, clamp(l))))
                    .collect();
                if upper.len() > 1 {
                    let poly: Vec<(f64, f64)> = upper.into_iter().chain(lower).collect();
                    chart
                        .draw_series(std::iter::once(Polygon::new(
                            poly,
                            line.color.mix(0.18).filled(),
                        )))
                        .map_err(&pe)?;
                }
            }
            Spread::ErrorBars { .. } => {
                for (x, _, s) in &line.points {
                    if let Some((l, h)) = s {
                        let x = x + shift;
                        let style = line.color.stroke_width(1);
                        chart
                            .draw_series([
                                PathElement::new(vec![(x, clamp(*l)), (x, clamp(*h))], style),
                                PathElement::new(
                                    vec![(x - 0.06, clamp(*l)), (x + 0.06, clamp(*l))],
                                    style,
                                ),
                                PathElement::new(
                                    vec![(x - 0.06, clamp(*h)), (x + 0.06, clamp(*h))],
                                    style,
                                ),
                            ])
                            .map_err(&pe)?;
                    }
                }
            }
            Spread::Hidden => {}
        }
        let pts: Vec<(f64, f64)> = line
            .points
            .iter()
            .map(|(x, m, _)| (x + shift, clamp(*m)))
            .collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), line.color.stroke_width(2)))
            .map_err(&pe)?;
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, line.color.filled())))
            .map_err(&pe)?;
    }
    Ok(())
}

/// How a legend entry is drawn.
#[derive(Clone, Copy)]
enum Key {
    Line,
    Box,
    Band,
    Dashed,
}

/// A row of legend entries, then lines of notes, in the footer area.
fn draw_footer(
    area: &Area,
    items: &[(String, RGBColor, Key)],
    notes: &[String],
    figure: &'static str,
) -> Result<(), TrialError> {
    let pe = plot_err(figure);
    let mut x = 70;
    let y = 14;
    for (label, color, key) in items {
        match key {
            Key::Line => {
                area.draw(&PathElement::new(
                    vec![(x, y), (x + 28, y)],
                    color.stroke_width(2),
                ))
                .map_err(&pe)?;
                area.draw(&Circle::new((x + 14, y), 3, color.filled()))
                    .map_err(&pe)?;
            }
            Key::Box => {
                area.draw(&Rectangle::new(
                    [(x + 6, y - 7), (x + 22, y + 7)],
                    color.mix(0.35).filled(),
                ))
                .map_err(&pe)?;
                area.draw(&Rectangle::new(
                    [(x + 6, y - 7), (x + 22, y + 7)],
                    color.stroke_width(1),
                ))
                .map_err(&pe)?;
            }
            Key::Band => {
                area.draw(&Rectangle::new(
                    [(x, y - 6), (x + 28, y + 6)],
                    color.mix(0.18).filled(),
                ))
                .map_err(&pe)?;
            }
            Key::Dashed => {
                for k in 0..3 {
                    area.draw(&PathElement::new(
                        vec![(x + 10 * k, y), (x + 10 * k + 6, y)],
                        color.stroke_width(1),
                    ))
                    .map_err(&pe)?;
                }
            }
        }
        area.draw(&Text::new(
            label.clone(),
            (x + 36, y),
            (FONT, 14)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(&pe)?;
        x += 36 + 8 * label.chars().count() as i32 + 30;
    }
    for (i, note) in notes.iter().enumerate() {
        area.draw(&Text::new(
            note.clone(),
            (70, 40 + 18 * i as i32),
            (FONT, 13).into_font().color(&RGBColor(60, 60, 60)),
        ))
        .map_err(&pe)?;
    }
    Ok(())
}

/// Draws the figure frame (white background, title) and returns the body
/// and footer areas.
fn frame<'a>(
    root: &Area<'a>,
    title: &str,
    footer_height: u32,
    figure: &'static str,
) -> Result<(Area<'a>, Area<'a>), TrialError> {
    let pe = plot_err(figure);
    root.fill(&WHITE).map_err(&pe)?;
    let body = root.titled(title, (FONT, 24)).map_err(&pe)?;
    let (_, h) = body.dim_in_pixel();
    let (main, footer) = body.split_vertically(h.saturating_sub(footer_height));
    Ok((main, footer))
}

fn draw_message(area: &Area, message: &str, figure: &'static str) -> Result<(), TrialError> {
    let (w, h) = area.dim_in_pixel();
    area.draw(&Text::new(
        message.to_string(),
        (w as i32 / 2, h as i32 / 2),
        (FONT, 18)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(plot_err(figure))
}

fn abba_arms(arms: &[ArmResult]) -> Vec<&ArmResult> {
    ordered_arms(arms)
        .into_iter()
        .filter(|a| a.advisor == "abba")
        .collect()
}

/// Mean ± SD line of `key` for one arm over `weeks`.
fn mean_sd_line(
    arm: &ArmResult,
    weeks: &[String],
    key: &str,
    color: RGBColor,
) -> Result<Line, TrialError> {
    let mut points = Vec::new();
    for w in weeks {
        if let Some(s) = summary_of(arm, w, key)? {
            let sd = s.sd.unwrap_or(0.0);
            points.push((week_number(w), s.mean, Some((s.mean - sd, s.mean + sd))));
        }
    }
    Ok(Line { color, points })
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

fn min_of(lines: &[Line]) -> f64 {
    lines
        .iter()
        .flat_map(|l| {
            l.points
                .iter()
                .map(|(_, m, s)| s.map_or(*m, |(lo, _)| lo.min(*m)))
        })
        .fold(f64::INFINITY, f64::min)
        .max(0.0)
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

/// A note on runs stopped early among `arms`, if any.
fn stopped_note(arms: &[&ArmResult]) -> Option<String> {
    let stopped: usize = arms.iter().map(|a| stopped_runs(a).len()).sum();
    let total: usize = arms.iter().map(|a| a.patients.len()).sum();
    (stopped > 0).then(|| {
        format!(
            "{stopped} of {total} runs stopped early (plasma glucose below the failure threshold); \
             weeks after a stop are summarised over the remaining patients."
        )
    })
}

fn week_notes() -> String {
    "Week k = days 7k-5 to 7k+1 (week 1 = D2-D8, standard therapy before any adaptation); \
     week 13 = D84-D90 (with insulin-sensitivity variability), week 14 = D92-D98 (without)."
        .to_string()
}

/// `fig5_lbgi_hbgi.svg`: weekly LBGI and HBGI of the `abba` arms (see the module docs).
pub fn fig5_lbgi_hbgi(arms: &[ArmResult]) -> Result<String, TrialError> {
    const FIG: &str = "fig5_lbgi_hbgi.svg";
    validate_arms(arms)?;
    let abba = abba_arms(arms);
    let weeks = week_axis(&abba);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1600, 860)).into_drawing_area();
        let (main, footer) = frame(
            &root,
            "Fig. 5 - Weekly LBGI and HBGI, ABBA (mean ± SD over patients)",
            90,
            FIG,
        )?;
        if abba.is_empty() {
            draw_message(&main, "No ABBA arm in this trial.", FIG)?;
        } else {
            let mut lbgi = Vec::new();
            let mut hbgi = Vec::new();
            for arm in &abba {
                let c = scenario_color(&arm.scenario);
                lbgi.push(mean_sd_line(arm, &weeks, "lbgi", c)?);
                hbgi.push(mean_sd_line(arm, &weeks, "hbgi", c)?);
            }
            let lbgi_max = nice_range(0.0, max_of(&lbgi).max(3.0)).1;
            let hbgi_max = nice_range(0.0, max_of(&hbgi).max(6.0)).1;
            let panels = main.split_evenly((2, abba.len()));
            for (i, arm) in abba.iter().enumerate() {
                let n = n_text(arm);
                draw_weekly_panel(
                    &panels[i],
                    &weeks,
                    &Panel {
                        caption: format!("{} · LBGI ({n})", arm.scenario),
                        y_desc: "LBGI",
                        y_range: (0.0, lbgi_max),
                        refs: &[(1.1, "1.1"), (2.5, "2.5")],
                        spread: Spread::Shaded,
                    },
                    std::slice::from_ref(&lbgi[i]),
                    FIG,
                )?;
                draw_weekly_panel(
                    &panels[abba.len() + i],
                    &weeks,
                    &Panel {
                        caption: format!("{} · HBGI ({n})", arm.scenario),
                        y_desc: "HBGI",
                        y_range: (0.0, hbgi_max),
                        refs: &[(5.0, "5")],
                        spread: Spread::Shaded,
                    },
                    std::slice::from_ref(&hbgi[i]),
                    FIG,
                )?;
            }
        }
        draw_footer(
            &footer,
            &[
                ("mean".to_string(), NEUTRAL, Key::Line),
                ("mean ± 1 SD (cut at 0)".to_string(), NEUTRAL, Key::Band),
                (
                    "paper's risk limits: LBGI minimal < 1.1, low 1.1-2.5; HBGI minimal < 5"
                        .to_string(),
                    REF_COLOR,
                    Key::Dashed,
                ),
            ],
            &[Some(week_notes()), stopped_note(&abba)]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>(),
            FIG,
        )?;
        root.present().map_err(plot_err(FIG))?;
    }
    Ok(svg)
}

/// `fig6_mage.svg`: weekly MAGE of the `abba` arms (see the module docs).
pub fn fig6_mage(arms: &[ArmResult]) -> Result<String, TrialError> {
    const FIG: &str = "fig6_mage.svg";
    validate_arms(arms)?;
    let abba = abba_arms(arms);
    let weeks = week_axis(&abba);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1200, 760)).into_drawing_area();
        let (main, footer) = frame(
            &root,
            "Fig. 6 - Weekly MAGE, ABBA (mean ± SD over patients)",
            90,
            FIG,
        )?;
        let mut undefined = 0usize;
        let mut total = 0usize;
        if abba.is_empty() {
            draw_message(&main, "No ABBA arm in this trial.", FIG)?;
        } else {
            let mut lines = Vec::new();
            for arm in &abba {
                lines.push(mean_sd_line(
                    arm,
                    &weeks,
                    "mage",
                    scenario_color(&arm.scenario),
                )?);
                for wk in arm.patients.iter().flat_map(|p| &p.weeks) {
                    total += 1;
                    undefined += usize::from(wk.metrics.mage.is_none());
                }
            }
            let y_range = nice_range(min_of(&lines), max_of(&lines));
            draw_weekly_panel(
                &main,
                &weeks,
                &Panel {
                    caption: String::new(),
                    y_desc: "MAGE (mg/dL)",
                    y_range,
                    refs: &[],
                    spread: Spread::ErrorBars { dodge: 0.12 },
                },
                &lines,
                FIG,
            )?;
        }
        let items: Vec<(String, RGBColor, Key)> = abba
            .iter()
            .map(|a| {
                (
                    format!("{} ({})", a.scenario, n_text(a)),
                    scenario_color(&a.scenario),
                    Key::Line,
                )
            })
            .collect();
        draw_footer(
            &footer,
            &items,
            &[
                Some(format!(
                    "Bars: ± 1 SD. MAGE: iglu's moving-average algorithm; undefined (no countable excursion) \
                     for {undefined} of {total} patient-weeks, left out of the means."
                )),
                    Some(week_notes()),
                stopped_note(&abba),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>(),
            FIG,
        )?;
        root.present().map_err(plot_err(FIG))?;
    }
    Ok(svg)
}

/// Tukey box of `values` (not empty): (q1, median, q3, lower whisker, upper
/// whisker, outliers).
fn tukey_box(values: &[f64]) -> (f64, f64, f64, f64, f64, Vec<f64>) {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let q1 = quantile_sorted(&v, 0.25);
    let med = quantile_sorted(&v, 0.5);
    let q3 = quantile_sorted(&v, 0.75);
    let iqr = q3 - q1;
    let (lo_fence, hi_fence) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
    let inside: Vec<f64> = v
        .iter()
        .copied()
        .filter(|x| *x >= lo_fence && *x <= hi_fence)
        .collect();
    let lo = inside.first().copied().unwrap_or(q1);
    let hi = inside.last().copied().unwrap_or(q3);
    let outliers = v
        .iter()
        .copied()
        .filter(|x| *x < lo_fence || *x > hi_fence)
        .collect();
    (q1, med, q3, lo, hi, outliers)
}

/// `fig7_tdi.svg`: weekly TDI box plots of the `abba` arms (see the module docs).
pub fn fig7_tdi(arms: &[ArmResult]) -> Result<String, TrialError> {
    const FIG: &str = "fig7_tdi.svg";
    validate_arms(arms)?;
    let abba = abba_arms(arms);
    let weeks = week_axis(&abba);
    let pe = plot_err(FIG);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1500, 760)).into_drawing_area();
        let (main, footer) = frame(
            &root,
            "Fig. 7 - Weekly total daily insulin (TDI), ABBA",
            90,
            FIG,
        )?;
        if abba.is_empty() {
            draw_message(&main, "No ABBA arm in this trial.", FIG)?;
        } else {
            let mut boxes = Vec::new();
            let (mut y_min, mut y_max) = (f64::INFINITY, 0.0f64);
            for (j, arm) in abba.iter().enumerate() {
                for w in &weeks {
                    let values: Vec<f64> = metric_column(arm, w, "tdi_u_per_day")
                        .into_iter()
                        .flatten()
                        .collect();
                    if values.is_empty() {
                        continue;
                    }
                    if let Some(bad) = values.iter().find(|v| !v.is_finite()) {
                        return Err(TrialError::InconsistentResults(format!(
                            "arm {}, week {w}: tdi_u_per_day is {bad}, expected a finite number",
                            arm.key()
                        )));
                    }
                    let b = tukey_box(&values);
                    y_max = y_max.max(values.iter().copied().fold(0.0, f64::max));
                    y_min = y_min.min(values.iter().copied().fold(f64::INFINITY, f64::min));
                    boxes.push((j, week_number(w), scenario_color(&arm.scenario), b));
                }
            }
            let axis = axis_of(&weeks);
            let (y_bottom, y_top) = if y_min.is_finite() {
                nice_range(y_min.max(0.0), y_max)
            } else {
                (0.0, 1.0)
            };
            let mut chart = ChartBuilder::on(&main)
                .margin(8)
                .x_label_area_size(42)
                .y_label_area_size(62)
                .build_cartesian_2d(axis.lo..axis.hi, y_bottom..y_top)
                .map_err(&pe)?;
            chart
                .configure_mesh()
                .x_labels(axis.labels)
                .x_label_formatter(&week_tick)
                .y_labels(8)
                .y_label_formatter(&tidy)
                .y_max_light_lines(1)
                .disable_x_mesh()
                .light_line_style(RGBColor(235, 235, 235))
                .bold_line_style(RGBColor(215, 215, 215))
                .x_desc("week")
                .y_desc("TDI (U/day)")
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 14))
                .draw()
                .map_err(&pe)?;
            let k = abba.len() as f64;
            let slot = 0.8 / k;
            let half = (slot * 0.36).min(0.15);
            for (j, x, color, (q1, med, q3, lo, hi, outliers)) in boxes {
                let xc = x + (j as f64 - (k - 1.0) / 2.0) * slot;
                let stroke = color.stroke_width(1);
                chart
                    .draw_series([
                        Rectangle::new(
                            [(xc - half, q1), (xc + half, q3)],
                            color.mix(0.35).filled(),
                        ),
                        Rectangle::new([(xc - half, q1), (xc + half, q3)], stroke),
                    ])
                    .map_err(&pe)?;
                chart
                    .draw_series([
                        PathElement::new(
                            vec![(xc - half, med), (xc + half, med)],
                            color.stroke_width(3),
                        ),
                        PathElement::new(vec![(xc, q3), (xc, hi)], stroke),
                        PathElement::new(vec![(xc, q1), (xc, lo)], stroke),
                        PathElement::new(
                            vec![(xc - half / 2.0, hi), (xc + half / 2.0, hi)],
                            stroke,
                        ),
                        PathElement::new(
                            vec![(xc - half / 2.0, lo), (xc + half / 2.0, lo)],
                            stroke,
                        ),
                    ])
                    .map_err(&pe)?;
                chart
                    .draw_series(outliers.iter().map(|&y| Circle::new((xc, y), 2, stroke)))
                    .map_err(&pe)?;
            }
        }
        let items: Vec<(String, RGBColor, Key)> = abba
            .iter()
            .map(|a| {
                (
                    format!("{} ({})", a.scenario, n_text(a)),
                    scenario_color(&a.scenario),
                    Key::Box,
                )
            })
            .collect();
        draw_footer(
            &footer,
            &items,
            &[
                Some(
                    "Box: Q1-Q3 of the patients' weekly mean TDI; thick bar: median; whiskers: most extreme values \
                     within 1.5 IQR of the box (Tukey); dots: values beyond."
                        .to_string(),
                ),
                    Some(week_notes()),
                stopped_note(&abba),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>(),
            FIG,
        )?;
        root.present().map_err(plot_err(FIG))?;
    }
    Ok(svg)
}

/// `fig_arms.svg`: ABBA against the baselines (see the module docs).
pub fn fig_arms(arms: &[ArmResult]) -> Result<String, TrialError> {
    const FIG: &str = "fig_arms.svg";
    validate_arms(arms)?;
    let ordered = ordered_arms(arms);
    let mut scenarios: Vec<&str> = Vec::new();
    for a in &ordered {
        if !scenarios.contains(&a.scenario.as_str()) {
            scenarios.push(&a.scenario);
        }
    }
    let mut advisors: Vec<&str> = Vec::new();
    for a in &ordered {
        if !advisors.contains(&a.advisor.as_str()) {
            advisors.push(&a.advisor);
        }
    }
    let weeks = week_axis(&ordered);
    let rows: [(&str, &str, f64, f64); 4] = [
        ("tir_70_180", "% time 70-180 mg/dL", 0.0, 100.0),
        ("below_70", "% time < 70 mg/dL", 0.0, 2.0),
        ("above_180", "% time > 180 mg/dL", 0.0, 10.0),
        ("tdi_u_per_day", "TDI (U/day)", 0.0, 10.0),
    ];
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (1600, 1400)).into_drawing_area();
        let (main, footer) = frame(
            &root,
            "ABBA vs baselines - weekly time in ranges and insulin (mean over patients)",
            80,
            FIG,
        )?;
        let panels = main.split_evenly((rows.len(), scenarios.len()));
        for (r, (key, label, lo_floor, hi_floor)) in rows.iter().enumerate() {
            let mut per_scenario = Vec::new();
            for s in &scenarios {
                let mut lines = Vec::new();
                for a in ordered.iter().filter(|a| a.scenario == *s) {
                    let mut points = Vec::new();
                    for w in &weeks {
                        if let Some(sum) = summary_of(a, w, key)? {
                            points.push((week_number(w), sum.mean, None));
                        }
                    }
                    lines.push(Line {
                        color: arm_color(&a.advisor),
                        points,
                    });
                }
                per_scenario.push(lines);
            }
            let all: Vec<f64> = per_scenario
                .iter()
                .flatten()
                .flat_map(|l| l.points.iter().map(|p| p.1))
                .collect();
            // TIR: zoomed on the data, up to 100 %; TDI: zoomed on the
            // data; the others from 0 up to at least `hi_floor`.
            let lo = all.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = all.iter().copied().fold(0.0, f64::max);
            let y_range = if *key == "tir_70_180" {
                let lo = if lo.is_finite() {
                    lo.min(90.0)
                } else {
                    *lo_floor
                };
                (nice_range(lo, 100.0).0.max(0.0), 100.0)
            } else if *key == "tdi_u_per_day" && lo.is_finite() {
                let (a, b) = nice_range(lo, hi);
                (a.max(0.0), b)
            } else {
                nice_range(*lo_floor, hi.max(*hi_floor))
            };
            for (c, s) in scenarios.iter().enumerate() {
                draw_weekly_panel(
                    &panels[r * scenarios.len() + c],
                    &weeks,
                    &Panel {
                        caption: format!("{s} · {label}"),
                        y_desc: label,
                        y_range,
                        refs: &[],
                        spread: Spread::Hidden,
                    },
                    &per_scenario[c],
                    FIG,
                )?;
            }
        }
        let items: Vec<(String, RGBColor, Key)> = advisors
            .iter()
            .map(|a| (arm_label(a), arm_color(a), Key::Line))
            .collect();
        let notes: Vec<String> = [Some(week_notes()), stopped_note(&ordered)]
            .into_iter()
            .flatten()
            .collect();
        draw_footer(&footer, &items, &notes, FIG)?;
        root.present().map_err(plot_err(FIG))?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let (q1, med, q3, lo, hi, out) = tukey_box(&v);
        assert_eq!((q1, med, q3, lo, hi), (3.25, 5.5, 7.75, 1.0, 9.0));
        assert_eq!(out, vec![30.0]);
    }

    #[test]
    fn week_ticks_label_integers_only() {
        assert_eq!(week_tick(&13.0), "13");
        assert_eq!(week_tick(&0.5), "");
        assert_eq!(week_tick(&15.0), "");
        assert_eq!(week_number("W14"), 14.0);
    }
}
