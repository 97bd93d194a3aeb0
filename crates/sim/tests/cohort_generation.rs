//! The three default cohorts (300 patients): exact steady states,
//! plausibility, standard therapy, determinism, the CSV table.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_sim::cohort::derive::{steady_state_residual, PRIMARY};
use abba_sim::cohort::{
    check_patient, read_csv, therapy, CarbRatioSource, Cohort, CohortConfig, Origin, Population,
    MAX_COHORT_SIZE,
};
use abba_sim::patient::{Patient, PatientParams, QuestRow};
use std::sync::OnceLock;

const SEED: u64 = 1;

fn cohorts() -> &'static Vec<Cohort> {
    static C: OnceLock<Vec<Cohort>> = OnceLock::new();
    C.get_or_init(|| {
        Population::ALL
            .iter()
            .map(|&p| Cohort::generate(&CohortConfig::new(p, 100, SEED)).unwrap())
            .collect()
    })
}

#[test]
fn every_patient_of_every_cohort_starts_at_an_exact_steady_state_and_is_plausible() {
    let mut n = 0;
    for c in cohorts() {
        assert_eq!(c.patients.len(), 100);
        for (k, vp) in c.patients.iter().enumerate() {
            let p = &vp.params;
            assert_eq!(p.name, c.config.population.patient_name(k as u32 + 1));
            let max = steady_state_residual(p)
                .iter()
                .fold(0.0f64, |m, v| m.max(v.abs()));
            assert!(max < 1e-9, "{}: max |dx/dt| = {max:e}", p.name);
            // And the model really stays put for a day at the exact basal rate.
            let mut pat = Patient::new(p.clone()).unwrap();
            let g0 = pat.glucose_mg_dl();
            for _ in 0..1440 {
                pat.step(0.0, p.basal_u_per_min(), 1.0).unwrap();
            }
            let drift = (pat.glucose_mg_dl() - g0).abs();
            assert!(
                drift < 1e-6,
                "{}: glucose drifted by {drift:e} mg/dL in a day",
                p.name
            );
            // The plausibility checks pass with the patient's own carb ratio.
            let checks = check_patient(p, vp.therapy.carb_ratio[0].0, &c.config)
                .unwrap_or_else(|f| panic!("{}: {} ({})", p.name, f.reason, f.detail));
            assert_eq!(checks, vp.checks);
            let lim = &c.config.limits;
            assert!(p.gb >= lim.basal_glucose_mg_dl[0] && p.gb <= lim.basal_glucose_mg_dl[1]);
            let d = &checks.standard_day;
            assert!(
                d.min_mg_dl >= lim.standard_day_mg_dl[0]
                    && d.max_mg_dl <= lim.standard_day_mg_dl[1]
            );
            n += 1;
        }
    }
    assert_eq!(n, 300);
}

#[test]
fn the_first_ten_are_the_public_patients_unchanged_with_quest_ratios() {
    for c in cohorts() {
        let prefix = format!("{}#", c.config.population.prefix());
        let public: Vec<_> = PatientParams::all_public()
            .unwrap()
            .into_iter()
            .filter(|p| p.name.starts_with(&prefix))
            .collect();
        assert_eq!(public.len(), 10);
        for (vp, p) in c.patients.iter().zip(&public) {
            assert_eq!(&vp.params, p, "public patient changed");
            assert_eq!(vp.origin, Origin::Public);
            assert_eq!(vp.carb_ratio_source, CarbRatioSource::Quest);
            let q = QuestRow::for_patient(&p.name).unwrap();
            assert_eq!(vp.therapy.carb_ratio.map(|r| r.0), [q.cr; 3]);
        }
        for vp in &c.patients[10..] {
            assert_eq!(vp.carb_ratio_source, CarbRatioSource::Titrated);
            assert_eq!(vp.therapy.carb_ratio[0].0, vp.titration.carb_ratio_g_per_u);
        }
    }
}

#[test]
fn standard_basal_is_the_steady_state_rate_rounded_to_the_pump_increment() {
    for c in cohorts() {
        for vp in &c.patients {
            let exact = vp.params.basal_u_per_min() * 60.0;
            let b = vp.therapy.basal.0;
            let steps = b / 0.05;
            assert!(
                (steps - steps.round()).abs() < 1e-9,
                "{}: {b} not a multiple of 0.05",
                vp.params.name
            );
            assert!(
                (b - exact).abs() <= 0.025 + 1e-12,
                "{}: exact {exact} rounded {b}",
                vp.params.name
            );
            assert_eq!(vp.checks.exact_basal_u_per_h, exact);
        }
    }
}

