//! Glucose: the last 24 hours or 14 days of readings as a chart with the
//! target range, in the person's unit and zone, and their summary (time
//! in ranges, mean).
//!
//! The window ends now; when the person has no reading in it (an export
//! imported days ago), it ends at their last reading instead and the
//! chart's name says so.

use super::page::{render, PageResult};
use super::session::{self, Ctx};
use crate::error::ApiError;
use crate::state::AppState;
use abba_core::units::GlucoseUnit;
use abba_core::units::MG_DL_PER_MMOL_L;
use abba_core::{EventKind, Timestamp};
use abba_store::advise;
use abba_store::Live;
use abba_web::chart::{self, Point};
use abba_web::pages::Layout;
use abba_web::texts::{fill, EN};
use axum::extract::{RawQuery, State};
use axum::http::StatusCode;
use serde::Serialize;

/// A link of a choice (the Glucose page's ranges).
#[derive(Debug, Clone, Serialize)]
pub struct LinkChoice {
    /// Where.
    pub href: &'static str,
    /// Its text.
    pub label: &'static str,
    /// True for the one shown (`aria-current`).
    pub current: bool,
}

/// One line of the Glucose page's summary.
#[derive(Debug, Clone, Serialize)]
pub struct SummaryItem {
    /// What.
    pub label: String,
    /// Its value in words.
    pub value: String,
}

/// The Glucose page.
#[derive(Debug, Clone, Serialize)]
pub struct Glucose {
    /// The ranges (24 h, 14 days).
    pub ranges: Vec<LinkChoice>,
    /// The chart's accessible name.
    pub chart_title: String,
    /// The glucose unit, written over the chart's glucose axis (its
    /// numbers alone do not say mg/dL or mmol/L).
    pub unit: &'static str,
    /// The chart (none: no reading in the range).
    pub chart: Option<abba_web::chart::Chart>,
    /// The summary (time in ranges, mean, readings).
    pub summary: Vec<SummaryItem>,
    /// A note under the summary (finger sticks: shares of readings).
    pub summary_note: Option<String>,
    /// The chart's readings as a table (by hour over a day, by day over
    /// two weeks), oldest first.
    pub table: Vec<GlucoseRow>,
    /// The table's caption.
    pub table_caption: String,
    /// The table's first column's name (hour or day).
    pub table_period: &'static str,
}

/// One row of the Glucose page's table.
#[derive(Debug, Clone, Serialize)]
pub struct GlucoseRow {
    /// The hour or the day.
    pub period: String,
    /// How many readings.
    pub readings: usize,
    /// Their mean, in the person's unit.
    pub mean: String,
    /// The lowest.
    pub lowest: String,
    /// The highest.
    pub highest: String,
    /// The share in the target range.
    pub in_range: String,
}

/// The two windows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Range {
    /// The last 24 hours.
    Day,
    /// The last 14 days.
    TwoWeeks,
}

impl Range {
    /// The range a query asks for: none (24 hours), `range=24h` or
    /// `range=14d`; anything else is 400 naming `range`, never the 24
    /// hours shown for a range that was not asked (`?range=1000000d`, a
    /// second `range`, another parameter were all answered with them).
    fn from_query(q: Option<&str>) -> Result<Self, ApiError> {
        let pairs: Vec<&str> = q
            .unwrap_or("")
            .split('&')
            .filter(|p| !p.is_empty())
            .collect();
        match pairs[..] {
            [] | ["range=24h"] => Ok(Range::Day),
            ["range=14d"] => Ok(Range::TwoWeeks),
            _ => Err(ApiError::new(
                StatusCode::BAD_REQUEST,
                abba_api::ErrorCode::BadQuery,
                format!(
                    "expected range=24h or range=14d, got {:?}",
                    q.unwrap_or("").chars().take(100).collect::<String>()
                ),
            )
            .at("range")),
        }
    }
    fn minutes(self) -> i64 {
        match self {
            Range::Day => 1440,
            Range::TwoWeeks => 14 * 1440,
        }
    }
    fn label(self) -> &'static str {
        match self {
            Range::Day => EN.range_24h,
            Range::TwoWeeks => EN.range_14d,
        }
    }
}

/// The person's unit: its name, the factor from mg/dL, the target range,
/// the least top of the axis and its tick step.
struct Unit {
    name: &'static str,
    per_mg_dl: f64,
    target: (f64, f64),
    floor: f64,
    step: f64,
    decimals: usize,
}

