//! The figures of the HTML pages, written as SVG directly (they are simple
//! shapes; plotters would add nothing here): the glucose profile, the
//! time-in-ranges bar and the daily panels. Every figure is
//! `<svg role="img">` whose first children are a `<title>` (its accessible
//! name) and a `<desc>` (the text alternative), axes from 0 with their units, and colours from
//! the Okabe-Ito palette (distinguishable with the common colour-vision
//! deficiencies); text is in the generic `sans-serif` family, so no font
//! is fetched.

use std::fmt::Write as _;

use crate::html::profile::{ProfileBin, DAY_MIN};
use abba_core::units::GlucoseUnit;

/// Okabe-Ito colours.
pub mod palette {
    /// Orange.
    pub const ORANGE: &str = "#E69F00";
    /// Sky blue.
    pub const SKY_BLUE: &str = "#56B4E9";
    /// Bluish green.
    pub const GREEN: &str = "#009E73";
    /// Yellow.
    pub const YELLOW: &str = "#F0E442";
    /// Blue.
    pub const BLUE: &str = "#0072B2";
    /// Vermillion.
    pub const VERMILLION: &str = "#D55E00";
    /// Reddish purple.
    pub const PURPLE: &str = "#CC79A7";
    /// Black.
    pub const BLACK: &str = "#000000";
}

/// The consensus ranges' names in the reader's unit, lowest first.
pub fn range_names(unit: GlucoseUnit) -> [String; 5] {
    let bounds = match unit {
        GlucoseUnit::MgDl => ["54", "54-69", "70-180", "181-250", "250"],
        GlucoseUnit::MmolL => ["3.0", "3.0-3.8", "3.9-10.0", "10.1-13.9", "13.9"],
    };
    let u = unit.label();
    [
        format!("Very low (< {} {u})", bounds[0]),
        format!("Low ({} {u})", bounds[1]),
        format!("Target ({} {u})", bounds[2]),
        format!("High ({} {u})", bounds[3]),
        format!("Very high (> {} {u})", bounds[4]),
    ]
}

/// The colour of each consensus range, lowest first.
pub const RANGE_COLOURS: [&str; 5] = [
    palette::VERMILLION,
    palette::ORANGE,
    palette::GREEN,
    palette::YELLOW,
    palette::PURPLE,
];

/// Escapes text for SVG/HTML content and attributes.
pub fn esc(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Every figure here is drawn about as wide (in SVG units) as the slot it
/// prints in on A4 (the report's 186 mm of text width is 703 CSS px), so
/// one unit prints as about one CSS px and [`FONT`] at about 9.4 pt; the
/// browser test of the reports measures the printed sizes (at least 9 pt).
/// A full-width figure.
pub const FULL_WIDTH: f64 = 700.0;
/// A figure in half the width (the `.row` and `.weeks` columns, 345 px on
/// A4).
pub const HALF_WIDTH: f64 = 340.0;
/// A day's panel (the `.days` grid's three columns, 230 px on A4).
pub const DAY_PANEL_WIDTH: f64 = 228.0;
/// The text of every figure (SVG units; at least 9 pt as printed).
pub const FONT: f64 = 12.5;
/// A figure's title.
const TITLE_FONT: f64 = 13.5;

/// An SVG under construction: the frame with its title and description.
struct Figure {
    out: String,
}

impl Figure {
    fn new(id: &str, width: f64, height: f64, title: &str, desc: &str) -> Figure {
        let mut out = String::new();
        let _ = write!(
            out,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {width} {height}" role="img" class="{id}"><title>{}</title><desc>{}</desc>"#,
            esc(title),
            esc(desc)
        );
        Figure { out }
    }

    fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, fill: &str, extra: &str) {
        let _ = write!(
            self.out,
            r#"<rect x="{x:.1}" y="{y:.1}" width="{:.1}" height="{:.1}" fill="{fill}"{extra}/>"#,
            w.max(0.0),
            h.max(0.0)
        );
    }

    fn line(&mut self, x1: f64, y1: f64, x2: f64, y2: f64, stroke: &str, extra: &str) {
        let _ = write!(
            self.out,
            r#"<line x1="{x1:.1}" y1="{y1:.1}" x2="{x2:.1}" y2="{y2:.1}" stroke="{stroke}"{extra}/>"#
        );
    }

    fn text(&mut self, x: f64, y: f64, size: f64, anchor: &str, s: &str) {
        let _ = write!(
            self.out,
            r#"<text x="{x:.1}" y="{y:.1}" font-size="{size}" text-anchor="{anchor}">{}</text>"#,
            esc(s)
        );
    }

    fn finish(mut self) -> String {
        self.out.push_str("</svg>");
        self.out
    }
}