#[test]
fn generated_patients_mix_two_distinct_public_parents() {
    for c in cohorts() {
        let mut total_rejected = 0u64;
        let mut ws = Vec::new();
        for vp in &c.patients[10..] {
            let Origin::Generated {
                parent_a,
                parent_b,
                w,
                rejected_before,
            } = &vp.origin
            else {
                panic!("{} should be generated", vp.params.name);
            };
            assert_ne!(parent_a, parent_b);
            assert!((0.0..1.0).contains(w));
            ws.push(*w);
            total_rejected += u64::from(*rejected_before);
            let a = PatientParams::public(parent_a).unwrap();
            let b = PatientParams::public(parent_b).unwrap();
            for col in PRIMARY {
                let (va, vb, v) = (
                    a.scalar(col).unwrap(),
                    b.scalar(col).unwrap(),
                    vp.params.scalar(col).unwrap(),
                );
                // log v − (w log a + (1 − w) log b) is the noise ε ~ N(0, 0.1²): within 6 SD.
                let eps = v.ln() - (w * va.ln() + (1.0 - w) * vb.ln());
                assert!(eps.abs() < 0.6, "{} {col}: ε = {eps}", vp.params.name);
            }
            let m30 = 1.5 * vp.params.m1;
            assert!(
                ((vp.params.m30 - m30) / m30).abs() < 1e-12,
                "m30 = 1.5·m1: expected {m30} got {}",
                vp.params.m30
            );
        }
        assert_eq!(
            c.rejections.total, total_rejected,
            "every rejection is counted"
        );
        assert_eq!(
            c.rejections.by_reason.values().sum::<u64>(),
            c.rejections.total
        );
        let mean_w = ws.iter().sum::<f64>() / ws.len() as f64;
        println!(
            "{}: mean w {mean_w:.3}, rejections {:?}",
            c.config.population, c.rejections
        );
        // 90 uniform draws: mean 0.5, SE 0.030.
        assert!((mean_w - 0.5).abs() < 0.12, "mean w {mean_w}");
    }
}

