//! The person report: an AGP-style page for one person over a period, then
//! what no AGP page has (settings by day, every suggestion with its reason
//! and the person's answer, per-meal outcomes, daily insulin and carbs).
//!
//! It is a pure function of [`PersonReportInput`], a plain struct any
//! source can fill (the person store's adapter lives with the CLI), so the
//! page does not depend on how a person is stored. Glucose metrics (mean,
//! GMI, CV, the consensus ranges) come from [`abba_core::metrics`].

use abba_advisor::Mode;
use abba_core::metrics::{metrics_timed, GlucoseMetrics};
use abba_core::MealSlot;
use serde::{Deserialize, Serialize};

use crate::error::ReportError;
use crate::html::profile::{time_of_day_profile, ProfileBin, DAY_MIN};
use crate::html::svg::{day_panel_svg, profile_svg, tir_bar_svg, FULL_WIDTH};
use crate::html::{render_page, Row, DISCLAIMER};
use abba_core::units::GlucoseUnit;

/// Width of the profile's time-of-day bins for CGM readings (minutes).
pub const PROFILE_BIN_MIN: u32 = 15;
/// Width of the profile's bins for meter readings (minutes): a few finger
/// sticks a day need wider bins to pool days.
pub const SMBG_PROFILE_BIN_MIN: u32 = 60;

/// The profile's bin width for a mode.
pub fn profile_bin_min(mode: Mode) -> u32 {
    match mode {
        Mode::Cgm => PROFILE_BIN_MIN,
        Mode::Smbg => SMBG_PROFILE_BIN_MIN,
    }
}
/// CGM sampling period assumed for "% time CGM active" (minutes).
pub const CGM_PERIOD_MIN: u32 = 5;
/// How far from 2 h / 4 h after a meal a reading may be to count as that
/// meal's outcome: CGM (minutes).
pub const OUTCOME_TOLERANCE_CGM_MIN: i64 = 10;
/// The same for meter readings (minutes): finger sticks are rarer.
pub const OUTCOME_TOLERANCE_SMBG_MIN: i64 = 30;

/// Everything the person report shows, already read from wherever the
/// person's data lives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PersonReportInput {
    /// The person's name.
    pub person: String,
    /// CGM or SMBG (meter) mode.
    pub mode: Mode,
    /// The unit the page prints glucose in.
    pub unit: GlucoseUnit,
    /// The days of the period, in order (local calendar days).
    pub days: Vec<PersonDay>,
    /// Every suggestion of the period, in order.
    pub suggestions: Vec<SuggestionLine>,
    /// What the reader must know about the data (how insulin was delivered,
    /// a closed loop and its evidence), shown at the top.
    #[serde(default)]
    pub notes: Vec<String>,
    /// Served in the app: the link back to where the reader came from
    /// (not printed); `None` for a file.
    #[serde(default)]
    pub back: Option<BackLink>,
}

/// A link at the top of a served report (a relative path and its words).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BackLink {
    /// Where it goes (a path of the app).
    pub href: String,
    /// What it says.
    pub label: String,
}

/// Fewer days than this make an AGP unreliable (the international
/// consensus on time in range, Battelino et al. 2019: 14 days).
pub const AGP_MIN_DAYS: usize = 14;
/// Less CGM wear than this (% of the period) makes an AGP unreliable (same consensus).
pub const AGP_MIN_WEAR_PCT: f64 = 70.0;

/// Warnings about the period: too few days, too little CGM wear.
pub fn data_warnings(input: &PersonReportInput, cgm_active_pct: Option<f64>) -> Vec<String> {
    let mut out = Vec::new();
    let n = input.days.len();
    if n < AGP_MIN_DAYS {
        out.push(format!(
            "This period has {n} days: an AGP needs at least {AGP_MIN_DAYS} days (international consensus on time in range); the statistics and the profile below may not represent this person."
        ));
    }
    if let Some(p) = cgm_active_pct.filter(|p| *p < AGP_MIN_WEAR_PCT) {
        out.push(format!(
            "The CGM was active {p:.0} % of the period: an AGP needs at least {AGP_MIN_WEAR_PCT:.0} % (international consensus on time in range); the statistics and the profile below may not represent this person."
        ));
    }
    out
}