/// A plot area: data ranges mapped onto a pixel box.
#[derive(Clone, Copy)]
struct Plot {
    left: f64,
    top: f64,
    width: f64,
    height: f64,
    y_max: f64,
}

impl Plot {
    fn x(&self, minute: f64) -> f64 {
        self.left + self.width * minute / f64::from(DAY_MIN)
    }
    fn y(&self, mg_dl: f64) -> f64 {
        self.top + self.height * (1.0 - mg_dl.clamp(0.0, self.y_max) / self.y_max)
    }
}

/// The y ticks of a glucose axis (mg/dL values), in the reader's unit.
fn glucose_ticks(unit: GlucoseUnit, y_max: f64) -> Vec<f64> {
    match unit {
        GlucoseUnit::MgDl => (0..)
            .map(|k| f64::from(k) * 50.0)
            .take_while(|v| *v <= y_max)
            .collect(),
        GlucoseUnit::MmolL => (0..)
            .map(|k| unit.to_mg_dl(f64::from(k) * 4.0))
            .take_while(|v| *v <= y_max + 1e-9)
            .collect(),
    }
}

/// Axes of a day: glucose from 0 with unit, time of day 00:00-24:00,
/// target lines at 70 and 180 mg/dL.
fn day_axes(
    fig: &mut Figure,
    plot: Plot,
    unit: GlucoseUnit,
    font: f64,
    every_h: u32,
    labels: bool,
) {
    fig.rect(
        plot.left,
        plot.y(180.0),
        plot.width,
        plot.y(70.0) - plot.y(180.0),
        "#EAF5EF",
        "",
    );
    for v in glucose_ticks(unit, plot.y_max) {
        let y = plot.y(v);
        fig.line(plot.left, y, plot.left + plot.width, y, "#DDDDDD", "");
        if labels {
            fig.text(plot.left - 4.0, y + font * 0.35, font, "end", &unit.tick(v));
        }
    }
    for h in (0..=24).step_by(every_h as usize) {
        let x = plot.x(f64::from(h * 60));
        fig.line(x, plot.top, x, plot.top + plot.height, "#EEEEEE", "");
        if labels {
            // The last tick ends at the plot's edge (centred, it would be
            // clipped by the figure's border).
            let anchor = if h == 24 { "end" } else { "middle" };
            fig.text(
                x,
                plot.top + plot.height + font * 1.2,
                font,
                anchor,
                &format!("{h:02}:00"),
            );
        }
    }
    target_lines(fig, plot);
    fig.rect(
        plot.left,
        plot.top,
        plot.width,
        plot.height,
        "none",
        r##" stroke="#555555""##,
    );
}

/// The target lines at 70 and 180 mg/dL.
fn target_lines(fig: &mut Figure, plot: Plot) {
    for target in [70.0, 180.0] {
        let y = plot.y(target);
        fig.line(
            plot.left,
            y,
            plot.left + plot.width,
            y,
            palette::GREEN,
            r#" stroke-width="1.5""#,
        );
    }
}

