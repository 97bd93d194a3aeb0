//! The right-hand side of the UVA/Padova 2008 model as simglucose computes it
//! (`spec/uva-padova-model.md` §1.3). Pure and allocation-free.
//!
//! References: Dalla Man, Rizza & Cobelli, IEEE TBME 54(10), 2007 (meal
//! model, "DM07"); Kovatchev et al., JDST 3(1), 2009 (the T1D simulator).

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
/// [`PatientParams`] into a compact struct for the hot loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelConsts {
    /// Body weight (kg).
    pub bw: f64,
    /// kabs (1/min).
    pub kabs: f64,
    /// kmax (1/min).
    pub kmax: f64,
    /// kmin (1/min).
    pub kmin: f64,
    /// b.
    pub b: f64,
    /// d.
    pub d: f64,
    /// f.
    pub f: f64,
    /// kp1 (mg/kg/min).
    pub kp1: f64,
    /// kp2 (1/min).
    pub kp2: f64,
    /// kp3 (mg/kg/min per pmol/L).
    pub kp3: f64,
    /// Fsnc (mg/kg/min).
    pub fsnc: f64,
    /// ke1 (1/min).
    pub ke1: f64,
    /// ke2 (mg/kg).
    pub ke2: f64,
    /// k1 (1/min).
    pub k1: f64,
    /// k2 (1/min).
    pub k2: f64,
    /// Vm0 (mg/kg/min).
    pub vm0: f64,
    /// Vmx (mg/kg/min per pmol/L).
    pub vmx: f64,
    /// Km0 (mg/kg).
    pub km0: f64,
    /// m1 (1/min).
    pub m1: f64,
    /// m2 (1/min).
    pub m2: f64,
    /// m4 (1/min).
    pub m4: f64,
    /// m30 (1/min).
    pub m30: f64,
    /// ka1 (1/min).
    pub ka1: f64,
    /// ka2 (1/min).
    pub ka2: f64,
    /// kd (1/min).
    pub kd: f64,
    /// Vi (L/kg).
    pub vi: f64,
    /// Ib (pmol/L).
    pub ib: f64,
    /// p2u (1/min).
    pub p2u: f64,
    /// ki (1/min).
    pub ki: f64,
    /// ksc (1/min).
    pub ksc: f64,
    /// f·kabs/BW, the factor from Qgut to Ra (1/(kg·min)).
    pub ra_per_q_gut: f64,
    /// 1/Vi (kg/L).
    pub inv_vi: f64,
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
        }
    }
}

/// What is held constant over one minute of integration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MinuteInput {
    /// Meal rate into the stomach, Dm = 1000·c (mg/min), c the eating rate in g/min.
    pub meal_mg_per_min: f64,
    /// Subcutaneous insulin input IIR = u·6000/BW (pmol/kg/min), u in U/min.
    pub insulin_pmol_per_kg_min: f64,
    /// Dbar of the gastric-emptying law (mg); 0 before the first meal.
    pub dbar_mg: f64,
    /// Insulin-sensitivity multiplier s(t) on Vmx (1 = nominal).
    pub sensitivity: f64,
    /// Insulin-sensitivity multiplier on kp3, the liver's insulin action
    /// (equal to `sensitivity` unless the scenario targets Vmx only).
    pub egp_sensitivity: f64,
    /// Slope α of the first tanh of kempt, 5/(2·Dbar·(1−b)) (1/mg); 0 if Dbar = 0.
    pub alpha: f64,
    /// Slope β of the second tanh of kempt, 5/(2·Dbar·d) (1/mg); 0 if Dbar = 0.
    pub beta: f64,
}

impl MinuteInput {
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
            dbar_mg,
            sensitivity,
            egp_sensitivity: sensitivity,
            alpha,
            beta,
        }
    }
}

/// tanh(x) as 1 − 2/(e^{2x} + 1): one `exp` instead of libm's `tanh`
/// (which goes through `expm1` and dominated the profile of a trial). The
/// absolute error is below 2e-16 for every x, and kempt only needs absolute
/// accuracy: the two tanh terms are added to 2. Saturates cleanly: e^{2x}
/// overflowing to infinity gives 1, underflowing to 0 gives −1.
#[inline]
pub fn tanh_fast(x: f64) -> f64 {
    1.0 - 2.0 / ((2.0 * x).exp() + 1.0)
}

