//! Integration of one minute with inputs held constant.
//!
//! The default is the classic fixed-step fourth-order Runge-Kutta method
//! with a configurable number of equal sub-steps per minute. Accuracy and
//! cost of the choices are measured in `BENCHMARKS.md`; the default is the
//! cheapest one that stays an order of magnitude inside the 0.05 mg/dL
//! agreement with simglucose's adaptive Dormand-Prince solver.

use super::model::{derivatives, MinuteInput, ModelConsts};
use serde::{Deserialize, Serialize};

/// How one minute is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Solver {
    /// Number of equal RK4 sub-steps per minute (1 = h of one minute).
    pub substeps: u32,
}

impl Solver {
    /// The default solver (see the module docs and BENCHMARKS.md).
    pub const DEFAULT: Solver = Solver { substeps: 2 };
    /// A reference-grade solver for tests: RK4 with h = 1/64 min
    /// (error below 1e-8 mg/dL on the reference days).
    pub const REFERENCE: Solver = Solver { substeps: 64 };

    /// Advances `x` by one minute under the constant input `u`.
    #[inline]
    pub fn advance_minute(&self, c: &ModelConsts, u: &MinuteInput, x: &mut [f64; 13]) {
        let n = self.substeps.max(1);
        let h = 1.0 / n as f64;
        for _ in 0..n {
            rk4_step(c, u, x, h);
        }
    }
}

impl Default for Solver {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[inline]
fn rk4_step(c: &ModelConsts, u: &MinuteInput, x: &mut [f64; 13], h: f64) {
    let k1 = derivatives(c, u, x);
    let mut y = [0.0; 13];
    for i in 0..13 {
        y[i] = x[i] + 0.5 * h * k1[i];
    }
    let k2 = derivatives(c, u, &y);
    for i in 0..13 {
        y[i] = x[i] + 0.5 * h * k2[i];
    }
    let k3 = derivatives(c, u, &y);
    for i in 0..13 {
        y[i] = x[i] + h * k3[i];
    }
    let k4 = derivatives(c, u, &y);
    for i in 0..13 {
        x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
}