/// The glucose profile (AGP style): 5-95 % and 25-75 % bands and the
/// median by time of day, target lines at 70 and 180 mg/dL, `w` units wide
/// ([`FULL_WIDTH`] or [`HALF_WIDTH`]; the legend wraps to the width). `id`
/// must be a CSS class naming the figure.
pub fn profile_svg(
    id: &str,
    bins: &[ProfileBin],
    unit: GlucoseUnit,
    title: &str,
    w: f64,
) -> String {
    let target = format!(
        "target {} and {} {}",
        unit.value(70.0),
        unit.value(180.0),
        unit.label()
    );
    let legend = [
        ("median (50th percentile)", palette::BLUE, true),
        ("25th-75th percentile", "#6FA8D6", false),
        ("5th-95th percentile", "#BFD9EC", false),
        (target.as_str(), palette::GREEN, true),
    ];
    // The legend's items left to right, wrapped at the figure's width.
    let (left, right) = (56.0, 16.0);
    let mut rows = 1.0;
    let mut at = Vec::new();
    let mut x = left;
    for (label, _, _) in &legend {
        let item = 22.0 + crate::chart::text_width(label, FONT);
        if x > left && x + item > w - 4.0 {
            rows += 1.0;
            x = left;
        }
        at.push((x, rows));
        x += item + 14.0;
    }
    let plot_h = if w >= FULL_WIDTH { 210.0 } else { 170.0 };
    let legend_top = 28.0 + plot_h + 2.6 * FONT;
    let h = legend_top + 6.0 + rows * 1.5 * FONT;
    let highest = bins
        .iter()
        .filter_map(|b| b.p.map(|p| p[4]))
        .fold(0.0, f64::max);
    let y_max = if highest > 350.0 { 400.0 } else { 350.0 };
    let desc = profile_description(bins, unit);
    let mut fig = Figure::new(id, w, h, title, &desc);
    let plot = Plot {
        left,
        top: 28.0,
        width: w - left - right,
        height: plot_h,
        y_max,
    };
    let every_h = if w >= FULL_WIDTH { 3 } else { 6 };
    day_axes(&mut fig, plot, unit, FONT, every_h, true);
    // Bands as polygons over the bins that have readings (a bin is drawn at its middle).
    let mid = |b: &ProfileBin, bin_w: f64| f64::from(b.start_min) + bin_w / 2.0;
    let bin_w = bins
        .get(1)
        .map_or(f64::from(DAY_MIN), |b| f64::from(b.start_min));
    for (lo, hi, fill) in [(0usize, 4usize, "#BFD9EC"), (1, 3, "#6FA8D6")] {
        for run in runs(bins) {
            let mut pts = String::new();
            for b in run {
                if let Some(p) = b.p {
                    let _ = write!(pts, "{:.1},{:.1} ", plot.x(mid(b, bin_w)), plot.y(p[hi]));
                }
            }
            for b in run.iter().rev() {
                if let Some(p) = b.p {
                    let _ = write!(pts, "{:.1},{:.1} ", plot.x(mid(b, bin_w)), plot.y(p[lo]));
                }
            }
            let _ = write!(
                fig.out,
                r#"<polygon points="{}" fill="{fill}" stroke="none"/>"#,
                pts.trim_end()
            );
        }
    }
    // A bin with no neighbour (sparse meter readings): its 5-95 range as a
    // whisker, 25-75 as a box and the median as a tick.
    for run in runs(bins).into_iter().filter(|r| r.len() == 1) {
        if let Some(p) = run[0].p {
            let x = plot.x(mid(&run[0], bin_w));
            fig.line(
                x,
                plot.y(p[0]),
                x,
                plot.y(p[4]),
                "#6FA8D6",
                r#" stroke-width="2""#,
            );
            fig.rect(
                x - 6.0,
                plot.y(p[3]),
                12.0,
                plot.y(p[1]) - plot.y(p[3]),
                "#6FA8D6",
                "",
            );
            fig.line(
                x - 8.0,
                plot.y(p[2]),
                x + 8.0,
                plot.y(p[2]),
                palette::BLUE,
                r#" stroke-width="2.5""#,
            );
        }
    }
    for run in runs(bins) {
        let pts: Vec<String> = run
            .iter()
            .filter_map(|b| {
                b.p.map(|p| format!("{:.1},{:.1}", plot.x(mid(b, bin_w)), plot.y(p[2])))
            })
            .collect();
        let _ = write!(
            fig.out,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="2.5"/>"#,
            pts.join(" "),
            palette::BLUE
        );
    }
    target_lines(&mut fig, plot);
    let cy = plot.top + plot.height / 2.0;
    let _ = write!(
        fig.out,
        r#"<text x="14" y="{cy:.1}" font-size="{FONT}" text-anchor="middle" transform="rotate(-90 14 {cy:.1})">Glucose ({})</text>"#,
        unit.label()
    );
    fig.text(
        plot.left + plot.width / 2.0,
        plot.top + plot.height + 2.4 * FONT,
        FONT,
        "middle",
        "Time of day (hh:mm)",
    );
    for ((label, fill, is_line), (x, row)) in legend.iter().zip(at) {
        let ly = legend_top + row * 1.5 * FONT;
        if *is_line {
            fig.line(
                x,
                ly - 4.0,
                x + 18.0,
                ly - 4.0,
                fill,
                r#" stroke-width="2.5""#,
            );
        } else {
            fig.rect(x, ly - 10.0, 18.0, 10.0, fill, "");
        }
        fig.text(x + 22.0, ly, FONT, "start", label);
    }
    fig.text(plot.left, 17.0, TITLE_FONT, "start", title);
    fig.finish()
}

