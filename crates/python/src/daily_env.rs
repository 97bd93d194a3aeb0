//! The daily advisor environment: one step is one simulated day of one of
//! the paper's scenarios (S1-S4) with the trial's devices; the action is the
//! day's therapy (a flat basal rate in U/h and the breakfast, lunch and
//! dinner carb ratios in g/U), the observation what the person's devices
//! recorded that day.
//!
//! Within a day, minute by minute (as in the trial's closed loop): plasma
//! glucose is sampled every 5 min for the reward; the CGM reads at its
//! sample times on days it is worn; the meter reads at the plan's SMBG
//! times; a meal starts (skipped meals are not eaten) and, when announced,
//! is bolused announced carbs / that meal's carb ratio through the pump;
//! the pump delivers, the eating queue yields at most 5 g/min, and the
//! patient advances one minute with that minute's insulin sensitivity s(t).
//! The day stops early when plasma glucose falls below the failure
//! threshold (10 mg/dL, as in the trial).

use abba_core::{MealSlot, MgDl, Timestamp, Units, UnitsPerHour};
use abba_sim::cohort::VirtualPatient;
use abba_sim::devices::cgm::{CgmConfig, CgmSensor};
use abba_sim::devices::meter::{MeterConfig, SmbgMeter};
use abba_sim::devices::pump::{Pump, PumpConfig};
use abba_sim::patient::{EatingQueue, Patient};
use abba_sim::scenario::{ScenarioConfig, ScenarioGenerator, SmbgPurpose};
use abba_sim::SimError;

/// Failure threshold of the trial (mg/dL).
pub const FAILURE_MG_DL: f64 = 10.0;

/// What one day produced.
#[derive(Debug, Clone, PartialEq)]
pub struct DayOut {
    /// 1-based day number.
    pub day: u32,
    /// CGM readings at every sample time of the day (0 where none was taken).
    pub cgm_mg_dl: Vec<f64>,
    /// Meter readings before breakfast, lunch, dinner and at bedtime (0 where none).
    pub smbg_mg_dl: [f64; 4],
    /// Carbohydrate announced for breakfast, lunch, dinner (g; 0 if skipped).
    pub announced_g: [f64; 3],
    /// Carbohydrate eaten over the day, snack included (g).
    pub eaten_g: f64,
    /// Plasma glucose every 5 min (mg/dL; shorter if the day stopped).
    pub plasma_mg_dl: Vec<f64>,
    /// Insulin delivered (U).
    pub insulin_u: f64,
    /// Plasma glucose fell below [`FAILURE_MG_DL`].
    pub failed: bool,
    /// Basal requests and boluses the pump capped at its maximum.
    pub pump_capped: u32,
}

/// One environment: a virtual patient living one scenario day by day.
#[derive(Debug, Clone)]
pub struct DailySim {
    vp: VirtualPatient,
    patient_number: u64,
    scenario: ScenarioConfig,
    generator: ScenarioGenerator,
    patient: Patient,
    queue: EatingQueue,
    pump: Pump,
    cgm: CgmSensor,
    meter: SmbgMeter,
    next_day: u32,
}

impl DailySim {
    /// A new environment for cohort patient `vp` (number `patient_number`
    /// in its cohort, 1-based) in `scenario`, reset with `seed`.
    pub fn new(
        vp: VirtualPatient,
        patient_number: u64,
        scenario: ScenarioConfig,
        seed: u64,
    ) -> Result<Self, SimError> {
        let generator = ScenarioGenerator::new(scenario.clone(), seed, patient_number)?;
        let cgm_config = CgmConfig::protocol()?;
        let mut sim = Self {
            patient: Patient::new(vp.params.clone())?,
            queue: EatingQueue::new(),
            pump: Pump::new(PumpConfig::default(), Timestamp(0))?,
            cgm: CgmSensor::new(cgm_config, generator.seeds().cgm_noise)?,
            meter: SmbgMeter::new(MeterConfig::default(), generator.seeds().meter_noise)?,
            vp,
            patient_number,
            scenario,
            generator,
            next_day: 0,
        };
        sim.reset(seed)?;
        Ok(sim)
    }

    /// The patient.
    pub fn virtual_patient(&self) -> &VirtualPatient {
        &self.vp
    }

