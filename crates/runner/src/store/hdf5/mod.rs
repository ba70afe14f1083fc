//! The HDF5 file: written from run records in grid order ([`write`]), and read back for merging
//! and `status` ([`read`]); both column by column as [`crate::record::columns::COLUMNS`] defines
//! them.
//!
//! Layout (see `README-sweeps.md`): root attributes describing the sweep; one coordinate dataset
//! per axis (an HDF5 dimension scale); per-run summaries as arrays shaped like the grid (plus a
//! `probe` dimension where there is one value per probe), with the scales attached; histories
//! under `runs/<flat index>/` in chunked, deflate-compressed datasets.

pub mod read;
pub mod write;

pub use read::FileRecords;
pub use write::write_file;

use std::ffi::CString;
use std::path::Path;

use hdf5::types::VarLenUnicode;
use hdf5::{Dataset, File, Group, H5Type, Location};

use crate::error::{Error, Result};
use crate::sweep::auto::AutoChoice;

/// Deflate level of history datasets.
pub const DEFLATE_LEVEL: u8 = 4;

/// Largest chunk of a history dataset, in samples.
pub const HISTORY_CHUNK: usize = 16384;

/// The HDF5 high-level library's dimension-scale functions, which hdf5-metno does not wrap.
mod ds {
    use hdf5_sys::h5::herr_t;
    use hdf5_sys::h5i::hid_t;
    use std::os::raw::{c_char, c_uint};

    extern "C" {
        pub fn H5DSset_scale(dsid: hid_t, dimname: *const c_char) -> herr_t;
        pub fn H5DSattach_scale(did: hid_t, dsid: hid_t, idx: c_uint) -> herr_t;
        pub fn H5DSset_label(did: hid_t, idx: c_uint, label: *const c_char) -> herr_t;
    }
}

/// Makes `scale` a dimension scale named `name`.
fn set_scale(scale: &Dataset, name: &str) -> Result<()> {
    let c = CString::new(name).map_err(|_| Error::Other(format!("bad scale name {name:?}")))?;
    // SAFETY: `scale.id()` is the id of an open dataset (`scale` borrows it for the call), `c`
    // is a NUL-terminated string alive for the call (the function copies it), and the call runs
    // under hdf5-metno's global lock, as every call into the (non-thread-safe) library must.
    let r = hdf5::sync::sync(|| unsafe { ds::H5DSset_scale(scale.id(), c.as_ptr()) });
    if r < 0 {
        return Err(Error::Other(format!("H5DSset_scale({name}) failed")));
    }
    Ok(())
}

/// Attaches dimension scale `scale` to dimension `dim` of `data`, and labels the dimension.
fn attach_scale(data: &Dataset, scale: &Dataset, dim: usize, label: &str) -> Result<()> {
    let c = CString::new(label).map_err(|_| Error::Other(format!("bad label {label:?}")))?;
    // SAFETY: `data.id()` and `scale.id()` are ids of open datasets (borrowed for the call);
    // `dim` is a dimension of `data` (callers pass the grid's dimensions, and the probe dimension
    // of per-probe datasets; HDF5 checks it and fails rather than writing out of bounds); `c` is
    // a NUL-terminated string alive for the call (copied by the library); the calls run under
    // hdf5-metno's global lock.
    let r = hdf5::sync::sync(|| unsafe {
        let a = ds::H5DSattach_scale(data.id(), scale.id(), dim as u32);
        if a < 0 {
            return a;
        }
        ds::H5DSset_label(data.id(), dim as u32, c.as_ptr())
    });
    if r < 0 {
        return Err(Error::Other(format!(
            "attaching dimension scale {label} failed"
        )));
    }
    Ok(())
}

pub(crate) fn vlen(s: &str) -> Result<VarLenUnicode> {
    s.replace('\0', "\u{FFFD}")
        .parse::<VarLenUnicode>()
        .map_err(|e| Error::Other(format!("string not storable in HDF5: {e}")))
}

/// Writes a scalar variable-length UTF-8 string attribute (h5py returns `str`).
pub(crate) fn attr_str(loc: &Location, name: &str, value: &str) -> Result<()> {
    let a = loc.new_attr::<VarLenUnicode>().shape(()).create(name)?;
    a.write_scalar(&vlen(value)?)?;
    Ok(())
}

