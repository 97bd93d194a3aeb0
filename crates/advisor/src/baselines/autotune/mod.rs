//! Autotune: our implementation of OpenAPS oref0's autotune (oref0 0.7.1,
//! MIT licence, <https://github.com/openaps/oref0>: lib/autotune-prep
//! (categorize.js, dosed.js), lib/autotune/index.js, lib/iob (history.js,
//! total.js, calculate.js), lib/profile (basal.js, isf.js),
//! lib/percentile.js and bin/oref0-autotune-prep.js / -core.js), written
//! from the published algorithm (the code was read to learn its rules; none
//! is copied). It is the community's baseline: every night it reads a day of
//! CGM and pump data, sorts each 5-minute glucose deviation into carb
//! absorption, ISF, basal or unannounced meal, and moves the hourly basals,
//! the ISF and the carb ratio 20 % toward what the day implies, capped at
//! `autosens_min`..`autosens_max` times the pump profile's values.
//!
//! - [`curve`]: the bilinear and exponential insulin curves (`curve`,
//!   `insulinPeakTime`, `useCustomPeakTime`, `dia`).
//! - [`iob`]: boluses and temporary basals as insulin on board and activity.
//! - [`prep`]: the categorisation (oref0's autotune-prep).
//! - [`tune`]: the nightly step (oref0's autotune-core).
//! - [`profile`]: oref0's profile JSON.
//! - [`history`]: which Nightscout treatments oref0 reads insulin from.
//! - [`arm`]: the trial arm ([`Autotune`]), nightly over the previous day.
//!
//! A day is what `oref0-autotune.sh` downloads for it: glucose from 4 h
//! after local midnight to 28 h after it (04:00 to 04:00 local; hours
//! elapsed, so on the days the clocks change from 05:00 or 03:00), insulin
//! and carbs from 18 h before to 42 h after midnight (IOB needs the hours
//! before). Times are ms since the epoch; the local hour comes from a
//! [`LocalClock`] (oref0 uses the process's time zone).
//!
//! # Choices (where oref0's data handling had to be mapped or we differ)
//!
//! 1. Records come from abba's readers (`abba-io`). On Nightscout files
//!    (`abba autotune --entries`), insulin is read only from the
//!    treatments oref0's lib/iob/history.js reads it from (`Meal Bolus`,
//!    `Correction Bolus`, `Snack Bolus`, `Bolus Wizard`, a pump record's
//!    `_type` Bolus, anything entered by `xdrip`, `HAPP_App` with insulin)
//!    and temps only from `Temp Basal`: Trio's `Bolus`, Careportal's
//!    `Combo Bolus` and `<none>` or a `Temp Basal Start` are left out as
//!    oref0 leaves them out, counted, and their units said, because the
//!    outputs must match oref0's on real days. From a store (no Nightscout
//!    document left), every insulin record counts, whatever its source.
//!    Carbs are any record with carbs > 0, as oref0's meal history takes
//!    them.
//! 2. A temporary basal's rate and duration are read as oref0 reads them
//!    ([`NightscoutTemp::oref0`]): `absolute` for AndroidAPS uploads, `rate`
//!    otherwise, Loop's delivered `amount` over the duration when present,
//!    the duration's fractions kept (`abba autotune` on Nightscout files).
//!    From a store, or where oref0 would compute no number, abba's reader's
//!    rate (`absolute`, else `rate`) and whole minutes are used; a
//!    percentage temp is then turned into a rate with the profile's
//!    scheduled rate at its start (oref0 gives it no rate, so no insulin).
//! 3. Pump suspends and resumes from Nightscout are not used, as in oref0
//!    (which reads suspends only from a Medtronic pump history); the caller
//!    counts them. Extended boluses from a store: the immediate part is a
//!    bolus, the extended part 0.05 U pieces spread over its duration
//!    (from Nightscout files, a `Combo Bolus` is left out, as in 1).
//! 4. oref0's duplicate check of meal entries (newest `created_at` first)
//!    drops a carb entry whose own `timestamp` field is within 2 s of a
//!    meal already taken ([`Carbs::stamp_ms`], [`DUPLICATE_MEAL_MS`]); an
//!    entry without that field (AndroidAPS, the Careportal) is never
//!    dropped. We do the same, and the run's notes count the dropped ones.
//!    Records repeated whole (same instant, kind and values) are read once
//!    by abba's readers, which report them; oref0 would count them twice
//!    (Nightscout itself refuses a second treatment with the same
//!    `created_at` and `eventType`, so real downloads rarely hold any).
//! 5. Rounding is JavaScript's: `Math.round` (halves up), `toFixed(2)`
//!    (exact decimal, halves away from zero), `parseInt` (truncation); see
//!    [`js`].
//! 6. oref0's splitTimespan drops, within one splitting pass, the later
//!    pieces of a temp that need no further split once an earlier piece was
//!    split (a temp of more than 30 min crossing a basal break point loses
//!    its tail). We reproduce it, because the outputs must match oref0's on
//!    real days; the loss is a few hundredths of a unit a day.
//! 7. `--tune-insulin-curve` (DIA and peak search) is not implemented: oref0's
//!    default is off; `dia` and the peak come back unchanged.
//! 8. A profile's unknown `curve` is refused (oref0 warns and uses
//!    rapid-acting); missing `min_5m_carbimpact`, `autosens_max` and
//!    `autosens_min` take oref0's defaults 8, 1.2 and 0.7; basal rates,
//!    ISF and carb ratio must lie in [`abba_core::limits`].
//! 9. The ISF and carb-ratio schedules: like oref0, only the first ISF and
//!    the one `carb_ratio` are tuned.
//! 10. oref0's `a - b` sorts are node's ([`js_sort`]: V8's TimSort), so a
//!     ratio of 0 / 0 (NaN, no insulin activity) lands where it lands in
//!     oref0, and a BGI of -0 divides as +0, as oref0's core reads it back
//!     from JSON.

