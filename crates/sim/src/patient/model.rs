//! The right-hand side of the UVA/Padova 2008 model as simglucose computes it
//! (`spec/uva-padova-model.md` §1.3). Pure and allocation-free.
//!
//! References: Dalla Man, Rizza & Cobelli, IEEE TBME 54(10), 2007 (meal
//! model, "DM07"); Kovatchev et al., JDST 3(1), 2009 (the T1D simulator).

use super::lanes::{Lanes, Real};
use super::params::PatientParams;
use abba_core::units::MG_PER_G;
use abba_core::PMOL_PER_UNIT;

/// Indices of the states in the solver's array (x1..x13 of the spec).
pub mod ix {
    /// Qsto1.
    pub const Q_STO1: usize = 0;
    /// Qsto2.
    pub const Q_STO2: usize = 1;
    /// Qgut.
    pub const Q_GUT: usize = 2;
    /// Gp.
    pub const GP: usize = 3;
    /// Gt.
    pub const GT: usize = 4;
    /// Ip.
    pub const IP: usize = 5;
    /// X.
    pub const X: usize = 6;
    /// I1.
    pub const I1: usize = 7;
    /// Id.
    pub const ID: usize = 8;
    /// Il.
    pub const IL: usize = 9;
    /// Isc1.
    pub const ISC1: usize = 10;
    /// Isc2.
    pub const ISC2: usize = 11;
    /// Gs.
    pub const GS: usize = 12;
}

/// The parameters the right-hand side reads, copied out of
/// [`PatientParams`] into a compact struct for the hot loop; `T` is `f64`
/// for one patient or [`Lanes`] for several side by side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelConsts<T = f64> {
    /// Body weight (kg).
    pub bw: T,
    /// kabs (1/min).
    pub kabs: T,
    /// kmax (1/min).
    pub kmax: T,
    /// kmin (1/min).
    pub kmin: T,
    /// b.
    pub b: T,
    /// d.
    pub d: T,
    /// f.
    pub f: T,
    /// kp1 (mg/kg/min).
    pub kp1: T,
    /// kp2 (1/min).
    pub kp2: T,
    /// kp3 (mg/kg/min per pmol/L).
    pub kp3: T,
    /// Fsnc (mg/kg/min).
    pub fsnc: T,
    /// ke1 (1/min).
    pub ke1: T,
    /// ke2 (mg/kg).
    pub ke2: T,
    /// k1 (1/min).
    pub k1: T,
    /// k2 (1/min).
    pub k2: T,
    /// Vm0 (mg/kg/min).
    pub vm0: T,
    /// Vmx (mg/kg/min per pmol/L).
    pub vmx: T,
    /// Km0 (mg/kg).
    pub km0: T,
    /// m1 (1/min).
    pub m1: T,
    /// m2 (1/min).
    pub m2: T,
    /// m4 (1/min).
    pub m4: T,
    /// m30 (1/min).
    pub m30: T,
    /// ka1 (1/min).
    pub ka1: T,
    /// ka2 (1/min).
    pub ka2: T,
    /// kd (1/min).
    pub kd: T,
    /// Vi (L/kg).
    pub vi: T,
    /// Ib (pmol/L).
    pub ib: T,
    /// p2u (1/min).
    pub p2u: T,
    /// ki (1/min).
    pub ki: T,
    /// ksc (1/min).
    pub ksc: T,
    /// f·kabs/BW, the factor from Qgut to Ra (1/(kg·min)).
    pub ra_per_q_gut: T,
    /// 1/Vi (kg/L).
    pub inv_vi: T,
    /// m2 + m4, the plasma insulin clearance (1/min).
    pub m2_m4: T,
    /// m1 + m30, the liver insulin clearance (1/min).
    pub m1_m30: T,
    /// ka1 + kd, the loss rate of Isc1 (1/min).
    pub ka1_kd: T,
    /// (kmax − kmin)/2, the half-range of kempt (1/min).
    pub half_k_range: T,
}

