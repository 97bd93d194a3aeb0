//! oref0's autotune (abba-advisor's implementation,
//! [`abba_advisor::baselines::autotune`]) on a person's real data: their
//! Nightscout entries and treatments as abba-io reads them, or their
//! records in a store, run day by day as `oref0-autotune.sh` runs it. What
//! `abba autotune` calls; it parses and prints only.
//!
//! The days are oref0's: glucose from 04:00 to 04:00 local (hours elapsed
//! from local midnight, so from 05:00 or 03:00 on the days the clocks
//! change), insulin and carbs from 18 h before midnight to 42 h after it;
//! each day is tuned from the profile the previous one left.
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use abba_advisor::baselines::autotune::{
    autotune_day, AutotuneError, Carbs, DayData, Insulin, IsfUnit, LocalClock, NightscoutTemp,
    Oref0Reads, Profile, Reading, Tuned,
};
use abba_core::units::GlucoseUnit;
use abba_io::record::{Origin, OriginAt, RecordKind, TempRate};
use abba_io::{Format, IoError, ReadOptions, Record};
use jiff::civil::Date;
use jiff::tz::TimeZone;

use crate::{Store, StoreError};

/// Why autotune could not run.
#[derive(Debug, thiserror::Error)]
pub enum TuneError {
    /// The store.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// Reading a file.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A profile, or a day's run (`context` names which).
    #[error("{context}: {error}")]
    Autotune {
        /// The file, or the day.
        context: String,
        /// What autotune found wrong.
        error: AutotuneError,
    },
    /// A date or time that cannot be placed.
    #[error("time: {0}")]
    Time(#[from] jiff::Error),
    /// What the data lack (no readings, no complete day, the future), with
    /// what reading noted.
    #[error("{0}")]
    Data(String),
}

/// The duration of insulin action of a profile made from the store (h).
pub const DEFAULT_DIA_H: f64 = 5.0;

/// The person's local hours, for autotune's schedules.
struct Zone(TimeZone);

impl LocalClock for Zone {
    fn minute_of_day(&self, at_ms: i64) -> u32 {
        match jiff::Timestamp::from_millisecond(at_ms) {
            Ok(t) => {
                let z = t.to_zoned(self.0.clone());
                u32::from(z.hour().unsigned_abs()) * 60 + u32::from(z.minute().unsigned_abs())
            }
            Err(_) => 0,
        }
    }
}

/// Local midnight of `day` plus `hours` (durations, as oref0's windows).
fn midnight_plus(tz: &TimeZone, day: Date, hours: i64) -> Result<i64, TuneError> {
    let midnight = day.to_zoned(tz.clone())?;
    Ok(midnight.timestamp().as_millisecond() + hours * 3_600_000)
}

/// Autotune's day `day` (ms, both ends included): its glucose from local
/// midnight + 4 h to midnight + 28 h, as `oref0-autotune.sh` asks
/// Nightscout for it (`date -d "DAY +4 hours"`).
fn day_window(tz: &TimeZone, day: Date) -> Result<(i64, i64), TuneError> {
    Ok((midnight_plus(tz, day, 4)?, midnight_plus(tz, day, 28)?))
}

/// An oref0 profile document, or a Nightscout profile store (an array of
/// documents, or one with a `store`), which becomes one (what was taken
/// from it goes to `said`).
pub fn read_profile(path: &Path, said: &mut Vec<String>) -> Result<Profile, TuneError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| IoError::Open {
        file: name.clone(),
        source,
    })?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| IoError::Format {
        file: name.clone(),
        message: format!("not valid JSON: {e}"),
    })?;
    let in_file = |error| TuneError::Autotune {
        context: name.clone(),
        error,
    };
    match v {
        serde_json::Value::Object(m) if !m.contains_key("store") => {
            Profile::from_map(m).map_err(in_file)
        }
        v => {
            let (p, notes) = Profile::from_nightscout(&v).map_err(in_file)?;
            for n in notes {
                let line = format!("{name}: {n}");
                if !said.contains(&line) {
                    said.push(line);
                }
            }
            Ok(p)
        }
    }
}

