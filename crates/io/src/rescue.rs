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
/// The rule in words, the low limit in the person's unit (70 mg/dL,
/// 3.9 mmol/L).
pub fn rule(units: crate::units::GlucoseUnit) -> String {
    format!(
        "carbohydrate within {AFTER_LOW_MIN} min after a glucose reading below {}, with no bolus within {BOLUS_NEAR_MIN} min",
        units.with_unit(LOW_MG_DL)
    )
}

/// The low readings and boluses of a record stream, by instant (only the
/// low readings are kept: a long log's in-range readings would weigh the
/// most and decide nothing).
pub struct Rescue {
    lows: Vec<jiff::Timestamp>,
    boluses: Vec<jiff::Timestamp>,
}

impl Rescue {
    /// Indexes `records` (any order).
    pub fn new(records: &[Record]) -> Self {
        let mut lows = Vec::new();
        let mut boluses = Vec::new();
        for r in records {
            match &r.kind {
                RecordKind::Cgm { glucose } | RecordKind::Smbg { glucose }
                    if glucose.mg_dl.0 < LOW_MG_DL =>
                {
                    lows.push(r.at)
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
        lows.sort();
        boluses.sort();
        Self { lows, boluses }
    }

    /// True when carbohydrate at `at` treats a low: a reading at or
    /// before `at`, within 15 min, was low (glucose below 70 mg/dL now or
    /// just before), and no bolus lies within 15 min.
    pub fn is_rescue(&self, at: jiff::Timestamp) -> bool {
        let window = jiff::SignedDuration::from_mins(AFTER_LOW_MIN);
        // The latest low at or before `at` is within the window exactly
        // when some low is.
        let i = self.lows.partition_point(|&t| t <= at);
        let low_before = i > 0 && at.duration_since(self.lows[i - 1]) <= window;
        if !low_before {
            return false;
        }
        let near = jiff::SignedDuration::from_mins(BOLUS_NEAR_MIN);
        let j = self.boluses.partition_point(|&b| b < at);
        let close = |b: &jiff::Timestamp| at.duration_since(*b).abs() <= near;
        !(self.boluses.get(j).is_some_and(close) || j > 0 && close(&self.boluses[j - 1]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Glucose, Origin, OriginAt, Source, SourceId};
    use abba_core::Units;

    fn at(min: i64) -> jiff::Timestamp {
        jiff::Timestamp::from_second(1_780_000_000 + min * 60).unwrap()
    }

    fn record(min: i64, kind: RecordKind) -> Record {
        Record {
            at: at(min),
            kind,
            source: Source::Nightscout,
            id: SourceId::Hash(min as u64),
            origin: Origin {
                file: 0,
                at: OriginAt::Item(0),
            },
        }
    }

    fn reading(min: i64, mg_dl: f64) -> Record {
        record(
            min,
            RecordKind::Cgm {
                glucose: Glucose::exact(mg_dl),
            },
        )
    }

    #[test]
    fn carbohydrate_within_15_min_after_a_low_without_a_bolus_is_a_rescue() {
        // A low at 0, an in-range reading at 5 (the low still counts), a
        // bolus at 100.
        let records = [
            reading(0, 62.0),
            reading(5, 75.0),
            reading(20, 80.0),
            record(100, RecordKind::Bolus { units: Units(2.0) }),
            reading(95, 65.0),
        ];
        let r = Rescue::new(&records);
        assert!(r.is_rescue(at(0)), "at the low itself");
        assert!(
            r.is_rescue(at(10)),
            "10 min after it, a later reading in range"
        );
        assert!(r.is_rescue(at(15)), "15 min after it");
        assert!(!r.is_rescue(at(16)), "16 min after it");
        assert!(!r.is_rescue(at(-1)), "before it");
        assert!(!r.is_rescue(at(96)), "a bolus 4 min later: a meal");
        assert!(
            !Rescue::new(&records[1..3]).is_rescue(at(10)),
            "no low at all"
        );
    }
}
