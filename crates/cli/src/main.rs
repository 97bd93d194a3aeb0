//! The `abba` command: simulate a patient, build a cohort, compute glucose
//! metrics, run the paper's in-silico trial.
use anyhow::Result;
use clap::{Parser, Subcommand};

mod cohort;
mod metrics;
mod shard;
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
    /// Compute glucose metrics for a CSV of readings.
    Metrics(metrics::Args),
    /// Run the paper's 98-day in-silico trial and write the report.
    Trial(trial::Args),
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Simulate(a) => simulate::run(a),
        Command::Cohort(a) => cohort::run(a),
        Command::Metrics(a) => metrics::run(a),
        Command::Trial(a) => trial::run(a),
    }
}
