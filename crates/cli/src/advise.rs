//! `abba advise`: what is in force and what to use today, with reasons.

use crate::advice_text::advice_text;
use anyhow::Result;

/// Arguments of `abba advise`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// Print the advice as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Runs `abba advise`.
pub fn run(a: Args) -> Result<()> {
    let mut store = a.who.open()?;
    let advice = store.advise(&a.who.person)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&advice)?);
    } else {
        print!("{}", advice_text(&advice));
    }
    Ok(())
}
