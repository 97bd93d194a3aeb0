//! One patient in one arm of one scenario, minute by minute
//! (`spec/architecture.md`, "The closed loop").
//!
//! Per minute: the scenario says what the person does; readings are taken
//! from the state at the start of the minute (CGM from subcutaneous glucose,
//! the meter from plasma glucose); a meal is announced to the advisor,
//! which may update that meal's carb ratio; the person boluses announced
//! carbs / carb ratio; the pump quantises and delivers; the patient model
//! advances one minute. Device events go to the advisor from D2 on, and its
//! answers change the pump's basal rate and the next boluses. Plasma glucose
//! is sampled every 5 min for evaluation only and never shown to the
//! advisor.

use crate::error::TrialError;
use crate::protocol::{ArmKind, TrialConfig};
use crate::results::{evaluation_windows, PatientResult, RunFailure, Week, WeekResult};
use abba_advisor::any::{AdvisorSpec, AnyAdvisor};
use abba_advisor::{Advisor, Mode};
use abba_core::metrics::metrics_regular;
use abba_core::{
    derive_seed, Event, EventKind, MgDl, Stream, TherapySettings, Timestamp, Units, UnitsPerHour,
    MINUTES_PER_DAY,
};
use abba_sim::cohort::VirtualPatient;
use abba_sim::devices::cgm::{CgmConfig, CgmSensor};
use abba_sim::devices::meter::{MeterConfig, SmbgMeter};
use abba_sim::devices::pump::{Pump, PumpConfig};
use abba_sim::patient::{EatingQueue, Patient};
use abba_sim::scenario::{ScenarioConfig, ScenarioGenerator, SmbgPurpose};

/// Minutes between evaluation samples of plasma glucose.
pub const EVAL_PERIOD_MIN: usize = 5;
const SAMPLES_PER_DAY: usize = MINUTES_PER_DAY as usize / EVAL_PERIOD_MIN;

/// Builds the advisor of an arm for one scenario.
pub fn advisor_spec(config: &TrialConfig, arm: ArmKind, mode: Mode) -> AdvisorSpec {
    match arm {
        ArmKind::Abba => {
            let mut c = config.abba.clone();
            c.mode = mode;
            c.init_days = config.init_days;
            if let (Mode::Smbg, Some(te_ref)) = (mode, config.te_ref_bits_smbg) {
                c.te.te_ref_bits = te_ref;
            }
            AdvisorSpec::Abba(c)
        }
        ArmKind::Standard => AdvisorSpec::Fixed {
            limits: config.fixed_limits.clone(),
        },
        ArmKind::R2r => {
            let mut c = config.r2r.clone();
            c.mode = mode;
            c.init_days = config.init_days;
            AdvisorSpec::RunToRun(c)
        }
    }
}

/// The device models of the trial.
pub fn devices(config: &TrialConfig) -> Result<(CgmConfig, MeterConfig, PumpConfig), TrialError> {
    let d = &config.devices;
    let sim = |source| TrialError::Sim {
        context: "device configuration".into(),
        source,
    };
    let cgm = CgmConfig::from_table(&d.cgm_model)
        .and_then(|c| c.with_sample_time(d.cgm_sample_time_min))
        .map_err(sim)?;
    let meter = MeterConfig {
        sd_below_threshold_mg_dl: d.meter_sd_below_mg_dl,
        sd_fraction_from_threshold: d.meter_sd_fraction_above,
        ..MeterConfig::default()
    };
    meter.validate().map_err(sim)?;
    let pump = PumpConfig {
        bolus_increment_u: d.pump_bolus_step_u,
        basal_increment_u_per_h: d.pump_basal_step_u_per_h,
        max_bolus_u: d.pump_max_bolus_u,
        max_basal_u_per_h: d.pump_max_basal_u_per_h,
        bolus_speed_u_per_min: d.pump_bolus_speed_u_per_min,
        ..PumpConfig::default()
    };
    pump.validate().map_err(sim)?;
    Ok((cgm, meter, pump))
}

/// Runs one patient (number `patient_no` in its cohort, 1-based) through
/// one scenario in one arm.
pub fn run_patient(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &ScenarioConfig,
    arm: ArmKind,
) -> Result<PatientResult, TrialError> {
    run_patient_with(config, vp, patient_no, scenario, arm, &mut Trace::default())
}

