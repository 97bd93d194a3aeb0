//! Many independent patients advanced minute by minute in lockstep, in a
//! structure-of-arrays layout that the compiler vectorises.
//!
//! A single patient's RK4 step is a chain of dependent operations (each
//! stage waits on the exp and divisions of the previous one), so one
//! patient at a time leaves most of the processor idle. [`PatientBatch`]
//! integrates [`LANES`] patients at once with the same equations
//! (`model::derivatives` over [`Lanes`]): one vector instruction does the
//! work of several patients, and their chains overlap.
//!
//! Each lane takes the sub-steps its own patient would take
//! ([`super::Solver`]'s busy-gut rule), so a batch differs from
//! [`Patient::step`] only in the exp of kempt's two tanh
//! ([`super::lanes::exp_small`], within 2 ulp of libm's): the glucose of a
//! batch stays within 1e-9 mg/dL of one-by-one stepping (test
//! `batch_matches_one_by_one`; measured 3e-13 mg/dL).

use super::lanes::Lanes;
use super::solver::rk4_step;
use super::{MinuteInput, ModelConsts, Patient};
use crate::inputs::MinuteRates;
use crate::SimError;

/// Patients integrated together.
pub const LANES: usize = 8;

/// Independent patients stepped together (see the module docs).
#[derive(Debug, Clone)]
pub struct PatientBatch {
    patients: Vec<Patient>,
    /// The constants of each full group of [`LANES`] patients, side by side.
    consts: Vec<ModelConsts<Lanes<LANES>>>,
}

impl PatientBatch {
    /// A batch of patients; they must share one solver.
    pub fn new(patients: Vec<Patient>) -> Result<Self, SimError> {
        if let Some(first) = patients.first() {
            if patients.iter().any(|p| p.solver != first.solver) {
                return Err(SimError::Config(
                    "the patients of a batch must share one solver".into(),
                ));
            }
        }
        let consts = patients
            .chunks_exact(LANES)
            .map(|g| ModelConsts::gather(std::array::from_fn(|l| &g[l].consts)))
            .collect();
        Ok(Self { patients, consts })
    }

    /// The patients, in the order given.
    pub fn patients(&self) -> &[Patient] {
        &self.patients
    }

    /// Number of patients.
    pub fn len(&self) -> usize {
        self.patients.len()
    }

    /// True when the batch has no patients.
    pub fn is_empty(&self) -> bool {
        self.patients.is_empty()
    }

    /// Advances every patient one minute: patient `i` with `rates[i]` and
    /// insulin sensitivity `sensitivity[i]`, as [`Patient::step`] would.
    pub fn step(&mut self, rates: &[MinuteRates], sensitivity: &[f64]) -> Result<(), SimError> {
        if rates.len() != self.patients.len() || sensitivity.len() != self.patients.len() {
            return Err(SimError::Config(format!(
                "a batch of {} patients needs as many inputs, got {} rates and {} sensitivities",
                self.patients.len(),
                rates.len(),
                sensitivity.len()
            )));
        }
        let mut groups = self.patients.chunks_exact_mut(LANES);
        for ((g, c), (r, s)) in (&mut groups).zip(&self.consts).zip(
            rates
                .chunks_exact(LANES)
                .zip(sensitivity.chunks_exact(LANES)),
        ) {
            step_group(g, c, r, s)?;
        }
        let done = self.consts.len() * LANES;
        for (k, p) in groups.into_remainder().iter_mut().enumerate() {
            let r = rates[done + k];
            p.step(r.cho_g_per_min, r.insulin_u_per_min, sensitivity[done + k])?;
        }
        Ok(())
    }
}

/// One minute of a group of [`LANES`] patients: the lanes whose gut is
/// quiet this minute together, then (if any) the busy ones together.
fn step_group(
    group: &mut [Patient],
    consts: &ModelConsts<Lanes<LANES>>,
    rates: &[MinuteRates],
    sensitivity: &[f64],
) -> Result<(), SimError> {
    let mut u = [MinuteInput::new(&group[0].consts, 0.0, 0.0, 0.0, 1.0); LANES];
    let mut busy = [false; LANES];
    let solver = group[0].solver;
    let quiet_n = solver.substeps.max(1);
    let busy_n = solver.busy_substeps.max(1);
    for (l, p) in group.iter_mut().enumerate() {
        p.begin_minute(
            rates[l].cho_g_per_min,
            rates[l].insulin_u_per_min,
            sensitivity[l],
        )?;
        u[l] = *p.minute_input();
        busy[l] = solver.substeps_for(&p.consts, &u[l], &p.x) == busy_n && busy_n != quiet_n;
    }
    let ul = MinuteInput::gather(std::array::from_fn(|l| &u[l]));
    let x0: [Lanes<LANES>; 13] =
        std::array::from_fn(|i| Lanes(std::array::from_fn(|l| group[l].x[i])));
    // One pass per sub-step count in use: every lane is integrated, and a
    // lane keeps the result of the pass that matches its own count.
    for (n, wanted) in [(quiet_n, false), (busy_n, true)] {
        if !busy.contains(&wanted) {
            continue;
        }
        let mut x = x0;
        let h = 1.0 / f64::from(n);
        for _ in 0..n {
            rk4_step(consts, &ul, &mut x, h);
        }
        for (l, p) in group.iter_mut().enumerate() {
            if busy[l] == wanted {
                p.x = std::array::from_fn(|i| x[i].0[l]);
            }
        }
    }
    for p in group.iter_mut() {
        p.end_minute()?;
    }
    Ok(())
}
