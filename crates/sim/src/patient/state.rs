//! The named 13-state vector of the UVA/Padova 2008 model.

use serde::{Deserialize, Serialize};

/// Model state (Dalla Man et al. 2007; Kovatchev et al. 2009), units as in
/// `spec/uva-padova-model.md` §1.1. Only the solver sees it as an array.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PatientState {
    /// x1, Qsto1: solid carbohydrate in the stomach (mg).
    pub q_sto1: f64,
    /// x2, Qsto2: ground carbohydrate in the stomach (mg).
    pub q_sto2: f64,
    /// x3, Qgut: glucose in the intestine (mg).
    pub q_gut: f64,
    /// x4, Gp: plasma glucose mass (mg/kg).
    pub gp: f64,
    /// x5, Gt: tissue glucose mass (mg/kg).
    pub gt: f64,
    /// x6, Ip: plasma insulin mass (pmol/kg).
    pub ip: f64,
    /// x7, X: insulin action on utilisation (pmol/L).
    pub x: f64,
    /// x8, I1: first delay of the insulin signal to the liver (pmol/L).
    pub i1: f64,
    /// x9, Id: delayed insulin signal to the liver (pmol/L).
    pub id: f64,
    /// x10, Il: liver insulin mass (pmol/kg).
    pub il: f64,
    /// x11, Isc1: subcutaneous non-monomeric insulin (pmol/kg).
    pub isc1: f64,
    /// x12, Isc2: subcutaneous monomeric insulin (pmol/kg).
    pub isc2: f64,
    /// x13, Gs: subcutaneous glucose, kept as a mass like Gp (mg/kg).
    pub gs: f64,
}

impl PatientState {
    /// Names of the states in array order (x1..x13).
    pub const NAMES: [&'static str; 13] = [
        "q_sto1", "q_sto2", "q_gut", "gp", "gt", "ip", "x", "i1", "id", "il", "isc1", "isc2", "gs",
    ];

    /// The state as the solver's array.
    pub fn to_array(&self) -> [f64; 13] {
        [
            self.q_sto1,
            self.q_sto2,
            self.q_gut,
            self.gp,
            self.gt,
            self.ip,
            self.x,
            self.i1,
            self.id,
            self.il,
            self.isc1,
            self.isc2,
            self.gs,
        ]
    }

    /// The state from the solver's array.
    pub fn from_array(a: &[f64; 13]) -> Self {
        Self {
            q_sto1: a[0],
            q_sto2: a[1],
            q_gut: a[2],
            gp: a[3],
            gt: a[4],
            ip: a[5],
            x: a[6],
            i1: a[7],
            id: a[8],
            il: a[9],
            isc1: a[10],
            isc2: a[11],
            gs: a[12],
        }
    }
}
