//! A simulated person: the whole simulated world one advisor talks to.
//!
//! A [`VirtualPerson`] owns the patient model, the eating queue, the CGM,
//! the meter, the pump, the scenario's day plans and the person's
//! [`Behaviour`]. It exchanges only events and settings with an advisor:
//! **events out** ([`VirtualPerson::next_event`]: readings, meal
//! announcements, the pump's log, day closings), **settings in**
//! ([`VirtualPerson::suggest`]). It never sees the advisor and the advisor
//! never sees it.
//!
//! One simulated minute, driven by the caller:
//!
//! ```text
//! person.begin_minute()?;                        // the day's plan at 00:00
//! while let Some(event) = person.next_event()? { // events out
//!     if let Some(s) = advisor.observe(&event)? { person.suggest(s)?; } // settings in
//! }
//! let record = person.finish_minute()?;          // deliver, eat, advance
//! ```
//!
//! Within a minute the events come in this order: readings from the state
//! at the start of the minute (CGM from subcutaneous glucose, the meter from
//! plasma glucose); then for each meal of the minute the announcement, and
//! once the caller has passed on any answer, the bolus for the announced
//! carbohydrate with the carb ratio in force *after* that answer; then the
//! day closing. The pump's log (bolus programmed, basal changed) is emitted
//! before the next event, so a basal rate suggested at a decision reaches
//! the pump, and its `BasalRate` event the advisor, in the same minute.
//! Before the app's first day ([`Behaviour::app_from_day`]) no event leaves
//! the person and they follow their starting therapy.

mod behaviour;

pub use behaviour::{Behaviour, DayClosing, SuggestionResponse};

use crate::cohort::VirtualPatient;
use crate::devices::{CgmSensor, DeviceSet, Pump, SmbgMeter};
#[cfg(doc)]
use crate::patient::Pair;
use crate::patient::{EatingQueue, GutTape, Patient, Side, SplitInput};
use crate::scenario::{
    DayPlan, ScenarioConfig, ScenarioGenerator, SensitivityTarget, SmbgPurpose, DAY_MINUTES,
};
use crate::SimError;
use abba_core::{
    Event, EventKind, GramsPerUnit, MealSlot, MgDl, SettingValue, TherapySettings, Timestamp,
    Units, UnitsPerHour,
};
use serde::Serialize;
use std::collections::VecDeque;

/// What happened in one simulated minute (for a 1-minute trace).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
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
    /// The person's carb ratios (breakfast, lunch, dinner; g/U).
    pub carb_ratio_g_per_u: [f64; 3],
}

/// Where the person is within the current minute.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// `begin_minute` not called yet.
    Idle,
    Readings,
    /// Next meal of the plan to look at.
    Meals(usize),
    /// Bolus for this meal of the plan, after its announcement was answered.
    Bolus(usize),
    DayClose,
    Done,
}

/// The simulated person (see the module docs).
#[derive(Debug, Clone)]
pub struct VirtualPerson {
    name: String,
    patient: Patient,
    queue: EatingQueue,
    cgm: CgmSensor,
    meter: SmbgMeter,
    pump: Pump,
    generator: ScenarioGenerator,
    behaviour: Behaviour,
    plan: Option<DayPlan>,
    sensitivity: Box<[f64; DAY_MINUTES]>,
    /// Minutes of the day that may emit an event (a CGM or finger-stick
    /// reading, a meal, midnight); the others take a short path.
    eventful: Box<[bool; DAY_MINUTES]>,
    /// The therapy the person follows.
    settings: TherapySettings,
    /// The basal rate last asked of the pump (the pump rounds it, so it is
    /// reprogrammed only when the asked rate moves).
    requested_basal: UnitsPerHour,
    /// Pump requests capped at the pump's maximum.
    capped: u32,
    now: Timestamp,
    /// `now` as minute of the day and day index, and whether the app is in
    /// use on that day, kept as `now` advances (read several times a
    /// minute; cheaper than dividing each time).
    minute_of_day: u32,
    day_index: i64,
    app_today: bool,
    phase: Phase,
    outbox: VecDeque<Event>,
    bedtime_reading: bool,
    record: MinuteRecord,
    /// Rescue carbohydrate eaten so far (g; scenario `hypo_treatment`).
    rescue_carbs_g: f64,
    /// Hypoglycaemia treatments so far.
    rescue_treatments: u32,
    /// Minute of the last treatment.
    last_treatment: Option<i64>,
}

