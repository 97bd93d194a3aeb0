//! The HTML pages' content: the person report's percentiles against an
//! independent computation from the same readings, a panel for every day,
//! every suggestion with its answer, both units, the meter variant; the
//! trial page from synthetic arms; structure, accessibility and validation.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_advisor::Mode;
use abba_core::units::GlucoseUnit;
use abba_report::html::person::{person_report_html, person_summary, profile_bin_min};
use common::{check_structure, out_dir, synthetic_person, validate_with_tidy};

/// Type-7 quantile written again here, from its definition.
fn quantile(values: &[f64], p: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let h = (v.len() as f64 - 1.0) * p;
    let (lo, frac) = (h.floor() as usize, h - h.floor());
    if lo + 1 < v.len() {
        v[lo] + frac * (v[lo + 1] - v[lo])
    } else {
        v[lo]
    }
}

#[test]
fn person_percentiles_equal_an_independent_computation() {
    for mode in [Mode::Cgm, Mode::Smbg] {
        let input = synthetic_person(14, mode, GlucoseUnit::MgDl);
        let summary = person_summary(&input).unwrap();
        let bin_min = profile_bin_min(mode);
        assert_eq!(summary.profile.len(), (1440 / bin_min) as usize);
        let mut bins_with_data = 0;
        for bin in &summary.profile {
            let values: Vec<f64> = input
                .days
                .iter()
                .flat_map(|d| &d.readings)
                .filter(|r| r.minute_of_day / bin_min * bin_min == bin.start_min)
                .map(|r| r.mg_dl)
                .collect();
            assert_eq!(bin.n, values.len());
            match bin.p {
                None => assert!(values.is_empty()),
                Some(p) => {
                    bins_with_data += 1;
                    for (got, q) in p.iter().zip([0.05, 0.25, 0.5, 0.75, 0.95]) {
                        let want = quantile(&values, q);
                        assert!(
                            (got - want).abs() < 1e-9,
                            "{mode:?} bin {}: {got} vs {want}",
                            bin.start_min
                        );
                    }
                }
            }
        }
        assert_eq!(bins_with_data, if mode == Mode::Cgm { 96 } else { 4 });
        // The page's text alternative of the profile prints the medians.
        let html = person_report_html(&input).unwrap();
        let noon = summary.profile.iter().find(|b| b.start_min == 720).unwrap();
        if let Some(p) = noon.p {
            assert!(html.contains(&format!(
                "12:00: median {:.0}, 5th-95th {:.0}-{:.0}.",
                p[2], p[0], p[4]
            )));
        }
    }
}

