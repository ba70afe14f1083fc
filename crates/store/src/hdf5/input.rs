//! The HDF5 reader the sweep crate reads a sweep file's HDF5 inputs through (recorded drives, fit
//! data, a fit's result): that crate links no HDF5 library, and a front end registers this one at
//! start ([`register`]).

use std::path::Path;

use chainsweep_sweep::sweep::data_files::{set_hdf5_reader, Array, Hdf5Reader, Object};
use hdf5::types::VarLenUnicode;

/// This crate's HDF5 library, as the sweep crate's [`Hdf5Reader`].
pub struct Input;

/// Registers [`Input`] as the sweep crate's HDF5 reader (once; later calls do nothing).
pub fn register() {
    static INPUT: Input = Input;
    set_hdf5_reader(&INPUT);
}

fn open(path: &Path) -> Result<hdf5::File, String> {
    hdf5::File::open(path).map_err(|e| e.to_string())
}

impl Hdf5Reader for Input {
    fn object(&self, path: &Path, name: &str) -> Result<Object, String> {
        let file = open(path)?;
        Ok(if file.group(name).is_ok() {
            Object::Group
        } else if file.dataset(name).is_ok() {
            Object::Dataset
        } else {
            Object::Missing
        })
    }

    fn read_f64(
        &self,
        path: &Path,
        name: &str,
        wanted: &dyn Fn(&[usize]) -> bool,
    ) -> Result<Array, String> {
        let d = open(path)?.dataset(name).map_err(|e| e.to_string())?;
        let shape = d.shape();
        let values = if wanted(&shape) {
            Some(d.read_raw::<f64>().map_err(|e| e.to_string())?)
        } else {
            None
        };
        Ok(Array { shape, values })
    }

    fn root_string_attribute(&self, path: &Path, name: &str) -> Result<Option<String>, String> {
        let file = open(path)?;
        Ok(file
            .attr(name)
            .and_then(|a| a.read_scalar::<VarLenUnicode>())
            .ok()
            .map(|s| s.to_string()))
    }
}
