//! Shared by the HTML tests: a synthetic person (14 days of CGM or meter
//! readings, meals, settings, suggestions with answers), checks of the
//! pages' structure, and where test outputs go.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod browser;

use std::path::{Path, PathBuf};

use abba_advisor::Mode;
use abba_core::units::GlucoseUnit;
use abba_core::MealSlot;
use abba_report::html::person::{
    MealTime, PersonDay, PersonReportInput, Reading, SettingsInForce, SuggestionLine,
};

/// 2026-11-02 00:00 UTC (the person's local time is UTC here).
pub const START_UNIX_S: i64 = 1_793_577_600;

/// Folder for this test's outputs under target/ (kept after the test, not in the repo).
pub fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("html")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A deterministic glucose curve: a daily rhythm, meal peaks, a small
/// day-to-day drift (mg/dL).
fn glucose(day: usize, minute: u32) -> f64 {
    let t = f64::from(minute);
    let mut g = 120.0 + 25.0 * (std::f64::consts::TAU * (t - 300.0) / 1440.0).sin();
    for meal in [420.0, 750.0, 1140.0] {
        let dt = t - meal;
        if dt > 0.0 {
            g += 90.0 * (dt / 60.0) * (-dt / 60.0).exp() * 2.0;
        }
    }
    g + 6.0 * ((day * 7 + minute as usize / 5) % 13) as f64 - 36.0 + 3.0 * day as f64
}

/// A person with `days` days: CGM every 5 min (a 2-hour gap on day 3),
/// or four meter readings a day; three meals; settings that change on the
/// days a suggestion was accepted.
pub fn synthetic_person(days: usize, mode: Mode, unit: GlucoseUnit) -> PersonReportInput {
    let mut out = Vec::new();
    let mut basal = 0.9;
    let mut suggestions = Vec::new();
    for d in 0..days {
        let day_start = START_UNIX_S + d as i64 * 86_400;
        let minutes: Vec<u32> = match mode {
            Mode::Cgm => (0..288)
                .map(|k| k * 5)
                .filter(|m| !(d == 2 && (600..720).contains(m)))
                .collect(),
            Mode::Smbg => vec![415, 745, 1135, 1320],
        };
        let readings = minutes
            .iter()
            .map(|&m| Reading {
                at_s: day_start + i64::from(m) * 60,
                minute_of_day: m,
                mg_dl: glucose(d, m),
            })
            .collect();
        let meals = [
            (MealSlot::Breakfast, 420),
            (MealSlot::Lunch, 750),
            (MealSlot::Dinner, 1140),
        ]
        .into_iter()
        .map(|(slot, m)| MealTime {
            at_s: day_start + i64::from(m) * 60,
            minute_of_day: m,
            slot,
            carbs_g: Some(40.0 + d as f64),
        })
        .collect();
        out.push(PersonDay {
            date: format!("2026-11-{:02}", 2 + d),
            readings,
            settings: Some(SettingsInForce {
                basal_u_per_h: basal,
                carb_ratio_g_per_u: [10.0, 12.0, 11.0],
            }),
            basal_u: Some(basal * 24.0),
            bolus_u: Some(12.0 + d as f64 * 0.1),
            carbs_g: Some(3.0 * (40.0 + d as f64)),
            meals,
            rescue_g: None,
        });
        if d % 4 == 3 {
            let new = basal * 1.05;
            let answer = match (d / 4) % 3 {
                0 => "accepted".to_string(),
                1 => "rejected".to_string(),
                _ => format!("set to {:.3} U/h", basal * 1.02),
            };
            suggestions.push(SuggestionLine {
                when: format!("2026-11-{:02} 23:59", 2 + d),
                setting: "basal rate".into(),
                from: format!("{basal:.3} U/h"),
                to: format!("{new:.3} U/h"),
                reason: format!("glucose stayed high overnight on day {}", d + 1),
                answer: answer.clone(),
            });
            if answer == "accepted" {
                basal = new;
            }
        }
    }
    PersonReportInput {
        person: "Ada <test> & co".into(),
        mode,
        unit,
        days: out,
        suggestions,
        notes: Vec::new(),
        back: None,
    }
}

/// Every `<svg>` has `role="img"`, a `<title>` and a `<desc>`; every table
/// has header cells; no script, no external resource.
pub fn check_structure(html: &str) {
    assert!(html.starts_with("<!DOCTYPE html>"));
    let svgs = html.matches("<svg").count();
    assert!(svgs > 0);
    for (i, part) in html.split("<svg").skip(1).enumerate() {
        let head = &part[..part.find('>').unwrap()];
        assert!(head.contains(r#"role="img""#), "svg {i} has no role=img");
        let after = &part[part.find('>').unwrap() + 1..];
        assert!(
            after.starts_with("<title"),
            "svg {i} does not start with a <title>"
        );
        assert!(after.contains("<desc"), "svg {i} has no <desc>");
    }
    let tables = html.matches("<table").count();
    assert_eq!(
        tables,
        html.matches("<thead>").count(),
        "a table without a header row"
    );
    for part in html.split("<table").skip(1) {
        let body = &part[..part.find("</table>").unwrap()];
        assert!(body.contains("<th"), "a table without <th>");
    }
    let lower = html.to_lowercase();
    assert!(!lower.contains("<script"), "the page must not carry script");
    assert!(!lower.contains("<link"), "the page must not link resources");
    assert!(!lower.contains("url("), "the style must not fetch anything");
    assert!(!lower.contains("@import"));
    let external = lower
        .replace("http://www.w3.org/2000/svg", "")
        .replace("http://www.w3.org/1999/xlink", "");
    assert!(
        !external.contains("http://") && !external.contains("https://"),
        "external reference"
    );
    assert!(lower.contains("research software, not a medical device"));
}

#[allow(unused_imports)]
pub use browser::validate_with_tidy;
