//! Integration of one minute with inputs held constant.
//!
//! The default is the classic fixed-step fourth-order Runge-Kutta method
//! with a configurable number of equal sub-steps per minute. Accuracy and
//! cost of the choices are measured in `BENCHMARKS.md`; the default is the
//! cheapest one that stays an order of magnitude inside the 0.05 mg/dL
//! agreement with simglucose's adaptive Dormand-Prince solver.

use super::lanes::Real;
use super::model::{
    body_derivatives, derivatives_given_kempt, gut_derivatives, kempt_at, MinuteInput, ModelConsts,
};
#[cfg(doc)]
use super::pair::Pair;
use super::pair::Side;
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

/// The gut's part of one integrated minute, to be shared by runs whose gut
/// is in the same state.
///
/// The gut (Qsto1, Qsto2, Qgut) is a closed subsystem: its derivatives, the
/// gastric emptying rate kempt at each RK4 stage and the busy-gut sub-step
/// count depend only on the gut's three states, the minute's meal input and
/// Dbar, the patient's gut parameters and the solver. Runs of one patient
/// that eat the same (the trial's arms and scenarios, until a rescue snack
/// or a skipped meal tells them apart) therefore compute the same gut
/// minute, bit for bit; kempt (two exp and two divisions per evaluation) is
/// most of the cost of a step. [`Solver::advance_minute_shared`] records
/// the first run's minute (Qgut at every stage, the gut's state at the
/// end) and replays it for the others when the key matches: they
/// integrate only the states after the gut, reading Qgut from the tape
/// (`model::body_derivatives`), with the same operations as the full step.
#[derive(Debug, Clone, Default)]
pub struct GutTape {
    key: Option<GutKey>,
    /// Sub-steps of the recorded minute.
    substeps: u32,
    /// Qgut at every RK4 stage of the recorded minute, in order.
    q_gut: Vec<f64>,
    /// Qsto1, Qsto2 and Qgut at the end of the recorded minute.
    end: [f64; 3],
    /// Minutes replayed (for benchmarks and tests).
    replays: u64,
}

/// Everything the gut's minute depends on, as bits (the slopes α and β of
/// kempt are functions of Dbar, b and d; Qgut and kabs enter Qgut's own
/// equation). Test: `gut_tape_tells_runs_with_different_qgut_apart`.
#[derive(Debug, Clone, Copy)]
struct GutKey {
    bits: [u64; 10],
    solver: Solver,
}

impl GutKey {
    #[inline]
    fn of(solver: Solver, c: &ModelConsts, u: &MinuteInput, x: &[f64; 13]) -> Self {
        Self {
            bits: [
                x[0],
                x[1],
                x[2],
                u.meal_mg_per_min,
                u.dbar_mg,
                c.kmax,
                c.kmin,
                c.b,
                c.d,
                c.kabs,
            ]
            .map(f64::to_bits),
            solver,
        }
    }

    /// Equal bits and solver (written out: the derived comparison called
    /// `memcmp` once a minute per run, which showed in the profile).
    #[inline]
    fn matches(&self, other: &GutKey) -> bool {
        let mut diff = 0;
        for i in 0..10 {
            diff |= self.bits[i] ^ other.bits[i];
        }
        diff == 0 && self.solver == other.solver
    }
}

impl GutTape {
    /// An empty tape.
    pub fn new() -> Self {
        Self::default()
    }

    /// Minutes whose gut was replayed instead of computed.
    pub fn replays(&self) -> u64 {
        self.replays
    }
}

impl Solver {
    /// [`Solver::advance_minute`], sharing the gut's work through `tape`
    /// (see [`GutTape`]): bit-identical to `advance_minute`.
    pub fn advance_minute_shared(
        &self,
        c: &ModelConsts,
        u: &MinuteInput,
        x: &mut [f64; 13],
        tape: &mut GutTape,
    ) {
        let key = GutKey::of(*self, c, u, x);
        if tape.key.is_some_and(|k| k.matches(&key)) {
            // The gut's minute is the recorded one, bit for bit: only the
            // rest of the body is integrated, reading Qgut at each stage
            // from the tape.
            let n = tape.substeps;
            let h = 1.0 / n as f64;
            for q in tape.q_gut.chunks_exact(4).take(n as usize) {
                rk4_body_step(c, u, x, h, [q[0], q[1], q[2], q[3]]);
            }
            x[0] = tape.end[0];
            x[1] = tape.end[1];
            x[2] = tape.end[2];
            tape.replays += 1;
            return;
        }
        let n = self.substeps_for(c, u, x);
        let h = 1.0 / n as f64;
        tape.q_gut.clear();
        for _ in 0..n {
            rk4_step_with(c, u, x, h, |y| {
                tape.q_gut.push(y[2]);
                kempt_at(c, u, y)
            });
        }
        tape.substeps = n;
        tape.end = [x[0], x[1], x[2]];
        tape.key = Some(key);
    }

