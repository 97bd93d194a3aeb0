//! `abba calibrate`: tunes the declared guessed knobs on a training cohort
//! and evaluates the choice once on a held-out cohort (library:
//! `abba_trial::calibrate`).

use abba_trial::calibrate::{calibrate, report_markdown, CalibrationConfig, LogEntry};
use abba_trial::protocol::RawTrialConfig;
use anyhow::{Context, Result};
use std::path::PathBuf;

/// Arguments of `abba calibrate`. With none, calibrates the default trial's
/// knobs on 60 generated adults (cohort seed 101, trial seed 101) and
/// evaluates on 100 held-out adults (cohort seed 202, trial seed 202).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory (created if missing): calibration.json (search log),
    /// calibration.md (summary) and chosen_config.json (for `abba trial --config`).
    #[arg(long, default_value = "abba-calibration")]
    pub out: PathBuf,
    /// A JSON trial configuration to start from (default: the built-in defaults).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// A JSON calibration configuration (cohorts, knob grids, objective;
    /// see --print-spec).
    #[arg(long)]
    pub spec: Option<PathBuf>,
    /// Print the effective calibration configuration as JSON and exit.
    #[arg(long)]
    pub print_spec: bool,
    /// Training patients (overrides the spec).
    #[arg(long)]
    pub train_patients: Option<u32>,
    /// Held-out patients (overrides the spec).
    #[arg(long)]
    pub held_out_patients: Option<u32>,
    /// Worker threads (0 = one per core, 1 = serial).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No per-evaluation lines on stderr.
    #[arg(long)]
    pub quiet: bool,
}

fn read_json<T: serde::de::DeserializeOwned>(path: &PathBuf, what: &str) -> Result<T> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read {what} {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a valid {what}", path.display()))
}

/// Runs `abba calibrate`.
pub fn run(args: Args) -> Result<()> {
    let base: RawTrialConfig = match &args.config {
        Some(p) => read_json(p, "trial configuration")?,
        None => RawTrialConfig::default(),
    };
    let mut spec: CalibrationConfig = match &args.spec {
        Some(p) => read_json(p, "calibration configuration")?,
        None => CalibrationConfig::default(),
    };
    if let Some(n) = args.train_patients {
        spec.training.patients = n;
    }
    if let Some(n) = args.held_out_patients {
        spec.held_out.patients = n;
    }
    spec.validate(&base)?;
    if args.print_spec {
        println!("{}", serde_json::to_string_pretty(&spec)?);
        return Ok(());
    }
    eprintln!("abba calibrate (research software, not a medical device)");
    let quiet = args.quiet;
    let show = |e: &LogEntry| {
        if !quiet {
            let knob = e.knob.map_or("start".to_string(), |k| format!("{k:?}"));
            let value = e.knob.and_then(|k| e.values.get(&k)).copied();
            eprintln!(
                "pass {} {:>5} {:<14} {:>8} score {:.4}",
                e.pass,
                e.arm,
                knob,
                value.map_or(String::new(), |v| v.to_string()),
                e.score
            );
        }
    };
    let report = calibrate(&base, &spec, args.threads, &show)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let write = |name: &str, text: String| -> Result<()> {
        let path = args.out.join(name);
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
    };
    write(
        "calibration.json",
        serde_json::to_string_pretty(&report)? + "\n",
    )?;
    write(
        "chosen_config.json",
        serde_json::to_string_pretty(&report.chosen_trial)? + "\n",
    )?;
    let md = report_markdown(&report);
    write("calibration.md", md.clone())?;
    println!("{md}");
    Ok(())
}