/// One field of `W` patients' structs as lanes.
macro_rules! gather {
    ($from:expr, $ty:ident { $($f:ident),* $(,)? }) => {
        $ty { $($f: Lanes(std::array::from_fn(|l| $from[l].$f)),)* }
    };
}

/// Lane `l` of every field of a struct of lanes.
macro_rules! pick {
    (($from:expr, $l:expr), $ty:ident { $($f:ident),* $(,)? }) => {
        $ty { $($f: $from.$f.0[$l],)* }
    };
}

/// Lane `lanes[j].1` of struct `lanes[j].0` into lane `j`, every field.
macro_rules! regather {
    ($lanes:expr, $ty:ident { $($f:ident),* $(,)? }) => {
        $ty { $($f: {
            let mut v = [0.0; W];
            for (j, x) in v.iter_mut().enumerate() {
                *x = $lanes[j].0.$f.0[$lanes[j].1];
            }
            Lanes(v)
        },)* }
    };
}

/// Every field of `W` structs through `f`: `f([s[0].field, ...])`.
macro_rules! gather_fields {
    (($s:expr, $f:expr), $ty:ident { $($fi:ident),* $(,)? }) => {
        $ty { $($fi: ($f)(std::array::from_fn(|l| $s[l].$fi)),)* }
    };
}

/// Calls `$mac!($arg, Struct { every field })` for the two structs that
/// exist as lanes, so that their field lists are written once.
macro_rules! with_fields {
    ($mac:ident, $arg:tt, ModelConsts) => {
        $mac!(
            $arg,
            ModelConsts {
                bw,
                kabs,
                kmax,
                kmin,
                b,
                d,
                f,
                kp1,
                kp2,
                kp3,
                fsnc,
                ke1,
                ke2,
                k1,
                k2,
                vm0,
                vmx,
                km0,
                m1,
                m2,
                m4,
                m30,
                ka1,
                ka2,
                kd,
                vi,
                ib,
                p2u,
                ki,
                ksc,
                ra_per_q_gut,
                inv_vi,
                m2_m4,
                m1_m30,
                ka1_kd,
                half_k_range
            }
        )
    };
    ($mac:ident, $arg:tt, MinuteInput) => {
        $mac!(
            $arg,
            MinuteInput {
                meal_mg_per_min,
                insulin_pmol_per_kg_min,
                insulin_u_per_min,
                dbar_mg,
                sensitivity,
                alpha,
                beta,
                two_alpha,
                two_beta,
                b_dbar,
                d_dbar,
                s_kp3,
                s_vmx
            }
        )
    };
}

impl<T: Copy> ModelConsts<T> {
    /// Field by field `f([s[0].field, s[1].field, ...])`: `W` patients'
    /// constants as one struct of another number type.
    #[inline(always)]
    pub fn gather_with<U, const W: usize>(
        s: [&Self; W],
        f: impl Fn([T; W]) -> U,
    ) -> ModelConsts<U> {
        with_fields!(gather_fields, (s, f), ModelConsts)
    }
}

impl<T: Copy> MinuteInput<T> {
    /// Field by field `f([s[0].field, s[1].field, ...])`.
    #[inline(always)]
    pub fn gather_with<U, const W: usize>(
        s: [&Self; W],
        f: impl Fn([T; W]) -> U,
    ) -> MinuteInput<U> {
        with_fields!(gather_fields, (s, f), MinuteInput)
    }
}

impl<const W: usize> ModelConsts<Lanes<W>> {
    /// Lane `j` of the result is lane `from[j].1` of `from[j].0`.
    #[inline(always)]
    pub fn regather<const V: usize>(from: [(&ModelConsts<Lanes<V>>, usize); W]) -> Self {
        with_fields!(regather, from, ModelConsts)
    }

