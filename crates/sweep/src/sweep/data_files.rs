//! The HDF5 files a sweep file names (recorded drives, fit data, a fit's result), read through a
//! reader the front end registers: this crate links no HDF5 library. The store crate's reader
//! (`chainsweep_store::hdf5::input`) is the one the command line and the Python package register,
//! as `log` takes its logger: once, at start.

use std::path::Path;
use std::sync::OnceLock;

/// What a path inside an HDF5 file names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Object {
    /// A group.
    Group,
    /// A dataset.
    Dataset,
    /// Nothing (or something else: a named datatype).
    Missing,
}

/// A dataset's shape, and its values when the reader was asked to read them.
#[derive(Debug, Clone, PartialEq)]
pub struct Array {
    /// Its shape.
    pub shape: Vec<usize>,
    /// Its values in row-major order, converted to `f64`; `None` when its shape was refused.
    pub values: Option<Vec<f64>>,
}

/// The number of values of an array of `shape`; `usize::MAX` when that does not fit (a damaged
/// or hostile file's dimensions), so that every limit refuses it.
pub fn values_in(shape: &[usize]) -> usize {
    shape
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .unwrap_or(usize::MAX)
}

/// What reading a sweep file needs of an HDF5 file. Each call opens the file once; errors (the
/// file cannot be opened, a dataset cannot be read as numbers) are the library's message, which
/// the caller puts after the file's name and the field that named it.
pub trait Hdf5Reader: Send + Sync {
    /// What `name` (a path inside the file) is.
    fn object(&self, path: &Path, name: &str) -> Result<Object, String>;
    /// The dataset `name`: its shape, and its values when `wanted` accepts that shape (checked
    /// before anything is read, so that a dataset too large or of the wrong shape costs nothing).
    fn read_f64(
        &self,
        path: &Path,
        name: &str,
        wanted: &dyn Fn(&[usize]) -> bool,
    ) -> Result<Array, String>;
    /// The string attribute `name` of the file's root group; `None` when it has none.
    fn root_string_attribute(&self, path: &Path, name: &str) -> Result<Option<String>, String>;
}

static READER: OnceLock<&'static dyn Hdf5Reader> = OnceLock::new();

/// Registers the reader of HDF5 files (once; later calls are ignored).
pub fn set_hdf5_reader(reader: &'static dyn Hdf5Reader) {
    let _ = READER.set(reader);
}

/// The registered reader, or why there is none.
pub(crate) fn hdf5_reader() -> Result<&'static dyn Hdf5Reader, String> {
    READER.get().copied().ok_or_else(|| {
        "this program reads no HDF5 files (no HDF5 reader was registered: \
         chainsweep::init, or chainsweep_sweep::sweep::data_files::set_hdf5_reader)"
            .to_string()
    })
}

/// Whether `path` is a regular file that starts with HDF5's signature (only a regular file is
/// opened: opening a FIFO would wait for a writer). The one test of it, the store's included.
pub fn is_hdf5(path: &Path) -> bool {
    let mut head = [0u8; 8];
    path.is_file()
        && std::fs::File::open(path)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .is_ok()
        && head == *b"\x89HDF\r\n\x1a\n"
}
