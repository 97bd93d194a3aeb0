//! The `abba` command: simulate a patient, build a cohort, compute glucose
//! metrics, run the paper's in-silico trial.
use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cohort;
mod errors;
mod metrics;
mod output;
mod progress;
mod simulate;
mod trial;
mod trial_limits;

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

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Simulate(a) => simulate::run(a),
        Command::Cohort(a) => cohort::run(a),
        Command::Metrics(a) => metrics::run(a),
        Command::Trial(a) => trial::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{}", errors::render(&e));
            ExitCode::FAILURE
        }
    }
}
