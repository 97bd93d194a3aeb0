//! Turning a [`ScenarioConfig`] and seeds into day plans.
//!
//! Reproducibility: every random quantity of day d is drawn from a ChaCha8
//! generator keyed by its stream seed and set to the ChaCha *stream* d (the
//! 0-based day index), so the plan of a day does not depend on which other
//! days were generated, in which order, or how long the trial is. The skipped
//! meals of 7-day block k come from the meal seed on ChaCha stream
//! 2^32 + k, which no day uses.
//!
//! Draw order (fixed; changing it changes every result):
//! - meals stream, day d: for each meal of the template in order, the time
//!   offset (uniform integer in [-w, w]), then the size (uniform in
//!   [c - j, c + j)), then, for an announced meal, the carb-counting factor
//!   (uniform in [min, max)). The draws are made even for a meal that is
//!   then skipped, so skipping never shifts another meal;
//! - meals stream, block k: the indices of the skipped main meals among the
//!   block's (days × main meals), drawn without replacement;
//! - sensitivity stream, day d: the daily factor (uniform in [min, max)),
//!   drawn on every day so that the factor of a day does not depend on the
//!   configured last day of variability;
//! - SMBG-timing stream, day d: one offset per reading (uniform integer in
//!   [-w, w]) in the order of the main meals, then bedtime, drawn only when
//!   the jitter is non-zero.
//!
//! A draw whose range is a single value (a jitter of 0, equal factor
//! bounds) is not made; the day streams make this harmless.
//!
//! Patients are numbered from 1 in cohort order (adult#001 is 1, the
//! cohort's k-th patient is k + 1 with k 0-based); the `i` column of the
//! parameter table is not a usable number (adult#004 has i = 42).

use super::config::{ScenarioConfig, ScenarioId};
use super::plan::{Dawn, DayPlan, PlannedMeal, SensitivityDay, SmbgPurpose, SmbgReading};
use crate::SimError;
use abba_core::{derive_seed, Grams, Stream};
use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// ChaCha stream numbers from here on are used for the skip blocks.
const BLOCK_STREAM_BASE: u64 = 1 << 32;

/// The seeds of every random stream of one patient in one scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct StreamSeeds {
    /// Meal times, sizes, carb-counting errors and skipped meals.
    pub meals: u64,
    /// Daily insulin-sensitivity factors.
    pub sensitivity: u64,
    /// SMBG measurement-time jitter.
    pub smbg_timing: u64,
    /// CGM sensor noise (used by the trial's CGM).
    pub cgm_noise: u64,
    /// SMBG meter error (used by the trial's meter).
    pub meter_noise: u64,
}

impl StreamSeeds {
    /// Seeds from `derive_seed(trial_seed, patient, random_key, stream)`.
    ///
    /// `patient` is the patient's number in its cohort (adult#001 is 1);
    /// `random_key` is [`ScenarioConfig::random_key`].
    pub fn derive(trial_seed: u64, patient: u64, random_key: u64) -> Self {
        let s = |stream| derive_seed(trial_seed, patient, random_key, stream);
        Self {
            meals: s(Stream::Meals),
            sensitivity: s(Stream::Sensitivity),
            smbg_timing: s(Stream::SmbgTiming),
            cgm_noise: s(Stream::CgmNoise),
            meter_noise: s(Stream::MeterNoise),
        }
    }
}

/// Generates the day plans of one patient in one scenario.
#[derive(Debug, Clone)]
pub struct ScenarioGenerator {
    config: ScenarioConfig,
    seeds: StreamSeeds,
}

/// The stream index of the sensitivity drift's phase (days use 0..days).
const DRIFT_PHASE_STREAM: u64 = u64::MAX;

fn day_rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

fn int_offset(rng: &mut ChaCha8Rng, half_width: u32) -> i64 {
    let w = i64::from(half_width);
    rng.gen_range(-w..=w)
}

impl ScenarioGenerator {
    /// A generator for patient number `patient` (adult#001 is 1) of a trial
    /// with seed `trial_seed`; validates the configuration.
    pub fn new(config: ScenarioConfig, trial_seed: u64, patient: u64) -> Result<Self, SimError> {
        let seeds = StreamSeeds::derive(trial_seed, patient, config.random_key);
        Self::with_seeds(config, seeds)
    }

    /// One of the paper's scenarios with default values.
    pub fn paper(id: ScenarioId, trial_seed: u64, patient: u64) -> Result<Self, SimError> {
        Self::new(ScenarioConfig::paper(id), trial_seed, patient)
    }

    /// A generator with explicit stream seeds; validates the configuration.
    pub fn with_seeds(config: ScenarioConfig, seeds: StreamSeeds) -> Result<Self, SimError> {
        config.validate()?;
        Ok(Self { config, seeds })
    }

    /// The configuration.
    pub fn config(&self) -> &ScenarioConfig {
        &self.config
    }

    /// The stream seeds (CGM and meter noise seeds are for the devices).
    pub fn seeds(&self) -> &StreamSeeds {
        &self.seeds
    }

    /// Number of days of the trial.
    pub fn days(&self) -> u32 {
        self.config.days
    }

