//! The drawing layer of the figures (plotters, SVG backend; text is SVG
//! `<text>` in the generic `sans-serif` family, so no font files are
//! needed): one shared chart builder for every weekly panel
//! ([`week_chart`]), the figure frame with title and footer
//! ([`render_svg`]), legends, and round axis ranges. [`crate::figures`]
//! computes what to draw; this module only draws it.

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::error::ReportError;
use crate::results::Week;

pub(crate) const FONT: &str = "sans-serif";
pub(crate) const REF_COLOR: RGBColor = RGBColor(150, 30, 30);
pub(crate) const NEUTRAL: RGBColor = RGBColor(90, 90, 90);

pub(crate) type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

pub(crate) fn plot_err<E: std::fmt::Display>(figure: &'static str) -> impl Fn(E) -> ReportError {
    move |e| ReportError::Plot {
        figure,
        reason: e.to_string(),
    }
}

/// A round step (1, 2, 2.5 or 5 × 10^k) of at least `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
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
pub(crate) fn nice_range(lo: f64, hi: f64) -> (f64, f64) {
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
pub(crate) fn tidy(v: &f64) -> String {
    let s = format!("{v:.2}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// The x position of a week on the axis: its number (W13/W14 are 13 and 14).
pub(crate) fn week_x(week: Week) -> f64 {
    f64::from(week.number())
}

/// x range and label settings shared by the weekly panels.
pub(crate) struct WeekAxis {
    lo: f64,
    hi: f64,
    labels: usize,
}

pub(crate) fn axis_of(weeks: &[Week]) -> WeekAxis {
    let nums: Vec<f64> = weeks.iter().map(|w| week_x(*w)).collect();
    let lo = nums.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = nums.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() { (lo, hi) } else { (1.0, 1.0) };
    WeekAxis {
        lo: lo - 0.6,
        hi: hi + 0.6,
        labels: (hi - lo) as usize + 3,
    }
}

pub(crate) fn week_tick(x: &f64) -> String {
    let r = x.round();
    if (x - r).abs() < 1e-6 && (1.0..=14.0).contains(&r) {
        format!("{r}")
    } else {
        String::new()
    }
}

/// (low, high) spread around a point.
pub(crate) type Span = Option<(f64, f64)>;

/// One line of a weekly panel: points (week number, mean, optional spread).
pub(crate) struct Line {
    pub(crate) color: RGBColor,
    pub(crate) points: Vec<(f64, f64, Span)>,
}

#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Spread {
    Shaded,
    ErrorBars { dodge: f64 },
    Hidden,
}

pub(crate) struct Panel<'a> {
    pub(crate) caption: String,
    pub(crate) y_desc: &'a str,
    pub(crate) y_range: (f64, f64),
    pub(crate) refs: &'a [(f64, &'a str)],
    pub(crate) spread: Spread,
}

/// A weekly chart on `area`.
pub(crate) type WeekChart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The one chart builder of every weekly figure: weeks on x (integer ticks
/// only, no vertical grid), round y ticks, light horizontal grid, the
/// axis descriptions; a caption when given.
pub(crate) fn week_chart<'a, 'b>(
    area: &'a Area<'b>,
    axis: &WeekAxis,
    y_range: (f64, f64),
    caption: Option<&str>,
    y_desc: &str,
    y_label_area: u32,
    figure: &'static str,
) -> Result<WeekChart<'a, 'b>, ReportError> {
    let pe = plot_err(figure);
    let mut builder = ChartBuilder::on(area);
    if let Some(caption) = caption {
        builder.caption(caption, (FONT, 19));
    }
    let mut chart = builder
        .margin(8)
        .x_label_area_size(42)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(axis.lo..axis.hi, y_range.0..y_range.1)
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
        .y_desc(y_desc)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .draw()
        .map_err(&pe)?;
    Ok(chart)
}

/// One weekly panel: reference lines, then each line with its spread.
pub(crate) fn draw_weekly_panel(
    area: &Area,
    weeks: &[Week],
    panel: &Panel,
    lines: &[Line],
    figure: &'static str,
) -> Result<(), ReportError> {
    let pe = plot_err(figure);
    let axis = axis_of(weeks);
    let (y0, y1) = panel.y_range;
    let mut chart = week_chart(
        area,
        &axis,
        panel.y_range,
        Some(&panel.caption),
        panel.y_desc,
        58,
        figure,
    )?;
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
pub(crate) enum Key {
    Line,
    Box,
    Band,
    Dashed,
}

/// A row of legend entries, then lines of notes, in the footer area.
pub(crate) fn draw_footer(
    area: &Area,
    items: &[(String, RGBColor, Key)],
    notes: &[String],
    figure: &'static str,
) -> Result<(), ReportError> {
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
pub(crate) fn frame<'a>(
    root: &Area<'a>,
    title: &str,
    footer_height: u32,
    figure: &'static str,
) -> Result<(Area<'a>, Area<'a>), ReportError> {
    let pe = plot_err(figure);
    root.fill(&WHITE).map_err(&pe)?;
    let body = root.titled(title, (FONT, 24)).map_err(&pe)?;
    let (_, h) = body.dim_in_pixel();
    let (main, footer) = body.split_vertically(h.saturating_sub(footer_height));
    Ok((main, footer))
}

pub(crate) fn draw_message(
    area: &Area,
    message: &str,
    figure: &'static str,
) -> Result<(), ReportError> {
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

/// An SVG figure of `size` pixels titled `title`: `draw` gets the body and
/// a footer of `footer_height` pixels.
pub(crate) fn render_svg(
    size: (u32, u32),
    title: &str,
    footer_height: u32,
    figure: &'static str,
    draw: impl FnOnce(&Area, &Area) -> Result<(), ReportError>,
) -> Result<String, ReportError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        let (main, footer) = frame(&root, title, footer_height, figure)?;
        draw(&main, &footer)?;
        root.present().map_err(plot_err(figure))?;
    }
    Ok(svg)
}
