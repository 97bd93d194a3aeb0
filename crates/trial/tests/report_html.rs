//! `report.html` of a small trial: the cohort profiles equal an independent
//! computation from the same 5-min plasma glucose, every arm has its page,
//! the page is valid, accessible and renders at A4 width in Chromium.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::browser;

use abba_report::build_report;
use abba_report::html::trial_page::{cohort_profile, COHORT_BIN_MIN};
use abba_report::results::Week;
use abba_sim::scenario::ScenarioId;
use abba_trial::runner::{run_trial, Silent};
use abba_trial::{ArmKind, TrialConfig};

fn quantile(values: &[f64], p: f64) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let h = (v.len() as f64 - 1.0) * p;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(v.len() - 1);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}

#[test]
fn the_trial_page_shows_pooled_profiles_per_arm() {
    let config = TrialConfig::try_from(abba_trial::protocol::RawTrialConfig {
        patients: 3,
        days: 9,
        scenarios: vec![ScenarioId::S1],
        arms: vec![ArmKind::Standard, ArmKind::R2r],
        ..abba_trial::protocol::RawTrialConfig::default()
    })
    .unwrap();
    let out = run_trial(&config, 2, &Silent).unwrap();
    for arm in &out.arms {
        for p in &arm.patients {
            let w1 = p.week(Week::W1).unwrap();
            assert_eq!(w1.plasma_5min_mg_dl.len(), 7 * 288);
        }
        let c = cohort_profile(arm, Week::W1).unwrap().unwrap();
        assert_eq!(c.n_patients, 3);
        assert_eq!(c.n_samples, 3 * 7 * 288);
        for bin in &c.profile {
            let values: Vec<f64> = arm
                .patients
                .iter()
                .flat_map(|p| {
                    p.week(Week::W1)
                        .unwrap()
                        .plasma_5min_mg_dl
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| {
                            (*i as u32 * 5) % 1440 / COHORT_BIN_MIN * COHORT_BIN_MIN
                                == bin.start_min
                        })
                        .map(|(_, g)| f64::from(*g))
                })
                .collect();
            assert_eq!(values.len(), 3 * 7 * 3);
            let p = bin.p.unwrap();
            for (got, q) in p.iter().zip([0.05, 0.25, 0.5, 0.75, 0.95]) {
                assert!((got - quantile(&values, q)).abs() < 1e-9);
            }
        }
        assert!(
            cohort_profile(arm, Week::W13).unwrap().is_none(),
            "9 days hold no W13"
        );
    }
    let files = build_report(
        &out.arms,
        &serde_json::json!({"tool": "abba", "seed": 1}),
        None,
    )
    .unwrap();
    let page = files.iter().find(|f| f.name == "report.html").unwrap();
    let html = String::from_utf8(page.bytes.clone()).unwrap();
    for arm in &out.arms {
        assert!(html.contains(&format!("{} (cgm mode): cohort glucose profile", arm.key())));
        assert!(html.contains(&format!("{} W1 (D2-D8), 3 patients", arm.key())));
    }
    assert!(html.contains("Table I: ours beside the paper"));
    assert!(html.contains("No run stopped"));
    assert!(!html.to_lowercase().contains("<script"));
    assert_eq!(
        html.matches("<svg").count(),
        html.matches("role=\"img\"").count()
    );
    assert_eq!(
        html.matches("<svg").count(),
        html.matches("<svg").zip(html.matches("<title>")).count()
    );
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("html")
        .join("trial-small");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("report.html");
    std::fs::write(&path, &html).unwrap();
    browser::validate_with_tidy(&path);
    browser::assert_renders_at_a4(&path);
}
