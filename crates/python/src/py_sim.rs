//! Patients, cohorts and open-loop / scenario runs.

use crate::value_error;
use abba_sim::cohort::{Cohort, CohortConfig, Population, VirtualPatient};
use abba_sim::patient::{Patient, PatientParams, PatientState};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(public_patients, m)?)?;
    m.add_function(wrap_pyfunction!(patient_params, m)?)?;
    m.add_function(wrap_pyfunction!(state_names, m)?)?;
    m.add_function(wrap_pyfunction!(cohort_json, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(run_scenario, m)?)?;
    Ok(())
}

/// A cohort member by name (`adult#001` .. `adult#010` are the public
/// patients; `adult#042` is the 42nd of the cohort with `cohort_seed`),
/// with its number in the cohort (1-based).
pub(crate) fn cohort_patient(name: &str, cohort_seed: u64) -> PyResult<(VirtualPatient, u64)> {
    let (pop, num) = name.split_once('#').ok_or_else(|| {
        value_error(format!(
            "patient '{name}': expected a name like adult#001, adolescent#010 or child#042"
        ))
    })?;
    let population: Population = pop.parse().map_err(value_error)?;
    let number: u32 =
        num.parse().ok().filter(|n| *n >= 1).ok_or_else(|| {
            value_error(format!("patient '{name}': '{num}' is not a number >= 1"))
        })?;
    let cohort = Cohort::generate(&CohortConfig::new(population, number, cohort_seed))
        .map_err(value_error)?;
    let vp = cohort
        .patients
        .into_iter()
        .nth(number as usize - 1)
        .ok_or_else(|| value_error(format!("patient '{name}' is not in the cohort")))?;
    Ok((vp, u64::from(number)))
}

/// Parameters of a patient: public by name, else a cohort member.
pub(crate) fn params_of(name: &str, cohort_seed: u64) -> PyResult<PatientParams> {
    match PatientParams::public(name) {
        Ok(p) => Ok(p),
        Err(_) => Ok(cohort_patient(name, cohort_seed)?.0.params),
    }
}

/// Names of the 30 public patients.
#[pyfunction]
fn public_patients() -> PyResult<Vec<String>> {
    Ok(PatientParams::all_public()
        .map_err(value_error)?
        .into_iter()
        .map(|p| p.name)
        .collect())
}

/// The state names x1..x13 (with units in the docs of `abba.STATE_UNITS`).
#[pyfunction]
fn state_names() -> Vec<&'static str> {
    PatientState::NAMES.to_vec()
}

/// Every parameter of a patient as (column, value), in the order of
/// simglucose's `vpatient_params.csv` (x0 states included).
#[pyfunction]
#[pyo3(signature = (name, cohort_seed = 1))]
fn patient_params(name: &str, cohort_seed: u64) -> PyResult<Vec<(String, f64)>> {
    let p = params_of(name, cohort_seed)?;
    let mut out: Vec<(String, f64)> = vec![("i".into(), f64::from(p.i))];
    for (k, v) in abba_sim::patient::params::X0_COLUMNS.iter().zip(p.x0) {
        out.push(((*k).to_string(), v));
    }
    for (k, v) in PatientParams::SCALAR_COLUMNS.iter().zip(p.scalars()) {
        out.push(((*k).to_string(), v));
    }
    Ok(out)
}

/// A cohort as JSON (patients with parameters and standard therapy).
#[pyfunction]
fn cohort_json(population: &str, size: u32, seed: u64) -> PyResult<String> {
    let population: Population = population.parse().map_err(value_error)?;
    let cohort =
        Cohort::generate(&CohortConfig::new(population, size, seed)).map_err(value_error)?;
    serde_json::to_string(&cohort).map_err(value_error)
}

