//! `abba autotune`: oref0's autotune (abba-advisor's implementation) over
//! Nightscout entries and treatments, or over a person's records in a
//! store, day by day as `oref0-autotune.sh` runs it; prints the tuned
//! profile in oref0's JSON shape and the recommendations table. Parsing and
//! printing only: reading is abba-io's and abba-store's, tuning
//! abba-advisor's.
use std::path::{Path, PathBuf};

use abba_advisor::baselines::autotune::{
    autotune_day, recommendations_table, Carbs, DayData, Insulin, IsfUnit, LocalClock,
    NightscoutTemp, Profile, Reading, Tuned,
};
use abba_core::units::GlucoseUnit;
use abba_io::record::{Origin, OriginAt, RecordKind, TempRate};
use abba_io::{Format, ReadOptions, Record};
use abba_store::Store;
use anyhow::{bail, Context, Result};
use jiff::civil::Date;
use jiff::tz::TimeZone;
use std::collections::HashMap;

use crate::input::date;

const NOTICE: &str =
    "abba is research software, not a medical device: discuss any change with your clinician";

/// Arguments of `abba autotune`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["entries", "db"])))]
pub struct Args {
    /// Nightscout entries (entries.json or entries/sgv.json).
    #[arg(long, value_name = "FILE", requires_all = ["treatments", "profile", "tz"])]
    entries: Option<PathBuf>,
    /// Nightscout treatments (boluses, carbs, temporary basals).
    #[arg(long, value_name = "FILE", requires = "entries")]
    treatments: Option<PathBuf>,
    /// The profile to tune, in oref0's JSON shape (basalprofile, isfProfile,
    /// carb_ratio, dia, curve, ...), or a Nightscout profile store
    /// (api/v1/profile.json: its newest default profile, oref0's defaults
    /// for the curve and autosens). With --db: instead of the person's
    /// therapy in force.
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// The pump's own profile (the caps' reference) [default: --profile].
    #[arg(long, value_name = "FILE")]
    pump_profile: Option<PathBuf>,
    /// The person's IANA time zone (autotune's days and hours are local).
    #[arg(long, value_name = "ZONE", conflicts_with = "db")]
    tz: Option<String>,
    /// A store file: tune from the records of --person.
    #[arg(long, value_name = "FILE", requires = "person")]
    db: Option<PathBuf>,
    /// The person (with --db).
    #[arg(long, value_name = "NAME", requires = "db")]
    person: Option<String>,
    /// With --db and no --profile: the person's insulin sensitivity factor,
    /// in the person's glucose unit per unit (mg/dL/U or mmol/L/U; the
    /// store does not keep one).
    #[arg(long, value_name = "ISF", allow_negative_numbers = true)]
    isf: Option<f64>,
    /// With --db and no --profile: duration of insulin action (h) of the
    /// exponential rapid-acting curve [default: 5].
    #[arg(long, value_name = "HOURS")]
    dia: Option<f64>,
    /// Tune the last N complete days (04:00 to 04:00 local, as oref0-autotune.sh counts them) of the data.
    #[arg(long, value_name = "N", conflicts_with = "start")]
    days: Option<u32>,
    /// First day to tune (YYYY-MM-DD) [default: the first complete day of the data].
    #[arg(long, value_name = "DATE")]
    start: Option<String>,
    /// Last day to tune [default: the last complete day of the data].
    #[arg(long, value_name = "DATE")]
    end: Option<String>,
    /// Print JSON: the tuned profile, the days and what each run noted.
    #[arg(long)]
    json: bool,
}

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
fn midnight_plus(tz: &TimeZone, day: Date, hours: i64) -> Result<i64> {
    let midnight = day.to_zoned(tz.clone())?;
    Ok(midnight.timestamp().as_millisecond() + hours * 3_600_000)
}

