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
    /// The twin check: hold back a suggestion whose predicted time below
    /// 70 mg/dL rises by more than 1 point on the person's twin (on, off).
    #[arg(long, value_name = "ON|OFF", default_value = "on")]
    pub twin_check: String,
}

/// Runs `abba advise`.
pub fn run(a: Args) -> Result<()> {
    let check = crate::twin_effect::twin_check(&a.twin_check)?;
    let mut store = a.who.open()?;
    let twin = crate::twin_effect::TwinPredictor::new(&a.who.db);
    let advice = store.advise_with(
        &a.who.person,
        Some(abba_store::effect::Effects {
            predictor: &twin,
            check,
        }),
    )?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&advice)?);
    } else {
        let glucose = store.person(&a.who.person)?.settings.units;
        print!("{}", advice_text(&advice, glucose));
    }
    Ok(())
}
