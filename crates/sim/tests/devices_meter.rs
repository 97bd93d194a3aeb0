//! SMBG meter: ISO 15197:2013-like accuracy, rounding, clipping, determinism.
//!
//! Run: `cargo test --release -p abba-sim --test integration devices_meter::`

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_core::MgDl;
use abba_sim::devices::meter::{MeterConfig, SmbgMeter};

/// Standard normal CDF by Simpson's rule on the density (4000 intervals;
/// error far below 1e-12 for |x| < 10).
fn phi(x: f64) -> f64 {
    let n = 4000;
    let h = x / n as f64;
    let f = |t: f64| (-t * t / 2.0).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let mut s = f(0.0) + f(x);
    for i in 1..n {
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i as f64 * h);
    }
    0.5 + s * h / 3.0
}

/// Probability that a reading of true value `g` lands in [lo, hi] (whole
/// numbers): the raw value must lie in [lo − 0.5, hi + 0.5) before rounding.
fn p_reading_in(g: f64, sd: f64, lo: f64, hi: f64) -> f64 {
    phi((hi + 0.5 - g) / sd) - phi((lo - 0.5 - g) / sd)
}

/// Four binomial standard errors (false alarm ~6e-5 per comparison).
fn within_4se(what: &str, expected: f64, got: f64, n: usize) {
    let se = (expected * (1.0 - expected) / n as f64)
        .sqrt()
        .max(1.0 / n as f64);
    println!(
        "{what}: expected {expected:.4}, got {got:.4} (tolerance {:.4})",
        4.0 * se
    );
    assert!(
        (got - expected).abs() <= 4.0 * se,
        "{what}: expected {expected}, got {got}, tolerance {}",
        4.0 * se
    );
}

#[test]
fn accuracy_meets_the_iso_15197_criterion_and_the_model() {
    let n = 40_000;
    let mut meter = SmbgMeter::new(MeterConfig::default(), 314).unwrap();
    for g in [40.0, 70.0, 99.0, 99.6, 100.0, 137.3, 180.0, 250.0, 400.0] {
        let (tol, sd) = if g < 100.0 {
            (15.0, 7.5)
        } else {
            (0.15 * g, 0.075 * g)
        };
        let readings: Vec<f64> = (0..n).map(|_| meter.measure(MgDl(g)).unwrap().0).collect();
        assert!(
            readings.iter().all(|r| r.fract() == 0.0),
            "non-integer reading at {g}"
        );
        let inside = readings.iter().filter(|&&r| (r - g).abs() <= tol).count();
        let got = inside as f64 / n as f64;
        // ISO 15197:2013: at least 95 % within ±15 mg/dL / ±15 %.
        assert!(got >= 0.95, "G = {g}: only {got} within ±{tol}");
        // The model's exact probability, rounding included.
        let expected = p_reading_in(g, sd, (g - tol).ceil(), (g + tol).floor());
        within_4se(
            &format!("G = {g}: fraction within ±{tol:.2}"),
            expected,
            got,
            n,
        );
        // Unbiased, with the stated SD (rounding adds 1/12 mg²/dL² of variance).
        let mean = readings.iter().sum::<f64>() / n as f64;
        let var = readings.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n as f64;
        let expected_sd = (sd * sd + 1.0 / 12.0).sqrt();
        let se_mean = expected_sd / (n as f64).sqrt();
        println!(
            "G = {g}: mean {mean:.3} (SE {se_mean:.3}), SD {:.3} expected {expected_sd:.3}",
            var.sqrt()
        );
        assert!((mean - g).abs() <= 4.0 * se_mean, "G = {g}: mean {mean}");
        // SE of a normal SD estimate: sd / sqrt(2n).
        let se_sd = expected_sd / (2.0 * n as f64).sqrt();
        assert!(
            (var.sqrt() - expected_sd).abs() <= 4.0 * se_sd,
            "G = {g}: SD expected {expected_sd}, got {}",
            var.sqrt()
        );
    }
}

