//! Many independent patients advanced minute by minute in lockstep, in a
//! structure-of-arrays layout that the compiler vectorises.
//!
//! A single patient's RK4 step is a chain of dependent operations (each
//! stage waits on the exp and divisions of the previous one), so one
//! patient at a time leaves most of the processor idle. [`PatientBatch`]
//! keeps [`LANES`] patients side by side for good: their states, the
//! minute's inputs, the eating-episode bookkeeping that defines Dbar and
//! the busy-gut test are all [`Lanes`] values, and the model's equations
//! (`model::derivatives` over [`Lanes`]) do the work of [`LANES`] patients
//! per instruction. Nothing is copied between a patient's own layout and
//! the lanes' from one minute to the next (an earlier version did, and
//! gained nothing over stepping the patients one by one).
//!
//! Busy minutes ([`Solver`]'s busy-gut rule: eating, or kempt in its
//! steep switch) take four RK4 sub-steps instead of one. Sub-stepping a
//! whole group because one lane is busy would double the batch's cost (with
//! 16 lanes some lane is busy in most minutes around meals), so each
//! minute every group takes its quiet step, and the busy lanes of all
//! groups are then gathered, from their state before the minute, into
//! full groups that take the busy sub-steps (a last few alone).
//!
//! The code is compiled for several instruction sets and the best one the
//! processor has is chosen at run time (`pulp`): AVX-512 or AVX2 where
//! present, the x86-64 baseline otherwise.
//!
//! Every lane does what [`Patient::step`] does, operation for operation,
//! except the exp of kempt's two tanh ([`abba_sim::patient::lanes::exp_small`], within
//! 2 ulp of libm's): the glucose of a batch stays within 1e-9 mg/dL of
//! one-by-one stepping (test `batch_matches_one_by_one`, which prints the
//! largest difference, 3e-13 mg/dL). Within the batch the results are
//! exact to the bit whatever the instruction set and whichever patients
//! share the batch (tests `every_instruction_set_gives_the_same_bits`,
//! `a_patient_is_the_same_in_any_company`).

use abba_core::units::MG_PER_G;
use abba_core::PMOL_PER_UNIT;
use abba_sim::inputs::MinuteRates;
use abba_sim::patient::lanes::{Lanes, Real};
use abba_sim::patient::model::{derivatives, ix};
use abba_sim::patient::{
    check_input, input_is_valid, MinuteInput, MinuteState, ModelConsts, Patient, PatientState,
    Solver,
};
use abba_sim::SimError;

/// Patients integrated together (one group of lanes). 16 measured best
/// (per patient-day on the bench's 64 adults, AVX-512: 8 lanes +40 %, 32
/// lanes +47 %): enough independent chains to hide the latency of exp and
/// division, few enough values for the registers and first-level cache.
pub const LANES: usize = 16;

/// A last chunk of at most this many busy lanes is sub-stepped lane by lane
/// (each as a group of one) rather than gathered into a group: one lane's
/// RK4 step costs about a quarter of a group's (0.19 against 0.7 µs,
/// measured). 2 and 4 tie on the bench's 64 adults, 8 is 9 % slower.
const FEW_BUSY: usize = 4;

type L = Lanes<LANES>;
type Mask = [bool; LANES];

/// Independent patients stepped together (see the module docs).
#[derive(Debug, Clone)]
pub struct PatientBatch {
    /// The patients as given (parameters and names; their states are the
    /// lanes' from the first step on, see [`PatientBatch::patient`]).
    patients: Vec<Patient>,
    /// Each patient's glucose distribution volume Vg (dL/kg), beside the
    /// lanes: reading a patient's glucose each minute touches no
    /// [`Patient`].
    vg: Vec<f64>,
    /// Groups of [`LANES`] patients; the last group is padded with copies
    /// of its last patient, whose results are never read.
    groups: Vec<Group>,
    /// The minute's busy lanes (kept to reuse its allocation).
    busy: Vec<BusyLane>,
    /// Where busy lanes from several groups are integrated together (one
    /// group, none for an empty batch).
    scratch: Vec<Group>,
    isa: Isa,
}

