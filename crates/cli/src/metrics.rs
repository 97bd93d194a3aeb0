//! `abba metrics`: glucose metrics (iglu's definitions, see
//! `abba_core::metrics`) of a CSV file of CGM readings.
//!
//! Input rules (a bad file is rejected, never repaired):
//! - a header row; the time column (default `time`) and the glucose column
//!   (default `glucose`, or `gl`, iglu's name, when there is no `glucose`
//!   column) are used, every other column is ignored;
//! - times as `2015-06-06 16:50:27` or ISO 8601 (`T` or space, seconds and
//!   fractions optional, optional `Z`/`±hh:mm` offset). Times without an
//!   offset are wall-clock times and are used as written (iglu with
//!   `tz = "UTC"`); times with an offset are converted to UTC. A file must
//!   not mix the two;
//! - every row needs a time and a glucose value > 0; an empty or unreadable
//!   cell is an error naming the file, line, column and value;
//! - one subject per run: if the file has an `id` column (iglu's layout)
//!   holding more than one value, `--subject ID` must pick one (its rows are
//!   used, the other subjects' rows are skipped);
//! - readings must be in strictly increasing time order. iglu sorts silently;
//!   we reject a file out of order unless `--sort` is given, and two readings
//!   at the same time are always an error (iglu keeps the last one).
use std::path::{Path, PathBuf};

use abba_core::metrics::{mage_timed, metrics_timed, GlucoseMetrics, MageOptions};
use abba_core::units::MG_DL_PER_MMOL_L;
use abba_core::MgDl;
use anyhow::{bail, Context, Result};
use chrono::{DateTime, NaiveDateTime};

/// Units of the glucose column.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum GlucoseUnits {
    /// Milligrams per decilitre.
    #[value(name = "mg/dL", alias = "mg/dl", alias = "mgdl")]
    MgDl,
    /// Millimoles per litre (converted with 18.0156 mg/dL per mmol/L).
    #[value(name = "mmol/L", alias = "mmol/l", alias = "mmol")]
    MmolL,
}

/// Arguments of `abba metrics`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// CSV file of readings, with a header row.
    #[arg(long, value_name = "FILE")]
    pub input: PathBuf,
    /// Name of the time column.
    #[arg(long, value_name = "NAME", default_value = "time")]
    pub time_column: String,
    /// Name of the glucose column [default: glucose, or gl if the file has no glucose column].
    #[arg(long, value_name = "NAME")]
    pub glucose_column: Option<String>,
    /// Units of the glucose column; metrics are always reported in mg/dL.
    #[arg(long, value_enum, default_value = "mg/dL")]
    pub units: GlucoseUnits,
    /// Print one JSON object with exactly the 15 metric keys of the protocol.
    #[arg(long)]
    pub json: bool,
    /// Sort the readings by time instead of rejecting a file that is out of order.
    #[arg(long)]
    pub sort: bool,
    /// Use only the rows whose `id` column equals ID (needed when the file holds several subjects).
    #[arg(long, value_name = "ID")]
    pub subject: Option<String>,
}

/// One accepted reading and where it came from.
struct Reading {
    line: u64,
    minutes: f64,
    glucose_mg_dl: f64,
}

