//! `abba cohort`: build a virtual cohort (protocol.md §2-§3) and write its
//! parameters and standard therapy as CSV, and/or print a JSON summary.
use crate::output::write_atomically;
use crate::progress::Progress;
use abba_sim::cohort::{Cohort, CohortConfig, Population, MAX_COHORT_SIZE};
use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `abba cohort`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Which group: adults, adolescents or children.
    #[arg(long, default_value = "adults")]
    pub population: String,
    /// Number of patients (the first 10 are the public ones; 1 to
    /// 100,000). With fewer than 2 public patients the SDs are undefined and
    /// reported as such (`null` in the JSON).
    #[arg(long, default_value_t = 100)]
    pub size: i64,
    /// Cohort seed: the generated patients are a pure function of it.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the cohort table here (the 62 columns of vpatient_params.csv,
    /// then basal_u_per_h, carb_ratio_g_per_u and the patient's origin).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print a JSON summary on stdout: per-parameter mean, SD, min, max;
    /// rejected candidates; titrated against Quest carb ratios.
    #[arg(long)]
    pub json: bool,
    /// No progress report on standard error.
    #[arg(long)]
    pub quiet: bool,
}

/// Runs `abba cohort`.
pub fn run(args: Args) -> Result<()> {
    if args.out.is_none() && !args.json {
        bail!("nothing to do: give --out FILE.csv and/or --json");
    }
    let Some(size) = u32::try_from(args.size)
        .ok()
        .filter(|n| (1..=MAX_COHORT_SIZE).contains(n))
    else {
        bail!(
            "--size must be between 1 and {MAX_COHORT_SIZE}, got {} (generating and checking a \
             patient takes a few milliseconds and about 2 kB: {MAX_COHORT_SIZE} already take \
             several minutes)",
            args.size
        );
    };
    let population: Population = args.population.parse()?;
    let config = CohortConfig::new(population, size, args.seed);
    let progress = Progress::new("abba cohort", "patients", args.quiet);
    let cohort =
        Cohort::generate_with_progress(&config, &mut |done, total| progress.update(done, total));
    progress.finish();
    let cohort =
        cohort.with_context(|| format!("building the {population} cohort (seed {})", args.seed))?;
    if let Some(path) = &args.out {
        write_atomically(path, |w| Ok(cohort.write_csv(w)?))
            .with_context(|| format!("writing the cohort table to {}", path.display()))?;
    }
    let summary = cohort.summary()?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &summary)?;
        writeln!(out)?;
    } else {
        let t = &summary.titration_vs_quest;
        writeln!(
            out,
            "{} {}: {} public + {} generated patients (seed {}), {} candidates rejected; \
             titrated/Quest carb ratio: geometric mean {:.2}, SD of log {}",
            summary.size,
            population,
            summary.public,
            summary.generated,
            summary.seed,
            summary.rejections.total,
            t.geometric_mean_ratio,
            t.sd_log_ratio.map_or_else(
                || "undefined (fewer than 2 public patients)".to_string(),
                |sd| format!("{sd:.2}")
            ),
        )?;
        if let Some(path) = &args.out {
            writeln!(out, "wrote {}", path.display())?;
        }
    }
    Ok(())
}