/// The profile of a person's therapy in force: the basal schedule (scaled
/// to the basal in force) or flat rate, the mean of the three carb ratios
/// in force (autotune tunes one), `isf` in the person's unit, `dia_h`; and
/// a line saying so.
pub fn person_profile(
    store: &mut Store,
    name: &str,
    isf: f64,
    dia_h: f64,
) -> Result<(Profile, String), TuneError> {
    let units = store.person(name)?.settings.units;
    let advice = store.advise(name)?;
    let advisor = store.advisor(name)?;
    let in_force = |key: &str| -> Result<f64, TuneError> {
        advice
            .settings
            .iter()
            .find(|s| s.setting == key)
            .map(|s| s.in_force)
            .ok_or_else(|| TuneError::Data(format!("person {name}: no {key} in force")))
    };
    let basal = in_force("basal")?;
    let ratios = [
        in_force("breakfast")?,
        in_force("lunch")?,
        in_force("dinner")?,
    ];
    let schedule: Vec<(u32, f64)> = match advisor.basal_schedule() {
        Some(s) if s.len() > 1 => {
            let mean = abba_advisor::steps::mean_rate(s);
            if (basal / mean - 1.0).abs() < 1e-9 {
                s.clone()
            } else {
                s.iter().map(|&(m, r)| (m, r * basal / mean)).collect()
            }
        }
        _ => vec![(0, basal)],
    };
    let cr = ratios.iter().sum::<f64>() / 3.0;
    let profile =
        Profile::from_schedule(&schedule, units.to_mg_dl(isf), cr, dia_h).map_err(|error| {
            TuneError::Autotune {
                context: format!("the therapy in force of {name} as an oref0 profile"),
                error,
            }
        })?;
    let said = format!(
        "profile: the therapy in force of {name} ({} basal segment(s), mean {basal:.3} U/h; carb ratio {cr:.2} g/U, the mean of {:.2}/{:.2}/{:.2}), ISF {isf} {} (--isf), DIA {dia_h} h rapid-acting exponential curve (--dia); the same as pump profile unless --pump-profile",
        schedule.len(),
        ratios[0],
        ratios[1],
        ratios[2],
        isf_unit(units).label(),
    );
    Ok((profile, said))
}

/// The unit an ISF in `u` is shown in.
pub fn isf_unit(u: GlucoseUnit) -> IsfUnit {
    match u {
        GlucoseUnit::MgDl => IsfUnit::MgDl,
        GlucoseUnit::MmolL => IsfUnit::MmolL,
    }
}

/// What to tune from: the records, where each was read, the person's zone,
/// what oref0 reads of each Nightscout treatment, and what reading noted.
pub struct Data {
    records: Vec<Record>,
    origin: Box<dyn Fn(&Record) -> String>,
    tz: TimeZone,
    oref0: Oref0Fields,
    /// What reading noted (records refused or read once, notes), one line
    /// each: nothing dropped unsaid.
    pub said: Vec<String>,
}

impl Data {
    /// Nightscout entries and treatments, read by abba-io in `tz`; records
    /// dated in the future are refused (and said).
    pub fn from_nightscout(
        entries: &Path,
        treatments: &Path,
        tz: TimeZone,
    ) -> Result<Data, TuneError> {
        let opts = ReadOptions {
            format: Some(Format::Nightscout),
            tz: Some(tz.clone()),
            ..ReadOptions::default()
        };
        let mut batch =
            abba_io::read_files(&[entries.to_path_buf(), treatments.to_path_buf()], &opts)?;
        let said = reading_report(&mut batch);
        let records = std::mem::take(&mut batch.records);
        let oref0 = oref0_fields(treatments, 1, &tz)?;
        Ok(Data {
            records,
            origin: Box::new(move |r: &Record| batch.origin(r)),
            tz,
            oref0,
            said,
        })
    }

