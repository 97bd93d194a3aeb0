//! `abba simulate`: open-loop replay of one patient with per-minute inputs.

use crate::output::{distinct_paths, write_atomically};
use abba_sim::cohort::read_csv;
use abba_sim::inputs::{hard_days, InputDay};
use abba_sim::patient::{Patient, PatientParams, PatientState, QuestRow};
use abba_sim::SimError;
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Arguments of `abba simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Patient name: a built-in one (adolescent#001..#010, adult#001..#010,
    /// child#001..#010), or a member of the table given with --cohort.
    #[arg(long)]
    pub patient: String,
    /// A cohort table written by `abba cohort --out` to take the patient
    /// from (for generated members such as adult#011).
    #[arg(long)]
    pub cohort: Option<PathBuf>,
    /// CSV with header `minute,cho_g_per_min,insulin_u_per_min` (other columns are
    /// ignored), one row per minute from 0: the carbohydrate eaten and insulin
    /// infused (basal + bolus) during that minute. A last row with both input
    /// cells empty (a final-glucose row) is allowed and carries no input.
    /// At most 5 g/min of carbohydrate and 30.5 U/min of insulin.
    #[arg(long, conflicts_with = "day")]
    pub inputs: Option<PathBuf>,
    /// A built-in input day instead of a file: standard, overlapping-meals,
    /// missed-boluses, insulin-suspension or long-fast (boluses use the
    /// patient's carb ratio: Quest's, or the cohort table's).
    #[arg(long)]
    pub day: Option<String>,
    /// Output CSV: `minute,bg_mg_dl,gs_mg_dl` (plasma and subcutaneous glucose
    /// at each minute, before that minute's inputs), rows 0..N. Written to a
    /// temporary file beside it and renamed, so a failed run leaves no
    /// partial file.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the 13 model states and Dbar on every row.
    #[arg(long)]
    pub states: bool,
    /// Also write the per-minute inputs that were replayed (the format of
    /// --inputs), e.g. to feed the same day to another simulator.
    #[arg(long)]
    pub inputs_out: Option<PathBuf>,
    /// Constant insulin-sensitivity multiplier on Vmx and kp3 (> 0).
    #[arg(long, default_value_t = 1.0)]
    pub sensitivity: f64,
}

/// Runs `abba simulate`.
pub fn run(args: Args) -> Result<()> {
    if !(args.sensitivity.is_finite() && args.sensitivity > 0.0) {
        bail!(
            "--sensitivity must be a finite number > 0 (a multiplier: 1 is nominal, 0.5 half as sensitive), got {}",
            args.sensitivity
        );
    }
    let mut files: Vec<(&str, &Path)> = vec![("--out", &args.out)];
    if let Some(p) = &args.inputs_out {
        files.push(("--inputs-out", p));
    }
    if let Some(p) = &args.inputs {
        files.push(("--inputs", p));
    }
    distinct_paths(&files)?;
    let (params, cr) = patient(&args)?;
    let day = match (&args.inputs, &args.day) {
        (Some(path), None) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot open input file {}", path.display()))?;
            InputDay::from_csv(&path.display().to_string(), &text)?
        }
        (None, Some(name)) => hard_days::build(name, &params, cr).ok_or_else(|| {
            anyhow!(
                "unknown built-in day '{name}' (known: {})",
                hard_days::NAMES.join(", ")
            )
        })?,
        _ => bail!("give either --inputs FILE or --day NAME"),
    };
    day.validate()?;
    let mut patient = Patient::new(params)?;
    write_atomically(&args.out, |w| {
        let mut header = String::from("minute,bg_mg_dl,gs_mg_dl");
        if args.states {
            for name in PatientState::NAMES {
                header.push(',');
                header.push_str(name);
            }
            header.push_str(",dbar_mg");
        }
        writeln!(w, "{header}")?;
        write_row(w, &patient, args.states)?;
        for r in &day.minutes {
            patient.step(r.cho_g_per_min, r.insulin_u_per_min, args.sensitivity)?;
            let g = patient.glucose_mg_dl();
            if g < 0.0 {
                bail!(
                    "{}, minute {}: plasma glucose fell to {} mg/dL, below 0: the inputs overdose \
                     this patient beyond the model's physical range, so no result is written",
                    args.patient,
                    patient.minute(),
                    if g > -1e6 {
                        format!("{g:.2}")
                    } else {
                        format!("{g:.3e}")
                    }
                );
            }
            write_row(w, &patient, args.states)?;
        }
        Ok(())
    })?;
    if let Some(path) = &args.inputs_out {
        write_atomically(path, |w| Ok(w.write_all(day.to_csv().as_bytes())?))?;
    }
    Ok(())
}

/// The patient's parameters and carb ratio (g/U): from the cohort table
/// given with --cohort, else from the built-in tables.
fn patient(args: &Args) -> Result<(PatientParams, f64)> {
    let name = &args.patient;
    if let Some(path) = &args.cohort {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read cohort table {shown}"))?;
        let rows = read_csv(&shown, &text)?;
        let names: Vec<&str> = rows.iter().map(|r| r.params.name.as_str()).collect();
        let row = rows.iter().find(|r| &r.params.name == name).ok_or_else(|| {
            anyhow!(
                "patient '{name}' is not in the cohort table {shown} (it holds {} patients, {} to {})",
                names.len(),
                names.first().unwrap_or(&"-"),
                names.last().unwrap_or(&"-"),
            )
        })?;
        return Ok((row.params.clone(), row.therapy.carb_ratio[0].0));
    }
    match PatientParams::public(name) {
        Ok(params) => {
            let cr = QuestRow::for_patient(&params.name)?.cr;
            Ok((params, cr))
        }
        Err(e @ SimError::UnknownPatient { .. }) => Err(anyhow!(
            "{e}; a generated cohort member (such as adult#011) is read from a cohort table: \
             write one with `abba cohort --size N --out cohort.csv`, then add `--cohort cohort.csv`"
        )),
        Err(e) => Err(e.into()),
    }
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