/// What a run can record beside its result.
#[derive(Debug, Default)]
pub struct Trace {
    /// Every event fed to the advisor (used to calibrate the TE reference
    /// from the standard-therapy week).
    pub events: Option<Vec<Event>>,
    /// Every decision of the advisor with its explanation.
    pub decisions: Option<Vec<abba_advisor::decision::Decision>>,
    /// One record per simulated minute (a 1-minute trace; about 140,000
    /// records for a 98-day run, so only on request).
    pub minutes: Option<Vec<MinuteRecord>>,
    /// Filled at the end of every run of an ABBA arm that got past its
    /// initialisation week: what the transfer-entropy initialisation did.
    pub init: Option<abba_advisor::abba::InitReport>,
}

/// What happened in one simulated minute (for a 1-minute trace).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MinuteRecord {
    /// Minutes since 00:00 of D1.
    pub minute: i64,
    /// Plasma glucose at the start of the minute (mg/dL).
    pub plasma_mg_dl: f64,
    /// Subcutaneous glucose at the start of the minute (mg/dL).
    pub subcutaneous_mg_dl: f64,
    /// CGM reading taken this minute, if any (mg/dL).
    pub cgm_mg_dl: Option<f64>,
    /// Finger-stick reading taken this minute, if any (mg/dL).
    pub smbg_mg_dl: Option<f64>,
    /// Carbohydrate eaten during the minute (g/min).
    pub cho_g_per_min: f64,
    /// Insulin infused during the minute, basal plus bolus (U/min).
    pub insulin_u_per_min: f64,
    /// Insulin-sensitivity multiplier s(t) during the minute.
    pub sensitivity: f64,
    /// Basal rate in force on the pump (U/h).
    pub basal_u_per_h: f64,
    /// The advisor's carb ratios (breakfast, lunch, dinner; g/U).
    pub carb_ratio_g_per_u: [f64; 3],
}

