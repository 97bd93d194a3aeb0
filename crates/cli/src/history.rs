//! `abba history`: every suggestion, the answer and the value in force.

use abba_store::history::to_text;
use anyhow::Result;

/// Arguments of `abba history`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// Print the history as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `abba history`.
pub fn run(a: Args) -> Result<()> {
    let mut store = a.who.open()?;
    let rows = store.history(&a.who.person)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print!("{}", to_text(&a.who.person, &rows));
    }
    Ok(())
}
