//! The per-CGM-sample environment, step for step what simglucose 0.2.11's
//! `T1DSimGymnaisumEnv` computes (read from its source,
//! `simglucose/simulation/env.py`, `envs/simglucose_gym_env.py`,
//! `actuator/pump.py`, `sensor/cgm.py`):
//!
//! - one step is `sample_time` minutes of the CGM (3 min for its default
//!   Dexcom sensor); the action is a basal rate in **U/min** held over the
//!   step, rounded by the pump to 0.05 pmol/min (= 0.05/6000 U/min, round
//!   half to even) and clipped to [0, max_basal] U/min (Insulet: 30);
//! - every minute: the scenario's meal of that minute goes to the eating
//!   queue (5 g/min), the patient advances one minute, then the CGM reads
//!   subcutaneous glucose when the patient's minute is a multiple of the
//!   sample time and holds its last reading otherwise;
//! - the step reports the means over its minutes of carbohydrate eaten
//!   (g/min), insulin (U/min), subcutaneous glucose ("BG", mg/dL) and the
//!   held CGM reading (the observation, mg/dL);
//! - the episode ends when that mean BG is below 10 or above 600 mg/dL.
//!
//! Differences, on purpose: random numbers come from ChaCha8 seeded by the
//! `reset` seed (so `reset(seed=...)` is honoured; simglucose ignores it),
//! so the random initial glucose, random meals and CGM noise have the same
//! distributions as simglucose's but other draws; and the CGM reads once at
//! reset (simglucose draws twice at t = 0).

use abba_batch::PatientBatch;
use abba_core::MgDl;
use abba_sim::devices::cgm::{CgmConfig, CgmSensor};
use abba_sim::inputs::MinuteRates;
use abba_sim::patient::{EatingQueue, Patient, PatientParams};
use abba_sim::SimError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// simglucose's pump constant: pmol per unit.
const PMOL_PER_U: f64 = 6000.0;

/// What a step produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepOut {
    /// Mean of the held CGM reading over the step (mg/dL): the observation.
    pub cgm_mg_dl: f64,
    /// Mean subcutaneous glucose over the step (mg/dL): simglucose's `bg`.
    pub bg_mg_dl: f64,
    /// Plasma glucose at the end of the step (mg/dL).
    pub plasma_mg_dl: f64,
    /// Mean carbohydrate eaten (g/min).
    pub cho_g_per_min: f64,
    /// Grams of the meals that started in the step divided by its length
    /// (g/min): what simglucose reports as `meal`.
    pub meal_g_per_min: f64,
    /// Mean insulin infused (U/min).
    pub insulin_u_per_min: f64,
    /// The episode ended (mean BG < 10 or > 600 mg/dL).
    pub done: bool,
}

impl StepOut {
    /// The step's arrays as the Python environments return them, in order:
    /// CGM, BG, plasma glucose, meal, carbohydrate eaten, insulin.
    pub fn columns(&self) -> [f64; 6] {
        [
            self.cgm_mg_dl,
            self.bg_mg_dl,
            self.plasma_mg_dl,
            self.meal_g_per_min,
            self.cho_g_per_min,
            self.insulin_u_per_min,
        ]
    }
}

/// The pump of simglucose's environment (a row of its `pump_params.csv`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompatPump {
    /// Increment in pmol/min (0.05).
    pub inc_pmol_per_min: f64,
    /// Largest rate, U/min (Insulet: 30).
    pub max_u_per_min: f64,
}

impl CompatPump {
    /// `amount` (U/min) as the pump delivers it.
    pub fn deliver(&self, amount_u_per_min: f64) -> f64 {
        let steps = (amount_u_per_min * PMOL_PER_U / self.inc_pmol_per_min).round_ties_even();
        (steps * self.inc_pmol_per_min / PMOL_PER_U)
            .min(self.max_u_per_min)
            .max(0.0)
    }
}

/// Where the meals come from.
#[derive(Debug, Clone, PartialEq)]
pub enum Meals {
    /// simglucose's `RandomScenario` distribution, a new day at each midnight.
    Random,
    /// Fixed meals: (minutes after the episode start, grams).
    Custom(Vec<(i64, f64)>),
}

