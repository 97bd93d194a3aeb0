//! Patient parameters of the UVA/Padova 2008 model, as in simglucose's
//! `vpatient_params.csv`, and the 30 public patients compiled into the binary.
//!
//! Column meanings and units: `data/uva-padova/README.md`.

use crate::error::SimError;
use serde::{Deserialize, Serialize};

/// The public parameter table (simglucose, MIT; see `data/uva-padova/README.md`).
pub const PUBLIC_TABLE_CSV: &str = include_str!("../../../../data/uva-padova/vpatient_params.csv");
/// The public questionnaire table (carb ratio, correction factor, age, TDI).
pub const QUEST_TABLE_CSV: &str = include_str!("../../../../data/uva-padova/Quest.csv");

/// Number of model states.
pub const N_STATES: usize = 13;

/// Column names of the initial state, as they appear in the table (note the spaces).
pub const X0_COLUMNS: [&str; N_STATES] = [
    "x0_ 1", "x0_ 2", "x0_ 3", "x0_ 4", "x0_ 5", "x0_ 6", "x0_ 7", "x0_ 8", "x0_ 9", "x0_10",
    "x0_11", "x0_12", "x0_13",
];

macro_rules! scalar_params {
    ($( $field:ident = $col:literal : $doc:literal ),* $(,)?) => {
        /// One virtual patient: every column of `vpatient_params.csv`.
        ///
        /// Field names are the column names in snake case; units as in the
        /// data README (minutes, mg/kg, pmol/kg, pmol/L, dL/kg, L/kg).
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        pub struct PatientParams {
            /// Patient name, e.g. `adult#001`.
            pub name: String,
            /// Integer id from the original population (unused by the model).
            pub i: u32,
            /// Initial state x1..x13 (columns `x0_ 1`..`x0_13`).
            pub x0: [f64; N_STATES],
            $( #[doc = $doc] pub $field: f64, )*
        }

        impl PatientParams {
            /// The scalar columns after the initial state, in table order.
            pub const SCALAR_COLUMNS: &'static [&'static str] = &[$($col),*];

            /// The scalar parameters in table order (parallel to `SCALAR_COLUMNS`).
            pub fn scalars(&self) -> Vec<f64> {
                vec![$(self.$field),*]
            }

            /// Mutable access to a scalar parameter by its column name.
            pub fn scalar_mut(&mut self, column: &str) -> Option<&mut f64> {
                match column {
                    $($col => Some(&mut self.$field),)*
                    _ => None,
                }
            }

            /// A scalar parameter by its column name.
            pub fn scalar(&self, column: &str) -> Option<f64> {
                match column {
                    $($col => Some(self.$field),)*
                    _ => None,
                }
            }
        }
    };
}

scalar_params! {
    bw = "BW": "Body weight (kg).",
    egpb = "EGPb": "Basal endogenous glucose production (mg/kg/min).",
    gb = "Gb": "Basal plasma glucose (mg/dL).",
    ib = "Ib": "Basal plasma insulin (pmol/L); used in the X equation.",
    kabs = "kabs": "Intestinal absorption rate (1/min).",
    kmax = "kmax": "Maximum gastric emptying rate, also the grinding rate (1/min).",
    kmin = "kmin": "Minimum gastric emptying rate (1/min).",
    b = "b": "Fraction of the dose where emptying first changes speed.",
    d = "d": "Fraction of the dose where emptying changes speed again.",
    vg = "Vg": "Glucose distribution volume (dL/kg).",
    vi = "Vi": "Insulin distribution volume (L/kg).",
    ipb = "Ipb": "Basal plasma insulin mass (pmol/kg).",
    vmx = "Vmx": "Insulin-dependent part of utilisation Vmax (mg/kg/min per pmol/L).",
    km0 = "Km0": "Michaelis-Menten constant of utilisation (mg/kg).",
    k2 = "k2": "Tissue to plasma glucose rate (1/min).",
    k1 = "k1": "Plasma to tissue glucose rate (1/min).",
    p2u = "p2u": "Rate of insulin action on utilisation (1/min).",
    m1 = "m1": "Liver to plasma insulin rate (1/min).",
    m5 = "m5": "Hepatic-extraction slope (unused by the model).",
    cl = "CL": "Insulin clearance (L/min; unused by the model).",
    heb = "HEb": "Basal hepatic extraction (unused by the model).",
    m2 = "m2": "Plasma to liver insulin rate (1/min).",
    m4 = "m4": "Peripheral insulin degradation rate (1/min).",
    m30 = "m30": "Hepatic insulin degradation rate (1/min).",
    ilb = "Ilb": "Basal liver insulin mass (pmol/kg).",
    ki = "ki": "Rate of the delayed insulin signal to the liver (1/min).",
    kp2 = "kp2": "Liver glucose effectiveness (1/min).",
    kp3 = "kp3": "Liver insulin action (mg/kg/min per pmol/L).",
    f = "f": "Fraction of meal carbohydrate appearing in plasma.",
    gpb = "Gpb": "Basal plasma glucose mass (mg/kg).",
    ke1 = "ke1": "Renal excretion rate (1/min).",
    ke2 = "ke2": "Renal threshold as a plasma glucose mass (mg/kg).",
    fsnc = "Fsnc": "Insulin-independent utilisation (mg/kg/min).",
    gtb = "Gtb": "Basal tissue glucose mass (mg/kg).",
    vm0 = "Vm0": "Basal part of utilisation Vmax (mg/kg/min).",
    rdb = "Rdb": "Basal rate of glucose disappearance (mg/kg/min; unused).",
    pcrb = "PCRb": "Rdb/Gb (dL/kg/min; unused).",
    kd = "kd": "Subcutaneous insulin rate Isc1 to Isc2 (1/min).",
    ksc = "ksc": "Plasma to subcutaneous glucose rate (1/min).",
    ka1 = "ka1": "Subcutaneous insulin rate Isc1 to plasma (1/min).",
    ka2 = "ka2": "Subcutaneous insulin rate Isc2 to plasma (1/min).",
    dosekempt = "dosekempt": "Reference meal dose (mg; unused by the model).",
    u2ss = "u2ss": "Steady-state subcutaneous insulin infusion (pmol/kg/min).",
    isc1ss = "isc1ss": "Steady-state Isc1 (pmol/kg).",
    isc2ss = "isc2ss": "Steady-state Isc2 (pmol/kg).",
    kp1 = "kp1": "EGP at zero glucose and insulin (mg/kg/min).",
    patient_history = "patient_history": "Unused flag (0 in every row).",
}

