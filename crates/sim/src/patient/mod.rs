//! The UVA/Padova 2008 patient model as simglucose computes it
//! (`spec/uva-padova-model.md`), advanced minute by minute.
//!
//! ```
//! use abba_sim::patient::{Patient, PatientParams};
//! let mut p = Patient::new(PatientParams::public("adult#001").unwrap()).unwrap();
//! let basal = p.params().basal_u_per_min();
//! for _ in 0..60 {
//!     p.step(0.0, basal, 1.0).unwrap();
//! }
//! assert!((p.glucose_mg_dl() - 138.56).abs() < 1e-6);
//! ```

pub mod eating;
pub mod lanes;
pub mod model;
pub mod pair;
pub mod params;
pub mod solver;
pub mod state;

pub use eating::{EatingQueue, EAT_RATE_G_PER_MIN};
pub use model::{derivatives, MinuteInput, ModelConsts};
pub use pair::{Pair, Side};
pub use params::{PatientParams, QuestRow, N_STATES};
pub use solver::{GutTape, Solver};
pub use state::PatientState;

use crate::error::SimError;
use abba_core::units::MG_PER_G;
use std::sync::Arc;

/// Where a patient stands between two minutes, beyond its parameters:
/// what a stepper outside this crate (`abba-batch`) reads to take a
/// patient over and writes back to hand it out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinuteState {
    /// The states x1..x13.
    pub x: [f64; 13],
    /// Minutes simulated so far.
    pub minute: i64,
    /// Eating rate of the previous minute (g/min).
    pub last_cho_g_per_min: f64,
    /// Stomach content when the current/last eating episode began (mg).
    pub last_q_sto_mg: f64,
    /// Grams eaten so far in the current/last episode.
    pub last_food_taken_g: f64,
    /// The input of the last integrated minute.
    pub last_input: MinuteInput,
}

/// One minute's inputs of [`Patient::step_split`] and its shared forms.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplitInput {
    /// Carbohydrate eaten (g/min, through the eating queue).
    pub cho_g_per_min: f64,
    /// Insulin infused (U/min).
    pub insulin_u_per_min: f64,
    /// Insulin sensitivity multiplier on Vmx (1 = nominal).
    pub sensitivity: f64,
    /// Insulin sensitivity multiplier on kp3, the liver's insulin action.
    pub egp_sensitivity: f64,
}

/// One virtual patient: parameters, state and the eating-episode
/// bookkeeping that defines Dbar.
#[derive(Debug, Clone)]
pub struct Patient {
    params: PatientParams,
    /// Shared by the runs of one patient once a side-by-side step found
    /// them equal ([`Patient::integrate_side_shared`]); never changed.
    consts: Arc<ModelConsts>,
    solver: Solver,
    /// State, minute count, eating bookkeeping and last input.
    now: MinuteState,
}

impl Patient {
    /// A patient at its initial state (`x0`, a steady state at basal for
    /// every public patient), minute 0, nothing eaten yet.
    pub fn new(params: PatientParams) -> Result<Self, SimError> {
        Self::with_solver(params, Solver::DEFAULT)
    }

    /// Like [`Patient::new`] with a chosen solver.
    pub fn with_solver(params: PatientParams, solver: Solver) -> Result<Self, SimError> {
        params.validate()?;
        if solver.substeps == 0 || solver.busy_substeps == 0 {
            return Err(SimError::Config(
                "solver sub-steps per minute must be >= 1".into(),
            ));
        }
        if !(solver.tanh_window.is_finite() && solver.tanh_window >= 0.0) {
            return Err(SimError::Config(
                "solver tanh_window must be a finite number >= 0".into(),
            ));
        }
        let consts = ModelConsts::from_params(&params);
        Ok(Self {
            now: MinuteState {
                x: params.x0,
                minute: 0,
                last_cho_g_per_min: 0.0,
                last_q_sto_mg: 0.0,
                last_food_taken_g: 0.0,
                last_input: MinuteInput::new(&consts, 0.0, 0.0, 0.0, 1.0),
            },
            consts: Arc::new(consts),
            params,
            solver,
        })
    }