/// [`LANES`] patients side by side: what a [`Patient`] holds, as lanes.
#[derive(Debug, Clone)]
struct Group {
    consts: ModelConsts<L>,
    x: [L; 13],
    /// The input of the last integrated minute.
    u: MinuteInput<L>,
    /// Eating rate of the previous minute (g/min).
    last_cho: L,
    /// Stomach content when the current/last eating episode began (mg).
    last_q_sto: L,
    /// Grams eaten so far in the current/last episode.
    food_taken: L,
    /// Minutes simulated so far, per lane.
    minute: [i64; LANES],
}

impl PatientBatch {
    /// A batch of patients; they must share one solver.
    pub fn new(patients: Vec<Patient>) -> Result<Self, SimError> {
        if let Some(first) = patients.first() {
            if patients.iter().any(|p| p.solver() != first.solver()) {
                return Err(SimError::Config(
                    "the patients of a batch must share one solver".into(),
                ));
            }
        }
        let groups: Vec<Group> = patients
            .chunks(LANES)
            .map(|g| Group::gather(std::array::from_fn(|l| &g[l.min(g.len() - 1)])))
            .collect();
        // (A batch without patients has no busy lanes and no scratch.)
        let scratch = groups.first().cloned().into_iter().collect();
        Ok(Self {
            vg: patients.iter().map(|p| p.params().vg).collect(),
            patients,
            groups,
            busy: Vec::new(),
            scratch,
            isa: Isa::Detected,
        })
    }

    /// The batch with its arithmetic on `isa` (see [`Isa`]).
    pub fn with_isa(mut self, isa: Isa) -> Self {
        self.isa = isa;
        self
    }

    /// Patient i's gut bookkeeping of the last integrated minute: D̄, the
    /// meal the gastric emptying is scaled by (mg), as
    /// `Patient::dbar_mg`.
    pub fn dbar_mg(&self, i: usize) -> f64 {
        self.groups[i / LANES].u.dbar_mg.0[i % LANES]
    }

    /// Number of patients.
    pub fn len(&self) -> usize {
        self.patients.len()
    }

    /// True when the batch has no patients.
    pub fn is_empty(&self) -> bool {
        self.patients.is_empty()
    }

    /// Patient `i` as it stands now, as a [`Patient`] that can go on
    /// alone (its state, minute and eating bookkeeping taken from the
    /// lanes).
    pub fn patient(&self, i: usize) -> Result<Patient, SimError> {
        let (g, l) = (&self.groups[i / LANES], i % LANES);
        self.patients[i].clone().with_minute_state(MinuteState {
            x: g.state_array(l),
            minute: g.minute[l],
            last_cho_g_per_min: g.last_cho.0[l],
            last_q_sto_mg: g.last_q_sto.0[l],
            last_food_taken_g: g.food_taken.0[l],
            last_input: g.u.lane(l),
        })
    }

    /// Puts `patient` (its parameters and its state as it stands) in
    /// place of patient `i`, the others unchanged: an environment starting
    /// a new episode. The patient must use the batch's solver.
    pub fn replace(&mut self, i: usize, patient: Patient) -> Result<(), SimError> {
        let n = self.patients.len();
        if i >= n {
            return Err(SimError::Config(format!("patient {i} of a batch of {n}")));
        }
        if patient.solver() != self.patients[0].solver() {
            return Err(SimError::Config(
                "the patients of a batch must share one solver".into(),
            ));
        }
        let g = i / LANES;
        let members = (g * LANES..((g + 1) * LANES).min(n))
            .map(|j| {
                if j == i {
                    Ok(patient.clone())
                } else {
                    self.patient(j)
                }
            })
            .collect::<Result<Vec<Patient>, SimError>>()?;
        self.groups[g] = Group::gather(std::array::from_fn(|l| &members[l.min(members.len() - 1)]));
        self.vg[i] = patient.params().vg;
        self.patients[i] = patient;
        Ok(())
    }

    /// The states x1..x13 of patient `i`.
    pub fn state_array(&self, i: usize) -> [f64; 13] {
        self.groups[i / LANES].state_array(i % LANES)
    }

    /// Minutes simulated so far by patient `i`.
    pub fn minute(&self, i: usize) -> i64 {
        self.groups[i / LANES].minute[i % LANES]
    }

    /// Plasma glucose of patient `i` (mg/dL), as [`Patient::glucose_mg_dl`].
    pub fn glucose_mg_dl(&self, i: usize) -> f64 {
        self.groups[i / LANES].x[ix::GP].0[i % LANES] / self.vg[i]
    }

