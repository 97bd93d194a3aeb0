//! `abba answer`: what the person put in force for the open suggestions.

use abba_store::answer::parse_param;
use abba_store::{AnswerRequest, NOTICE};
use anyhow::{bail, Context, Result};

/// Arguments of `abba answer`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("what").required(true).args(["accept", "reject", "set"])))]
pub struct Args {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// Accept every open suggestion.
    #[arg(long)]
    pub accept: bool,
    /// Reject every open suggestion (the previous values stay in force).
    #[arg(long)]
    pub reject: bool,
    /// Your own values instead: basal=0.95,breakfast=11.5,lunch=...,dinner=...
    #[arg(long, value_name = "SETTING=VALUE,...")]
    pub set: Option<String>,
    /// Print the answers as JSON.
    #[arg(long)]
    pub json: bool,
}

fn parse_set(text: &str) -> Result<Vec<(abba_advisor::Parameter, f64)>> {
    let mut out = Vec::new();
    for part in text.split(',') {
        let (k, v) = part.split_once('=').with_context(|| {
            format!("--set \"{part}\": expected SETTING=VALUE (basal, breakfast, lunch, dinner)")
        })?;
        let p = parse_param(k).with_context(|| {
            format!("--set \"{part}\": unknown setting \"{k}\" (basal, breakfast, lunch, dinner)")
        })?;
        let v: f64 = v
            .trim()
            .parse()
            .with_context(|| format!("--set \"{part}\": \"{v}\" is not a number"))?;
        if out.iter().any(|(q, _)| *q == p) {
            bail!("--set: {k} is given twice");
        }
        out.push((p, v));
    }
    Ok(out)
}

/// Runs `abba answer`.
pub fn run(a: Args) -> Result<()> {
    let req = match (&a.set, a.accept, a.reject) {
        (Some(s), _, _) => AnswerRequest::Set(parse_set(s)?),
        (None, true, _) => AnswerRequest::Accept,
        _ => AnswerRequest::Reject,
    };
    let mut store = a.who.open()?;
    let answers = store.answer(&a.who.person, &req)?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&answers)?);
        return Ok(());
    }
    for x in &answers {
        println!(
            "{} {}: suggested {:.3}, previous {:.3}; in force now {:.3} {}.",
            x.parameter,
            x.kind.name(),
            x.suggested,
            x.previous,
            x.in_force,
            x.parameter.unit()
        );
    }
    // A basal rate answered for a schedule: the schedule it puts in force,
    // on the pump's step, is what to program (its mean may differ from the
    // answered rate by the steps' rounding).
    if answers
        .iter()
        .any(|x| x.parameter == abba_advisor::Parameter::Basal)
    {
        let advice = store.advise(&a.who.person)?;
        if let (Some(s), Some(mean)) = (
            &advice.therapy.basal_schedule,
            advice.therapy.basal_schedule_mean,
        ) {
            println!(
                "The basal schedule in force now, to program on the pump: {} U/h (mean {:.3} U/h).",
                abba_advisor::words::segments(s),
                mean
            );
        }
    }
    println!("The advisor's next update of each starts from the value in force.\n{NOTICE}");
    Ok(())
}
