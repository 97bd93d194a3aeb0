//! `abba trial`: the paper's 98-day in-silico trial and its report.

use abba_sim::cohort::Population;
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::report::{effective_threads, patient_runs, ReportPlan, RunInfo, ToolInfo};
use abba_trial::runner::run_trial;
use abba_trial::{ArmKind, TrialConfig};
use anyhow::{bail, Context, Result};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `abba trial`. With none, runs the full paper protocol:
/// 100 adults, 98 days, S1-S4, arms abba, standard and r2r, seed 1.
#[derive(clap::Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub struct Args {
    /// `abba trial merge`: merge shard files into the report.
    #[command(subcommand)]
    pub command: Option<crate::shard::TrialCommand>,
    /// Run only shard I of N of the trial's (scenario, arm, patient) jobs
    /// and write `shard-I-of-N.json` into --out; `abba trial merge` turns
    /// the N files into the report a single run writes.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<abba_trial::shard::ShardSpec>,
    /// Report folder: new, empty, or an earlier abba report (whose files
    /// abba replaces; other files are left alone). Checked before the run.
    #[arg(long, default_value = "abba-out")]
    pub out: PathBuf,
    /// A JSON trial configuration (every knob; see --print-config). Flags
    /// given on the command line override its values.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Print the effective configuration as JSON and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Cohort population: adults, adolescents or children (without --config,
    /// with ABBA's defaults for that population: the basal agent's hours in
    /// CGM mode)
    #[arg(long)]
    pub population: Option<String>,
    /// Number of patients (the first 10 are the public ones).
    #[arg(long)]
    pub patients: Option<u32>,
    /// Days to simulate (98 in the paper; at least 9).
    #[arg(long)]
    pub days: Option<u32>,
    /// Scenarios, comma-separated (S1,S2,S3,S4).
    #[arg(long, value_delimiter = ',')]
    pub scenarios: Option<Vec<ScenarioId>>,
    /// Arms, comma-separated (abba,standard,r2r; autotune and abba-twin, ABBA with
    /// the twin check, are opt-in: abba,standard,r2r,autotune,abba-twin).
    #[arg(long, value_delimiter = ',')]
    pub arms: Option<Vec<ArmKind>>,
    /// Trial seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Cohort seed.
    #[arg(long)]
    pub cohort_seed: Option<u64>,
    /// Worker threads (0 = one per core, 1 = serial).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Use the configured TE reference instead of calibrating it on the cohort.
    #[arg(long)]
    pub no_te_calibration: bool,
    /// Also write a full trace of these patients (comma-separated names,
    /// e.g. adult#001,adult#042) in every scenario and arm: every simulated
    /// minute (`traces/<patient>-<scenario>-<arm>.csv`) and every decision
    /// with its explanation (`... .decisions.jsonl`).
    #[arg(long, value_delimiter = ',')]
    pub trace: Vec<String>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

pub(crate) fn config_from(args: &Args) -> Result<TrialConfig> {
    let mut c = match &args.config {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read trial configuration {}", path.display()))?;
            RawTrialConfig::from_json(&text)
                .with_context(|| format!("{}: not a valid trial configuration", path.display()))?
        }
        None => RawTrialConfig::default(),
    };
    if let Some(p) = &args.population {
        let population = match p.as_str() {
            "adults" => Population::Adults,
            "adolescents" => Population::Adolescents,
            "children" => Population::Children,
            _ => bail!("--population: expected adults, adolescents or children, got '{p}'"),
        };
        // Without a configuration file, the population's own defaults; a
        // file's knobs stay as written.
        if args.config.is_none() {
            c = RawTrialConfig::for_population(population);
        }
        c.population = population;
    }
    if let Some(n) = args.patients {
        c.patients = n;
    }
    if let Some(d) = args.days {
        c.days = d;
    }
    if let Some(s) = &args.scenarios {
        c.scenarios.clone_from(s);
    }
    if let Some(a) = &args.arms {
        c.arms.clone_from(a);
    }
    if let Some(s) = args.seed {
        c.seed = s;
    }
    if let Some(s) = args.cohort_seed {
        c.cohort_seed = s;
    }
    if args.no_te_calibration {
        c.calibrate_te_ref = false;
    }
    let checked = match &args.config {
        Some(path) => TrialConfig::try_from(c).with_context(|| format!("{}", path.display()))?,
        None => TrialConfig::try_from(c)?,
    };
    crate::trial_limits::check(&checked)?;
    Ok(checked)
}

/// Runs `abba trial`: checks the report folder and the traced patients,
/// runs the trial, writes the report.
pub fn run(args: Args) -> Result<()> {
    if let Some(command) = args.command {
        return crate::shard::run_command(command);
    }
    let config = config_from(&args)?;
    if args.print_config {
        println!("{}", serde_json::to_string_pretty(&config)?);
        return Ok(());
    }
    if let Some(spec) = args.shard {
        if !args.trace.is_empty() {
            bail!(
                "--trace cannot be combined with --shard: trace the patient with a single run (runs are pure functions of the configuration)"
            );
        }
        let run = crate::shard::ShardRun {
            out: &args.out,
            threads: args.threads,
            quiet: args.quiet,
        };
        return crate::shard::run_shard(run, &config, spec);
    }
    // Before the run: a bad folder or patient name must not cost a trial.
    let plan = ReportPlan::check(&config, &args.out, &args.trace)?;
    let started = Instant::now();
    let progress = crate::progress::Progress::new("abba trial", "patient-runs", args.quiet);
    let output = run_trial(&config, args.threads, &progress);
    progress.finish();
    let output = output?;
    let run = RunInfo {
        wall_time_s: started.elapsed().as_secs_f64(),
        threads: effective_threads(args.threads),
        patient_runs: patient_runs(&output.config),
    };
    let tool = ToolInfo {
        version: env!("CARGO_PKG_VERSION"),
        git_revision: env!("ABBA_GIT_REV"),
    };
    let written = plan.write(&output, &tool, &run)?;
    if !args.quiet {
        eprintln!(
            "abba trial: {} patient-runs in {:.1} s; report in {} ({} files{})",
            run.patient_runs,
            run.wall_time_s,
            written.dir.display(),
            written.files.len(),
            if written.traces.is_empty() {
                String::new()
            } else {
                format!(", {} trace files", written.traces.len())
            }
        );
    }
    Ok(())
}
