//! The `abba` Python package's native module (`abba._abba`).
use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _abba(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