fn unit_of(u: GlucoseUnit) -> Unit {
    match u {
        GlucoseUnit::MgDl => Unit {
            name: "mg/dL",
            per_mg_dl: 1.0,
            target: (70.0, 180.0),
            floor: 300.0,
            step: 50.0,
            decimals: 0,
        },
        GlucoseUnit::MmolL => Unit {
            name: "mmol/L",
            per_mg_dl: 1.0 / MG_DL_PER_MMOL_L,
            target: (3.9, 10.0),
            floor: 16.0,
            step: 2.0,
            decimals: 1,
        },
    }
}

impl Unit {
    fn text(&self, v: f64) -> String {
        format!("{v:.*}", self.decimals)
    }
}

/// The page's model: the readings of `range` up to `now` (advisor time).
pub fn model(live: &Live, range: Range, now: Option<Timestamp>) -> Glucose {
    let unit = unit_of(live.person.settings.units);
    let clock = advise::clock(&live.person);
    let readings: Vec<(i64, f64, bool)> = live
        .stream
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Cgm(g) => Some((e.at.0, g.0, true)),
            EventKind::Smbg(g) => Some((e.at.0, g.0, false)),
            _ => None,
        })
        .collect();
    let span = range.minutes();
    let mut end = now.map_or(i64::MIN, |t| t.0);
    let last = readings.last().map(|r| r.0);
    let up_to_last = match last {
        Some(l) if l <= end - span || end == i64::MIN => {
            end = l;
            true
        }
        _ => false,
    };
    let start = end - span;
    let shown: Vec<&(i64, f64, bool)> = readings
        .iter()
        .filter(|r| r.0 > start && r.0 <= end)
        .collect();
    let ranges = [
        ("/glucose?range=24h", Range::Day),
        ("/glucose?range=14d", Range::TwoWeeks),
    ]
    .iter()
    .map(|&(href, r)| LinkChoice {
        href,
        label: r.label(),
        current: r == range,
    })
    .collect();
    let local = |t: i64| advise::local(clock.as_ref(), Timestamp(t));
    let mut chart_title = fill(
        EN.chart_title,
        &[
            ("range", &range.label().to_lowercase()),
            ("unit", unit.name),
            ("low", &unit.text(unit.target.0)),
            ("high", &unit.text(unit.target.1)),
        ],
    );
    if up_to_last {
        chart_title.push_str(&format!(" (up to the last reading, {})", local(end)));
    }
    if shown.is_empty() {
        return Glucose {
            ranges,
            chart_title,
            unit: unit.name,
            chart: None,
            summary: Vec::new(),
            summary_note: None,
            table: Vec::new(),
            table_caption: String::new(),
            table_period: EN.table_hour,
        };
    }
    let points: Vec<Point> = shown
        .iter()
        .map(|&&(at, mg, cgm)| Point {
            at,
            value: mg * unit.per_mg_dl,
            cgm,
        })
        .collect();
    // Ticks on local wall times: every 3 hours over a day, every 2 days'
    // midnight over two weeks (a day and a month's name: "12-02" reads as
    // the 12th of February to many).
    let every = match range {
        Range::Day => 180,
        Range::TwoWeeks => 2 * 1440,
    };
    let first_tick = start.div_euclid(every) * every + every;
    let x_ticks: Vec<(i64, String)> = (0..)
        .map(|k| first_tick + k * every)
        .take_while(|&t| t <= end)
        .map(|t| {
            let l = local(t);
            let label = match range {
                Range::Day => l.get(11..16).unwrap_or(&l).to_string(),
                Range::TwoWeeks => day_month(&l),
            };
            (t, label)
        })
        .collect();
    let c = chart::place(
        &points,
        (start, end),
        unit.target,
        unit.floor,
        unit.step,
        &x_ticks,
    );
    let mg: Vec<f64> = shown.iter().map(|r| r.1).collect();
    let cgm = shown.iter().filter(|r| r.2).count();
    let kind = match (cgm, mg.len() - cgm) {
        (_, 0) => EN.kind_cgm,
        (0, _) => EN.kind_smbg,
        _ => EN.kind_both,
    };
    let mut summary = vec![SummaryItem {
        label: fill(EN.summary_readings, &[("kind", kind)]),
        value: mg.len().to_string(),
    }];
    if let Ok(r) = abba_core::metrics::range_percentages(&mg) {
        let (low, high) = (unit.text(unit.target.0), unit.text(unit.target.1));
        let unit_fill = |t: &str| fill(t, &[("low", &low), ("high", &high), ("unit", unit.name)]);
        summary.push(SummaryItem {
            label: unit_fill(EN.summary_tir),
            value: format!("{:.0} %", r[2]),
        });
        summary.push(SummaryItem {
            label: unit_fill(EN.summary_below),
            value: format!("{:.1} %", r[1]),
        });
        summary.push(SummaryItem {
            label: unit_fill(EN.summary_above),
            value: format!("{:.0} %", r[3]),
        });
        let mean = mg.iter().sum::<f64>() / mg.len() as f64;
        summary.push(SummaryItem {
            label: EN.summary_mean.to_string(),
            value: format!("{} {}", unit.text(mean * unit.per_mg_dl), unit.name),
        });
    }
    let (table_period, bucket) = match range {
        Range::Day => (EN.table_hour, 60),
        Range::TwoWeeks => (EN.table_day, 1440),
    };
    let table = table(&shown, bucket, &unit, |t| {
        let l = local(t);
        match range {
            // The hour's local start, "HH:00".
            Range::Day => format!(
                "{}–{}",
                l.get(11..16).unwrap_or(&l),
                local(t + 60).get(11..16).unwrap_or("")
            ),
            Range::TwoWeeks => l.get(..10).unwrap_or(&l).to_string(),
        }
    });
    Glucose {
        ranges,
        chart_title,
        unit: unit.name,
        chart: Some(c),
        summary,
        summary_note: (cgm < mg.len()).then(|| EN.summary_share.to_string()),
        table,
        table_caption: fill(EN.table_caption, &[("unit", unit.name)]),
        table_period,
    }
}

