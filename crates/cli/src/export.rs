//! `abba export`: a simulated patient's device data (the event stream the
//! trial fed the advisor) as Nightscout JSON, via abba-io's writer.
use std::path::PathBuf;

use abba_io::clock::AdvisorClock;
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::{ArmKind, RawTrialConfig, TrialConfig};
use std::io::Write;

use anyhow::{anyhow, Context, Result};

use crate::input::date;

/// Arguments of `abba export`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Patient name in the trial's cohort (for example adult#001).
    #[arg(long, value_name = "PATIENT")]
    patient: String,
    /// Cohort size (the trial's --patients; the first 10 are the public patients).
    #[arg(long, default_value_t = 10)]
    patients: u32,
    /// Days to simulate; the first is the trial's warm-up day, which has
    /// no device data (so N days give N - 1 days of data).
    #[arg(long, default_value_t = 14)]
    days: u32,
    /// Arm whose advisor runs: abba, standard or r2r.
    #[arg(long, default_value = "abba")]
    arm: String,
    /// The person's IANA time zone.
    #[arg(long, value_name = "ZONE", default_value = "UTC")]
    tz: String,
    /// Calendar date of the simulation's first day (YYYY-MM-DD), the
    /// warm-up day: the device data, and so a person's day 1, start the
    /// next day (the pump profile is dated from this one).
    #[arg(long, value_name = "DATE", default_value = "2026-01-05")]
    start: String,
    /// Folder for entries.json, treatments.json and profile.json.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
}

/// Runs `abba export` (scenario S1: CGM, days closing at midnight).
pub fn run(args: Args) -> Result<()> {
    let arm = ArmKind::ALL
        .into_iter()
        .find(|a| a.name() == args.arm)
        .ok_or_else(|| anyhow!("--arm {}: expected abba, standard or r2r", args.arm))?;
    // Zone, start and folder are checked before the simulation runs.
    let clock = AdvisorClock::new(
        abba_io::time::zone(&args.tz)?,
        date("--start", &args.start)?,
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("--out {}: cannot create the folder", args.out.display()))?;
    let config = TrialConfig::try_from(RawTrialConfig {
        days: args.days,
        patients: args.patients,
        ..RawTrialConfig::default()
    })?;
    let cohort = abba_trial::runner::build_cohort(&config)?;
    let (_, trace) =
        abba_trial::runner::trace_patient(&config, &cohort, &args.patient, ScenarioId::S1, arm)?;
    let therapy = cohort
        .patients
        .iter()
        .find(|p| p.params.name == args.patient)
        .map(|p| p.therapy)
        .ok_or_else(|| anyhow!("no patient {} in the cohort", args.patient))?;
    let files =
        abba_io::nightscout_out::write(trace.events.as_deref().unwrap_or(&[]), &therapy, &clock)?;
    for (name, text) in [
        ("entries.json", &files.entries),
        ("treatments.json", &files.treatments),
        ("profile.json", &files.profile),
    ] {
        let path = args.out.join(name);
        crate::output::write_atomically(&path, |w| {
            w.write_all(text.as_bytes())
                .with_context(|| format!("cannot write {}", path.display()))
        })?;
    }
    println!(
        "wrote {}/{{entries,treatments,profile}}.json for {} (simulated; abba is research software, not a medical device)",
        args.out.display(),
        args.patient
    );
    Ok(())
}