impl PatientParams {
    /// All column names of the table, in order.
    pub fn columns() -> Vec<&'static str> {
        let mut c = vec!["Name", "i"];
        c.extend_from_slice(&X0_COLUMNS);
        c.extend_from_slice(Self::SCALAR_COLUMNS);
        c
    }

    /// The basal insulin rate that keeps the patient at steady state (U/min):
    /// u2ss·BW/6000.
    pub fn basal_u_per_min(&self) -> f64 {
        self.u2ss * self.bw / abba_core::PMOL_PER_UNIT
    }

    /// One row of the table as strings, in `columns()` order (shortest
    /// round-trip float formatting, so a written table reads back exactly).
    pub fn to_record(&self) -> Vec<String> {
        let mut r = vec![self.name.clone(), self.i.to_string()];
        r.extend(self.x0.iter().map(|v| v.to_string()));
        r.extend(self.scalars().iter().map(|v| v.to_string()));
        r
    }

    /// Parses one row. `header` is the table's header; `line` is the
    /// 1-based line number for error messages.
    pub fn from_record(
        table: &str,
        header: &csv::StringRecord,
        record: &csv::StringRecord,
        line: u64,
    ) -> Result<Self, SimError> {
        let err = |reason: String| SimError::Table {
            table: table.to_string(),
            line,
            reason,
        };
        let get = |col: &str| -> Result<&str, SimError> {
            let idx = header
                .iter()
                .position(|h| h == col)
                .ok_or_else(|| err(format!("missing column '{col}'")))?;
            record
                .get(idx)
                .ok_or_else(|| err(format!("row has no value for column '{col}'")))
        };
        let num = |col: &str| -> Result<f64, SimError> {
            let s = get(col)?;
            let v: f64 = s
                .trim()
                .parse()
                .map_err(|_| err(format!("column '{col}': expected a number, got '{s}'")))?;
            if !v.is_finite() {
                return Err(err(format!(
                    "column '{col}': expected a finite number, got '{s}'"
                )));
            }
            Ok(v)
        };
        let name = get("Name")?.trim().to_string();
        if name.is_empty() {
            return Err(err("column 'Name' is empty".into()));
        }
        let i_str = get("i")?;
        let i: u32 = i_str.trim().parse().map_err(|_| {
            err(format!(
                "column 'i': expected a non-negative integer, got '{i_str}'"
            ))
        })?;
        let mut x0 = [0.0; N_STATES];
        for (k, col) in X0_COLUMNS.iter().enumerate() {
            x0[k] = num(col)?;
        }
        let mut p = PatientParams::zeroed(name, i, x0);
        for col in Self::SCALAR_COLUMNS {
            let v = num(col)?;
            if let Some(slot) = p.scalar_mut(col) {
                *slot = v;
            }
        }
        Ok(p)
    }

    fn zeroed(name: String, i: u32, x0: [f64; N_STATES]) -> Self {
        PatientParams {
            name,
            i,
            x0,
            bw: 0.0,
            egpb: 0.0,
            gb: 0.0,
            ib: 0.0,
            kabs: 0.0,
            kmax: 0.0,
            kmin: 0.0,
            b: 0.0,
            d: 0.0,
            vg: 0.0,
            vi: 0.0,
            ipb: 0.0,
            vmx: 0.0,
            km0: 0.0,
            k2: 0.0,
            k1: 0.0,
            p2u: 0.0,
            m1: 0.0,
            m5: 0.0,
            cl: 0.0,
            heb: 0.0,
            m2: 0.0,
            m4: 0.0,
            m30: 0.0,
            ilb: 0.0,
            ki: 0.0,
            kp2: 0.0,
            kp3: 0.0,
            f: 0.0,
            gpb: 0.0,
            ke1: 0.0,
            ke2: 0.0,
            fsnc: 0.0,
            gtb: 0.0,
            vm0: 0.0,
            rdb: 0.0,
            pcrb: 0.0,
            kd: 0.0,
            ksc: 0.0,
            ka1: 0.0,
            ka2: 0.0,
            dosekempt: 0.0,
            u2ss: 0.0,
            isc1ss: 0.0,
            isc2ss: 0.0,
            kp1: 0.0,
            patient_history: 0.0,
        }
    }

    /// Reads a whole parameter table (CSV text with the 62 columns).
    pub fn read_table(table: &str, csv_text: &str) -> Result<Vec<PatientParams>, SimError> {
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .from_reader(csv_text.as_bytes());
        let header = rdr
            .headers()
            .map_err(|e| SimError::Table {
                table: table.into(),
                line: 1,
                reason: e.to_string(),
            })?
            .clone();
        let mut out = Vec::new();
        for (k, rec) in rdr.records().enumerate() {
            let line = k as u64 + 2;
            let rec = rec.map_err(|e| SimError::Table {
                table: table.into(),
                line,
                reason: e.to_string(),
            })?;
            let p = PatientParams::from_record(table, &header, &rec, line)?;
            p.validate()?;
            out.push(p);
        }
        Ok(out)
    }

    /// The 30 public patients (adolescents, adults, children), validated.
    pub fn all_public() -> Result<Vec<PatientParams>, SimError> {
        Self::read_table("vpatient_params.csv (built in)", PUBLIC_TABLE_CSV)
    }

    /// One public patient by exact name (`adult#001`, `adolescent#010`, `child#005`, ...).
    pub fn public(name: &str) -> Result<PatientParams, SimError> {
        let all = Self::all_public()?;
        let names: Vec<String> = all.iter().map(|p| p.name.clone()).collect();
        all.into_iter()
            .find(|p| p.name == name)
            .ok_or_else(|| SimError::UnknownPatient {
                name: name.to_string(),
                known: name_ranges(&names),
            })
    }

    /// Checks every parameter the model reads: finite, and positive where
    /// the physiology needs it; the initial state finite and non-negative
    /// where the model's sign guards assume it.
    pub fn validate(&self) -> Result<(), SimError> {
        let bad = |param: &str, value: f64, reason: &str| SimError::InvalidParameter {
            patient: self.name.clone(),
            param: param.to_string(),
            value,
            reason: reason.to_string(),
        };
        for (col, v) in Self::SCALAR_COLUMNS.iter().zip(self.scalars()) {
            if !v.is_finite() {
                return Err(bad(col, v, "must be a finite number"));
            }
        }
        let positive = [
            ("BW", self.bw),
            ("kabs", self.kabs),
            ("kmax", self.kmax),
            ("Vg", self.vg),
            ("Vi", self.vi),
            ("Km0", self.km0),
            ("k1", self.k1),
            ("k2", self.k2),
            ("p2u", self.p2u),
            ("ki", self.ki),
            ("kd", self.kd),
            ("ka1", self.ka1),
            ("ka2", self.ka2),
            ("ksc", self.ksc),
            ("u2ss", self.u2ss),
            ("Ib", self.ib),
        ];
        for (col, v) in positive {
            if v <= 0.0 {
                return Err(bad(col, v, "must be > 0"));
            }
        }
        let non_negative = [
            ("kmin", self.kmin),
            ("Vmx", self.vmx),
            ("m1", self.m1),
            ("m2", self.m2),
            ("m4", self.m4),
            ("m30", self.m30),
            ("kp1", self.kp1),
            ("kp2", self.kp2),
            ("kp3", self.kp3),
            ("ke1", self.ke1),
            ("ke2", self.ke2),
            ("Fsnc", self.fsnc),
            ("Vm0", self.vm0),
        ];
        for (col, v) in non_negative {
            if v < 0.0 {
                return Err(bad(col, v, "must be >= 0"));
            }
        }
        if self.kmin > self.kmax {
            return Err(bad("kmin", self.kmin, "must not exceed kmax"));
        }
        if !(self.b > 0.0 && self.b < 1.0) {
            return Err(bad("b", self.b, "must lie in (0, 1)"));
        }
        if !(self.d > 0.0 && self.d < 1.0) {
            return Err(bad("d", self.d, "must lie in (0, 1)"));
        }
        if !(self.f > 0.0 && self.f <= 1.0) {
            return Err(bad("f", self.f, "must lie in (0, 1]"));
        }
        for (k, v) in self.x0.iter().enumerate() {
            if !v.is_finite() {
                return Err(bad(X0_COLUMNS[k], *v, "initial state must be finite"));
            }
        }
        for k in [0usize, 1, 2, 3, 4, 5, 9, 10, 11, 12] {
            if self.x0[k] < 0.0 {
                return Err(bad(X0_COLUMNS[k], self.x0[k], "initial mass must be >= 0"));
            }
        }
        Ok(())
    }
}