    /// [`Solver::advance_minute_shared`] for `W` runs of one patient (the
    /// same `c`) at once, `T` holding one value of each ([`Pair`]): when
    /// all eat the same this minute (their gut keys match), the gut's
    /// minute is computed once (or taken from the tape) and their bodies
    /// are integrated side by side, which a core steps in about the time
    /// of one (see [`super::pair`]). Otherwise each goes alone, in order.
    /// Bit-identical to `advance_minute_shared` on each run in order.
    pub fn advance_side_shared<T: Side<W>, const W: usize>(
        &self,
        c: &ModelConsts,
        u: [&MinuteInput; W],
        mut x: [&mut [f64; 13]; W],
        tape: &mut GutTape,
    ) {
        let key = GutKey::of(*self, c, u[0], x[0]);
        if !(1..W).all(|l| GutKey::of(*self, c, u[l], x[l]).matches(&key)) {
            for (u, x) in u.into_iter().zip(x) {
                self.advance_minute_shared(c, u, x, tape);
            }
            return;
        }
        if tape.key.is_some_and(|k| k.matches(&key)) {
            tape.replays += W as u64;
        } else {
            // The gut's minute alone, as the full step computes it (the
            // gut reads no other state), recorded for these runs and later
            // ones; the first run's body is then integrated from the tape
            // like the others'.
            self.record_gut(c, u[0], x[0], tape);
            tape.key = Some(key);
            tape.replays += W as u64 - 1;
        }
        let n = tape.substeps;
        let h = 1.0 / n as f64;
        let cw = ModelConsts::gather_with([c], |[v]| T::splat(v));
        let uw = MinuteInput::gather_with(u, T::from_lanes);
        let mut xw: [T; 13] =
            std::array::from_fn(|i| T::from_lanes(std::array::from_fn(|l| x[l][i])));
        for q in tape.q_gut.chunks_exact(4).take(n as usize) {
            rk4_body_step(&cw, &uw, &mut xw, h, [q[0], q[1], q[2], q[3]].map(T::splat));
        }
        for (i, v) in xw.iter().enumerate().skip(3) {
            for (l, run) in v.lanes().into_iter().enumerate() {
                x[l][i] = run;
            }
        }
        for run in x.iter_mut() {
            run[..3].copy_from_slice(&tape.end);
        }
    }

    /// Integrates the gut's minute (Qsto1, Qsto2, Qgut) from state `x`
    /// alone into `tape` (sub-steps, Qgut at every RK4 stage, the end
    /// state), with the same operations on those states as the full step
    /// ([`rk4_step`]): the gut is a closed subsystem. `x` is not changed.
    fn record_gut(&self, c: &ModelConsts, u: &MinuteInput, x: &[f64; 13], tape: &mut GutTape) {
        let n = self.substeps_for(c, u, x);
        let h = 1.0 / n as f64;
        tape.q_gut.clear();
        // The gut's states in a full state vector (the rest zero: nothing
        // the gut's equations read).
        let mut g = [0.0; 13];
        g[..3].copy_from_slice(&x[..3]);
        for _ in 0..n {
            let stage = |y: &[f64; 13], q: &mut Vec<f64>| {
                q.push(y[2]);
                gut_derivatives(c, u, y, kempt_at(c, u, y))
            };
            let k1 = stage(&g, &mut tape.q_gut);
            let mut y = g;
            for i in 0..3 {
                y[i] = g[i] + k1[i] * (0.5 * h);
            }
            let k2 = stage(&y, &mut tape.q_gut);
            for i in 0..3 {
                y[i] = g[i] + k2[i] * (0.5 * h);
            }
            let k3 = stage(&y, &mut tape.q_gut);
            for i in 0..3 {
                y[i] = g[i] + k3[i] * h;
            }
            let k4 = stage(&y, &mut tape.q_gut);
            for i in 0..3 {
                g[i] += (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0);
            }
        }
        tape.substeps = n;
        tape.end = [g[0], g[1], g[2]];
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
    rk4_step_with(c, u, x, h, |y| kempt_at(c, u, y));
}

/// [`rk4_step`] taking each stage's kempt from `kempt` (called once per
/// stage, in order, with the stage's state).
#[inline(always)]
fn rk4_step_with<T: Real>(
    c: &ModelConsts<T>,
    u: &MinuteInput<T>,
    x: &mut [T; 13],
    h: f64,
    mut kempt: impl FnMut(&[T; 13]) -> T,
) {
    let k1 = derivatives_given_kempt(c, u, x, kempt(x));
    let mut y = *x;
    for i in 0..13 {
        y[i] = x[i] + k1[i] * (0.5 * h);
    }
    let k2 = derivatives_given_kempt(c, u, &y, kempt(&y));
    for i in 0..13 {
        y[i] = x[i] + k2[i] * (0.5 * h);
    }
    let k3 = derivatives_given_kempt(c, u, &y, kempt(&y));
    for i in 0..13 {
        y[i] = x[i] + k3[i] * h;
    }
    let k4 = derivatives_given_kempt(c, u, &y, kempt(&y));
    for i in 0..13 {
        x[i] = x[i] + (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0);
    }
}

/// The part of [`rk4_step`] after the gut (states 3..13), with Qgut at
/// each of the four stages given: the same operations on those states as
/// the full step, so the same bits.
#[inline(always)]
fn rk4_body_step<T: Real>(
    c: &ModelConsts<T>,
    u: &MinuteInput<T>,
    x: &mut [T; 13],
    h: f64,
    q_gut: [T; 4],
) {
    let k1 = body_derivatives(c, u, x, q_gut[0]);
    let mut y = *x;
    for i in 0..10 {
        y[i + 3] = x[i + 3] + k1[i] * (0.5 * h);
    }
    let k2 = body_derivatives(c, u, &y, q_gut[1]);
    for i in 0..10 {
        y[i + 3] = x[i + 3] + k2[i] * (0.5 * h);
    }
    let k3 = body_derivatives(c, u, &y, q_gut[2]);
    for i in 0..10 {
        y[i + 3] = x[i + 3] + k3[i] * h;
    }
    let k4 = body_derivatives(c, u, &y, q_gut[3]);
    for i in 0..10 {
        x[i + 3] = x[i + 3] + (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * (h / 6.0);
    }
}