    /// The records of person `name` in `store` (shown as `db`), in the
    /// person's zone: those their days are made from (one source for each
    /// kind of data and day, [`crate::one_source`]; what was set aside is
    /// said).
    pub fn from_store(store: &Store, db: &str, name: &str) -> Result<Data, TuneError> {
        let person = store.person(name)?;
        let chosen = store.used_records(name)?;
        let set_aside = chosen.notes();
        let records = chosen.records;
        let who = name.to_string();
        let db = db.to_string();
        Ok(Data {
            records,
            origin: Box::new(move |r: &Record| {
                format!(
                    "{db}: person {who}: a {} record ({}) at {}",
                    r.kind.name(),
                    r.source.name(),
                    r.at
                )
            }),
            tz: person.tz.clone(),
            oref0: Oref0Fields::default(),
            said: std::iter::once(
                "a store keeps abba's reading of each record, not every Nightscout field oref0 reads (a meal's own `timestamp`, Loop's delivered `amount`): on such uploads oref0 on the same files can differ (give --entries and --treatments for oref0's figures)"
                    .to_string(),
            )
            .chain(set_aside)
            .collect(),
        })
    }
}

/// What reading the files removed or noted, one line each; records dated
/// in the future are refused here.
fn reading_report(batch: &mut abba_io::Batch) -> Vec<String> {
    let mut out = Vec::new();
    let future = batch.refuse_future(jiff::Timestamp::now());
    if future.count > 0 {
        out.push(format!(
            "refused {} record(s) dated in the future; the first: {}",
            future.count,
            future.first.as_deref().unwrap_or("?")
        ));
    }
    if !batch.duplicates.is_empty() {
        let kinds: Vec<String> = batch
            .duplicates
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        out.push(format!("duplicates read once: {}", kinds.join(", ")));
    }
    if batch.older_versions > 0 {
        out.push(format!(
            "older versions of a record replaced by the latest: {}",
            batch.older_versions
        ));
    }
    out.extend(batch.notes.iter().cloned());
    out
}

/// The records as autotune's inputs.
struct Inputs {
    glucose: Vec<Reading>,
    insulin: Vec<Insulin>,
    carbs: Vec<Carbs>,
    /// Records autotune does not read, by kind.
    unused: BTreeMap<String, usize>,
    /// Bolus insulin (U) in treatments oref0 reads no insulin from.
    unread_units: f64,
}

fn inputs(data: &Data, profile: &Profile, clock: &Zone) -> Result<Inputs, TuneError> {
    let now =
        jiff::Timestamp::now().as_millisecond() + abba_core::limits::FUTURE_SKEW_MINUTES * 60_000;
    let oref0 = &data.oref0;
    let mut x = Inputs {
        glucose: Vec::new(),
        insulin: Vec::new(),
        carbs: Vec::new(),
        unused: BTreeMap::new(),
        unread_units: 0.0,
    };
    for r in &data.records {
        let at = r.at.as_millisecond();
        if at > now {
            return Err(TuneError::Data(format!(
                "{}: dated {} (in the future); refusing data from the future (`abba store remove-future` removes such records from a store)",
                (data.origin)(r),
                r.at
            )));
        }
        // Insulin in a treatment oref0 reads no insulin from (or a temp it
        // does not read as one) is left out, as oref0 leaves it, and said.
        let wanted = match &r.kind {
            RecordKind::Bolus { .. } | RecordKind::ExtendedBolus { .. } => Some(Oref0Reads::Bolus),
            RecordKind::TempBasal { .. } => Some(Oref0Reads::Temp),
            _ => None,
        };
        if let (Some(wanted), Some(reads)) = (wanted, oref0.reads.get(&r.origin)) {
            if *reads != wanted {
                let units = match &r.kind {
                    RecordKind::Bolus { units } => Some(units.0),
                    RecordKind::ExtendedBolus { now, extended, .. } => Some(now.0 + extended.0),
                    _ => None,
                };
                let kind = format!(
                    "{} in \"{}\" (oref0 reads no insulin there)",
                    r.kind.name(),
                    reads.name()
                );
                *x.unused.entry(kind).or_default() += 1;
                x.unread_units += units.unwrap_or(0.0);
                continue;
            }
        }
        match &r.kind {
            RecordKind::Cgm { glucose: g } => x.glucose.push(Reading {
                at_ms: at,
                mg_dl: g.mg_dl.0,
            }),
            RecordKind::Bolus { units } => x.insulin.push(Insulin::Bolus {
                at_ms: at,
                units: units.0,
            }),
            RecordKind::Carbs { grams } => x.carbs.push(Carbs {
                at_ms: at,
                grams: grams.0,
                stamp_ms: oref0.stamps.get(&r.origin).copied(),
            }),
            RecordKind::TempBasal { rate, duration_min } => {
                let (rate, duration_min) = match (oref0.temps.get(&r.origin), rate) {
                    (Some(&seen), _) => seen,
                    (None, TempRate::Absolute(r)) => (r.0, f64::from(*duration_min)),
                    (None, TempRate::Percent(p)) => (
                        p / 100.0 * profile.basal_at(clock.minute_of_day(at)),
                        f64::from(*duration_min),
                    ),
                };
                x.insulin.push(Insulin::Temp {
                    at_ms: at,
                    rate,
                    duration_min,
                });
            }
            // A Nightscout bolus oref0 reads (Loop's square "Correction
            // Bolus") is all of its insulin at its start, as oref0 reads
            // `insulin`.
            RecordKind::ExtendedBolus { now, extended, .. }
                if oref0.reads.get(&r.origin) == Some(&Oref0Reads::Bolus) =>
            {
                x.insulin.push(Insulin::Bolus {
                    at_ms: at,
                    units: now.0 + extended.0,
                });
            }
            RecordKind::ExtendedBolus {
                now,
                extended,
                duration_min,
            } => {
                x.insulin.push(Insulin::Bolus {
                    at_ms: at,
                    units: now.0,
                });
                let pieces = (extended.0 / 0.05).round() as i64;
                for j in 0..pieces {
                    let t = at + j * i64::from(*duration_min) * 60_000 / pieces.max(1);
                    x.insulin.push(Insulin::Bolus {
                        at_ms: t,
                        units: 0.05,
                    });
                }
            }
            other => *x.unused.entry(other.name().to_string()).or_default() += 1,
        }
    }
    Ok(x)
}