/// Like [`run_patient`], recording what `trace` asks for.
pub fn run_patient_with(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &ScenarioConfig,
    arm: ArmKind,
    trace: &mut Trace,
) -> Result<PatientResult, TrialError> {
    let mut record = trace.events.as_mut();
    let context = format!("{} {}/{}", vp.params.name, scenario.name, arm.name());
    let sim = |source| TrialError::Sim {
        context: context.clone(),
        source,
    };
    let adv = |source| TrialError::Advisor {
        context: context.clone(),
        source,
    };

    let mode = TrialConfig::mode_for(scenario);
    let generator =
        ScenarioGenerator::new(scenario.clone(), config.seed, patient_no).map_err(sim)?;
    let seeds = *generator.seeds();
    let (cgm_cfg, meter_cfg, pump_cfg) = devices(config)?;
    let mut cgm = CgmSensor::new(cgm_cfg, seeds.cgm_noise).map_err(sim)?;
    let mut meter = SmbgMeter::new(meter_cfg, seeds.meter_noise).map_err(sim)?;
    let pump = Pump::new(pump_cfg, Timestamp(0)).map_err(sim)?;
    let mut patient = Patient::new(vp.params.clone()).map_err(sim)?;
    let mut queue = EatingQueue::new();
    let start: TherapySettings = vp.therapy;
    let exploration = derive_seed(
        config.seed,
        patient_no,
        scenario.random_key,
        Stream::Exploration,
    );
    let advisor: AnyAdvisor = advisor_spec(config, arm, mode)
        .build(start, exploration)
        .map_err(adv)?;
    let mut ctl = Controls {
        advisor,
        pump,
        requested_basal: start.basal,
        capped: 0,
        pump_events: Vec::with_capacity(4),
    };
    if ctl.pump.set_basal(start.basal).map_err(sim)?.capped {
        ctl.capped += 1;
    }
    ctl.pump.drain_events().for_each(drop);

    let days = scenario.days as usize;
    let mut glucose = vec![0.0; days * SAMPLES_PER_DAY];
    let mut daily_insulin = vec![0.0; days];
    let mut min_glucose = f64::INFINITY;
    let mut events: Vec<Event> = Vec::with_capacity(8);
    let mut failure = None;

    'days: for day in 0..days {
        let plan = generator.day(day as u32);
        let s_per_minute = plan.sensitivity.per_minute();
        let insulin_at_midnight = ctl.pump.totals().total().0;
        let feed = day >= 1; // D1 is warm-up: the advisor starts at D2.
        for m in 0..MINUTES_PER_DAY as u32 {
            let now = plan.at(m);
            events.clear();
            let plasma = patient.glucose_mg_dl();
            if (m as usize).is_multiple_of(EVAL_PERIOD_MIN) {
                glucose[day * SAMPLES_PER_DAY + m as usize / EVAL_PERIOD_MIN] = plasma;
            }
            min_glucose = min_glucose.min(plasma);
            if plasma < config.failure_glucose_mg_dl {
                failure = Some(RunFailure {
                    day: day as u32 + 1,
                    minute_of_day: m,
                    glucose_mg_dl: plasma,
                });
                break 'days;
            }

            // Readings.
            let (mut cgm_reading, mut smbg_reading) = (None, None);
            if plan.cgm_sample_at(m) {
                let reading = cgm
                    .read(MgDl(patient.subcutaneous_glucose_mg_dl()))
                    .map_err(sim)?;
                cgm_reading = Some(reading.0);
                events.push(Event::new(now, EventKind::Cgm(reading)));
            }
            let mut bedtime_reading = false;
            for r in plan.smbg.iter().filter(|r| r.at == now) {
                let reading = meter.measure(MgDl(plasma)).map_err(sim)?;
                smbg_reading = Some(reading.0);
                events.push(Event::new(now, EventKind::Smbg(reading)));
                bedtime_reading |= r.purpose == SmbgPurpose::Bedtime;
            }
            if feed && !events.is_empty() {
                ctl.feed(&events, record.as_deref_mut())
                    .map_err(|e| e.with(&context))?;
            }
            events.clear();

            // Meals: announce (the advisor may update this meal's carb
            // ratio), then bolus announced carbs / carb ratio.
            for meal in plan
                .meals
                .iter()
                .filter(|meal| meal.at == now && !meal.skipped)
            {
                queue.add(meal.carbs.0);
                let Some(announced) = meal.announced else {
                    continue; // the snack: eaten, not announced, no bolus
                };
                if feed {
                    let announce = Event::new(
                        now,
                        EventKind::MealAnnounced {
                            carbs: announced,
                            slot: meal.slot,
                        },
                    );
                    ctl.feed(&[announce], record.as_deref_mut())
                        .map_err(|e| e.with(&context))?;
                }
                if let Some(ratio) = ctl.advisor.settings().carb_ratio_for(meal.slot) {
                    let outcome = ctl
                        .pump
                        .request_bolus(Units(announced.0 / ratio.0))
                        .map_err(sim)?;
                    if outcome.capped {
                        ctl.capped += 1;
                    }
                }
            }

            // The day closes after the bedtime reading (SMBG mode) or at
            // midnight (CGM mode, from D3's midnight, which closes D2, the
            // first day the advisor sees).
            let day_closes = (bedtime_reading && mode == Mode::Smbg && day >= 1)
                || (mode == Mode::Cgm && m == 0 && day >= 2);
            if day_closes {
                events.push(Event::new(now, EventKind::DayClosed));
            }
            if feed {
                // Pending pump events (the bolus just programmed) go first.
                ctl.feed(&events, record.as_deref_mut())
                    .map_err(|e| e.with(&context))?;
            } else {
                ctl.pump.drain_events().for_each(drop);
            }
            events.clear();

            // Deliver and advance one minute.
            let insulin = ctl.pump.insulin_for_minute();
            let cho = queue.eat_minute();
            if let Some(trace_minutes) = trace.minutes.as_mut() {
                let cr = ctl.advisor.settings().carb_ratio;
                trace_minutes.push(MinuteRecord {
                    minute: now.minutes(),
                    plasma_mg_dl: plasma,
                    subcutaneous_mg_dl: patient.subcutaneous_glucose_mg_dl(),
                    cgm_mg_dl: cgm_reading,
                    smbg_mg_dl: smbg_reading,
                    cho_g_per_min: cho,
                    insulin_u_per_min: insulin,
                    sensitivity: s_per_minute[m as usize],
                    basal_u_per_h: ctl.pump.basal_rate().0,
                    carb_ratio_g_per_u: [cr[0].0, cr[1].0, cr[2].0],
                });
            }
            patient
                .step(cho, insulin, s_per_minute[m as usize])
                .map_err(sim)?;
        }
        daily_insulin[day] = ctl.pump.totals().total().0 - insulin_at_midnight;
        // Keep the advisor's decision log bounded; keep the decisions only
        // when asked to.
        let decisions = ctl.advisor.take_decisions();
        if let Some(d) = trace.decisions.as_mut() {
            d.extend(decisions);
        }
    }

    // Whole days simulated (a failed run ends before its failure day).
    let complete_days = failure.map_or(days, |f| f.day as usize - 1);
    let mut weeks = Vec::new();
    for (name, first, last) in evaluation_windows() {
        if last as usize > complete_days {
            continue;
        }
        let (a, b) = (
            (first as usize - 1) * SAMPLES_PER_DAY,
            last as usize * SAMPLES_PER_DAY,
        );
        let metrics = metrics_regular(&glucose[a..b]).map_err(|source| TrialError::Metric {
            context: format!("{context} {name}"),
            source,
        })?;
        let n_days = (last - first + 1) as f64;
        let tdi = daily_insulin[first as usize - 1..last as usize]
            .iter()
            .sum::<f64>()
            / n_days;
        weeks.push(WeekResult {
            week: name,
            first_day: first,
            last_day: last,
            metrics,
            tdi_u_per_day: tdi,
            plasma_5min_mg_dl: if Week::TABLE.contains(&name) {
                glucose[a..b].iter().map(|g| *g as f32).collect()
            } else {
                Vec::new()
            },
        });
    }
    trace.init = ctl.advisor.init_report().cloned();
    let fin = ctl.advisor.settings();
    Ok(PatientResult {
        patient: vp.params.name.clone(),
        weeks,
        final_basal_u_per_h: fin.basal.0,
        final_carb_ratio_g_per_u: [
            fin.carb_ratio[0].0,
            fin.carb_ratio[1].0,
            fin.carb_ratio[2].0,
        ],
        start_basal_u_per_h: start.basal.0,
        start_carb_ratio_g_per_u: start.carb_ratio[0].0,
        pump_capped: ctl.capped,
        min_glucose_mg_dl: min_glucose,
        failure,
    })
}

