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

use abba_core::MgDl;
use abba_sim::devices::cgm::{CgmConfig, CgmSensor};
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

/// One environment.
#[derive(Debug, Clone)]
pub struct MinuteSim {
    config: MinuteEnvConfig,
    patient: Patient,
    queue: EatingQueue,
    cgm: CgmSensor,
    last_cgm: f64,
    start_minute_of_day: u32,
    meal_seed: u64,
    day_meals: (i64, Vec<(u32, f64)>),
}

fn seed_of(seed: u64, stream: u64) -> u64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng.gen()
}

impl MinuteSim {
    /// A new environment, reset with `seed`.
    pub fn new(config: MinuteEnvConfig, seed: u64) -> Result<Self, SimError> {
        let patient = Patient::new(config.params.clone())?;
        let cgm = CgmSensor::new(config.cgm.clone(), 0)?;
        let mut sim = Self {
            config,
            patient,
            queue: EatingQueue::new(),
            cgm,
            last_cgm: 0.0,
            start_minute_of_day: 0,
            meal_seed: 0,
            day_meals: (-1, Vec::new()),
        };
        sim.reset(seed)?;
        Ok(sim)
    }

    /// The configuration.
    pub fn config(&self) -> &MinuteEnvConfig {
        &self.config
    }

    /// Starts a new episode from `seed`; returns the first CGM reading (mg/dL).
    pub fn reset(&mut self, seed: u64) -> Result<f64, SimError> {
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
        self.patient = Patient::new(params)?;
        self.queue = EatingQueue::new();
        self.cgm = CgmSensor::new(self.config.cgm.clone(), seed_of(seed, 2))?;
        self.meal_seed = seed_of(seed, 3);
        self.day_meals = (-1, Vec::new());
        let first = self
            .cgm
            .read(MgDl(self.patient.subcutaneous_glucose_mg_dl()))?;
        self.last_cgm = first.0;
        Ok(first.0)
    }

    /// Minutes since the episode started.
    pub fn minute(&self) -> i64 {
        self.patient.minute()
    }

    /// Time of day now (minutes after midnight).
    pub fn minute_of_day(&self) -> u32 {
        ((i64::from(self.start_minute_of_day) + self.patient.minute()).rem_euclid(1440)) as u32
    }

    /// The patient.
    pub fn patient(&self) -> &Patient {
        &self.patient
    }

    /// The CGM's sample time (minutes per step).
    pub fn sample_time_min(&self) -> u32 {
        self.config.cgm.sample_time_min
    }

    /// Grams announced at the current minute.
    fn meal_now(&mut self) -> f64 {
        let t = self.patient.minute();
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

    /// One step: `basal_u_per_min` and `bolus_u_per_min` (each through the
    /// pump) held for `sample_time` minutes.
    pub fn step(
        &mut self,
        basal_u_per_min: f64,
        bolus_u_per_min: f64,
    ) -> Result<StepOut, SimError> {
        if !(basal_u_per_min.is_finite() && bolus_u_per_min.is_finite()) {
            return Err(SimError::InvalidInput {
                patient: self.config.params.name.clone(),
                minute: self.patient.minute(),
                reason: format!(
                    "action must be finite: basal {basal_u_per_min} U/min, bolus {bolus_u_per_min} U/min"
                ),
            });
        }
        let insulin =
            self.config.pump.deliver(basal_u_per_min) + self.config.pump.deliver(bolus_u_per_min);
        let n = self.sample_time_min();
        let (mut cho, mut bg, mut cgm, mut announced) = (0.0, 0.0, 0.0, 0.0);
        for _ in 0..n {
            let meal = self.meal_now();
            if meal > 0.0 {
                self.queue.add(meal);
                announced += meal;
            }
            let eaten = self.queue.eat_minute();
            self.patient.step(eaten, insulin, 1.0)?;
            let gs = self.patient.subcutaneous_glucose_mg_dl();
            if self.patient.minute() % i64::from(n) == 0 {
                self.last_cgm = self.cgm.read(MgDl(gs))?.0;
            }
            cho += eaten;
            bg += gs;
            cgm += self.last_cgm;
        }
        let k = f64::from(n);
        let bg = bg / k;
        Ok(StepOut {
            cgm_mg_dl: cgm / k,
            bg_mg_dl: bg,
            plasma_mg_dl: self.patient.glucose_mg_dl(),
            cho_g_per_min: cho / k,
            meal_g_per_min: announced / k,
            insulin_u_per_min: insulin,
            done: !(10.0..=600.0).contains(&bg),
        })
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