/// How an episode starts.
#[derive(Debug, Clone, PartialEq)]
pub struct MinuteEnvConfig {
    /// The patient.
    pub params: PatientParams,
    /// The CGM (simglucose's default is Dexcom: 3-min samples).
    pub cgm: CgmConfig,
    /// The pump.
    pub pump: CompatPump,
    /// Meals.
    pub meals: Meals,
    /// Draw Gp, Gt, Gs from N(x0, 0.1·x0) as simglucose's env does.
    pub random_init_bg: bool,
    /// A full initial state (x1..x13) instead of x0 (overrides `random_init_bg`).
    pub init_state: Option<[f64; 13]>,
    /// Start time of day (minutes after midnight); `None` draws a whole hour.
    pub start_minute_of_day: Option<u32>,
}

/// Everything of one environment around its patient: the meals, the
/// eating queue, the pump and the CGM. [`MinuteSim`] pairs it with a
/// [`Patient`]; [`MinuteShard`] with a lane of a [`PatientBatch`].
#[derive(Debug, Clone)]
pub struct Surround {
    config: MinuteEnvConfig,
    queue: EatingQueue,
    cgm: CgmSensor,
    last_cgm: f64,
    /// Minutes until the CGM's next sample (it reads at every multiple of
    /// its sample time from minute 0: a countdown, not a division per
    /// minute).
    to_sample: u32,
    /// The last action and what the pump made of it (U/min): most
    /// policies hold a rate for many steps, and the pump's rounding is a
    /// library call.
    last_action: (f64, f64),
    last_delivered: f64,
    start_minute_of_day: u32,
    meal_seed: u64,
    day_meals: (i64, Vec<(u32, f64)>),
    /// The episode minute of the next meal (no meal before it): most
    /// minutes have none, and finding that out is one comparison.
    next_meal: i64,
    /// The step under way: its insulin (U/min) and its sums.
    insulin: f64,
    sums: StepSums,
}

/// Sums over the minutes of a step.
#[derive(Debug, Clone, Copy, Default)]
struct StepSums {
    cho: f64,
    bg: f64,
    cgm: f64,
    announced: f64,
}

fn seed_of(seed: u64, stream: u64) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng.gen()
}

impl Surround {
    /// The surroundings of a new environment and its patient, reset with
    /// `seed`; then [`Surround::first_reading`] of the patient.
    fn new(config: MinuteEnvConfig, seed: u64) -> Result<(Self, Patient), SimError> {
        let cgm = CgmSensor::new(config.cgm.clone(), 0)?;
        let mut s = Self {
            config,
            queue: EatingQueue::new(),
            cgm,
            last_cgm: 0.0,
            to_sample: 0,
            last_action: (f64::NAN, f64::NAN),
            last_delivered: 0.0,
            start_minute_of_day: 0,
            meal_seed: 0,
            day_meals: (-1, Vec::new()),
            next_meal: 0,
            insulin: 0.0,
            sums: StepSums::default(),
        };
        let patient = s.reset(seed)?;
        Ok((s, patient))
    }

    /// The configuration.
    pub fn config(&self) -> &MinuteEnvConfig {
        &self.config
    }

