//! The HDF5 file: written from run records in grid order ([`write`]), and read back for merging
//! and `status` ([`read`]); both column by column as [`chainsweep_sweep::record::columns::COLUMNS`] defines
//! them.
//!
//! Layout (see `docs/REFERENCE.md`): root attributes describing the sweep; one coordinate dataset
//! per axis; per-run summaries as arrays shaped like the grid (plus a `probe` dimension where
//! there is one value per probe); the runs' histories and minimum overlaps as one chunked,
//! compressed dataset per quantity over the grid ([`arrays`]; run groups under `runs/` in
//! layouts 4 and earlier, still read).
//!
//! The layout is the one netCDF-4 gives HDF5, so that xarray (through h5netcdf or netCDF4) reads
//! the file exactly as labelled. netCDF-4 names a dimension after its dimension scale, a dataset
//! named like the dimension, and takes the last scale attached to a dimension of a dataset as
//! that dimension. So each grid dimension has exactly one scale: the axis named like the
//! dimension, or, for a zipped group named after none of its axes, an empty dataset marked as a
//! netCDF dimension without a variable ([`NETCDF_DIM_ONLY`]). The other axes of a zipped group
//! are plain datasets on that dimension (the scale attached to them), and every summary lists
//! them in its `coordinates` attribute (the CF convention xarray follows), with `probe_units`
//! for the per-probe ones. Every numeric summary carries its missing-value marker (NaN, or
//! [`chainsweep_sweep::record::INT_FILL`]) as its HDF5 fill value and as a `_FillValue` attribute of its
//! own type, so xarray masks failed and pending points.
//!
//! The file follows the CF conventions ([`CONVENTIONS`], checked by cfchecker in the tests): every
//! variable has a `long_name`, every numeric one but a flag a `units` that UDUNITS parses, flags
//! their `flag_values` (typed like the variable) and `flag_meanings`. Text is stored as netCDF's
//! `char` arrays ([`char_dataset`]: one-byte strings along a last dimension `<name>_strlen`,
//! `_Encoding = "utf-8"`), the type CF and its checker accept (not HDF5's variable-length
//! strings, netCDF-4's `string`); a text coordinate named like its dimension (`probe`, an axis of
//! text values) is that dimension's scale, two-dimensional, as netCDF-C writes one: its
//! dimensions in `_Netcdf4Coordinates` by the ids every dimension scale of the root carries in
//! `_Netcdf4Dimid` ([`number_dimensions`]). Dimension scales are attached without labels
//! (`DIMENSION_LABELS`, which netCDF does not write and xarray would show as an attribute).

pub mod arrays;
pub mod fit;
pub mod input;
pub mod periodic;
pub mod plain;
pub mod read;
pub(crate) mod scales;
pub mod search;
mod text;
pub mod write;

pub use chainsweep_sweep::sweep::data_files::is_hdf5;
pub use read::FileRecords;
pub use text::TEXT_DEFLATE_LEVEL;
pub(crate) use text::{char_dataset, read_chars, read_text, text_of, Text};
pub use write::{write_file, Written};

use std::ffi::CString;
use std::path::Path;

use hdf5::types::VarLenUnicode;
use hdf5::{Dataset, File, Group, H5Type, Location};

use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::sweep::auto::AutoChoice;

/// Version of the file layout, the `layout_version` root attribute. Its history: CHANGELOG.md,
/// "Results-file layout versions".
pub const LAYOUT_VERSION: i64 = 6;

/// The first layout whose pending points name no run (an empty `run_hash`, `summary_checksum` 0).
pub const UNNAMED_PENDING_LAYOUT: i64 = 6;

/// The first layout whose runs' arrays are datasets over the grid ([`arrays`]), not run groups.
pub const ARRAYS_LAYOUT: i64 = 5;

/// The CF version the files follow (the `Conventions` root attribute): the newest that cfchecker
/// (4.1) checks against.
pub const CONVENTIONS: &str = "CF-1.8";

/// The `_Encoding` attribute of a text variable stored as characters: its bytes are UTF-8 (xarray
/// decodes such a variable to `str`).
pub const CHAR_ENCODING: &str = "utf-8";