/// One row of Quest.csv: a patient's clinical questionnaire values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuestRow {
    /// Patient name.
    #[serde(rename = "Name")]
    pub name: String,
    /// Carbohydrate ratio (g/U).
    #[serde(rename = "CR")]
    pub cr: f64,
    /// Correction factor (mg/dL per U).
    #[serde(rename = "CF")]
    pub cf: f64,
    /// Age (years).
    #[serde(rename = "Age")]
    pub age: f64,
    /// Total daily insulin (U/day).
    #[serde(rename = "TDI")]
    pub tdi: f64,
}

impl QuestRow {
    /// All 30 rows of the built-in Quest table.
    pub fn all() -> Result<Vec<QuestRow>, SimError> {
        let mut rdr = csv::Reader::from_reader(QUEST_TABLE_CSV.as_bytes());
        let mut out = Vec::new();
        for (k, rec) in rdr.deserialize().enumerate() {
            let row: QuestRow = rec.map_err(|e| SimError::Table {
                table: "Quest.csv (built in)".into(),
                line: k as u64 + 2,
                reason: e.to_string(),
            })?;
            out.push(row);
        }
        Ok(out)
    }

    /// The Quest row of a public patient.
    pub fn for_patient(name: &str) -> Result<QuestRow, SimError> {
        Self::all()?
            .into_iter()
            .find(|q| q.name == name)
            .ok_or_else(|| SimError::UnknownPatient {
                name: name.into(),
                known: "the 30 public patients".into(),
            })
    }
}

