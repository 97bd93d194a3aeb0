//! Property tests: for any valid setting of the scenario knobs, every day
//! plan stays inside the ranges the configuration allows.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use abba_core::Grams;
use abba_sim::scenario::{ScenarioConfig, ScenarioGenerator, ScenarioId, SmbgPurpose};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn plans_respect_every_knob(
        seed in any::<u64>(),
        patient in 1u64..500,
        time_jitter in 0u32..60,
        size_jitter in 0.0f64..20.0,
        f_lo in 0.1f64..1.0,
        f_span in 0.0f64..1.0,
        s_lo in 0.2f64..1.0,
        s_span in 0.0f64..1.0,
        dawn in 0.1f64..1.5,
        ramp in 0u32..100,
        smbg_jitter in 0u32..30,
        per_block in 0u32..10,
        until in 0u32..98,
    ) {
        let mut cfg = ScenarioConfig::paper(ScenarioId::S4);
        for m in &mut cfg.meals.meals {
            m.time_jitter_min = time_jitter;
            m.size_jitter = Grams(size_jitter.min(m.carbs.0 - 1.0));
        }
        cfg.meals.announce_factor_min = f_lo;
        cfg.meals.announce_factor_max = f_lo + f_span;
        cfg.sensitivity.daily_factor_min = s_lo;
        cfg.sensitivity.daily_factor_max = s_lo + s_span;
        cfg.sensitivity.dawn_factor = dawn;
        cfg.sensitivity.dawn_ramp_min = ramp;
        cfg.sensitivity.variable_until_day = until;
        cfg.smbg.as_mut().unwrap().jitter_min = smbg_jitter;
        cfg.skip.as_mut().unwrap().per_block = per_block;
        let gen = ScenarioGenerator::new(cfg.clone(), seed, patient).unwrap();
        let days = gen.all_days();
        for (week, block) in days.chunks(7).enumerate() {
            let skipped: u32 = block.iter().map(|d| d.meals.iter().filter(|m| m.skipped).count() as u32).sum();
            prop_assert_eq!(skipped, per_block, "week {}", week + 1);
        }
        for d in &days {
            for (m, t) in d.meals.iter().zip(&cfg.meals.meals) {
                let off = m.at.minute_of_day() - i64::from(t.minute_of_day);
                prop_assert!(off.unsigned_abs() <= u64::from(time_jitter));
                prop_assert!((m.carbs.0 - t.carbs.0).abs() <= t.size_jitter.0);
                if let Some(a) = m.announced {
                    let r = a.0 / m.carbs.0;
                    prop_assert!(r >= f_lo - 1e-12 && r <= f_lo + f_span + 1e-12);
                }
            }
            let prof = d.sensitivity.per_minute();
            if d.day_number() <= until {
                let f = d.sensitivity.daily_factor;
                prop_assert!(f >= s_lo && f <= s_lo + s_span);
                let (lo, hi) = (f * dawn.min(1.0), f * dawn.max(1.0));
                prop_assert!(prof.iter().all(|&v| v >= lo - 1e-12 && v <= hi + 1e-12));
                prop_assert!((d.sensitivity.at(360.0) - f * dawn).abs() < 1e-12);
            } else {
                prop_assert!(prof.iter().all(|&v| v == 1.0));
            }
            for r in &d.smbg {
                let nominal = match r.purpose {
                    SmbgPurpose::BeforeMeal(slot) => d.meal(slot).unwrap().at.minutes() - 20,
                    SmbgPurpose::Bedtime => d.at(23 * 60).minutes(),
                };
                prop_assert!((r.at.minutes() - nominal).unsigned_abs() <= u64::from(smbg_jitter));
                prop_assert_eq!(r.at.day_index(), i64::from(d.day_index));
            }
        }
    }
}
