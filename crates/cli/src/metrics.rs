//! `abba metrics`: coverage and glucose metrics (iglu's definitions, see
//! `abba_core::metrics`) of CGM exports read by abba-io. As in a person's
//! store, each local day's readings come from one source
//! (`abba_store::one_source`): one sensor's export beside its readings in
//! Nightscout counts each reading once, and what was set aside is said.
use abba_core::metrics::{mage_timed, metrics_timed, GlucoseMetrics};
use abba_io::coverage::{coverage, Coverage, MIN_COVERAGE_PERCENT};
use abba_io::record::{Censor, RecordKind};
use anyhow::{bail, Context, Result};

use crate::input::{date, InputArgs};

/// Arguments of `abba metrics`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    input: InputArgs,
    /// First local day to use (YYYY-MM-DD, in --tz, UTC without it).
    #[arg(long, value_name = "DATE")]
    from: Option<String>,
    /// Last local day to use (YYYY-MM-DD, inclusive).
    #[arg(long, value_name = "DATE")]
    to: Option<String>,
    /// Print one JSON object with exactly the 15 metric keys of the protocol.
    #[arg(long)]
    json: bool,
}

/// Runs `abba metrics`.
pub fn run(args: Args) -> Result<()> {
    let opts = args.input.options()?;
    let mut batch = abba_io::read_files(&args.input.input, &opts)?;
    if batch.records.is_empty() {
        bail!("no readings in {}", batch.files.join(", "));
    }
    let future = batch.refuse_future(jiff::Timestamp::now());
    if future.count > 0 {
        eprintln!(
            "warning: {} records dated after now were refused; the first: {}",
            future.count,
            future.first.as_deref().unwrap_or("?")
        );
    }
    for f in batch.empty_files() {
        eprintln!("warning: no readings in {f}");
    }
    for n in &batch.notes {
        eprintln!("note: {n}");
    }
    let tz = opts.tz.clone().unwrap_or(jiff::tz::TimeZone::UTC);
    let chosen = abba_store::one_source::choose(&tz, std::mem::take(&mut batch.records));
    batch.records = chosen.records;
    for o in &chosen.set_aside {
        eprintln!("note: {}", abba_store::one_source::sentence_as(o, "read"));
    }
    let from = args
        .from
        .as_deref()
        .map(|d| date("--from", d))
        .transpose()?;
    let to = args.to.as_deref().map(|d| date("--to", d)).transpose()?;
    let (mut times, mut glucose, mut censored) = (Vec::new(), Vec::new(), 0usize);
    let mut last: Option<&abba_io::Record> = None;
    let mut outside = 0usize;
    for r in &batch.records {
        let RecordKind::Cgm { glucose: g } = r.kind else {
            continue;
        };
        let day = tz.to_datetime(r.at).date();
        if from.is_some_and(|f| day < f) || to.is_some_and(|t| day > t) {
            outside += 1;
            continue;
        }
        if let Some(prev) = last.filter(|p| p.at == r.at) {
            bail!(
                "{} has the same time as {} but another glucose value; each reading needs its own time",
                batch.origin(r),
                batch.origin(prev)
            );
        }
        last = Some(r);
        censored += usize::from(g.censor != Censor::Exact);
        times.push(r.at.as_millisecond() as f64 / 60_000.0);
        glucose.push(g.mg_dl.0);
    }
    let files = batch.files.join(", ");
    if times.len() < 2 {
        bail!(
            "{files}: need at least 2 CGM readings in the chosen days, found {}{}",
            times.len(),
            not_cgm(&batch, outside)
        );
    }
    let cov = coverage(&times).context("coverage")?;
    if cov.percent < MIN_COVERAGE_PERCENT {
        eprintln!(
            "warning: CGM coverage is {:.1} % of the expected readings (below the consensus' {MIN_COVERAGE_PERCENT} %); the metrics may not represent the period",
            cov.percent
        );
    }
    let metrics = metrics_timed(&times, &glucose).with_context(|| format!("{files}: metrics"))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&metrics)?);
        return Ok(());
    }
    let mage = mage_timed(&times, &glucose, &Default::default())
        .with_context(|| format!("{files}: MAGE"))?;
    let first = tz.to_datetime(batch_first(&times));
    print_table(
        &files,
        &batch.formats,
        &cov,
        censored,
        &metrics,
        &mage,
        first,
    );
    Ok(())
}