    /// The constants of `W` patients side by side.
    pub fn gather(c: [&ModelConsts; W]) -> Self {
        with_fields!(gather, c, ModelConsts)
    }
}

impl<const W: usize> MinuteInput<Lanes<W>> {
    /// Lane `j` of the result is lane `from[j].1` of `from[j].0`.
    #[inline(always)]
    pub fn regather<const V: usize>(from: [(&MinuteInput<Lanes<V>>, usize); W]) -> Self {
        with_fields!(regather, from, MinuteInput)
    }

    /// The minute input of lane `l`.
    pub fn lane(&self, l: usize) -> MinuteInput {
        with_fields!(pick, (self, l), MinuteInput)
    }

    /// The minute inputs of `W` patients side by side.
    pub fn gather(u: [&MinuteInput; W]) -> Self {
        with_fields!(gather, u, MinuteInput)
    }
}

impl ModelConsts {
    /// Copies the parameters the model reads.
    pub fn from_params(p: &PatientParams) -> Self {
        Self {
            bw: p.bw,
            kabs: p.kabs,
            kmax: p.kmax,
            kmin: p.kmin,
            b: p.b,
            d: p.d,
            f: p.f,
            kp1: p.kp1,
            kp2: p.kp2,
            kp3: p.kp3,
            fsnc: p.fsnc,
            ke1: p.ke1,
            ke2: p.ke2,
            k1: p.k1,
            k2: p.k2,
            vm0: p.vm0,
            vmx: p.vmx,
            km0: p.km0,
            m1: p.m1,
            m2: p.m2,
            m4: p.m4,
            m30: p.m30,
            ka1: p.ka1,
            ka2: p.ka2,
            kd: p.kd,
            vi: p.vi,
            ib: p.ib,
            p2u: p.p2u,
            ki: p.ki,
            ksc: p.ksc,
            ra_per_q_gut: p.f * p.kabs / p.bw,
            inv_vi: 1.0 / p.vi,
            m2_m4: p.m2 + p.m4,
            m1_m30: p.m1 + p.m30,
            ka1_kd: p.ka1 + p.kd,
            half_k_range: (p.kmax - p.kmin) / 2.0,
        }
    }
}

/// What is held constant over one minute of integration (`T` as in
/// [`ModelConsts`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinuteInput<T = f64> {
    /// Meal rate into the stomach, Dm = 1000·c (mg/min), c the eating rate in g/min.
    pub meal_mg_per_min: T,
    /// Subcutaneous insulin input IIR = u·6000/BW (pmol/kg/min), u in U/min.
    pub insulin_pmol_per_kg_min: T,
    /// The insulin rate u (U/min) that IIR was computed from.
    pub insulin_u_per_min: T,
    /// Dbar of the gastric-emptying law (mg); 0 before the first meal.
    pub dbar_mg: T,
    /// Insulin-sensitivity multiplier s(t) on Vmx and kp3 (1 = nominal).
    pub sensitivity: T,
    /// Slope α of the first tanh of kempt, 5/(2·Dbar·(1−b)) (1/mg); 0 if Dbar = 0.
    pub alpha: T,
    /// Slope β of the second tanh of kempt, 5/(2·Dbar·d) (1/mg); 0 if Dbar = 0.
    pub beta: T,
    /// 2α (1/mg), so that the first tanh's doubled argument is one product.
    pub two_alpha: T,
    /// 2β (1/mg).
    pub two_beta: T,
    /// Centre b·Dbar of the first tanh of kempt (mg).
    pub b_dbar: T,
    /// Centre d·Dbar of the second tanh of kempt (mg).
    pub d_dbar: T,
    /// s(t)·kp3, the insulin action on EGP this minute.
    pub s_kp3: T,
    /// s(t)·Vmx, the insulin action on utilisation this minute.
    pub s_vmx: T,
}