/// Consecutive bins with readings (a gap in the data breaks the bands).
fn runs(bins: &[ProfileBin]) -> Vec<&[ProfileBin]> {
    bins.split(|b| b.p.is_none())
        .filter(|r| !r.is_empty())
        .collect()
}

/// The text alternative of a profile: the median and the 5-95 range at
/// six times of day.
fn profile_description(bins: &[ProfileBin], unit: GlucoseUnit) -> String {
    let mut s = format!(
        "Glucose percentiles by time of day in {}; target range {}-{} {}.",
        unit.label(),
        unit.value(70.0),
        unit.value(180.0),
        unit.label()
    );
    for hour in [0u32, 4, 8, 12, 16, 20] {
        if let Some(b) = bins
            .iter()
            .find(|b| b.start_min >= hour * 60 && b.p.is_some())
        {
            if let Some(p) = b.p {
                let _ = write!(
                    s,
                    " {:02}:{:02}: median {}, 5th-95th {}-{}.",
                    b.start_min / 60,
                    b.start_min % 60,
                    unit.value(p[2]),
                    unit.value(p[0]),
                    unit.value(p[4])
                );
            }
        }
    }
    s
}

/// Time in ranges as one stacked bar, the consensus ranges lowest at the
/// bottom, each labelled with its percentage and goal. `pct` are the
/// percentages of [`range_names`], in that order.
pub fn tir_bar_svg(id: &str, pct: [f64; 5], title: &str, unit: GlucoseUnit) -> String {
    let names = range_names(unit);
    const GOALS: [&str; 5] = [
        "goal < 1 %",
        "goal < 4 %",
        "goal > 70 %",
        "goal < 25 %",
        "goal < 5 %",
    ];
    let (w, h) = (HALF_WIDTH, 260.0);
    let desc = names
        .iter()
        .zip(pct)
        .zip(GOALS)
        .map(|((n, p), g)| format!("{n}: {p:.1} % ({g})"))
        .collect::<Vec<_>>()
        .join("; ");
    let mut fig = Figure::new(id, w, h, title, &desc);
    let (bar_x, bar_w, top, height) = (24.0, 56.0, 24.0, 220.0);
    let total: f64 = pct.iter().sum::<f64>().max(1e-9);
    let mut y = top + height;
    let mut label_y = Vec::new();
    for (i, p) in pct.iter().enumerate() {
        let bh = height * p / total;
        y -= bh;
        fig.rect(
            bar_x,
            y,
            bar_w,
            bh,
            RANGE_COLOURS[i],
            r##" stroke="#FFFFFF""##,
        );
        label_y.push(y + bh / 2.0);
    }
    // Labels spread out so they never overlap (bottom to top, 32 px apart at least).
    let mut placed: Vec<f64> = Vec::new();
    for want in &label_y {
        let mut ly = want.min(top + height - 10.0);
        if let Some(prev) = placed.last() {
            ly = ly.min(prev - 32.0);
        }
        placed.push(ly);
    }
    // Then top to bottom: nothing above the frame (5 labels × 32 px fit in
    // the bar's height, so the lowest stays inside).
    let mut floor = top + 14.0 - 32.0;
    for ly in placed.iter_mut().rev() {
        *ly = ly.max(floor + 32.0);
        floor = *ly;
    }
    for (i, ly) in placed.iter().copied().enumerate() {
        fig.line(
            bar_x + bar_w,
            label_y[i],
            bar_x + bar_w + 14.0,
            ly - 4.0,
            "#777777",
            "",
        );
        fig.text(
            bar_x + bar_w + 18.0,
            ly - 6.0,
            FONT,
            "start",
            &format!("{}: {:.1} %", names[i], pct[i]),
        );
        fig.text(bar_x + bar_w + 18.0, ly + 9.0, FONT, "start", GOALS[i]);
    }
    fig.text(bar_x, 14.0, FONT, "start", "% of readings (0-100 %)");
    fig.finish()
}