    /// Readings per day of the CGM.
    pub fn cgm_per_day(&self) -> usize {
        (1440 / self.cgm.config().sample_time_min) as usize
    }

    /// 0-based index of the next day to simulate.
    pub fn next_day(&self) -> u32 {
        self.next_day
    }

    /// Restarts at D1 with the scenario's streams of `seed`.
    pub fn reset(&mut self, seed: u64) -> Result<(), SimError> {
        self.generator = ScenarioGenerator::new(self.scenario.clone(), seed, self.patient_number)?;
        let seeds = *self.generator.seeds();
        self.patient = Patient::new(self.vp.params.clone())?;
        self.queue = EatingQueue::new();
        self.pump = Pump::new(PumpConfig::default(), Timestamp(0))?;
        self.cgm = CgmSensor::new(self.cgm.config().clone(), seeds.cgm_noise)?;
        self.meter = SmbgMeter::new(MeterConfig::default(), seeds.meter_noise)?;
        self.next_day = 0;
        Ok(())
    }

    /// Simulates the next day with basal `basal_u_per_h` and carb ratios
    /// `carb_ratio_g_per_u` (breakfast, lunch, dinner).
    pub fn day(
        &mut self,
        basal_u_per_h: f64,
        carb_ratio_g_per_u: [f64; 3],
    ) -> Result<DayOut, SimError> {
        let name = || self.vp.params.name.clone();
        if !carb_ratio_g_per_u.iter().all(|c| c.is_finite() && *c > 0.0) {
            return Err(SimError::InvalidInput {
                patient: name(),
                minute: self.patient.minute(),
                reason: format!(
                    "carb ratios must be finite numbers > 0 g/U, got {carb_ratio_g_per_u:?}"
                ),
            });
        }
        let plan = self.generator.day(self.next_day);
        let basal = self.pump.set_basal(UnitsPerHour(basal_u_per_h))?;
        let sensitivity = plan.sensitivity.per_minute();
        let period = self.cgm.config().sample_time_min;
        let mut out = DayOut {
            day: plan.day_number(),
            cgm_mg_dl: vec![0.0; self.cgm_per_day()],
            smbg_mg_dl: [0.0; 4],
            announced_g: [0.0; 3],
            eaten_g: 0.0,
            plasma_mg_dl: Vec::with_capacity(288),
            insulin_u: 0.0,
            failed: false,
            pump_capped: u32::from(basal.capped),
        };
        for m in 0..1440u32 {
            let at = plan.at(m);
            let plasma = self.patient.glucose_mg_dl();
            if m % 5 == 0 {
                out.plasma_mg_dl.push(plasma);
            }
            if plan.cgm_sample_at(m, period) {
                let r = self
                    .cgm
                    .read(MgDl(self.patient.subcutaneous_glucose_mg_dl()))?;
                out.cgm_mg_dl[(m / period) as usize] = r.0;
            }
            for r in plan.smbg.iter().filter(|r| r.at == at) {
                let k = match r.purpose {
                    SmbgPurpose::BeforeMeal(slot) => slot.main_index().unwrap_or(3),
                    SmbgPurpose::Bedtime => 3,
                };
                out.smbg_mg_dl[k] = self.meter.measure(MgDl(plasma))?.0;
            }
            for meal in plan.meals.iter().filter(|x| x.at == at && !x.skipped) {
                self.queue.add(meal.carbs.0);
                out.eaten_g += meal.carbs.0;
                if let (Some(announced), Some(k)) = (meal.announced, meal.slot.main_index()) {
                    out.announced_g[k] = announced.0;
                    let bolus = self
                        .pump
                        .request_bolus(Units(announced.0 / carb_ratio_g_per_u[k]))?;
                    out.pump_capped += u32::from(bolus.capped);
                }
            }
            let insulin = self.pump.insulin_for_minute();
            out.insulin_u += insulin;
            let eaten = self.queue.eat_minute();
            self.patient.step(eaten, insulin, sensitivity[m as usize])?;
            if self.patient.glucose_mg_dl() < FAILURE_MG_DL {
                out.failed = true;
                break;
            }
        }
        self.pump.drain_events().for_each(drop);
        self.next_day += 1;
        Ok(out)
    }
}

/// The meal slots in observation order.
pub const SLOTS: [MealSlot; 3] = MealSlot::MAIN;
