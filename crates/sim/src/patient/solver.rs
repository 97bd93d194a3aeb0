//! Integration of one minute with inputs held constant.
//!
//! The default is the classic fixed-step fourth-order Runge-Kutta method
//! with a configurable number of equal sub-steps per minute. Accuracy and
//! cost of the choices are measured in `BENCHMARKS.md`; the default is the
//! cheapest one that stays an order of magnitude inside the 0.05 mg/dL
//! agreement with simglucose's adaptive Dormand-Prince solver.

use super::lanes::Real;
use super::model::{derivatives, MinuteInput, ModelConsts};
use serde::{Deserialize, Serialize};

/// How one minute is integrated.
///
/// RK4 with `substeps` equal sub-steps per minute, except in minutes where
/// the gastric-emptying rate kempt is in its steep transition (or the
/// patient is eating): those use `busy_substeps`. kempt switches between
/// kmax and kmin through two tanh terms whose steepness grows with
/// 1/(1 − b) and 1/d; with b close to 1 (many public patients) the switch
/// takes a few minutes, and a fixed one-minute step misses its shape.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Solver {
    /// Number of equal RK4 sub-steps per quiet minute (1 = h of one minute).
    pub substeps: u32,
    /// Number of sub-steps in a minute where the gut is busy.
    pub busy_substeps: u32,
    /// A minute is busy when the patient eats, or when either tanh argument
    /// of kempt is within this distance of 0 (widened by how far it can
    /// move in the minute) and moving faster than `tanh_rate` per minute.
    pub tanh_window: f64,
    /// Bound on the change of a tanh argument per minute below which one
    /// quiet step is accurate enough.
    pub tanh_rate: f64,
}

impl Solver {
    /// The default solver (see the module docs and BENCHMARKS.md).
    pub const DEFAULT: Solver = Solver {
        substeps: 1,
        busy_substeps: 4,
        tanh_window: 3.0,
        tanh_rate: 0.3,
    };
    /// A reference-grade solver for tests: RK4 with h = 1/64 min everywhere.
    pub const REFERENCE: Solver = Solver::fixed(64);

    /// Plain RK4 with `n` equal sub-steps in every minute.
    pub const fn fixed(n: u32) -> Solver {
        Solver {
            substeps: n,
            busy_substeps: n,
            tanh_window: 0.0,
            tanh_rate: 0.0,
        }
    }

    /// Advances `x` by one minute under the constant input `u`.
    #[inline]
    pub fn advance_minute(&self, c: &ModelConsts, u: &MinuteInput, x: &mut [f64; 13]) {
        let n = self.substeps_for(c, u, x);
        let h = 1.0 / n as f64;
        for _ in 0..n {
            rk4_step(c, u, x, h);
        }
    }

    /// The number of RK4 sub-steps for this minute.
    #[inline]
    pub(crate) fn substeps_for(&self, c: &ModelConsts, u: &MinuteInput, x: &[f64; 13]) -> u32 {
        if self.busy_substeps != self.substeps && self.gut_is_busy(c, u, x) {
            self.busy_substeps
        } else {
            self.substeps
        }
        .max(1)
    }
}

impl Default for Solver {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Solver {
    /// True when food enters the stomach this minute, or when a tanh
    /// argument of kempt is near 0 and moving fast: the stomach content
    /// Qsto falls at most at kmax·Qsto2 mg/min without eating, so each
    /// argument moves at most (its slope)·kmax·Qsto2 per minute.
    #[inline]
    fn gut_is_busy(&self, c: &ModelConsts, u: &MinuteInput, x: &[f64; 13]) -> bool {
        if u.meal_mg_per_min > 0.0 {
            return true;
        }
        if u.dbar_mg <= 0.0 || x[1] == 0.0 {
            return false;
        }
        let q_sto = x[0] + x[1];
        let q_rate = c.kmax * x[1].abs() + c.kmax * x[0].abs();
        let near = |slope: f64, centre: f64| {
            let moves = slope * q_rate;
            moves > self.tanh_rate && (slope * (q_sto - centre)).abs() < self.tanh_window + moves
        };
        near(u.alpha, c.b * u.dbar_mg) || near(u.beta, c.d * u.dbar_mg)
    }
}

/// One classic RK4 step of length `h` for one patient (`T = f64`) or
/// several side by side (`T = Lanes`).
#[inline(always)]
pub(crate) fn rk4_step<T: Real>(c: &ModelConsts<T>, u: &MinuteInput<T>, x: &mut [T; 13], h: f64) {
    let k1 = derivatives(c, u, x);
    let mut y = *x;
    for i in 0..13 {
        y[i] = x[i] + k1[i] * (0.5 * h);
    }
    let k2 = derivatives(c, u, &y);
    for i in 0..13 {
        y[i] = x[i] + k2[i] * (0.5 * h);
    }
    let k3 = derivatives(c, u, &y);
    for i in 0..13 {
        y[i] = x[i] + k3[i] * h;
    }
    let k4 = derivatives(c, u, &y);
    for i in 0..13 {
        x[i] = x[i] + (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0);
    }
}
