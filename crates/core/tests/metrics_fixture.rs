//! Cross-checks of the glucose metrics against the team's iglu fixture and
//! iglu's own example subject (data in `tests/data`, see PROVENANCE.md).
#![allow(clippy::unwrap_used)]

use abba_core::metrics::{
    mage_regular, mage_timed, metrics_regular, metrics_timed, GlucoseMetrics, MageDirection,
    MageOptions,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");

/// Days from 1970-01-01 to a proleptic Gregorian date (Hinnant's algorithm).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// "YYYY-MM-DD HH:MM:SS" to minutes since 1970-01-01 00:00 (wall clock).
fn minutes(ts: &str) -> f64 {
    let n = |r: std::ops::Range<usize>| ts[r].parse::<i64>().unwrap();
    let days = days_from_civil(n(0..4), n(5..7), n(8..10));
    (days * 1440 + n(11..13) * 60 + n(14..16)) as f64 + n(17..19) as f64 / 60.0
}

/// (times in minutes, glucose) from a CSV whose last two columns are time and gl.
fn read(file: &str) -> (Vec<f64>, Vec<f64>) {
    let text = std::fs::read_to_string(format!("{DATA}/{file}")).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|h| h.replace('"', ""))
        .collect();
    assert_eq!(header[header.len() - 2..], ["time", "gl"]);
    let (mut t, mut g) = (Vec::new(), Vec::new());
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        t.push(minutes(f[f.len() - 2]));
        g.push(f[f.len() - 1].parse::<f64>().unwrap());
    }
    (t, g)
}

