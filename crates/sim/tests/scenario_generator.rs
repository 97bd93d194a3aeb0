//! Statistical and structural tests of the scenario generator (protocol.md §4)
//! over many simulated days.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_core::{MealSlot, MINUTES_PER_DAY};
use abba_sim::scenario::{
    DayPlan, ScenarioConfig, ScenarioGenerator, ScenarioId, SmbgPurpose, DAY_MINUTES,
};

const TRIAL_SEED: u64 = 20_260_101;
const PATIENTS: u64 = 100;

fn days_of(id: ScenarioId) -> Vec<DayPlan> {
    let mut out = Vec::new();
    for p in 1..=PATIENTS {
        out.extend(
            ScenarioGenerator::paper(id, TRIAL_SEED, p)
                .unwrap()
                .all_days(),
        );
    }
    out
}

struct Stats {
    n: f64,
    sum: f64,
    sum2: f64,
    min: f64,
    max: f64,
}

impl Stats {
    fn new() -> Self {
        Self {
            n: 0.0,
            sum: 0.0,
            sum2: 0.0,
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }
    fn push(&mut self, x: f64) {
        self.n += 1.0;
        self.sum += x;
        self.sum2 += x * x;
        self.min = self.min.min(x);
        self.max = self.max.max(x);
    }
    fn mean(&self) -> f64 {
        self.sum / self.n
    }
    fn sd(&self) -> f64 {
        ((self.sum2 - self.sum * self.sum / self.n) / (self.n - 1.0)).sqrt()
    }
    /// Asserts the sample mean is within 4 standard errors of `expected`,
    /// computed from the known SD of the distribution.
    fn assert_mean(&self, what: &str, expected: f64, dist_sd: f64) {
        let se = dist_sd / self.n.sqrt();
        let got = self.mean();
        println!(
            "{what}: n {} mean expected {expected} got {got:.4} (4·SE {:.4}), sd expected {dist_sd:.4} got {:.4}, range [{:.3}, {:.3}]",
            self.n,
            4.0 * se,
            self.sd(),
            self.min,
            self.max
        );
        assert!(
            (got - expected).abs() < 4.0 * se,
            "{what}: mean expected {expected} got {got}"
        );
        assert!(
            (self.sd() - dist_sd).abs() < 0.05 * dist_sd,
            "{what}: sd expected {dist_sd} got {}",
            self.sd()
        );
    }
}

/// Pearson chi-square statistic of counts against equal expected counts.
fn chi_square_uniform(counts: &[u64]) -> f64 {
    let total: u64 = counts.iter().sum();
    let e = total as f64 / counts.len() as f64;
    counts.iter().map(|&c| (c as f64 - e).powi(2) / e).sum()
}

#[test]
fn meal_times_and_sizes_are_uniform_in_their_ranges_with_the_papers_means() {
    let days = days_of(ScenarioId::S1);
    let nominal = [
        (MealSlot::Breakfast, 420, 50.0, 10.0),
        (MealSlot::Lunch, 720, 60.0, 10.0),
        (MealSlot::Dinner, 1110, 80.0, 10.0),
        (MealSlot::Snack, 1380, 15.0, 5.0),
    ];
    for (slot, minute, carbs, half) in nominal {
        let mut size = Stats::new();
        let mut time = Stats::new();
        let mut offsets = [0u64; 31];
        for d in &days {
            let m = d.meal(slot).unwrap();
            assert_eq!(m.at.day_index(), i64::from(d.day_index));
            let off = m.at.minute_of_day() - minute;
            assert!((-15..=15).contains(&off), "{slot:?} offset {off}");
            offsets[(off + 15) as usize] += 1;
            time.push(off as f64);
            assert!(
                m.carbs.0 >= carbs - half && m.carbs.0 < carbs + half,
                "{slot:?} size {} outside [{}, {})",
                m.carbs.0,
                carbs - half,
                carbs + half
            );
            size.push(m.carbs.0);
        }
        // Uniform on [c - h, c + h): SD = 2h/√12.
        size.assert_mean(
            &format!("{slot:?} size (g)"),
            carbs,
            2.0 * half / 12f64.sqrt(),
        );
        // Uniform integer on [-15, 15]: variance (31² - 1)/12 = 80.
        time.assert_mean(&format!("{slot:?} time offset (min)"), 0.0, 80f64.sqrt());
        let chi = chi_square_uniform(&offsets);
        // 30 degrees of freedom: P(chi² > 70) ≈ 5e-5.
        println!("{slot:?} time offsets: chi² = {chi:.1} (df 30, limit 70); counts {offsets:?}");
        assert!(
            offsets.iter().all(|&c| c > 0),
            "every whole-minute offset occurs"
        );
        assert!(chi < 70.0, "{slot:?} time offsets not uniform: chi² {chi}");
    }
}

#[test]
fn announced_carbs_are_actual_times_uniform_half_to_one_and_a_half() {
    let days = days_of(ScenarioId::S2);
    let mut ratio = Stats::new();
    for d in &days {
        for m in &d.meals {
            match m.slot {
                MealSlot::Snack => assert_eq!(m.announced, None, "the snack is never announced"),
                _ => {
                    let a = m.announced.expect("main meals are announced in S2");
                    let r = a.0 / m.carbs.0;
                    assert!((0.5..1.5).contains(&r), "ratio {r}");
                    ratio.push(r);
                }
            }
        }
    }
    ratio.assert_mean("announced / actual", 1.0, 1.0 / 12f64.sqrt());
}

#[test]
fn s4_skips_exactly_two_main_meals_per_week_and_no_other_scenario_skips() {
    for id in [ScenarioId::S1, ScenarioId::S2, ScenarioId::S3] {
        assert!(
            days_of(id)
                .iter()
                .all(|d| d.meals.iter().all(|m| !m.skipped)),
            "{id} skips a meal"
        );
    }
    let mut position = [0u64; 21];
    let mut blocks = 0;
    for p in 1..=PATIENTS {
        let days = ScenarioGenerator::paper(ScenarioId::S4, TRIAL_SEED, p)
            .unwrap()
            .all_days();
        assert_eq!(days.len(), 98);
        for (b, week) in days.chunks(7).enumerate() {
            assert_eq!(week.len(), 7);
            assert_eq!(
                week[0].day_number() as usize,
                7 * b + 1,
                "blocks start on D1, D8, ..."
            );
            let mut skipped = 0;
            for (k, d) in week.iter().enumerate() {
                for m in &d.meals {
                    if m.skipped {
                        assert_ne!(m.slot, MealSlot::Snack, "the snack is never skipped");
                        assert_eq!(m.announced, None, "a skipped meal is not announced");
                        assert_eq!(m.eaten().0, 0.0, "a skipped meal is not eaten");
                        skipped += 1;
                        position[3 * k + m.slot.main_index().unwrap()] += 1;
                    } else {
                        assert_eq!(m.eaten(), m.carbs);
                    }
                }
            }
            assert_eq!(skipped, 2, "patient {p} block {} skipped {skipped}", b + 1);
            blocks += 1;
        }
    }
    // Each of the 21 positions is skipped with probability 2/21.
    let chi = chi_square_uniform(&position);
    println!(
        "skip positions over {blocks} blocks: chi² = {chi:.1} (df 20, limit 52); {position:?}"
    );
    assert!(chi < 52.0, "skip positions not uniform: chi² {chi}");
}

#[test]
fn sensitivity_follows_the_daily_factor_and_dawn_profile_until_day_90() {
    let days = days_of(ScenarioId::S1);
    let mut factor = Stats::new();
    for d in &days {
        let s = &d.sensitivity;
        let prof = s.per_minute();
        assert_eq!(prof.len(), DAY_MINUTES);
        if d.day_number() <= 90 {
            let f = s.daily_factor;
            assert!((0.75..1.25).contains(&f), "daily factor {f}");
            factor.push(f);
            let close = |got: f64, want: f64, what: &str| {
                assert!(
                    (got - want).abs() < 1e-12,
                    "day {} {what}: expected {want} got {got}",
                    d.day_number()
                )
            };
            close(s.at(5.0 * 60.0), 0.5 * f, "s(05:00)");
            close(s.at(10.0 * 60.0), f, "s(10:00)");
            close(s.at(4.0 * 60.0), f, "s(04:00)");
            close(s.at(4.0 * 60.0 + 15.0), 0.75 * f, "s(04:15)");
            close(s.at(4.0 * 60.0 + 30.0), 0.5 * f, "s(04:30)");
            close(s.at(7.0 * 60.0 + 30.0), 0.5 * f, "s(07:30)");
            close(s.at(7.0 * 60.0 + 45.0), 0.75 * f, "s(07:45)");
            close(s.at(8.0 * 60.0), f, "s(08:00)");
            close(prof[5 * 60], 0.5 * f, "minute 05:00");
            close(prof[10 * 60], f, "minute 10:00");
            close(prof[0], f, "minute 00:00");
            close(
                prof[240],
                f * (1.0 - 0.5 * 0.5 / 30.0),
                "minute 04:00 (mean over the minute)",
            );
            // The per-minute value is the mean of the continuous s over the minute.
            for m in [239usize, 240, 255, 269, 270, 449, 450, 465, 479, 480] {
                let steps = 1000;
                let mean: f64 = (0..steps)
                    .map(|k| s.at(m as f64 + (k as f64 + 0.5) / steps as f64))
                    .sum::<f64>()
                    / steps as f64;
                assert!(
                    (prof[m] - mean).abs() < 1e-9,
                    "minute {m}: expected mean {mean} got {}",
                    prof[m]
                );
            }
            assert!(prof.iter().all(|&v| v >= 0.5 * f - 1e-12 && v <= f + 1e-12));
        } else {
            assert_eq!(s.daily_factor, 1.0, "day {}", d.day_number());
            assert!(
                prof.iter().all(|&v| v == 1.0),
                "day {}: s != 1",
                d.day_number()
            );
            assert_eq!(s.at(5.0 * 60.0), 1.0);
        }
    }
    factor.assert_mean("daily sensitivity factor", 1.0, 0.5 / 12f64.sqrt());
}

#[test]
fn smbg_is_20_min_before_meals_and_at_23_jittered_only_in_s3_s4() {
    assert!(
        days_of(ScenarioId::S1).iter().all(|d| d.smbg.is_empty()),
        "S1 has no SMBG"
    );
    for id in [ScenarioId::S2, ScenarioId::S3, ScenarioId::S4] {
        let jittered = id != ScenarioId::S2;
        let mut offsets = [0u64; 21];
        let mut jitter = Stats::new();
        for d in &days_of(id) {
            assert_eq!(d.smbg.len(), 4, "{id} day {}", d.day_number());
            assert!(
                d.smbg.windows(2).all(|w| w[0].at <= w[1].at),
                "in time order"
            );
            for r in &d.smbg {
                assert_eq!(r.at.day_index(), i64::from(d.day_index));
                let nominal = match r.purpose {
                    SmbgPurpose::BeforeMeal(slot) => {
                        // Taken before every main meal, skipped or not.
                        d.meal(slot).unwrap().at.minutes() - 20
                    }
                    SmbgPurpose::Bedtime => i64::from(d.day_index) * MINUTES_PER_DAY + 23 * 60,
                };
                let off = r.at.minutes() - nominal;
                if jittered {
                    assert!((-10..=10).contains(&off), "{id} jitter {off}");
                    offsets[(off + 10) as usize] += 1;
                    jitter.push(off as f64);
                } else {
                    assert_eq!(off, 0, "{id}: no jitter");
                }
            }
            let purposes: Vec<_> = d.smbg.iter().map(|r| r.purpose).collect();
            for slot in MealSlot::MAIN {
                assert!(purposes.contains(&SmbgPurpose::BeforeMeal(slot)));
            }
            assert!(purposes.contains(&SmbgPurpose::Bedtime));
        }
        if jittered {
            // Uniform integer on [-10, 10]: variance (21² - 1)/12.
            jitter.assert_mean(
                &format!("{id} SMBG jitter (min)"),
                0.0,
                (440f64 / 12.0).sqrt(),
            );
            let chi = chi_square_uniform(&offsets);
            println!("{id} SMBG jitter: chi² = {chi:.1} (df 20, limit 52)");
            assert!(chi < 52.0);
        }
    }
}

#[test]
fn cgm_is_worn_days_1_to_8_everywhere_and_throughout_in_s1() {
    for id in ScenarioId::ALL {
        let gen = ScenarioGenerator::paper(id, TRIAL_SEED, 3).unwrap();
        for d in gen.all_days() {
            let expect = id == ScenarioId::S1 || d.day_number() <= 8;
            assert_eq!(d.cgm_worn, expect, "{id} day {}", d.day_number());
            if expect {
                assert!(
                    d.cgm_sample_at(0, 5) && d.cgm_sample_at(1435, 5) && !d.cgm_sample_at(7, 5)
                );
            } else {
                assert!(!d.cgm_sample_at(0, 5));
            }
        }
    }
}

#[test]
fn a_day_plan_depends_only_on_seeds_and_day_index() {
    let gen = ScenarioGenerator::paper(ScenarioId::S4, 7, 12).unwrap();
    let all = gen.all_days();
    // Any order, any subset, a fresh generator: the same plans.
    let again = ScenarioGenerator::paper(ScenarioId::S4, 7, 12).unwrap();
    for d in (0..98u32).rev() {
        assert_eq!(again.day(d), all[d as usize]);
    }
    // A shorter trial has the same first days.
    let mut cfg = ScenarioConfig::paper(ScenarioId::S4);
    cfg.days = 10;
    let short = ScenarioGenerator::new(cfg, 7, 12).unwrap().all_days();
    assert_eq!(short.as_slice(), &all[..10]);
    // Another patient, another trial seed: different days.
    let other = ScenarioGenerator::paper(ScenarioId::S4, 7, 13)
        .unwrap()
        .day(5);
    assert_ne!(other.meals, all[5].meals);
    let other = ScenarioGenerator::paper(ScenarioId::S4, 8, 12)
        .unwrap()
        .day(5);
    assert_ne!(other.meals, all[5].meals);
}

#[test]
fn paper_scenarios_share_their_days_except_for_what_the_protocol_changes() {
    for p in [1u64, 50] {
        let g: Vec<_> = ScenarioId::ALL
            .iter()
            .map(|&id| ScenarioGenerator::paper(id, TRIAL_SEED, p).unwrap())
            .collect();
        for d in 0..98 {
            let [s1, s2, s3, s4] = [0, 1, 2, 3].map(|k| g[k].day(d));
            assert_eq!(s1.meals, s2.meals);
            assert_eq!(s2.meals, s3.meals);
            assert_eq!(s1.sensitivity, s4.sensitivity);
            for (a, b) in s3.meals.iter().zip(&s4.meals) {
                assert_eq!((a.slot, a.at, a.carbs), (b.slot, b.at, b.carbs));
                if !b.skipped {
                    assert_eq!(a.announced, b.announced);
                }
            }
            assert_eq!(s3.smbg, s4.smbg, "S3 and S4 share the SMBG jitter");
        }
        assert_eq!(g[0].seeds(), g[3].seeds());
    }
    // A distinct random key gives an independent realisation.
    let mut cfg = ScenarioConfig::paper(ScenarioId::S2);
    cfg.random_key = 2;
    let a = ScenarioGenerator::new(cfg, TRIAL_SEED, 1).unwrap().day(3);
    let b = ScenarioGenerator::paper(ScenarioId::S2, TRIAL_SEED, 1)
        .unwrap()
        .day(3);
    assert_ne!(a.meals, b.meals);
}

#[test]
fn every_number_of_the_protocol_is_a_knob() {
    let mut cfg = ScenarioConfig::paper(ScenarioId::S4);
    cfg.meals.meals[1].carbs = abba_core::Grams(100.0);
    cfg.meals.meals[1].size_jitter = abba_core::Grams(0.0);
    cfg.meals.meals[1].time_jitter_min = 0;
    cfg.meals.announce_factor_min = 1.0;
    cfg.meals.announce_factor_max = 1.0;
    cfg.skip.as_mut().unwrap().per_block = 0;
    cfg.sensitivity.variable_until_day = 10;
    cfg.sensitivity.dawn_factor = 0.8;
    cfg.smbg.as_mut().unwrap().before_meal_min = 30;
    cfg.smbg.as_mut().unwrap().jitter_min = 0;
    let gen = ScenarioGenerator::new(cfg, 1, 1).unwrap();
    for d in gen.all_days() {
        let lunch = d.meal(MealSlot::Lunch).unwrap();
        assert_eq!(lunch.carbs.0, 100.0);
        assert_eq!(lunch.at.minute_of_day(), 720);
        assert_eq!(lunch.announced, Some(lunch.carbs));
        assert!(d.meals.iter().all(|m| !m.skipped));
        let s5 = d.sensitivity.at(300.0);
        if d.day_number() <= 10 {
            assert!((s5 - 0.8 * d.sensitivity.daily_factor).abs() < 1e-12);
        } else {
            assert_eq!(s5, 1.0);
        }
        let before_lunch = d
            .smbg
            .iter()
            .find(|r| r.purpose == SmbgPurpose::BeforeMeal(MealSlot::Lunch))
            .unwrap();
        assert_eq!(before_lunch.at.minute_of_day(), 690);
    }
}

#[test]
fn invalid_configurations_are_rejected_naming_the_field() {
    let check = |f: &dyn Fn(&mut ScenarioConfig), field: &str| {
        let mut cfg = ScenarioConfig::paper(ScenarioId::S4);
        f(&mut cfg);
        let err = ScenarioGenerator::new(cfg, 1, 1).unwrap_err().to_string();
        println!("{err}");
        assert!(
            err.contains(field),
            "expected the error to name {field}: {err}"
        );
    };
    check(&|c| c.days = 0, "days");
    check(&|c| c.meals.announce_factor_min = -0.1, "announce_factor");
    check(
        &|c| c.meals.meals[0].size_jitter = abba_core::Grams(60.0),
        "meals.meals[0] (breakfast)",
    );
    check(
        &|c| c.meals.meals[3].minute_of_day = 1430,
        "meals.meals[3] (snack)",
    );
    check(
        &|c| c.meals.meals[3].announced = true,
        "meals.meals[3] (snack)",
    );
    check(&|c| c.meals.meals.swap(0, 1), "meals.meals[1]");
    check(&|c| c.skip.as_mut().unwrap().from_day = 9, "skip.from_day");
    check(
        &|c| c.skip.as_mut().unwrap().per_block = 22,
        "skip.per_block",
    );
    check(
        &|c| c.sensitivity.daily_factor_max = 0.5,
        "sensitivity.daily_factor",
    );
    check(&|c| c.sensitivity.dawn_ramp_min = 200, "sensitivity.dawn");
    check(
        &|c| c.smbg.as_mut().unwrap().bedtime_min = 1435,
        "smbg.bedtime_min",
    );
    check(&|c| c.cgm.until_day = Some(0), "cgm.until_day");
    assert!("s3".parse::<ScenarioId>().unwrap() == ScenarioId::S3);
    assert!("S7".parse::<ScenarioId>().is_err());
}

#[test]
fn skip_blocks_can_start_later() {
    let mut cfg = ScenarioConfig::paper(ScenarioId::S4);
    cfg.skip.as_mut().unwrap().from_day = 15;
    let gen = ScenarioGenerator::new(cfg, 3, 4).unwrap();
    let days = gen.all_days();
    let paper = ScenarioGenerator::paper(ScenarioId::S4, 3, 4)
        .unwrap()
        .all_days();
    for (k, d) in days.iter().enumerate() {
        let n = d.meals.iter().filter(|m| m.skipped).count();
        if k < 14 {
            assert_eq!(n, 0);
        } else {
            // Same blocks, same choice as when skipping starts on day 1.
            assert_eq!(d, &paper[k]);
        }
    }
}
