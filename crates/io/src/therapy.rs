//! The therapy a pump runs, from its export: the basal schedule and the carb
//! ratios of a settings profile (a Nightscout profile store or Profile
//! Switch, Tidepool `pumpSettings`), each value checked against
//! [`abba_core::limits`], the carb-ratio schedule mapped to the three meal
//! slots by the value in force for the longest part of each meal window.
//!
//! A schedule record without carb ratios (Tidepool's delivered scheduled
//! basal) says what was delivered, not what the settings are: it is not a
//! settings profile here.

use std::path::PathBuf;

use abba_core::limits::{BASAL_U_PER_H, CARB_RATIO_G_PER_U};
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use serde::Serialize;
use serde_json::Value;

use crate::error::{IoError, Location};
use crate::meals::MealWindows;
use crate::read::{read_files, Batch, Format, ReadOptions};
use crate::record::{Profile, RecordKind};

/// A pump's settings in force from an instant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PumpTherapy {
    /// The basal schedule: (minute of the local day it starts, U/h).
    pub basal: Vec<(u32, f64)>,
    /// The carb-ratio schedule: (minute of the local day, g/U).
    pub carb_ratio_schedule: Vec<(u32, f64)>,
    /// The carb ratio of breakfast, lunch and dinner (the value in force
    /// for the longest part of each meal window).
    pub carb_ratio: [f64; 3],
    /// Where it was read (file and JSON item).
    pub origin: String,
    /// In force from (UTC).
    #[serde(serialize_with = "crate::time::serialize_instant")]
    pub at: jiff::Timestamp,
}

/// The value of a time-of-day schedule in force for the longest part of
/// `[from, to)` (minutes of the day; the earlier value on a tie).
pub fn value_for_window(schedule: &[(u32, f64)], (from, to): (u32, u32)) -> Option<f64> {
    let mut best: Option<(u32, f64)> = None;
    for (i, &(start, v)) in schedule.iter().enumerate() {
        let end = schedule.get(i + 1).map_or(1440, |s| s.0);
        let overlap = end.min(to).saturating_sub(start.max(from));
        if overlap > 0 && best.is_none_or(|(b, _)| overlap > b) {
            best = Some((overlap, v));
        }
    }
    best.map(|b| b.1)
}

fn hhmm(m: u32) -> String {
    format!("{:02}:{:02}", m / 60, m % 60)
}

impl PumpTherapy {
    /// From a profile: every value checked against the plausibility limits
    /// (an error names `origin` and the segment).
    pub fn from_profile(
        profile: &Profile,
        meals: &MealWindows,
        origin: String,
        at: jiff::Timestamp,
    ) -> Result<Self, IoError> {
        let loc = Location::file(&origin);
        let basal: Vec<(u32, f64)> = profile
            .basal
            .segments
            .iter()
            .map(|s| (s.0, s.1 .0))
            .collect();
        let cr: Vec<(u32, f64)> = profile.carb_ratio.iter().map(|s| (s.0, s.1 .0)).collect();
        for &(m, r) in &basal {
            BASAL_U_PER_H.check(r).map_err(|e| {
                IoError::invalid(
                    loc.clone(),
                    &format!("basal from {}", hhmm(m)),
                    e.to_string(),
                )
            })?;
        }
        for &(m, r) in &cr {
            CARB_RATIO_G_PER_U.check(r).map_err(|e| {
                IoError::invalid(
                    loc.clone(),
                    &format!("carb ratio from {}", hhmm(m)),
                    e.to_string(),
                )
            })?;
        }
        if basal.is_empty() || cr.is_empty() {
            return Err(IoError::invalid(
                loc,
                "profile",
                "a settings profile needs a basal schedule and carb ratios",
            ));
        }
        let windows = [meals.breakfast, meals.lunch, meals.dinner];
        let mut carb_ratio = [0.0; 3];
        for (i, w) in windows.into_iter().enumerate() {
            carb_ratio[i] = value_for_window(&cr, w).unwrap_or(cr[0].1);
        }
        Ok(Self {
            basal,
            carb_ratio_schedule: cr,
            carb_ratio,
            origin,
            at,
        })
    }