/// One local calendar day.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PersonDay {
    /// Local date, `YYYY-MM-DD`.
    pub date: String,
    /// Glucose readings (CGM or meter, as the mode says), in time order.
    pub readings: Vec<Reading>,
    /// Settings in force at the start of the day, if known.
    pub settings: Option<SettingsInForce>,
    /// Basal insulin delivered (U), if known.
    pub basal_u: Option<f64>,
    /// Bolus insulin delivered (U), if known.
    pub bolus_u: Option<f64>,
    /// Carbohydrate announced (g), if known.
    pub carbs_g: Option<f64>,
    /// Main meals (and snacks) of the day.
    pub meals: Vec<MealTime>,
    /// Carbohydrate taken to treat low glucose (g; not meals), if known.
    #[serde(default)]
    pub rescue_g: Option<f64>,
}

/// One glucose reading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Reading {
    /// The instant in seconds on any clock that only moves forward (Unix
    /// time, or the advisor's clock: minutes since 00:00 of day 1 × 60);
    /// used for the order of readings and the times after a meal.
    pub at_s: i64,
    /// Local time of day, minutes after midnight (0..1440).
    pub minute_of_day: u32,
    /// Glucose, mg/dL.
    pub mg_dl: f64,
}

/// Basal rate and carb ratios in force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SettingsInForce {
    /// Basal rate, U/h.
    pub basal_u_per_h: f64,
    /// Carb ratios for breakfast, lunch, dinner, g/U.
    pub carb_ratio_g_per_u: [f64; 3],
}

/// A meal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MealTime {
    /// The instant, on the same clock as [`Reading::at_s`].
    pub at_s: i64,
    /// Local time of day, minutes after midnight.
    pub minute_of_day: u32,
    /// Which meal.
    pub slot: MealSlot,
    /// Carbohydrate (g), if announced.
    pub carbs_g: Option<f64>,
}

/// One suggestion with its reason and the person's answer, in words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SuggestionLine {
    /// Local date and time it was made (`YYYY-MM-DD HH:MM`).
    pub when: String,
    /// The setting (`basal rate`, `carb ratio (breakfast)` ...).
    pub setting: String,
    /// Value in force before, with unit.
    pub from: String,
    /// Suggested value, with unit.
    pub to: String,
    /// Why, in plain words.
    pub reason: String,
    /// The person's answer (`accepted`, `rejected`, `set to ...`, `not answered yet`).
    pub answer: String,
}

/// The page's numbers, computed from the input (public so tests and other
/// renderers can check them).
#[derive(Debug, Clone, PartialEq)]
pub struct PersonSummary {
    /// Glucose metrics of all readings of the period (abba-core).
    pub metrics: Option<GlucoseMetrics>,
    /// % of 5-min slots of the period with a CGM reading (CGM mode).
    pub cgm_active_pct: Option<f64>,
    /// The glucose profile.
    pub profile: Vec<ProfileBin>,
    /// The five consensus ranges (% of readings), lowest first.
    pub ranges_pct: Option<[f64; 5]>,
}

fn bad(what: String) -> ReportError {
    ReportError::PersonInput(what)
}

/// Checks the input: at least one day, dates in increasing order, readings
/// with a time of day below 24:00, a finite glucose > 0 and instants in
/// increasing order.
pub fn check_input(input: &PersonReportInput) -> Result<(), ReportError> {
    if input.days.is_empty() {
        return Err(bad("the period has no days".into()));
    }
    let mut last_instant: Option<i64> = None;
    for (d, day) in input.days.iter().enumerate() {
        if d > 0 && day.date <= input.days[d - 1].date {
            return Err(bad(format!(
                "days[{d}] date {} does not follow {}",
                day.date,
                input.days[d - 1].date
            )));
        }
        for (i, r) in day.readings.iter().enumerate() {
            if r.minute_of_day >= DAY_MIN {
                return Err(bad(format!(
                    "days[{d}] ({}) readings[{i}].minute_of_day is {}, expected 0..1440",
                    day.date, r.minute_of_day
                )));
            }
            if !(r.mg_dl.is_finite() && r.mg_dl > 0.0) {
                return Err(bad(format!(
                    "days[{d}] ({}) readings[{i}].mg_dl is {}, expected a finite glucose > 0 mg/dL",
                    day.date, r.mg_dl
                )));
            }
            if last_instant.is_some_and(|l| r.at_s <= l) {
                return Err(bad(format!(
                    "days[{d}] ({}) readings[{i}].at_s {} is not after the previous reading",
                    day.date, r.at_s
                )));
            }
            last_instant = Some(r.at_s);
        }
    }
    Ok(())
}