pub mod arm;
pub mod curve;
pub mod history;
pub mod iob;
pub mod js;
pub mod js_sort;
pub mod prep;
pub mod profile;
pub mod tune;

pub use arm::{Autotune, AutotuneConfig};
pub use history::Oref0Reads;
pub use prep::{categorize, Category, Prepped};
pub use profile::Profile;
pub use tune::{tune, Tuned};

/// The minute of the local day (0-1439) of an instant, as JavaScript's
/// `getHours() * 60 + getMinutes()` in the process's zone.
pub trait LocalClock {
    /// Minute of the local day of `at_ms` (ms since the epoch).
    fn minute_of_day(&self, at_ms: i64) -> u32;
}

/// Local time = UTC (the trial's clock).
#[derive(Debug, Clone, Copy, Default)]
pub struct UtcClock;

impl LocalClock for UtcClock {
    fn minute_of_day(&self, at_ms: i64) -> u32 {
        (at_ms.div_euclid(60_000).rem_euclid(1440)) as u32
    }
}

/// A CGM reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// When (ms since the epoch).
    pub at_ms: i64,
    /// Glucose (mg/dL).
    pub mg_dl: f64,
}

/// Carbohydrate entered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Carbs {
    /// When (ms since the epoch; Nightscout's `created_at`).
    pub at_ms: i64,
    /// Grams.
    pub grams: f64,
    /// The instant of the record's own `timestamp` field, when it has one
    /// (Nightscout treatments uploaded by Loop and OpenAPS rigs do; those
    /// of AndroidAPS and the Careportal do not): what oref0's duplicate
    /// check of meals compares (choice 4 of the module's doc).
    pub stamp_ms: Option<i64>,
}

/// How close (ms, exclusive) a meal's `timestamp` must be to the time of a
/// meal already taken for oref0 to drop it as the same meal uploaded twice
/// (lib/meal/history.js).
pub const DUPLICATE_MEAL_MS: i64 = 2_000;