/// Runs `abba metrics`.
pub fn run(args: Args) -> Result<()> {
    let file = args.input.display().to_string();
    let mut readings = read_readings(&args)?;
    if readings.len() < 2 {
        bail!("{file}: need at least 2 readings, found {}", readings.len());
    }
    if args.sort {
        // Stable: equal times keep file order and are reported below.
        readings.sort_by(|a, b| a.minutes.total_cmp(&b.minutes));
    }
    for w in readings.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if b.minutes == a.minutes {
            bail!(
                "{file}: line {} has the same time as line {}; each reading needs its own time",
                b.line,
                a.line
            );
        }
        if b.minutes < a.minutes {
            bail!(
                "{file}: line {}: time is earlier than line {}'s; readings must be in time order \
                 (pass --sort to sort them)",
                b.line,
                a.line
            );
        }
    }
    let times: Vec<f64> = readings.iter().map(|r| r.minutes).collect();
    let glucose: Vec<f64> = readings.iter().map(|r| r.glucose_mg_dl).collect();
    let metrics = metrics_timed(&times, &glucose).with_context(|| format!("{file}: metrics"))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&metrics)?);
    } else {
        let mage = mage_timed(&times, &glucose, &MageOptions::default())
            .with_context(|| format!("{file}: MAGE"))?;
        print_table(&file, &args, &readings, &metrics, &mage);
    }
    Ok(())
}