    /// Starts a new episode from `seed`: its patient (at minute 0); the
    /// CGM's first reading comes from [`Surround::first_reading`].
    fn reset(&mut self, seed: u64) -> Result<Patient, SimError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed_of(seed, 1));
        let mut params = self.config.params.clone();
        if let Some(x) = self.config.init_state {
            params.x0 = x;
        } else if self.config.random_init_bg {
            for k in [3, 4, 12] {
                let mean = params.x0[k];
                let z: f64 = rng.sample(StandardNormal);
                params.x0[k] = mean + z * (0.1 * mean).sqrt();
            }
        }
        self.start_minute_of_day = match self.config.start_minute_of_day {
            Some(m) => m % 1440,
            None => rng.gen_range(0..24) * 60,
        };
        let patient = Patient::new(params)?;
        self.queue = EatingQueue::new();
        self.cgm = CgmSensor::new(self.config.cgm.clone(), seed_of(seed, 2))?;
        self.meal_seed = seed_of(seed, 3);
        self.day_meals = (-1, Vec::new());
        self.next_meal = 0;
        Ok(patient)
    }

    /// The CGM's reading at reset, of subcutaneous glucose `gs` (mg/dL).
    fn first_reading(&mut self, gs: f64) -> Result<f64, SimError> {
        let first = self.cgm.read(MgDl(gs))?;
        self.last_cgm = first.0;
        self.to_sample = self.sample_time_min();
        Ok(first.0)
    }

    /// Time of day at `minute` of the episode (minutes after midnight).
    pub fn minute_of_day(&self, minute: i64) -> u32 {
        ((i64::from(self.start_minute_of_day) + minute).rem_euclid(1440)) as u32
    }

    /// The CGM's sample time (minutes per step).
    pub fn sample_time_min(&self) -> u32 {
        self.config.cgm.sample_time_min
    }

    /// Grams announced at minute `t` of the episode (called minute after
    /// minute).
    fn meal_at(&mut self, t: i64) -> f64 {
        if t < self.next_meal {
            return 0.0;
        }
        let grams = self.meals_of_minute(t);
        self.next_meal = self.first_meal_after(t);
        grams
    }

    /// The episode minute of the first meal after minute `t` (for random
    /// meals at most the next midnight, where the next day's are drawn).
    fn first_meal_after(&self, t: i64) -> i64 {
        match &self.config.meals {
            Meals::Custom(list) => list
                .iter()
                .map(|(m, _)| *m)
                .filter(|m| *m > t)
                .min()
                .unwrap_or(i64::MAX),
            Meals::Random => {
                let start = i64::from(self.start_minute_of_day);
                let day = (start + t).div_euclid(1440);
                let tod = (start + t).rem_euclid(1440);
                let next_tod = self
                    .day_meals
                    .1
                    .iter()
                    .map(|(m, _)| i64::from(*m))
                    .filter(|m| *m > tod)
                    .min()
                    .unwrap_or(1440);
                day * 1440 + next_tod - start
            }
        }
    }

    /// Grams announced at minute `t` of the episode, looked up.
    fn meals_of_minute(&mut self, t: i64) -> f64 {
        match &self.config.meals {
            Meals::Custom(list) => list.iter().filter(|(m, _)| *m == t).map(|(_, g)| g).sum(),
            Meals::Random => {
                let clock = i64::from(self.start_minute_of_day) + t;
                let day = clock.div_euclid(1440);
                if self.day_meals.0 != day {
                    self.day_meals = (day, random_day(seed_of(self.meal_seed, day as u64)));
                }
                let tod = clock.rem_euclid(1440) as u32;
                self.day_meals
                    .1
                    .iter()
                    .filter(|(m, _)| *m == tod)
                    .map(|(_, g)| g)
                    .sum()
            }
        }
    }

    /// Starts a step: `basal_u_per_min` and `bolus_u_per_min` through the
    /// pump, held for the step.
    fn begin_step(
        &mut self,
        basal_u_per_min: f64,
        bolus_u_per_min: f64,
        minute: i64,
    ) -> Result<(), SimError> {
        if !(basal_u_per_min.is_finite() && bolus_u_per_min.is_finite()) {
            return Err(SimError::InvalidInput {
                patient: self.config.params.name.clone(),
                minute,
                reason: format!(
                    "action must be finite: basal {basal_u_per_min} U/min, bolus {bolus_u_per_min} U/min"
                ),
            });
        }
        // (NaN never equals, so the first step always asks the pump.)
        if self.last_action != (basal_u_per_min, bolus_u_per_min) {
            self.last_action = (basal_u_per_min, bolus_u_per_min);
            self.last_delivered = self.config.pump.deliver(basal_u_per_min)
                + self.config.pump.deliver(bolus_u_per_min);
        }
        self.insulin = self.last_delivered;
        self.sums = StepSums::default();
        Ok(())
    }

    /// The patient's input for minute `t` of the episode: the meal of the
    /// minute to the eating queue, what is eaten in it, the step's insulin.
    fn minute_input(&mut self, t: i64) -> MinuteRates {
        let meal = self.meal_at(t);
        if meal > 0.0 {
            self.queue.add(meal);
            self.sums.announced += meal;
        }
        let eaten = self.queue.eat_minute();
        self.sums.cho += eaten;
        MinuteRates {
            cho_g_per_min: eaten,
            insulin_u_per_min: self.insulin,
        }
    }

    /// After the patient reached the next minute with subcutaneous glucose
    /// `gs`: the CGM reads at its sample times and holds its reading.
    fn after_minute(&mut self, gs: f64) -> Result<(), SimError> {
        self.to_sample = self.to_sample.saturating_sub(1);
        if self.to_sample == 0 {
            self.last_cgm = self.cgm.read(MgDl(gs))?.0;
            self.to_sample = self.sample_time_min();
        }
        self.sums.bg += gs;
        self.sums.cgm += self.last_cgm;
        Ok(())
    }

    /// What the step produced, plasma glucose `plasma` at its end.
    fn end_step(&self, plasma: f64) -> StepOut {
        let k = f64::from(self.sample_time_min());
        let bg = self.sums.bg / k;
        StepOut {
            cgm_mg_dl: self.sums.cgm / k,
            bg_mg_dl: bg,
            plasma_mg_dl: plasma,
            cho_g_per_min: self.sums.cho / k,
            meal_g_per_min: self.sums.announced / k,
            insulin_u_per_min: self.insulin,
            done: !(10.0..=600.0).contains(&bg),
        }
    }
}

