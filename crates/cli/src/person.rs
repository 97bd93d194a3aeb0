//! `abba person new|list`: the persons of a store file.
use std::path::PathBuf;

use abba_advisor::bounds::Range;
use abba_advisor::{AgeGroup, Mode, PumpSteps};
use abba_core::units::GlucoseUnit;
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_io::meals::MealWindows;
use abba_store::person::TherapySource;
use abba_store::{NewPerson, NOTICE};
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
        /// The store: a file, or a postgres:// URL.
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

/// Age group (its defaults of the advisor's knobs).
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum AgeGroupArg {
    Adult,
    Adolescent,
    Child,
}

#[derive(clap::Args, Debug)]
struct NewArgs {
    /// The store: a file, or a postgres:// URL.
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
    /// The person's age group: it chooses the advisor's defaults calibrated
    /// for it in the trial (the hours the basal rate learns from: adults
    /// the whole day in CGM mode and the night's bedtime and fasting
    /// readings, 22:30-07:30, in SMBG mode; adolescents 00:00-07:00 and
    /// children 02:00-07:00 in CGM mode, both the fasting reading,
    /// 00:00-07:30, in SMBG mode).
    #[arg(long, value_enum, default_value = "adult")]
    age_group: AgeGroupArg,
    /// The therapy in force from the pump's export: a Nightscout profile
    /// store (profile.json) or Profile Switch, Tidepool pumpSettings (its
    /// JSON, or the Basal Schedules and Carb Ratios sheets of its Excel
    /// export), or a
    /// CareLink CSV (its last full day's basal rates, the bolus wizard's
    /// carb ratios): the latest settings of the files.
    #[arg(long, value_name = "FILE", num_args = 1.., conflicts_with_all = ["basal"])]
    therapy_from: Vec<PathBuf>,
    /// With --therapy-from a CareLink export whose bolus wizard counts in exchanges (`BWZ Carb Ratio (U/Ex)`): grams of carbohydrate in one exchange (10 for the Spanish ración), to read its carb ratios as g/U.
    #[arg(long, value_name = "G", requires = "therapy_from")]
    grams_per_exchange: Option<f64>,
    /// With --therapy-from an export whose dates do not tell their order (CareLink, LibreView: no day above 12): day-first or month-first.
    #[arg(long, value_name = "ORDER", requires = "therapy_from")]
    date_order: Option<String>,
    /// Current flat basal rate (U/h), when not --therapy-from.
    #[arg(long, value_name = "U_PER_H", required_unless_present = "therapy_from")]
    basal: Option<f64>,
    /// Current carb ratios of breakfast, lunch, dinner (g/U): B,L,D; with
    /// --therapy-from they replace the export's carb ratios (for a CareLink
    /// export without a wizard event in some meal window).
    #[arg(long, value_name = "B,L,D", required_unless_present = "therapy_from")]
    carb_ratio: Option<String>,
    /// The pump's basal step (U/h): suggestions are rounded to it.
    #[arg(long, value_name = "U_PER_H", default_value_t = 0.05)]
    basal_step: f64,
    /// The pump's carb-ratio step (g/U): 0.1 or 1.
    #[arg(long, value_name = "G_PER_U", default_value_t = 0.1)]
    carb_ratio_step: f64,
    /// Research only: suggest basal rates even when the data show a closed
    /// loop or injections (ABBA was validated for open-loop pump therapy).
    #[arg(long)]
    allow_closed_loop: bool,
    /// The glucose unit of the person's texts: mg/dL or mmol/L.
    #[arg(long, value_name = "UNIT", default_value = "mg/dL")]
    units: String,
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

/// Parses `B,L,D` carb ratios.
pub fn carb_ratios(flag: &str, text: &str) -> Result<[f64; 3]> {
    let cr: Vec<f64> = text
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{flag} \"{text}\": expected three numbers B,L,D"))?;
    let [b, l, d] = cr[..] else {
        bail!(
            "{flag} \"{text}\": expected three numbers B,L,D, got {}",
            cr.len()
        );
    };
    Ok([b, l, d])
}

