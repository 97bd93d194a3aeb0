//! The `abba` command: simulate a patient, build a cohort, compute glucose
//! metrics, run the paper's in-silico trial.
use anyhow::Result;
use clap::{Parser, Subcommand};

mod advise;
mod answer;
mod cohort;
mod events;
mod export;
mod history;
mod import;
mod input;
mod metrics;
mod person;
mod person_report;
mod report;
mod simulate;
mod trial;

/// abba: adaptive basal-bolus advisor and in-silico trial platform.
#[derive(Parser)]
#[command(name = "abba", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Open-loop replay of one patient with per-minute carbohydrate and insulin inputs.
    Simulate(simulate::Args),
    /// Build a virtual cohort and write its parameters and standard therapy.
    Cohort(cohort::Args),
    /// Coverage and glucose metrics of CGM exports (Nightscout, Clarity, LibreView, Tidepool, CSV).
    Metrics(metrics::Args),
    /// Device exports as normalised records and the advisor's events.
    Events(events::Args),
    /// A simulated patient's device data as Nightscout JSON.
    Export(export::Args),
    /// Run the paper's 98-day in-silico trial and write the report.
    Trial(trial::Args),
    /// Create or list persons in a store file (research software, not a medical device).
    Person(person::Args),
    /// Import device exports into a person's log (idempotent).
    Import(import::Args),
    /// Today's advice for a person: what is in force, what to use, why.
    Advise(advise::Args),
    /// Answer the open suggestions: --accept, --reject or --set.
    Answer(answer::Args),
    /// Every suggestion, the answer and the value in force, by day.
    History(history::Args),
    /// A person's AGP-style report as one HTML page (research software, not a medical device).
    Report(report::Args),
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Simulate(a) => simulate::run(a),
        Command::Cohort(a) => cohort::run(a),
        Command::Metrics(a) => metrics::run(a),
        Command::Events(a) => events::run(a),
        Command::Export(a) => export::run(a),
        Command::Trial(a) => trial::run(a),
        Command::Person(a) => person::run(a),
        Command::Import(a) => import::run(a),
        Command::Advise(a) => advise::run(a),
        Command::Answer(a) => answer::run(a),
        Command::History(a) => history::run(a),
        Command::Report(a) => report::run(a),
    }
}