/// One environment: a patient and its surroundings.
#[derive(Debug, Clone)]
pub struct MinuteSim {
    surround: Surround,
    patient: Patient,
}

impl MinuteSim {
    /// A new environment, reset with `seed`.
    pub fn new(config: MinuteEnvConfig, seed: u64) -> Result<Self, SimError> {
        let (mut surround, patient) = Surround::new(config, seed)?;
        surround.first_reading(patient.subcutaneous_glucose_mg_dl())?;
        Ok(Self { surround, patient })
    }

    /// The configuration.
    pub fn config(&self) -> &MinuteEnvConfig {
        self.surround.config()
    }

    /// Starts a new episode from `seed`; returns the first CGM reading (mg/dL).
    pub fn reset(&mut self, seed: u64) -> Result<f64, SimError> {
        self.patient = self.surround.reset(seed)?;
        self.surround
            .first_reading(self.patient.subcutaneous_glucose_mg_dl())
    }

    /// Minutes since the episode started.
    pub fn minute(&self) -> i64 {
        self.patient.minute()
    }

    /// Time of day now (minutes after midnight).
    pub fn minute_of_day(&self) -> u32 {
        self.surround.minute_of_day(self.patient.minute())
    }

    /// The patient.
    pub fn patient(&self) -> &Patient {
        &self.patient
    }

    /// The CGM's sample time (minutes per step).
    pub fn sample_time_min(&self) -> u32 {
        self.surround.sample_time_min()
    }

    /// One step: `basal_u_per_min` and `bolus_u_per_min` (each through the
    /// pump) held for `sample_time` minutes.
    pub fn step(
        &mut self,
        basal_u_per_min: f64,
        bolus_u_per_min: f64,
    ) -> Result<StepOut, SimError> {
        let (s, p) = (&mut self.surround, &mut self.patient);
        s.begin_step(basal_u_per_min, bolus_u_per_min, p.minute())?;
        for _ in 0..s.sample_time_min() {
            let u = s.minute_input(p.minute());
            p.step(u.cho_g_per_min, u.insulin_u_per_min, 1.0)?;
            s.after_minute(p.subcutaneous_glucose_mg_dl())?;
        }
        Ok(s.end_step(p.glucose_mg_dl()))
    }
}

/// Many environments whose patients are the lanes of one
/// [`PatientBatch`], stepped together (one sample time for all). Patient
/// i's glucose is within 1e-9 mg/dL of [`MinuteSim`]'s (the batch's exp of
/// kempt's tanh, within 2 ulp of libm's; `abba-batch`), and does not
/// depend on which environments share the shard (exactly: the batch's
/// "any company" property).
#[derive(Debug, Clone)]
pub struct MinuteShard {
    batch: PatientBatch,
    surrounds: Vec<Surround>,
    rates: Vec<MinuteRates>,
    ones: Vec<f64>,
}

impl MinuteShard {
    /// Environments `configs[i]` reset with `seeds[i]`; returns the shard
    /// and each environment's first CGM reading.
    pub fn new(configs: Vec<MinuteEnvConfig>, seeds: &[u64]) -> Result<(Self, Vec<f64>), SimError> {
        let mut surrounds = Vec::with_capacity(configs.len());
        let mut patients = Vec::with_capacity(configs.len());
        let mut first = Vec::with_capacity(configs.len());
        for (c, seed) in configs.into_iter().zip(seeds) {
            let (mut s, p) = Surround::new(c, *seed)?;
            first.push(s.first_reading(p.subcutaneous_glucose_mg_dl())?);
            surrounds.push(s);
            patients.push(p);
        }
        let n = patients.len();
        Ok((
            Self {
                batch: PatientBatch::new(patients)?,
                surrounds,
                rates: Vec::with_capacity(n),
                ones: vec![1.0; n],
            },
            first,
        ))
    }