    /// The plan of day `day_index` (0-based). Days past the configured
    /// length are generated with the same rules (they are simply not part of
    /// the trial).
    pub fn day(&self, day_index: u32) -> DayPlan {
        let cfg = &self.config;
        let day_number = day_index + 1;
        let skipped = self.skipped_in_day(day_index);

        let mut rng = day_rng(self.seeds.meals, u64::from(day_index));
        let mut meals = Vec::with_capacity(cfg.meals.meals.len());
        let mut main_k = 0usize;
        for t in &cfg.meals.meals {
            let offset = int_offset(&mut rng, t.time_jitter_min);
            let j = t.size_jitter.0;
            let carbs = if j > 0.0 {
                t.carbs.0 + rng.gen_range(-j..j)
            } else {
                t.carbs.0
            };
            let factor = if t.announced {
                let (lo, hi) = (cfg.meals.announce_factor_min, cfg.meals.announce_factor_max);
                Some(if hi > lo { rng.gen_range(lo..hi) } else { lo })
            } else {
                None
            };
            let is_skipped = match t.slot.main_index() {
                Some(_) => {
                    let s = skipped.get(main_k).copied().unwrap_or(false);
                    main_k += 1;
                    s
                }
                None => false,
            };
            let minute = i64::from(t.minute_of_day) + offset;
            meals.push(PlannedMeal {
                slot: t.slot,
                at: abba_core::Timestamp::from_day_and_minute(i64::from(day_index), minute),
                carbs: Grams(carbs),
                announced: if is_skipped {
                    None
                } else {
                    factor.map(|f| Grams(carbs * f))
                },
                skipped: is_skipped,
            });
        }

        let sensitivity = self.sensitivity_day(day_index);

        let mut smbg = Vec::new();
        if let Some(b) = cfg.smbg.as_ref().filter(|b| day_number >= b.from_day) {
            let mut rng = day_rng(self.seeds.smbg_timing, u64::from(day_index));
            let mut jitter = || {
                if b.jitter_min > 0 {
                    int_offset(&mut rng, b.jitter_min)
                } else {
                    0
                }
            };
            for m in meals.iter().filter(|m| m.slot.main_index().is_some()) {
                let at = m.at.plus(-i64::from(b.before_meal_min) + jitter());
                smbg.push(SmbgReading {
                    at,
                    purpose: SmbgPurpose::BeforeMeal(m.slot),
                });
            }
            let at = abba_core::Timestamp::from_day_and_minute(
                i64::from(day_index),
                i64::from(b.bedtime_min) + jitter(),
            );
            smbg.push(SmbgReading {
                at,
                purpose: SmbgPurpose::Bedtime,
            });
            smbg.sort_by_key(|r| r.at);
        }

        let cgm_worn = cfg.cgm.until_day.is_none_or(|last| day_number <= last);

        DayPlan {
            day_index,
            meals,
            sensitivity,
            smbg,
            cgm_worn,
        }
    }

    /// The plans of all the trial's days, in order.
    pub fn all_days(&self) -> Vec<DayPlan> {
        (0..self.config.days).map(|d| self.day(d)).collect()
    }

    /// The insulin-sensitivity profile of day `day_index` (0-based) alone,
    /// without generating the rest of the plan.
    pub fn sensitivity_day(&self, day_index: u32) -> SensitivityDay {
        let s = &self.config.sensitivity;
        let mut rng = day_rng(self.seeds.sensitivity, u64::from(day_index));
        let factor = if s.daily_factor_max > s.daily_factor_min {
            rng.gen_range(s.daily_factor_min..s.daily_factor_max)
        } else {
            s.daily_factor_min
        };
        let drift = self.drift_factor(day_index);
        if day_index < s.variable_until_day {
            SensitivityDay {
                daily_factor: factor * drift,
                dawn: Some(Dawn {
                    factor: s.dawn_factor,
                    start_min: s.dawn_start_min,
                    end_min: s.dawn_end_min,
                    ramp_min: s.dawn_ramp_min,
                }),
            }
        } else {
            SensitivityDay {
                daily_factor: drift,
                dawn: None,
            }
        }
    }

    /// The slow drift's factor on day `day_index` (0-based); 1 without a
    /// drift or before it starts. The phase comes from the sensitivity
    /// stream under a stream index no day uses.
    fn drift_factor(&self, day_index: u32) -> f64 {
        let Some(d) = self.config.sensitivity.drift else {
            return 1.0;
        };
        let day = day_index + 1;
        if day < d.from_day {
            return 1.0;
        }
        let phase = day_rng(self.seeds.sensitivity, DRIFT_PHASE_STREAM)
            .gen_range(0.0..std::f64::consts::TAU);
        let t = f64::from(day - d.from_day) / f64::from(d.period_days);
        1.0 + d.amplitude * (std::f64::consts::TAU * t + phase).sin()
    }

    /// For day `day_index`, whether each main meal (in template order) is skipped.
    fn skipped_in_day(&self, day_index: u32) -> Vec<bool> {
        let mains = self
            .config
            .meals
            .meals
            .iter()
            .filter(|t| t.slot.main_index().is_some())
            .count();
        let mut out = vec![false; mains];
        let Some(s) = &self.config.skip else {
            return out;
        };
        if day_index + 1 < s.from_day || s.per_block == 0 || mains == 0 {
            return out;
        }
        let block = day_index / s.block_days;
        let day_in_block = (day_index % s.block_days) as usize;
        let total = mains * s.block_days as usize;
        let mut rng = day_rng(self.seeds.meals, BLOCK_STREAM_BASE + u64::from(block));
        for k in sample(&mut rng, total, s.per_block as usize).iter() {
            if k / mains == day_in_block {
                out[k % mains] = true;
            }
        }
        out
    }
}
