//! The trial: a whole run, or shards merged, with the report in memory.

use crate::value_error;
use abba_trial::runner::{run_trial, Silent, TrialOutput};
use abba_trial::shard::{self, ShardFile, ShardSpec};
use abba_trial::TrialConfig;
use pyo3::prelude::*;
use pyo3::types::PyBytes;

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(default_config_json, m)?)?;
    m.add_function(wrap_pyfunction!(trial_report, m)?)?;
    m.add_function(wrap_pyfunction!(trial_shard, m)?)?;
    m.add_function(wrap_pyfunction!(merge_shards, m)?)?;
    Ok(())
}

fn config_of(json: &str) -> PyResult<TrialConfig> {
    TrialConfig::from_json(json).map_err(|e| value_error(format!("trial configuration: {e}")))
}

/// The report files of `output` as (name, bytes), written exactly as
/// `abba trial` writes them (manifest.json without its `run` section).
fn report<'py>(
    py: Python<'py>,
    output: &TrialOutput,
) -> PyResult<Vec<(String, Bound<'py, PyBytes>)>> {
    let tool = abba_trial::report::ToolInfo {
        version: env!("CARGO_PKG_VERSION"),
        git_revision: env!("ABBA_GIT_REV"),
    };
    // Every file as `abba trial` writes it, the W1 block among them.
    let files = abba_trial::report::trial_report_files(output, &tool, None).map_err(value_error)?;
    Ok(files
        .into_iter()
        .map(|f| (f.name.to_string(), PyBytes::new(py, &f.bytes)))
        .collect())
}

/// The paper's protocol as JSON (every knob at its default; for a cohort
/// of `population`, ABBA's defaults for it).
#[pyfunction]
#[pyo3(signature = (population = None))]
fn default_config_json(population: Option<&str>) -> PyResult<String> {
    let raw = match population {
        None => abba_trial::protocol::RawTrialConfig::default(),
        Some(p) => abba_trial::protocol::RawTrialConfig::for_population(
            p.parse::<abba_sim::cohort::Population>()
                .map_err(value_error)?,
        ),
    };
    serde_json::to_string_pretty(&raw).map_err(value_error)
}

/// Runs a whole trial; returns its report files.
#[pyfunction]
#[pyo3(signature = (config_json, threads = 0))]
fn trial_report<'py>(
    py: Python<'py>,
    config_json: &str,
    threads: usize,
) -> PyResult<Vec<(String, Bound<'py, PyBytes>)>> {
    let config = config_of(config_json)?;
    let output = py
        .allow_threads(|| run_trial(&config, threads, &Silent))
        .map_err(value_error)?;
    report(py, &output)
}

/// Runs shard `index` of `count`; returns the shard file's JSON.
#[pyfunction]
#[pyo3(signature = (config_json, index, count, threads = 0))]
fn trial_shard(
    py: Python<'_>,
    config_json: &str,
    index: u32,
    count: u32,
    threads: usize,
) -> PyResult<String> {
    let config = config_of(config_json)?;
    let spec = ShardSpec::new(index, count).map_err(value_error)?;
    let file = py
        .allow_threads(|| shard::run_shard(&config, spec, threads, &Silent))
        .map_err(value_error)?;
    serde_json::to_string(&file).map_err(value_error)
}

/// Merges shard files (JSON texts); returns the report files.
#[pyfunction]
fn merge_shards<'py>(
    py: Python<'py>,
    shards: Vec<String>,
) -> PyResult<Vec<(String, Bound<'py, PyBytes>)>> {
    let files = shards
        .iter()
        .enumerate()
        .map(|(i, s)| {
            serde_json::from_str::<ShardFile>(s)
                .map_err(|e| value_error(format!("shard {i}: not an abba trial shard: {e}")))
        })
        .collect::<PyResult<Vec<_>>>()?;
    let output = shard::merge(&files).map_err(value_error)?;
    report(py, &output)
}