    /// Number of environments.
    pub fn len(&self) -> usize {
        self.surrounds.len()
    }

    /// True when the shard has no environment.
    pub fn is_empty(&self) -> bool {
        self.surrounds.is_empty()
    }

    /// Starts environment `i`'s new episode from `seed`; returns its first
    /// CGM reading.
    pub fn reset_one(&mut self, i: usize, seed: u64) -> Result<f64, SimError> {
        let patient = self.surrounds[i].reset(seed)?;
        let gs = patient.subcutaneous_glucose_mg_dl();
        self.batch.replace(i, patient)?;
        self.surrounds[i].first_reading(gs)
    }

    /// Time of day of environment `i` (minutes after midnight).
    pub fn minute_of_day(&self, i: usize) -> u32 {
        self.surrounds[i].minute_of_day(self.batch.minute(i))
    }

    /// One step of every environment (`basal[i]`, `bolus[i]` for
    /// environment i, as [`MinuteSim::step`]).
    ///
    /// Each environment's inputs for the whole step are worked out first
    /// (what is eaten depends on the meals only, never on the patient), so
    /// each minute touches only the lanes and the CGM: one pass over the
    /// environments per step, not three per minute.
    pub fn step(&mut self, basal: &[f64], bolus: &[f64]) -> Result<Vec<StepOut>, SimError> {
        let n = self.len();
        let minutes = self.surrounds.first().map_or(0, Surround::sample_time_min) as usize;
        self.rates.clear();
        self.rates.resize(minutes * n, MinuteRates::default());
        for (i, s) in self.surrounds.iter_mut().enumerate() {
            let start = self.batch.minute(i);
            s.begin_step(basal[i], bolus[i], start)?;
            for m in 0..minutes {
                self.rates[m * n + i] = s.minute_input(start + m as i64);
            }
        }
        for m in 0..minutes {
            self.batch
                .step(&self.rates[m * n..(m + 1) * n], &self.ones[..n])?;
            for (i, s) in self.surrounds.iter_mut().enumerate() {
                s.after_minute(self.batch.subcutaneous_glucose_mg_dl(i))?;
            }
        }
        Ok(self
            .surrounds
            .iter()
            .enumerate()
            .map(|(i, s)| s.end_step(self.batch.glucose_mg_dl(i)))
            .collect())
    }
}

/// One day of simglucose's `RandomScenario`: six possible meals
/// (breakfast, snack, lunch, snack, dinner, snack) with probabilities 0.95,
/// 0.3, 0.95, 0.3, 0.95, 0.3; times from normal distributions truncated to
/// their windows, rounded to the minute; amounts max(round(N(μ, σ)), 0) g.
/// Returns (minute of day, grams).
pub fn random_day(seed: u64) -> Vec<(u32, f64)> {
    const PROB: [f64; 6] = [0.95, 0.3, 0.95, 0.3, 0.95, 0.3];
    const LB_H: [f64; 6] = [5.0, 9.0, 10.0, 14.0, 16.0, 20.0];
    const UB_H: [f64; 6] = [9.0, 10.0, 14.0, 16.0, 20.0, 23.0];
    const MU_H: [f64; 6] = [7.0, 9.5, 12.0, 15.0, 18.0, 21.5];
    const SD_MIN: [f64; 6] = [60.0, 30.0, 60.0, 30.0, 60.0, 30.0];
    const AMOUNT_MU: [f64; 6] = [45.0, 10.0, 70.0, 10.0, 80.0, 10.0];
    const AMOUNT_SD: [f64; 6] = [10.0, 5.0, 10.0, 5.0, 10.0, 5.0];
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    for k in 0..6 {
        if rng.gen::<f64>() < PROB[k] {
            let (lb, ub, mu) = (LB_H[k] * 60.0, UB_H[k] * 60.0, MU_H[k] * 60.0);
            let t = loop {
                let z: f64 = rng.sample(StandardNormal);
                let t = mu + SD_MIN[k] * z;
                if (lb..=ub).contains(&t) {
                    break t;
                }
            };
            let z: f64 = rng.sample(StandardNormal);
            let grams = (AMOUNT_MU[k] + AMOUNT_SD[k] * z).round().max(0.0);
            out.push((t.round() as u32, grams));
        }
    }
    out
}