impl VirtualPerson {
    /// Patient `vp` (number `patient_no` of its cohort, 1-based; it selects
    /// the random streams) living `scenario` with `devices`, starting on the
    /// therapy of the cohort, at 00:00 of D1.
    pub fn new(
        vp: &VirtualPatient,
        patient_no: u64,
        scenario: &ScenarioConfig,
        trial_seed: u64,
        devices: &DeviceSet,
        behaviour: Behaviour,
    ) -> Result<Self, SimError> {
        if behaviour.app_from_day == 0 {
            return Err(SimError::Config(
                "behaviour.app_from_day: days are counted from 1".into(),
            ));
        }
        let generator = ScenarioGenerator::new(scenario.clone(), trial_seed, patient_no)?;
        let seeds = *generator.seeds();
        let cgm = CgmSensor::new(devices.cgm.clone(), seeds.cgm_noise)?;
        let meter = SmbgMeter::new(devices.meter, seeds.meter_noise)?;
        let mut pump = Pump::new(devices.pump.clone(), Timestamp(0))?;
        let start = vp.therapy;
        let capped = u32::from(pump.set_basal(start.basal)?.capped);
        pump.drain_events().for_each(drop);
        let app_today = behaviour.app_from_day <= 1;
        Ok(Self {
            name: vp.params.name.clone(),
            patient: Patient::new(vp.params.clone())?,
            queue: EatingQueue::new(),
            cgm,
            meter,
            pump,
            generator,
            behaviour,
            plan: None,
            sensitivity: Box::new([1.0; DAY_MINUTES]),
            eventful: Box::new([true; DAY_MINUTES]),
            settings: start,
            requested_basal: start.basal,
            capped,
            now: Timestamp(0),
            minute_of_day: 0,
            day_index: 0,
            app_today,
            phase: Phase::Idle,
            outbox: VecDeque::with_capacity(8),
            bedtime_reading: false,
            record: empty_record(),
            rescue_carbs_g: 0.0,
            rescue_treatments: 0,
            last_treatment: None,
        })
    }

    /// Rescue carbohydrate eaten so far (g) and the number of treatments
    /// (0 unless the scenario has `hypo_treatment`).
    pub fn rescue(&self) -> (f64, u32) {
        (self.rescue_carbs_g, self.rescue_treatments)
    }

    /// The patient's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The minute about to be simulated (or being simulated).
    pub fn now(&self) -> Timestamp {
        self.now
    }

    /// Plasma glucose now (mg/dL): for evaluation only, never an event.
    pub fn plasma_glucose_mg_dl(&self) -> f64 {
        self.patient.glucose_mg_dl()
    }

    /// The therapy the person follows now.
    pub fn settings(&self) -> &TherapySettings {
        &self.settings
    }

    /// Insulin the pump has delivered so far (U).
    pub fn insulin_delivered(&self) -> Units {
        self.pump.totals().total()
    }

    /// Pump requests (bolus or basal) capped at the pump's maximum so far.
    pub fn pump_capped(&self) -> u32 {
        self.capped
    }

    /// The plan of the current day (after the first `begin_minute`).
    pub fn plan(&self) -> Option<&DayPlan> {
        self.plan.as_ref()
    }

    /// The app is in use at `at`.
    fn app_on(&self, at: Timestamp) -> bool {
        if at == self.now {
            return self.app_today;
        }
        at.day_index() + 1 >= i64::from(self.behaviour.app_from_day)
    }

    /// Starts the minute [`now`](Self::now): at 00:00 the day's plan is drawn.
    pub fn begin_minute(&mut self) -> Result<(), SimError> {
        if self.phase != Phase::Idle {
            return Err(SimError::Config(format!(
                "{}: begin_minute called twice at {}",
                self.name, self.now
            )));
        }
        let m = self.minute_of_day as usize;
        if m == 0 || self.plan.is_none() {
            let day = u32::try_from(self.day_index).map_err(|_| {
                SimError::Config(format!("{}: minute {} is before D1", self.name, self.now))
            })?;
            let plan = self.generator.day(day);
            *self.sensitivity = plan.sensitivity.per_minute();
            let period = self.cgm.config().sample_time_min;
            for (minute, e) in self.eventful.iter_mut().enumerate() {
                *e = minute == 0 || plan.cgm_sample_at(minute as u32, period);
            }
            let today = i64::from(day);
            let times = plan.meals.iter().map(|meal| meal.at);
            for at in times.chain(plan.smbg.iter().map(|r| r.at)) {
                if at.day_index() == today {
                    self.eventful[at.minute_of_day() as usize] = true;
                }
            }
            self.plan = Some(plan);
        }
        self.record = empty_record();
        self.record.minute = self.now.minutes();
        self.record.plasma_mg_dl = self.patient.glucose_mg_dl();
        self.record.subcutaneous_mg_dl = self.patient.subcutaneous_glucose_mg_dl();
        self.record.sensitivity = self.sensitivity[m];
        self.bedtime_reading = false;
        self.phase = Phase::Readings;
        Ok(())
    }