    /// Subcutaneous glucose of patient `i` (mg/dL), as
    /// [`Patient::subcutaneous_glucose_mg_dl`].
    pub fn subcutaneous_glucose_mg_dl(&self, i: usize) -> f64 {
        self.groups[i / LANES].x[ix::GS].0[i % LANES] / self.vg[i]
    }

    /// Advances every patient one minute: patient `i` with `rates[i]` and
    /// insulin sensitivity `sensitivity[i]`, as [`Patient::step`] would.
    /// Every input is checked before any patient moves.
    pub fn step(&mut self, rates: &[MinuteRates], sensitivity: &[f64]) -> Result<(), SimError> {
        let n = self.patients.len();
        if rates.len() != n || sensitivity.len() != n {
            return Err(SimError::Config(format!(
                "a batch of {n} patients needs as many inputs, got {} rates and {} sensitivities",
                rates.len(),
                sensitivity.len()
            )));
        }
        let solver = self
            .patients
            .first()
            .map(Patient::solver)
            .unwrap_or_default();
        let groups = &mut self.groups;
        let busy = &mut self.busy;
        let scratch = &mut self.scratch;
        let patients = &self.patients;
        let op = StepGroups {
            groups,
            scratch,
            busy,
            patients,
            solver: &solver,
            rates,
            sensitivity,
        };
        // The same code compiled for the vector extensions this processor
        // has (AVX-512 or AVX2 on most x86-64 of the last decade), chosen
        // at run time by `pulp`; the shipped binary still runs on any
        // x86-64. Rust never fuses a multiply and an add on its own, so
        // every variant gives the same bits (test
        // `every_instruction_set_gives_the_same_bits`).
        match self.isa {
            Isa::Detected => pulp::Arch::new().dispatch(op),
            Isa::Baseline => pulp::Simd::vectorize(pulp::Scalar::new(), op),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => match pulp::x86::V3::try_new() {
                Some(simd) => pulp::Simd::vectorize(simd, op),
                None => Err(SimError::Config("no AVX2 here".into())),
            },
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => match pulp::x86::V4::try_new() {
                Some(simd) => pulp::Simd::vectorize(simd, op),
                None => Err(SimError::Config("no AVX-512 here".into())),
            },
        }
    }
}

/// Which instruction set a batch's arithmetic runs on: the best this
/// processor has (the default), or a chosen one (for the test that every
/// variant gives the same bits; a chosen set this processor lacks makes
/// `step` fail). The variants are compiled in either way, as `pulp`'s
/// dispatch needs them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    /// The best this processor has, chosen at run time.
    Detected,
    /// No vector extension (`pulp::Scalar`).
    Baseline,
    /// AVX2 and FMA (x86-64-v3).
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// AVX-512 (x86-64-v4).
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

/// The arguments of [`step_groups`], for `pulp`'s dispatch (a closure
/// would be compiled apart, for the baseline instruction set only).
struct StepGroups<'a> {
    groups: &'a mut [Group],
    scratch: &'a mut [Group],
    busy: &'a mut Vec<BusyLane>,
    patients: &'a [Patient],
    solver: &'a Solver,
    rates: &'a [MinuteRates],
    sensitivity: &'a [f64],
}

impl pulp::WithSimd for StepGroups<'_> {
    type Output = Result<(), SimError>;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        step_groups(
            self.groups,
            self.scratch,
            self.busy,
            self.patients,
            self.solver,
            self.rates,
            self.sensitivity,
        )
    }
}