impl MinuteInput {
    /// The input of the next minute from this one's, recomputing only what
    /// changed: the kempt slopes when Dbar moved, the insulin input when
    /// the rate moved (most minutes neither does). Equal, bit for bit, to
    /// [`MinuteInput::new`] with the same arguments when `self` was made by
    /// it (or by this function) with the same `c`.
    #[inline]
    pub fn next(
        &self,
        c: &ModelConsts,
        cho_g_per_min: f64,
        insulin_u_per_min: f64,
        dbar_mg: f64,
        sensitivity: f64,
    ) -> Self {
        let mut u = *self;
        if dbar_mg.to_bits() != self.dbar_mg.to_bits() {
            let fresh = Self::new(c, 0.0, 0.0, dbar_mg, 1.0);
            u.dbar_mg = dbar_mg;
            u.alpha = fresh.alpha;
            u.beta = fresh.beta;
            u.two_alpha = fresh.two_alpha;
            u.two_beta = fresh.two_beta;
            u.b_dbar = fresh.b_dbar;
            u.d_dbar = fresh.d_dbar;
        }
        if insulin_u_per_min.to_bits() != self.insulin_u_per_min.to_bits() {
            u.insulin_u_per_min = insulin_u_per_min;
            u.insulin_pmol_per_kg_min = insulin_u_per_min * PMOL_PER_UNIT / c.bw;
        }
        u.meal_mg_per_min = MG_PER_G * cho_g_per_min;
        u.sensitivity = sensitivity;
        u.s_kp3 = sensitivity * c.kp3;
        u.s_vmx = sensitivity * c.vmx;
        u
    }

    /// Converts the per-minute rates of the public interface (g/min, U/min).
    pub fn new(
        c: &ModelConsts,
        cho_g_per_min: f64,
        insulin_u_per_min: f64,
        dbar_mg: f64,
        sensitivity: f64,
    ) -> Self {
        let (alpha, beta) = if dbar_mg > 0.0 {
            (
                5.0 / (2.0 * dbar_mg * (1.0 - c.b)),
                5.0 / (2.0 * dbar_mg * c.d),
            )
        } else {
            (0.0, 0.0)
        };
        Self {
            meal_mg_per_min: MG_PER_G * cho_g_per_min,
            insulin_pmol_per_kg_min: insulin_u_per_min * PMOL_PER_UNIT / c.bw,
            insulin_u_per_min,
            dbar_mg,
            sensitivity,
            alpha,
            beta,
            two_alpha: 2.0 * alpha,
            two_beta: 2.0 * beta,
            b_dbar: c.b * dbar_mg,
            d_dbar: c.d * dbar_mg,
            s_kp3: sensitivity * c.kp3,
            s_vmx: sensitivity * c.vmx,
        }
    }
}

/// tanh(x) as 1 − 2/(e^{2x} + 1): one `exp` instead of libm's `tanh`
/// (which goes through `expm1` and dominated the profile of a trial). The
/// absolute error is below 2e-16 for every x, and kempt only needs absolute
/// accuracy: the two tanh terms are added to 2. For |x| >= 20 the formula
/// gives exactly ±1 in floating point, so the lanes' exp may clamp 2x to
/// [−40, 40] without changing a result.
#[inline(always)]
pub fn tanh_fast<T: Real>(x: T) -> T {
    tanh_of_double(x * 2.0)
}

/// tanh(y/2) from y = 2x (saves the doubling on the dependency chain of
/// kempt; doubling is exact, so tanh_of_double(2x) == tanh_fast(x)).
#[inline(always)]
fn tanh_of_double<T: Real>(two_x: T) -> T {
    T::splat(1.0) - T::splat(2.0) / (two_x.exp_for_tanh() + 1.0)
}