/// The `NAME` netCDF-4 gives the dimension scale of a dimension that has no variable (followed
/// by the dimension's length, right-aligned in 10 characters); h5netcdf and netCDF-C read a scale
/// with this name as a dimension only.
pub const NETCDF_DIM_ONLY: &str = "This is a netCDF dimension but not a netCDF variable.";

/// The HDF5 high-level library's dimension-scale functions, which hdf5-metno does not wrap.
mod ds {
    use hdf5_sys::h5::{herr_t, htri_t};
    use hdf5_sys::h5i::hid_t;
    use std::os::raw::{c_char, c_uint};

    extern "C" {
        pub fn H5DSset_scale(dsid: hid_t, dimname: *const c_char) -> herr_t;
        pub fn H5DSattach_scale(did: hid_t, dsid: hid_t, idx: c_uint) -> herr_t;
        pub fn H5DSis_scale(did: hid_t) -> htri_t;
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

/// Attaches dimension scale `scale` to dimension `dim` of `data` (`name`: the dimension's, for
/// the error). No label: netCDF names a dimension after its scale, and writes no
/// `DIMENSION_LABELS` (xarray would show one as an attribute of every variable).
fn attach_scale(data: &Dataset, scale: &Dataset, dim: usize, name: &str) -> Result<()> {
    // SAFETY: `data.id()` and `scale.id()` are ids of open datasets (borrowed for the call);
    // `dim` is a dimension of `data` (callers pass the grid's dimensions, the probe dimension of
    // per-probe datasets and the characters' of text; HDF5 checks it and fails rather than
    // writing out of bounds); the call runs under hdf5-metno's global lock.
    let r = hdf5::sync::sync(|| unsafe { ds::H5DSattach_scale(data.id(), scale.id(), dim as u32) });
    if r < 0 {
        return Err(Error::Other(format!(
            "attaching dimension scale {name} failed"
        )));
    }
    Ok(())
}

/// Whether `d` is a dimension scale.
fn is_scale(d: &Dataset) -> bool {
    // SAFETY: `d.id()` is the id of an open dataset (borrowed for the call), under hdf5-metno's
    // global lock.
    hdf5::sync::sync(|| unsafe { ds::H5DSis_scale(d.id()) }) > 0
}

/// The dimension scale of a dimension without a variable, as netCDF-4 writes one: an unwritten
/// float dataset `name` of the dimension's length, whose scale name says so ([`NETCDF_DIM_ONLY`]).
pub(crate) fn dimension_only(group: &Group, name: &str, len: usize) -> Result<Dataset> {
    let d = group
        .new_dataset::<f32>()
        .shape(len)
        .create(name)
        .map_err(crate::h5)?;
    set_scale(&d, &format!("{NETCDF_DIM_ONLY}{len:>10}"))?;
    Ok(d)
}

/// A name for a new member of `group`: `name`, or with `_` appended until no member has it.
fn free_name(group: &Group, name: &str) -> String {
    let mut n = name.to_string();
    while group.link_exists(&n) {
        n.push('_');
    }
    n
}

/// Numbers every dimension scale of `file`'s root for netCDF (the `_Netcdf4Dimid` attribute: 0, 1,
/// … in the order of their names), and records the dimensions of each two-dimensional text
/// coordinate `(name, characters' dimension)` of `text_scales` in its `_Netcdf4Coordinates` (a
/// scale cannot have scales attached: netCDF-C and h5netcdf take its dimensions from there). The
/// scales of the run groups are left unnumbered: netCDF-C numbers them after the root's.
pub(crate) fn number_dimensions(file: &File, text_scales: &[(String, String)]) -> Result<()> {
    let mut ids = std::collections::HashMap::new();
    for name in file.member_names().map_err(crate::h5)? {
        // A summary column is never a dimension scale: not opened to ask (33 of the 37 datasets
        // of the Fig. 8 sweep's file).
        if chainsweep_sweep::record::columns::is_column_dataset(&name) {
            continue;
        }
        let Ok(d) = file.dataset(&name) else {
            continue;
        };
        if is_scale(&d) {
            let id = ids.len() as i32;
            attr_scalar(&d, "_Netcdf4Dimid", id)?;
            ids.insert(name, id);
        }
    }
    for (name, strlen) in text_scales {
        let id = |n: &String| {
            ids.get(n)
                .copied()
                .ok_or_else(|| Error::Other(format!("no dimension scale {n}")))
        };
        let d = file.dataset(name).map_err(crate::h5)?;
        attr_vec(&d, "_Netcdf4Coordinates", &[id(name)?, id(strlen)?])?;
    }
    Ok(())
}

/// Largest chunk of a summary or coordinate dataset, bytes: a damaged byte makes HDF5's
/// Fletcher-32 check fail for its whole chunk in a reader that checks (h5py, xarray), and small
/// chunks keep what such a reader loses small, while larger ones cost fewer chunk-index entries.
pub const SUMMARY_CHUNK_BYTES: usize = 1 << 16;

/// The chunk shape of a dataset of `shape` whose elements take `item` bytes: the trailing
/// dimensions whole while the chunk stays within [`SUMMARY_CHUNK_BYTES`], then as much of the
/// next one as fits (at least one).
pub fn chunk_shape(shape: &[usize], item: usize) -> Vec<usize> {
    let mut chunk = vec![1; shape.len()];
    let mut bytes = item.max(1);
    for d in (0..shape.len()).rev() {
        let n = shape[d].max(1);
        if bytes * n <= SUMMARY_CHUNK_BYTES {
            chunk[d] = n;
            bytes *= n;
        } else {
            chunk[d] = (SUMMARY_CHUNK_BYTES / bytes).clamp(1, n);
            break;
        }
    }
    chunk
}

/// A dataset builder whose data HDF5 checks: chunked ([`chunk_shape`]) with the Fletcher-32
/// filter, or for a scalar (which cannot be chunked: a search without outer axes has scalar
/// outcomes) compact, its value inside the object header that the 1.10 format checksums.
fn checked_builder<T: H5Type>(group: &Group, shape: &[usize]) -> hdf5::DatasetBuilderEmpty {
    let b = group.new_dataset::<T>();
    if shape.is_empty() {
        b.layout(hdf5::plist::dataset_create::Layout::Compact)
    } else {
        b.chunk(chunk_shape(shape, std::mem::size_of::<T>()))
            .fletcher32()
    }
}

/// A numeric dataset holding `data`, chunked ([`chunk_shape`]) with the Fletcher-32 filter.
pub(crate) fn checked_dataset<T: H5Type>(
    group: &Group,
    name: &str,
    shape: &[usize],
    data: &[T],
) -> Result<Dataset> {
    let d = checked_builder::<T>(group, shape)
        .shape(shape.to_vec())
        .create(name)
        .map_err(crate::h5)?;
    if !data.is_empty() {
        d.write_raw(data).map_err(crate::h5)?;
    }
    Ok(d)
}

/// [`checked_dataset`] whose HDF5 fill value is `fill`, with the same value as its `_FillValue`
/// attribute (of the dataset's own type, as netCDF wants it), by which xarray masks it.
pub(crate) fn filled_checked_dataset<T: H5Type + Copy + Into<hdf5::types::OwnedDynValue>>(
    group: &Group,
    name: &str,
    shape: &[usize],
    data: &[T],
    fill: T,
) -> Result<Dataset> {
    let d = checked_builder::<T>(group, shape)
        .fill_value(fill)
        .shape(shape.to_vec())
        .create(name)
        .map_err(crate::h5)?;
    if !data.is_empty() {
        d.write_raw(data).map_err(crate::h5)?;
    }
    attr_scalar(&d, "_FillValue", fill)?;
    Ok(d)
}

/// [`checked_dataset`] (with `fill`: [`filled_checked_dataset`]) of a summary column: the chunks
/// that hold only the fill value are left unwritten ([`write_points`]).
pub(crate) fn checked_column<T: H5Type + Copy + Into<hdf5::types::OwnedDynValue>>(
    group: &Group,
    name: &str,
    shape: &[usize],
    data: &[T],
    fill: Option<T>,
) -> Result<Dataset> {
    let b = checked_builder::<T>(group, shape);
    let b = match fill {
        Some(f) => b.fill_value(f),
        None => b,
    };
    let d = b.shape(shape.to_vec()).create(name).map_err(crate::h5)?;
    // The bytes HDF5 gives back where nothing was written: the fill value, or zeros without one.
    let fill_bytes = match &fill {
        Some(f) => as_bytes(std::slice::from_ref(f)).to_vec(),
        None => vec![0u8; std::mem::size_of::<T>()],
    };
    let mem = hdf5::Datatype::from_type::<T>().map_err(crate::h5)?;
    write_points(&d, mem.id(), shape, as_bytes(data), &fill_bytes)?;
    if let Some(f) = fill {
        attr_scalar(&d, "_FillValue", f)?;
    }
    Ok(d)
}

/// The bytes of `data` as they lie in memory (numbers and one-byte characters: no padding).
fn as_bytes<T: H5Type + Copy>(data: &[T]) -> &[u8] {
    // SAFETY: the element types written here (f64, i64, u64, u8) are plain data without padding
    // or invalid bit patterns; the slice covers exactly `data`'s memory, borrowed as long as it.
    unsafe { std::slice::from_raw_parts(data.as_ptr().cast::<u8>(), std::mem::size_of_val(data)) }
}

/// Writes `bytes` (every element of `d`, row-major, in memory type `mem_type`) chunk by chunk
/// ([`chunk_shape`]: each chunk a contiguous run of elements), leaving out every chunk whose
/// elements all equal `fill` (the bytes of one element that HDF5 gives back where nothing was
/// written). Such a chunk is never allocated: a reader gets exactly the values it would have
/// held. So a column costs what it holds: a file with few finished points is small (refreshing
/// the output while a sweep runs costs what it holds, not the whole grid), and a column nothing
/// was recorded in (the verification's errors of a sweep that verifies nothing, the failure
/// reasons of one where nothing failed) costs its header only.
fn write_points(
    d: &Dataset,
    mem_type: hdf5_sys::h5i::hid_t,
    shape: &[usize],
    bytes: &[u8],
    fill: &[u8],
) -> Result<()> {
    let item = fill.len().max(1);
    let elements: usize = shape.iter().product();
    if elements == 0 {
        return Ok(());
    }
    if bytes.len() != elements * item {
        return Err(Error::Other(format!(
            "dataset {}: {} bytes for {} elements",
            d.name(),
            bytes.len(),
            elements,
        )));
    }
    let chunk = chunk_shape(shape, item);
    // The dimension a chunk cuts (the ones after it are whole, the ones before it one wide).
    let cut = (0..shape.len())
        .rev()
        .find(|&k| chunk[k] < shape[k])
        .unwrap_or(0);
    let inner: usize = shape[cut + 1..].iter().product();
    let outer: usize = shape[..cut].iter().product();
    let step = chunk[cut];
    let mut start = vec![0u64; shape.len()];
    let mut count: Vec<u64> = chunk.iter().map(|&c| c as u64).collect();
    for o in 0..outer {
        // The leading coordinates of outer index `o`.
        let mut rest = o;
        for k in (0..cut).rev() {
            start[k] = (rest % shape[k]) as u64;
            rest /= shape[k];
        }
        let mut at = 0;
        while at < shape[cut] {
            let n = step.min(shape[cut] - at);
            let first = (o * shape[cut] + at) * inner;
            let len = n * inner;
            let block = &bytes[first * item..(first + len) * item];
            if !block.chunks_exact(item).all(|e| e == fill) {
                start[cut] = at as u64;
                count[cut] = n as u64;
                write_block(d, mem_type, &start, &count, block)?;
            }
            at += n;
        }
    }
    Ok(())
}

/// Writes `block` (in memory type `mem_type`) into the hyperslab `start`, `count` of `d`.
fn write_block(
    d: &Dataset,
    mem_type: hdf5_sys::h5i::hid_t,
    start: &[u64],
    count: &[u64],
    block: &[u8],
) -> Result<()> {
    use hdf5_sys::h5d::{H5Dget_space, H5Dwrite};
    use hdf5_sys::h5p::H5P_DEFAULT;
    use hdf5_sys::h5s::{H5S_seloper_t, H5Sclose, H5Screate_simple, H5Sselect_hyperslab};
    // The memory space has the file selection's shape (`block` is that hyperslab, row-major):
    // HDF5 then maps memory to file a block at a time. With a one-dimensional memory space it
    // maps them an element at a time, which made writing the text columns (one element per
    // character) most of the time a file took to write.
    let rank = count.len() as std::ffi::c_int;
    // SAFETY: `d.id()` and `mem_type` are open ids (borrowed for the call); the file space
    // selects `count` elements starting at `start` (inside the dataset: the callers' chunks), the
    // memory space is the same `count` elements of `mem_type`, which `block` holds exactly; both
    // spaces are closed before returning; the calls run under hdf5-metno's global lock.
    let r = hdf5::sync::sync(|| unsafe {
        let file_space = H5Dget_space(d.id());
        if file_space < 0 {
            return -1;
        }
        let mut r = H5Sselect_hyperslab(
            file_space,
            H5S_seloper_t::H5S_SELECT_SET,
            start.as_ptr(),
            std::ptr::null(),
            count.as_ptr(),
            std::ptr::null(),
        );
        let mem_space = H5Screate_simple(rank, count.as_ptr(), std::ptr::null());
        if r >= 0 && mem_space >= 0 {
            r = H5Dwrite(
                d.id(),
                mem_type,
                mem_space,
                file_space,
                H5P_DEFAULT,
                block.as_ptr().cast(),
            );
        } else {
            r = -1;
        }
        if mem_space >= 0 {
            H5Sclose(mem_space);
        }
        H5Sclose(file_space);
        r
    });
    if r < 0 {
        return Err(Error::Other(format!("writing dataset {} failed", d.name())));
    }
    Ok(())
}

/// The text attributes of `loc` (name, text), by name: HDF5 checksums the other attributes itself
/// (they lie in object headers), but keeps text in a heap it does not check.
fn text_attrs(loc: &Location) -> Result<Vec<(String, String)>> {
    use hdf5::types::TypeDescriptor;
    let mut out = Vec::new();
    for name in loc.attr_names().map_err(crate::h5)? {
        if name == "header_checksum" {
            continue;
        }
        let a = loc.attr(&name).map_err(crate::h5)?;
        // (HDF5's own attributes, dimension-scale references among them, are no text.)
        if let Ok(TypeDescriptor::VarLenUnicode) = a.dtype().and_then(|d| d.to_descriptor()) {
            let v: VarLenUnicode = a.read_scalar().map_err(crate::h5)?;
            out.push((name, text_of(&v)));
        }
    }
    out.sort();
    Ok(out)
}

fn text_checksum(entries: &[(String, String, String)], shape: &[i64]) -> u64 {
    chainsweep_sweep::identity::checksum64(|h| {
        use sha2::Digest;
        h.update(b"chainsweep text checksum v1\n");
        for (object, name, text) in entries {
            for part in [object, name, text] {
                h.update((part.len() as u64).to_le_bytes());
                h.update(part.as_bytes());
            }
        }
        h.update(b"grid_shape");
        for x in shape {
            h.update(x.to_le_bytes());
        }
    })
}

/// The checksum of what says what a file is (the `header_checksum` root attribute): every text
/// attribute of its root (its sweep, shard, dimensions, what `integrator: auto` chose, and the
/// `column_checksums` of the summary columns' own attributes) and of its datasets other than the
/// summary columns (the coordinates: units, field, dimension), and its grid shape. Coordinate
/// values and probes are functions of the sweep text, checked against it.
pub fn header_checksum(file: &File) -> Result<u64> {
    let mut entries: Vec<(String, String, String)> = text_attrs(file)?
        .into_iter()
        .map(|(n, t)| ("/".to_string(), n, t))
        .collect();
    for member in file.member_names().map_err(crate::h5)? {
        if chainsweep_sweep::record::columns::is_column_dataset(&member) {
            continue;
        }
        if let Ok(d) = file.dataset(&member) {
            for (n, t) in text_attrs(&d)? {
                entries.push((member.clone(), n, t));
            }
        }
    }
    let shape = file
        .attr("grid_shape")
        .map_err(crate::h5)?
        .read_raw::<i64>()
        .map_err(crate::h5)?;
    Ok(text_checksum(&entries, &shape))
}

/// The checksum of a summary column's own text attributes (its units, long name, coordinates,
/// flag meanings): kept per column in the root attribute `column_checksums` (JSON, name to
/// checksum), so that a column whose dataset cannot be read costs its points, not the file.
pub fn column_text_checksum(d: &Dataset) -> Result<u64> {
    let entries: Vec<(String, String, String)> = text_attrs(d)?
        .into_iter()
        .map(|(n, t)| (String::new(), n, t))
        .collect();
    Ok(text_checksum(&entries, &[]))
}

/// Reads every element of a numeric dataset without HDF5's error-detection check (Fletcher-32):
/// a damaged chunk then reads as it is stored, and the per-point checksums say which of its
/// points are damaged, rather than HDF5 refusing the whole chunk.
pub(crate) fn read_unchecked<T: H5Type + Copy + Default>(d: &Dataset) -> Result<Vec<T>> {
    let mut buf = vec![T::default(); d.size()];
    read_all_unchecked(
        d,
        &hdf5::Datatype::from_type::<T>().map_err(crate::h5)?,
        &mut buf,
    )?;
    Ok(buf)
}

/// Reads every element of `d` into `buf` (as many elements as `d` has) as the memory type
/// `mem`, whose size is that of `E`, without HDF5's error-detection check (Fletcher-32): a
/// damaged chunk reads as it is stored.
fn read_all_unchecked<E>(d: &Dataset, mem: &hdf5::Datatype, buf: &mut [E]) -> Result<()> {
    use hdf5_sys::h5d::H5Dread;
    use hdf5_sys::h5p::{H5Pclose, H5Pcreate, H5Pset_edc_check};
    use hdf5_sys::h5s::H5S_ALL;
    use hdf5_sys::h5z::H5Z_EDC_t;
    assert_eq!(
        buf.len(),
        d.size(),
        "one element of the buffer per element of the dataset"
    );
    assert_eq!(
        mem.size(),
        std::mem::size_of::<E>(),
        "the memory type is the buffer's"
    );
    // SAFETY: `d.id()` and `mem.id()` are open ids (borrowed for the call); `buf` holds exactly
    // the dataset's elements, each of `mem`'s size (checked above; H5S_ALL selects them all, and
    // HDF5 converts to `mem`); the property list is created and closed here; all under
    // hdf5-metno's global lock, as every call into the library must be.
    let r = hdf5::sync::sync(|| unsafe {
        let xfer = H5Pcreate(*hdf5::globals::H5P_DATASET_XFER);
        if xfer < 0 {
            return -1;
        }
        let mut r = H5Pset_edc_check(xfer, H5Z_EDC_t::H5Z_DISABLE_EDC);
        if r >= 0 && !buf.is_empty() {
            r = H5Dread(
                d.id(),
                mem.id(),
                H5S_ALL,
                H5S_ALL,
                xfer,
                buf.as_mut_ptr().cast(),
            );
        }
        H5Pclose(xfer);
        r
    });
    if r < 0 {
        return Err(Error::Other(format!("reading dataset {} failed", d.name())));
    }
    Ok(())
}

/// Whether every chunk of `d` passes HDF5's error-detection check (Fletcher-32), as h5py and
/// xarray read it: its whole contents read in its own type with the check on. (The readers here
/// read values unchecked and check them against the points' checksums; a damaged checksum of a
/// chunk whose values are intact is found by this alone.)
pub(crate) fn passes_filter_check(d: &Dataset) -> Result<()> {
    use hdf5_sys::h5d::H5Dread;
    use hdf5_sys::h5p::H5P_DEFAULT;
    use hdf5_sys::h5s::H5S_ALL;
    let ty = d.dtype().map_err(crate::h5)?;
    let mut buf = vec![0u8; d.size() * ty.size()];
    if buf.is_empty() {
        return Ok(());
    }
    // SAFETY: `d.id()` and `ty.id()` are open ids (borrowed for the call); `buf` holds every
    // element of the dataset in its own type (`d.size()` elements of `ty.size()` bytes), which
    // H5S_ALL selects, so HDF5 converts nothing and writes within it (a variable-length type
    // would allocate, but these datasets hold numbers and characters); under hdf5-metno's
    // global lock.
    let r = hdf5::sync::sync(|| unsafe {
        H5Dread(
            d.id(),
            ty.id(),
            H5S_ALL,
            H5S_ALL,
            H5P_DEFAULT,
            buf.as_mut_ptr().cast(),
        )
    });
    if r < 0 {
        return Err(Error::Other(format!(
            "dataset {} fails HDF5's check (Fletcher-32)",
            d.name()
        )));
    }
    Ok(())
}

/// The values of numeric dataset `name` of the file `path` (or the characters of a text stored as
/// netCDF `char`s, numpy dtype `S1`), read without the Fletcher-32 check (for a reader that masks
/// the damaged points of a chunk and serves the others): their bytes (little endian, C order),
/// their numpy dtype name, and the dataset's shape.
pub fn read_numeric_unchecked(
    path: &Path,
    name: &str,
) -> Result<(Vec<u8>, &'static str, Vec<usize>)> {
    use hdf5::types::{FloatSize, IntSize, TypeDescriptor};
    let f = File::open(path).map_err(crate::h5)?;
    let d = f.dataset(name).map_err(crate::h5)?;
    let shape = d.shape();
    let le = |b: Vec<[u8; 8]>| b.concat();
    Ok(
        match d
            .dtype()
            .map_err(crate::h5)?
            .to_descriptor()
            .map_err(crate::h5)?
        {
            TypeDescriptor::Float(FloatSize::U8) => (
                le(read_unchecked::<f64>(&d)?
                    .iter()
                    .map(|x| x.to_le_bytes())
                    .collect()),
                "float64",
                shape,
            ),
            TypeDescriptor::Integer(IntSize::U8) => (
                le(read_unchecked::<i64>(&d)?
                    .iter()
                    .map(|x| x.to_le_bytes())
                    .collect()),
                "int64",
                shape,
            ),
            TypeDescriptor::Unsigned(IntSize::U8) => (
                le(read_unchecked::<u64>(&d)?
                    .iter()
                    .map(|x| x.to_le_bytes())
                    .collect()),
                "uint64",
                shape,
            ),
            TypeDescriptor::Unsigned(IntSize::U1) => (read_unchecked::<u8>(&d)?, "uint8", shape),
            // Text as netCDF `char`s: its bytes, one per character.
            TypeDescriptor::FixedAscii(1) | TypeDescriptor::FixedUnicode(1) => {
                (read_chars(&d)?, "S1", shape)
            }
            other => {
                return Err(Error::Other(format!(
                    "dataset {name} holds {other:?}, not numbers"
                )))
            }
        },
    )
}

pub(crate) fn vlen(s: &str) -> Result<VarLenUnicode> {
    s.replace('\0', "\u{FFFD}")
        .parse::<VarLenUnicode>()
        .map_err(|e| Error::Other(format!("string not storable in HDF5: {e}")))
}

/// Writes a scalar variable-length UTF-8 string attribute (h5py returns `str`).
pub(crate) fn attr_str(loc: &Location, name: &str, value: &str) -> Result<()> {
    let a = loc
        .new_attr::<VarLenUnicode>()
        .shape(())
        .create(name)
        .map_err(crate::h5)?;
    a.write_scalar(&vlen(value)?).map_err(crate::h5)?;
    Ok(())
}

pub(crate) fn attr_scalar<T: H5Type>(loc: &Location, name: &str, value: T) -> Result<()> {
    let a = loc
        .new_attr::<T>()
        .shape(())
        .create(name)
        .map_err(crate::h5)?;
    a.write_scalar(&value).map_err(crate::h5)?;
    Ok(())
}

pub(crate) fn attr_vec<T: H5Type>(loc: &Location, name: &str, values: &[T]) -> Result<()> {
    let a = loc
        .new_attr::<T>()
        .shape(values.len())
        .create(name)
        .map_err(crate::h5)?;
    a.write_raw(values).map_err(crate::h5)?;
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
        .create(name)
        .map_err(crate::h5)?;
    if !data.is_empty() {
        d.write_raw(data).map_err(crate::h5)?;
    }
    Ok(d)
}

/// Creates (or truncates) an output file at `path`, in HDF5's 1.10 format: the library checksums
/// its own metadata (superblock, object headers, chunk indexes), so damage to it is an error,
/// never a misread (HDF5 1.10 readers, netCDF-C and h5py read it); without objects' times, so
/// that the same runs give the same bytes.
pub(crate) fn create_file(path: &Path) -> Result<File> {
    File::with_options()
        .with_fapl(|p| {
            p.libver_bounds(
                hdf5::file::LibraryVersion::V110,
                hdf5::file::LibraryVersion::V110,
            )
        })
        .with_fcpl(|p| p.obj_track_times(false))
        .create(path)
        .map_err(crate::h5)
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
    /// Successful runs (settled, where a steady state is recorded).
    pub ok: usize,
    /// Failed runs.
    pub failed: usize,
    /// Points not run (or not in this shard).
    pub pending: usize,
    /// Runs that finished but whose steady state did not settle
    /// ([`chainsweep_sweep::record::STATUS_UNSETTLED`]).
    pub unsettled: usize,
}

impl Counts {
    /// Finished runs: ok, unsettled or failed.
    pub fn done(&self) -> usize {
        self.ok + self.unsettled + self.failed
    }

    /// `N ok, [M unsettled, ]K failed`: the finished runs as every report words them (the
    /// unsettled ones only where there are some).
    pub fn finished_text(&self) -> String {
        if self.unsettled > 0 {
            format!(
                "{} ok, {} unsettled, {} failed",
                self.ok, self.unsettled, self.failed
            )
        } else {
            format!("{} ok, {} failed", self.ok, self.failed)
        }
    }

    /// The exit code of a sweep whose points stand so: 0 when every one succeeded, 3
    /// ([`chainsweep_sweep::EXIT_PARTIAL`]) when some failed or are pending. The one mapping of the command
    /// line and of Python.
    pub fn exit_code(&self) -> i32 {
        if self.failed > 0 || self.pending > 0 || self.unsettled > 0 {
            chainsweep_sweep::EXIT_PARTIAL
        } else {
            chainsweep_sweep::EXIT_OK
        }
    }
}

/// Name of the group under `runs/` of the run at flat (row-major) grid index `index`: a name
/// that starts with a letter (a valid netCDF name: `ncdump` escapes a leading digit) and does not
/// depend on the grid's size (layout 1's zero-padding changed width as a sweep grew past 10, 100,
/// … points), so scripts can build it: `f"runs/run_{i}"`. The flat index rather than the run hash: it says where the run lies in the
/// grid (and is short), and the file is a function of the grid anyway; each group holds its
/// `run_hash` as an attribute.
pub fn run_group_name(index: usize) -> String {
    format!("run_{index}")
}

/// The run group's name in a file of layout version `layout` (1: zero-padded to the width of the
/// grid's largest flat index, for `grid_len` points).
pub fn run_group_name_in(layout: i64, grid_len: usize, index: usize) -> String {
    if layout >= 2 {
        return run_group_name(index);
    }
    let width = format!("{}", grid_len.saturating_sub(1)).len();
    format!("{index:0width$}")
}

fn read_attr_str(loc: &Location, name: &str) -> Result<String> {
    let v: VarLenUnicode = loc
        .attr(name)
        .map_err(crate::h5)?
        .read_scalar()
        .map_err(crate::h5)?;
    Ok(text_of(&v))
}

/// Reads what `integrator: auto` chose from an output file's `auto` attribute (`None` when the
/// file has none).
pub fn read_auto_choice(path: &Path) -> Result<Option<AutoChoice>> {
    let read = || -> Result<Option<String>> {
        let f = File::open(path).map_err(crate::h5)?;
        if !f
            .attr_names()
            .map_err(crate::h5)?
            .iter()
            .any(|a| a == "auto")
        {
            return Ok(None);
        }
        read_attr_str(&f, "auto").map(Some)
    };
    let text = read().map_err(|e| e.hdf5_context(|| format!("reading {}", path.display())))?;
    text.map(|t| AutoChoice::from_json(&t)).transpose()
}

/// Reads the `sweep` root attribute of an HDF5 file made by chainsweep.
pub fn read_sweep_text(path: &Path) -> Result<String> {
    File::open(path)
        .and_then(|f| f.attr("sweep")?.read_scalar::<VarLenUnicode>())
        .map(|v| text_of(&v))
        .map_err(|e| crate::h5(e).hdf5_context(|| format!("reading {}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_groups_are_named_by_flat_index_in_either_layout() {
        assert_eq!(run_group_name(3), "run_3");
        assert_eq!(run_group_name_in(LAYOUT_VERSION, 12, 3), "run_3");
        assert_eq!(run_group_name_in(LAYOUT_VERSION, 1000, 3), "run_3");
        // layout 1: padded to the width of the largest index
        assert_eq!(run_group_name_in(1, 12, 3), "03");
        assert_eq!(run_group_name_in(1, 1000, 3), "003");
        assert_eq!(run_group_name_in(1, 10, 3), "3");
    }
}