/// [`PatientBatch::step`] after its checks, for every group.
#[inline(always)]
fn step_groups(
    groups: &mut [Group],
    scratch: &mut [Group],
    busy: &mut Vec<BusyLane>,
    patients: &[Patient],
    solver: &Solver,
    rates: &[MinuteRates],
    sensitivity: &[f64],
) -> Result<(), SimError> {
    let n = patients.len();
    let all_ok = rates.iter().zip(sensitivity).fold(true, |ok, (r, s)| {
        ok & input_is_valid(r.cho_g_per_min, r.insulin_u_per_min, *s)
    });
    if !all_ok {
        for (i, (r, s)) in rates.iter().zip(sensitivity).enumerate() {
            let name = &patients[i].params().name;
            let (cho, ins) = (r.cho_g_per_min, r.insulin_u_per_min);
            check_input(name, groups[i / LANES].minute[i % LANES], cho, ins, *s)?;
        }
    }
    busy.clear();
    for (k, g) in groups.iter_mut().enumerate() {
        let at = |l: usize| (k * LANES + l).min(n - 1);
        let cho = lanes_of(|l| rates[at(l)].cho_g_per_min);
        let ins = lanes_of(|l| rates[at(l)].insulin_u_per_min);
        let s = lanes_of(|l| sensitivity[at(l)]);
        g.step_quiet(solver, cho, ins, s, k * LANES, n, busy);
    }
    let busy_n = solver.busy_substeps.max(1);
    for chunk in busy.chunks(LANES) {
        if chunk.len() <= FEW_BUSY {
            for b in chunk {
                substep_alone(&mut groups[b.group], b, busy_n);
            }
        } else {
            substep_together(groups, &mut scratch[0], chunk, busy_n);
        }
    }
    for (k, g) in groups.iter().enumerate() {
        if let Some((l, state)) = g.first_non_finite() {
            let i = k * LANES + l;
            if i < n {
                return Err(SimError::NonFinite {
                    patient: patients[i].params().name.clone(),
                    minute: g.minute[l],
                    state: PatientState::NAMES[state].to_string(),
                });
            }
        }
    }
    Ok(())
}

/// A lane whose gut is busy this minute, and its state before the minute.
#[derive(Debug, Clone)]
struct BusyLane {
    group: usize,
    lane: usize,
    start: [f64; 13],
}

/// The busy sub-steps of one lane alone, as a group of one lane (the same
/// operations as in a full group, so the same bits). Not inlined: one lane
/// gains nothing from vector instructions, and each inlined copy costs
/// compile time (the crate's build: 99 s → 80 s).
#[inline(never)]
fn substep_alone(g: &mut Group, b: &BusyLane, busy_n: u32) {
    let c = ModelConsts::regather([(&g.consts, b.lane)]);
    let u = MinuteInput::regather([(&g.u, b.lane)]);
    let mut x: [Lanes<1>; 13] = b.start.map(|v| Lanes([v]));
    let h = Lanes([1.0 / f64::from(busy_n)]);
    for _ in 0..busy_n {
        rk4_step(&c, &u, &mut x, h);
    }
    for (to, from) in g.x.iter_mut().zip(x) {
        to.0[b.lane] = from.0[0];
    }
}

/// The busy sub-steps of up to [`LANES`] busy lanes, gathered from their
/// groups into one (padded with copies of the first).
#[inline(always)]
fn substep_together(groups: &mut [Group], scratch: &mut Group, chunk: &[BusyLane], busy_n: u32) {
    // The gathered lanes live in `scratch`, in memory like a group's own
    // (as local variables the compiler kept them in registers and spilled
    // them, which made a step twice as slow as a group's).
    let pick = |j: usize| &chunk[j.min(chunk.len() - 1)];
    scratch.consts = ModelConsts::regather(std::array::from_fn(|j| {
        (&groups[pick(j).group].consts, pick(j).lane)
    }));
    scratch.u = MinuteInput::regather(std::array::from_fn(|j| {
        (&groups[pick(j).group].u, pick(j).lane)
    }));
    for (i, v) in scratch.x.iter_mut().enumerate() {
        *v = lanes_of(|j| pick(j).start[i]);
    }
    let h = L::splat(1.0 / f64::from(busy_n));
    for _ in 0..busy_n {
        rk4_step(&scratch.consts, &scratch.u, &mut scratch.x, h);
    }
    for (j, b) in chunk.iter().enumerate() {
        for (i, v) in scratch.x.iter().enumerate() {
            groups[b.group].x[i].0[b.lane] = v.0[j];
        }
    }
}

impl Group {
    fn gather(p: [&Patient; LANES]) -> Self {
        let m: [MinuteState; LANES] = std::array::from_fn(|l| p[l].minute_state());
        let lanes = |f: &dyn Fn(&MinuteState) -> f64| Lanes(std::array::from_fn(|l| f(&m[l])));
        Self {
            consts: ModelConsts::gather(std::array::from_fn(|l| p[l].consts())),
            x: std::array::from_fn(|i| lanes(&|q| q.x[i])),
            u: MinuteInput::gather(std::array::from_fn(|l| &m[l].last_input)),
            last_cho: lanes(&|q| q.last_cho_g_per_min),
            last_q_sto: lanes(&|q| q.last_q_sto_mg),
            food_taken: lanes(&|q| q.last_food_taken_g),
            minute: std::array::from_fn(|l| m[l].minute),
        }
    }

