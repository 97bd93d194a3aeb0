//! `patients.csv`: one row per arm × patient × evaluation week (every week
//! simulated, W1..W12, W13, W14), with the window's days, the 16 metric keys
//! in the protocol's order ([`Metric::ALL`]; an undefined MAGE is an empty
//! cell) and, repeated on each of the patient's rows, the patient's start and
//! final therapy settings, pump caps, minimum glucose over the run and, for
//! a run stopped early (plasma glucose below the failure threshold), where
//! it stopped (`stopped_*`, empty otherwise; such a patient has rows only
//! for the weeks that ended before the stop). Rows
//! follow the report's arm order (S1..S4; abba, standard, r2r), then cohort
//! order, then week order. Numbers are written in full precision (shortest
//! round-trip form).

use abba_core::Metric;

use crate::error::ReportError;
use crate::results::ArmResult;
use crate::select::{ordered_arms, validate_arms};

/// The header of `patients.csv`.
pub fn patients_csv_header() -> Vec<&'static str> {
    let mut h = vec![
        "scenario",
        "advisor",
        "mode",
        "patient",
        "week",
        "first_day",
        "last_day",
    ];
    h.extend(Metric::ALL.map(Metric::key));
    h.extend([
        "start_basal_u_per_h",
        "start_carb_ratio_g_per_u",
        "final_basal_u_per_h",
        "final_carb_ratio_breakfast_g_per_u",
        "final_carb_ratio_lunch_g_per_u",
        "final_carb_ratio_dinner_g_per_u",
        "pump_capped",
        "min_glucose_mg_dl",
        "stopped_day",
        "stopped_minute_of_day",
        "stopped_glucose_mg_dl",
    ]);
    h
}

/// The whole `patients.csv` text.
pub fn patients_csv(arms: &[ArmResult]) -> Result<String, ReportError> {
    validate_arms(arms)?;
    let err = |reason: String| ReportError::Csv {
        what: "patients.csv",
        reason,
    };
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(patients_csv_header())
        .map_err(|e| err(e.to_string()))?;
    for arm in ordered_arms(arms) {
        for p in &arm.patients {
            for week in &p.weeks {
                let mut rec: Vec<String> = vec![
                    arm.scenario.to_string(),
                    arm.advisor.to_string(),
                    arm.mode.name().to_string(),
                    p.patient.clone(),
                    week.week.to_string(),
                    week.first_day.to_string(),
                    week.last_day.to_string(),
                ];
                rec.extend(
                    Metric::ALL.map(|m| week.value(m).map(|v| v.to_string()).unwrap_or_default()),
                );
                rec.extend([
                    p.start_basal_u_per_h.to_string(),
                    p.start_carb_ratio_g_per_u.to_string(),
                    p.final_basal_u_per_h.to_string(),
                    p.final_carb_ratio_g_per_u[0].to_string(),
                    p.final_carb_ratio_g_per_u[1].to_string(),
                    p.final_carb_ratio_g_per_u[2].to_string(),
                    p.pump_capped.to_string(),
                    p.min_glucose_mg_dl.to_string(),
                    p.failure.map(|f| f.day.to_string()).unwrap_or_default(),
                    p.failure
                        .map(|f| f.minute_of_day.to_string())
                        .unwrap_or_default(),
                    p.failure
                        .map(|f| f.glucose_mg_dl.to_string())
                        .unwrap_or_default(),
                ]);
                w.write_record(&rec).map_err(|e| err(e.to_string()))?;
            }
        }
    }
    let bytes = w.into_inner().map_err(|e| err(e.to_string()))?;
    String::from_utf8(bytes).map_err(|e| err(e.to_string()))
}