/// The gastric emptying rate kempt(Qsto, Dbar) (DM07 eq. 7; simglucose's
/// "kgut"). With Dbar = 0 it is kmax.
#[inline(always)]
pub fn k_empt<T: Real>(c: &ModelConsts<T>, u: &MinuteInput<T>, q_sto: T) -> T {
    let switching = c.kmin
        + c.half_k_range
            * (tanh_of_double(u.two_alpha * (q_sto - u.b_dbar))
                - tanh_of_double(u.two_beta * (q_sto - u.d_dbar))
                + 2.0);
    u.dbar_mg.if_gt(T::splat(0.0), switching, c.kmax)
}

/// dx/dt at state `x` under the minute's constant input `u`, for one
/// patient (`T = f64`) or several side by side (`T = Lanes`).
///
/// Each line follows `spec/uva-padova-model.md` §1.3; the DM07 equation
/// numbers are given where the model is the published one.
#[inline(always)]
pub fn derivatives<T: Real>(c: &ModelConsts<T>, u: &MinuteInput<T>, x: &[T; 13]) -> [T; 13] {
    derivatives_given_kempt(c, u, x, kempt_at(c, u, x))
}

/// The gastric emptying rate at state `x`: [`k_empt`] of Qsto1 + Qsto2,
/// or kmax when the second compartment is empty (kempt multiplies Qsto2
/// only). It depends on Qsto1, Qsto2 and the minute's Dbar alone.
#[inline(always)]
pub fn kempt_at<T: Real>(c: &ModelConsts<T>, u: &MinuteInput<T>, x: &[T; 13]) -> T {
    use ix::*;
    let q_sto = x[Q_STO1] + x[Q_STO2];
    if T::EAGER {
        x[Q_STO2].select_zero(c.kmax, k_empt(c, u, q_sto))
    } else {
        x[Q_STO2].if_zero(c.kmax, || k_empt(c, u, q_sto))
    }
}

/// [`derivatives`] with kempt given (as [`kempt_at`] computes it for `x`).
#[inline(always)]
pub fn derivatives_given_kempt<T: Real>(
    c: &ModelConsts<T>,
    u: &MinuteInput<T>,
    x: &[T; 13],
    kempt: T,
) -> [T; 13] {
    use ix::*;
    let [d_q_sto1, d_q_sto2, d_q_gut] = gut_derivatives(c, u, x, kempt);
    let body = body_derivatives(c, u, x, x[Q_GUT]);
    [
        d_q_sto1, d_q_sto2, d_q_gut, body[0], body[1], body[2], body[3], body[4], body[5], body[6],
        body[7], body[8], body[9],
    ]
}

/// The gastrointestinal tract (DM07 eqs. 4-8; grinding kgri = kmax):
/// d(Qsto1, Qsto2, Qgut)/dt. It reads no other state: the gut is a closed
/// subsystem.
#[inline(always)]
pub fn gut_derivatives<T: Real>(
    c: &ModelConsts<T>,
    u: &MinuteInput<T>,
    x: &[T; 13],
    kempt: T,
) -> [T; 3] {
    use ix::*;
    let d_q_sto1 = -c.kmax * x[Q_STO1] + u.meal_mg_per_min;
    let d_q_sto2 = c.kmax * x[Q_STO1] - kempt * x[Q_STO2];
    let d_q_gut = kempt * x[Q_STO2] - c.kabs * x[Q_GUT];
    [d_q_sto1, d_q_sto2, d_q_gut]
}