    /// The schedule's mean rate (daily basal / 24 h): the flat equivalent the
    /// advisor adapts.
    pub fn mean_basal(&self) -> f64 {
        let mut total = 0.0;
        for (i, &(from, r)) in self.basal.iter().enumerate() {
            let to = self.basal.get(i + 1).map_or(1440, |s| s.0);
            total += r * f64::from(to.saturating_sub(from));
        }
        total / 1440.0
    }

    /// As the advisor's settings (the mean basal rate, three carb ratios).
    pub fn settings(&self) -> TherapySettings {
        TherapySettings {
            basal: UnitsPerHour(self.mean_basal()),
            carb_ratio: self.carb_ratio.map(GramsPerUnit),
        }
    }

    /// The basal schedule and carb ratios in words.
    pub fn describe(&self) -> String {
        let basal = if self.basal.len() == 1 {
            format!("basal {} U/h", self.basal[0].1)
        } else {
            let segs: Vec<String> = self
                .basal
                .iter()
                .map(|&(m, r)| format!("{} {r}", hhmm(m)))
                .collect();
            format!(
                "basal schedule {} U/h (mean {:.3} U/h)",
                segs.join(", "),
                self.mean_basal()
            )
        };
        let [b, l, d] = self.carb_ratio;
        format!("{basal}, carb ratios {b}/{l}/{d} g/U")
    }

    /// True when both say the same (schedule and per-slot ratios).
    pub fn same_settings(&self, basal: &[(u32, f64)], carb_ratio: [f64; 3]) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
        self.basal.len() == basal.len()
            && self
                .basal
                .iter()
                .zip(basal)
                .all(|(a, b)| a.0 == b.0 && close(a.1, b.1))
            && self
                .carb_ratio
                .iter()
                .zip(carb_ratio)
                .all(|(a, b)| close(*a, b))
    }
}

/// Every settings profile of a batch (schedule records that carry carb
/// ratios), oldest first.
pub fn settings_profiles(batch: &Batch, meals: &MealWindows) -> Result<Vec<PumpTherapy>, IoError> {
    let mut out = Vec::new();
    for r in &batch.records {
        if let RecordKind::Schedule { profile } = &r.kind {
            if !profile.carb_ratio.is_empty() {
                out.push(PumpTherapy::from_profile(
                    profile,
                    meals,
                    batch.origin(r),
                    r.at,
                )?);
            }
        }
    }
    Ok(out)
}

