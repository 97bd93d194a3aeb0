//! Full traces of single runs (`abba trial --trace`): every simulated
//! minute as CSV (`traces/<patient>-<scenario>-<arm>.csv`) and every
//! decision with its explanation as JSON lines (`... .decisions.jsonl`).
//! The rows are this module's own type, so the report does not depend on
//! the simulator that produced them.

use std::fmt::Write as _;

use abba_advisor::Decision;
use abba_core::{ScenarioId, Timestamp};

use crate::error::ReportError;
use crate::results::ArmKind;

/// The folder of the traces inside the report folder.
pub const TRACE_DIR: &str = "traces";

/// What happened in one simulated minute.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TraceMinute {
    /// Minutes since 00:00 of D1.
    pub minute: i64,
    /// Plasma glucose at the start of the minute (mg/dL).
    pub plasma_mg_dl: f64,
    /// Subcutaneous glucose at the start of the minute (mg/dL).
    pub subcutaneous_mg_dl: f64,
    /// CGM reading taken this minute, if any (mg/dL).
    pub cgm_mg_dl: Option<f64>,
    /// Finger-stick reading taken this minute, if any (mg/dL).
    pub smbg_mg_dl: Option<f64>,
    /// Carbohydrate eaten during the minute (g/min).
    pub cho_g_per_min: f64,
    /// Insulin infused during the minute, basal plus bolus (U/min).
    pub insulin_u_per_min: f64,
    /// Insulin-sensitivity multiplier s(t) during the minute.
    pub sensitivity: f64,
    /// Basal rate in force on the pump (U/h).
    pub basal_u_per_h: f64,
    /// The advisor's carb ratios (breakfast, lunch, dinner; g/U).
    pub carb_ratio_g_per_u: [f64; 3],
}

/// The header of a minute trace.
pub const TRACE_HEADER: &str = "minute,day,time,plasma_mg_dl,subcutaneous_mg_dl,cgm_mg_dl,smbg_mg_dl,cho_g_per_min,insulin_u_per_min,sensitivity,basal_u_per_h,cr_breakfast_g_per_u,cr_lunch_g_per_u,cr_dinner_g_per_u";

/// The file stem of one run's trace: `adult-003-S1-abba` (`#` would need
/// quoting in shells and URLs).
pub fn trace_stem(patient: &str, scenario: ScenarioId, arm: ArmKind) -> String {
    format!("{}-{scenario}-{arm}", patient.replace('#', "-"))
}

/// Whether `name` (a file in [`TRACE_DIR`]) is one abba writes.
pub fn is_trace_file(name: &str) -> bool {
    name.ends_with(".csv") || name.ends_with(".decisions.jsonl")
}

/// The minute trace as CSV (header, then one line per minute; an absent
/// reading is an empty cell; numbers in shortest round-trip form).
pub fn trace_csv(minutes: impl IntoIterator<Item = TraceMinute>) -> String {
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    let mut csv = format!("{TRACE_HEADER}\n");
    for r in minutes {
        let t = Timestamp(r.minute);
        let m = t.minute_of_day();
        let _ = writeln!(
            csv,
            "{},{},{:02}:{:02},{},{},{},{},{},{},{},{},{},{},{}",
            r.minute,
            t.day_number(),
            m / 60,
            m % 60,
            r.plasma_mg_dl,
            r.subcutaneous_mg_dl,
            opt(r.cgm_mg_dl),
            opt(r.smbg_mg_dl),
            r.cho_g_per_min,
            r.insulin_u_per_min,
            r.sensitivity,
            r.basal_u_per_h,
            r.carb_ratio_g_per_u[0],
            r.carb_ratio_g_per_u[1],
            r.carb_ratio_g_per_u[2]
        );
    }
    csv
}

/// The decisions as JSON lines, one decision a line.
pub fn decisions_jsonl(decisions: &[Decision]) -> Result<String, ReportError> {
    let mut out = String::new();
    for d in decisions {
        out.push_str(
            &serde_json::to_string(d).map_err(|source| ReportError::Json {
                what: "a decision",
                source,
            })?,
        );
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn one_line_per_minute_with_day_and_clock_time() {
        let row = |minute: i64, cgm: Option<f64>| TraceMinute {
            minute,
            plasma_mg_dl: 120.5,
            subcutaneous_mg_dl: 118.0,
            cgm_mg_dl: cgm,
            smbg_mg_dl: None,
            cho_g_per_min: 0.0,
            insulin_u_per_min: 0.015,
            sensitivity: 1.0,
            basal_u_per_h: 0.9,
            carb_ratio_g_per_u: [10.0, 11.0, 12.5],
        };
        let csv = trace_csv([row(0, Some(119.0)), row(1440 + 75, None)]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3);
        assert_eq!(lines[0], TRACE_HEADER);
        assert_eq!(lines[0].split(',').count(), lines[1].split(',').count());
        assert_eq!(
            lines[1],
            "0,1,00:00,120.5,118,119,,0,0.015,1,0.9,10,11,12.5"
        );
        assert!(lines[2].starts_with("1515,2,01:15,"), "{}", lines[2]);
        assert_eq!(
            trace_stem("adult#003", ScenarioId::S3, ArmKind::Abba),
            "adult-003-S3-abba"
        );
        assert!(is_trace_file("adult-003-S3-abba.decisions.jsonl"));
        assert!(!is_trace_file("notes.txt"));
    }
}