#[test]
fn every_day_has_its_panel_and_every_suggestion_its_answer() {
    let input = synthetic_person(14, Mode::Cgm, GlucoseUnit::MgDl);
    assert!(input.suggestions.len() >= 3);
    let html = person_report_html(&input).unwrap();
    for (i, day) in input.days.iter().enumerate() {
        assert!(
            html.contains(&format!(r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {} 150" role="img" class="day{i}"><title>{}</title>"#, abba_report::html::svg::DAY_PANEL_WIDTH, day.date)),
            "no panel for {}",
            day.date
        );
    }
    let panel = format!(
        r#"viewBox="0 0 {} 150""#,
        abba_report::html::svg::DAY_PANEL_WIDTH
    );
    assert_eq!(html.matches(&panel).count(), 14);
    for s in &input.suggestions {
        let row = html
            .split("<tr>")
            .find(|r| r.contains(&s.reason))
            .unwrap_or_else(|| panic!("suggestion '{}' missing", s.reason));
        assert!(
            row.contains(&format!("<td>{}</td>", s.answer)),
            "answer of '{}' missing",
            s.reason
        );
        assert!(row.contains(&s.when) && row.contains(&s.to));
    }
    for answer in ["accepted", "rejected", "set to"] {
        assert!(input
            .suggestions
            .iter()
            .any(|s| s.answer.starts_with(answer)));
    }
    // The name is escaped, the period and CGM time are in the header.
    assert!(html.contains("Ada &lt;test&gt; &amp; co"));
    assert!(!html.contains("Ada <test>"));
    assert!(html.contains("2026-11-02 to 2026-11-15"));
    // 14 days of 288 slots, 24 readings missing on day 3.
    let active = 100.0 * (14.0 * 288.0 - 24.0) / (14.0 * 288.0);
    assert!(html.contains(&format!("{active:.1} %")));
    // Per-meal outcomes: 3 meals a day, each with a 2 h and 4 h reading.
    let meal_rows = html
        .split("<tr>")
        .filter(|r| r.contains(">breakfast<") || r.contains(">lunch<") || r.contains(">dinner<"))
        .count();
    assert_eq!(meal_rows, 42);
    check_structure(&html);
}

#[test]
fn ranges_and_statistics_come_from_abba_core() {
    let input = synthetic_person(14, Mode::Cgm, GlucoseUnit::MgDl);
    let s = person_summary(&input).unwrap();
    let m = s.metrics.unwrap();
    let r = s.ranges_pct.unwrap();
    assert!((r.iter().sum::<f64>() - 100.0).abs() < 1e-9);
    let html = person_report_html(&input).unwrap();
    assert!(html.contains(&format!("{:.1} %", m.gmi_pct)));
    assert!(html.contains(&format!("{:.1} %", m.cv_pct)));
    assert!(html.contains(&format!("Target (70-180 mg/dL): {:.1} %", r[2])));
}

#[test]
fn mmol_per_litre_is_printed_when_chosen() {
    let input = synthetic_person(7, Mode::Cgm, GlucoseUnit::MmolL);
    let s = person_summary(&input).unwrap();
    let html = person_report_html(&input).unwrap();
    let mean = s.metrics.unwrap().mean_mg_dl / abba_core::units::MG_DL_PER_MMOL_L;
    assert!(html.contains(&format!("{mean:.1} mmol/L")));
    assert!(html.contains("Glucose (mmol/L)"));
    assert!(html.contains("Target (3.9-10.0 mmol/L): "));
    assert!(html.contains("target 3.9 and 10.0 mmol/L"));
    assert!(!html.contains("Target (70-180 mg/dL)"));
}

#[test]
fn the_meter_variant_shows_readings_per_day() {
    let input = synthetic_person(14, Mode::Smbg, GlucoseUnit::MgDl);
    let html = person_report_html(&input).unwrap();
    assert!(html.contains("Meter readings per day"));
    assert!(html.contains("meter (SMBG)"));
    assert!(!html.contains("Time CGM active"));
    assert_eq!(html.matches("<circle").count(), 14 * 4);
    check_structure(&html);
}

#[test]
fn bad_input_is_refused_with_the_place() {
    let mut input = synthetic_person(3, Mode::Cgm, GlucoseUnit::MgDl);
    input.days[1].readings[5].mg_dl = f64::NAN;
    let err = person_report_html(&input).unwrap_err().to_string();
    assert!(
        err.contains("days[1] (2026-11-03) readings[5].mg_dl"),
        "{err}"
    );
    let mut input = synthetic_person(3, Mode::Cgm, GlucoseUnit::MgDl);
    input.days[2].readings[0].minute_of_day = 1440;
    assert!(person_report_html(&input)
        .unwrap_err()
        .to_string()
        .contains("expected 0..1440"));
    let mut input = synthetic_person(3, Mode::Cgm, GlucoseUnit::MgDl);
    input.days.clear();
    assert!(person_report_html(&input).is_err());
}

#[test]
fn the_same_input_gives_the_same_bytes_and_the_page_validates() {
    let input = synthetic_person(14, Mode::Cgm, GlucoseUnit::MgDl);
    let a = person_report_html(&input).unwrap();
    assert_eq!(a, person_report_html(&input).unwrap());
    let dir = out_dir("validate");
    let path = dir.join("person.html");
    std::fs::write(&path, &a).unwrap();
    validate_with_tidy(&path);
    let path = dir.join("person-smbg.html");
    std::fs::write(
        &path,
        person_report_html(&synthetic_person(14, Mode::Smbg, GlucoseUnit::MmolL)).unwrap(),
    )
    .unwrap();
    validate_with_tidy(&path);
}

#[test]
fn every_range_label_of_the_bar_stays_inside_the_figure() {
    // Crowded at the top (tiny high ranges) and at the bottom (tiny low ones).
    for pct in [
        [0.0, 0.0, 99.0, 0.5, 0.5],
        [0.5, 0.5, 99.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 0.0, 100.0],
    ] {
        let svg = abba_report::html::svg::tir_bar_svg("t", pct, "t", GlucoseUnit::MgDl);
        let ys: Vec<f64> = svg
            .split("<text ")
            .skip(1)
            .map(|t| {
                let i = t.find("y=\"").unwrap() + 3;
                t[i..i + t[i..].find('"').unwrap()].parse().unwrap()
            })
            .collect();
        assert_eq!(ys.len(), 11, "{pct:?}");
        assert!(ys.iter().all(|y| *y > 0.0 && *y < 258.0), "{pct:?}: {ys:?}");
    }
}
