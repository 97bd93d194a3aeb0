//! `abba history`: every suggestion, the answer and the value in force.
use std::path::PathBuf;

use abba_store::history::to_text;
use abba_store::Store;
use anyhow::{Context, Result};

/// Arguments of `abba history`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The store file.
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// The person.
    #[arg(long, value_name = "NAME")]
    pub person: String,
    /// Print the history as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `abba history`.
pub fn run(a: Args) -> Result<()> {
    let mut store = Store::open(&a.db).with_context(|| format!("opening {}", a.db.display()))?;
    let rows = store.history(&a.person)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", to_text(&a.person, &rows));
    }
    Ok(())
}
