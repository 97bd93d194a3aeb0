//! The `abba` command. It only parses, calls the libraries and prints.
//!
//! - the trial platform: `simulate`, `cohort`, `trial` (with `--shard` and
//!   `trial merge`), `calibrate`;
//! - a person's data: `metrics`, `events`, `export` (a simulated patient as
//!   Nightscout JSON);
//! - a person's advisor: `person`, `import`, `advise`, `answer`, `history`,
//!   `report`;
//! - the service: `serve`, `token`, `app` (a simulated patient through it);
//! - a person's Nightscout: `link`, `sync`.
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

mod advice_text;
mod advise;
mod answer;
mod app;
mod autotune;
mod calibrate;
mod cohort;
mod errors;
mod events;
mod export;
mod history;
mod import;
mod input;
mod link;
mod metrics;
mod output;
mod person;
mod progress;
mod remote;
mod report;
mod serve;
mod shard;
mod simulate;
mod store_args;
mod store_cmd;
mod therapy;
mod trial;
mod trial_limits;
mod twin;
mod twin_effect;

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
    /// Tune the guessed knobs on a training cohort; evaluate on a held-out one.
    Calibrate(calibrate::Args),
    /// Serve a store over HTTP/JSON for pump and phone apps (research software, not a medical device).
    Serve(serve::ServeArgs),
    /// Print a new bearer token for the service once: --admin or --person NAME.
    Token(serve::TokenArgs),
    /// A simulated trial patient through a running `abba serve`, as a pump app would talk to it.
    App(app::Args),
    /// A person's twin: fit it from their records, check it, replay what-ifs (research software, not a medical device).
    Twin(twin::Args),
    /// Check a store (`check`) and remove events dated in the future (`remove-future`).
    Store(store_cmd::Args),
    /// Record the clinician's change of settings (`therapy set`), at any time.
    Therapy(therapy::Args),
    /// oref0's autotune over Nightscout entries and treatments (research software, not a medical device).
    Autotune(autotune::Args),
    /// Link a person to their Nightscout site (`link nightscout`), list (`--list`) or remove links.
    Link(link::Args),
    /// Pull what is new from each linked Nightscout site into the store, then the day's advice.
    Sync(link::SyncArgs),
}

/// The parsed command line. Every subcommand takes negative numbers as
/// values (`--sensitivity -1`, `--days -5`), so that the command can refuse
/// them with a reason instead of clap calling them an unexpected argument.
fn parse() -> Cli {
    let mut cmd = Cli::command();
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|c| c.get_name().to_string())
        .collect();
    for name in names {
        cmd = cmd.mut_subcommand(name, |c| c.allow_negative_numbers(true));
    }
    Cli::from_arg_matches(&cmd.get_matches()).unwrap_or_else(|e| e.exit())
}

fn main() -> ExitCode {
    let command = parse().command;
    // A command that prints ends quietly when its reader goes away
    // (`abba events ... | head`): the default SIGPIPE action, as other
    // Unix tools. Not for the commands that talk over sockets, where a
    // peer that closes must not end the process.
    if !matches!(command, Command::Serve(_) | Command::App(_)) {
        sigpipe::reset();
    }
    // The store file, to say who holds it when it stays busy.
    let db = match &command {
        Command::Import(a) => Some(a.who.db.clone()),
        Command::Answer(a) => Some(a.who.db.clone()),
        Command::Advise(a) => Some(a.who.db.clone()),
        Command::History(a) => Some(a.who.db.clone()),
        Command::Sync(a) => Some(a.db.clone()),
        _ => None,
    };
    let result = match command {
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
        Command::Calibrate(a) => calibrate::run(a),
        Command::Serve(a) => serve::serve(a),
        Command::Token(a) => serve::token(a),
        Command::App(a) => app::run(a),
        Command::Twin(a) => twin::run(a),
        Command::Store(a) => store_cmd::run(a),
        Command::Therapy(a) => therapy::run(a),
        Command::Autotune(a) => autotune::run(a),
        Command::Link(a) => link::run(a),
        Command::Sync(a) => link::sync(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            match errors::busy(&e, db.as_deref()) {
                Some(b) => eprintln!("{b}\n\n{}", errors::render(&e)),
                None => eprintln!("{}", errors::render(&e)),
            }
            // With RUST_BACKTRACE=1 (for developers), where it came from.
            let trace = e.backtrace();
            if trace.status() == std::backtrace::BacktraceStatus::Captured {
                eprintln!("\nStack backtrace:\n{trace}");
            }
            ExitCode::FAILURE
        }
    }
}
