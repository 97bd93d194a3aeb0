//! `abba trial --shard I/N` and `abba trial merge`: a trial split into
//! shards for batch schedulers, merged into the report a single run writes.

use abba_trial::report::{patient_runs, ReportPlan, RunInfo, ToolInfo};
use abba_trial::shard::{self, ShardSpec};
use abba_trial::TrialConfig;
use anyhow::{Context, Result};
use std::path::PathBuf;
use std::time::Instant;

/// Subcommands of `abba trial`.
#[derive(clap::Subcommand, Debug)]
pub enum TrialCommand {
    /// Merge the shard files of one trial (from `abba trial --shard I/N`)
    /// into its report: the same files a single run writes.
    Merge(MergeArgs),
}

/// Arguments of `abba trial merge`.
#[derive(clap::Args, Debug)]
pub struct MergeArgs {
    /// Report directory (created if missing).
    #[arg(long, default_value = "abba-out")]
    pub out: PathBuf,
    /// The shard files (all N of them, any order).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// No closing message.
    #[arg(long)]
    pub quiet: bool,
}

/// Where and how `abba trial --shard` runs (the trial's own flags).
pub struct ShardRun<'a> {
    /// The folder the shard file goes to (`--out`).
    pub out: &'a std::path::Path,
    /// Worker threads (`--threads`).
    pub threads: usize,
    /// No progress and no closing message (`--quiet`).
    pub quiet: bool,
}

/// Runs one shard and writes `shard-I-of-N.json` into `--out`.
pub fn run_shard(run: ShardRun<'_>, config: &TrialConfig, spec: ShardSpec) -> Result<()> {
    let started = Instant::now();
    let progress = crate::progress::Progress::new(
        &format!("abba trial --shard {spec}"),
        "patient-runs",
        run.quiet,
    );
    let file = shard::run_shard(config, spec, run.threads, &progress);
    progress.finish();
    let file = file?;
    std::fs::create_dir_all(run.out)
        .with_context(|| format!("cannot create {}", run.out.display()))?;
    let path = run
        .out
        .join(format!("shard-{}-of-{}.json", spec.index, spec.count));
    shard::write_shard(&path, &file)?;
    if !run.quiet {
        eprintln!(
            "abba trial: shard {spec}: {} of {} patient-runs in {:.1} s; wrote {}",
            file.jobs.len(),
            file.total_jobs,
            started.elapsed().as_secs_f64(),
            path.display()
        );
    }
    Ok(())
}

/// Runs a subcommand of `abba trial`.
pub fn run_command(command: TrialCommand) -> Result<()> {
    match command {
        TrialCommand::Merge(args) => merge(args),
    }
}

fn merge(args: MergeArgs) -> Result<()> {
    let started = Instant::now();
    let shards = args
        .shards
        .iter()
        .map(|p| shard::read_shard(p))
        .collect::<Result<Vec<_>, _>>()?;
    let output = shard::merge(&shards)?;
    let plan = ReportPlan::check(&output.config, &args.out, &[])?;
    let tool = ToolInfo {
        version: env!("CARGO_PKG_VERSION"),
        git_revision: env!("ABBA_GIT_REV"),
    };
    // `run` in manifest.json: the merge itself (the shards ran elsewhere).
    let run = RunInfo {
        wall_time_s: started.elapsed().as_secs_f64(),
        threads: 1,
        patient_runs: patient_runs(&output.config),
    };
    let written = plan.write(&output, &tool, &run)?;
    if !args.quiet {
        eprintln!(
            "abba trial merge: {} shards; report in {} ({} files)",
            shards.len(),
            written.dir.display(),
            written.files.len()
        );
    }
    Ok(())
}
