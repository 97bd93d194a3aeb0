//! The glucose chart of the Glucose page as numbers for an inline SVG: the
//! template draws it (so every value passes the template's escaping), this
//! module only places the readings.
//!
//! - x: time, from `start` to `end` (minutes), left to right.
//! - y: glucose in the person's unit, from 0 to the larger of the
//!   highest reading and a floor (300 mg/dL or 16.7 mmol/L), bottom to top.
//! - CGM readings are joined into lines, broken where two readings are more
//!   than [`GAP_MIN`] minutes apart (no line across a sensor gap);
//!   finger-stick readings are dots.
//! - The target range (70-180 mg/dL, 3.9-10.0 mmol/L) is a band.

use serde::Serialize;

/// Width of the drawing (SVG user units).
pub const WIDTH: f64 = 720.0;
/// Height of the drawing.
pub const HEIGHT: f64 = 320.0;
/// Left margin (the glucose axis' labels, at a phone's larger size).
const LEFT: f64 = 56.0;
/// Right margin.
const RIGHT: f64 = 12.0;
/// Top margin (the glucose unit above the axis' top label).
const TOP: f64 = 52.0;
/// Bottom margin (the time axis' labels).
const BOTTOM: f64 = 36.0;
/// Two CGM readings further apart than this are not joined.
pub const GAP_MIN: i64 = 15;

/// One reading, in the person's unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Minutes (any origin; the same as `start` and `end`).
    pub at: i64,
    /// Glucose in the chart's unit.
    pub value: f64,
    /// True for a CGM reading, false for a finger stick.
    pub cgm: bool,
}

/// A tick of an axis: its position and its label.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Tick {
    /// Position along its axis (SVG units).
    pub pos: f64,
    /// The label.
    pub label: String,
}

/// A finger-stick reading's dot.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Dot {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
}

/// The chart, ready for the template.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Chart {
    /// The drawing's width.
    pub width: f64,
    /// The drawing's height.
    pub height: f64,
    /// The plot area: left, top, right, bottom.
    pub left: f64,
    /// Top of the plot area.
    pub top: f64,
    /// Right of the plot area.
    pub right: f64,
    /// Bottom of the plot area.
    pub bottom: f64,
    /// The target band's top y and its height.
    pub band_y: f64,
    /// The target band's height.
    pub band_h: f64,
    /// The CGM lines: each an SVG path (`M x y L x y ...`).
    pub lines: Vec<String>,
    /// The finger sticks.
    pub dots: Vec<Dot>,
    /// Time ticks (x).
    pub x_ticks: Vec<Tick>,
    /// Glucose ticks (y).
    pub y_ticks: Vec<Tick>,
}

/// Places `points` (sorted by time) between `start` and `end` minutes.
/// `target` is the range's low and high in the chart's unit, `floor` the
/// least top of the glucose axis, `y_step` its tick spacing; `x_ticks`
/// (minutes, label) are placed as given.
pub fn place(
    points: &[Point],
    (start, end): (i64, i64),
    target: (f64, f64),
    floor: f64,
    y_step: f64,
    x_ticks: &[(i64, String)],
) -> Chart {
    let (left, top, right, bottom) = (LEFT, TOP, WIDTH - RIGHT, HEIGHT - BOTTOM);
    let span = (end - start).max(1) as f64;
    let top_value = points
        .iter()
        .map(|p| p.value)
        .fold(floor, f64::max)
        .max(target.1);
    // The axis ends on a tick.
    let top_value = (top_value / y_step).ceil() * y_step;
    let x = |t: i64| left + (t - start) as f64 / span * (right - left);
    let y = |v: f64| bottom - v / top_value * (bottom - top);
    let mut lines = Vec::new();
    let mut line = String::new();
    let mut prev: Option<i64> = None;
    let mut dots = Vec::new();
    for p in points.iter().filter(|p| p.at >= start && p.at <= end) {
        if !p.cgm {
            dots.push(Dot {
                x: round(x(p.at)),
                y: round(y(p.value)),
            });
            continue;
        }
        let joined = prev.is_some_and(|t| p.at - t <= GAP_MIN);
        if !joined && !line.is_empty() {
            lines.push(std::mem::take(&mut line));
        }
        let cmd = if joined { " L" } else { "M" };
        line.push_str(&format!("{cmd}{:.1} {:.1}", x(p.at), y(p.value)));
        prev = Some(p.at);
    }
    if !line.is_empty() {
        lines.push(line);
    }
    let mut y_ticks = Vec::new();
    let mut v = 0.0;
    while v <= top_value + 1e-9 {
        let label = if y_step < 1.0 {
            format!("{v:.1}")
        } else {
            format!("{v:.0}")
        };
        y_ticks.push(Tick {
            pos: round(y(v)),
            label,
        });
        v += y_step;
    }
    Chart {
        width: WIDTH,
        height: HEIGHT,
        left,
        top,
        right,
        bottom,
        band_y: round(y(target.1)),
        band_h: round(y(target.0) - y(target.1)),
        lines,
        dots,
        x_ticks: x_ticks
            .iter()
            .filter(|(t, _)| *t >= start && *t <= end)
            .map(|(t, label)| Tick {
                pos: round(x(*t)),
                label: label.clone(),
            })
            .collect(),
        y_ticks,
    }
}

