//! Plain HDF5 files of attributes and datasets, for files that are no sweep's output (a
//! work-precision study, `chainsweep accuracy`): the engine writes them through this module, as
//! it links no HDF5 library itself.

use std::path::Path;

use hdf5::{Dataset, Group, H5Type};

use super::{attr_scalar, attr_str, vlen};
use chainsweep_sweep::error::Result;

/// A number type a plain file stores: `f64`, `i64`, `u8`.
pub trait Element: H5Type + Copy {}
impl Element for f64 {}
impl Element for i64 {}
impl Element for u8 {}

/// A new HDF5 file, written through its root group ([`PlainFile::root`]).
pub struct PlainFile {
    file: hdf5::File,
}

/// A group of a [`PlainFile`] (its root included).
pub struct PlainGroup {
    group: Group,
}

/// A dataset of a [`PlainFile`], to which attributes are added.
pub struct PlainDataset {
    dataset: Dataset,
}

impl PlainFile {
    /// Creates (or truncates) the file at `path`.
    pub fn create(path: &Path) -> Result<PlainFile> {
        Ok(PlainFile {
            file: hdf5::File::create(path).map_err(crate::h5)?,
        })
    }

    /// The root group.
    pub fn root(&self) -> PlainGroup {
        PlainGroup {
            group: (*self.file).clone(),
        }
    }

    /// Closes this handle of the file; the file itself closes, its writes flushed, once the last
    /// group of it ([`PlainFile::root`] and those made from it) is dropped too.
    pub fn close(self) -> Result<()> {
        self.file.close().map_err(crate::h5)
    }
}

impl PlainGroup {
    /// A new group `name` in this one.
    pub fn group(&self, name: &str) -> Result<PlainGroup> {
        Ok(PlainGroup {
            group: self.group.create_group(name).map_err(crate::h5)?,
        })
    }

    /// A scalar UTF-8 string attribute.
    pub fn attr_str(&self, name: &str, value: &str) -> Result<()> {
        attr_str(&self.group, name, value)
    }

    /// A scalar number attribute.
    pub fn attr<T: Element>(&self, name: &str, value: T) -> Result<()> {
        attr_scalar(&self.group, name, value)
    }

    /// A dataset of `shape` holding `data` in row-major order.
    pub fn dataset<T: Element>(
        &self,
        name: &str,
        shape: &[usize],
        data: &[T],
    ) -> Result<PlainDataset> {
        Ok(PlainDataset {
            dataset: super::dataset(&self.group, name, shape, data)?,
        })
    }

    /// A dataset of UTF-8 strings of `shape`.
    pub fn str_dataset(
        &self,
        name: &str,
        shape: &[usize],
        data: &[String],
    ) -> Result<PlainDataset> {
        let v = data.iter().map(|s| vlen(s)).collect::<Result<Vec<_>>>()?;
        Ok(PlainDataset {
            dataset: super::dataset(&self.group, name, shape, &v)?,
        })
    }
}

impl PlainDataset {
    /// A scalar UTF-8 string attribute.
    pub fn attr_str(&self, name: &str, value: &str) -> Result<()> {
        attr_str(&self.dataset, name, value)
    }
}
