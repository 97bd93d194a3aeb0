//! `abba person new|list`: the persons of a store file.
use std::path::PathBuf;

use abba_advisor::bounds::Range;
use abba_advisor::Mode;
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_io::meals::MealWindows;
use abba_store::{NewPerson, Store, NOTICE};
use anyhow::{bail, Context, Result};

/// Arguments of `abba person`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

// Parsed once per run: the size difference does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Create a person in a store file (the file is created if needed).
    New(Box<NewArgs>),
    /// List the persons of a store file.
    List {
        /// The store file.
        #[arg(long, value_name = "FILE")]
        db: PathBuf,
    },
}

/// Advisor mode.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum ModeArg {
    Cgm,
    Smbg,
}

#[derive(clap::Args, Debug)]
struct NewArgs {
    /// The store file.
    #[arg(long, value_name = "FILE")]
    db: PathBuf,
    /// Unique name in the file.
    #[arg(long)]
    name: String,
    /// IANA time zone (for example Europe/Zurich).
    #[arg(long, value_name = "ZONE")]
    tz: String,
    /// Which readings the advisor learns from.
    #[arg(long, value_enum)]
    mode: ModeArg,
    /// Current flat basal rate (U/h).
    #[arg(long, value_name = "U_PER_H")]
    basal: f64,
    /// Current carb ratios of breakfast, lunch, dinner (g/U): B,L,D.
    #[arg(long, value_name = "B,L,D")]
    carb_ratio: String,
    /// Meal windows, local time: HH:MM-HH:MM,HH:MM-HH:MM,HH:MM-HH:MM
    /// [default: 05:00-10:30,10:30-15:30,15:30-22:00].
    #[arg(long, value_name = "B,L,D")]
    meal_windows: Option<String>,
    /// Clinician bounds of the basal rate (U/h): MIN-MAX.
    #[arg(long, value_name = "MIN-MAX")]
    basal_range: Option<String>,
    /// Clinician bounds of every carb ratio (g/U): MIN-MAX.
    #[arg(long, value_name = "MIN-MAX")]
    carb_ratio_range: Option<String>,
    /// Day 1 of the advisor (YYYY-MM-DD) [default: the date of the first record imported].
    #[arg(long, value_name = "DATE")]
    first_day: Option<String>,
    /// SMBG mode: the day closes at the first meter reading from this local time.
    #[arg(long, value_name = "HH:MM", default_value = "22:00")]
    bedtime: String,
}

fn range(flag: &str, text: &str) -> Result<Range> {
    let (a, b) = text
        .split_once('-')
        .with_context(|| format!("{flag} \"{text}\": expected MIN-MAX, for example 0.5-1.5"))?;
    let min: f64 = a
        .trim()
        .parse()
        .with_context(|| format!("{flag}: \"{a}\" is not a number"))?;
    let max: f64 = b
        .trim()
        .parse()
        .with_context(|| format!("{flag}: \"{b}\" is not a number"))?;
    Ok(Range { min, max })
}

fn new(a: NewArgs) -> Result<()> {
    let cr: Vec<f64> = a
        .carb_ratio
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| {
            format!(
                "--carb-ratio \"{}\": expected three numbers B,L,D",
                a.carb_ratio
            )
        })?;
    let [b, l, d] = cr[..] else {
        bail!(
            "--carb-ratio \"{}\": expected three numbers B,L,D, got {}",
            a.carb_ratio,
            cr.len()
        );
    };
    let mut start = TherapySettings::new(UnitsPerHour(a.basal), GramsPerUnit(b))
        .with_context(|| format!("--basal {} / --carb-ratio", a.basal))?;
    start.carb_ratio = [GramsPerUnit(b), GramsPerUnit(l), GramsPerUnit(d)];
    let mode = match a.mode {
        ModeArg::Cgm => Mode::Cgm,
        ModeArg::Smbg => Mode::Smbg,
    };
    let mut p = NewPerson::new(&a.name, &a.tz, mode, start);
    if let Some(w) = &a.meal_windows {
        let parts: Vec<&str> = w.split(',').collect();
        let [b, l, d] = parts[..] else {
            bail!("--meal-windows \"{w}\": expected three windows HH:MM-HH:MM separated by commas");
        };
        p.settings.meal_windows = MealWindows {
            breakfast: MealWindows::parse_window(b)?,
            lunch: MealWindows::parse_window(l)?,
            dinner: MealWindows::parse_window(d)?,
        };
    }
    if let Some(r) = &a.basal_range {
        p.settings.bounds.basal = Some(range("--basal-range", r)?);
    }
    if let Some(r) = &a.carb_ratio_range {
        p.settings.bounds.carb_ratio = [Some(range("--carb-ratio-range", r)?); 3];
    }
    if let Some(d) = &a.first_day {
        p.first_day = Some(
            d.parse()
                .with_context(|| format!("--first-day \"{d}\": expected YYYY-MM-DD"))?,
        );
    }
    let bed = MealWindows::parse_window(&format!("{}-24:00", a.bedtime)).context("--bedtime")?;
    p.settings.bedtime_min = bed.0;
    let mut store = Store::open(&a.db).with_context(|| format!("opening {}", a.db.display()))?;
    let person = store.create_person(&p)?;
    println!(
        "Created {} in {} ({} mode, zone {}): basal {} U/h, carb ratios {b}/{l}/{d} g/U.",
        person.name,
        a.db.display(),
        match mode {
            Mode::Cgm => "CGM",
            Mode::Smbg => "SMBG",
        },
        a.tz,
        a.basal
    );
    println!("{NOTICE}");
    Ok(())
}

/// Runs `abba person`.
pub fn run(a: Args) -> Result<()> {
    match a.command {
        Command::New(n) => new(*n),
        Command::List { db } => {
            let store = Store::open(&db).with_context(|| format!("opening {}", db.display()))?;
            for n in store.persons()? {
                println!("{n}");
            }
            Ok(())
        }
    }
}