/// The rest of the body, driven by the gut through Qgut = `q_gut`: the
/// derivatives of the states after the gut (Gp, Gt, Ip, X, I1, Id, Il,
/// Isc1, Isc2, Gs: `x[3..13]`). It reads no gut state but `q_gut`.
#[inline(always)]
pub fn body_derivatives<T: Real>(
    c: &ModelConsts<T>,
    u: &MinuteInput<T>,
    x: &[T; 13],
    q_gut: T,
) -> [T; 10] {
    use ix::*;
    let ra = c.ra_per_q_gut * q_gut; // rate of appearance f·kabs·Qgut/BW (mg/kg/min)

    // Glucose subsystem (DM07 eqs. 1, 10-15 without the portal term).
    // s(t) scales the insulin actions on EGP (kp3) and utilisation (Vmx).
    let egp = c.kp1 - c.kp2 * x[GP] - u.s_kp3 * x[ID];
    let uii = c.fsnc;
    let renal = x[GP].if_gt(c.ke2, c.ke1 * (x[GP] - c.ke2), T::splat(0.0));
    let d_gp = egp.max0() + ra - uii - renal - c.k1 * x[GP] + c.k2 * x[GT];
    let uid = (c.vm0 + u.s_vmx * x[X]) * x[GT] / (c.km0 + x[GT]);
    let d_gt = -uid + c.k1 * x[GP] - c.k2 * x[GT];

    // Insulin subsystem (DM07 eqs. 2-3, 17-21; Kovatchev 2009 s.c. route).
    let d_ip = -c.m2_m4 * x[IP] + c.m1 * x[IL] + c.ka1 * x[ISC1] + c.ka2 * x[ISC2];
    let plasma_insulin = x[IP] * c.inv_vi; // I = Ip/Vi (pmol/L)
    let d_x = -c.p2u * x[X] + c.p2u * (plasma_insulin - c.ib);
    let d_i1 = -c.ki * (x[I1] - plasma_insulin);
    let d_id = -c.ki * (x[ID] - x[I1]);
    let d_il = -c.m1_m30 * x[IL] + c.m2 * x[IP];
    let d_isc1 = u.insulin_pmol_per_kg_min - c.ka1_kd * x[ISC1];
    let d_isc2 = c.kd * x[ISC1] - c.ka2 * x[ISC2];

    // Subcutaneous glucose, as a mass (Kovatchev 2009).
    let d_gs = -c.ksc * x[GS] + c.ksc * x[GP];

    // Sign guards: a negative mass may not keep falling (simglucose).
    [
        d_gp.unless_negative(x[GP]),
        d_gt.unless_negative(x[GT]),
        d_ip.unless_negative(x[IP]),
        d_x,
        d_i1,
        d_id,
        d_il.unless_negative(x[IL]),
        d_isc1.unless_negative(x[ISC1]),
        d_isc2.unless_negative(x[ISC2]),
        d_gs.unless_negative(x[GS]),
    ]
}

#[cfg(test)]
mod tests {
    use super::tanh_fast;
    use crate::patient::lanes::Lanes;

    /// The lanes' tanh uses the vectorisable exp (within 2 ulp): one unit
    /// in the last place of 2 (2^-51) at worst, from the division.
    #[test]
    fn lanes_tanh_matches_libm_to_one_ulp_of_two() {
        let mut worst: f64 = 0.0;
        for k in -400_000..=400_000 {
            let x = k as f64 * 1e-4;
            worst = worst.max((tanh_fast(Lanes([x])).0[0] - x.tanh()).abs());
        }
        for x in [-1e6, -800.0, -355.0, 355.0, 800.0, 1e6, f64::MAX, f64::MIN] {
            worst = worst.max((tanh_fast(Lanes([x])).0[0] - x.tanh()).abs());
        }
        assert!(
            worst <= 2f64.powi(-51),
            "largest |tanh - libm tanh| = {worst:e}"
        );
    }

    #[test]
    fn fast_tanh_matches_libm_to_machine_precision() {
        let mut worst: f64 = 0.0;
        for k in -400_000..=400_000 {
            let x = k as f64 * 1e-4;
            worst = worst.max((tanh_fast(x) - x.tanh()).abs());
        }
        for x in [-1e6, -800.0, -355.0, 355.0, 800.0, 1e6, f64::MAX, f64::MIN] {
            worst = worst.max((tanh_fast(x) - x.tanh()).abs());
        }
        assert!(worst < 4e-16, "largest |tanh_fast - tanh| = {worst:e}");
    }
}