/// The numbers of the page (see [`PersonSummary`]).
pub fn person_summary(input: &PersonReportInput) -> Result<PersonSummary, ReportError> {
    check_input(input)?;
    let all: Vec<&Reading> = input.days.iter().flat_map(|d| &d.readings).collect();
    let metrics = if all.len() >= 2 {
        let times: Vec<f64> = all.iter().map(|r| r.at_s as f64 / 60.0).collect();
        let values: Vec<f64> = all.iter().map(|r| r.mg_dl).collect();
        Some(
            metrics_timed(&times, &values).map_err(|source| ReportError::Stats {
                what: format!("person {}: glucose metrics", input.person),
                source,
            })?,
        )
    } else {
        None
    };
    let cgm_active_pct = (input.mode == Mode::Cgm).then(|| {
        let slots: std::collections::BTreeSet<i64> = all
            .iter()
            .map(|r| r.at_s.div_euclid(i64::from(CGM_PERIOD_MIN) * 60))
            .collect();
        let expected = input.days.len() as f64 * f64::from(DAY_MIN / CGM_PERIOD_MIN);
        (100.0 * slots.len() as f64 / expected).min(100.0)
    });
    let ranges_pct = metrics.map(|m| {
        [
            m.below_54,
            m.below_70 - m.below_54,
            m.tir_70_180,
            m.above_180 - m.above_250,
            m.above_250,
        ]
    });
    Ok(PersonSummary {
        metrics,
        cgm_active_pct,
        profile: time_of_day_profile(
            all.iter().map(|r| (r.minute_of_day, r.mg_dl)),
            profile_bin_min(input.mode),
        ),
        ranges_pct,
    })
}

/// The reading nearest to `target` (unix s) within `tolerance_min`.
fn reading_near(readings: &[&Reading], target: i64, tolerance_min: i64) -> Option<f64> {
    readings
        .iter()
        .filter(|r| (r.at_s - target).abs() <= tolerance_min * 60)
        .min_by_key(|r| (r.at_s - target).abs())
        .map(|r| r.mg_dl)
}

fn opt(v: Option<f64>, decimals: usize, unit: &str) -> String {
    v.map_or_else(|| "—".to_string(), |x| format!("{x:.decimals$} {unit}"))
}

fn slot_name(slot: MealSlot) -> &'static str {
    match slot {
        MealSlot::Breakfast => "breakfast",
        MealSlot::Lunch => "lunch",
        MealSlot::Dinner => "dinner",
        MealSlot::Snack => "snack",
    }
}