/// A local time `YYYY-MM-DD HH:MM` as its day and month, `2 Dec`
/// (the time itself when it is not one).
fn day_month(local: &str) -> String {
    local
        .get(..10)
        .and_then(|d| d.parse::<jiff::civil::Date>().ok())
        .map_or_else(|| local.to_string(), |d| d.strftime("%-d %b").to_string())
}

/// The readings by `bucket` minutes (local wall time), oldest first.
fn table(
    shown: &[&(i64, f64, bool)],
    bucket: i64,
    unit: &Unit,
    label: impl Fn(i64) -> String,
) -> Vec<GlucoseRow> {
    let mut rows = Vec::new();
    let mut i = 0;
    while i < shown.len() {
        let key = shown[i].0.div_euclid(bucket);
        let mut j = i;
        while j < shown.len() && shown[j].0.div_euclid(bucket) == key {
            j += 1;
        }
        let mg: Vec<f64> = shown[i..j].iter().map(|r| r.1).collect();
        let mean = mg.iter().sum::<f64>() / mg.len() as f64;
        let lo = mg.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = mg.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let tir =
            mg.iter().filter(|g| (70.0..=180.0).contains(*g)).count() as f64 / mg.len() as f64;
        let v = |x: f64| unit.text(x * unit.per_mg_dl);
        rows.push(GlucoseRow {
            period: label(key * bucket),
            readings: mg.len(),
            mean: v(mean),
            lowest: v(lo),
            highest: v(hi),
            in_range: format!("{:.0} %", tir * 100.0),
        });
        i = j;
    }
    rows
}

/// `GET /glucose?range=24h|14d`.
pub async fn page(State(s): State<AppState>, ctx: Ctx, RawQuery(q): RawQuery) -> PageResult {
    let (id, w) = session::person_page(&s, &ctx).await?;
    let range = Range::from_query(q.as_deref())?;
    let (g, name) = s
        .person(id, false, move |_, live| {
            let now = advise::clock(&live.person).map(|c| c.timestamp(jiff::Timestamp::now()));
            Ok((model(live, range, now), live.person.name.clone()))
        })
        .await?;
    let layout = Layout::person(EN.glucose_title, &w.csrf, "/glucose").signed_in_as(&name);
    render(StatusCode::OK, "glucose.html", &layout, &g)
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::get;
    axum::Router::new().route("/glucose", get(page))
}