    /// The patient's parameters.
    pub fn params(&self) -> &PatientParams {
        &self.params
    }

    /// The model's constants, derived from the parameters.
    pub fn consts(&self) -> &ModelConsts {
        &self.consts
    }

    /// The solver.
    pub fn solver(&self) -> Solver {
        self.solver
    }

    /// Where the patient stands between two minutes.
    pub fn minute_state(&self) -> MinuteState {
        self.now
    }

    /// The patient continued from `state` (as another stepper left it);
    /// refused when a state is not finite.
    pub fn with_minute_state(mut self, state: MinuteState) -> Result<Self, SimError> {
        if let Some(k) = state.x.iter().position(|v| !v.is_finite()) {
            return Err(SimError::NonFinite {
                patient: self.params.name.clone(),
                minute: state.minute,
                state: PatientState::NAMES[k].to_string(),
            });
        }
        self.now = state;
        Ok(self)
    }

    /// Minutes simulated so far.
    pub fn minute(&self) -> i64 {
        self.now.minute
    }

    /// The current state.
    pub fn state(&self) -> PatientState {
        PatientState::from_array(&self.now.x)
    }

    /// The current state as the solver's array (x1..x13).
    pub fn state_array(&self) -> &[f64; 13] {
        &self.now.x
    }

    /// True plasma glucose G = Gp/Vg (mg/dL).
    pub fn glucose_mg_dl(&self) -> f64 {
        self.now.x[model::ix::GP] / self.params.vg
    }

    /// Subcutaneous glucose Gs/Vg (mg/dL): what a CGM reads.
    pub fn subcutaneous_glucose_mg_dl(&self) -> f64 {
        self.now.x[model::ix::GS] / self.params.vg
    }

    /// Dbar (mg) of the gastric-emptying law as it stands now (the value
    /// used for the last integrated minute).
    pub fn dbar_mg(&self) -> f64 {
        self.now.last_q_sto_mg + MG_PER_G * self.now.last_food_taken_g
    }

    /// Advances one minute with carbohydrate eaten at `cho_g_per_min`
    /// (g/min, already through the 5 g/min eating queue) and insulin infused
    /// at `insulin_u_per_min` (U/min, basal plus bolus), both constant over
    /// the minute, and insulin sensitivity `sensitivity` (1 = nominal).
    pub fn step(
        &mut self,
        cho_g_per_min: f64,
        insulin_u_per_min: f64,
        sensitivity: f64,
    ) -> Result<(), SimError> {
        self.begin_minute(cho_g_per_min, insulin_u_per_min, sensitivity)?;
        self.solver
            .advance_minute(&self.consts, &self.now.last_input, &mut self.now.x);
        self.end_minute()
    }

    /// As [`Patient::step`], with separate sensitivity multipliers on Vmx
    /// (insulin-dependent utilisation, `sensitivity`) and on kp3 (the
    /// liver's insulin action, `egp_sensitivity`).
    pub fn step_split(
        &mut self,
        cho_g_per_min: f64,
        insulin_u_per_min: f64,
        sensitivity: f64,
        egp_sensitivity: f64,
    ) -> Result<(), SimError> {
        if !(egp_sensitivity.is_finite() && egp_sensitivity > 0.0) {
            return Err(self.bad_input(cho_g_per_min, insulin_u_per_min, egp_sensitivity));
        }
        self.begin_minute(cho_g_per_min, insulin_u_per_min, sensitivity)?;
        // (The next minute's input recomputes s·kp3 from its own sensitivity.)
        self.now.last_input.s_kp3 = egp_sensitivity * self.consts.kp3;
        self.solver
            .advance_minute(&self.consts, &self.now.last_input, &mut self.now.x);
        self.end_minute()
    }