/// Insulin delivery records.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Insulin {
    /// A bolus.
    Bolus {
        /// When (ms since the epoch).
        at_ms: i64,
        /// Units.
        units: f64,
    },
    /// A temporary basal rate.
    Temp {
        /// Start (ms since the epoch).
        at_ms: i64,
        /// Rate (U/h).
        rate: f64,
        /// Minutes.
        duration_min: f64,
    },
}

/// A Nightscout "Temp Basal" treatment's fields that oref0's insulin
/// history reads (lib/iob/history.js), for [`NightscoutTemp::oref0`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NightscoutTemp<'a> {
    /// `enteredBy`.
    pub entered_by: Option<&'a str>,
    /// `rate` (U/h).
    pub rate: Option<f64>,
    /// `absolute` (U/h).
    pub absolute: Option<f64>,
    /// `amount`: the units delivered (Loop uploads it).
    pub amount: Option<f64>,
    /// `duration` (minutes, fractions kept).
    pub duration_min: Option<f64>,
}

impl NightscoutTemp<'_> {
    /// The (rate U/h, minutes) oref0 takes: `absolute` from AndroidAPS and
    /// HAPP, otherwise `rate`, or the delivered `amount` over the duration
    /// when there is one (Loop's temps: choice 2 of the module's doc).
    /// `None` when a field it needs is missing or the duration is not
    /// positive (oref0 would compute no number; the caller keeps its own
    /// reading).
    pub fn oref0(&self) -> Option<(f64, f64)> {
        let minutes = self.duration_min.filter(|d| d.is_finite() && *d > 0.0)?;
        let rate = if matches!(self.entered_by, Some("HAPP_App" | "openaps://AndroidAPS")) {
            self.absolute?
        } else {
            match self.amount {
                Some(units) => units / minutes * 60.0,
                None => self.rate?,
            }
        };
        rate.is_finite().then_some((rate, minutes))
    }
}

impl Insulin {
    /// When the record starts.
    pub fn at_ms(&self) -> i64 {
        match *self {
            Insulin::Bolus { at_ms, .. } | Insulin::Temp { at_ms, .. } => at_ms,
        }
    }
}

/// One day's data (see the module doc for the windows).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DayData {
    /// CGM readings of the day (local midnight + 4 h to + 28 h).
    pub glucose: Vec<Reading>,
    /// Insulin records (from 18 h before the day).
    pub insulin: Vec<Insulin>,
    /// Carb entries.
    pub carbs: Vec<Carbs>,
}

/// What can go wrong.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum AutotuneError {
    /// A profile field is missing or out of range.
    #[error("{path}: {problem}")]
    Profile {
        /// JSON path of the field.
        path: String,
        /// What is wrong and what was expected.
        problem: String,
    },
}

/// One whole autotune run over a day, as `oref0-autotune-prep` then
/// `oref0-autotune-core` run it: `previous` is the profile tuned so far
/// (the pump profile on the first day), `pump` the pump's own.
pub fn autotune_day(
    day: &DayData,
    previous: &Profile,
    pump: &Profile,
    clock: &dyn LocalClock,
) -> Result<(Prepped, Tuned, serde_json::Value), AutotuneError> {
    // Both bins take the pump's curve, and its DIA and peak unless the pump
    // profile uses a custom peak.
    let mut p = previous.clone();
    p.curve = pump.curve;
    if !pump.use_custom_peak {
        p.dia_h = pump.dia_h;
        p.insulin_peak_min = pump.insulin_peak_min;
    }
    if let Some(c) = pump.raw.get("curve") {
        p.raw.insert("curve".into(), c.clone());
    }
    let mut for_prep = p.clone();
    if for_prep.carb_ratio.is_none_or(|cr| cr < 2.0) {
        match pump.carb_ratio {
            Some(cr) if cr >= 2.0 => for_prep.carb_ratio = Some(cr),
            _ => return Err(AutotuneError::Profile {
                path: "carb_ratio".into(),
                problem:
                    "neither the profile nor the pump profile has a carb ratio of at least 2 g/U"
                        .into(),
            }),
        }
    }
    let prepped = categorize(day, &for_prep, clock);
    let tuned = tune(&prepped, &p, pump, clock);
    let json = tuned.to_json(&p);
    Ok((prepped, tuned, json))
}