pub(crate) fn attr_scalar<T: H5Type>(loc: &Location, name: &str, value: T) -> Result<()> {
    let a = loc.new_attr::<T>().shape(()).create(name)?;
    a.write_scalar(&value)?;
    Ok(())
}

pub(crate) fn attr_vec<T: H5Type>(loc: &Location, name: &str, values: &[T]) -> Result<()> {
    let a = loc.new_attr::<T>().shape(values.len()).create(name)?;
    a.write_raw(values)?;
    Ok(())
}

pub(crate) fn dataset<T: H5Type>(
    group: &Group,
    name: &str,
    shape: &[usize],
    data: &[T],
) -> Result<Dataset> {
    let d = group
        .new_dataset::<T>()
        .shape(shape.to_vec())
        .create(name)?;
    if !data.is_empty() {
        d.write_raw(data)?;
    }
    Ok(d)
}

pub(crate) fn str_dataset(
    group: &Group,
    name: &str,
    shape: &[usize],
    data: &[String],
) -> Result<Dataset> {
    let v = data.iter().map(|s| vlen(s)).collect::<Result<Vec<_>>>()?;
    dataset(group, name, shape, &v)
}

/// Root attributes that vary between otherwise identical files.
#[derive(Debug, Clone)]
pub struct Provenance {
    /// Creation time, ISO 8601 UTC.
    pub created_utc: String,
    /// The command line that made the file.
    pub command_line: String,
}

impl Provenance {
    /// Provenance of a file made now by `command_line`.
    pub fn now(command_line: String) -> Self {
        Provenance {
            created_utc: utc_now(),
            command_line,
        }
    }

    /// Provenance of a file made now by this process: its command line, quoted for a shell
    /// where needed (the `chainsweep` command, or the program that embeds the runner).
    pub fn of_this_process() -> Self {
        let command_line = std::env::args()
            .map(|a| {
                if a.is_empty() || a.contains(|c: char| c.is_whitespace() || c == '\'' || c == '"')
                {
                    format!("'{}'", a.replace('\'', "'\\''"))
                } else {
                    a
                }
            })
            .collect::<Vec<_>>()
            .join(" ");
        Provenance::now(command_line)
    }
}

/// Current time as ISO 8601 UTC (`2026-01-31T23:59:59Z`).
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs())
        .unwrap_or(0) as i64;
    let days = secs.div_euclid(86400);
    let rem = secs.rem_euclid(86400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        (rem / 60) % 60,
        rem % 60
    )
}

/// Counts of a file's grid points.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Successful runs.
    pub ok: usize,
    /// Failed runs.
    pub failed: usize,
    /// Points not run (or not in this shard).
    pub pending: usize,
}

/// Zero-padded name of a run's group under `runs/`.
pub fn run_group_name(grid_len: usize, index: usize) -> String {
    let width = format!("{}", grid_len.saturating_sub(1)).len();
    format!("{index:0width$}")
}

fn read_attr_str(loc: &Location, name: &str) -> Result<String> {
    let v: VarLenUnicode = loc.attr(name)?.read_scalar()?;
    Ok(v.as_str().to_string())
}

/// Reads what `integrator: auto` chose from an output file's `auto` attribute (`None` when the
/// file has none).
pub fn read_auto_choice(path: &Path) -> Result<Option<AutoChoice>> {
    let read = || -> Result<Option<String>> {
        let f = File::open(path)?;
        if !f.attr_names()?.iter().any(|a| a == "auto") {
            return Ok(None);
        }
        read_attr_str(&f, "auto").map(Some)
    };
    let text = read().map_err(|e| e.hdf5_context(|| format!("reading {}", path.display())))?;
    text.map(|t| AutoChoice::from_json(&t)).transpose()
}

/// Whether the file at `path` starts with the HDF5 signature.
pub fn is_hdf5(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .map(|_| &magic == b"\x89HDF\r\n\x1a\n")
        .unwrap_or(false)
}

/// Reads the `sweep` root attribute of an HDF5 file made by chainsweep.
pub fn read_sweep_text(path: &Path) -> Result<String> {
    File::open(path)
        .and_then(|f| f.attr("sweep")?.read_scalar::<VarLenUnicode>())
        .map(|v| v.as_str().to_string())
        .map_err(|e| Error::from(e).hdf5_context(|| format!("reading {}", path.display())))
}