    /// The next event of this minute for the advisor, `None` when the
    /// minute has nothing more to say (then call
    /// [`finish_minute`](Self::finish_minute)).
    pub fn next_event(&mut self) -> Result<Option<Event>, SimError> {
        // A minute with no reading, meal or midnight and nothing queued
        // goes from readings to done without an event (what the phases
        // below would find); most minutes are such.
        if self.phase == Phase::Readings
            && !self.eventful[self.minute_of_day as usize]
            && self.outbox.is_empty()
            && self.pump.events().is_empty()
            && self.plan.is_some()
        {
            self.phase = Phase::Done;
            return Ok(None);
        }
        loop {
            if let Some(e) = self.outbox.pop_front() {
                return Ok(Some(e));
            }
            if !self.pump.events().is_empty() {
                let share = self.app_today;
                for e in self.pump.drain_events() {
                    if share {
                        self.outbox.push_back(e);
                    }
                }
                if !self.outbox.is_empty() {
                    continue;
                }
            }
            let Some(plan) = self.plan.as_ref() else {
                return Ok(None);
            };
            let now = self.now;
            let m = self.minute_of_day;
            match self.phase {
                Phase::Idle | Phase::Done => return Ok(None),
                Phase::Readings => {
                    let cgm_due = plan.cgm_sample_at(m, self.cgm.config().sample_time_min);
                    let n_smbg = plan.smbg.len();
                    if cgm_due {
                        let gs = MgDl(self.patient.subcutaneous_glucose_mg_dl());
                        let reading = self.cgm.read(gs)?;
                        self.record.cgm_mg_dl = Some(reading.0);
                        self.emit(Event::new(now, EventKind::Cgm(reading)));
                    }
                    let plasma = MgDl(self.patient.glucose_mg_dl());
                    for j in 0..n_smbg {
                        let Some(r) = self.plan.as_ref().map(|p| p.smbg[j]) else {
                            break;
                        };
                        if r.at != now {
                            continue;
                        }
                        let reading = self.meter.measure(plasma)?;
                        self.record.smbg_mg_dl = Some(reading.0);
                        self.emit(Event::new(now, EventKind::Smbg(reading)));
                        self.bedtime_reading |= r.purpose == SmbgPurpose::Bedtime;
                    }
                    self.react_to_readings();
                    self.phase = Phase::Meals(0);
                }
                Phase::Meals(k) => {
                    let next = plan
                        .meals
                        .iter()
                        .enumerate()
                        .skip(k)
                        .find(|(_, meal)| meal.at == now && !meal.skipped)
                        .map(|(i, meal)| (i, *meal));
                    let Some((i, meal)) = next else {
                        self.phase = Phase::DayClose;
                        continue;
                    };
                    self.queue.add(meal.carbs.0);
                    self.phase = Phase::Meals(i + 1);
                    if let Some(announced) = meal.announced {
                        // Announce first; the bolus waits for the answer.
                        self.emit(Event::new(
                            now,
                            EventKind::MealAnnounced {
                                carbs: announced,
                                slot: meal.slot,
                            },
                        ));
                        self.phase = Phase::Bolus(i);
                    }
                }
                Phase::Bolus(i) => {
                    let meal = plan.meals[i];

                    self.phase = Phase::Meals(i + 1);
                    if let (Some(announced), Some(ratio)) =
                        (meal.announced, self.settings.carb_ratio_for(meal.slot))
                    {
                        let outcome = self.pump.request_bolus(Units(announced.0 / ratio.0))?;
                        self.capped += u32::from(outcome.capped);
                    }
                }
                Phase::DayClose => {
                    self.phase = Phase::Done;
                    if self.day_closes() {
                        self.emit(Event::new(now, EventKind::DayClosed));
                    }
                }
            }
        }
    }

    /// Whether the app closes a day at this minute.
    fn day_closes(&self) -> bool {
        let first = i64::from(self.behaviour.app_from_day) - 1;
        let day = self.day_index;
        match self.behaviour.day_closing {
            DayClosing::AfterBedtimeReading => self.bedtime_reading && day >= first,
            // Midnight closes the day before, which must be an app day.
            DayClosing::AtMidnight => self.minute_of_day == 0 && day > first,
        }
    }