/// Which days to tune: from `start` (default: the first complete day of the
/// readings) or the `last` N days, to `end` (default: the last complete
/// day).
#[derive(Debug, Clone, Copy, Default)]
pub struct Days {
    /// The first day.
    pub start: Option<Date>,
    /// The last day.
    pub end: Option<Date>,
    /// The last N days to `end` (at least 1; instead of `start`).
    pub last: Option<u32>,
}

/// The days of `wanted` within the readings (each complete, 04:00 to 04:00
/// local).
fn days(wanted: &Days, tz: &TimeZone, glucose: &[Reading]) -> Result<(Date, Date), TuneError> {
    let (Some(first), Some(last)) = (
        glucose.iter().map(|g| g.at_ms).min(),
        glucose.iter().map(|g| g.at_ms).max(),
    ) else {
        return Err(TuneError::Data(
            "no CGM readings (sgv entries): autotune needs CGM data".into(),
        ));
    };
    let day_of = |ms: i64| -> Result<Date, TuneError> {
        Ok(jiff::Timestamp::from_millisecond(ms)?
            .to_zoned(tz.clone())
            .date())
    };
    // The last day whose window's end has been reached by the readings.
    let mut last_complete = day_of(last)?;
    while day_window(tz, last_complete)?.1 > last {
        last_complete = last_complete.yesterday()?;
    }
    let end = wanted.end.unwrap_or(last_complete);
    let start = match (wanted.start, wanted.last) {
        (Some(d), _) => d,
        (None, Some(0)) => {
            return Err(TuneError::Data(
                "the number of days to tune must be at least 1, not 0".into(),
            ))
        }
        (None, Some(n)) => end.checked_sub(jiff::Span::new().days(i64::from(n) - 1))?,
        // The first day whose window starts at or before the first reading.
        (None, None) => {
            let d = day_of(first)?;
            if day_window(tz, d)?.0 >= first {
                d
            } else {
                d.tomorrow()?
            }
        }
    };
    if end < start {
        return Err(TuneError::Data(format!(
            "no complete day (04:00 to 04:00 local) between {start} and {end}: the readings run from {} to {}",
            jiff::Timestamp::from_millisecond(first)?,
            jiff::Timestamp::from_millisecond(last)?
        )));
    }
    if day_window(tz, end)?.1 > last {
        return Err(TuneError::Data(format!(
            "{end}: the day (to 04:00 of the next) is not complete in the readings, which end at {}",
            jiff::Timestamp::from_millisecond(last)?
        )));
    }
    Ok((start, end))
}

