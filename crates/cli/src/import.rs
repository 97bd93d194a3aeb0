//! `abba import`: add device exports to a person's log (idempotent).
use std::path::PathBuf;

use abba_store::{ProfileResolution, NOTICE};
use anyhow::Result;

/// Arguments of `abba import`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    #[command(flatten)]
    pub read: crate::input::ReadFlags,
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
    /// Export files (a Nightscout export is entries.json, treatments.json, profile.json).
    #[arg(required = true, value_name = "FILE")]
    pub files: Vec<PathBuf>,
}

/// Runs `abba import`.
pub fn run(a: Args) -> Result<()> {
    let read = a.read.options()?;
    let mut store = a.who.open()?;
    let resolve = match (a.adopt_profile, a.keep_therapy) {
        (true, _) => ProfileResolution::Adopt,
        (_, true) => ProfileResolution::Keep,
        _ => ProfileResolution::Stop,
    };
    let s = store.import_files_read(&a.who.person, &a.files, &read, resolve)?;
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
