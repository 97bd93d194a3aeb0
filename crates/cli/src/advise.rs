//! `abba advise`: what is in force and what to use today, with reasons.
use std::path::PathBuf;

use abba_store::render::advice_text;
use abba_store::Store;
use anyhow::{Context, Result};

/// Arguments of `abba advise`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The store file.
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// The person.
    #[arg(long, value_name = "NAME")]
    pub person: String,
    /// Print the advice as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `abba advise`.
pub fn run(a: Args) -> Result<()> {
    let mut store = Store::open(&a.db).with_context(|| format!("opening {}", a.db.display()))?;
    let advice = store.advise(&a.person)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&advice)?);
    } else {
        print!("{}", advice_text(&advice));
    }
    Ok(())
}