    /// [`Patient::step_split`] sharing the gut's work with other runs of
    /// this patient through `tape` ([`GutTape`]): the same result, bit for
    /// bit.
    pub fn step_split_shared(
        &mut self,
        cho_g_per_min: f64,
        insulin_u_per_min: f64,
        sensitivity: f64,
        egp_sensitivity: f64,
        tape: &mut GutTape,
    ) -> Result<(), SimError> {
        self.begin_step(SplitInput {
            cho_g_per_min,
            insulin_u_per_min,
            sensitivity,
            egp_sensitivity,
        })?;
        self.solver.advance_minute_shared(
            &self.consts,
            &self.now.last_input,
            &mut self.now.x,
            tape,
        );
        self.end_minute()
    }

    /// [`Patient::step_split_shared`] for `W` runs at once, in order: the
    /// same results, bit for bit, but when all are this patient eating the
    /// same, their bodies are integrated side by side as one `T` ([`Pair`];
    /// [`Solver::advance_side_shared`]), in about the time of one. When a
    /// run's inputs are refused, the runs before it have taken their
    /// minute (as they would have one by one) and the others have not.
    pub fn step_split_shared_side<T: Side<W>, const W: usize>(
        mut runs: [&mut Patient; W],
        inputs: [SplitInput; W],
        tape: &mut GutTape,
    ) -> Result<(), SimError> {
        for k in 0..W {
            if let Err(e) = runs[k].begin_step(inputs[k]) {
                for run in &mut runs[..k] {
                    run.integrate_shared(tape);
                    run.end_minute()?;
                }
                return Err(e);
            }
        }
        Self::integrate_side_shared::<T, W>(&mut runs, tape);
        let mut ended = Ok(());
        for run in runs {
            ended = ended.and(run.end_minute());
        }
        ended
    }

    /// Integrates the minute begun by [`Patient::begin_step`] of every run,
    /// sharing the gut through `tape`; side by side when they are the same
    /// patient with the same solver, else one after the other.
    #[inline]
    pub(crate) fn integrate_side_shared<T: Side<W>, const W: usize>(
        runs: &mut [&mut Patient; W],
        tape: &mut GutTape,
    ) {
        let (first, rest) = runs.split_at_mut(1);
        let first = &first[0];
        let mut same = true;
        for run in rest.iter_mut() {
            // Equal constants are shared from the first time (one pointer
            // comparison a minute after that, not forty values).
            let same_consts = Arc::ptr_eq(&first.consts, &run.consts) || {
                let equal = *first.consts == *run.consts;
                if equal {
                    run.consts = Arc::clone(&first.consts);
                }
                equal
            };
            same &= same_consts && run.solver == first.solver;
        }
        if !same {
            for run in runs.iter_mut() {
                run.integrate_shared(tape);
            }
            return;
        }
        let solver = runs[0].solver;
        // Each run's constants (shared) and state, borrowed apart (no
        // reference count touched in the minute).
        let parts = runs.each_mut().map(|run| {
            let Patient { consts, now, .. } = &mut **run;
            let MinuteState { x, last_input, .. } = now;
            (&**consts, &*last_input, x)
        });
        let consts = parts[0].0;
        let inputs = parts.each_ref().map(|(_, input, _)| *input);
        let states = parts.map(|(_, _, x)| x);
        solver.advance_side_shared::<T, W>(consts, inputs, states, tape);
    }

    /// The part of [`Patient::step_split`] before the integration: checks
    /// and books the minute's inputs.
    #[inline]
    pub(crate) fn begin_step(&mut self, i: SplitInput) -> Result<(), SimError> {
        if !(i.egp_sensitivity.is_finite() && i.egp_sensitivity > 0.0) {
            return Err(self.bad_input(i.cho_g_per_min, i.insulin_u_per_min, i.egp_sensitivity));
        }
        self.begin_minute(i.cho_g_per_min, i.insulin_u_per_min, i.sensitivity)?;
        // (The next minute's input recomputes s·kp3 from its own sensitivity.)
        self.now.last_input.s_kp3 = i.egp_sensitivity * self.consts.kp3;
        Ok(())
    }