/// What a run of autotune found.
pub struct Outcome {
    /// The first and last day tuned.
    pub range: (Date, Date),
    /// Each day tuned.
    pub days: Vec<String>,
    /// Each day's run: its data counts and notes (JSON).
    pub runs: Vec<serde_json::Value>,
    /// The last day's result.
    pub tuned: Tuned,
    /// The tuned profile in oref0's JSON shape.
    pub profile: serde_json::Value,
    /// Records autotune does not read (as oref0), by kind.
    pub unused: BTreeMap<String, usize>,
    /// What reading and tuning noted, one line each.
    pub said: Vec<String>,
}

/// Autotune over `data`, from `profile` (with `pump` as the caps'
/// reference), on the days of `wanted`, day after day. `said` is what the
/// caller noted (reading the profiles); an error after reading carries
/// what reading noted.
pub fn run(
    data: Data,
    profile: Profile,
    pump: &Profile,
    wanted: &Days,
    said: Vec<String>,
) -> Result<Outcome, TuneError> {
    let clock = Zone(data.tz.clone());
    let mut said: Vec<String> = data.said.iter().cloned().chain(said).collect();
    let x = inputs(&data, &profile, &clock)?;
    if x.unread_units > 0.0 {
        said.push(format!(
            "{:.2} U of boluses are in treatments oref0 reads no insulin from (eventType other than Meal Bolus, Correction Bolus, Snack Bolus or Bolus Wizard; counted below): left out as oref0 leaves them out, so the tuned profile does not account for them",
            x.unread_units
        ));
    }
    let with_notes = |e: TuneError| -> TuneError {
        if said.is_empty() {
            e
        } else {
            TuneError::Data(format!(
                "{e}\nwhat reading the files noted:\n  {}",
                said.join("\n  ")
            ))
        }
    };
    let range = days(wanted, &data.tz, &x.glucose).map_err(with_notes)?;
    let (days, runs, tuned, tuned_profile) =
        run_days(&x, &data.tz, range, profile, pump).map_err(with_notes)?;
    Ok(Outcome {
        range,
        days,
        runs,
        tuned,
        profile: tuned_profile,
        unused: x.unused,
        said,
    })
}

type Runs = (
    Vec<String>,
    Vec<serde_json::Value>,
    Tuned,
    serde_json::Value,
);

fn run_days(
    x: &Inputs,
    tz: &TimeZone,
    (start, end): (Date, Date),
    mut profile: Profile,
    pump: &Profile,
) -> Result<Runs, TuneError> {
    let clock = Zone(tz.clone());
    let mut days = Vec::new();
    let mut runs = Vec::new();
    let mut last = None;
    let mut d = start;
    while d <= end {
        let (g0, g1) = day_window(tz, d)?;
        let (t0, t1) = (midnight_plus(tz, d, -18)?, midnight_plus(tz, d, 42)?);
        let day = DayData {
            glucose: x
                .glucose
                .iter()
                .copied()
                .filter(|g| g.at_ms >= g0 && g.at_ms <= g1)
                .collect(),
            insulin: x
                .insulin
                .iter()
                .copied()
                .filter(|i| i.at_ms() >= t0 && i.at_ms() <= t1)
                .collect(),
            carbs: x
                .carbs
                .iter()
                .copied()
                .filter(|c| c.at_ms >= t0 && c.at_ms <= t1)
                .collect(),
        };
        let n = day.glucose.len();
        let (prepped, tuned, json) =
            autotune_day(&day, &profile, pump, &clock).map_err(|error| TuneError::Autotune {
                context: format!("autotune of {d}"),
                error,
            })?;
        runs.push(serde_json::json!({
            "day": d.to_string(),
            "readings": n,
            "basal_data": prepped.basal.len(),
            "isf_data": prepped.isf.len(),
            "carb_absorption_data": prepped.csf.len(),
            "uam_data": prepped.uam.len(),
            "carb_ratio_periods": prepped.cr.len(),
            "notes": prepped.notes.iter().chain(&tuned.notes).collect::<Vec<_>>(),
        }));
        let serde_json::Value::Object(map) = json.clone() else {
            return Err(TuneError::Data(format!(
                "autotune of {d}: the tuned profile is not an object"
            )));
        };
        profile = Profile::from_map(map).map_err(|error| TuneError::Autotune {
            context: format!("tuned profile of {d}"),
            error,
        })?;
        days.push(d.to_string());
        last = Some((tuned, json));
        d = d.tomorrow()?;
    }
    let Some((tuned, json)) = last else {
        return Err(TuneError::Data("no day to tune".into()));
    };
    Ok((days, runs, tuned, json))
}

