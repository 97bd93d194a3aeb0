//! Which parameters of a virtual patient are primary and which follow from
//! them, and the steady-state derivation (protocol.md §2).
//!
//! The steady state at basal insulin and no food (spec/uva-padova-model.md
//! §1.3 with every derivative zero, X = 0, I = Ib, Id = I1 = Ib, empty gut):
//!
//! - gut: Qsto1 = Qsto2 = Qgut = 0;
//! - insulin action: X = 0, I1 = Id = Ib, hence Ip = Ipb = Ib·Vi;
//! - liver insulin: 0 = −(m1 + m30)·Il + m2·Ip, so Ilb = m2·Ipb/(m1 + m30),
//!   with m30 = HEb·m1/(1 − HEb) (= 1.5·m1 for HEb = 0.6, as in every row);
//! - plasma insulin: 0 = −(m2 + m4)·Ipb + m1·Ilb + ka1·Isc1 + ka2·Isc2 and
//!   0 = u2ss − (ka1 + kd)·Isc1, 0 = kd·Isc1 − ka2·Isc2, hence
//!   u2ss = (m2 + m4)·Ipb − m1·Ilb, isc1ss = u2ss/(ka1 + kd),
//!   isc2ss = kd·isc1ss/ka2;
//! - EGP: kp1 is defined so that EGP(Gpb, Ib) = EGPb:
//!   kp1 = EGPb + kp2·Gpb + kp3·Ib;
//! - plasma glucose: 0 = EGPb − Fsnc − E(Gpb) − k1·Gpb + k2·Gtb with
//!   E(Gp) = ke1·max(Gp − ke2, 0), hence
//!   Gtb = (Fsnc + E(Gpb) + k1·Gpb − EGPb)/k2;
//! - tissue glucose: 0 = −Vm0·Gtb/(Km0 + Gtb) + k1·Gpb − k2·Gtb, hence
//!   Vm0 = (EGPb − Fsnc − E(Gpb))·(Km0 + Gtb)/Gtb;
//! - subcutaneous glucose: Gs = Gp = Gpb (both masses).
//!
//! With the basal production EGPb primary (as in the published model, where
//! it is a measured basal flux), both glucose balances are explicit: Gtb
//! comes from the plasma balance and the tissue balance then fixes Vm0. The
//! tissue balance is nonlinear in Gtb only if Vm0 is taken as given instead,
//! which is why Gtb is not k1·Gpb/k2. The unused bookkeeping columns follow
//! the public rows: Rdb = EGPb, PCRb = Rdb/Gb.

use crate::patient::{derivatives, MinuteInput, ModelConsts, PatientParams, N_STATES};
use crate::SimError;

/// Columns drawn for a generated patient (log-space mix of two public
/// patients plus noise): body weight, basal glucose, insulin and glucose
/// production, and every rate, volume and gain of the model. m5 and CL are
/// not read by the model; they are mixed like the others so the table stays
/// coherent for whoever reads it.
pub const PRIMARY: [&str; 28] = [
    "BW", "EGPb", "Gb", "Ib", "kabs", "kmax", "kmin", "b", "d", "Vg", "Vi", "Vmx", "Km0", "k2",
    "k1", "p2u", "m1", "m5", "CL", "m2", "m4", "ki", "kp2", "kp3", "kd", "ksc", "ka1", "ka2",
];

/// Columns with one value for every public patient, kept at that value.
pub const COMMON: [&str; 7] = [
    "HEb",
    "f",
    "ke1",
    "ke2",
    "Fsnc",
    "dosekempt",
    "patient_history",
];

/// Columns computed from the primary and common ones (plus the 13 initial
/// states `x0_ 1`..`x0_13`).
pub const DERIVED: [&str; 12] = [
    "Ipb", "m30", "Ilb", "Gpb", "Gtb", "Vm0", "Rdb", "PCRb", "u2ss", "isc1ss", "isc2ss", "kp1",
];

/// Renal excretion E(Gp) (mg/kg/min) of the model.
fn renal(p: &PatientParams, gp: f64) -> f64 {
    if gp > p.ke2 {
        p.ke1 * (gp - p.ke2)
    } else {
        0.0
    }
}

/// Fills every derived column and the initial state from the primary and
/// common columns, so that `x0` is an exact steady state at the basal rate
/// u2ss·BW/6000 U/min with no food. Fails (naming the quantity) when the
/// primary values admit no physical steady state (Gtb <= 0, Vm0 < 0,
/// u2ss <= 0, HEb outside [0, 1)).
pub fn derive_steady_state(p: &mut PatientParams) -> Result<(), SimError> {
    let bad = |param: &str, value: f64, reason: &str| SimError::InvalidParameter {
        patient: p.name.clone(),
        param: param.to_string(),
        value,
        reason: reason.to_string(),
    };
    if !(0.0..1.0).contains(&p.heb) {
        return Err(bad("HEb", p.heb, "hepatic extraction must lie in [0, 1)"));
    }
    let gpb = p.gb * p.vg;
    let ipb = p.ib * p.vi;
    let m30 = p.heb * p.m1 / (1.0 - p.heb);
    let ilb = p.m2 * ipb / (p.m1 + m30);
    let u2ss = (p.m2 + p.m4) * ipb - p.m1 * ilb;
    if !(u2ss.is_finite() && u2ss > 0.0) {
        return Err(bad(
            "u2ss",
            u2ss,
            "derived basal insulin infusion must be > 0 ((m2 + m4)·Ipb > m1·Ilb)",
        ));
    }
    let isc1ss = u2ss / (p.ka1 + p.kd);
    let isc2ss = p.kd * isc1ss / p.ka2;
    let kp1 = p.egpb + p.kp2 * gpb + p.kp3 * p.ib;
    let e = renal(p, gpb);
    let gtb = (p.fsnc + e + p.k1 * gpb - p.egpb) / p.k2;
    if !(gtb.is_finite() && gtb > 0.0) {
        return Err(bad(
            "Gtb",
            gtb,
            "derived basal tissue glucose must be > 0 (k1·Gpb + Fsnc + E > EGPb)",
        ));
    }
    let vm0 = (p.egpb - p.fsnc - e) * (p.km0 + gtb) / gtb;
    if !(vm0.is_finite() && vm0 >= 0.0) {
        return Err(bad(
            "Vm0",
            vm0,
            "derived basal utilisation must be >= 0 (EGPb >= Fsnc + renal excretion)",
        ));
    }
    p.gpb = gpb;
    p.ipb = ipb;
    p.m30 = m30;
    p.ilb = ilb;
    p.u2ss = u2ss;
    p.isc1ss = isc1ss;
    p.isc2ss = isc2ss;
    p.kp1 = kp1;
    p.gtb = gtb;
    p.vm0 = vm0;
    p.rdb = p.egpb;
    p.pcrb = p.egpb / p.gb;
    p.x0 = [
        0.0, 0.0, 0.0, gpb, gtb, ipb, 0.0, p.ib, p.ib, ilb, isc1ss, isc2ss, gpb,
    ];
    Ok(())
}

/// dx/dt at the initial state, with insulin at the basal rate
/// u2ss·BW/6000 U/min, no food and nominal sensitivity: all zero for an
/// exact steady state.
pub fn steady_state_residual(p: &PatientParams) -> [f64; N_STATES] {
    let c = ModelConsts::from_params(p);
    let u = MinuteInput::new(&c, 0.0, p.basal_u_per_min(), 0.0, 1.0);
    derivatives(&c, &u, &p.x0)
}
