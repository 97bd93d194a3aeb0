//! The therapy a pump runs, from its export: the basal schedule and the carb
//! ratios of a settings profile (a Nightscout profile store or Profile
//! Switch, Tidepool `pumpSettings`, CareLink's basal-rate and bolus-wizard
//! rows), each value checked against [`abba_core::limits`], the carb-ratio
//! schedule mapped to the three meal slots by the value in force for the
//! longest part of each meal window.
//!
//! A CareLink export has no settings profile; its rows say what the pump
//! ran ([`carelink_settings`]): the **basal schedule** is the one of the
//! last full local day before the export's last row (the rate in force at
//! its midnight, from the latest `Basal Rate (U/h)` row at or before it,
//! then each row of that day that changes the rate starts a segment at its
//! minute); the **carb ratio** of each meal slot is the `BWZ Carb Ratio
//! (g/U)` of the latest bolus-wizard event whose local time lies in that
//! meal window (any day of the export). Refused: an export without
//! `Basal Rate` rows or that does not cover a full day with the rate known
//! at its midnight; a slot without a wizard event (name the carb ratios
//! with `--carb-ratio` then); a wizard ratio not in g/U (exchanges).
//!
//! In SmartGuard auto mode (the 670G/770G/780G's closed loop) the pump
//! delivers auto basal (`CLOSED_LOOP_AUTO_BASAL` micro-boluses) and the
//! manual-mode basal patterns are not active (Tidepool's uploader makes an
//! empty "Auto Mode" pattern the active one then: tidepool-org/uploader
//! pull request 583, `lib/drivers/medtronic600/NGPHistoryParser.js`
//! `buildSettingsRecords`); the `Basal Rate` rows then are not what it
//! ran. The CSV marks no time of entering or leaving auto mode, but each
//! `Bolus Source` `CLOSED_LOOP_*` row with a delivered volume and each
//! "Aggregated Auto Insulin Data" daily total says auto mode ran on its
//! local day ([`crate::read::carelink::SettingsRows::closed_loop`],
//! `auto_insulin_days`). So the basal schedule of an export mixing the
//! modes is the one of the latest full day without any of it (a manual
//! day) whose rate at midnight comes from a row of a manual day too; the
//! auto days are named in a note, stretch by stretch, and an export
//! without such a day is refused as before (the whole of it in auto mode).
//! The export stays loop evidence for the advice ([`crate::automation`]).
//!
//! A schedule record without carb ratios (Tidepool's delivered scheduled
//! basal) says what was delivered, not what the settings are: it is not a
//! settings profile here.

use std::path::PathBuf;

use abba_core::limits::{BASAL_U_PER_H, CARB_RATIO_G_PER_U};
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use serde::Serialize;

use crate::error::{IoError, Location};
use crate::meals::MealWindows;
use crate::read::{Batch, Format, ReadOptions};
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
    /// A temporary profile (an AndroidAPS Profile Switch with a duration):
    /// its minutes. It is not the person's settings (see
    /// [`therapy_from_contents`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub temporary_min: Option<u32>,
    /// What a person should know about how these settings were chosen (a
    /// temporary profile running at the end of the data, not taken).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// The value of a time-of-day schedule in force for the longest part of
/// `[from, to)` (minutes of the day; the earlier value on a tie).
pub fn value_for_window(schedule: &[(u32, f64)], window: (u32, u32)) -> Option<f64> {
    segment_for_window(schedule, window).map(|i| schedule[i].1)
}

/// The index of the segment of a time-of-day schedule in force for the
/// longest part of `[from, to)` (the earlier one on a tie).
pub fn segment_for_window(schedule: &[(u32, f64)], (from, to): (u32, u32)) -> Option<usize> {
    let mut best: Option<(u32, usize)> = None;
    for (i, &(start, _)) in schedule.iter().enumerate() {
        let end = schedule.get(i + 1).map_or(1440, |s| s.0);
        let overlap = end.min(to).saturating_sub(start.max(from));
        if overlap > 0 && best.is_none_or(|(b, _)| overlap > b) {
            best = Some((overlap, i));
        }
    }
    best.map(|b| b.1)
}

