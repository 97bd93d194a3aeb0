//! Options shared by `abba metrics`, `abba events` and `abba import`:
//! which files, how to read them. Parsing only; reading is abba-io's.
use std::path::PathBuf;

use abba_io::time::DateOrder;
use abba_io::{Format, GlucoseUnit, ReadOptions};
use anyhow::{anyhow, bail, Result};

/// How to read the input files.
#[derive(clap::Args, Debug)]
pub struct InputArgs {
    /// Export files (Nightscout JSON, Dexcom Clarity CSV, LibreView CSV, Tidepool JSON or Excel (.xlsx), Medtronic CareLink CSV, plain CSV).
    #[arg(long, value_name = "FILE", num_args = 1.., required = true)]
    pub input: Vec<PathBuf>,
    /// The person's IANA time zone (how times without an offset are read, how days are grouped).
    #[arg(long, value_name = "ZONE")]
    pub tz: Option<String>,
    #[command(flatten)]
    pub read: ReadFlags,
}

impl InputArgs {
    /// The reader options these arguments ask for.
    pub fn options(&self) -> Result<ReadOptions> {
        Ok(ReadOptions {
            tz: match &self.tz {
                Some(z) => Some(abba_io::time::zone(z)?),
                None => None,
            },
            ..self.read.options()?
        })
    }
}

/// What a file does not say about itself, given by the person: the
/// flags the readers' errors name (`abba import`, `abba events`, `abba
/// metrics`). The zone is the person's (or `--tz`), never one of these.
#[derive(clap::Args, Debug, Default)]
pub struct ReadFlags {
    /// Format of every input: nightscout, clarity, libreview, tidepool (JSON or its Excel export), tidepool-xlsx, carelink, csv [default: detected from content].
    #[arg(long, value_name = "FORMAT")]
    pub format: Option<String>,
    /// Glucose unit of values that do not say theirs (plain CSV, a Nightscout BG Check without `units`): mg/dL or mmol/L; checked against files that do say.
    #[arg(long, value_name = "UNIT")]
    pub units: Option<String>,
    /// Plain CSV: name of the time column.
    #[arg(long, value_name = "NAME")]
    pub time_column: Option<String>,
    /// Plain CSV: name of the glucose column.
    #[arg(long, value_name = "NAME")]
    pub glucose_column: Option<String>,
    /// Plain CSV: use only the rows whose `id` column equals ID.
    #[arg(long, value_name = "ID")]
    pub subject: Option<String>,
    #[command(flatten)]
    pub dates: DateFlags,
}

/// How dates are read where the file does not tell, and CareLink's exchanges
/// (also for `abba person new --therapy-from`).
#[derive(clap::Args, Debug, Default)]
pub struct DateFlags {
    /// Dates that do not tell their order (LibreView, CareLink, plain CSV: no day above 12; AM/PM does not tell): day-first or month-first.
    #[arg(long, value_name = "ORDER")]
    pub date_order: Option<String>,
    /// CareLink: grams of carbohydrate in one exchange, for a pump whose bolus wizard counts in exchanges (10 for the Spanish ración; 12 and 15 are used elsewhere). Without it such carbohydrate is not read.
    #[arg(long, value_name = "G")]
    pub grams_per_exchange: Option<f64>,
}

impl ReadFlags {
    /// The reader options these flags ask for (no zone).
    pub fn options(&self) -> Result<ReadOptions> {
        Ok(ReadOptions {
            format: match &self.format {
                Some(f) => Some(Format::parse(f).ok_or_else(|| {
                    anyhow!(
                        "--format {f}: expected nightscout, clarity, libreview, tidepool, tidepool-xlsx, carelink or csv"
                    )
                })?),
                None => None,
            },
            units: match &self.units {
                Some(u) => Some(
                    GlucoseUnit::parse(u)
                        .ok_or_else(|| anyhow!("--units {u}: expected mg/dL or mmol/L"))?,
                ),
                None => None,
            },
            time_column: self.time_column.clone(),
            glucose_column: self.glucose_column.clone(),
            subject: self.subject.clone(),
            ..self.dates.options()?
        })
    }
}

impl DateFlags {
    /// The reader options these flags ask for (the rest default).
    pub fn options(&self) -> Result<ReadOptions> {
        Ok(ReadOptions {
            date_order: match self.date_order.as_deref() {
                None => None,
                Some("day-first") => Some(DateOrder::DayFirst),
                Some("month-first") => Some(DateOrder::MonthFirst),
                Some(o) => bail!("--date-order {o}: expected day-first or month-first"),
            },
            grams_per_exchange: grams_per_exchange(self.grams_per_exchange)?,
            ..ReadOptions::default()
        })
    }
}

/// Checks `--grams-per-exchange` ([`abba_io::read::check_grams_per_exchange`]).
pub fn grams_per_exchange(g: Option<f64>) -> Result<Option<f64>> {
    g.map(|g| {
        abba_io::read::check_grams_per_exchange(g)
            .map_err(|e| anyhow!("--grams-per-exchange {g}: {e}"))
    })
    .transpose()
}

/// Parses `YYYY-MM-DD`.
pub fn date(flag: &str, text: &str) -> Result<jiff::civil::Date> {
    text.parse()
        .map_err(|e| anyhow!("{flag} {text}: expected a date like 2024-03-31 ({e})"))
}
