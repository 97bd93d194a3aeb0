//! One run of a candidate twin over the window: the simulator's per-minute
//! path (`abba_sim::patient::Patient::step`) fed the delivered insulin and
//! the carbohydrate (eaten at 5 g/min, as the simulator's eating queue
//! does), from an initial state set by the first reading.

use crate::error::TwinError;
use crate::tape::Meal;
use abba_sim::patient::model::ix;
use abba_sim::patient::{EatingQueue, Patient, PatientParams};

/// The inputs of one run: per-minute insulin (U/min), meals (grams already
/// scaled), and the glucose the run starts from.
#[derive(Debug, Clone)]
pub struct RunInputs<'a> {
    /// First minute of the run (the tape's start).
    pub start_minute: i64,
    /// Insulin per minute.
    pub insulin_u_per_min: &'a [f64],
    /// Meals in time order, with the grams that are eaten.
    pub meals: &'a [Meal],
    /// Glucose at the start (mg/dL).
    pub start_glucose_mg_dl: f64,
    /// Insulin sensitivity at dawn ([`dawn`]).
    pub dawn_factor: f64,
}

/// Insulin sensitivity at local `minute` with dawn factor `factor`: 1, then
/// a 30-minute ramp from 04:00 down to `factor`, held, and a 30-minute ramp
/// back to 1 ending at 08:00 (the dawn window of the trial's scenarios).
pub fn dawn(minute: i64, factor: f64) -> f64 {
    const START: i64 = 4 * 60;
    const END: i64 = 8 * 60;
    const RAMP: i64 = 30;
    let m = minute.rem_euclid(abba_core::MINUTES_PER_DAY);
    let w = if !(START..END).contains(&m) {
        0.0
    } else if m < START + RAMP {
        (m - START) as f64 / RAMP as f64
    } else if m >= END - RAMP {
        (END - m) as f64 / RAMP as f64
    } else {
        1.0
    };
    1.0 + w * (factor - 1.0)
}

/// The initial state: the steady state of `p` at the insulin rate
/// `insulin_u_per_min`, with plasma, tissue and subcutaneous glucose scaled
/// to `glucose_mg_dl`. Insulin on board from before the window is not known
/// and is left out (the fit skips the first hours, [`crate::fit::BURN_IN_MIN`]).
pub fn initial_state(p: &PatientParams, insulin_u_per_min: f64, glucose_mg_dl: f64) -> [f64; 13] {
    let mut x = p.x0;
    let r = (insulin_u_per_min / p.basal_u_per_min()).max(0.0);
    for k in [ix::IP, ix::IL, ix::ISC1, ix::ISC2] {
        x[k] *= r;
    }
    x[ix::I1] = r * p.ib;
    x[ix::ID] = r * p.ib;
    x[ix::X] = (r - 1.0) * p.ib;
    let g = glucose_mg_dl / p.gb;
    x[ix::GP] *= g;
    x[ix::GT] *= g;
    x[ix::GS] *= g;
    x
}

/// A run paused at the start of a minute: the patient and what is still
/// to be eaten.
#[derive(Debug, Clone)]
pub struct Paused {
    /// Index of the minute in the run.
    pub k: usize,
    /// The patient at the start of that minute.
    pub patient: Patient,
    /// Carbohydrate not yet eaten.
    pub queue: EatingQueue,
}

/// The run at its first minute.
pub fn start(p: &PatientParams, inputs: &RunInputs) -> Result<Paused, TwinError> {
    let first_rate = inputs.insulin_u_per_min.first().copied().unwrap_or(0.0);
    let patient = Patient::new(p.clone())?;
    let mut state = patient.minute_state();
    state.x = initial_state(p, first_rate, inputs.start_glucose_mg_dl);
    Ok(Paused {
        k: 0,
        patient: patient.with_minute_state(state)?,
        queue: EatingQueue::new(),
    })
}

/// Advances `at` to minute index `to` (at most the run's length), pushing
/// the subcutaneous glucose at the start of each minute onto `out`, and a
/// copy of the paused run every `every` minutes onto `checkpoints`. Meals
/// of `inputs` and `extra` are eaten from their minute on.
pub fn advance(
    at: &mut Paused,
    inputs: &RunInputs,
    extra: Option<Meal>,
    to: usize,
    out: &mut Vec<f64>,
    mut checkpoints: Option<(&mut Vec<Paused>, usize)>,
) -> Result<(), TwinError> {
    let to = to.min(inputs.insulin_u_per_min.len());
    let first = inputs.start_minute + at.k as i64;
    let mut meals = inputs
        .meals
        .iter()
        .skip_while(|m| m.minute < first)
        .peekable();
    while at.k < to {
        let minute = inputs.start_minute + at.k as i64;
        if let Some((cps, every)) = checkpoints.as_mut() {
            if at.k.is_multiple_of(*every) {
                cps.push(at.clone());
            }
        }
        while let Some(m) = meals.next_if(|m| m.minute <= minute) {
            if m.minute == minute && m.grams > 0.0 {
                at.queue.add(m.grams);
            }
        }
        if let Some(m) = extra.filter(|m| m.minute == minute && m.grams > 0.0) {
            at.queue.add(m.grams);
        }
        out.push(at.patient.subcutaneous_glucose_mg_dl());
        at.patient.step(
            at.queue.eat_minute(),
            inputs.insulin_u_per_min[at.k],
            dawn(minute, inputs.dawn_factor),
        )?;
        at.k += 1;
    }
    Ok(())
}

/// Subcutaneous glucose (mg/dL) at the start of every minute of the run
/// (`insulin_u_per_min.len()` values).
pub fn run(p: &PatientParams, inputs: &RunInputs) -> Result<Vec<f64>, TwinError> {
    let n = inputs.insulin_u_per_min.len();
    let mut at = start(p, inputs)?;
    let mut out = Vec::with_capacity(n);
    advance(&mut at, inputs, None, n, &mut out, None)?;
    Ok(out)
}