/// The person report as one self-contained HTML page.
pub fn person_report_html(input: &PersonReportInput) -> Result<String, ReportError> {
    let summary = person_summary(input)?;
    let unit = input.unit;
    let meter = input.mode == Mode::Smbg;
    let all: Vec<&Reading> = input.days.iter().flat_map(|d| &d.readings).collect();
    let first = &input.days[0].date;
    let last = &input.days[input.days.len() - 1].date;

    let stats: Vec<Row> = match summary.metrics {
        Some(m) => vec![
            Row::of(["Mean glucose", &unit.with_unit(m.mean_mg_dl), "—"]),
            Row::of([
                "Glucose management indicator (GMI)",
                &format!("{:.1} %", m.gmi_pct),
                "goal < 7 %",
            ]),
            Row::of([
                "Glucose variability (CV)",
                &format!("{:.1} %", m.cv_pct),
                "goal ≤ 36 %",
            ]),
            Row::of(["Readings", &m.n_readings.to_string(), "—"]),
        ],
        None => Vec::new(),
    };
    let tir_svg = summary
        .ranges_pct
        .map(|p| tir_bar_svg("tir", p, "Time in ranges (% of readings)", unit))
        .unwrap_or_default();
    let profile = profile_svg(
        "agp",
        &summary.profile,
        unit,
        &format!(
            "Glucose profile, {first} to {last} ({} days)",
            input.days.len()
        ),
        FULL_WIDTH,
    );
    let panels: Vec<String> = input
        .days
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let r: Vec<(u32, f64)> = d
                .readings
                .iter()
                .map(|r| (r.minute_of_day, r.mg_dl))
                .collect();
            day_panel_svg(&format!("day{i}"), &d.date, &r, meter, unit)
        })
        .collect();
    let settings: Vec<Row> = input
        .days
        .iter()
        .map(|d| match d.settings {
            Some(s) => Row::of([
                &d.date,
                &format!("{:.3} U/h", s.basal_u_per_h),
                &format!("{:.1} g/U", s.carb_ratio_g_per_u[0]),
                &format!("{:.1} g/U", s.carb_ratio_g_per_u[1]),
                &format!("{:.1} g/U", s.carb_ratio_g_per_u[2]),
            ]),
            None => Row::of([&d.date, "—", "—", "—", "—"]),
        })
        .collect();
    let suggestions: Vec<Row> = input
        .suggestions
        .iter()
        .map(|s| Row::of([&s.when, &s.setting, &s.from, &s.to, &s.reason, &s.answer]))
        .collect();
    let tolerance = if meter {
        OUTCOME_TOLERANCE_SMBG_MIN
    } else {
        OUTCOME_TOLERANCE_CGM_MIN
    };
    let mut meals = Vec::new();
    for d in &input.days {
        for m in d.meals.iter().filter(|m| m.slot != MealSlot::Snack) {
            let at = |h: i64| {
                reading_near(&all, m.at_s + h * 3600, tolerance)
                    .map_or_else(|| "no reading".to_string(), |g| unit.with_unit(g))
            };
            meals.push(Row::of([
                &d.date,
                slot_name(m.slot),
                &format!("{:02}:{:02}", m.minute_of_day / 60, m.minute_of_day % 60),
                &opt(m.carbs_g, 0, "g"),
                &reading_near(&all, m.at_s, tolerance)
                    .map_or_else(|| "no reading".to_string(), |g| unit.with_unit(g)),
                &at(2),
                &at(4),
            ]));
        }
    }
    let insulin: Vec<Row> = input
        .days
        .iter()
        .map(|d| {
            let total = match (d.basal_u, d.bolus_u) {
                (Some(a), Some(b)) => Some(a + b),
                _ => None,
            };
            Row::of([
                &d.date,
                &opt(d.basal_u, 1, "U"),
                &opt(d.bolus_u, 1, "U"),
                &opt(total, 1, "U"),
                &opt(d.carbs_g, 0, "g"),
                &opt(d.rescue_g, 0, "g"),
            ])
        })
        .collect();
    let profile_rows: Vec<Row> = summary
        .profile
        .iter()
        .filter_map(|b| {
            b.p.map(|p| {
                Row::of([
                    &format!("{:02}:{:02}", b.start_min / 60, b.start_min % 60),
                    &b.n.to_string(),
                    &unit.value(p[0]),
                    &unit.value(p[1]),
                    &unit.value(p[2]),
                    &unit.value(p[3]),
                    &unit.value(p[4]),
                ])
            })
        })
        .collect();
    let readings_per_day: Vec<Row> = input
        .days
        .iter()
        .map(|d| Row::of([&d.date, &d.readings.len().to_string()]))
        .collect();

    let ctx = minijinja::context! {
        title => format!("abba person report: {}", input.person),
        disclaimer => DISCLAIMER,
        person => &input.person,
        period => format!("{first} to {last}"),
        n_days => input.days.len(),
        mode => if meter { "meter (SMBG)" } else { "CGM" },
        meter => meter,
        unit => unit.label(),
        cgm_active => summary.cgm_active_pct.map(|p| format!("{p:.1} %")),
        stats => stats,
        tir_svg => tir_svg,
        profile_svg => profile,
        profile_rows => profile_rows,
        bin_min => profile_bin_min(input.mode),
        target_range => unit.range(70.0, 180.0),
        panels => panels,
        readings_per_day => readings_per_day,
        settings => settings,
        suggestions => suggestions,
        meals => meals,
        outcome_tolerance => tolerance,
        insulin => insulin,
        warnings => data_warnings(input, summary.cgm_active_pct),
        notes => &input.notes,
        back => &input.back,
    };
    render_page("person.html", "person report", ctx)
}