/// An error on the way from the advisor to the pump.
enum LoopError {
    Advisor(abba_advisor::AdvisorError),
    Sim(abba_sim::SimError),
}

impl LoopError {
    fn with(self, context: &str) -> TrialError {
        match self {
            LoopError::Advisor(source) => TrialError::Advisor {
                context: context.into(),
                source,
            },
            LoopError::Sim(source) => TrialError::Sim {
                context: context.into(),
                source,
            },
        }
    }
}

/// The advisor and the pump it programs.
struct Controls {
    advisor: AnyAdvisor,
    pump: Pump,
    /// The advisor's basal rate last sent to the pump (the pump rounds it,
    /// so it is reprogrammed only when the advisor's rate moves).
    requested_basal: UnitsPerHour,
    /// Requests the pump capped at its maximum.
    capped: u32,
    /// Reused buffer for the pump's events.
    pump_events: Vec<Event>,
}

impl Controls {
    /// Feeds the pump's pending events, then `events`, to the advisor; a new
    /// basal rate goes to the pump at once and its `BasalRate` event is fed
    /// right after. Every event fed is also appended to `record`.
    fn feed(
        &mut self,
        events: &[Event],
        mut record: Option<&mut Vec<Event>>,
    ) -> Result<(), LoopError> {
        self.feed_pump_events(record.as_deref_mut())?;
        for e in events {
            self.observe(e, record.as_deref_mut())?;
        }
        self.feed_pump_events(record)
    }

    fn feed_pump_events(&mut self, mut record: Option<&mut Vec<Event>>) -> Result<(), LoopError> {
        if self.pump.events().is_empty() {
            return Ok(()); // the usual minute: nothing to move
        }
        let mut pending = std::mem::take(&mut self.pump_events);
        loop {
            pending.clear();
            pending.extend(self.pump.drain_events());
            if pending.is_empty() {
                break;
            }
            for e in &pending {
                self.observe(e, record.as_deref_mut())?;
            }
        }
        self.pump_events = pending;
        Ok(())
    }

    fn observe(&mut self, event: &Event, record: Option<&mut Vec<Event>>) -> Result<(), LoopError> {
        if let Some(r) = record {
            r.push(*event);
        }
        if let Some(new) = self.advisor.observe(event).map_err(LoopError::Advisor)? {
            if new.basal != self.requested_basal {
                self.requested_basal = new.basal;
                if self
                    .pump
                    .set_basal(new.basal)
                    .map_err(LoopError::Sim)?
                    .capped
                {
                    self.capped += 1;
                }
            }
        }
        Ok(())
    }
}