/// One day's small panel: glucose from 0 to 400 mg/dL over 00:00-24:00,
/// the target band shaded; CGM readings as a line (broken at gaps of more
/// than 15 min), meter readings as dots.
pub fn day_panel_svg(
    id: &str,
    title: &str,
    readings: &[(u32, f64)],
    meter: bool,
    unit: GlucoseUnit,
) -> String {
    let (w, h) = (DAY_PANEL_WIDTH, 150.0);
    let desc = if readings.is_empty() {
        "No readings this day.".to_string()
    } else {
        let lo = readings.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
        let hi = readings.iter().map(|r| r.1).fold(0.0, f64::max);
        format!(
            "{} {} readings from {} to {} {}.",
            readings.len(),
            if meter { "meter" } else { "CGM" },
            unit.value(lo),
            unit.value(hi),
            unit.label()
        )
    };
    let mut fig = Figure::new(id, w, h, title, &desc);
    let plot = Plot {
        left: 32.0,
        top: 20.0,
        width: w - 32.0 - 6.0,
        height: h - 20.0 - 1.6 * FONT,
        y_max: 400.0,
    };
    day_axes(&mut fig, plot, unit, FONT, 6, true);
    fig.text(plot.left, 14.0, FONT, "start", title);
    if meter {
        for (m, g) in readings {
            let _ = write!(
                fig.out,
                r#"<circle cx="{:.1}" cy="{:.1}" r="2.6" fill="{}"/>"#,
                plot.x(f64::from(*m)),
                plot.y(*g),
                palette::BLUE
            );
        }
    } else {
        let mut segment: Vec<String> = Vec::new();
        let mut last: Option<u32> = None;
        let flush = |seg: &mut Vec<String>, out: &mut String| {
            if seg.len() > 1 {
                let _ = write!(
                    out,
                    r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.2"/>"#,
                    seg.join(" "),
                    palette::BLUE
                );
            }
            seg.clear();
        };
        for (m, g) in readings {
            if last.is_some_and(|l| m.saturating_sub(l) > 15) {
                flush(&mut segment, &mut fig.out);
            }
            segment.push(format!("{:.1},{:.1}", plot.x(f64::from(*m)), plot.y(*g)));
            last = Some(*m);
        }
        flush(&mut segment, &mut fig.out);
    }
    fig.finish()
}

/// Makes a plotters SVG fit the page: the fixed size becomes a viewBox,
/// and it gets `role="img"`, a `<title>` and a `<desc>`.
pub fn accessible_svg(svg: &str, id: &str, title: &str, desc: &str) -> String {
    let Some(start) = svg.find("<svg") else {
        return String::new();
    };
    let svg = &svg[start..];
    let Some(end) = svg.find('>') else {
        return String::new();
    };
    let head = &svg[..end];
    let attr = |name: &str| -> Option<String> {
        let key = format!(" {name}=\"");
        let i = head.find(&key)? + key.len();
        let j = head[i..].find('"')? + i;
        Some(head[i..j].to_string())
    };
    let (w, h) = (
        attr("width").unwrap_or_default(),
        attr("height").unwrap_or_default(),
    );
    format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {w} {h}" role="img" class="{id}"><title>{}</title><desc>{}</desc>{}"#,
        esc(title),
        esc(desc),
        &svg[end + 1..]
    )
}
