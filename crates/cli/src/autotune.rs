//! `abba autotune`: oref0's autotune (abba-advisor's implementation) over
//! Nightscout entries and treatments, or over a person's records in a
//! store, day by day as `oref0-autotune.sh` runs it; prints the tuned
//! profile in oref0's JSON shape and the recommendations table. Parsing and
//! printing only: the runs are abba-store's ([`abba_store::autotune`]),
//! reading abba-io's, tuning abba-advisor's.
use std::path::PathBuf;

use abba_advisor::baselines::autotune::{recommendations_table, IsfUnit};
use abba_store::autotune::{self as tune, Data, Days, DEFAULT_DIA_H};
use anyhow::{bail, Result};

use crate::input::date;

const NOTICE: &str =
    "abba is research software, not a medical device: discuss any change with your clinician";

/// Arguments of `abba autotune`.
#[derive(clap::Args, Debug)]
#[command(group(clap::ArgGroup::new("source").required(true).args(["entries", "db"])))]
pub struct Args {
    /// Nightscout entries (entries.json or entries/sgv.json).
    #[arg(long, value_name = "FILE", requires_all = ["treatments", "profile", "tz"])]
    entries: Option<PathBuf>,
    /// Nightscout treatments (boluses, carbs, temporary basals).
    #[arg(long, value_name = "FILE", requires = "entries")]
    treatments: Option<PathBuf>,
    /// The profile to tune, in oref0's JSON shape (basalprofile, isfProfile,
    /// carb_ratio, dia, curve, ...), or a Nightscout profile store
    /// (api/v1/profile.json: its newest default profile, oref0's defaults
    /// for the curve and autosens). With --db: instead of the person's
    /// therapy in force.
    #[arg(long, value_name = "FILE")]
    profile: Option<PathBuf>,
    /// The pump's own profile (the caps' reference) [default: --profile].
    #[arg(long, value_name = "FILE")]
    pump_profile: Option<PathBuf>,
    /// The person's IANA time zone (autotune's days and hours are local).
    #[arg(long, value_name = "ZONE", conflicts_with = "db")]
    tz: Option<String>,
    /// A store file: tune from the records of --person.
    #[arg(long, value_name = "FILE", requires = "person")]
    db: Option<PathBuf>,
    /// The person (with --db).
    #[arg(long, value_name = "NAME", requires = "db")]
    person: Option<String>,
    /// With --db and no --profile: the person's insulin sensitivity factor,
    /// in the person's glucose unit per unit (mg/dL/U or mmol/L/U; the
    /// store does not keep one).
    #[arg(long, value_name = "ISF", allow_negative_numbers = true)]
    isf: Option<f64>,
    /// With --db and no --profile: duration of insulin action (h) of the
    /// exponential rapid-acting curve [default: 5].
    #[arg(long, value_name = "HOURS")]
    dia: Option<f64>,
    /// Tune the last N complete days (04:00 to 04:00 local, as oref0-autotune.sh counts them) of the data.
    #[arg(long, value_name = "N", conflicts_with = "start")]
    days: Option<u32>,
    /// First day to tune (YYYY-MM-DD) [default: the first complete day of the data].
    #[arg(long, value_name = "DATE")]
    start: Option<String>,
    /// Last day to tune [default: the last complete day of the data].
    #[arg(long, value_name = "DATE")]
    end: Option<String>,
    /// Print JSON: the tuned profile, the days and what each run noted.
    #[arg(long)]
    json: bool,
}

/// `--isf` and `--dia` describe the profile abba makes from a store; with
/// `--profile` (which has its own) they would be ignored, so they are
/// refused.
fn given_with_profile(args: &Args) -> Result<()> {
    if args.isf.is_some() {
        bail!("--isf and --profile: give one (the profile has its own ISF, `sens` in a Nightscout profile store, `isfProfile` in oref0's)");
    }
    if args.dia.is_some() {
        bail!("--dia and --profile: give one (the profile has its own duration of insulin action, `dia`)");
    }
    Ok(())
}

/// Runs `abba autotune`.
pub fn run(args: Args) -> Result<()> {
    let mut said = Vec::new();
    let (data, profile, unit) = match (&args.entries, &args.db, &args.person) {
        (Some(entries), _, _) => {
            let (Some(treatments), Some(profile), Some(tz)) =
                (&args.treatments, &args.profile, &args.tz)
            else {
                bail!("--entries needs --treatments, --profile and --tz");
            };
            given_with_profile(&args)?;
            let data = Data::from_nightscout(entries, treatments, abba_io::time::zone(tz)?)?;
            let profile = tune::read_profile(profile, &mut said)?;
            (data, profile, IsfUnit::MgDl)
        }
        (None, Some(db), Some(name)) => {
            let mut store = crate::store_args::open(db)?;
            let unit = tune::isf_unit(store.person(name)?.settings.units);
            let profile = match (&args.profile, args.isf) {
                (Some(p), _) => {
                    given_with_profile(&args)?;
                    tune::read_profile(p, &mut said)?
                }
                (None, Some(isf)) => {
                    let dia = args.dia.unwrap_or(DEFAULT_DIA_H);
                    let (p, line) = tune::person_profile(&mut store, name, isf, dia)?;
                    said.push(line);
                    p
                }
                (None, None) => bail!(
                    "--isf: the person's insulin sensitivity factor ({}) is needed, since the store keeps none (or give --profile)",
                    unit.label()
                ),
            };
            let shown = abba_store::backend::shown(db).to_string();
            (Data::from_store(&store, &shown, name)?, profile, unit)
        }
        _ => bail!("give --entries, --treatments, --profile and --tz, or --db and --person"),
    };
    let pump = match &args.pump_profile {
        Some(p) => tune::read_profile(p, &mut said)?,
        None => profile.clone(),
    };
    let wanted = Days {
        start: args
            .start
            .as_deref()
            .map(|d| date("--start", d))
            .transpose()?,
        end: args.end.as_deref().map(|d| date("--end", d)).transpose()?,
        last: args.days,
    };
    if wanted.last == Some(0) {
        bail!("--days: expected at least 1, got 0");
    }
    let out = tune::run(data, profile, &pump, &wanted, said)?;
    if args.json {
        let doc = serde_json::json!({
            "notice": NOTICE,
            "days": out.days,
            "notes": out.said,
            "unused_records": out.unused,
            "isf": {"unit": unit.label(), "pump": unit.of(out.tuned.pump_isf), "tuned": unit.of(out.tuned.isf)},
            "runs": out.runs,
            "profile": out.profile,
        });
        println!("{}", serde_json::to_string_pretty(&doc)?);
        return Ok(());
    }
    println!(
        "Autotune (oref0 0.7.1's algorithm) over {} day(s): {} to {}",
        out.days.len(),
        out.range.0,
        out.range.1
    );
    println!("{NOTICE}.");
    for s in &out.said {
        println!("{s}");
    }
    if !out.unused.is_empty() {
        let kinds: Vec<String> = out.unused.iter().map(|(k, n)| format!("{k} {n}")).collect();
        println!(
            "Records autotune does not read (as oref0): {}",
            kinds.join(", ")
        );
    }
    println!();
    print!("{}", recommendations_table(&out.tuned, unit));
    println!();
    println!("The tuned profile (oref0's JSON, ISF in mg/dL/U):");
    println!("{}", serde_json::to_string_pretty(&out.profile)?);
    Ok(())
}
