//! `abba import`: add device exports to a person's log (idempotent).
use std::path::PathBuf;

use abba_io::read::Format;
use abba_store::{ProfileResolution, NOTICE};
use anyhow::{Context, Result};

/// Arguments of `abba import`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// Format of the files (nightscout, clarity, libreview, tidepool, carelink, csv) [default: detected].
    #[arg(long)]
    pub format: Option<String>,
    /// Print the summary as JSON.
    #[arg(long)]
    pub json: bool,
    /// When the export's pump profile differs from the therapy the store
    /// holds: put the profile in force (what the pump runs).
    #[arg(long, conflicts_with = "keep_therapy")]
    pub adopt_profile: bool,
    /// When the export's pump profile differs from the therapy the store
    /// holds: keep the store's values (profiles are then not read as therapy).
    #[arg(long)]
    pub keep_therapy: bool,
    /// CareLink: grams of carbohydrate in one exchange, for a pump whose bolus wizard counts in exchanges (10 for the Spanish ración; 12 and 15 are used elsewhere). Without it such carbohydrate is not read.
    #[arg(long, value_name = "G")]
    pub grams_per_exchange: Option<f64>,
    /// Export files (a Nightscout export is entries.json, treatments.json, profile.json).
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
}

/// Runs `abba import`.
pub fn run(a: Args) -> Result<()> {
    let format = match &a.format {
        Some(f) => Some(Format::parse(f).with_context(|| {
            format!("--format \"{f}\": expected nightscout, clarity, libreview, tidepool, carelink or csv")
        })?),
        None => None,
    };
    let mut store = a.who.open()?;
    let resolve = match (a.adopt_profile, a.keep_therapy) {
        (true, _) => ProfileResolution::Adopt,
        (_, true) => ProfileResolution::Keep,
        _ => ProfileResolution::Stop,
    };
    let g = crate::input::grams_per_exchange(a.grams_per_exchange)?;
    let s = store.import_files_with(&a.who.person, &a.files, format, resolve, g)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&s)?);
        return Ok(());
    }
    print_summary(&s, &a.who.person);
    println!("{NOTICE}");
    Ok(())
}

/// Prints what an import did (also after `abba sync`).
pub fn print_summary(s: &abba_store::ImportSummary, person: &str) {
    for line in s.lines(person) {
        println!("{line}");
    }
}
