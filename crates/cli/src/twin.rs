//! `abba twin fit` and `abba twin replay`: a person's twin from the store's
//! records (abba-twin), kept beside the store file.
use std::path::PathBuf;

use abba_core::units::GlucoseUnit;
use abba_sim::cohort::Population;
use abba_twin::file::Refit;
use abba_twin::{Banded, BasalChange, Ranges, Twin, TwinOptions, WhatIf, NOTICE};
use anyhow::{anyhow, Result};

/// A line of the what-if table: its name and the figure it reads.
type Row = (String, fn(&Ranges) -> f64);

/// Arguments of `abba twin`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Fit (or refit on new data) the person's twin and check it on held-out days.
    Fit(FitArgs),
    /// Re-simulate the last days under another basal or other carb ratios.
    Replay(ReplayArgs),
}

/// Where and whose.
#[derive(clap::Args, Debug)]
struct Who {
    /// The store file (the twin is kept in FILE.twins/; not yet for a postgres:// store).
    #[arg(long, value_name = "FILE")]
    db: PathBuf,
    /// The person.
    #[arg(long, value_name = "NAME")]
    person: String,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
struct FitArgs {
    #[command(flatten)]
    who: Who,
    /// Days of the window (the last days of the log).
    #[arg(long, default_value_t = 14)]
    days: usize,
    /// Days at the end of the window never fitted, only predicted.
    #[arg(long, default_value_t = 2)]
    held_out: usize,
    /// The person's population (the prior): adults, adolescents or children.
    #[arg(long, default_value = "adults")]
    population: String,
    /// Refit even when the log has not changed since the stored twin.
    #[arg(long)]
    force: bool,
}

#[derive(clap::Args, Debug)]
struct ReplayArgs {
    #[command(flatten)]
    who: Who,
    /// The last N days of the twin's window to replay.
    #[arg(long, default_value_t = 7)]
    days: usize,
    /// A flat scheduled basal rate (U/h).
    #[arg(long, conflicts_with = "basal_factor")]
    basal: Option<f64>,
    /// Every basal rate times F.
    #[arg(long, value_name = "F")]
    basal_factor: Option<f64>,
    /// Carb ratios of breakfast, lunch and dinner (g/U), as B,L,D.
    #[arg(long, value_name = "B,L,D", conflicts_with = "carb_ratio_factor")]
    carb_ratio: Option<String>,
    /// Every carb ratio times F.
    #[arg(long, value_name = "F")]
    carb_ratio_factor: Option<f64>,
}

/// Runs `abba twin`.
pub fn run(a: Args) -> Result<()> {
    match a.command {
        Command::Fit(f) => fit(f),
        Command::Replay(r) => replay(r),
    }
}

/// The person's events, the basal rate in force at the start and the
/// unit they read glucose in.
fn events(who: &Who) -> Result<(Vec<abba_core::Event>, f64, GlucoseUnit)> {
    let (events, basal, units, _) = events_dated(who)?;
    Ok((events, basal, units))
}

/// [`events`] and the person's day 1 (the date of day index 0).
fn events_dated(
    who: &Who,
) -> Result<(
    Vec<abba_core::Event>,
    f64,
    GlucoseUnit,
    Option<jiff::civil::Date>,
)> {
    let store = crate::store_args::open(&who.db)?;
    let person = store.person(&who.person)?;
    Ok((
        store.events(&who.person)?,
        person.settings.start.basal.0,
        person.settings.units,
        person.first_day,
    ))
}

fn fit(a: FitArgs) -> Result<()> {
    let population: Population = a
        .population
        .parse()
        .map_err(|e| anyhow!("--population: {e}"))?;
    let db = crate::twin_effect::twins_beside(&a.who.db).map_err(|e| anyhow!(e))?;
    let (events, basal, units, first_day) = events_dated(&a.who)?;
    let options = TwinOptions {
        days: a.days,
        held_out_days: a.held_out,
        population,
        basal_in_force_u_per_h: basal,
        units,
        ..TwinOptions::default()
    };
    let twin = match abba_twin::file::refit(db, &a.who.person, &events, &options, a.force)? {
        Refit::Unchanged(t) => {
            eprintln!(
                "the log has not changed since twin revision {}: shown as stored (--force refits)",
                t.revision
            );
            t
        }
        Refit::Stored { twin, path } => {
            eprintln!(
                "stored twin revision {} in {}",
                twin.revision,
                path.display()
            );
            twin
        }
    };
    if a.who.json {
        println!("{}", serde_json::to_string_pretty(&twin)?);
    } else {
        print!("{}", fit_text(&twin, units, first_day));
    }
    Ok(())
}

/// The date of a day index (0 = day 1), or "day N" without day 1.
fn day_words(first_day: Option<jiff::civil::Date>, index: i64) -> String {
    first_day
        .and_then(|d| d.checked_add(jiff::Span::new().days(index)).ok())
        .map_or_else(|| format!("day {}", index + 1), |d| d.to_string())
}

/// A fitted parameter's value and prior in words, with its unit: the
/// basal glucose in the person's unit, the others as the model has them.
fn estimate_line(e: &abba_twin::twin::Estimate, units: GlucoseUnit) -> String {
    let (value, prior, unit) = match e.name.as_str() {
        "basal_glucose" => (
            units.from_mg_dl(e.value),
            units.from_mg_dl(e.prior_value),
            units.label().to_string(),
        ),
        "basal_need" => (e.value, e.prior_value, "U/h".to_string()),
        "absorption" => (e.value, e.prior_value, "/min".to_string()),
        _ => (e.value, e.prior_value, "×".to_string()),
    };
    format!(
        "  {:<22} {:>9.4} {unit:<6} (prior {prior:.4}, SD {:.3})\n",
        e.name, value, e.posterior_log_sd
    )
}

/// The fitted twin in words, glucose in the person's `units`, days as
/// dates when day 1 is known.
fn fit_text(t: &Twin, units: GlucoseUnit, first_day: Option<jiff::civil::Date>) -> String {
    let unit = units.label();
    let spread = |mg_dl: f64| abba_twin::check::spread(units, mg_dl);
    let (low, high) = (units.value(70.0), units.value(180.0));
    let mut s = format!(
        "Twin of {} (revision {}, prior: {}): {}\n{NOTICE}\n\n",
        t.person,
        t.revision,
        t.prior.population,
        t.grade.name()
    );
    s += &format!("Grade: {} ({})\n", t.grade.name(), t.grade_reason);
    s += &format!(
        "Window: {} days from {} (day {}), {} fitted, {} held out; {} readings\n",
        t.data.days,
        day_words(first_day, t.data.start_minute.div_euclid(1440)),
        t.data.start_minute.div_euclid(1440) + 1,
        t.data.fit_days,
        t.data.held_out_days,
        t.data.readings
    );
    if let Some(h) = &t.held_out {
        s += &format!(
            "Held-out days: RMSE {} {unit} (their own mean glucose: {}), MARD {:.1} %\n",
            spread(h.rmse_mg_dl),
            spread(h.mean_glucose_rmse_mg_dl),
            h.mard_pct
        );
        s += &format!(
            "  time in {low}-{high}: observed {:.1} %, predicted {}\n  time below {low}:  observed {:.1} %, predicted {}\n",
            h.observed.tir_pct,
            band(&h.predicted, |r| r.tir_pct),
            h.observed.below_70_pct,
            band(&h.predicted, |r| r.below_70_pct),
        );
    } else if let Some(e) = &t.held_out_error {
        s += &format!("Held-out days: no check ({e})\n");
    }
    s += &format!(
        "Fit: RMSE {} {unit}, MARD {:.1} % over {} readings; {} simulations of the window, {} short runs\n",
        spread(t.fit.rmse_mg_dl),
        t.fit.mard_pct,
        t.fit.readings,
        t.fit.simulations,
        t.fit.local_runs
    );
    s += "Parameters (fitted, unit, prior, posterior SD of the log; × a multiplier):\n";
    for e in &t.estimates {
        s += &estimate_line(e, units);
    }
    let meals: Vec<String> = t
        .found_meals
        .iter()
        .map(|m| {
            format!(
                "{} {:02}:{:02} {:.0} g",
                day_words(first_day, m.minute.div_euclid(1440)),
                m.minute.rem_euclid(1440) / 60,
                m.minute.rem_euclid(60),
                m.grams
            )
        })
        .collect();
    s += &match meals.len() {
        0 => "Unlogged meals found: none\n".to_string(),
        n => format!("Unlogged meals found: {n}: {}\n", meals.join("; ")),
    };
    s += &format!(
        "Days not explained (left out): {}\n",
        if t.unexplained_days.is_empty() {
            "none".to_string()
        } else {
            t.unexplained_days
                .iter()
                .map(|d| {
                    format!(
                        "{} (RMSE {} {unit})",
                        day_words(first_day, d.day_index),
                        units.value(d.rmse_mg_dl)
                    )
                })
                .collect::<Vec<_>>()
                .join(", ")
        }
    );
    s
}

fn band(b: &Banded, f: fn(&Ranges) -> f64) -> String {
    format!("{:.1} ({:.1} to {:.1})", f(&b.value), f(&b.low), f(&b.high))
}

fn replay(a: ReplayArgs) -> Result<()> {
    let basal = match (a.basal, a.basal_factor) {
        (Some(x), _) => BasalChange::Rate(x),
        (None, Some(f)) => BasalChange::Factor(f),
        (None, None) => BasalChange::Keep,
    };
    let carb_ratio = match &a.carb_ratio {
        None => None,
        Some(text) => {
            let v: Vec<f64> = text
                .split(',')
                .map(|p| {
                    p.trim().parse::<f64>().map_err(|_| {
                        anyhow!(
                            "--carb-ratio {text}: '{p}' is not a number (expected B,L,D in g/U)"
                        )
                    })
                })
                .collect::<Result<_>>()?;
            let [b, l, d] = v[..] else {
                return Err(anyhow!(
                    "--carb-ratio {text}: expected three ratios B,L,D in g/U, got {}",
                    v.len()
                ));
            };
            Some([b, l, d])
        }
    };
    let what_if = WhatIf {
        basal,
        carb_ratio,
        carb_ratio_factor: a.carb_ratio_factor,
        carb_ratio_factors: None,
    };
    what_if.check()?;
    let db = crate::twin_effect::twins_beside(&a.who.db).map_err(|e| anyhow!(e))?;
    let (events, _, units) = events(&a.who)?;
    let twin = abba_twin::file::load(db, &a.who.person)?.ok_or_else(|| {
        anyhow!(
            "{} has no twin yet: run `abba twin fit --db {} --person {}` first",
            a.who.person,
            a.who.db.display(),
            a.who.person
        )
    })?;
    let r = twin.replay(&events, &what_if, a.days)?;
    if a.who.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
        return Ok(());
    }
    println!(
        "What-if on the last {} days for {} (twin revision {}, {}; {} posterior draws)\n{NOTICE}\n",
        r.days,
        twin.person,
        twin.revision,
        twin.grade.name(),
        r.draws
    );
    println!("Settings: {}", describe(&what_if, &r.used_carb_ratios));
    println!(
        "{:<16} {:>10} {:>26} {:>26} {:>26}",
        "", "recorded", "twin, recorded settings", "twin, what-if", "change"
    );
    let (low, high) = (units.value(70.0), units.value(180.0));
    let rows: [Row; 4] = [
        (format!("time {low}-{high} %"), |r| r.tir_pct),
        (format!("time < {low} %"), |r| r.below_70_pct),
        ("LBGI".into(), |r| r.lbgi),
        ("HBGI".into(), |r| r.hbgi),
    ];
    for (name, f) in rows {
        println!(
            "{:<16} {:>10} {:>26} {:>26} {:>26}",
            name,
            r.observed
                .as_ref()
                .map_or("-".into(), |o| format!("{:.1}", f(o))),
            band(&r.twin_recorded, f),
            band(&r.twin_what_if, f),
            band(&r.change, f)
        );
    }
    if r.failed_draws > 0 {
        println!(
            "({} draws had no steady state and were left out)",
            r.failed_draws
        );
    }
    Ok(())
}

fn describe(w: &WhatIf, used: &[Option<f64>; 3]) -> String {
    let basal = match w.basal {
        BasalChange::Keep => "basal as recorded".to_string(),
        BasalChange::Rate(x) => format!("basal {x} U/h"),
        BasalChange::Factor(f) => format!("basal x {f}"),
    };
    let fmt = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.1}"));
    let cr = match (w.carb_ratio, w.carb_ratio_factor) {
        (Some(c), _) => format!("carb ratios {}, {}, {} g/U", c[0], c[1], c[2]),
        (None, Some(f)) => format!("carb ratios x {f}"),
        (None, None) => "carb ratios as recorded".into(),
    };
    format!(
        "{basal}; {cr} (the boluses implied {}, {}, {} g/U)",
        fmt(used[0]),
        fmt(used[1]),
        fmt(used[2])
    )
}