/// How a carb-ratio schedule of more than one segment becomes abba's three
/// meal ratios, in words for the person and the clinician: which segment
/// each meal's ratio is read from (the one an accepted suggestion changes
/// on the pump), meals that share a segment, and segments no meal reads
/// (abba suggests nothing for them). Empty for a single ratio and for
/// three segments each read by one meal.
pub fn carb_ratio_schedule_notes(cr: &[(u32, f64)], meals: &MealWindows) -> Vec<String> {
    if cr.len() < 2 {
        return Vec::new();
    }
    let span = |i: usize| {
        let end = cr.get(i + 1).map_or(1440, |s| s.0);
        format!("{}-{}", hhmm(cr[i].0), hhmm(end))
    };
    let names = ["breakfast", "lunch", "dinner"];
    let windows = [meals.breakfast, meals.lunch, meals.dinner];
    let read: Vec<Option<usize>> = windows.iter().map(|&w| segment_for_window(cr, w)).collect();
    // Each segment read by one meal: the three ratios are the schedule.
    if cr.len() == 3 && (0..3).all(|i| read.contains(&Some(i))) {
        return Vec::new();
    }
    let all: Vec<String> = cr
        .iter()
        .map(|&(m, r)| format!("{} {}", hhmm(m), num(r)))
        .collect();
    let per_meal: Vec<String> = names
        .iter()
        .zip(&read)
        .zip(windows)
        .map(|((name, seg), (from, to))| match seg {
            Some(i) => format!(
                "{name} {} g/U (the segment {}, longest in the {name} window {}-{})",
                num(cr[*i].1),
                span(*i),
                hhmm(from),
                hhmm(to)
            ),
            None => format!("{name}: no segment (an empty window)"),
        })
        .collect();
    let mut out = vec![format!(
        "The pump's carb-ratio schedule has {} segments ({} g/U); abba adapts one ratio per meal: {}. An accepted carb-ratio suggestion is for that segment.",
        cr.len(),
        all.join(", "),
        per_meal.join("; ")
    )];
    for i in 0..cr.len() {
        let sharing: Vec<&str> = names
            .iter()
            .zip(&read)
            .filter(|(_, s)| **s == Some(i))
            .map(|(n, _)| *n)
            .collect();
        if sharing.len() > 1 {
            out.push(format!(
                "{} are read from the same segment ({}): the pump needs that segment split at the meal windows' boundary to follow different suggestions for them.",
                sharing.join(" and "),
                span(i)
            ));
        }
    }
    let unread: Vec<String> = (0..cr.len())
        .filter(|i| !read.contains(&Some(*i)))
        .map(|i| format!("{} {} g/U", span(i), num(cr[i].1)))
        .collect();
    if !unread.is_empty() {
        out.push(format!(
            "No meal's ratio is read from the segment{} {}: abba suggests nothing for {}; {} as the pump has {}.",
            if unread.len() == 1 { "" } else { "s" },
            unread.join(", "),
            if unread.len() == 1 { "it" } else { "them" },
            if unread.len() == 1 { "it stays" } else { "they stay" },
            if unread.len() == 1 { "it" } else { "them" },
        ));
    }
    out
}