#[test]
fn readings_are_clipped_to_20_and_600() {
    let n = 20_000;
    let mut meter = SmbgMeter::new(MeterConfig::default(), 2).unwrap();
    // G = 5: the reading is 20 when the raw value rounds to 20 or less, i.e.
    // is below 20.5: probability Φ(15.5/7.5).
    let low: Vec<f64> = (0..n)
        .map(|_| meter.measure(MgDl(5.0)).unwrap().0)
        .collect();
    assert!(low.iter().all(|&r| r >= 20.0 && r.fract() == 0.0));
    let at_20 = low.iter().filter(|&&r| r == 20.0).count() as f64 / n as f64;
    within_4se(
        "share of readings at 20 for G = 5",
        phi(15.5 / 7.5),
        at_20,
        n,
    );
    // G = 600: SD 45; the raw value is at or above 599.5 with probability Φ(0.5/45).
    let high: Vec<f64> = (0..n)
        .map(|_| meter.measure(MgDl(600.0)).unwrap().0)
        .collect();
    assert!(high.iter().all(|&r| r <= 600.0 && r.fract() == 0.0));
    let at_600 = high.iter().filter(|&&r| r == 600.0).count() as f64 / n as f64;
    within_4se(
        "share of readings at 600 for G = 600",
        phi(0.5 / 45.0),
        at_600,
        n,
    );
    for _ in 0..100 {
        assert!(meter.measure(MgDl(0.0)).unwrap().0 >= 20.0);
    }
    for _ in 0..100 {
        assert_eq!(meter.measure(MgDl(5000.0)).unwrap().0, 600.0);
    }
}

#[test]
fn rounding_is_to_the_nearest_whole_mg_dl() {
    // With zero SD the reading is the true value rounded (half away from zero).
    let cfg = MeterConfig {
        sd_below_threshold_mg_dl: 0.0,
        sd_fraction_from_threshold: 0.0,
        ..MeterConfig::default()
    };
    let mut meter = SmbgMeter::new(cfg, 1).unwrap();
    for (g, expected) in [
        (99.4, 99.0),
        (99.5, 100.0),
        (120.49, 120.0),
        (120.5, 121.0),
        (19.0, 20.0),
        (650.0, 600.0),
    ] {
        assert_eq!(meter.measure(MgDl(g)).unwrap().0, expected, "G = {g}");
    }
}

#[test]
fn sd_fields_are_configurable() {
    let cfg = MeterConfig {
        sd_below_threshold_mg_dl: 3.0,
        sd_fraction_from_threshold: 0.03,
        ..MeterConfig::default()
    };
    let n = 20_000;
    let mut meter = SmbgMeter::new(cfg, 9).unwrap();
    let r: Vec<f64> = (0..n)
        .map(|_| meter.measure(MgDl(200.0)).unwrap().0)
        .collect();
    let mean = r.iter().sum::<f64>() / n as f64;
    let sd = (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
    let expected = (36.0f64 + 1.0 / 12.0).sqrt();
    let se = expected / (2.0 * n as f64).sqrt();
    println!("SD expected {expected:.3}, got {sd:.3}");
    assert!(
        (sd - expected).abs() <= 4.0 * se,
        "SD expected {expected}, got {sd}"
    );
}

#[test]
fn bad_input_and_config_are_errors() {
    let mut meter = SmbgMeter::new(MeterConfig::default(), 1).unwrap();
    for bad in [-0.1, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let e = meter.measure(MgDl(bad));
        assert!(e.is_err(), "glucose {bad} accepted");
    }
    let e = SmbgMeter::new(
        MeterConfig {
            sd_below_threshold_mg_dl: -1.0,
            ..MeterConfig::default()
        },
        1,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("sd_below_threshold_mg_dl"), "{e}");
}

#[test]
fn same_seed_same_readings() {
    let run = |seed| {
        let mut m = SmbgMeter::new(MeterConfig::default(), seed).unwrap();
        (0..500)
            .map(|i| m.measure(MgDl(60.0 + i as f64)).unwrap().0)
            .collect::<Vec<f64>>()
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
}