fn json() -> serde_json::Value {
    let text = std::fs::read_to_string(format!("{DATA}/synthetic_2day_5min.metrics.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn close(name: &str, expected: f64, got: f64, tol: f64) {
    println!("{name:>20}: expected {expected:.10}, got {got:.10}");
    assert!(
        (expected - got).abs() <= tol,
        "{name}: expected {expected}, got {got} (tolerance {tol})"
    );
}

/// Our key → the fixture's value.
fn fixture_values(j: &serde_json::Value) -> Vec<(&'static str, f64)> {
    let iglu = &j["iglu"];
    let bands = &j["independent_numpy"]["seed_bands"];
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    vec![
        ("tir_70_180", f(&iglu["in_range_percent_70_180"])),
        ("hypo_50_70", f(&bands["hypo_50_to_lt70"])),
        ("severe_hypo_lt50", f(&bands["severe_hypo_lt50"])),
        ("hyper_180_300", f(&bands["hyper_gt180_to_300"])),
        ("severe_hyper_gt300", f(&bands["severe_hyper_gt300"])),
        ("lbgi", f(&iglu["lbgi"])),
        ("hbgi", f(&iglu["hbgi"])),
        ("mage", f(&iglu["mage_default"])),
        ("mean_mg_dl", f(&iglu["mean_glu"])),
        ("cv_pct", f(&iglu["cv_glu"])),
        ("gmi_pct", f(&iglu["gmi"])),
        ("below_54", f(&iglu["below_percent"]["below_54"])),
        ("below_70", f(&iglu["below_percent"]["below_70"])),
        ("above_180", f(&iglu["above_percent"]["above_180"])),
        ("above_250", f(&iglu["above_percent"]["above_250"])),
    ]
}

#[test]
fn synthetic_fixture_matches_iglu_for_every_metric() {
    let j = json();
    let (t, g) = read("synthetic_2day_5min.csv");
    assert_eq!(g.len(), 576);
    let m = metrics_timed(&t, &g).unwrap();
    let want = fixture_values(&j);
    assert_eq!(want.len(), abba_core::Metric::GLUCOSE.len());
    for (key, expected) in want {
        close(key, expected, by_key(&m, key).unwrap(), 1e-6);
    }
    close(
        "sd_mg_dl",
        j["iglu"]["sd_glu"].as_f64().unwrap(),
        m.sd_mg_dl,
        1e-6,
    );
}

#[test]
fn synthetic_fixture_matches_iglu_in_every_mage_direction() {
    let j = json();
    let (t, g) = read("synthetic_2day_5min.csv");
    let mage = mage_timed(&t, &g, &MageOptions::default()).unwrap();
    let f = |k: &str| j["iglu"][k].as_f64().unwrap();
    for (name, dir, key) in [
        ("avg", MageDirection::Avg, "mage_default"),
        ("plus", MageDirection::Plus, "mage_ma_plus"),
        ("minus", MageDirection::Minus, "mage_ma_minus"),
        ("max", MageDirection::Max, "mage_ma_max"),
        ("service", MageDirection::Service, "mage_ma_service"),
    ] {
        close(name, f(key), mage.value(dir).unwrap(), 1e-6);
    }
    assert_eq!((mage.segments, mage.segments_with_excursions), (1, 1));
}

#[test]
fn regular_entry_point_agrees_with_the_timed_one() {
    let j = json();
    let (_, g) = read("synthetic_2day_5min.csv");
    let regular = metrics_regular(&g).unwrap();
    let want = fixture_values(&j);
    for (key, expected) in &want {
        if *key != "mage" {
            close(key, *expected, by_key(&regular, key).unwrap(), 1e-6);
        }
    }
    // iglu's grid starts 5 min after midnight, so the reading at 00:00 is not
    // on it: the regular series from the second reading is exactly iglu's grid.
    let mage = mage_regular(&g[1..], &MageOptions::default()).unwrap();
    close(
        "mage (regular)",
        j["iglu"]["mage_default"].as_f64().unwrap(),
        mage.avg.unwrap(),
        1e-6,
    );
    // With the midnight reading the value may move, but only slightly.
    let with_first = regular.mage.unwrap();
    println!("mage of all 576 readings as a regular series: {with_first}");
    assert!((with_first - mage.avg.unwrap()).abs() < 5.0);
}

/// The definitions written out again, as plainly as possible.
fn straightforward(g: &[f64]) -> Vec<(&'static str, f64)> {
    let n = g.len() as f64;
    let pct = |p: &dyn Fn(f64) -> bool| 100.0 * g.iter().filter(|&&x| p(x)).count() as f64 / n;
    let mean = g.iter().sum::<f64>() / n;
    let sd = (g.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let risk = |x: f64| 1.509 * (x.ln().powf(1.084) - 5.381);
    let lbgi = g
        .iter()
        .map(|&x| 10.0 * risk(x).min(0.0).powi(2))
        .sum::<f64>()
        / n;
    let hbgi = g
        .iter()
        .map(|&x| 10.0 * risk(x).max(0.0).powi(2))
        .sum::<f64>()
        / n;
    vec![
        ("tir_70_180", pct(&|x| (70.0..=180.0).contains(&x))),
        ("hypo_50_70", pct(&|x| (50.0..70.0).contains(&x))),
        ("severe_hypo_lt50", pct(&|x| x < 50.0)),
        ("hyper_180_300", pct(&|x| x > 180.0 && x <= 300.0)),
        ("severe_hyper_gt300", pct(&|x| x > 300.0)),
        ("lbgi", lbgi),
        ("hbgi", hbgi),
        ("mean_mg_dl", mean),
        ("cv_pct", 100.0 * sd / mean),
        ("gmi_pct", 3.31 + 0.02392 * mean),
        ("below_54", pct(&|x| x < 54.0)),
        ("below_70", pct(&|x| x < 70.0)),
        ("above_180", pct(&|x| x > 180.0)),
        ("above_250", pct(&|x| x > 250.0)),
    ]
}

#[test]
fn iglu_example_subject_basic_metrics_match_a_direct_recomputation() {
    let (t, g) = read("iglu_example_data_1_subject.csv");
    assert_eq!(g.len(), 2915);
    let m = metrics_timed(&t, &g).unwrap();
    for (key, expected) in straightforward(&g) {
        close(key, expected, by_key(&m, key).unwrap(), 1e-9);
    }
}

fn example_reference() -> serde_json::Value {
    let path = format!("{DATA}/iglu_example_data_1_subject.iglu_python.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn iglu_example_subject_matches_iglu_python() {
    let r = example_reference();
    let f = |k: &str| r["iglu"][k].as_f64().unwrap();
    let (t, g) = read("iglu_example_data_1_subject.csv");
    let m = metrics_timed(&t, &g).unwrap();
    for (key, iglu_key) in [
        ("tir_70_180", "in_range_percent_70_180"),
        ("lbgi", "lbgi"),
        ("hbgi", "hbgi"),
        ("mage", "mage_default"),
        ("mean_mg_dl", "mean_glu"),
        ("cv_pct", "cv_glu"),
        ("gmi_pct", "gmi"),
        ("below_54", "below_54"),
        ("below_70", "below_70"),
        ("above_180", "above_180"),
        ("above_250", "above_250"),
    ] {
        close(key, f(iglu_key), by_key(&m, key).unwrap(), 1e-6);
    }
    close("sd_mg_dl", f("sd_glu"), m.sd_mg_dl, 1e-6);
}

#[test]
fn iglu_example_subject_mage_with_gaps_matches_iglu_python() {
    // This Dexcom trace has 14 gaps over 45 min (not interpolated) and 4 over
    // 180 min, which cut it into 5 segments; one (14:00-14:10 on 12 June) is
    // too short to measure.
    let r = example_reference();
    let (t, g) = read("iglu_example_data_1_subject.csv");
    let mage = mage_timed(&t, &g, &MageOptions::default()).unwrap();
    println!("iglu example subject: {mage:?}");
    assert_eq!((mage.segments, mage.segments_with_excursions), (5, 4));
    let f = |k: &str| r["iglu"][k].as_f64().unwrap();
    close("avg", f("mage_default"), mage.avg.unwrap(), 1e-6);
    close("plus", f("mage_ma_plus"), mage.plus.unwrap(), 1e-6);
    close("minus", f("mage_ma_minus"), mage.minus.unwrap(), 1e-6);
    let d = |k: &str| r["derived_from_segments"][k].as_f64().unwrap();
    close("service", d("mage_ma_service"), mage.service.unwrap(), 1e-6);
    close("max", d("mage_ma_max"), mage.max.unwrap(), 1e-6);
}

/// A metric by its protocol key (the fixtures name metrics by key); an
/// unknown key fails the test.
fn by_key(m: &GlucoseMetrics, key: &str) -> Option<f64> {
    m.get(key.parse().unwrap())
}