fn round(v: f64) -> f64 {
    (v * 10.0).round() / 10.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cgm(at: i64, value: f64) -> Point {
        Point {
            at,
            value,
            cgm: true,
        }
    }

    #[test]
    fn a_sensor_gap_breaks_the_line_and_finger_sticks_are_dots() {
        let pts = [
            cgm(0, 100.0),
            cgm(5, 110.0),
            cgm(10, 120.0),
            // 30 minutes without the sensor.
            cgm(40, 150.0),
            cgm(45, 160.0),
            Point {
                at: 50,
                value: 90.0,
                cgm: false,
            },
        ];
        let c = place(&pts, (0, 60), (70.0, 180.0), 300.0, 50.0, &[]);
        assert_eq!(c.lines.len(), 2, "{:?}", c.lines);
        assert_eq!(c.lines[0].matches('L').count(), 2);
        assert_eq!(c.lines[1].matches('L').count(), 1);
        assert_eq!(c.dots.len(), 1);
    }

    #[test]
    fn time_runs_left_to_right_and_glucose_bottom_to_top() {
        let pts = [cgm(0, 0.0), cgm(5, 300.0)];
        let c = place(&pts, (0, 5), (70.0, 180.0), 300.0, 50.0, &[]);
        assert_eq!(
            c.lines[0],
            format!(
                "M{:.1} {:.1} L{:.1} {:.1}",
                c.left, c.bottom, c.right, c.top
            )
        );
        // The band spans 70 to 180 of the 0-300 axis.
        let h = c.bottom - c.top;
        assert!((c.band_h - h * 110.0 / 300.0).abs() < 0.2, "{c:?}");
        assert!((c.band_y - (c.bottom - h * 180.0 / 300.0)).abs() < 0.2);
    }

    #[test]
    fn the_axis_grows_to_the_highest_reading_and_ends_on_a_tick() {
        let pts = [cgm(0, 412.0)];
        let c = place(&pts, (0, 10), (70.0, 180.0), 300.0, 50.0, &[]);
        assert_eq!(c.y_ticks.last().unwrap().label, "450");
        let m = [cgm(0, 5.0)];
        let c = place(&m, (0, 10), (3.9, 10.0), 16.7, 2.0, &[]);
        assert_eq!(c.y_ticks.last().unwrap().label, "18");
    }

    #[test]
    fn readings_outside_the_window_are_left_out() {
        let pts = [cgm(-10, 100.0), cgm(5, 100.0), cgm(100, 100.0)];
        let c = place(
            &pts,
            (0, 60),
            (70.0, 180.0),
            300.0,
            50.0,
            &[(30, "noon".into()), (90, "x".into())],
        );
        assert_eq!(
            c.lines,
            vec![format!(
                "M{:.1} {:.1}",
                c.left + 5.0 / 60.0 * (c.right - c.left),
                c.bottom - 100.0 / 300.0 * (c.bottom - c.top)
            )]
        );
        assert_eq!(c.x_ticks.len(), 1);
    }
}