/// Autotune's day `day` (ms, both ends included): its glucose from local
/// midnight + 4 h to midnight + 28 h, as `oref0-autotune.sh` asks
/// Nightscout for it (`date -d "DAY +4 hours"`: hours elapsed, so 04:00 to
/// 04:00 local, but from 05:00 or 03:00 on the days the clocks change).
fn day_window(tz: &TimeZone, day: Date) -> Result<(i64, i64)> {
    Ok((midnight_plus(tz, day, 4)?, midnight_plus(tz, day, 28)?))
}

/// An oref0 profile document, or a Nightscout profile store (an array of
/// documents, or one with a `store`), which becomes one (what was taken
/// from it goes to `said`).
fn read_profile(path: &Path, said: &mut Vec<String>) -> Result<Profile> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let name = path.display().to_string();
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{name}: not valid JSON"))?;
    match v {
        serde_json::Value::Object(m) if !m.contains_key("store") => {
            Profile::from_map(m).with_context(|| name.clone())
        }
        v => {
            let (p, notes) = Profile::from_nightscout(&v).with_context(|| name.clone())?;
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

/// The records as autotune's inputs.
struct Inputs {
    glucose: Vec<Reading>,
    insulin: Vec<Insulin>,
    carbs: Vec<Carbs>,
    /// Records autotune does not read, by kind.
    unused: std::collections::BTreeMap<String, usize>,
    /// Bolus insulin (U) in treatments oref0 reads no insulin from.
    unread_units: f64,
}

fn inputs(
    records: &[Record],
    origin: &dyn Fn(&Record) -> String,
    oref0: &Oref0Fields,
    profile: &Profile,
    clock: &Zone,
) -> Result<Inputs> {
    let now =
        jiff::Timestamp::now().as_millisecond() + abba_core::limits::FUTURE_SKEW_MINUTES * 60_000;
    let mut x = Inputs {
        glucose: Vec::new(),
        insulin: Vec::new(),
        carbs: Vec::new(),
        unused: Default::default(),
        unread_units: 0.0,
    };
    for r in records {
        let at = r.at.as_millisecond();
        if at > now {
            bail!(
                "{}: dated {} (in the future); refusing data from the future (`abba store remove-future` removes such records from a store)",
                origin(r),
                r.at
            );
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
                let event = match reads {
                    Oref0Reads::Neither(e) => e.clone(),
                    Oref0Reads::Bolus => "a bolus".into(),
                    Oref0Reads::Temp => "Temp Basal".into(),
                };
                let units = match &r.kind {
                    RecordKind::Bolus { units } => Some(units.0),
                    RecordKind::ExtendedBolus { now, extended, .. } => Some(now.0 + extended.0),
                    _ => None,
                };
                let kind = format!(
                    "{} in \"{event}\" (oref0 reads no insulin there)",
                    r.kind.name()
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

/// What reading the files removed or noted, one line each (nothing
/// dropped unsaid); records dated in the future are refused here.
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

/// An error after reading, with what reading noted (records refused as
/// dated in the future, above all, may be why no day is left).
fn with_notes(e: anyhow::Error, said: &[String]) -> anyhow::Error {
    if said.is_empty() {
        e
    } else {
        anyhow::anyhow!(
            "{e:#}\nwhat reading the files noted:\n  {}",
            said.join("\n  ")
        )
    }
}

/// Which days: `--start`/`--end`, `--days N` (the last N complete days), or
/// every complete day ([`day_window`] within the readings).
fn days(args: &Args, tz: &TimeZone, glucose: &[Reading]) -> Result<(Date, Date)> {
    let (Some(first), Some(last)) = (
        glucose.iter().map(|g| g.at_ms).min(),
        glucose.iter().map(|g| g.at_ms).max(),
    ) else {
        bail!("no CGM readings (sgv entries): autotune needs CGM data");
    };
    let day_of = |ms: i64| -> Result<Date> {
        Ok(jiff::Timestamp::from_millisecond(ms)?
            .to_zoned(tz.clone())
            .date())
    };
    // The last day whose window's end has been reached by the readings.
    let mut last_complete = day_of(last)?;
    while day_window(tz, last_complete)?.1 > last {
        last_complete = last_complete.yesterday()?;
    }
    let end = match &args.end {
        Some(d) => date("--end", d)?,
        None => last_complete,
    };
    let start = match (&args.start, args.days) {
        (Some(d), _) => date("--start", d)?,
        (None, Some(0)) => bail!("--days: expected at least 1, got 0"),
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
        bail!(
            "no complete day (04:00 to 04:00 local) between {start} and {end}: the readings run from {} to {}",
            jiff::Timestamp::from_millisecond(first)?,
            jiff::Timestamp::from_millisecond(last)?
        );
    }
    if day_window(tz, end)?.1 > last {
        bail!(
            "{end}: the day (to 04:00 of the next) is not complete in the readings, which end at {}",
            jiff::Timestamp::from_millisecond(last)?
        );
    }
    Ok((start, end))
}

/// What `abba autotune` found.
struct Outcome {
    days: Vec<String>,
    runs: Vec<serde_json::Value>,
    tuned: Tuned,
    profile: serde_json::Value,
}

fn run_days(
    x: &Inputs,
    tz: &TimeZone,
    (start, end): (Date, Date),
    mut profile: Profile,
    pump: &Profile,
) -> Result<Outcome> {
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
        let (prepped, tuned, json) = autotune_day(&day, &profile, pump, &clock)
            .with_context(|| format!("autotune of {d}"))?;
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
            bail!("autotune of {d}: the tuned profile is not an object");
        };
        profile = Profile::from_map(map).with_context(|| format!("tuned profile of {d}"))?;
        days.push(d.to_string());
        last = Some((tuned, json));
        d = d.tomorrow()?;
    }
    let Some((tuned, profile)) = last else {
        bail!("no day to tune");
    };
    Ok(Outcome {
        days,
        runs,
        tuned,
        profile,
    })
}

/// The profile of a person's therapy in force: the basal schedule (scaled
/// to the basal in force) or flat rate, the mean of the three carb ratios
/// in force (autotune tunes one), `isf` in the person's unit, `dia_h`.
fn person_profile(
    store: &mut Store,
    name: &str,
    units: GlucoseUnit,
    isf: f64,
    dia_h: f64,
) -> Result<(Profile, Vec<String>)> {
    let advice = store.advise(name)?;
    let advisor = store.advisor(name)?;
    let in_force = |key: &str| -> Result<f64> {
        advice
            .settings
            .iter()
            .find(|s| s.setting == key)
            .map(|s| s.in_force)
            .with_context(|| format!("person {name}: no {key} in force"))
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
    let isf_mg_dl = units.to_mg_dl(isf);
    let cr = ratios.iter().sum::<f64>() / 3.0;
    let profile = Profile::from_schedule(&schedule, isf_mg_dl, cr, dia_h)
        .with_context(|| format!("the therapy in force of {name} as an oref0 profile"))?;
    let said = vec![
        format!(
            "profile: the therapy in force of {name} ({} basal segment(s), mean {basal:.3} U/h; carb ratio {cr:.2} g/U, the mean of {:.2}/{:.2}/{:.2}), ISF {isf} {} (--isf), DIA {dia_h} h rapid-acting exponential curve (--dia); the same as pump profile unless --pump-profile",
            schedule.len(),
            ratios[0],
            ratios[1],
            ratios[2],
            isf_unit(units).label(),
        ),
    ];
    Ok((profile, said))
}

fn isf_unit(u: GlucoseUnit) -> IsfUnit {
    match u {
        GlucoseUnit::MgDl => IsfUnit::MgDl,
        GlucoseUnit::MmolL => IsfUnit::MmolL,
    }
}

/// What to tune from: the records, where each was read, the zone, the
/// profile and the unit the ISF is shown in.
type Source = (
    Vec<Record>,
    Box<dyn Fn(&Record) -> String>,
    TimeZone,
    Profile,
    IsfUnit,
    Oref0Fields,
);

/// What oref0 reads of each Nightscout treatment beyond abba's reader, by
/// where the treatment was read (abba-advisor's autotune, choices 2 and
/// 4). A store keeps neither.
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

/// What oref0 0.7.1 reads insulin from in a Nightscout treatment: the first
/// rule of its `lib/iob/history.js` that matches (carbs are read from any
/// treatment that has them, by `lib/meal/history.js`).
#[derive(Debug, Clone, PartialEq)]
enum Oref0Reads {
    /// A bolus: a pump record (`_type` "Bolus"), eventType "Meal Bolus",
    /// "Correction Bolus", "Snack Bolus" or "Bolus Wizard", or any
    /// treatment entered by "xdrip" (or by "HAPP_App" with insulin).
    Bolus,
    /// A temporary basal: eventType exactly "Temp Basal".
    Temp,
    /// No insulin: any other treatment (Trio's "Bolus", Careportal's
    /// "Combo Bolus" and "<none>", "Temp Basal Start" ...), named by its
    /// eventType.
    Neither(String),
}

impl Oref0Reads {
    fn of(obj: &serde_json::Map<String, serde_json::Value>) -> Self {
        let text = |k: &str| obj.get(k).and_then(serde_json::Value::as_str);
        let pump_bolus = text("_type") == Some("Bolus")
            || obj
                .get("bolus")
                .and_then(|b| b.get("_type"))
                .and_then(serde_json::Value::as_str)
                == Some("Bolus");
        let event = text("eventType");
        let entered_by = text("enteredBy");
        let has_insulin = obj.get("insulin").is_some_and(|v| {
            v.as_f64().is_some_and(|u| u != 0.0) || v.as_str().is_some_and(|s| !s.is_empty())
        });
        if pump_bolus
            || matches!(
                event,
                Some("Meal Bolus" | "Correction Bolus" | "Snack Bolus" | "Bolus Wizard")
            )
            || entered_by == Some("xdrip")
            || (entered_by == Some("HAPP_App") && has_insulin)
        {
            Oref0Reads::Bolus
        } else if event == Some("Temp Basal") {
            Oref0Reads::Temp
        } else {
            Oref0Reads::Neither(event.unwrap_or("no eventType").to_string())
        }
    }
}

/// [`Oref0Fields`] of the treatments in file `file` of a batch, read as
/// abba's reader reads them (UTF-16 or a BOM decoded; a JSON array, or one
/// document a line as mongoexport writes them; extended-JSON numbers). A
/// `timestamp` is read as JavaScript's `Date` reads it: a number is ms, a
/// text without an offset is local time; one that is neither is left out
/// (oref0 can match no time with it either). A field oref0 could not use
/// leaves abba's reading of that treatment in place.
fn oref0_fields(path: &Path, file: u16, tz: &TimeZone) -> Result<Oref0Fields> {
    use abba_io::read::{json, table};
    use serde_json::Value;
    let name = path.display().to_string();
    let bytes = std::fs::read(path).with_context(|| format!("{name}: cannot read"))?;
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

/// The duration of insulin action of a profile made from the store (h).
const DEFAULT_DIA_H: f64 = 5.0;

/// `--isf` and `--dia` describe the profile abba makes from a store; with
/// `--profile` (which has its own) they would be ignored, so they are
/// refused.
fn given_with_profile(args: &Args) -> Result<()> {
    if args.isf.is_some() {
        bail!("--isf and --profile: give one (the profile has its own ISF, `sens` in a Nightscout profile store, `isfProfile` in oref0's)");
    }
    if args.dia.is_some() {
        bail!("--dia and --profile: give one (the profile has its own duration of insulin action, `dia`)");
    }
    Ok(())
}

/// Runs `abba autotune`.
pub fn run(args: Args) -> Result<()> {
    let mut said = Vec::new();
    let (records, origin, tz, profile, unit, oref0): Source = match (
        &args.entries,
        &args.db,
        &args.person,
    ) {
        (Some(entries), _, _) => {
            let (Some(treatments), Some(profile), Some(tz)) =
                (&args.treatments, &args.profile, &args.tz)
            else {
                bail!("--entries needs --treatments, --profile and --tz");
            };
            given_with_profile(&args)?;
            let tz = abba_io::time::zone(tz)?;
            let opts = ReadOptions {
                format: Some(Format::Nightscout),
                tz: Some(tz.clone()),
                ..ReadOptions::default()
            };
            let mut batch = abba_io::read_files(&[entries.clone(), treatments.clone()], &opts)?;
            said.extend(reading_report(&mut batch));
            let records = batch.records.clone();
            let oref0 = oref0_fields(treatments, 1, &tz)?;
            let origin = Box::new(move |r: &Record| batch.origin(r));
            (
                records,
                origin,
                tz,
                read_profile(profile, &mut said)?,
                IsfUnit::MgDl,
                oref0,
            )
        }
        (None, Some(db), Some(name)) => {
            let mut store = crate::store_args::open(db)?;
            let person = store.person(name)?;
            let unit = isf_unit(person.settings.units);
            let profile = match (&args.profile, args.isf) {
                    (Some(p), _) => {
                        given_with_profile(&args)?;
                        read_profile(p, &mut said)?
                    }
                    (None, Some(isf)) => {
                        let dia = args.dia.unwrap_or(DEFAULT_DIA_H);
                        let (p, s) =
                            person_profile(&mut store, name, person.settings.units, isf, dia)?;
                        said.extend(s);
                        p
                    }
                    (None, None) => bail!(
                        "--isf: the person's insulin sensitivity factor ({}) is needed, since the store keeps none (or give --profile)",
                        unit.label()
                    ),
                };
            let records = store.records(name)?;
            said.push(
                "a store keeps abba's reading of each record, not every Nightscout field oref0 reads (a meal's own `timestamp`, Loop's delivered `amount`): on such uploads oref0 on the same files can differ (give --entries and --treatments for oref0's figures)"
                    .into(),
            );
            let who = name.clone();
            let db = db.display().to_string();
            let origin = Box::new(move |r: &Record| {
                format!(
                    "{db}: person {who}: a {} record ({}) at {}",
                    r.kind.name(),
                    r.source.name(),
                    r.at
                )
            });
            (
                records,
                origin,
                person.tz.clone(),
                profile,
                unit,
                Oref0Fields::default(),
            )
        }
        _ => bail!("give --entries, --treatments, --profile and --tz, or --db and --person"),
    };
    let pump = match &args.pump_profile {
        Some(p) => read_profile(p, &mut said)?,
        None => profile.clone(),
    };
    let x = inputs(&records, &*origin, &oref0, &profile, &Zone(tz.clone()))?;
    if x.unread_units > 0.0 {
        said.push(format!(
            "{:.2} U of boluses are in treatments oref0 reads no insulin from (eventType other than Meal Bolus, Correction Bolus, Snack Bolus or Bolus Wizard; counted below): left out as oref0 leaves them out, so the tuned profile does not account for them",
            x.unread_units
        ));
    }
    let range = days(&args, &tz, &x.glucose).map_err(|e| with_notes(e, &said))?;
    let out = run_days(&x, &tz, range, profile, &pump).map_err(|e| with_notes(e, &said))?;
    if args.json {
        let doc = serde_json::json!({
            "notice": NOTICE,
            "days": out.days,
            "notes": said,
            "unused_records": x.unused,
            "isf": {"unit": unit.label(), "pump": unit.of(out.tuned.pump_isf), "tuned": unit.of(out.tuned.isf)},
            "runs": out.runs,
            "profile": out.profile,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    println!(
        "Autotune (oref0 0.7.1's algorithm) over {} day(s): {} to {}",
        out.days.len(),
        range.0,
        range.1
    );
    println!("{NOTICE}.");
    for s in &said {
        println!("{s}");
    }
    if !x.unused.is_empty() {
        let kinds: Vec<String> = x.unused.iter().map(|(k, n)| format!("{k} {n}")).collect();
        println!(
            "Records autotune does not read (as oref0): {}",
            kinds.join(", ")
        );
    }
    println!();
    print!("{}", recommendations_table(&out.tuned, unit));
    println!();
    println!("The tuned profile (oref0's JSON, ISF in mg/dL/U):");
    println!("{}", serde_json::to_string_pretty(&out.profile)?);
    Ok(())
}
