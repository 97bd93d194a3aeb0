//! `abba autotune`: oref0's autotune (abba-advisor's implementation) over
//! a person's Nightscout entries and treatments, day by day as
//! `oref0-autotune.sh` runs it; prints the tuned profile in oref0's JSON
//! shape and the recommendations table. Parsing and printing only: reading
//! is abba-io's, tuning abba-advisor's.
use std::path::PathBuf;

use abba_advisor::baselines::autotune::{
    autotune_day, recommendations_table, Carbs, DayData, Insulin, LocalClock, Profile, Reading,
};
use abba_io::record::{RecordKind, TempRate};
use abba_io::{Format, ReadOptions};
use anyhow::{bail, Context, Result};
use jiff::civil::Date;
use jiff::tz::TimeZone;

use crate::input::date;

/// Arguments of `abba autotune`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Nightscout entries (entries.json or entries/sgv.json).
    #[arg(long, value_name = "FILE")]
    entries: PathBuf,
    /// Nightscout treatments (boluses, carbs, temporary basals).
    #[arg(long, value_name = "FILE")]
    treatments: PathBuf,
    /// The profile to tune, in oref0's JSON shape (basalprofile, isfProfile, carb_ratio, dia, curve, ...).
    #[arg(long, value_name = "FILE")]
    profile: PathBuf,
    /// The pump's own profile (the caps' reference) [default: --profile].
    #[arg(long, value_name = "FILE")]
    pump_profile: Option<PathBuf>,
    /// The person's IANA time zone (autotune's days and hours are local).
    #[arg(long, value_name = "ZONE")]
    tz: String,
    /// First day to tune (YYYY-MM-DD) [default: the first complete day of the entries].
    #[arg(long, value_name = "DATE")]
    start: Option<String>,
    /// Last day to tune [default: the last complete day of the entries].
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
                (i32::from(z.hour()) * 60 + i32::from(z.minute())) as u32
            }
            Err(_) => 0,
        }
    }
}

fn local_ms(tz: &TimeZone, day: Date, hours: i64) -> Result<i64> {
    let midnight = day.to_zoned(tz.clone())?;
    Ok(midnight.timestamp().as_millisecond() + hours * 3_600_000)
}

fn read_profile(path: &PathBuf) -> Result<Profile> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    Profile::from_json(&text).with_context(|| format!("{}", path.display()))
}

