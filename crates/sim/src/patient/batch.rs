//! Many independent patients advanced minute by minute in lockstep.
//!
//! [`PatientBatch::step`] gives every patient exactly the result of
//! [`Patient::step`] (bit for bit: the same operations in the same order),
//! but integrates quiet minutes of [`LANES`] patients together, stage by
//! stage, so that their dependency chains overlap. A single patient's RK4
//! step is a chain of dependent operations (each stage waits on the exp and
//! divisions of the previous one), so one patient at a time leaves most of
//! the processor idle.

use super::solver::rk4_step_lanes;
use super::{MinuteInput, Patient};
use crate::inputs::MinuteRates;
use crate::SimError;

/// Patients integrated together.
pub const LANES: usize = 4;

/// Independent patients stepped together (see the module docs).
#[derive(Debug, Clone)]
pub struct PatientBatch {
    patients: Vec<Patient>,
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
        Ok(Self { patients })
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
        let mut chunks = self.patients.chunks_exact_mut(LANES);
        let mut offset = 0;
        for chunk in &mut chunks {
            let lanes: &mut [Patient; LANES] = chunk
                .try_into()
                .map_err(|_| SimError::Config("batch chunk size".into()))?;
            step_lanes(
                lanes,
                &rates[offset..offset + LANES],
                &sensitivity[offset..offset + LANES],
            )?;
            offset += LANES;
        }
        for (k, p) in chunks.into_remainder().iter_mut().enumerate() {
            let r = rates[offset + k];
            p.step(r.cho_g_per_min, r.insulin_u_per_min, sensitivity[offset + k])?;
        }
        Ok(())
    }
}

/// One minute of [`LANES`] patients. Minutes that need the quiet number of
/// sub-steps in every lane are integrated together; otherwise each lane
/// takes its own path.
fn step_lanes(
    lanes: &mut [Patient; LANES],
    rates: &[MinuteRates],
    sensitivity: &[f64],
) -> Result<(), SimError> {
    let mut u = [MinuteInput::default(); LANES];
    for (l, p) in lanes.iter_mut().enumerate() {
        u[l] = p.begin_minute(
            rates[l].cho_g_per_min,
            rates[l].insulin_u_per_min,
            sensitivity[l],
        )?;
    }
    let solver = lanes[0].solver;
    let quiet = lanes
        .iter()
        .zip(&u)
        .all(|(p, u)| solver.substeps_for(&p.consts, u, &p.x) == solver.substeps.max(1));
    if quiet {
        let n = solver.substeps.max(1);
        let h = 1.0 / n as f64;
        let c = [0, 1, 2, 3].map(|l| &lanes[l].consts);
        let ur = [0, 1, 2, 3].map(|l| &u[l]);
        let mut x = [0, 1, 2, 3].map(|l| lanes[l].x);
        for _ in 0..n {
            rk4_step_lanes(&c, &ur, &mut x, h);
        }
        for (p, xl) in lanes.iter_mut().zip(x) {
            p.x = xl;
        }
    } else {
        for (p, ul) in lanes.iter_mut().zip(&u) {
            p.solver.advance_minute(&p.consts, ul, &mut p.x);
        }
    }
    for p in lanes.iter_mut() {
        p.end_minute()?;
    }
    Ok(())
}