    #[inline(always)]
    fn state_array(&self, l: usize) -> [f64; 13] {
        std::array::from_fn(|i| self.x[i].0[l])
    }

    /// The first lane (and its first state) that is not finite.
    #[inline(always)]
    fn first_non_finite(&self) -> Option<(usize, usize)> {
        // A value is not finite when its exponent bits are all ones: one
        // branch-free pass over every state first.
        const EXP: u64 = 0x7ff0_0000_0000_0000;
        let mut bad = [0u64; LANES];
        for v in &self.x {
            for (b, x) in bad.iter_mut().zip(v.0) {
                *b |= u64::from(x.to_bits() & EXP == EXP);
            }
        }
        if bad.iter().fold(0, |a, b| a | b) == 0 {
            return None;
        }
        self.first_non_finite_slow()
    }

    #[cold]
    fn first_non_finite_slow(&self) -> Option<(usize, usize)> {
        (0..LANES).find_map(|l| {
            let i = self.x.iter().position(|v| !v.0[l].is_finite())?;
            Some((l, i))
        })
    }

    /// One minute of every lane: [`Patient::begin_minute`]'s bookkeeping,
    /// the solver's sub-step choice and the quiet sub-steps, lane by lane
    /// the same operations as one patient's (inputs already checked).
    /// Returns which lanes are busy, and the state before the minute.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn step_quiet(
        &mut self,
        solver: &Solver,
        cho: L,
        ins: L,
        s: L,
        first: usize,
        n: usize,
        busy_lanes: &mut Vec<BusyLane>,
    ) {
        let c = &self.consts;
        // Eating-episode bookkeeping (§1.4, as `Patient::begin_minute`).
        let eating = cho.0.map(|v| v > 0.0);
        let starts = mask_and(eating, self.last_cho.0.map(|v| v <= 0.0));
        let q_sto = self.x[ix::Q_STO1] + self.x[ix::Q_STO2];
        self.last_q_sto = select(starts, q_sto, self.last_q_sto);
        self.food_taken = select(starts, L::splat(0.0), self.food_taken);
        self.food_taken = select(eating, self.food_taken + cho, self.food_taken);
        self.last_cho = cho;
        let dbar = self.last_q_sto + self.food_taken * MG_PER_G;

        // The minute's input (as `MinuteInput::next`: the kempt slopes
        // only when Dbar moved, the insulin input only when the rate did).
        let u = &mut self.u;
        if bits_differ(dbar, u.dbar_mg) {
            let positive = dbar.0.map(|v| v > 0.0);
            let two_dbar = dbar * 2.0;
            let alpha = L::splat(5.0) / (two_dbar * (L::splat(1.0) - c.b));
            let beta = L::splat(5.0) / (two_dbar * c.d);
            u.alpha = select(positive, alpha, L::splat(0.0));
            u.beta = select(positive, beta, L::splat(0.0));
            u.two_alpha = u.alpha * 2.0;
            u.two_beta = u.beta * 2.0;
            u.b_dbar = c.b * dbar;
            u.d_dbar = c.d * dbar;
            u.dbar_mg = dbar;
        }
        if bits_differ(ins, u.insulin_u_per_min) {
            u.insulin_u_per_min = ins;
            u.insulin_pmol_per_kg_min = ins * PMOL_PER_UNIT / c.bw;
        }
        u.meal_mg_per_min = cho * MG_PER_G;
        u.sensitivity = s;
        u.s_kp3 = s * c.kp3;
        u.s_vmx = s * c.vmx;

        // Sub-steps per lane (as `Solver::substeps_for`): every lane takes
        // the quiet sub-steps here; the caller integrates the busy lanes
        // again from `start`, with the busy sub-steps.
        let quiet_n = solver.substeps.max(1);
        let busy = if solver.busy_substeps.max(1) != quiet_n {
            self.gut_is_busy(solver)
        } else {
            [false; LANES]
        };
        for l in (0..LANES).filter(|&l| busy[l] && first + l < n) {
            busy_lanes.push(BusyLane {
                group: first / LANES,
                lane: l,
                start: self.state_array(l),
            });
        }
        let h = L::splat(1.0 / f64::from(quiet_n));
        for _ in 0..quiet_n {
            rk4_step(&self.consts, &self.u, &mut self.x, h);
        }
        for m in &mut self.minute {
            *m += 1;
        }
    }

    /// [`Solver::gut_is_busy`] for every lane.
    #[inline(always)]
    fn gut_is_busy(&self, solver: &Solver) -> Mask {
        let (c, u, x) = (&self.consts, &self.u, &self.x);
        let q_sto = x[ix::Q_STO1] + x[ix::Q_STO2];
        let q_rate = c.kmax * abs(x[ix::Q_STO2]) + c.kmax * abs(x[ix::Q_STO1]);
        let first = near(solver, u.alpha, u.b_dbar, q_sto, q_rate);
        let second = near(solver, u.beta, u.d_dbar, q_sto, q_rate);
        mask_of(|l| {
            (u.meal_mg_per_min.0[l] > 0.0)
                | ((u.dbar_mg.0[l] > 0.0) & (x[ix::Q_STO2].0[l] != 0.0) & (first[l] | second[l]))
        })
    }
}