/// Reads and validates every row of the input.
fn read_readings(args: &Args) -> Result<Vec<Reading>> {
    let path: &Path = &args.input;
    let file = path.display().to_string();
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(true)
        .from_path(path)
        .with_context(|| format!("cannot open {file}"))?;
    let headers = reader
        .headers()
        .with_context(|| format!("{file}: cannot read the header row"))?
        .clone();
    let names: Vec<&str> = headers.iter().collect();
    let found = || {
        names
            .iter()
            .map(|n| format!("\"{n}\""))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let find = |name: &str| names.iter().position(|n| n.trim() == name);
    let time_at = find(&args.time_column).with_context(|| {
        format!(
            "{file}: no time column \"{}\"; the columns found are {} (choose one with --time-column)",
            args.time_column,
            found()
        )
    })?;
    let (glucose_name, glucose_at) = match &args.glucose_column {
        Some(name) => (name.clone(), find(name)),
        None => match find("glucose") {
            Some(i) => ("glucose".to_string(), Some(i)),
            None => ("gl".to_string(), find("gl")),
        },
    };
    let glucose_at = glucose_at.with_context(|| {
        let asked = match &args.glucose_column {
            Some(name) => format!("\"{name}\""),
            None => "\"glucose\" (or \"gl\")".to_string(),
        };
        format!(
            "{file}: no glucose column {asked}; the columns found are {} (choose one with --glucose-column)",
            found()
        )
    })?;

    let id_at = find("id");
    if args.subject.is_some() && id_at.is_none() {
        bail!(
            "{file}: --subject needs an \"id\" column; the columns found are {}",
            found()
        );
    }
    let mut readings = Vec::new();
    let mut with_offset: Option<(bool, u64)> = None;
    let mut first_id: Option<(String, u64)> = None;
    let mut subject_seen = false;
    for record in reader.records() {
        let record = record.with_context(|| format!("{file}: unreadable CSV row"))?;
        let line = record.position().map_or(0, |p| p.line());
        let cell = |at: usize| record.get(at).unwrap_or("").trim();
        if let Some(at) = id_at {
            let id = cell(at);
            match &args.subject {
                Some(wanted) => {
                    if id != wanted {
                        continue;
                    }
                    subject_seen = true;
                }
                None => match &first_id {
                    None => first_id = Some((id.to_string(), line)),
                    Some((first, first_line)) if first != id => bail!(
                        "{file}: line {line}: subject \"{id}\" differs from \"{first}\" on line \
                         {first_line}; the file holds several subjects, choose one with --subject"
                    ),
                    Some(_) => {}
                },
            }
        }
        let time_text = cell(time_at);
        let (minutes, has_offset) = parse_time(time_text).with_context(|| {
            format!(
                "{file}: line {line}, column \"{}\": expected a time like 2015-06-06 16:50:27 or \
                 2015-06-06T16:50:27Z, got \"{time_text}\"",
                args.time_column
            )
        })?;
        match with_offset {
            None => with_offset = Some((has_offset, line)),
            Some((first, first_line)) if first != has_offset => bail!(
                "{file}: line {line}, column \"{}\": time \"{time_text}\" {} a UTC offset but the \
                 time on line {first_line} {}; a file must not mix the two",
                args.time_column,
                if has_offset { "has" } else { "has no" },
                if first { "has one" } else { "has none" },
            ),
            Some(_) => {}
        }
        let glucose_text = cell(glucose_at);
        let value: f64 = glucose_text.parse().ok().filter(|v: &f64| v.is_finite()).with_context(|| {
            format!(
                "{file}: line {line}, column \"{glucose_name}\": expected a glucose number, got \"{glucose_text}\""
            )
        })?;
        if value <= 0.0 {
            bail!(
                "{file}: line {line}, column \"{glucose_name}\": glucose must be > 0, got \"{glucose_text}\""
            );
        }
        let glucose_mg_dl = match args.units {
            GlucoseUnits::MgDl => value,
            GlucoseUnits::MmolL => MgDl::from_mmol_l(value).value(),
        };
        readings.push(Reading {
            line,
            minutes,
            glucose_mg_dl,
        });
    }
    if let (Some(wanted), false) = (&args.subject, subject_seen) {
        bail!("{file}: no rows with id \"{wanted}\"");
    }
    Ok(readings)
}

/// Minutes since 1970-01-01 00:00 and whether the text carried a UTC offset
/// (then the minutes are UTC). `None` if the text is not a time we accept.
fn parse_time(text: &str) -> Option<(f64, bool)> {
    let mut s = text.trim().to_string();
    if s.len() > 10 && s.as_bytes()[10] == b'T' {
        s.replace_range(10..11, " ");
    }
    if s.ends_with('Z') || s.ends_with('z') {
        s.pop();
        s.push_str("+00:00");
    }
    let to_minutes = |t: NaiveDateTime| {
        let since = t.and_utc().timestamp_nanos_opt()?;
        Some(since as f64 / 60e9)
    };
    for fmt in [
        "%Y-%m-%d %H:%M:%S%.f%:z",
        "%Y-%m-%d %H:%M%:z",
        "%Y-%m-%d %H:%M:%S%.f%z",
        "%Y-%m-%d %H:%M%z",
    ] {
        if let Ok(t) = DateTime::parse_from_str(&s, fmt) {
            return Some((to_minutes(t.naive_utc())?, true));
        }
    }
    for fmt in ["%Y-%m-%d %H:%M:%S%.f", "%Y-%m-%d %H:%M"] {
        if let Ok(t) = NaiveDateTime::parse_from_str(&s, fmt) {
            return Some((to_minutes(t)?, false));
        }
    }
    None
}

/// Formats minutes since the epoch back as a date and time.
fn show_time(minutes: f64) -> String {
    let nanos = (minutes * 60e9).round() as i64;
    DateTime::from_timestamp_nanos(nanos)
        .naive_utc()
        .format("%Y-%m-%d %H:%M:%S")
        .to_string()
}

/// The human-readable report.
fn print_table(
    file: &str,
    args: &Args,
    readings: &[Reading],
    m: &GlucoseMetrics,
    mage: &abba_core::metrics::Mage,
) {
    let (first, last) = (readings[0].minutes, readings[readings.len() - 1].minutes);
    match &args.subject {
        Some(id) => println!("Glucose metrics of {file}, subject \"{id}\""),
        None => println!("Glucose metrics of {file}"),
    }
    println!(
        "  {} readings, {} .. {} ({:.1} days){}",
        m.n_readings,
        show_time(first),
        show_time(last),
        (last - first) / 1440.0,
        if args.units == GlucoseUnits::MmolL {
            format!(", read as mmol/L x {MG_DL_PER_MMOL_L} mg/dL per mmol/L")
        } else {
            String::new()
        }
    );
    println!(
        "  percentages count readings (iglu); bands as in the seed paper and the 2019 consensus"
    );
    println!();
    let pct = |label: &str, key: &str, v: f64| println!("  {label:<34} {v:>8.2} %   {key}");
    println!("  Seed paper bands");
    pct("target 70-180 mg/dL", "tir_70_180", m.tir_70_180);
    pct("hypo 50-<70 mg/dL", "hypo_50_70", m.hypo_50_70);
    pct(
        "severe hypo <50 mg/dL",
        "severe_hypo_lt50",
        m.severe_hypo_lt50,
    );
    pct("hyper >180-300 mg/dL", "hyper_180_300", m.hyper_180_300);
    pct(
        "severe hyper >300 mg/dL",
        "severe_hyper_gt300",
        m.severe_hyper_gt300,
    );
    println!("  2019 consensus bands");
    pct("below 54 mg/dL", "below_54", m.below_54);
    pct("below 70 mg/dL", "below_70", m.below_70);
    pct("above 180 mg/dL", "above_180", m.above_180);
    pct("above 250 mg/dL", "above_250", m.above_250);
    println!("  Summary");
    let mmol = |v: f64| {
        if args.units == GlucoseUnits::MmolL {
            format!(" ({:.2} mmol/L)", v / MG_DL_PER_MMOL_L)
        } else {
            String::new()
        }
    };
    println!(
        "  {:<34} {:>8.2} mg/dL{}   mean_mg_dl",
        "mean",
        m.mean_mg_dl,
        mmol(m.mean_mg_dl)
    );
    println!(
        "  {:<34} {:>8.2} mg/dL{}",
        "SD (n-1)",
        m.sd_mg_dl,
        mmol(m.sd_mg_dl)
    );
    println!("  {:<34} {:>8.2} %       cv_pct", "CV", m.cv_pct);
    println!("  {:<34} {:>8.2} %       gmi_pct", "GMI", m.gmi_pct);
    println!("  {:<34} {:>8.3}         lbgi", "LBGI (Kovatchev)", m.lbgi);
    println!("  {:<34} {:>8.3}         hbgi", "HBGI (Kovatchev)", m.hbgi);
    match m.mage {
        Some(v) => println!(
            "  {:<34} {:>8.2} mg/dL{}   mage",
            "MAGE (iglu ma 5/32, avg)",
            v,
            mmol(v)
        ),
        None => println!(
            "  {:<34} {:>8}         mage (no countable excursion)",
            "MAGE (iglu ma 5/32, avg)", "-"
        ),
    }
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    println!(
        "  {:<34} MAGE+ {} / MAGE- {} mg/dL; {} of {} segments with excursions",
        "",
        opt(mage.plus),
        opt(mage.minus),
        mage.segments_with_excursions,
        mage.segments
    );
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn accepts_iglu_and_iso_times() {
        let base = parse_time("2015-06-06 16:50:27").unwrap();
        assert!(!base.1);
        let minutes = 16_592.0 * 1440.0 + 16.0 * 60.0 + 50.0 + 27.0 / 60.0;
        assert!((base.0 - minutes).abs() < 1e-9, "{} vs {minutes}", base.0);
        for same in ["2015-06-06T16:50:27", " 2015-06-06 16:50:27.000 "] {
            assert_eq!(parse_time(same), Some(base), "{same}");
        }
        let utc = parse_time("2015-06-06T16:50:27Z").unwrap();
        assert_eq!(utc, (base.0, true));
        let shifted = parse_time("2015-06-06T18:50:27+02:00").unwrap();
        assert!((shifted.0 - base.0).abs() < 1e-9);
        assert_eq!(
            parse_time("2015-06-06 16:50").unwrap().0,
            base.0 - 27.0 / 60.0
        );
        assert!(parse_time("2015-06-06T16:50+0000").unwrap().1);
        for bad in [
            "",
            "16:50",
            "2015-06-06",
            "2015-13-06 16:50:27",
            "yesterday",
        ] {
            assert_eq!(parse_time(bad), None, "{bad}");
        }
    }
}