    /// Integrates the minute begun by [`Patient::begin_step`], sharing the
    /// gut through `tape`.
    #[inline]
    pub(crate) fn integrate_shared(&mut self, tape: &mut GutTape) {
        self.solver.advance_minute_shared(
            &self.consts,
            &self.now.last_input,
            &mut self.now.x,
            tape,
        );
    }

    /// Checks the minute's inputs, updates the eating-episode bookkeeping
    /// and puts what the solver holds constant over the minute in
    /// `last_input` (written in place: a returned copy of the struct cost
    /// measurable time in the trial's profile).
    #[inline]
    pub(crate) fn begin_minute(
        &mut self,
        cho_g_per_min: f64,
        insulin_u_per_min: f64,
        sensitivity: f64,
    ) -> Result<(), SimError> {
        check_input(
            &self.params.name,
            self.now.minute,
            cho_g_per_min,
            insulin_u_per_min,
            sensitivity,
        )?;
        // Eating-episode bookkeeping (§1.4): an episode starts when eating
        // follows a minute without eating; the stomach content is read
        // before this minute is integrated, and this minute's grams count.
        if cho_g_per_min > 0.0 {
            if self.now.last_cho_g_per_min <= 0.0 {
                self.now.last_q_sto_mg =
                    self.now.x[model::ix::Q_STO1] + self.now.x[model::ix::Q_STO2];
                self.now.last_food_taken_g = 0.0;
            }
            self.now.last_food_taken_g += cho_g_per_min;
        }
        self.now.last_cho_g_per_min = cho_g_per_min;
        self.now.last_input = self.now.last_input.next(
            &self.consts,
            cho_g_per_min,
            insulin_u_per_min,
            self.dbar_mg(),
            sensitivity,
        );
        Ok(())
    }

    /// Counts the minute and checks that the state stayed finite.
    #[inline]
    pub(crate) fn end_minute(&mut self) -> Result<(), SimError> {
        self.now.minute += 1;
        // One branch-free test of all states first (the search below
        // branched on each of the 13 every minute).
        if !self.now.x.iter().fold(false, |bad, v| bad | !v.is_finite()) {
            return Ok(());
        }
        if let Some(k) = self.now.x.iter().position(|v| !v.is_finite()) {
            return Err(SimError::NonFinite {
                patient: self.params.name.clone(),
                minute: self.now.minute,
                state: PatientState::NAMES[k].to_string(),
            });
        }
        Ok(())
    }

    fn bad_input(&self, cho: f64, ins: f64, s: f64) -> SimError {
        bad_input(&self.params.name, self.now.minute, cho, ins, s)
    }
}

/// Checks one minute's inputs of a patient (`name`, at `minute`): rates
/// finite and >= 0, sensitivity finite and > 0.
#[inline]
pub fn check_input(name: &str, minute: i64, cho: f64, ins: f64, s: f64) -> Result<(), SimError> {
    if input_is_valid(cho, ins, s) {
        Ok(())
    } else {
        Err(bad_input(name, minute, cho, ins, s))
    }
}

/// True when one minute's inputs are valid (see [`check_input`]).
#[inline(always)]
pub fn input_is_valid(cho: f64, ins: f64, s: f64) -> bool {
    cho.is_finite() && cho >= 0.0 && ins.is_finite() && ins >= 0.0 && s.is_finite() && s > 0.0
}

#[cold]
fn bad_input(name: &str, minute: i64, cho: f64, ins: f64, s: f64) -> SimError {
    let reason = if !(cho.is_finite() && cho >= 0.0) {
        format!("carbohydrate rate must be a finite number >= 0 g/min, got {cho}")
    } else if !(ins.is_finite() && ins >= 0.0) {
        format!("insulin rate must be a finite number >= 0 U/min, got {ins}")
    } else {
        format!("insulin sensitivity must be a finite number > 0, got {s}")
    };
    SimError::InvalidInput {
        patient: name.to_string(),
        minute,
        reason,
    }
}
