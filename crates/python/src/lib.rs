//! The `abba` Python package's native module (`abba._abba`): the
//! simulator, the trial (whole or in shards), the advisor and the cores of
//! the gymnasium environments. The Python side (`python/abba`) wraps these
//! in documented classes; units are in every argument name.

use pyo3::prelude::*;

pub mod daily_env;
pub mod minute_env;
mod py_advisor;
mod py_envs;
mod py_sim;
mod py_trial;

/// A Python `ValueError` carrying `e`'s message.
pub(crate) fn value_error(e: impl std::fmt::Display) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(e.to_string())
}

/// The native module.
#[pymodule]
fn _abba(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("GIT_REVISION", env!("ABBA_GIT_REV"))?;
    py_sim::register(m)?;
    py_envs::register(m)?;
    py_advisor::register(m)?;
    py_trial::register(m)?;
    Ok(())
}