/// The glucose unit the ISF is shown in (autotune itself works in mg/dL).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum IsfUnit {
    /// mg/dL per unit.
    #[default]
    MgDl,
    /// mmol/L per unit (mg/dL / [`abba_core::units::MG_DL_PER_MMOL_L`]).
    MmolL,
}

impl IsfUnit {
    /// An ISF in mg/dL/U in this unit.
    pub fn of(self, mg_dl_per_u: f64) -> f64 {
        match self {
            IsfUnit::MgDl => mg_dl_per_u,
            IsfUnit::MmolL => mg_dl_per_u / abba_core::units::MG_DL_PER_MMOL_L,
        }
    }

    /// `mg/dL/U` or `mmol/L/U`.
    pub fn label(self) -> &'static str {
        match self {
            IsfUnit::MgDl => "mg/dL/U",
            IsfUnit::MmolL => "mmol/L/U",
        }
    }
}

/// The table people know from oref0-autotune-recommends-report (hourly
/// rows; `Days Missing` is the `untuned` count), the ISF in `unit`.
pub fn recommendations_table(t: &Tuned, unit: IsfUnit) -> String {
    let mut s = String::new();
    s.push_str("Parameter         | Pump        | Autotune    | Days Missing\n");
    s.push_str("------------------------------------------------------------\n");
    s.push_str(&format!(
        "{:<18}| {:<12.3}| {:<12.3}|\n",
        format!("ISF [{}]", unit.label()),
        unit.of(t.pump_isf),
        unit.of(t.isf)
    ));
    s.push_str(&format!(
        "{:<18}| {:<12.3}| {:<12.3}|\n",
        "Carb Ratio [g/U]", t.pump_carb_ratio, t.carb_ratio
    ));
    s.push_str(&format!(
        "{:<18}| {:<12}| {:<12}|\n",
        "Basals [U/h]", "", ""
    ));
    for (h, e) in t.basal.iter().enumerate() {
        s.push_str(&format!(
            "  {:<16}| {:<12.3}| {:<12.3}| {}\n",
            format!("{h:02}:00"),
            t.pump_basal[h],
            e.rate,
            e.untuned.unwrap_or(0)
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::NightscoutTemp;

    #[test]
    fn a_nightscout_temp_is_read_as_oref0_reads_it() {
        let loop_temp = NightscoutTemp {
            entered_by: Some("loop://iPhone"),
            rate: Some(0.55),
            absolute: Some(0.55),
            amount: Some(0.25),
            duration_min: Some(29.75),
        };
        // Loop: the units delivered over the minutes ran, fractions kept.
        assert_eq!(loop_temp.oref0(), Some((0.25 / 29.75 * 60.0, 29.75)));
        // Without `amount`: `rate`, not `absolute`.
        let rig = NightscoutTemp {
            entered_by: Some("openaps://medtronic/723"),
            rate: Some(0.5),
            absolute: Some(0.45),
            amount: None,
            duration_min: Some(30.0),
        };
        assert_eq!(rig.oref0(), Some((0.5, 30.0)));
        // AndroidAPS and HAPP: `absolute`, even beside an `amount`.
        for who in ["openaps://AndroidAPS", "HAPP_App"] {
            let t = NightscoutTemp {
                entered_by: Some(who),
                amount: Some(1.0),
                ..rig
            };
            assert_eq!(t.oref0(), Some((0.45, 30.0)), "{who}");
        }
        // No number oref0 could use: the caller keeps its own reading.
        let none = [
            NightscoutTemp { rate: None, ..rig },
            NightscoutTemp {
                duration_min: Some(0.0),
                ..loop_temp
            },
            NightscoutTemp {
                duration_min: None,
                ..rig
            },
            NightscoutTemp {
                entered_by: Some("openaps://AndroidAPS"),
                absolute: None,
                ..rig
            },
        ];
        for t in none {
            assert_eq!(t.oref0(), None, "{t:?}");
        }
    }
}