#[test]
fn the_noise_has_the_configured_spread() {
    // Pool ε over all primary parameters of all generated adults: SD 0.1
    // (conditioning on plausibility trims it only slightly).
    let c = &cohorts()[0];
    let mut e = Vec::new();
    for vp in &c.patients[10..] {
        let Origin::Generated {
            parent_a,
            parent_b,
            w,
            ..
        } = &vp.origin
        else {
            unreachable!()
        };
        let a = PatientParams::public(parent_a).unwrap();
        let b = PatientParams::public(parent_b).unwrap();
        for col in PRIMARY {
            let v = vp.params.scalar(col).unwrap();
            e.push(
                v.ln()
                    - (w * a.scalar(col).unwrap().ln() + (1.0 - w) * b.scalar(col).unwrap().ln()),
            );
        }
    }
    let n = e.len() as f64;
    let m = e.iter().sum::<f64>() / n;
    let sd = (e.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    println!("ε over {n} draws: mean {m:.4} (expected 0), sd {sd:.4} (expected 0.1)");
    assert!(m.abs() < 0.01, "mean ε {m}");
    assert!((sd - 0.1).abs() < 0.01, "sd ε {sd}");
}

#[test]
fn same_seed_same_cohort_and_smaller_sizes_are_prefixes() {
    let big = &cohorts()[0];
    let small = Cohort::generate(&CohortConfig::new(Population::Adults, 20, SEED)).unwrap();
    assert_eq!(small.patients.as_slice(), &big.patients[..20]);
    let tiny = Cohort::generate(&CohortConfig::new(Population::Adults, 4, SEED)).unwrap();
    assert_eq!(tiny.patients.as_slice(), &big.patients[..4]);
    let other = Cohort::generate(&CohortConfig::new(Population::Adults, 12, SEED + 1)).unwrap();
    assert_eq!(&other.patients[..10], &big.patients[..10]);
    assert_ne!(other.patients[10].params, big.patients[10].params);
    let mut a = Vec::new();
    let mut b = Vec::new();
    small.write_csv(&mut a).unwrap();
    Cohort::generate(&CohortConfig::new(Population::Adults, 20, SEED))
        .unwrap()
        .write_csv(&mut b)
        .unwrap();
    assert_eq!(a, b, "same seed, same bytes");
}

#[test]
fn the_csv_table_reads_back_exactly() {
    for c in cohorts() {
        let mut buf = Vec::new();
        c.write_csv(&mut buf).unwrap();
        let text = String::from_utf8(buf).unwrap();
        let header = text.lines().next().unwrap();
        assert!(header.starts_with("Name,i,x0_ 1,"), "{header}");
        assert!(header.ends_with("basal_u_per_h,carb_ratio_g_per_u,carb_ratio_source,titrated_carb_ratio_g_per_u,origin,parent_a,parent_b,mix_w"));
        let rows = read_csv("cohort.csv", &text).unwrap();
        assert_eq!(rows.len(), c.patients.len());
        for (r, vp) in rows.iter().zip(&c.patients) {
            assert_eq!(r.params, vp.params);
            assert_eq!(r.therapy, vp.therapy);
            assert_eq!(r.carb_ratio_source, vp.carb_ratio_source);
        }
    }
    let bad = "Name,i\nadult#001,1\n";
    let e = read_csv("bad.csv", bad).unwrap_err().to_string();
    assert!(e.contains("bad.csv") && e.contains("basal_u_per_h"), "{e}");
}

/// Independent re-implementation of the titration test: G(240) − G(0) and
/// the nadir after a 50 g meal bolused with `cr` at minute 0.
fn test_meal(p: &PatientParams, cr: f64) -> (f64, f64) {
    let mut pat = Patient::new(p.clone()).unwrap();
    let g0 = pat.glucose_mg_dl();
    let mut left = 50.0f64;
    let mut nadir = g0;
    for minute in 0..240 {
        let eat = left.min(5.0);
        left -= eat;
        let bolus = if minute == 0 { 50.0 / cr } else { 0.0 };
        pat.step(eat, p.basal_u_per_min() + bolus, 1.0).unwrap();
        nadir = nadir.min(pat.glucose_mg_dl());
    }
    (pat.glucose_mg_dl() - g0, nadir)
}

#[test]
fn titration_meets_its_definition() {
    let rule = therapy::TitrationRule::default();
    assert_eq!(
        (rule.meal_g, rule.horizon_min, rule.nadir_floor_mg_dl),
        (50.0, 240, 70.0)
    );
    for c in cohorts() {
        for vp in c.patients.iter().step_by(7) {
            let t = &vp.titration;
            let name = &vp.params.name;
            let exact = t.exact_g_per_u;
            let (delta, nadir) = test_meal(&vp.params, exact);
            let (delta_lo, nadir_lo) = test_meal(&vp.params, exact * 0.99);
            if t.nadir_limited {
                // The floor binds: at the ratio the nadir is 70, just below it lower.
                assert!((nadir - 70.0).abs() < 1e-3, "{name}: nadir {nadir}");
                assert!(nadir_lo < 70.0 && delta > 0.0, "{name}");
            } else {
                println!(
                    "{name}: exact {exact:.3} g/U, G(4h) − G(0) = {delta:.2e}, nadir {nadir:.1}"
                );
                assert!(delta.abs() < 1e-3, "{name}: G(4h) − G(0) = {delta}");
                assert!(delta_lo < 0.0, "{name}: more insulin must end lower");
                assert!(nadir >= 70.0 && nadir_lo <= nadir, "{name}");
            }
            let r = t.carb_ratio_g_per_u;
            assert_eq!(r, r.round(), "{name}: whole g/U");
            assert!((r - exact).abs() <= 1.0 + 1e-9, "{name}: {r} vs {exact}");
            let (d, n) = test_meal(&vp.params, r);
            assert!(n >= 70.0, "{name}: the clinic value keeps the nadir >= 70");
            assert!(
                (d - t.delta_at_horizon_mg_dl).abs() < 1e-9 && (n - t.nadir_mg_dl).abs() < 1e-9
            );
        }
    }
}

#[test]
fn titration_vs_quest_is_reported() {
    for c in cohorts() {
        let s = c.summary().unwrap();
        let t = &s.titration_vs_quest;
        assert_eq!(t.patients.len(), 10);
        println!(
            "{}: titrated/Quest geometric mean {:.2}, SD log {:?}, r(log) {:?}, within ±20 %: {}/10",
            c.config.population, t.geometric_mean_ratio, t.sd_log_ratio, t.correlation_log, t.within_20_percent
        );
        for r in &t.patients {
            println!(
                "  {:15} Quest {:4} titrated {:4} (exact {:.2})",
                r.name, r.quest_g_per_u, r.titrated_g_per_u, r.titrated_exact_g_per_u
            );
        }
        assert!(
            t.correlation_log.unwrap() > 0.5,
            "titration should rank patients like Quest"
        );
        assert_eq!(s.size, 100);
        assert_eq!(s.public + s.generated, 100);
        let gb = s.parameters.iter().find(|p| p.name == "Gb").unwrap();
        assert!(gb.min >= 120.0 && gb.max <= 170.0 && gb.sd.unwrap() > 0.0);
    }
}

#[test]
fn a_one_patient_cohort_has_no_standard_deviation() {
    let c = Cohort::generate(&CohortConfig::new(Population::Adults, 1, 1)).unwrap();
    let s = c.summary().unwrap();
    assert_eq!(s.titration_vs_quest.sd_log_ratio, None);
    assert_eq!(s.titration_vs_quest.correlation_log, None);
    assert!(s.parameters.iter().all(|p| p.sd.is_none()));
    let two = Cohort::generate(&CohortConfig::new(Population::Adults, 2, 1)).unwrap();
    let t = two.summary().unwrap().titration_vs_quest;
    assert!(t.sd_log_ratio.is_some_and(f64::is_finite));
}

#[test]
fn an_impossible_cohort_size_is_refused_before_any_work() {
    let e = Cohort::generate(&CohortConfig::new(Population::Adults, 100_000_000, 1))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("100000000") && e.contains(&format!("limit of {MAX_COHORT_SIZE}")),
        "{e}"
    );
}

#[test]
fn progress_is_reported_for_every_patient() {
    let mut seen = Vec::new();
    Cohort::generate_with_progress(
        &CohortConfig::new(Population::Children, 12, 3),
        &mut |done, total| seen.push((done, total)),
    )
    .unwrap();
    assert_eq!(seen, (1..=12).map(|d| (d, 12)).collect::<Vec<_>>());
}