/// The gastric emptying rate kempt(Qsto, Dbar) (DM07 eq. 7; simglucose's
/// "kgut"). With Dbar = 0 it is kmax.
#[inline]
pub fn k_empt(c: &ModelConsts, u: &MinuteInput, q_sto: f64) -> f64 {
    if u.dbar_mg > 0.0 {
        c.kmin
            + (c.kmax - c.kmin) / 2.0
                * (tanh_fast(u.alpha * (q_sto - c.b * u.dbar_mg))
                    - tanh_fast(u.beta * (q_sto - c.d * u.dbar_mg))
                    + 2.0)
    } else {
        c.kmax
    }
}

/// dx/dt at state `x` under the minute's constant input `u`.
///
/// Each line follows `spec/uva-padova-model.md` §1.3; the DM07 equation
/// numbers are given where the model is the published one.
#[inline]
pub fn derivatives(c: &ModelConsts, u: &MinuteInput, x: &[f64; 13]) -> [f64; 13] {
    use ix::*;
    let mut dx = [0.0; 13];

    // Gastrointestinal tract (DM07 eqs. 4-8). Grinding kgri = kmax.
    let q_sto = x[Q_STO1] + x[Q_STO2];
    // kempt only multiplies Qsto2; skip the two tanh when it is exactly zero.
    let kempt = if x[Q_STO2] == 0.0 {
        c.kmax
    } else {
        k_empt(c, u, q_sto)
    };
    dx[Q_STO1] = -c.kmax * x[Q_STO1] + u.meal_mg_per_min;
    dx[Q_STO2] = c.kmax * x[Q_STO1] - kempt * x[Q_STO2];
    dx[Q_GUT] = kempt * x[Q_STO2] - c.kabs * x[Q_GUT];
    let ra = c.ra_per_q_gut * x[Q_GUT]; // rate of appearance f·kabs·Qgut/BW (mg/kg/min)

    // Glucose subsystem (DM07 eqs. 1, 10-15 without the portal term).
    // s(t) scales the insulin actions on EGP (kp3) and utilisation (Vmx).
    let egp = c.kp1 - c.kp2 * x[GP] - u.egp_sensitivity * c.kp3 * x[ID];
    let uii = c.fsnc;
    let renal = if x[GP] > c.ke2 {
        c.ke1 * (x[GP] - c.ke2)
    } else {
        0.0
    };
    dx[GP] = egp.max(0.0) + ra - uii - renal - c.k1 * x[GP] + c.k2 * x[GT];
    let uid = (c.vm0 + u.sensitivity * c.vmx * x[X]) * x[GT] / (c.km0 + x[GT]);
    dx[GT] = -uid + c.k1 * x[GP] - c.k2 * x[GT];

    // Insulin subsystem (DM07 eqs. 2-3, 17-21; Kovatchev 2009 s.c. route).
    dx[IP] = -(c.m2 + c.m4) * x[IP] + c.m1 * x[IL] + c.ka1 * x[ISC1] + c.ka2 * x[ISC2];
    let plasma_insulin = x[IP] * c.inv_vi; // I = Ip/Vi (pmol/L)
    dx[X] = -c.p2u * x[X] + c.p2u * (plasma_insulin - c.ib);
    dx[I1] = -c.ki * (x[I1] - plasma_insulin);
    dx[ID] = -c.ki * (x[ID] - x[I1]);
    dx[IL] = -(c.m1 + c.m30) * x[IL] + c.m2 * x[IP];
    dx[ISC1] = u.insulin_pmol_per_kg_min - (c.ka1 + c.kd) * x[ISC1];
    dx[ISC2] = c.kd * x[ISC1] - c.ka2 * x[ISC2];

    // Subcutaneous glucose, as a mass (Kovatchev 2009).
    dx[GS] = -c.ksc * x[GS] + c.ksc * x[GP];

    // Sign guards: a negative mass may not keep falling (simglucose).
    for k in [GP, GT, IP, IL, ISC1, ISC2, GS] {
        if x[k] < 0.0 {
            dx[k] = 0.0;
        }
    }
    dx
}

#[cfg(test)]
mod tests {
    use super::tanh_fast;

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
