//! A result file checked before `chainsweep.open` serves it: the engine's own check of every
//! stored value against its checksum ([`chainsweep::engine::status::check_file`]), and the values
//! of a numeric dataset read without HDF5's Fletcher-32 check (so that the intact points of a
//! damaged chunk can still be served, the damaged ones masked).

use std::path::PathBuf;

use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

use chainsweep::engine::status::check_file as engine_check;

/// Checks the result file `path` (its histories too with `histories`): a dict with `checked`
/// (whether the file carries checksums), `file` (why it cannot be read at all, or None),
/// `header` (what is wrong with its header, coordinates or probes, or None), `damaged` (a list of
/// `(flat index, axis values, why)`) and `unreadable` (summary datasets HDF5 cannot read, as
/// `(name, why, per_probe)`).
#[pyfunction]
#[pyo3(signature = (path, histories = false))]
pub fn check_file(py: Python<'_>, path: PathBuf, histories: bool) -> PyResult<Py<PyDict>> {
    let c = py.detach(|| engine_check(&path, histories));
    let d = PyDict::new(py);
    d.set_item("checked", c.checked)?;
    d.set_item("file", c.file)?;
    d.set_item("header", c.header)?;
    d.set_item("damaged", PyList::new(py, c.damaged)?)?;
    d.set_item("unreadable", PyList::new(py, c.unreadable)?)?;
    Ok(d.unbind())
}

/// The values of the numeric dataset `name` of the result file `path`, read without HDF5's
/// Fletcher-32 check: `(bytes, dtype, shape)`, the bytes little endian in C order, the dtype as
/// numpy names it.
#[pyfunction]
pub fn read_unchecked(
    py: Python<'_>,
    path: PathBuf,
    name: String,
) -> PyResult<(Py<PyBytes>, String, Vec<usize>)> {
    let read = py.detach(|| chainsweep::store::hdf5::read_numeric_unchecked(&path, &name));
    let (bytes, dtype, shape) =
        read.map_err(|e| PyOSError::new_err(format!("{}: {name}: {e}", path.display())))?;
    Ok((PyBytes::new(py, &bytes).unbind(), dtype.to_string(), shape))
}