    /// Queues an event for the advisor if the app is in use.
    fn emit(&mut self, e: Event) {
        if self.app_on(e.at) {
            self.outbox.push_back(e);
        }
    }

    /// The hook for behaviour that reacts to this minute's readings
    /// (`self.record.cgm_mg_dl`, `self.record.smbg_mg_dl`): the scenario's
    /// hypoglycaemia treatment, if any. A reading the person sees below the
    /// threshold makes them eat the rescue carbohydrate (not announced, no
    /// bolus) unless they treated less than `recheck_min` minutes ago; the
    /// next reading after that is the re-check.
    fn react_to_readings(&mut self) {
        let Some(t) = self.generator.config().hypo_treatment else {
            return;
        };
        let low = [self.record.cgm_mg_dl, self.record.smbg_mg_dl]
            .into_iter()
            .flatten()
            .any(|g| g < t.below_mg_dl);
        let now = self.now.minutes();
        let ready = self
            .last_treatment
            .is_none_or(|at| now - at >= i64::from(t.recheck_min));
        if low && ready {
            self.queue.add(t.carbs_g);
            self.rescue_carbs_g += t.carbs_g;
            self.rescue_treatments += 1;
            self.last_treatment = Some(now);
        }
    }

    /// Settings suggested by the advisor. The person answers them as their
    /// [`Behaviour::suggestions`] says: today they take them at once (a new
    /// basal rate goes to the pump now; its `BasalRate` event is the next
    /// event).
    pub fn suggest(&mut self, suggested: TherapySettings) -> Result<(), SimError> {
        match self.behaviour.suggestions {
            SuggestionResponse::AcceptAll => self.settings = suggested,
            response => self.answer(response, suggested),
        }
        if self.settings.basal != self.requested_basal {
            self.requested_basal = self.settings.basal;
            let outcome = self.pump.set_basal(self.requested_basal)?;
            self.capped += u32::from(outcome.capped);
        }
        Ok(())
    }

