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
pub struct Args {
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

fn config_from(args: &Args) -> Result<TrialConfig> {
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
    let config = config_from(&args)?;
    if args.print_config {
        println!("{}", serde_json::to_string_pretty(&config)?);
        return Ok(());
    }
    let started = Instant::now();
    let progress = crate::progress::Progress::new("abba trial", "patient-runs", args.quiet);
    let output = run_trial(&config, args.threads, &progress);
    progress.finish();
    let output = output?;
    let wall_s = started.elapsed().as_secs_f64();
    let used = &output.config;
    let mut manifest = json!({
        "tool": "abba",
        "version": env!("CARGO_PKG_VERSION"),
        "git_revision": env!("ABBA_GIT_REV"),
        "seed": used.seed,
        "cohort": {
            "population": used.population,
            "patients": output.cohort.patients.len(),
            "seed": used.cohort_seed,
            "rejected_candidates": output.cohort.rejections,
        },
        "protocol": {
            "days": used.days,
            "warm_up_days": 1,
            "init_days": used.init_days,
            "scenarios": used.scenarios,
            "arms": used.arms,
            "modes": used.planned().iter().map(|s| (s.id.name(), s.mode.name())).collect::<std::collections::BTreeMap<_, _>>(),
            "advisors_run": advisors_run(used),
            "evaluation": "plasma glucose G = Gp/Vg every 5 min; W1 = D2-D8, W13 = D84-D90, W14 = D92-D98; weekly Wk = D(7k-5)..D(7k+1)",
        },
        "te_calibration": {
            "calibrated": used.calibrate_te_ref && used.arms.contains(&ArmKind::Abba),
            "te_ref_bits_cgm": used.abba.te.te_ref_bits,
            "te_ref_bits_smbg": used.te_ref_bits_smbg.unwrap_or(used.abba.te.te_ref_bits),
            "how": "median over the cohort of ABBA's own first-week TE estimate in each mode (spec §7.3)",
            "first_week_te_bits": output.first_week_te_bits,
        },
        "knobs": used,
    });
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
    // W1 sensitivity block: the standard arm's W1 with each variability source off.
    let first = used.scenarios[0];
    let w1 = abba_trial::w1_sensitivity::w1_sensitivity(used, first)?;
    let w1_path = args.out.join("w1_sensitivity.md");
    std::fs::write(
        &w1_path,
        abba_trial::w1_sensitivity::w1_markdown(first, &w1),
    )
    .with_context(|| format!("cannot write {}", w1_path.display()))?;
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

/// What each arm ran in each mode, with the knobs the trial set (ABBA's
/// exploration seed is derived per patient).
fn advisors_run(used: &TrialConfig) -> serde_json::Value {
    let mut out = serde_json::Map::new();
    for p in used.planned() {
        let mode = p.mode.name().to_string();
        if out.contains_key(&mode) {
            continue;
        }
        let arms: serde_json::Map<_, _> = used
            .arms
            .iter()
            .map(|a| (a.name().to_string(), json!(used.advisor_spec(*a, p.mode))))
            .collect();
        out.insert(mode, serde_json::Value::Object(arms));
    }
    out.insert(
        "exploration_seed".into(),
        json!("derive_seed(seed, patient number, scenario random_key, exploration), per patient"),
    );
    serde_json::Value::Object(out)
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}