/// Runs `abba autotune`.
pub fn run(args: Args) -> Result<()> {
    let tz = abba_io::time::zone(&args.tz)?;
    let clock = Zone(tz.clone());
    let opts = ReadOptions {
        format: Some(Format::Nightscout),
        tz: Some(tz.clone()),
        ..ReadOptions::default()
    };
    let batch = abba_io::read_files(&[args.entries.clone(), args.treatments.clone()], &opts)?;
    let mut profile = read_profile(&args.profile)?;
    let pump = match &args.pump_profile {
        Some(p) => read_profile(p)?,
        None => profile.clone(),
    };
    let now = jiff::Timestamp::now().as_millisecond()
        + abba_core::limits::FUTURE_SKEW_MINUTES * 60_000;

    let mut glucose = Vec::new();
    let mut insulin = Vec::new();
    let mut carbs = Vec::new();
    let mut unused = std::collections::BTreeMap::<String, usize>::new();
    for r in &batch.records {
        let at = r.at.as_millisecond();
        if at > now {
            bail!(
                "{}: dated {} (in the future); refusing data from the future",
                batch.origin(r),
                r.at
            );
        }
        match &r.kind {
            RecordKind::Cgm { glucose: g } => glucose.push(Reading {
                at_ms: at,
                mg_dl: g.mg_dl.0,
            }),
            RecordKind::Bolus { units } => insulin.push(Insulin::Bolus {
                at_ms: at,
                units: units.0,
            }),
            RecordKind::Carbs { grams } => carbs.push(Carbs {
                at_ms: at,
                grams: grams.0,
            }),
            RecordKind::TempBasal { rate, duration_min } => {
                let rate = match rate {
                    TempRate::Absolute(r) => r.0,
                    TempRate::Percent(p) => p / 100.0 * profile.basal_at(clock.minute_of_day(at)),
                };
                insulin.push(Insulin::Temp {
                    at_ms: at,
                    rate,
                    duration_min: f64::from(*duration_min),
                });
            }
            RecordKind::ExtendedBolus {
                now,
                extended,
                duration_min,
            } => {
                insulin.push(Insulin::Bolus {
                    at_ms: at,
                    units: now.0,
                });
                let pieces = (extended.0 / 0.05).round() as i64;
                for j in 0..pieces {
                    let t = at + j * i64::from(*duration_min) * 60_000 / pieces.max(1);
                    insulin.push(Insulin::Bolus {
                        at_ms: t,
                        units: 0.05,
                    });
                }
            }
            other => *unused.entry(other.name().to_string()).or_default() += 1,
        }
    }
    if glucose.is_empty() {
        bail!("{}: no CGM readings (sgv entries)", args.entries.display());
    }
    let first = glucose.iter().map(|g| g.at_ms).min().unwrap_or(0);
    let last = glucose.iter().map(|g| g.at_ms).max().unwrap_or(0);
    let day_of = |ms: i64| -> Result<Date> {
        Ok(jiff::Timestamp::from_millisecond(ms)?
            .to_zoned(tz.clone())
            .date())
    };
    let start = match &args.start {
        Some(d) => date("--start", d)?,
        // The first day whose 04:00 has a reading at or after it.
        None => {
            let d = day_of(first)?;
            if local_ms(&tz, d, 4)? >= first {
                d
            } else {
                d.tomorrow()?
            }
        }
    };
    let end = match &args.end {
        Some(d) => date("--end", d)?,
        None => day_of(last - 28 * 3_600_000)?,
    };
    if end < start {
        bail!("no complete day (04:00 to 04:00 local) in the entries between {start} and {end}");
    }
    let mut days = Vec::new();
    let mut notes = Vec::new();
    let mut last_tuned = None;
    let mut d = start;
    while d <= end {
        let (g0, g1) = (local_ms(&tz, d, 4)?, local_ms(&tz, d, 28)?);
        let (t0, t1) = (local_ms(&tz, d, -18)?, local_ms(&tz, d, 42)?);
        if g1 > now {
            bail!("{d}: the day ends in the future");
        }
        let day = DayData {
            glucose: glucose
                .iter()
                .copied()
                .filter(|g| g.at_ms >= g0 && g.at_ms <= g1)
                .collect(),
            insulin: insulin
                .iter()
                .copied()
                .filter(|i| i.at_ms() >= t0 && i.at_ms() <= t1)
                .collect(),
            carbs: carbs
                .iter()
                .copied()
                .filter(|c| c.at_ms >= t0 && c.at_ms <= t1)
                .collect(),
        };
        let n = day.glucose.len();
        let (prepped, tuned, json) = autotune_day(&day, &profile, &pump, &clock)
            .with_context(|| format!("autotune of {d}"))?;
        notes.push(serde_json::json!({
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
        last_tuned = Some((tuned, json));
        d = d.tomorrow()?;
    }
    let Some((tuned, json)) = last_tuned else {
        bail!("no day to tune");
    };
    let notice = "abba is research software, not a medical device: discuss any change with your clinician";
    if args.json {
        let out = serde_json::json!({
            "notice": notice,
            "days": days,
            "unused_records": unused,
            "runs": notes,
            "profile": json,
        });
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    println!("Autotune (oref0 0.7.1's algorithm) over {} day(s): {} to {}", days.len(), start, end);
    println!("{notice}.");
    if !unused.is_empty() {
        println!("Records autotune does not use (as oref0): {unused:?}");
    }
    println!();
    print!("{}", recommendations_table(&tuned));
    println!();
    println!("{}", serde_json::to_string_pretty(&json)?);
    Ok(())
}
