//! # `chainsweep._chainsweep`: the native part of the Python package
//!
//! The pure-Python package `chainsweep` (`python/chainsweep/`) builds xarray datasets, exceptions
//! and progress bars; this extension module only runs things, through the runner's own code paths:
//!
//! - [`run_scene`]: one scene, exactly as `chainsweep point` runs a grid point ([`point`]);
//! - [`run_sweep`]: a sweep file into HDF5, exactly as `chainsweep run` does ([`sweep`]), with
//!   progress (what the engine's `ProgressSink` hears) and Ctrl-C;
//! - [`check_file`]: a result file's every value checked against its checksums, before
//!   `chainsweep.open` serves it ([`check`]).
//!
//! Both release the GIL while the solver runs, so Python threads run scenes in parallel.
//! Errors reach Python as the package's own exceptions (`chainsweep.InputError`, …), made by
//! `chainsweep.errors.from_runner` from the runner's error kind, field and message.

use pyo3::prelude::*;

mod check;
mod point;
mod sweep;

/// A runner error as the Python exception the package defines for it.
fn py_error(py: Python<'_>, e: &chainsweep::error::Error, context: &str) -> PyErr {
    use chainsweep::error::Error;
    let (kind, field, message) = match e {
        Error::Input { field, message, .. } => ("input", field.as_str(), message.clone()),
        other => ("other", "", other.to_string()),
    };
    let made = py
        .import("chainsweep.errors")
        .and_then(|m| m.getattr("from_runner"))
        .and_then(|f| f.call1((kind, field, message.as_str(), context)));
    match made {
        Ok(exc) => PyErr::from_value(exc),
        Err(import_failure) => import_failure,
    }
}

/// The extension module.
#[pymodule]
fn _chainsweep(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(point::run_scene, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::run_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(check::check_file, m)?)?;
    m.add_function(wrap_pyfunction!(check::read_unchecked, m)?)?;
    m.add("ENGINE_VERSION", chainsweep::ENGINE_VERSION)?;
    m.add("SOLVER_VERSION", chainsweep::SOLVER_VERSION)?;
    m.add("NUMERICS_VERSION", chainsweep::NUMERICS_VERSION)?;
    m.add("GIT_REVISION", chainsweep::GIT_REVISION)?;
    m.add(
        "DEFAULT_CHECKPOINT_INTERVAL_S",
        chainsweep::engine::run::DEFAULT_CHECKPOINT_INTERVAL_S,
    )?;
    m.add(
        "DEFAULT_PROGRESS_INTERVAL_S",
        chainsweep::engine::run::DEFAULT_PROGRESS_INTERVAL_S,
    )?;
    Ok(())
}
