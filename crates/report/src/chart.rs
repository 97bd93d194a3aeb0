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

/// The width every figure is drawn at (SVG user units). `report.html`
/// scales a figure to the width of its column.
pub const FIGURE_WIDTH: u32 = 800;

/// The width a figure is printed at in `report.html` on A4: 210 mm less the
/// page's two 12 mm margins, in CSS px (96 per inch; about 703).
pub const A4_FIGURE_WIDTH_PX: f64 = (210.0 - 2.0 * 12.0) / 25.4 * 96.0;

/// The smallest text of a figure printed at [`A4_FIGURE_WIDTH_PX`] (pt).
pub const MIN_TEXT_PT: f64 = 9.0;

/// plotters writes a font of size `s` as `font-size = s / 1.24`.
const PLOTTERS_FONT_SCALE: f64 = 1.24;

/// The font size to ask plotters for so that the text prints at `pt`
/// points when the figure ([`FIGURE_WIDTH`] wide) is printed at
/// [`A4_FIGURE_WIDTH_PX`] (1 pt = 4/3 CSS px); rounded up to 0.1.
pub(crate) fn text_size(pt: f64) -> f64 {
    let svg_px = pt * 4.0 / 3.0 * f64::from(FIGURE_WIDTH) / A4_FIGURE_WIDTH_PX;
    (svg_px * PLOTTERS_FONT_SCALE * 10.0).ceil() / 10.0
}

/// The font size plotters writes into the SVG for `text_size(pt)`.
pub(crate) fn svg_font_px(pt: f64) -> f64 {
    text_size(pt) / PLOTTERS_FONT_SCALE
}

/// Text sizes of the figures (pt at A4 width), none below [`MIN_TEXT_PT`].
pub(crate) mod pt {
    /// Tick labels, footer notes, legend, reference-line labels.
    pub(crate) const SMALL: f64 = super::MIN_TEXT_PT;
    /// Axis descriptions.
    pub(crate) const AXIS: f64 = 9.5;
    /// Panel captions and messages.
    pub(crate) const CAPTION: f64 = 10.0;
    /// The figure's title.
    pub(crate) const TITLE: f64 = 11.5;
}

/// A generous estimate of the width of `text` at SVG font size `px` (the
/// generic sans-serif averages about 0.55 em a character).
pub fn text_width(text: &str, px: f64) -> f64 {
    0.58 * px * text.chars().count() as f64
}

/// `text` broken at spaces into lines no wider than `width` at font size `px`.
pub(crate) fn wrap(text: &str, px: f64, width: f64) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let candidate = if line.is_empty() {
            word.to_string()
        } else {
            format!("{line} {word}")
        };
        if !line.is_empty() && text_width(&candidate, px) > width {
            lines.push(std::mem::replace(&mut line, word.to_string()));
        } else {
            line = candidate;
        }
    }
    if !line.is_empty() {
        lines.push(line);
    }
    lines
}

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

/// The label of week tick `x` when only every `step`-th week, counted back
/// from the axis's last week `last`, is labelled (a narrow panel).
pub(crate) fn week_tick_every(x: &f64, step: u32, last: u32) -> String {
    let label = week_tick(x);
    let r = x.round();
    if label.is_empty() || r > f64::from(last) || !(last - r as u32).is_multiple_of(step.max(1)) {
        String::new()
    } else {
        label
    }
}

/// The smallest step between labelled weeks that keeps two-digit labels
/// apart on a plot `plot_width` wide showing the weeks of `axis`.
pub(crate) fn week_label_step(axis: &WeekAxis, plot_width: f64) -> u32 {
    let per_week = plot_width / (axis.hi - axis.lo).max(1.0);
    let need = text_width("10", svg_font_px(pt::SMALL)) * 1.6;
    (1..=14)
        .find(|k| per_week * f64::from(*k) >= need)
        .unwrap_or(14)
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
        builder.caption(caption, (FONT, text_size(pt::CAPTION)));
    }
    let mut chart = builder
        .margin(6)
        .x_label_area_size((3.2 * svg_font_px(pt::SMALL)) as u32)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(axis.lo..axis.hi, y_range.0..y_range.1)
        .map_err(&pe)?;
    let plot_width = f64::from(area.dim_in_pixel().0) - f64::from(y_label_area) - 12.0;
    let step = week_label_step(axis, plot_width);
    let last = (axis.hi - 0.6).round() as u32;
    let tick = move |x: &f64| week_tick_every(x, step, last);
    chart
        .configure_mesh()
        .x_labels(axis.labels)
        .x_label_formatter(&tick)
        .y_labels(8)
        .y_label_formatter(&tidy)
        .y_max_light_lines(1)
        .disable_x_mesh()
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .x_desc("week")
        .y_desc(y_desc)
        .label_style((FONT, text_size(pt::SMALL)))
        .axis_desc_style((FONT, text_size(pt::AXIS)))
        .draw()
        .map_err(&pe)?;
    Ok(chart)
}