/// Open-loop run: per-minute carbohydrate eaten (g/min) and insulin
/// (U/min), optional per-minute insulin sensitivity; returns plasma and
/// subcutaneous glucose (mg/dL) at minutes 0..=n.
#[pyfunction]
#[pyo3(signature = (patient, cho_g_per_min, insulin_u_per_min, sensitivity = None, cohort_seed = 1))]
#[allow(clippy::type_complexity)]
fn simulate<'py>(
    py: Python<'py>,
    patient: &str,
    cho_g_per_min: PyReadonlyArray1<'py, f64>,
    insulin_u_per_min: PyReadonlyArray1<'py, f64>,
    sensitivity: Option<PyReadonlyArray1<'py, f64>>,
    cohort_seed: u64,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
    let cho = cho_g_per_min.as_slice().map_err(value_error)?;
    let ins = insulin_u_per_min.as_slice().map_err(value_error)?;
    if cho.len() != ins.len() {
        return Err(value_error(format!(
            "cho_g_per_min has {} minutes but insulin_u_per_min has {}",
            cho.len(),
            ins.len()
        )));
    }
    let sens = match &sensitivity {
        Some(s) => {
            let s = s.as_slice().map_err(value_error)?;
            if s.len() != cho.len() {
                return Err(value_error(format!(
                    "sensitivity has {} minutes, expected {}",
                    s.len(),
                    cho.len()
                )));
            }
            Some(s)
        }
        None => None,
    };
    let mut p = Patient::new(params_of(patient, cohort_seed)?).map_err(value_error)?;
    let mut g = Vec::with_capacity(cho.len() + 1);
    let mut gs = Vec::with_capacity(cho.len() + 1);
    g.push(p.glucose_mg_dl());
    gs.push(p.subcutaneous_glucose_mg_dl());
    for i in 0..cho.len() {
        p.step(cho[i], ins[i], sens.map_or(1.0, |s| s[i]))
            .map_err(value_error)?;
        g.push(p.glucose_mg_dl());
        gs.push(p.subcutaneous_glucose_mg_dl());
    }
    Ok((g.into_pyarray(py), gs.into_pyarray(py)))
}

/// One patient of a trial's cohort through a scenario and arm with the
/// trial's closed loop: every simulated minute, as named columns.
#[pyfunction]
#[pyo3(signature = (config_json, patient, scenario, arm))]
fn run_scenario(
    py: Python<'_>,
    config_json: &str,
    patient: &str,
    scenario: &str,
    arm: &str,
) -> PyResult<Vec<(&'static str, PyObject)>> {
    let config = abba_trial::TrialConfig::from_json(config_json).map_err(value_error)?;
    let scenario: abba_sim::scenario::ScenarioId = scenario.parse().map_err(value_error)?;
    let arm: abba_trial::ArmKind = arm.parse().map_err(value_error)?;
    let cohort = abba_trial::runner::build_cohort(&config).map_err(value_error)?;
    let (_, trace) = py
        .allow_threads(|| {
            abba_trial::runner::trace_patient(&config, &cohort, patient, scenario, arm)
        })
        .map_err(value_error)?;
    let rows = trace.minutes.unwrap_or_default();
    let col = |f: &dyn Fn(&abba_trial::closed_loop::MinuteRecord) -> f64| -> PyObject {
        rows.iter()
            .map(f)
            .collect::<Vec<f64>>()
            .into_pyarray(py)
            .into_any()
            .unbind()
    };
    Ok(vec![
        ("minute", col(&|r| r.minute as f64)),
        ("plasma_mg_dl", col(&|r| r.plasma_mg_dl)),
        ("subcutaneous_mg_dl", col(&|r| r.subcutaneous_mg_dl)),
        ("cgm_mg_dl", col(&|r| r.cgm_mg_dl.unwrap_or(f64::NAN))),
        ("smbg_mg_dl", col(&|r| r.smbg_mg_dl.unwrap_or(f64::NAN))),
        ("cho_g_per_min", col(&|r| r.cho_g_per_min)),
        ("insulin_u_per_min", col(&|r| r.insulin_u_per_min)),
        ("sensitivity", col(&|r| r.sensitivity)),
        ("basal_u_per_h", col(&|r| r.basal_u_per_h)),
        (
            "carb_ratio_breakfast_g_per_u",
            col(&|r| r.carb_ratio_g_per_u[0]),
        ),
        (
            "carb_ratio_lunch_g_per_u",
            col(&|r| r.carb_ratio_g_per_u[1]),
        ),
        (
            "carb_ratio_dinner_g_per_u",
            col(&|r| r.carb_ratio_g_per_u[2]),
        ),
    ])
}
