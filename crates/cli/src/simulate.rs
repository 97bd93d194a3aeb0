//! `abba simulate`: open-loop replay of one patient with per-minute inputs.

use abba_sim::inputs::{hard_days, InputDay, MinuteRates};
use abba_sim::patient::{Patient, PatientParams, PatientState, QuestRow};
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `abba simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Patient name from the built-in tables (adult#001..#010, adolescent#..., child#...).
    #[arg(long)]
    pub patient: String,
    /// CSV with header `minute,cho_g_per_min,insulin_u_per_min` (other columns are
    /// ignored), one row per minute from 0: the carbohydrate eaten and insulin
    /// infused (basal + bolus) during that minute. A last row with both input
    /// cells empty (a final-glucose row) is allowed and carries no input.
    #[arg(long, conflicts_with = "day")]
    pub inputs: Option<PathBuf>,
    /// A built-in input day instead of a file: standard, overlapping-meals,
    /// missed-boluses, insulin-suspension or long-fast (boluses use the
    /// patient's Quest carb ratio).
    #[arg(long)]
    pub day: Option<String>,
    /// Output CSV: `minute,bg_mg_dl,gs_mg_dl` (plasma and subcutaneous glucose
    /// at each minute, before that minute's inputs), rows 0..N.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the 13 model states and Dbar on every row.
    #[arg(long)]
    pub states: bool,
    /// Also write the per-minute inputs that were replayed (the format of
    /// --inputs), e.g. to feed the same day to another simulator.
    #[arg(long)]
    pub inputs_out: Option<PathBuf>,
    /// Constant insulin-sensitivity multiplier on Vmx and kp3.
    #[arg(long, default_value_t = 1.0)]
    pub sensitivity: f64,
}

/// Runs `abba simulate`.
pub fn run(args: Args) -> Result<()> {
    let params = PatientParams::public(&args.patient)?;
    let day = match (&args.inputs, &args.day) {
        (Some(path), None) => read_inputs(path)?,
        (None, Some(name)) => {
            let cr = QuestRow::for_patient(&params.name)?.cr;
            hard_days::build(name, &params, cr).ok_or_else(|| {
                anyhow!(
                    "unknown built-in day '{name}' (known: {})",
                    hard_days::NAMES.join(", ")
                )
            })?
        }
        _ => bail!("give either --inputs FILE or --day NAME"),
    };
    if !(args.sensitivity.is_finite() && args.sensitivity > 0.0) {
        bail!(
            "--sensitivity must be a finite number > 0, got {}",
            args.sensitivity
        );
    }
    if let Some(path) = &args.inputs_out {
        let mut text = String::from("minute,cho_g_per_min,insulin_u_per_min\n");
        for (m, r) in day.minutes.iter().enumerate() {
            text.push_str(&format!(
                "{m},{},{}\n",
                r.cho_g_per_min, r.insulin_u_per_min
            ));
        }
        std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let mut patient = Patient::new(params)?;
    let file = std::fs::File::create(&args.out)
        .with_context(|| format!("cannot create output file {}", args.out.display()))?;
    let mut w = std::io::BufWriter::new(file);
    let mut header = String::from("minute,bg_mg_dl,gs_mg_dl");
    if args.states {
        for name in PatientState::NAMES {
            header.push(',');
            header.push_str(name);
        }
        header.push_str(",dbar_mg");
    }
    writeln!(w, "{header}")?;
    write_row(&mut w, &patient, args.states)?;
    for r in &day.minutes {
        patient.step(r.cho_g_per_min, r.insulin_u_per_min, args.sensitivity)?;
        write_row(&mut w, &patient, args.states)?;
    }
    w.flush()
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    Ok(())
}

fn write_row(w: &mut impl Write, p: &Patient, states: bool) -> Result<()> {
    write!(
        w,
        "{},{},{}",
        p.minute(),
        p.glucose_mg_dl(),
        p.subcutaneous_glucose_mg_dl()
    )?;
    if states {
        for v in p.state_array() {
            write!(w, ",{v}")?;
        }
        write!(w, ",{}", p.dbar_mg())?;
    }
    writeln!(w)?;
    Ok(())
}

/// Reads an input file, checking every row; errors name the file, line and column.
pub fn read_inputs(path: &Path) -> Result<InputDay> {
    let shown = path.display();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(path)
        .with_context(|| format!("cannot open input file {shown}"))?;
    let header = rdr
        .headers()
        .with_context(|| format!("{shown}: cannot read the header"))?
        .clone();
    let col = |name: &str| {
        header.iter().position(|h| h == name).ok_or_else(|| {
            anyhow!(
                "{shown}: missing column '{name}' (expected minute,cho_g_per_min,insulin_u_per_min; found {})",
                header.iter().collect::<Vec<_>>().join(",")
            )
        })
    };
    let (c_min, c_cho, c_ins) = (
        col("minute")?,
        col("cho_g_per_min")?,
        col("insulin_u_per_min")?,
    );
    let mut minutes = Vec::new();
    // A last row whose two input cells are both empty only carries the final
    // glucose (the layout of the simglucose reference files); anywhere else
    // an empty cell is an error.
    let mut final_row: Option<usize> = None;
    for (k, rec) in rdr.records().enumerate() {
        let line = k + 2;
        let rec = rec.with_context(|| format!("{shown}, line {line}: malformed CSV row"))?;
        let field = |c: usize, name: &str| -> Result<&str> {
            rec.get(c)
                .ok_or_else(|| anyhow!("{shown}, line {line}: no value for column '{name}'"))
        };
        if let Some(at) = final_row {
            bail!(
                "{shown}, line {at}: empty cho_g_per_min and insulin_u_per_min are only allowed on the last row (the final-glucose row), but line {line} follows"
            );
        }
        let minute_s = field(c_min, "minute")?;
        let minute: usize = minute_s.parse().map_err(|_| {
            anyhow!(
                "{shown}, line {line}, column 'minute': expected a whole number, got '{minute_s}'"
            )
        })?;
        if minute != minutes.len() {
            bail!(
                "{shown}, line {line}, column 'minute': expected minute {} (rows must be consecutive from 0), got {minute}",
                minutes.len()
            );
        }
        if field(c_cho, "cho_g_per_min")?.is_empty()
            && field(c_ins, "insulin_u_per_min")?.is_empty()
        {
            final_row = Some(line);
            continue;
        }
        let rate = |c: usize, name: &str, unit: &str| -> Result<f64> {
            let s = field(c, name)?;
            let v: f64 = s.parse().map_err(|_| {
                anyhow!(
                    "{shown}, line {line}, column '{name}': expected a number ({unit}), got '{s}'"
                )
            })?;
            if !v.is_finite() || v < 0.0 {
                bail!("{shown}, line {line}, column '{name}': expected a finite rate >= 0 {unit}, got {s}");
            }
            Ok(v)
        };
        minutes.push(MinuteRates {
            cho_g_per_min: rate(c_cho, "cho_g_per_min", "g/min")?,
            insulin_u_per_min: rate(c_ins, "insulin_u_per_min", "U/min")?,
        });
    }
    if minutes.is_empty() {
        bail!("{shown}: no input rows after the header");
    }
    Ok(InputDay { minutes })
}