/// What the files held besides the CGM readings used, for the error when
/// there are too few: readings outside the chosen days and every other
/// record by kind (those counted and not read say so; the readers' notes,
/// printed above, say why).
fn not_cgm(batch: &abba_io::Batch, outside: usize) -> String {
    let mut kinds = std::collections::BTreeMap::<String, usize>::new();
    for r in &batch.records {
        match &r.kind {
            RecordKind::Cgm { .. } => {}
            RecordKind::Ignored { kind } => {
                *kinds
                    .entry(format!("{kind} (counted, not read)"))
                    .or_default() += 1
            }
            k => *kinds.entry(k.name().to_string()).or_default() += 1,
        }
    }
    let mut parts = Vec::new();
    if outside > 0 {
        parts.push(format!("{outside} CGM readings outside the chosen days"));
    }
    parts.extend(kinds.iter().map(|(k, n)| format!("{n} {k}")));
    if parts.is_empty() {
        return String::new();
    }
    format!(
        "; the records read: {}{}",
        parts.join(", "),
        if batch.notes.is_empty() {
            ""
        } else {
            " (see the notes above)"
        }
    )
}

fn batch_first(times: &[f64]) -> jiff::Timestamp {
    jiff::Timestamp::from_millisecond((times[0] * 60_000.0) as i64).unwrap_or_default()
}

fn print_table(
    files: &str,
    formats: &[abba_io::Format],
    c: &Coverage,
    censored: usize,
    m: &GlucoseMetrics,
    mage: &abba_core::metrics::Mage,
    first: jiff::civil::DateTime,
) {
    println!("Glucose metrics of {files} ({formats:?})");
    println!("  abba is research software, not a medical device.");
    println!(
        "  {} readings from {first} over {:.1} days; coverage {:.1} % of {} expected at {:.0} min; longest gap {:.0} min",
        m.n_readings, c.days, c.percent, c.expected, c.period_min, c.longest_gap_min
    );
    if censored > 0 {
        println!("  {censored} readings were reported only as Low/High and are counted at the sensor's limit");
    }
    println!(
        "  percentages count readings (iglu); bands as in the seed paper and the 2019 consensus"
    );
    let pct = |label: &str, key: &str, v: f64| println!("  {label:<34} {v:>8.2} %   {key}");
    pct("target 70-180 mg/dL", "tir_70_180", m.tir_70_180);
    pct("hypo 50-<70 mg/dL", "hypo_50_70", m.hypo_50_70);
    pct(
        "severe hypo <50 mg/dL",
        "severe_hypo_lt50",
        m.severe_hypo_lt50,
    );
    pct("hyper >180-300 mg/dL", "hyper_180_300", m.hyper_180_300);
    pct(
        "severe hyper >300 mg/dL",
        "severe_hyper_gt300",
        m.severe_hyper_gt300,
    );
    pct("below 54 mg/dL", "below_54", m.below_54);
    pct("below 70 mg/dL", "below_70", m.below_70);
    pct("above 180 mg/dL", "above_180", m.above_180);
    pct("above 250 mg/dL", "above_250", m.above_250);
    println!("  {:<34} {:>8.2} mg/dL   mean_mg_dl", "mean", m.mean_mg_dl);
    println!("  {:<34} {:>8.2} mg/dL", "SD (n-1)", m.sd_mg_dl);
    println!("  {:<34} {:>8.2} %       cv_pct", "CV", m.cv_pct);
    println!("  {:<34} {:>8.2} %       gmi_pct", "GMI", m.gmi_pct);
    println!("  {:<34} {:>8.3}         lbgi", "LBGI (Kovatchev)", m.lbgi);
    println!("  {:<34} {:>8.3}         hbgi", "HBGI (Kovatchev)", m.hbgi);
    let opt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    println!(
        "  {:<34} {:>8} mg/dL   mage",
        "MAGE (iglu ma 5/32, avg)",
        opt(m.mage)
    );
    println!(
        "  {:<34} MAGE+ {} / MAGE- {} mg/dL; {} of {} segments with excursions",
        "",
        opt(mage.plus),
        opt(mage.minus),
        mage.segments_with_excursions,
        mage.segments
    );
}
