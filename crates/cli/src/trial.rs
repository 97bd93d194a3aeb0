//! `abba trial`: the paper's 98-day in-silico trial and its report.

use abba_sim::cohort::Population;
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::runner::run_trial;
use abba_trial::{ArmKind, TrialConfig};
use anyhow::{bail, Context, Result};
use serde_json::json;
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
    /// Report directory (created if missing).
    #[arg(long, default_value = "abba-out")]
    pub out: PathBuf,
    /// A JSON trial configuration (every knob; see --print-config). Flags
    /// given on the command line override its values.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Print the effective configuration as JSON and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Cohort population: adults, adolescents or children.
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
    pub scenarios: Option<Vec<String>>,
    /// Arms, comma-separated (abba,standard,r2r).
    #[arg(long, value_delimiter = ',')]
    pub arms: Option<Vec<String>>,
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
        c.population = match p.as_str() {
            "adults" => Population::Adults,
            "adolescents" => Population::Adolescents,
            "children" => Population::Children,
            _ => bail!("--population: expected adults, adolescents or children, got '{p}'"),
        };
    }
    if let Some(n) = args.patients {
        c.patients = n;
    }
    if let Some(d) = args.days {
        c.days = d;
    }
    if let Some(s) = &args.scenarios {
        c.scenarios = s
            .iter()
            .map(|x| {
                x.parse::<ScenarioId>()
                    .map_err(|e| anyhow::anyhow!("--scenarios: {e}"))
            })
            .collect::<Result<_>>()?;
    }
    if let Some(a) = &args.arms {
        c.arms = a
            .iter()
            .map(|x| {
                x.parse::<ArmKind>()
                    .map_err(|e| anyhow::anyhow!("--arms: {e}"))
            })
            .collect::<Result<_>>()?;
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

/// Runs `abba trial`.
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
        return crate::shard::run_shard(&args, &config, spec);
    }
    let started = Instant::now();
    let progress = crate::progress::Progress::new("abba trial", "patient-runs", args.quiet);
    let output = run_trial(&config, args.threads, &progress);
    progress.finish();
    let output = output?;
    let wall_s = started.elapsed().as_secs_f64();
    let used = &output.config;
    let mut manifest =
        abba_trial::manifest::manifest(&output, env!("CARGO_PKG_VERSION"), env!("ABBA_GIT_REV"));
    let summary_manifest = manifest.clone();
    manifest["run"] = json!({
        "wall_time_s": wall_s,
        "threads": if args.threads == 0 { rayon_threads() } else { args.threads },
        "patient_runs": used.patients as usize * used.scenarios.len() * used.arms.len(),
    });
    let files = abba_trial::report::write_report(&args.out, &output.arms, &summary_manifest)?;
    // manifest.json also records how the run went (timing, threads);
    // summary.json's copy leaves that out so it is identical across runs.
    let manifest_path = args.out.join("manifest.json");
    std::fs::write(
        &manifest_path,
        serde_json::to_string_pretty(&manifest)? + "\n",
    )
    .with_context(|| format!("cannot write {}", manifest_path.display()))?;
    if !args.trace.is_empty() {
        write_traces(&args, &output)?;
    }
    if !args.quiet {
        eprintln!(
            "abba trial: {} patient-runs in {:.1} s; report in {} ({} files)",
            used.patients as usize * used.scenarios.len() * used.arms.len(),
            wall_s,
            files.dir.display(),
            files.files.len()
        );
    }
    Ok(())
}

/// Writes the 1-minute traces and decision logs asked for with `--trace`.
fn write_traces(args: &Args, output: &abba_trial::runner::TrialOutput) -> Result<()> {
    use std::fmt::Write as _;
    let dir = args.out.join("traces");
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    for patient in &args.trace {
        for scenario in &output.config.scenarios {
            for arm in &output.config.arms {
                let (_, trace) = abba_trial::runner::trace_patient(
                    &output.config,
                    &output.cohort,
                    patient,
                    *scenario,
                    *arm,
                )?;
                let stem = format!("{}-{}-{}", patient.replace('#', "-"), scenario, arm.name());
                let mut csv = String::from(
                    "minute,day,time,plasma_mg_dl,subcutaneous_mg_dl,cgm_mg_dl,smbg_mg_dl,cho_g_per_min,insulin_u_per_min,sensitivity,basal_u_per_h,cr_breakfast_g_per_u,cr_lunch_g_per_u,cr_dinner_g_per_u\n",
                );
                for r in trace.minutes.unwrap_or_default() {
                    let t = abba_core::Timestamp(r.minute);
                    let m = t.minute_of_day();
                    writeln!(
                        csv,
                        "{},{},{:02}:{:02},{},{},{},{},{},{},{},{},{},{},{}",
                        r.minute,
                        t.day_number(),
                        m / 60,
                        m % 60,
                        r.plasma_mg_dl,
                        r.subcutaneous_mg_dl,
                        opt(r.cgm_mg_dl),
                        opt(r.smbg_mg_dl),
                        r.cho_g_per_min,
                        r.insulin_u_per_min,
                        r.sensitivity,
                        r.basal_u_per_h,
                        r.carb_ratio_g_per_u[0],
                        r.carb_ratio_g_per_u[1],
                        r.carb_ratio_g_per_u[2]
                    )?;
                }
                let path = dir.join(format!("{stem}.csv"));
                std::fs::write(&path, csv)
                    .with_context(|| format!("cannot write {}", path.display()))?;
                let mut jsonl = String::new();
                for d in trace.decisions.unwrap_or_default() {
                    jsonl.push_str(&serde_json::to_string(&d)?);
                    jsonl.push('\n');
                }
                let path = dir.join(format!("{stem}.decisions.jsonl"));
                std::fs::write(&path, jsonl)
                    .with_context(|| format!("cannot write {}", path.display()))?;
            }
        }
    }
    Ok(())
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}