    /// Answers each suggested change as `response` says, puts the result in
    /// force and tells the advisor (the answer is the next event). The draws
    /// are a hash of the person, the minute and the setting: deterministic.
    fn answer(&mut self, response: SuggestionResponse, suggested: TherapySettings) {
        let get = |s: &TherapySettings, k: usize| {
            if k == 0 {
                s.basal.0
            } else {
                s.carb_ratio[k - 1].0
            }
        };
        for k in 0..4 {
            let (before, after) = (get(&self.settings, k), get(&suggested, k));
            if before == after {
                continue;
            }
            let mut h: u64 = 0xcbf2_9ce4_8422_2325;
            let minute = self.now.0.to_le_bytes();
            for &b in self.name.as_bytes().iter().chain(&minute).chain(&[k as u8]) {
                h ^= u64::from(b);
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
            let u = (h >> 11) as f64 / (1u64 << 53) as f64;
            let (value, kind): (f64, fn(SettingValue) -> EventKind) = match response {
                SuggestionResponse::RejectShare { percent } if u < f64::from(percent) / 100.0 => {
                    (before, EventKind::SuggestionRejected)
                }
                SuggestionResponse::OverrideWithin { percent } => (
                    after * (1.0 + (2.0 * u - 1.0) * f64::from(percent) / 100.0),
                    EventKind::SuggestionOverridden,
                ),
                _ => (after, EventKind::SuggestionAccepted),
            };
            let v = if k == 0 {
                self.settings.basal = UnitsPerHour(value);
                SettingValue::Basal {
                    rate: UnitsPerHour(value),
                }
            } else {
                self.settings.carb_ratio[k - 1] = GramsPerUnit(value);
                SettingValue::CarbRatio {
                    slot: MealSlot::MAIN[k - 1],
                    ratio: GramsPerUnit(value),
                }
            };
            self.outbox.push_back(Event::new(self.now, kind(v)));
        }
    }

    /// Ends the minute: the pump delivers, the person eats, the patient
    /// model advances one minute. Returns what happened in the minute.
    pub fn finish_minute(&mut self) -> Result<MinuteRecord, SimError> {
        self.end_minute()?;
        Ok(self.record)
    }

    /// As [`finish_minute`](Self::finish_minute) without copying the
    /// minute's record out ([`last_record`](Self::last_record) has it): the
    /// closed loop's form, where the copy showed in the profile.
    pub fn end_minute(&mut self) -> Result<(), SimError> {
        self.end_minute_with(None)
    }

    /// As [`end_minute`](Self::end_minute), sharing the patient model's gut
    /// work with other people who are the same patient eating the same
    /// ([`GutTape`]; the trial's arms of one scenario): bit-identical.
    pub fn end_minute_shared(&mut self, tape: &mut GutTape) -> Result<(), SimError> {
        self.end_minute_with(Some(tape))
    }

    fn end_minute_with(&mut self, tape: Option<&mut GutTape>) -> Result<(), SimError> {
        let i = self.before_integration()?;
        let (cho, insulin, s, liver) = (
            i.cho_g_per_min,
            i.insulin_u_per_min,
            i.sensitivity,
            i.egp_sensitivity,
        );
        match tape {
            Some(t) => self.patient.step_split_shared(cho, insulin, s, liver, t)?,
            None => self.patient.step_split(cho, insulin, s, liver)?,
        }
        self.after_integration();
        Ok(())
    }

    /// [`end_minute_shared`](Self::end_minute_shared) of each person in
    /// order, with the same results bit for bit; when all are the same
    /// patient eating the same (the trial's arms and scenarios), their
    /// bodies are integrated side by side as one `T` ([`Pair`];
    /// [`Patient::step_split_shared_side`]), in about the time of one.
    /// When a person's minute is refused, those before it have ended
    /// theirs; when a state turns non-finite, those before it have ended
    /// theirs and those after it are left mid-minute.
    pub fn end_minutes_shared_side<T: Side<W>, const W: usize>(
        mut people: [&mut VirtualPerson; W],
        tape: &mut GutTape,
    ) -> Result<(), SimError> {
        for k in 0..W {
            let begun = people[k]
                .before_integration()
                .and_then(|input| people[k].patient.begin_step(input));
            if let Err(e) = begun {
                for person in &mut people[..k] {
                    person.patient.integrate_shared(tape);
                    person.patient.end_minute()?;
                    person.after_integration();
                }
                return Err(e);
            }
        }
        let mut patients = people.each_mut().map(|person| &mut person.patient);
        Patient::integrate_side_shared::<T, W>(&mut patients, tape);
        for person in people {
            person.patient.end_minute()?;
            person.after_integration();
        }
        Ok(())
    }

    /// The minute's delivery and eating, recorded, as the patient model's
    /// inputs (after every event of the minute was taken).
    #[inline]
    fn before_integration(&mut self) -> Result<SplitInput, SimError> {
        if self.phase != Phase::Done {
            return Err(SimError::Config(format!(
                "{}: finish_minute at {} before every event of the minute was taken",
                self.name, self.now
            )));
        }
        let insulin = self.pump.insulin_for_minute();
        let cho = self.queue.eat_minute();
        let r = &mut self.record;
        r.cho_g_per_min = cho;
        r.insulin_u_per_min = insulin;
        r.basal_u_per_h = self.pump.basal_rate().0;
        let cr = self.settings.carb_ratio;
        r.carb_ratio_g_per_u = [cr[0].0, cr[1].0, cr[2].0];
        let sensitivity = r.sensitivity;
        let liver = match self.generator.config().sensitivity.target {
            SensitivityTarget::VmxAndKp3 => sensitivity,
            SensitivityTarget::Vmx => 1.0,
        };
        Ok(SplitInput {
            cho_g_per_min: cho,
            insulin_u_per_min: insulin,
            sensitivity,
            egp_sensitivity: liver,
        })
    }

    /// The clock after the minute was integrated.
    #[inline]
    fn after_integration(&mut self) {
        self.now = self.now.plus(1);
        self.minute_of_day += 1;
        if self.minute_of_day == DAY_MINUTES as u32 {
            self.minute_of_day = 0;
            self.day_index += 1;
            self.app_today = self.day_index + 1 >= i64::from(self.behaviour.app_from_day);
        }
        self.phase = Phase::Idle;
    }

    /// The record of the minute: complete after
    /// [`end_minute`](Self::end_minute) (what happened in the minute just
    /// finished), partly filled between `begin_minute` and `end_minute`.
    pub fn last_record(&self) -> &MinuteRecord {
        &self.record
    }
}

fn empty_record() -> MinuteRecord {
    MinuteRecord {
        minute: 0,
        plasma_mg_dl: f64::NAN,
        subcutaneous_mg_dl: f64::NAN,
        cgm_mg_dl: None,
        smbg_mg_dl: None,
        cho_g_per_min: 0.0,
        insulin_u_per_min: 0.0,
        sensitivity: 1.0,
        basal_u_per_h: 0.0,
        carb_ratio_g_per_u: [0.0; 3],
    }
}