/// Per lane: is a tanh argument of kempt (slope·(Qsto − centre)) near 0
/// and moving fast (as in [`Solver`]'s busy-gut test)?
#[inline(always)]
fn near(solver: &Solver, slope: L, centre: L, q_sto: L, q_rate: L) -> Mask {
    let moves = slope * q_rate;
    let dist = abs(slope * (q_sto - centre));
    let reach = moves + solver.tanh_window;
    mask_of(|l| (moves.0[l] > solver.tanh_rate) & (dist.0[l] < reach.0[l]))
}

/// One classic RK4 step of lane-wise length `h`: the operations of
/// `solver::rk4_step` for one patient, lane by lane.
#[inline(always)]
fn rk4_step<T: Real>(c: &ModelConsts<T>, u: &MinuteInput<T>, x: &mut [T; 13], h: T) {
    let half = h * 0.5;
    let sixth = h / T::splat(6.0);
    let k1 = derivatives(c, u, x);
    let mut y = *x;
    for i in 0..13 {
        y[i] = x[i] + k1[i] * half;
    }
    let k2 = derivatives(c, u, &y);
    for i in 0..13 {
        y[i] = x[i] + k2[i] * half;
    }
    let k3 = derivatives(c, u, &y);
    for i in 0..13 {
        y[i] = x[i] + k3[i] * h;
    }
    let k4 = derivatives(c, u, &y);
    for i in 0..13 {
        x[i] = x[i] + (k1[i] + k2[i] * 2.0 + k3[i] * 2.0 + k4[i]) * sixth;
    }
}

/// Lanes from a function of the lane index (a plain loop: the closures
/// of `std::array::from_fn` were not always inlined, and a call leaves the
/// run-time-selected instruction set).
#[inline(always)]
fn lanes_of<const W: usize>(f: impl Fn(usize) -> f64) -> Lanes<W> {
    let mut v = [0.0; W];
    for (l, x) in v.iter_mut().enumerate() {
        *x = f(l);
    }
    Lanes(v)
}

/// A mask from a function of the lane index (as [`lanes_of`]).
#[inline(always)]
fn mask_of(f: impl Fn(usize) -> bool) -> Mask {
    let mut m = [false; LANES];
    for (l, x) in m.iter_mut().enumerate() {
        *x = f(l);
    }
    m
}

#[inline(always)]
fn select(mask: Mask, a: L, b: L) -> L {
    lanes_of(|l| if mask[l] { a.0[l] } else { b.0[l] })
}

#[inline(always)]
fn mask_and(a: Mask, b: Mask) -> Mask {
    mask_of(|l| a[l] & b[l])
}

#[inline(always)]
fn abs(v: L) -> L {
    Lanes(v.0.map(f64::abs))
}

#[inline(always)]
fn bits_differ(a: L, b: L) -> bool {
    a.0.iter().zip(b.0).any(|(x, y)| x.to_bits() != y.to_bits())
}
