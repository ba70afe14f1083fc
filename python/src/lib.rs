//! # `chainsweep._chainsweep`: the native part of the Python package
//!
//! The pure-Python package `chainsweep` (`python/chainsweep/`) builds xarray datasets, exceptions
//! and progress bars; this extension module only runs things, through the runner's own code paths:
//!
//! - [`run_scene`]: one scene, exactly as `chainsweep point` runs a grid point ([`point`]);
//! - [`run_sweep`]: a sweep file into HDF5, exactly as `chainsweep run` does ([`sweep`]), with
//!   progress (what the engine's `ProgressSink` hears) and Ctrl-C;
//! - [`spectrum::spectrum`]: the linear spectrum at the static state of a scene or of a sweep
//!   file's grid point, without time integration ([`spectrum`]);
//! - [`check_file`]: a result file's every value checked against its checksums, before
//!   `chainsweep.open` serves it ([`check`]);
//! - [`cli_main`]: the whole `chainsweep` command line, the package's console script ([`cli`]).
//!
//! Both release the GIL while the solver runs, so Python threads run scenes in parallel.
//! Errors reach Python as the package's own exceptions (`chainsweep.InputError`, …), made by
//! `chainsweep.errors.from_runner` from the runner's error kind, field and message.

use pyo3::prelude::*;

mod check;
mod cli;
mod point;
mod spectrum;
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

/// The runner's table of stored summary columns, for the package's labels: one dict per column
/// (name, numpy dtype, per_probe, per_harmonic, units — `None` for none, `"of_probes"` for the probes' own —,
/// description, label (its short `long_name`), long_name, flag_values, flag_meanings, written, kind).
fn column_table(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyList>> {
    use chainsweep::record::columns::{Units, COLUMNS};
    let rows = COLUMNS
        .iter()
        .map(|c| -> PyResult<Bound<'_, pyo3::types::PyDict>> {
            let d = pyo3::types::PyDict::new(py);
            d.set_item("name", c.name)?;
            d.set_item("dtype", c.dtype.numpy())?;
            d.set_item("per_probe", c.per_probe)?;
            d.set_item("per_harmonic", c.per_harmonic)?;
            d.set_item(
                "units",
                match c.units {
                    Units::None => None,
                    Units::Fixed(u) => Some(u),
                    Units::OfProbes => Some("of_probes"),
                },
            )?;
            d.set_item("description", c.description)?;
            d.set_item("label", c.label())?;
            d.set_item("long_name", c.long_name)?;
            let values = c
                .flags
                .map(|(v, _)| v.iter().map(|&x| u32::from(x)).collect::<Vec<_>>());
            d.set_item("flag_values", values)?;
            d.set_item("flag_meanings", c.flags.map(|(_, m)| m))?;
            d.set_item("written", c.written.name())?;
            d.set_item("kind", c.fill.kind())?;
            Ok(d)
        })
        .collect::<PyResult<Vec<_>>>()?;
    pyo3::types::PyList::new(py, rows)
}

/// The extension module.
/// The runs' arrays as the store writes them (variables and coordinates beside the summary
/// columns): name → {long_name, comment, units, over} (over: the coordinate a per-element variable
/// is over). `chainsweep.open` and `chainsweep.run` label their Datasets with these, so the labels
/// have one definition, the store's.
fn array_table(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    use chainsweep::record::columns::{
        field_name, CONTACT, ENERGY_FLOW, ENERGY_FLOW_COMMENTS, FIELD_TIME, HISTORY, MIN_OVERLAP,
        PARTICLE,
    };
    use chainsweep::store::hdf5::arrays as a;
    use chainsweep_solver::observe::probes::FieldQuantity;
    let out = pyo3::types::PyDict::new(py);
    let entry = |name: &str,
                 long_name: &str,
                 comment: Option<&str>,
                 units: Option<&str>,
                 over: Option<&str>|
     -> PyResult<()> {
        let d = pyo3::types::PyDict::new(py);
        d.set_item("long_name", long_name)?;
        d.set_item("comment", comment)?;
        d.set_item("units", units)?;
        d.set_item("over", over)?;
        out.set_item(name, d)
    };
    entry(HISTORY, a::HISTORY_LONG_NAME, None, None, None)?;
    entry(
        MIN_OVERLAP,
        a::MIN_OVERLAP_LONG_NAME,
        None,
        Some("m"),
        Some(CONTACT),
    )?;
    entry(
        CONTACT,
        a::CONTACT_LONG_NAME,
        Some(a::CONTACT_COMMENT),
        Some("1"),
        None,
    )?;
    entry(
        PARTICLE,
        a::PARTICLE_LONG_NAME,
        Some(a::PARTICLE_COMMENT),
        Some("1"),
        None,
    )?;
    entry(
        FIELD_TIME,
        a::FIELD_TIME_LONG_NAME,
        Some(a::FIELD_TIME_COMMENT),
        Some("s"),
        None,
    )?;
    let harmonic = chainsweep::store::hdf5::write::HARMONIC_LONG_NAME;
    entry("harmonic", harmonic, None, Some("1"), None)?;
    for q in FieldQuantity::ALL {
        let over = if q.per_contact() { CONTACT } else { PARTICLE };
        entry(
            field_name(q),
            a::field_long_name(q),
            Some(a::field_comment(q)),
            Some(q.unit()),
            Some(over),
        )?;
    }
    for ((name, per_contact, long_name), comment) in ENERGY_FLOW.iter().zip(ENERGY_FLOW_COMMENTS) {
        let over = if *per_contact { CONTACT } else { PARTICLE };
        entry(name, long_name, Some(comment), Some("J"), Some(over))?;
    }
    Ok(out)
}

#[pymodule]
fn _chainsweep(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(point::run_scene, m)?)?;
    m.add_function(wrap_pyfunction!(spectrum::spectrum, m)?)?;
    m.add_function(wrap_pyfunction!(sweep::run_sweep, m)?)?;
    m.add_function(wrap_pyfunction!(check::check_file, m)?)?;
    m.add_function(wrap_pyfunction!(check::read_unchecked, m)?)?;
    m.add_function(wrap_pyfunction!(cli::cli_main, m)?)?;
    m.add("ENGINE_VERSION", chainsweep::ENGINE_VERSION)?;
    m.add("SOLVER_VERSION", chainsweep::SOLVER_VERSION)?;
    m.add("NUMERICS_VERSION", chainsweep::NUMERICS_VERSION)?;
    chainsweep::init(chainsweep_cli::GIT_REVISION);
    m.add("GIT_REVISION", chainsweep::git_revision())?;
    m.add("COLUMNS", column_table(m.py())?)?;
    m.add("ARRAYS", array_table(m.py())?)?;
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
