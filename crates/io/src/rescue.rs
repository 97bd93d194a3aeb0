//! Hypoglycaemia treatments are not meals: carbohydrate taken while
//! glucose is below 70 mg/dL, or within 15 minutes after such a reading,
//! with no bolus (or injection logged as an event marker) within 15
//! minutes of it, is a rescue treatment. It is
//! counted and shown, never announced to the advisor as a meal, so it
//! never moves a carb ratio.

use crate::record::{Record, RecordKind};

/// A reading below this is low (mg/dL).
pub const LOW_MG_DL: f64 = 70.0;
/// Carbohydrate this soon after a low reading treats it (minutes).
pub const AFTER_LOW_MIN: i64 = 15;
/// A bolus this close to the carbohydrate makes it a meal (minutes).
pub const BOLUS_NEAR_MIN: i64 = 15;
/// The key of the rescue count in an event stream's counts.
pub const COUNT_KEY: &str = "rescue_carbs";
/// The rule in words.
pub const RULE: &str = "carbohydrate within 15 min after a glucose reading below 70 mg/dL, with no bolus within 15 min";

/// The low readings and boluses of a record stream, by instant.
pub struct Rescue {
    lows: Vec<jiff::Timestamp>,
    /// Every glucose reading: (instant, low?).
    readings: Vec<(jiff::Timestamp, bool)>,
    boluses: Vec<jiff::Timestamp>,
}

impl Rescue {
    /// Indexes `records` (any order).
    pub fn new(records: &[Record]) -> Self {
        let mut readings = Vec::new();
        let mut boluses = Vec::new();
        for r in records {
            match &r.kind {
                RecordKind::Cgm { glucose } | RecordKind::Smbg { glucose } => {
                    readings.push((r.at, glucose.mg_dl.0 < LOW_MG_DL))
                }
                RecordKind::Bolus { units } if units.0 > 0.0 => boluses.push(r.at),
                RecordKind::ExtendedBolus { .. } => boluses.push(r.at),
                // An injection logged in a CGM's app (CareLink's `Insulin:
                // N` marker): insulin at the meal, as a bolus is.
                RecordKind::Ignored { kind } if kind == crate::read::carelink::INSULIN_MARKER => {
                    boluses.push(r.at)
                }
                _ => {}
            }
        }
        readings.sort_by_key(|x| x.0);
        boluses.sort();
        let lows = readings.iter().filter(|x| x.1).map(|x| x.0).collect();
        Self {
            lows,
            readings,
            boluses,
        }
    }

    /// True when carbohydrate at `at` treats a low: the latest reading at
    /// or before `at` within 15 min was low (glucose below 70 mg/dL now or
    /// just before), and no bolus lies within 15 min.
    pub fn is_rescue(&self, at: jiff::Timestamp) -> bool {
        if self.lows.is_empty() {
            return false;
        }
        let window = jiff::SignedDuration::from_mins(AFTER_LOW_MIN);
        let i = self.readings.partition_point(|x| x.0 <= at);
        let low_before = self.readings[..i]
            .iter()
            .rev()
            .take_while(|x| at.duration_since(x.0) <= window)
            .any(|x| x.1);
        if !low_before {
            return false;
        }
        let near = jiff::SignedDuration::from_mins(BOLUS_NEAR_MIN);
        let j = self.boluses.partition_point(|&b| b < at);
        let close = |b: &jiff::Timestamp| at.duration_since(*b).abs() <= near;
        !(self.boluses.get(j).is_some_and(close) || j > 0 && close(&self.boluses[j - 1]))
    }
}
