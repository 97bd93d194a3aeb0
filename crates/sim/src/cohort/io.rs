//! Cohort tables: the 62 columns of vpatient_params.csv, then the standard
//! therapy and where each patient comes from.

use super::{CarbRatioSource, Cohort, Origin};
use crate::patient::PatientParams;
use crate::SimError;
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};

/// Columns written after the patient-table columns.
pub const THERAPY_COLUMNS: [&str; 8] = [
    "basal_u_per_h",
    "carb_ratio_g_per_u",
    "carb_ratio_source",
    "titrated_carb_ratio_g_per_u",
    "origin",
    "parent_a",
    "parent_b",
    "mix_w",
];

fn io_err(table: &str, line: u64, e: impl std::fmt::Display) -> SimError {
    SimError::Table {
        table: table.to_string(),
        line,
        reason: e.to_string(),
    }
}

impl Cohort {
    /// The header of [`Cohort::write_csv`].
    pub fn csv_header() -> Vec<&'static str> {
        let mut h = PatientParams::columns();
        h.extend_from_slice(&THERAPY_COLUMNS);
        h
    }

    /// Writes one row per patient: the patient-table columns (shortest
    /// round-trip number formatting, so the file reads back exactly), then
    /// [`THERAPY_COLUMNS`]. The output is a pure function of the cohort.
    pub fn write_csv<W: std::io::Write>(&self, out: W) -> Result<(), SimError> {
        let table = "cohort table";
        let mut w = csv::Writer::from_writer(out);
        w.write_record(Self::csv_header())
            .map_err(|e| io_err(table, 1, e))?;
        for (k, p) in self.patients.iter().enumerate() {
            let mut rec = p.params.to_record();
            rec.push(p.therapy.basal.0.to_string());
            rec.push(p.therapy.carb_ratio[0].0.to_string());
            rec.push(p.carb_ratio_source.name().to_string());
            rec.push(p.titration.carb_ratio_g_per_u.to_string());
            match &p.origin {
                Origin::Public => {
                    rec.extend(["public".into(), String::new(), String::new(), String::new()])
                }
                Origin::Generated {
                    parent_a,
                    parent_b,
                    w: mix,
                    ..
                } => rec.extend([
                    "generated".into(),
                    parent_a.clone(),
                    parent_b.clone(),
                    mix.to_string(),
                ]),
            }
            w.write_record(&rec)
                .map_err(|e| io_err(table, k as u64 + 2, e))?;
        }
        w.flush().map_err(|e| io_err(table, 0, e))?;
        Ok(())
    }
}

/// One row of a cohort table read back.
#[derive(Debug, Clone, PartialEq)]
pub struct CohortRow {
    /// The patient.
    pub params: PatientParams,
    /// Its standard therapy.
    pub therapy: TherapySettings,
    /// Where the carb ratio came from.
    pub carb_ratio_source: CarbRatioSource,
}

/// Reads a table written by [`Cohort::write_csv`] (`table` names it in
/// errors). Every row is validated; an error names the line and column.
pub fn read_csv(table: &str, csv_text: &str) -> Result<Vec<CohortRow>, SimError> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_reader(csv_text.as_bytes());
    let header = rdr.headers().map_err(|e| io_err(table, 1, e))?.clone();
    let col = |name: &str| {
        header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| io_err(table, 1, format!("missing column '{name}'")))
    };
    let basal_ix = col("basal_u_per_h")?;
    let cr_ix = col("carb_ratio_g_per_u")?;
    let src_ix = col("carb_ratio_source")?;
    let mut out = Vec::new();
    for (k, rec) in rdr.records().enumerate() {
        let line = k as u64 + 2;
        let rec = rec.map_err(|e| io_err(table, line, e))?;
        let params = PatientParams::from_record(table, &header, &rec, line)?;
        params.validate()?;
        let num = |ix: usize, name: &str| -> Result<f64, SimError> {
            let s = rec.get(ix).unwrap_or("");
            s.trim().parse::<f64>().map_err(|_| {
                io_err(
                    table,
                    line,
                    format!("column '{name}': expected a number, got '{s}'"),
                )
            })
        };
        let basal = num(basal_ix, "basal_u_per_h")?;
        let cr = num(cr_ix, "carb_ratio_g_per_u")?;
        let therapy = TherapySettings::new(UnitsPerHour(basal), GramsPerUnit(cr))
            .map_err(|e| io_err(table, line, e))?;
        let source = match rec.get(src_ix).unwrap_or("").trim() {
            "quest" => CarbRatioSource::Quest,
            "titrated" => CarbRatioSource::Titrated,
            other => {
                return Err(io_err(
                    table,
                    line,
                    format!(
                        "column 'carb_ratio_source': expected quest or titrated, got '{other}'"
                    ),
                ))
            }
        };
        out.push(CohortRow {
            params,
            therapy,
            carb_ratio_source: source,
        });
    }
    Ok(out)
}