/// The names as ranges per group, in table order:
/// `adolescent#001..#010, adult#001..#010, child#001..#010`.
fn name_ranges(names: &[String]) -> String {
    let mut groups: Vec<(&str, &str, &str)> = Vec::new();
    for name in names {
        let (group, number) = name.split_once('#').unwrap_or((name.as_str(), ""));
        match groups.last_mut() {
            Some((g, _, last)) if *g == group => *last = number,
            _ => groups.push((group, number, number)),
        }
    }
    groups
        .iter()
        .map(|(g, first, last)| format!("{g}#{first}..#{last}"))
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loads_all_thirty_public_patients() {
        let all = PatientParams::all_public().unwrap();
        assert_eq!(all.len(), 30);
        let a1 = PatientParams::public("adult#001").unwrap();
        assert_eq!(a1.bw, 102.32);
        assert_eq!(a1.x0[3], 265.370112);
        assert!((a1.basal_u_per_min() - 0.02112267499992533).abs() < 1e-15);
        assert_eq!(QuestRow::for_patient("adult#001").unwrap().cr, 10.0);
    }

    #[test]
    fn unknown_patient_is_a_clear_error() {
        let e = PatientParams::public("adult#999").unwrap_err().to_string();
        assert!(e.contains("adult#999"), "{e}");
    }

    #[test]
    fn record_round_trips() {
        let p = PatientParams::public("child#003").unwrap();
        let header = csv::StringRecord::from(PatientParams::columns());
        let rec = csv::StringRecord::from(p.to_record());
        let q = PatientParams::from_record("t", &header, &rec, 2).unwrap();
        assert_eq!(p, q);
    }

    #[test]
    fn bad_value_names_line_and_column() {
        let mut text = PUBLIC_TABLE_CSV
            .lines()
            .take(3)
            .collect::<Vec<_>>()
            .join("\n");
        text = text.replacen("68.706", "abc", 1);
        let e = PatientParams::read_table("t.csv", &text)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("BW") && e.contains("abc"),
            "{e}"
        );
    }
}