fn new(a: NewArgs) -> Result<()> {
    let mode = match a.mode {
        ModeArg::Cgm => Mode::Cgm,
        ModeArg::Smbg => Mode::Smbg,
    };
    let mut meal_windows = MealWindows::default();
    if let Some(w) = &a.meal_windows {
        let parts: Vec<&str> = w.split(',').collect();
        let [b, l, d] = parts[..] else {
            bail!("--meal-windows \"{w}\": expected three windows HH:MM-HH:MM separated by commas");
        };
        meal_windows = MealWindows {
            breakfast: MealWindows::parse_window(b)?,
            lunch: MealWindows::parse_window(l)?,
            dinner: MealWindows::parse_window(d)?,
        };
    }
    let (start, schedule, from) = match (&a.basal, &a.carb_ratio) {
        (Some(basal), Some(cr)) if a.therapy_from.is_empty() => {
            let [b, l, d] = carb_ratios("--carb-ratio", cr)?;
            let start = TherapySettings {
                basal: UnitsPerHour(*basal),
                carb_ratio: [GramsPerUnit(b), GramsPerUnit(l), GramsPerUnit(d)],
            };
            (start, None, None)
        }
        _ => {
            let tz = jiff::tz::TimeZone::get(&a.tz)
                .with_context(|| format!("--tz \"{}\": not a known IANA zone", a.tz))?;
            let dates = crate::input::DateFlags {
                date_order: a.date_order.clone(),
                grams_per_exchange: a.grams_per_exchange,
            };
            let opts = abba_io::ReadOptions {
                tz: Some(tz),
                ..dates.options()?
            };
            let given = a
                .carb_ratio
                .as_deref()
                .map(|c| carb_ratios("--carb-ratio", c))
                .transpose()?;
            let t = abba_io::therapy::therapy_from_files_with(
                &a.therapy_from,
                &opts,
                &meal_windows,
                given,
            )
            .context("--therapy-from")?;
            let schedule = (t.basal.len() > 1).then(|| t.basal.clone());
            (t.settings(), schedule, Some(t))
        }
    };
    let mut p = NewPerson::new(&a.name, &a.tz, mode, start);
    p.settings.set_age_group(match a.age_group {
        AgeGroupArg::Adult => AgeGroup::Adult,
        AgeGroupArg::Adolescent => AgeGroup::Adolescent,
        AgeGroupArg::Child => AgeGroup::Child,
    });
    p.settings.meal_windows = meal_windows;
    p.settings.basal_schedule = schedule;
    if let Some(t) = &from {
        p.settings.therapy_source = TherapySource::Profile;
        p.settings.therapy_notes.clone_from(&t.notes);
    }
    p.settings.pump_steps = Some(PumpSteps {
        basal_u_per_h: a.basal_step,
        carb_ratio_g_per_u: a.carb_ratio_step,
    });
    p.settings.allow_closed_loop = a.allow_closed_loop;
    p.settings.units = match GlucoseUnit::parse(&a.units) {
        Some(u) => u,
        None => bail!("--units \"{}\": expected mg/dL or mmol/L", a.units),
    };
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
    let mut store = crate::store_args::open(&a.db)?;
    let person = store.create_person(&p)?;
    let [b, l, d] = start.carb_ratio.map(|c| c.0);
    let therapy = match &from {
        Some(t) => format!(
            "{} (from {}, {})",
            t.describe(),
            t.origin,
            since_words(t.at, &a.tz)
        ),
        None => format!("basal {} U/h, carb ratios {b}/{l}/{d} g/U", start.basal.0),
    };
    let group = person.settings.age_group;
    let hours = match person.settings.advisor.features.basal_window_for(mode) {
        Some([from, to]) => format!(
            "the basal rate learns from {} to {}",
            abba_advisor::words::window_clock(from),
            abba_advisor::words::window_clock(to)
        ),
        None => "the basal rate learns from the whole day".into(),
    };
    println!(
        "Created {} in {} ({} mode, zone {}, age group {}: {hours}): {therapy}; pump steps {} U/h and {} g/U.",
        person.name,
        a.db.display(),
        match mode {
            Mode::Cgm => "CGM",
            Mode::Smbg => "SMBG",
        },
        a.tz,
        group.name(),
        a.basal_step,
        a.carb_ratio_step
    );
    for n in from.iter().flat_map(|t| &t.notes) {
        println!("Note: {n}.");
    }
    if a.allow_closed_loop {
        println!("--allow-closed-loop: basal rates will be suggested even if the data show a closed loop or injections (research only; ABBA was validated for open-loop pump therapy).");
    }
    println!("{NOTICE}");
    Ok(())
}

/// Runs `abba person`.
pub fn run(a: Args) -> Result<()> {
    match a.command {
        Command::New(n) => new(*n),
        Command::List { db } => {
            let store = crate::store_args::open(&db)?;
            for n in store.persons()? {
                println!("{n}");
            }
            // The names alone on stdout (for scripts); the notice beside them.
            eprintln!("{}", abba_advisor::words::NOTICE);
            Ok(())
        }
    }
}

/// When a therapy read from an export took effect, in the person's zone
/// (the person's own clock, as every date abba prints for them).
fn since_words(at: jiff::Timestamp, tz: &str) -> String {
    if at == abba_io::record::SINCE_ALWAYS {
        return "undated: in force since always".into();
    }
    match jiff::tz::TimeZone::get(tz) {
        Ok(z) => format!(
            "in force since {}",
            at.to_zoned(z).strftime("%Y-%m-%d %H:%M %Z")
        ),
        Err(_) => format!("in force since {at}"),
    }
}