/// Room for the y tick labels and the y axis description (SVG units).
pub(crate) const Y_LABEL_AREA: u32 = 62;

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
        Y_LABEL_AREA,
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
                (FONT, text_size(pt::SMALL))
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

/// A figure's footer: legend entries (wrapped into rows), then notes
/// (each wrapped into lines), all at [`pt::SMALL`].
pub(crate) struct Footer<'a> {
    pub(crate) items: &'a [(String, RGBColor, Key)],
    pub(crate) notes: &'a [String],
}

const FOOTER_LEFT: i32 = 16;
const KEY_WIDTH: i32 = 28;

impl Footer<'_> {
    fn px() -> f64 {
        svg_font_px(pt::SMALL)
    }

    fn line_height() -> i32 {
        (1.35 * Self::px()).ceil() as i32
    }

    /// Each legend entry's position (x, y of its key's centre line).
    fn item_positions(&self) -> Vec<(i32, i32)> {
        let right = FIGURE_WIDTH as i32 - FOOTER_LEFT;
        let (mut x, mut y) = (FOOTER_LEFT, Self::line_height() / 2 + 4);
        let mut out = Vec::new();
        for (label, _, _) in self.items {
            let w = KEY_WIDTH + 8 + text_width(label, Self::px()).ceil() as i32;
            if x > FOOTER_LEFT && x + w > right {
                x = FOOTER_LEFT;
                y += Self::line_height() + 4;
            }
            out.push((x, y));
            x += w + 24;
        }
        out
    }

    /// The notes' lines and the y of each (top).
    fn note_lines(&self) -> Vec<(String, i32)> {
        let top = self
            .item_positions()
            .last()
            .map_or(4, |(_, y)| y + Self::line_height());
        let width = f64::from(FIGURE_WIDTH) - 2.0 * f64::from(FOOTER_LEFT);
        self.notes
            .iter()
            .flat_map(|n| wrap(n, Self::px(), width))
            .enumerate()
            .map(|(i, l)| (l, top + 4 + Self::line_height() * i as i32))
            .collect()
    }

    /// The footer's height (SVG units).
    pub(crate) fn height(&self) -> u32 {
        let bottom = self
            .note_lines()
            .last()
            .map(|(_, y)| y + Self::line_height())
            .or_else(|| {
                self.item_positions()
                    .last()
                    .map(|(_, y)| y + Self::line_height())
            })
            .unwrap_or(0);
        bottom.max(0) as u32 + 6
    }

    fn draw(&self, area: &Area, figure: &'static str) -> Result<(), ReportError> {
        let pe = plot_err(figure);
        let size = text_size(pt::SMALL);
        for ((label, color, key), (x, y)) in self.items.iter().zip(self.item_positions()) {
            draw_key(area, *key, *color, x, y, figure)?;
            area.draw(&Text::new(
                label.clone(),
                (x + KEY_WIDTH + 8, y),
                (FONT, size)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(&pe)?;
        }
        for (line, y) in self.note_lines() {
            area.draw(&Text::new(
                line,
                (FOOTER_LEFT, y),
                (FONT, size).into_font().color(&RGBColor(60, 60, 60)),
            ))
            .map_err(&pe)?;
        }
        Ok(())
    }
}

/// A legend key at (x, y): a line with a dot, a box, a band or a dashed line.
fn draw_key(
    area: &Area,
    key: Key,
    color: RGBColor,
    x: i32,
    y: i32,
    figure: &'static str,
) -> Result<(), ReportError> {
    let pe = plot_err(figure);
    match key {
        Key::Line => {
            area.draw(&PathElement::new(
                vec![(x, y), (x + KEY_WIDTH, y)],
                color.stroke_width(2),
            ))
            .map_err(&pe)?;
            area.draw(&Circle::new((x + KEY_WIDTH / 2, y), 3, color.filled()))
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
                [(x, y - 6), (x + KEY_WIDTH, y + 6)],
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
    Ok(())
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
        (FONT, text_size(pt::CAPTION))
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(plot_err(figure))
}

/// An SVG figure [`FIGURE_WIDTH`] wide titled `title`: `draw` gets a body
/// `main_height` high; the footer below it is as high as its wrapped
/// legend and notes need.
pub(crate) fn render_svg(
    main_height: u32,
    title: &str,
    footer: &Footer,
    figure: &'static str,
    draw: impl FnOnce(&Area) -> Result<(), ReportError>,
) -> Result<String, ReportError> {
    let pe = plot_err(figure);
    let title_height = (1.6 * svg_font_px(pt::TITLE)).ceil() as u32;
    let footer_height = footer.height();
    let size = (FIGURE_WIDTH, title_height + main_height + footer_height);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(&pe)?;
        let body = root
            .titled(title, (FONT, text_size(pt::TITLE)))
            .map_err(&pe)?;
        let (_, h) = body.dim_in_pixel();
        let (main, foot) = body.split_vertically(h.saturating_sub(footer_height));
        draw(&main)?;
        footer.draw(&foot, figure)?;
        root.present().map_err(&pe)?;
    }
    Ok(svg)
}
