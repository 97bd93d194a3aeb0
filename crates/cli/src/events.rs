//! `abba events`: the normalised records of exports and the advisor events
//! they map to (abba-io's `to_events`), with counts and every rejection.
//! As in a person's store, each kind of data on each local day comes from
//! one source (`abba_store::one_source`): files of one pump or sensor by
//! two routes count each dose and reading once, and what was set aside is
//! said.
use abba_io::events::PersonSettings;
use abba_io::meals::MealWindows;
use anyhow::{Context, Result};

use crate::input::{date, InputArgs};

/// Arguments of `abba events`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// Day 1 of the advisor's clock (YYYY-MM-DD) [default: the first record's local day].
    #[arg(long, value_name = "DATE")]
    first_day: Option<String>,
    /// Breakfast window, HH:MM-HH:MM.
    #[arg(long, value_name = "WINDOW", default_value = "05:00-10:30")]
    breakfast: String,
    /// Lunch window, HH:MM-HH:MM.
    #[arg(long, value_name = "WINDOW", default_value = "10:30-15:30")]
    lunch: String,
    /// Dinner window, HH:MM-HH:MM.
    #[arg(long, value_name = "WINDOW", default_value = "15:30-22:00")]
    dinner: String,
    /// Print records and events as JSON.
    #[arg(long)]
    json: bool,
    /// Also list every record and every advisor event, one a line.
    #[arg(long)]
    list: bool,
}

/// Runs `abba events`.
pub fn run(args: Args) -> Result<()> {
    let opts = args.input.options()?;
    let tz = opts
        .tz
        .clone()
        .context("--tz ZONE is required: the advisor's days are the person's local days")?;
    let mut batch = abba_io::read_files(&args.input.input, &opts)?;
    if batch.records.is_empty() {
        anyhow::bail!("no readings in {}", batch.files.join(", "));
    }
    let future = batch.refuse_future(jiff::Timestamp::now());
    let chosen = abba_store::one_source::choose(&tz, std::mem::take(&mut batch.records));
    batch.records = chosen.records;
    let set_aside: Vec<String> = (chosen.set_aside.iter())
        .map(|o| abba_store::one_source::sentence_as(o, "read"))
        .collect();
    let mut person = PersonSettings::new(tz);
    person.first_day = args
        .first_day
        .as_deref()
        .map(|d| date("--first-day", d))
        .transpose()?;
    person.meals = MealWindows {
        breakfast: MealWindows::parse_window(&args.breakfast)?,
        lunch: MealWindows::parse_window(&args.lunch)?,
        dinner: MealWindows::parse_window(&args.dinner)?,
    };
    let stream = batch.to_events(&person)?;
    if args.json {
        let out = serde_json::json!({
            "note": "abba is research software, not a medical device",
            "records": batch.records,
            "files": batch.files,
            "duplicates": batch.duplicates,
            "older_versions": batch.older_versions,
            "cross_upload": batch.cross_upload,
            "future": future,
            "notes": batch.notes,
            "set_aside": chosen.set_aside,
            "mapping": stream,
        });
        println!("{}", serde_json::to_string(&out)?);
        return Ok(());
    }
    println!(
        "Events of {} (abba is research software, not a medical device)",
        batch.files.join(", ")
    );
    println!(
        "  formats: {:?}; {} records after merging, {} set aside (another source covers their kind and day more fully)",
        batch.formats,
        batch.records.len(),
        chosen.set_aside.iter().map(|o| o.count).sum::<usize>()
    );
    let mut kinds = std::collections::BTreeMap::<&str, usize>::new();
    for r in &batch.records {
        *kinds.entry(r.kind.name()).or_default() += 1;
    }
    println!("  records by kind: {kinds:?}");
    println!("  duplicates removed: {:?}", batch.duplicates);
    println!(
        "  older versions of a repeated id removed: {}; carried by two uploads seconds apart: {:?}",
        batch.older_versions, batch.cross_upload
    );
    if future.count > 0 {
        println!(
            "  dated after now, refused: {} (the first: {})",
            future.count,
            future.first.as_deref().unwrap_or("?")
        );
    }
    for f in batch.empty_files() {
        println!("  no readings in {f}");
    }
    for n in batch.notes.iter().chain(&set_aside) {
        println!("  note: {n}");
    }
    println!("  ignored by kind: {:?}", stream.ignored);
    println!("  kept but not mapped: {:?}", stream.not_mapped);
    println!(
        "  advisor events (day 1 = {}, {}): {:?}",
        stream.first_day, stream.tz, stream.counts
    );
    println!(
        "  readings reported as Low/High, passed on at the sensor's limit: {}",
        stream.censored
    );
    println!("  meal rule: {}", stream.meal_rule);
    for note in &stream.notes {
        println!("  note: {note}");
    }
    println!("  rejected: {}", stream.rejected.len());
    for r in &stream.rejected {
        println!("    {} ({}): {}", r.origin, r.kind, r.reason);
    }
    if args.list {
        println!("records (UTC instant, source, where, what):");
        for r in &batch.records {
            println!(
                "  {} {} {} {:?}",
                r.at,
                r.source.name(),
                batch.origin(r),
                r.kind
            );
        }
        println!("advisor events (day and local minute):");
        for e in &stream.events {
            println!("  {} {:?}", e.at, e.kind);
        }
    }
    Ok(())
}