/// What oref0 reads of each Nightscout treatment beyond abba's reader, by
/// where the treatment was read (abba-advisor's autotune, choices 1, 2 and
/// 4). A store keeps none.
#[derive(Default)]
struct Oref0Fields {
    /// The treatment's own `timestamp` field (ms), which oref0's duplicate
    /// check of meals compares.
    stamps: HashMap<Origin, i64>,
    /// A "Temp Basal"'s (rate U/h, minutes) as oref0 takes them.
    temps: HashMap<Origin, (f64, f64)>,
    /// What oref0 reads insulin from in each treatment (empty for a store,
    /// whose records have no Nightscout document: all are read).
    reads: HashMap<Origin, Oref0Reads>,
}

/// [`Oref0Fields`] of the treatments in file `file` of a batch, read as
/// abba's reader reads them (UTF-16 or a BOM decoded; a JSON array, or one
/// document a line as mongoexport writes them; extended-JSON numbers). A
/// `timestamp` is read as JavaScript's `Date` reads it: a number is ms, a
/// text without an offset is local time; one that is neither is left out
/// (oref0 can match no time with it either). A field oref0 could not use
/// leaves abba's reading of that treatment in place.
fn oref0_fields(path: &Path, file: u16, tz: &TimeZone) -> Result<Oref0Fields, TuneError> {
    use abba_io::read::{json, table};
    use serde_json::Value;
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| IoError::Open {
        file: name.clone(),
        source,
    })?;
    let decoded = table::utf16_to_utf8(&name, &bytes)?;
    let text = table::strip_bom(decoded.as_deref().unwrap_or(&bytes));
    let values = json::parse_array(&name, text)?;
    let instant = |v: &Value| -> Option<i64> {
        match v {
            Value::Number(n) => n.as_f64().map(|ms| ms as i64),
            Value::String(s) => s
                .parse::<jiff::Timestamp>()
                .ok()
                .or_else(|| {
                    let civil: jiff::civil::DateTime = s.parse().ok()?;
                    civil.to_zoned(tz.clone()).ok().map(|z| z.timestamp())
                })
                .map(|t| t.as_millisecond()),
            _ => None,
        }
    };
    let mut out = Oref0Fields::default();
    for (index, v) in values.iter().enumerate() {
        let Value::Object(obj) = v else { continue };
        let item = json::Item::json(&name, index, obj);
        let origin = Origin {
            file,
            at: OriginAt::Item(u32::try_from(index).unwrap_or(u32::MAX)),
        };
        if let Some(t) = item.get("timestamp").and_then(instant) {
            out.stamps.insert(origin, t);
        }
        out.reads.insert(origin, Oref0Reads::of(obj));
        if item.str("eventType").ok().flatten() == Some("Temp Basal") {
            let number = |k: &str| item.num(k).ok().flatten();
            let temp = NightscoutTemp {
                entered_by: item.str("enteredBy").ok().flatten(),
                rate: number("rate"),
                absolute: number("absolute"),
                amount: number("amount"),
                duration_min: number("duration"),
            };
            if let Some(t) = temp.oref0() {
                out.temps.insert(origin, t);
            }
        }
    }
    Ok(out)
}