/// A rate or ratio for people: at most four decimals (a profile scaled by
/// a percentage gives 0.6400000000000001).
fn num(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
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
        let notes = carb_ratio_schedule_notes(&cr, meals);
        Ok(Self {
            basal,
            carb_ratio_schedule: cr,
            carb_ratio,
            origin,
            at,
            temporary_min: profile.temporary_min,
            notes,
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
            format!("basal {} U/h", num(self.basal[0].1))
        } else {
            let segs: Vec<String> = self
                .basal
                .iter()
                .map(|&(m, r)| format!("{} {}", hhmm(m), num(r)))
                .collect();
            format!(
                "basal schedule {} U/h (mean {:.3} U/h)",
                segs.join(", "),
                self.mean_basal()
            )
        };
        let [b, l, d] = self.carb_ratio.map(num);
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

/// What a CareLink export says about the pump's therapy (see the module
/// documentation); a slot without a wizard event has no carb ratio.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CareLinkTherapy {
    /// The basal schedule of `day`: (minute of the local day, U/h).
    pub basal: Vec<(u32, f64)>,
    /// The latest wizard carb ratio of breakfast, lunch and dinner.
    pub carb_ratio: [Option<f64>; 3],
    /// The last full day, whose schedule it is.
    pub day: jiff::civil::Date,
    /// Where it was read.
    pub origin: String,
    /// In force from (the day's local midnight, UTC).
    #[serde(serialize_with = "crate::time::serialize_instant")]
    pub at: jiff::Timestamp,
    /// What a person should know: the stretches of SmartGuard auto mode,
    /// whose `Basal Rate` rows were not read.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// The days of SmartGuard auto mode in words: each stretch of consecutive
/// local days, with the local times of its first and last `CLOSED_LOOP_*`
/// pump row and its daily auto insulin totals.
fn auto_periods(
    days: &std::collections::BTreeSet<jiff::civil::Date>,
    rows: &crate::read::carelink::SettingsRows,
    local: &dyn Fn(jiff::Timestamp) -> jiff::civil::DateTime,
) -> String {
    let mut stretches: Vec<(jiff::civil::Date, jiff::civil::Date)> = Vec::new();
    for &d in days {
        match stretches.last_mut() {
            Some(s) if s.1.tomorrow().ok() == Some(d) => s.1 = d,
            _ => stretches.push((d, d)),
        }
    }
    let words: Vec<String> = stretches
        .iter()
        .map(|&(from, to)| {
            let span = if from == to {
                from.to_string()
            } else {
                format!("{from} to {to}")
            };
            let inside: Vec<jiff::civil::DateTime> = rows
                .closed_loop
                .iter()
                .map(|c| local(c.0))
                .filter(|t| (from..=to).contains(&t.date()))
                .collect();
            let totals = rows
                .auto_insulin_days
                .iter()
                .filter(|d| (from..=to).contains(&d.0))
                .count();
            let hm = |t: &jiff::civil::DateTime| t.strftime("%Y-%m-%d %H:%M").to_string();
            let mut what = Vec::new();
            match (inside.first(), inside.last()) {
                (Some(a), Some(b)) if inside.len() > 1 => what.push(format!(
                    "{} CLOSED_LOOP_* rows from {} to {} local time",
                    inside.len(),
                    hm(a),
                    hm(b)
                )),
                (Some(a), _) => what.push(format!("a CLOSED_LOOP_* row at {} local time", hm(a))),
                _ => {}
            }
            if totals > 0 {
                what.push(format!("{totals} daily auto insulin totals"));
            }
            format!("{span} ({})", what.join(", "))
        })
        .collect();
    words.join("; ")
}

const SLOTS: [&str; 3] = ["breakfast", "lunch", "dinner"];

impl CareLinkTherapy {
    /// As a pump's settings: the carb ratios `given` (all three, in place
    /// of the export's), else the export's, every slot needed (an error
    /// names the slot without a wizard event and its window).
    pub fn complete(
        &self,
        meals: &MealWindows,
        given: Option<[f64; 3]>,
    ) -> Result<PumpTherapy, IoError> {
        let windows = [meals.breakfast, meals.lunch, meals.dinner];
        let mut carb_ratio = [0.0; 3];
        for i in 0..3 {
            carb_ratio[i] = match (given, self.carb_ratio[i]) {
                (Some(g), _) => g[i],
                (None, Some(v)) => v,
                (None, None) => {
                    return Err(IoError::invalid(
                        Location::file(&self.origin),
                        &format!("{} carb ratio", SLOTS[i]),
                        format!(
                            "no bolus wizard event with a carb ratio in the {} window ({}-{}): the export does not say the pump's {} carb ratio; give the carb ratios with --carb-ratio B,L,D",
                            SLOTS[i],
                            hhmm(windows[i].0),
                            hhmm(windows[i].1),
                            SLOTS[i]
                        ),
                    ))
                }
            };
        }
        let origin = match given {
            Some(_) => format!("{} (carb ratios as given)", self.origin),
            None => self.origin.clone(),
        };
        self.build(meals, carb_ratio, origin)
    }

    /// As a pump's settings, a slot without a wizard event taking its
    /// value from `held` (the therapy the store holds: the export says
    /// nothing about it, so nothing differs there); the origin names them.
    pub fn or_held(&self, meals: &MealWindows, held: [f64; 3]) -> Result<PumpTherapy, IoError> {
        let mut carb_ratio = held;
        let mut kept = Vec::new();
        for i in 0..3 {
            match self.carb_ratio[i] {
                Some(v) => carb_ratio[i] = v,
                None => kept.push(SLOTS[i]),
            }
        }
        let origin = if kept.is_empty() {
            self.origin.clone()
        } else {
            format!(
                "{} (no wizard event for {}: the store's value)",
                self.origin,
                kept.join(", ")
            )
        };
        self.build(meals, carb_ratio, origin)
    }

    fn build(
        &self,
        meals: &MealWindows,
        carb_ratio: [f64; 3],
        origin: String,
    ) -> Result<PumpTherapy, IoError> {
        for (i, v) in carb_ratio.iter().enumerate() {
            CARB_RATIO_G_PER_U.check(*v).map_err(|e| {
                IoError::invalid(
                    Location::file(&self.origin),
                    &format!("{} carb ratio", SLOTS[i]),
                    e.to_string(),
                )
            })?;
        }
        let mut carb_ratio_schedule = vec![(0, carb_ratio[0])];
        carb_ratio_schedule.push((meals.lunch.0, carb_ratio[1]));
        carb_ratio_schedule.push((meals.dinner.0, carb_ratio[2]));
        Ok(PumpTherapy {
            basal: self.basal.clone(),
            carb_ratio_schedule,
            carb_ratio,
            origin,
            at: self.at,
            temporary_min: None,
            notes: self.notes.clone(),
        })
    }
}

/// What one CareLink file says about the pump's therapy: the settings, or
/// why it says none (no `Basal Rate` rows, no full day).
pub fn carelink_settings(
    file: &str,
    bytes: &[u8],
    opts: &ReadOptions,
    meals: &MealWindows,
) -> Result<Result<CareLinkTherapy, String>, IoError> {
    let tz = opts.tz.clone().ok_or_else(|| {
        IoError::format(
            file,
            "CareLink writes pump times without an offset: give the person's zone with --tz",
        )
    })?;
    let rows = crate::read::carelink_settings_rows(file, bytes, opts)?;
    let auto = crate::read::carelink::auto_mode(bytes);
    let auto_rows = auto.auto_mode_boluses + auto.automatic_doses + auto.auto_insulin_totals;
    let device = auto.device.map_or(String::new(), |d| format!(", {d}"));
    let local = |t: jiff::Timestamp| tz.to_datetime(t);
    // The local days SmartGuard's auto mode ran on (any part of them).
    let mut auto_days: std::collections::BTreeSet<jiff::civil::Date> =
        rows.closed_loop.iter().map(|c| local(c.0).date()).collect();
    auto_days.extend(rows.auto_insulin_days.iter().map(|d| d.0));
    let closed_loop = |periods: &str| {
        format!(
            "{file}: the pump ran SmartGuard auto mode ({auto_rows} rows with Bolus Source \
             CLOSED_LOOP_*{device}{periods}): in auto mode it does not deliver the \"Basal Rate \
             (U/h)\" rows' manual-mode pattern but auto basal of its own, so they are not read \
             as the basal schedule; abba was not designed for a closed loop and gives it no \
             basal advice; the export holds no full local day in manual mode with the \
             scheduled basal rate known at its midnight (an export of a period in manual mode \
             can be read)"
        )
    };
    if auto_rows > 0 && auto_days.is_empty() {
        // Rows the counts saw and the dates did not: refused as a whole.
        return Ok(Err(closed_loop("")));
    }
    let (Some(end), Some(first_basal)) = (rows.end, rows.basal.first()) else {
        if auto_rows > 0 {
            return Ok(Err(closed_loop("")));
        }
        return Ok(Err(format!(
            "{file}: no \"Basal Rate (U/h)\" rows (the pump's scheduled basal rate is not in the export)"
        )));
    };
    let last_day = local(end)
        .date()
        .yesterday()
        .map_err(|e| IoError::format(file, e.to_string()))?;
    let midnight = |d: jiff::civil::Date| {
        d.to_zoned(tz.clone())
            .map(|z| z.timestamp())
            .map_err(|e| IoError::format(file, e.to_string()))
    };
    // The latest full day in manual mode (none of it in auto mode) whose
    // rate at midnight comes from a row written in manual mode too: in
    // auto mode the `Basal Rate` rows are not what the pump ran.
    let first_day = local(first_basal.0).date();
    let mut day = last_day;
    let chosen = loop {
        if day < first_day {
            break None;
        }
        if !auto_days.contains(&day) {
            let start = midnight(day)?;
            if let Some(&b) = rows.basal.iter().rev().find(|b| b.0 <= start) {
                if !auto_days.contains(&local(b.0).date()) {
                    break Some((day, start, b));
                }
            }
            if auto_days.is_empty() {
                break None;
            }
        }
        day = day
            .yesterday()
            .map_err(|e| IoError::format(file, e.to_string()))?;
    };
    let periods = auto_periods(&auto_days, &rows, &local);
    let Some((day, start, (_, first_rate, first_line))) = chosen else {
        if !auto_days.is_empty() {
            return Ok(Err(closed_loop(&format!("; auto mode on {periods}"))));
        }
        return Ok(Err(format!(
            "{file}: the export covers no full day with the scheduled basal rate known at its midnight (the last full day is {last_day}; its first \"Basal Rate (U/h)\" row is after 00:00): export a longer period"
        )));
    };
    let notes = if auto_days.is_empty() {
        Vec::new()
    } else {
        vec![format!(
            "{file}: the pump ran SmartGuard auto mode (a closed loop{device}) on {periods}: \
             those days' \"Basal Rate (U/h)\" rows are not read as the basal schedule, and abba \
             gives a closed loop no basal advice; the basal schedule is the one of {day}, the \
             latest full day in manual mode"
        )]
    };
    let stop = midnight(
        day.tomorrow()
            .map_err(|e| IoError::format(file, e.to_string()))?,
    )?;
    let check = |r: f64, line: u64| {
        BASAL_U_PER_H.check(r).map_err(|e| {
            IoError::invalid(
                Location::line(file, line),
                "Basal Rate (U/h)",
                e.to_string(),
            )
        })
    };
    check(first_rate, first_line)?;
    let mut basal: Vec<(u32, f64)> = vec![(0, first_rate)];
    for &(at, rate, line) in rows.basal.iter().filter(|b| b.0 > start && b.0 < stop) {
        check(rate, line)?;
        let t = local(at);
        let minute = u32::try_from(i32::from(t.hour()) * 60 + i32::from(t.minute())).unwrap_or(0);
        let last = basal.last().copied().unwrap_or((0, rate));
        if minute == last.0 {
            if let Some(l) = basal.last_mut() {
                l.1 = rate;
            }
        } else if rate != last.1 {
            basal.push((minute, rate));
        }
    }
    basal.dedup_by(|b, a| a.1 == b.1);
    let windows = [meals.breakfast, meals.lunch, meals.dinner];
    let mut carb_ratio = [None; 3];
    for (i, (from, to)) in windows.into_iter().enumerate() {
        carb_ratio[i] = rows
            .carb_ratio
            .iter()
            .rev()
            .find(|c| {
                let t = local(c.0);
                let m =
                    u32::try_from(i32::from(t.hour()) * 60 + i32::from(t.minute())).unwrap_or(0);
                (from..to).contains(&m)
            })
            .map(|c| c.1);
    }
    let mode = if auto_days.is_empty() {
        ""
    } else {
        " (manual mode)"
    };
    let origin = match &rows.ratio_not_grams {
        None => format!(
            "{file}: the Basal Rate rows of {day}{mode} and the bolus wizard's carb ratios"
        ),
        Some(col) => format!(
            "{file}: the Basal Rate rows of {day}{mode} (the wizard's \"{col}\" is not in g/U: not read)"
        ),
    };
    Ok(Ok(CareLinkTherapy {
        basal,
        carb_ratio,
        day,
        origin,
        at: start,
        notes,
    }))
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

/// Tidepool `pumpSettings` of one file (Tidepool JSON or Tidepool's Excel
/// export), each read by [`crate::read::tidepool::pump_settings_profile`]
/// (the active basal schedule, the carb ratios in g/U; exchanges refused)
/// and checked against the limits; an error names the datum. `time` is
/// when the pump was read (for Medtronic: when the settings took effect),
/// so a record at the upload says what the pump ran then.
pub fn tidepool_pump_settings(
    file: &str,
    bytes: &[u8],
    meals: &MealWindows,
) -> Result<Vec<PumpTherapy>, IoError> {
    let mut out = Vec::new();
    for (at, place, profile) in crate::read::tidepool::pump_settings(file, bytes)? {
        out.push(PumpTherapy::from_profile(&profile?, meals, place, at?)?);
    }
    Ok(out)
}

/// Like [`tidepool_pump_settings`], skipping the `pumpSettings` it cannot
/// read (the reader counts them, with a note, as settings not read): an
/// import compares the readable ones with the store's therapy and goes on.
pub fn tidepool_pump_settings_readable(
    file: &str,
    bytes: &[u8],
    meals: &MealWindows,
) -> Result<Vec<PumpTherapy>, IoError> {
    Ok(crate::read::tidepool::pump_settings(file, bytes)?
        .into_iter()
        .filter_map(|(at, place, profile)| {
            PumpTherapy::from_profile(&profile.ok()?, meals, place, at.ok()?).ok()
        })
        .collect())
}

/// The settings profile in force at the end of `paths` (the latest one):
/// Nightscout profiles and Profile Switches, Tidepool `pumpSettings`,
/// CareLink's rows (see the module documentation).
pub fn therapy_from_files(
    paths: &[PathBuf],
    opts: &ReadOptions,
    meals: &MealWindows,
) -> Result<PumpTherapy, IoError> {
    therapy_from_files_with(paths, opts, meals, None)
}

/// Like [`therapy_from_files`]; `carb_ratio` (breakfast, lunch, dinner)
/// replaces the carb ratios of the profile (needed for a CareLink export
/// whose wizard events leave a meal slot without one).
pub fn therapy_from_files_with(
    paths: &[PathBuf],
    opts: &ReadOptions,
    meals: &MealWindows,
    carb_ratio: Option<[f64; 3]>,
) -> Result<PumpTherapy, IoError> {
    let mut inputs = Vec::with_capacity(paths.len());
    for path in paths {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| IoError::Open {
            file: name.clone(),
            source,
        })?;
        inputs.push((name, bytes));
    }
    therapy_from_contents(&inputs, opts, meals, carb_ratio)
}

/// Like [`therapy_from_files_with`], of files already in memory (name,
/// bytes): an upload on the clinic's page.
pub fn therapy_from_contents(
    inputs: &[(String, Vec<u8>)],
    opts: &ReadOptions,
    meals: &MealWindows,
    carb_ratio: Option<[f64; 3]>,
) -> Result<PumpTherapy, IoError> {
    let batch = crate::read::read_all(inputs, opts)?;
    let mut all = settings_profiles(&batch, meals)?;
    let mut why_not = Vec::new();
    for ((name, bytes), format) in inputs.iter().zip(&batch.formats) {
        if matches!(format, Format::Tidepool | Format::TidepoolXlsx) {
            all.extend(tidepool_pump_settings(name, bytes, meals)?);
        } else if *format == Format::CareLink {
            match carelink_settings(name, bytes, opts, meals)? {
                Ok(c) => all.push(c.complete(meals, carb_ratio)?),
                Err(why) => why_not.push(why),
            }
        }
    }
    all.sort_by_key(|t| t.at);
    let data_end = batch.records.iter().map(|r| r.at).max();
    let auto = auto_mode_switches(&batch);
    let mut latest = permanent_at_end(&mut all, data_end)?.ok_or_else(|| {
        let names: Vec<&str> = inputs.iter().map(|(n, _)| n.as_str()).collect();
        let mut msg = "no settings profile with a basal schedule and carb ratios (expected a Nightscout profile store or Profile Switch, Tidepool pumpSettings, or a CareLink export with Basal Rate and bolus wizard rows)".to_string();
        if let Some(words) = &auto {
            msg.push_str(&format!(
                "; the files' only Profile Switches with a profile are {words}, a closed loop's and not a therapy: the files hold no manual profile (export a period that includes one, or give --basal and --carb-ratio)"
            ));
        }
        for w in &why_not {
            msg.push_str("; ");
            msg.push_str(w);
        }
        IoError::format(&names.join(", "), msg)
    })?;
    if batch.unread.count > 0 {
        latest.notes.push(format!(
            "{} rows or items of the files could not be read and were left out (the first: {}); \
             the settings are the latest of what was read",
            batch.unread.count,
            batch.unread.first.join("; ")
        ));
    }
    if let Some(words) = &auto {
        latest.notes.push(format!(
            "The files' {words} were skipped: the pump's auto mode is a closed loop, not a therapy; the settings are the latest manual profile, of {}",
            latest.at
        ));
    }
    if let Some(cr) = carb_ratio {
        for (i, v) in cr.iter().enumerate() {
            CARB_RATIO_G_PER_U.check(*v).map_err(|e| {
                IoError::invalid(Location::file("--carb-ratio"), SLOTS[i], e.to_string())
            })?;
        }
        latest.carb_ratio = cr;
    }
    Ok(latest)
}

/// The Profile Switches of `batch` to the pump's auto mode
/// ([`crate::read::nightscout::is_auto_mode_switch`]) in words: how many,
/// when, the latest's place; `None` when there are none.
fn auto_mode_switches(batch: &Batch) -> Option<String> {
    let auto: Vec<&crate::record::Record> = batch
        .records
        .iter()
        .filter(|r| {
            matches!(&r.kind, RecordKind::Ignored { kind }
                if kind == crate::read::nightscout::AUTO_MODE_SWITCH)
        })
        .collect();
    let first = auto.iter().map(|r| r.at).min()?;
    let last = auto.iter().max_by_key(|r| r.at)?;
    Some(format!(
        "{} Profile Switches to the pump's auto mode (\"Auto Mode\", a placeholder basal), from {first} to {}, the latest at {}",
        auto.len(),
        last.at,
        batch.origin(last)
    ))
}

/// The person's settings among `all` (oldest first): the latest one,
/// unless it is a temporary profile (an AndroidAPS Profile Switch with a
/// duration that no later profile follows, so still running at the end of
/// its file's records): then the latest permanent profile before it, the
/// one AndroidAPS returns to, with a note naming the temporary one. An
/// error when no permanent profile comes before it (what the pump returns
/// to is not known). `None` when `all` is empty.
fn permanent_at_end(
    all: &mut Vec<PumpTherapy>,
    data_end: Option<jiff::Timestamp>,
) -> Result<Option<PumpTherapy>, IoError> {
    let Some(latest) = all.pop() else {
        return Ok(None);
    };
    let Some(minutes) = latest.temporary_min else {
        return Ok(Some(latest));
    };
    let end = latest
        .at
        .checked_add(jiff::SignedDuration::from_mins(i64::from(minutes)))
        .unwrap_or(jiff::Timestamp::MAX);
    let window = format!(
        "{}, in force from {} for {minutes} min, until {end}",
        latest.describe(),
        latest.at
    );
    let what = format!("a temporary profile, {} ({window})", latest.origin);
    let ended = data_end.filter(|&last| end <= last);
    let Some(mut base) = all
        .iter()
        .rev()
        .find(|t| t.temporary_min.is_none())
        .cloned()
    else {
        let when = match ended {
            Some(last) => format!("ended at {end}, after the last record of its file (the data go on to {last}), and the profile it returned to is not known"),
            None => "was still running at the end of the data".to_string(),
        };
        return Err(IoError::format(
            &latest.origin,
            format!(
                "the latest settings profile is a temporary profile ({window}), and it {when}; a temporary profile is not the person's settings, and the files hold no permanent profile before it (the one the pump returns to): export a longer period that includes the permanent Profile Switch, or give --basal and --carb-ratio"
            ),
        ));
    };
    let note = match ended {
        Some(last) => format!(
            "{} ended at {end}, after the last record of its file (the data go on to {last}): the settings at the end of the data are the permanent profile it returned to: {}, in force since {} ({})",
            upper_first(&what),
            base.describe(),
            base.at,
            base.origin
        ),
        None => format!(
            "{} was still running at the end of the data{}: it was not taken as the person's settings, which are the permanent profile it returns to: {}, in force since {} ({})",
            upper_first(&what),
            data_end.map_or(String::new(), |l| format!(" ({l})")),
            base.describe(),
            base.at,
            base.origin
        ),
    };
    base.notes.push(note);
    Ok(Some(base))
}

fn upper_first(s: &str) -> String {
    let mut c = s.chars();
    match c.next() {
        Some(f) => f.to_uppercase().chain(c).collect(),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_carb_ratio_schedule_says_which_segment_each_meal_reads_and_which_none_reads() {
        let meals = MealWindows::default(); // 05:00-10:30, 10:30-15:30, 15:30-22:00
                                            // Five segments: the night's and the late evening's are read by no
                                            // meal; breakfast reads 06:00-11:00, lunch 11:00-17:00 (its whole
                                            // window but 10:30-11:00), dinner 17:00-21:00.
        let cr = [
            (0, 15.0),
            (360, 8.0),
            (660, 12.0),
            (1020, 10.0),
            (1260, 14.0),
        ];
        let n = carb_ratio_schedule_notes(&cr, &meals);
        assert_eq!(n.len(), 2, "{n:?}");
        assert!(
            n[0].starts_with("The pump's carb-ratio schedule has 5 segments (00:00 15, 06:00 8, 11:00 12, 17:00 10, 21:00 14 g/U)")
                && n[0].contains("breakfast 8 g/U (the segment 06:00-11:00, longest in the breakfast window 05:00-10:30)")
                && n[0].contains("lunch 12 g/U (the segment 11:00-17:00")
                && n[0].contains("dinner 10 g/U (the segment 17:00-21:00"),
            "{n:?}"
        );
        assert_eq!(
            n[1],
            "No meal's ratio is read from the segments 00:00-06:00 15 g/U, 21:00-24:00 14 g/U: abba suggests nothing for them; they stay as the pump has them."
        );
        // Two segments: lunch and dinner share one, and the notes say the
        // pump needs it split to follow both.
        let two = carb_ratio_schedule_notes(&[(0, 9.0), (660, 11.0)], &meals);
        assert!(
            two.iter()
                .any(|l| l
                    .starts_with("lunch and dinner are read from the same segment (11:00-24:00)")),
            "{two:?}"
        );
        // One ratio, or one segment a meal: nothing to say.
        assert!(carb_ratio_schedule_notes(&[(0, 10.0)], &meals).is_empty());
        assert!(
            carb_ratio_schedule_notes(&[(0, 8.0), (600, 12.0), (1020, 10.0)], &meals).is_empty()
        );
    }

    #[test]
    fn a_carb_ratio_schedule_maps_to_meal_slots_by_the_longest_part_of_each_window() {
        let cr = [(0, 8.0), (600, 12.0), (1020, 10.0)];
        assert_eq!(value_for_window(&cr, (300, 630)), Some(8.0));
        assert_eq!(value_for_window(&cr, (630, 930)), Some(12.0));
        assert_eq!(value_for_window(&cr, (930, 1320)), Some(10.0));
    }
}