/// Tidepool `pumpSettings` of one file: the active basal schedule and the
/// carb ratios (`carbRatio` or `carbRatios` of the active schedule), `start`
/// in ms from midnight.
pub fn tidepool_pump_settings(
    file: &str,
    bytes: &[u8],
    meals: &MealWindows,
) -> Result<Vec<PumpTherapy>, IoError> {
    let v: Value = serde_json::from_slice(bytes).map_err(|e| {
        IoError::invalid(
            Location::line(file, e.line() as u64),
            "json",
            format!("not valid JSON: {e}"),
        )
    })?;
    let items = match v {
        Value::Array(a) => a,
        other => vec![other],
    };
    let mut out = Vec::new();
    for (i, item) in items.iter().enumerate() {
        if item.get("type").and_then(Value::as_str) != Some("pumpSettings") {
            continue;
        }
        let path = format!("$[{i}]");
        let err =
            |field: &str, msg: String| IoError::invalid(Location::json(file, &path), field, msg);
        let time = item
            .get("time")
            .and_then(Value::as_str)
            .ok_or_else(|| err("time", "missing: expected an ISO 8601 time".into()))?;
        let at = crate::time::parse_instant(time).ok_or_else(|| {
            err(
                "time",
                format!("expected an ISO 8601 time with Z or offset, got \"{time}\""),
            )
        })?;
        let active = item.get("activeSchedule").and_then(Value::as_str);
        let pick = |field: &str| -> Option<&Value> {
            let v = item.get(field)?;
            match v {
                Value::Object(named) => active
                    .and_then(|a| named.get(a))
                    .or_else(|| (named.len() == 1).then(|| named.values().next()).flatten()),
                other => Some(other),
            }
        };
        let segments = |field: &str, value: &str| -> Result<Vec<(u32, f64)>, IoError> {
            let Some(Value::Array(rows)) = pick(field) else {
                return Err(err(field, format!("missing: expected an array of {{start, {value}}} (of the active schedule {active:?})")));
            };
            let mut s: Vec<(u32, f64)> = Vec::new();
            for (j, row) in rows.iter().enumerate() {
                let f = format!("{field}[{j}]");
                let start = row
                    .get("start")
                    .and_then(Value::as_f64)
                    .ok_or_else(|| err(&f, "missing start (ms from midnight)".into()))?;
                let x = row
                    .get(value)
                    .and_then(Value::as_f64)
                    .ok_or_else(|| err(&f, format!("missing {value}")))?;
                let m = start / 60_000.0;
                if !(0.0..1440.0).contains(&m) || m.fract() != 0.0 {
                    return Err(err(
                        &f,
                        format!("start {start} ms is not a whole minute of the day"),
                    ));
                }
                let m = m as u32;
                if s.last().is_some_and(|l| m <= l.0) || (s.is_empty() && m != 0) {
                    return Err(err(&f, "starts must begin at 0 and increase".into()));
                }
                s.push((m, x));
            }
            if s.is_empty() {
                return Err(err(field, "the schedule is empty".into()));
            }
            Ok(s)
        };
        let basal = segments("basalSchedules", "rate")?;
        let cr_field = if item.get("carbRatios").is_some() {
            "carbRatios"
        } else {
            "carbRatio"
        };
        let cr = segments(cr_field, "amount")?;
        let profile = Profile {
            basal: crate::record::BasalSchedule {
                segments: basal
                    .into_iter()
                    .map(|(m, r)| (m, UnitsPerHour(r)))
                    .collect(),
            },
            carb_ratio: cr.into_iter().map(|(m, r)| (m, GramsPerUnit(r))).collect(),
            timezone: None,
        };
        out.push(PumpTherapy::from_profile(
            &profile,
            meals,
            format!("{file}: {path}"),
            at,
        )?);
    }
    Ok(out)
}

/// The settings profile in force at the end of `paths` (the latest one):
/// Nightscout profiles and Profile Switches, Tidepool `pumpSettings`.
pub fn therapy_from_files(
    paths: &[PathBuf],
    opts: &ReadOptions,
    meals: &MealWindows,
) -> Result<PumpTherapy, IoError> {
    let batch = read_files(paths, opts)?;
    let mut all = settings_profiles(&batch, meals)?;
    for (path, format) in paths.iter().zip(&batch.formats) {
        if *format == Format::Tidepool {
            let name = path.display().to_string();
            let bytes = std::fs::read(path).map_err(|source| IoError::Open {
                file: name.clone(),
                source,
            })?;
            all.extend(tidepool_pump_settings(&name, &bytes, meals)?);
        }
    }
    all.sort_by_key(|t| t.at);
    all.pop().ok_or_else(|| {
        let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
        IoError::format(
            &names.join(", "),
            "no settings profile with a basal schedule and carb ratios (expected a Nightscout profile store or Profile Switch, or Tidepool pumpSettings)",
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_carb_ratio_schedule_maps_to_meal_slots_by_the_longest_part_of_each_window() {
        let cr = [(0, 8.0), (600, 12.0), (1020, 10.0)];
        assert_eq!(value_for_window(&cr, (300, 630)), Some(8.0));
        assert_eq!(value_for_window(&cr, (630, 930)), Some(12.0));
        assert_eq!(value_for_window(&cr, (930, 1320)), Some(10.0));
    }
}
