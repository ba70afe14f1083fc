//! Dimension scales attached to many datasets in one pass, and read back.
//!
//! `H5DSattach_scale` attaches one scale to one dimension of one dataset: it reads the dataset's
//! `DIMENSION_LIST` and writes it over one entry longer, and reads the scale's `REFERENCE_LIST`,
//! deletes it and creates it again one entry longer. Attaching the grid's scales to every summary
//! column so rewrote each scale's list once per column: about 1.3 ms of the 6 ms the Fig. 8
//! sweep's file took to write, every time it was published. [`attach_all`] leaves the same two
//! attributes, with the same types, entries and entry order as the calls one at a time would,
//! writing each once. The reader reads both back ([`dimension_list`], [`reference_list`]) to
//! check them: the first lies in the file's global heap, which no checksum covers.

use std::ffi::{c_void, CStr};
use std::os::raw::c_uint;

use hdf5::Dataset;
use hdf5_sys::h5::{herr_t, hsize_t};
use hdf5_sys::h5a::{
    H5Aclose, H5Acreate2, H5Adelete, H5Aexists, H5Aget_space, H5Aget_type, H5Aopen, H5Aread,
    H5Awrite,
};
use hdf5_sys::h5i::hid_t;
use hdf5_sys::h5p::H5P_DEFAULT;
use hdf5_sys::h5r::{hobj_ref_t, H5R_type_t, H5Rcreate};
use hdf5_sys::h5s::{H5Sclose, H5Screate_simple, H5Sget_simple_extent_npoints};
use hdf5_sys::h5t::{
    hvl_t, H5T_class_t, H5Tclose, H5Tcreate, H5Tinsert, H5Treclaim, H5Tvlen_create,
    H5T_NATIVE_UINT, H5T_STD_REF_OBJ,
};

use chainsweep_sweep::error::{Error, Result};

const DIMENSION_LIST: &CStr = c"DIMENSION_LIST";
const REFERENCE_LIST: &CStr = c"REFERENCE_LIST";

/// An entry of a scale's `REFERENCE_LIST`: the dataset it is attached to and the dimension.
/// HDF5's `ds_list_t` (an object reference of the 1.10 format and an `unsigned int`, 16 bytes
/// with the padding), whose layout the attribute's compound type gives.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Attached {
    pub(crate) dataset: hobj_ref_t,
    pub(crate) dimension: c_uint,
    /// The padding, zero: written to the file as it lies in memory.
    padding: c_uint,
}

/// An identifier that HDF5 gave and that is closed when dropped.
struct Id(hid_t, unsafe extern "C" fn(hid_t) -> herr_t);

impl Drop for Id {
    fn drop(&mut self) {
        // SAFETY: the id was returned open by HDF5 (checked where it was made) and is closed once.
        unsafe {
            (self.1)(self.0);
        }
    }
}

/// `id` as a closing [`Id`], or the failure of `what`.
fn open(id: hid_t, close: unsafe extern "C" fn(hid_t) -> herr_t, what: &str) -> Result<Id> {
    if id < 0 {
        return Err(Error::Other(format!("HDF5's {what} failed")));
    }
    Ok(Id(id, close))
}

fn ok(r: herr_t, what: &str) -> Result<()> {
    if r < 0 {
        return Err(Error::Other(format!("HDF5's {what} failed")));
    }
    Ok(())
}

/// Attaches, for each `(data, scale, dimension)` of `attachments` in order, the dimension scale
/// `scale` to that dimension of `data`, as `H5DSattach_scale` would one call at a time: every
/// `data` ends with a `DIMENSION_LIST` (a variable-length list of object references per
/// dimension, kept from before and extended) and every scale with a `REFERENCE_LIST` (kept and
/// extended in the order of the attachments), each written once. A scale already on that
/// dimension of `data` is not listed there again, though its scale's `REFERENCE_LIST` records the
/// attachment again, as `H5DSattach_scale` does.
///
/// What `H5DSattach_scale` checks is the callers' to keep: each `scale` is a dimension scale
/// ([`super::set_scale`]) with no scales of its own, no `data` is one, and each dimension is one
/// of its `data`'s.
pub(crate) fn attach_all(attachments: &[(&Dataset, &Dataset, usize)]) -> Result<()> {
    attach_each(attachments).map_err(|e| Error::Other(format!("attaching dimension scales: {e}")))
}

fn attach_each(attachments: &[(&Dataset, &Dataset, usize)]) -> Result<()> {
    hdf5::sync::sync(|| {
        // Each dataset and each scale in the order first named, with what is attached to it.
        let mut datas: Vec<(&Dataset, Vec<(hobj_ref_t, usize)>)> = Vec::new();
        let mut scales: Vec<(&Dataset, Vec<Attached>)> = Vec::new();
        let mut refs: Vec<(hid_t, hobj_ref_t)> = Vec::new();
        for &(data, scale, dim) in attachments {
            let scale_ref = reference(scale, &mut refs)?;
            let data_ref = reference(data, &mut refs)?;
            match datas.iter_mut().find(|(d, _)| d.id() == data.id()) {
                Some((_, list)) => list.push((scale_ref, dim)),
                None => datas.push((data, vec![(scale_ref, dim)])),
            }
            let entry = Attached {
                dataset: data_ref,
                dimension: dim as c_uint,
                padding: 0,
            };
            match scales.iter_mut().find(|(s, _)| s.id() == scale.id()) {
                Some((_, list)) => list.push(entry),
                None => scales.push((scale, vec![entry])),
            }
        }
        for (data, attached) in &datas {
            write_dimension_list(data, attached)?;
        }
        for (scale, entries) in &scales {
            write_reference_list(scale, entries)?;
        }
        Ok(())
    })
}

/// The object reference of `d` (looked up in `refs`, of the datasets referred to so far).
fn reference(d: &Dataset, refs: &mut Vec<(hid_t, hobj_ref_t)>) -> Result<hobj_ref_t> {
    if let Some(&(_, r)) = refs.iter().find(|(id, _)| *id == d.id()) {
        return Ok(r);
    }
    let r = object_ref(d)?;
    refs.push((d.id(), r));
    Ok(r)
}

/// The attribute `name` of the object `loc` opened, with its dataspace; `None` when it has none.
fn open_attribute(loc: hid_t, name: &CStr) -> Result<Option<(Id, Id)>> {
    // SAFETY: `loc` is an open object's id (the callers'); `name` is NUL-terminated; every id
    // made is checked and closed by its guard; under hdf5-metno's global lock (the caller's).
    unsafe {
        let what = name.to_string_lossy();
        let had = H5Aexists(loc, name.as_ptr());
        ok(had, &format!("H5Aexists({what})"))?;
        if had == 0 {
            return Ok(None);
        }
        let a = open(
            H5Aopen(loc, name.as_ptr(), H5P_DEFAULT),
            H5Aclose,
            &format!("H5Aopen({what})"),
        )?;
        let space = open(H5Aget_space(a.0), H5Sclose, "H5Aget_space")?;
        Ok(Some((a, space)))
    }
}

/// The object references of `data`'s `DIMENSION_LIST`, one list per dimension (the scales
/// attached to it), or `None` when it has none. An error where HDF5 cannot read it: the
/// variable-length lists lie in the file's global heap, which HDF5 keeps no checksum of.
pub(crate) fn dimension_list(data: &Dataset) -> Result<Option<Vec<Vec<hobj_ref_t>>>> {
    let rank = data.ndim().max(1);
    let did = data.id();
    hdf5::sync::sync(|| {
        // SAFETY: every id is checked when made and closed by its guard; the buffer read holds
        // as many elements as the attribute (checked), each a variable-length list of object
        // references, the memory type HDF5 converts the stored one to; the lists HDF5 allocates
        // are copied out and given back with H5Treclaim; under hdf5-metno's global lock.
        unsafe {
            let Some((a, space)) = open_attribute(did, DIMENSION_LIST)? else {
                return Ok(None);
            };
            let vlen = open(H5Tvlen_create(*H5T_STD_REF_OBJ), H5Tclose, "H5Tvlen_create")?;
            if H5Sget_simple_extent_npoints(space.0) != rank as i64 {
                return Err(Error::Other(
                    "a DIMENSION_LIST of another rank than its dataset".into(),
                ));
            }
            let mut buf = vec![
                hvl_t {
                    len: 0,
                    p: std::ptr::null_mut()
                };
                rank
            ];
            ok(
                H5Aread(a.0, vlen.0, buf.as_mut_ptr().cast::<c_void>()),
                "H5Aread(DIMENSION_LIST)",
            )?;
            let lists = buf
                .iter()
                .map(|v| {
                    if v.len > 0 && !v.p.is_null() {
                        std::slice::from_raw_parts(v.p.cast::<hobj_ref_t>(), v.len).to_vec()
                    } else {
                        Vec::new()
                    }
                })
                .collect();
            ok(
                H5Treclaim(
                    vlen.0,
                    space.0,
                    H5P_DEFAULT,
                    buf.as_mut_ptr().cast::<c_void>(),
                ),
                "H5Treclaim",
            )?;
            Ok(Some(lists))
        }
    })
}

/// The object reference of the dataset `d`: an old-style reference (`H5R_OBJECT1`, its
/// address in the file), the kind H5DS writes in this library's build.
pub(crate) fn object_ref(d: &Dataset) -> Result<hobj_ref_t> {
    let mut r: hobj_ref_t = 0;
    // SAFETY: `d.id()` is an open dataset's; `r` is the 8 bytes an object reference of the 1.10
    // format takes; "." names the object itself; under hdf5-metno's global lock.
    let status = hdf5::sync::sync(|| unsafe {
        H5Rcreate(
            (&mut r as *mut hobj_ref_t).cast::<c_void>(),
            d.id(),
            c".".as_ptr(),
            H5R_type_t::H5R_OBJECT1,
            -1,
        )
    });
    ok(status, "H5Rcreate")?;
    Ok(r)
}

/// Writes `data`'s `DIMENSION_LIST`: the references it had, then each `(scale, dimension)` of
/// `attached` not there already.
fn write_dimension_list(data: &Dataset, attached: &[(hobj_ref_t, usize)]) -> Result<()> {
    let rank = data.ndim().max(1);
    let did = data.id();
    let had = dimension_list(data)?;
    let mut lists = had.clone().unwrap_or_else(|| vec![Vec::new(); rank]);
    for &(scale, dim) in attached {
        let list = lists.get_mut(dim).ok_or_else(|| {
            Error::Other(format!("no dimension {dim} in a dataset of rank {rank}"))
        })?;
        if !list.contains(&scale) {
            list.push(scale);
        }
    }
    // SAFETY: every id is checked when made and closed by its guard; the buffer written holds
    // `rank` elements of the attribute's type, each pointing into `lists`, alive for the call;
    // under hdf5-metno's global lock (the caller's).
    unsafe {
        let vlen = open(H5Tvlen_create(*H5T_STD_REF_OBJ), H5Tclose, "H5Tvlen_create")?;
        // A list there already is written over, as H5DSattach_scale writes it: writing frees
        // its old lists in the global heap, which deleting the attribute would leave behind.
        let a = if had.is_some() {
            open(
                H5Aopen(did, DIMENSION_LIST.as_ptr(), H5P_DEFAULT),
                H5Aclose,
                "H5Aopen(DIMENSION_LIST)",
            )?
        } else {
            let dims = [rank as hsize_t];
            let space = open(
                H5Screate_simple(1, dims.as_ptr(), std::ptr::null()),
                H5Sclose,
                "H5Screate_simple",
            )?;
            open(
                H5Acreate2(
                    did,
                    DIMENSION_LIST.as_ptr(),
                    vlen.0,
                    space.0,
                    H5P_DEFAULT,
                    H5P_DEFAULT,
                ),
                H5Aclose,
                "H5Acreate2(DIMENSION_LIST)",
            )?
        };
        let buf: Vec<hvl_t> = lists
            .iter()
            .map(|l| hvl_t {
                len: l.len(),
                p: if l.is_empty() {
                    std::ptr::null_mut()
                } else {
                    l.as_ptr().cast_mut().cast::<c_void>()
                },
            })
            .collect();
        ok(
            H5Awrite(a.0, vlen.0, buf.as_ptr().cast::<c_void>()),
            "H5Awrite(DIMENSION_LIST)",
        )?;
        Ok(())
    }
}

/// The compound type of a `REFERENCE_LIST` entry in memory, [`Attached`]'s layout.
fn entry_type() -> Result<Id> {
    // SAFETY: the type made is checked and closed by its guard; the members lie within
    // `Attached` at its fields' offsets; under hdf5-metno's global lock (the caller's).
    unsafe {
        let memory = open(
            H5Tcreate(H5T_class_t::H5T_COMPOUND, std::mem::size_of::<Attached>()),
            H5Tclose,
            "H5Tcreate",
        )?;
        ok(
            H5Tinsert(
                memory.0,
                c"dataset".as_ptr(),
                std::mem::offset_of!(Attached, dataset),
                *H5T_STD_REF_OBJ,
            ),
            "H5Tinsert(dataset)",
        )?;
        ok(
            H5Tinsert(
                memory.0,
                c"dimension".as_ptr(),
                std::mem::offset_of!(Attached, dimension),
                *H5T_NATIVE_UINT,
            ),
            "H5Tinsert(dimension)",
        )?;
        Ok(memory)
    }
}

/// `scale`'s `REFERENCE_LIST` read in the memory type `memory` ([`entry_type`]), with its stored
/// type; `None` when it has none.
fn read_reference_list(scale: &Dataset, memory: &Id) -> Result<Option<(Vec<Attached>, Id)>> {
    let sid = scale.id();
    // SAFETY: every id is checked when made and closed by its guard; the buffer read holds as
    // many `Attached` as the attribute has elements, in `memory` (HDF5 converts the stored type
    // to it by member name); under hdf5-metno's global lock (the caller's).
    unsafe {
        let Some((a, space)) = open_attribute(sid, REFERENCE_LIST)? else {
            return Ok(None);
        };
        let n = H5Sget_simple_extent_npoints(space.0);
        if n < 0 {
            return Err(Error::Other(
                "HDF5's H5Sget_simple_extent_npoints failed".into(),
            ));
        }
        let mut entries = vec![
            Attached {
                dataset: 0,
                dimension: 0,
                padding: 0,
            };
            n as usize
        ];
        ok(
            H5Aread(a.0, memory.0, entries.as_mut_ptr().cast::<c_void>()),
            "H5Aread(REFERENCE_LIST)",
        )?;
        let stored = open(H5Aget_type(a.0), H5Tclose, "H5Aget_type")?;
        Ok(Some((entries, stored)))
    }
}

/// The entries of `scale`'s `REFERENCE_LIST` (the datasets it labels and their dimensions), or
/// `None` when it has none.
pub(crate) fn reference_list(scale: &Dataset) -> Result<Option<Vec<Attached>>> {
    hdf5::sync::sync(|| {
        let memory = entry_type()?;
        Ok(read_reference_list(scale, &memory)?.map(|(entries, _)| entries))
    })
}

/// Writes `scale`'s `REFERENCE_LIST`: the entries it had, then `new`.
fn write_reference_list(scale: &Dataset, new: &[Attached]) -> Result<()> {
    if new.is_empty() {
        return Ok(());
    }
    let sid = scale.id();
    let memory = entry_type()?;
    let (mut entries, stored) = match read_reference_list(scale, &memory)? {
        Some((entries, stored)) => (entries, Some(stored)),
        None => (Vec::new(), None),
    };
    entries.extend_from_slice(new);
    // SAFETY: every id is checked when made and closed by its guard; the buffer written holds
    // as many `Attached` as the attribute has elements, in `memory`; under hdf5-metno's global
    // lock (the caller's).
    unsafe {
        if stored.is_some() {
            ok(
                H5Adelete(sid, REFERENCE_LIST.as_ptr()),
                "H5Adelete(REFERENCE_LIST)",
            )?;
        }
        let dims = [entries.len() as hsize_t];
        let space = open(
            H5Screate_simple(1, dims.as_ptr(), std::ptr::null()),
            H5Sclose,
            "H5Screate_simple",
        )?;
        // The stored type is kept when the list is extended, as H5DSattach_scale keeps it.
        let file_type = stored.as_ref().map_or(memory.0, |t| t.0);
        let a = open(
            H5Acreate2(
                sid,
                REFERENCE_LIST.as_ptr(),
                file_type,
                space.0,
                H5P_DEFAULT,
                H5P_DEFAULT,
            ),
            H5Aclose,
            "H5Acreate2(REFERENCE_LIST)",
        )?;
        ok(
            H5Awrite(a.0, memory.0, entries.as_ptr().cast::<c_void>()),
            "H5Awrite(REFERENCE_LIST)",
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hdf5::File;
    use hdf5_sys::h5::htri_t;

    extern "C" {
        fn H5DSattach_scale(did: hid_t, dsid: hid_t, idx: c_uint) -> herr_t;
        fn H5DSdetach_scale(did: hid_t, dsid: hid_t, idx: c_uint) -> herr_t;
        fn H5DSis_attached(did: hid_t, dsid: hid_t, idx: c_uint) -> htri_t;
        fn H5DSget_num_scales(did: hid_t, idx: c_uint) -> std::os::raw::c_int;
    }

    /// What HDF5's own dimension-scale functions read of `file`: for each dataset and dimension,
    /// the scales attached (asked of both lists, as H5DSis_attached does) and how many there are;
    /// the length of each scale's REFERENCE_LIST.
    fn seen(file: &File, datas: &[&str], scales: &[&str]) -> Vec<String> {
        let mut out = Vec::new();
        for &n in datas {
            let d = file.dataset(n).unwrap();
            for k in 0..d.ndim() {
                let count = hdf5::sync::sync(|| unsafe { H5DSget_num_scales(d.id(), k as c_uint) });
                out.push(format!("{n}[{k}]: {count} scales"));
                for &s in scales {
                    let s_d = file.dataset(s).unwrap();
                    let on = hdf5::sync::sync(|| unsafe {
                        H5DSis_attached(d.id(), s_d.id(), k as c_uint)
                    });
                    out.push(format!("{n}[{k}] {s}: {on}"));
                }
            }
        }
        // The lists themselves, in order, their references named.
        let all: Vec<&str> = datas.iter().chain(scales).copied().collect();
        let name_of = |r: &hobj_ref_t| {
            all.iter()
                .find(|n| object_ref(&file.dataset(n).unwrap()).unwrap() == *r)
                .copied()
                .unwrap_or("?")
        };
        for &n in datas {
            if let Some(lists) = dimension_list(&file.dataset(n).unwrap()).unwrap() {
                let named: Vec<Vec<&str>> = lists
                    .iter()
                    .map(|l| l.iter().map(name_of).collect())
                    .collect();
                out.push(format!("{n} DIMENSION_LIST {named:?}"));
            }
        }
        for &s in scales {
            let entries = reference_list(&file.dataset(s).unwrap()).unwrap();
            let named: Vec<(&str, u32)> = entries
                .iter()
                .flatten()
                .map(|e| (name_of(&e.dataset), e.dimension))
                .collect();
            out.push(format!("{s}: {} in REFERENCE_LIST {named:?}", named.len()));
        }
        out
    }

    /// A file of two scales `x` (3) and `y` (2), `a` (3 × 2) and `b` (3 × 2), a text column
    /// `t` (3 × 4) already given its characters' scale `c`, and `u` (3) attached to `x` already;
    /// then `attachments` made, by `attach_all` or one at a time.
    fn build(path: &std::path::Path, together: bool) -> File {
        let file = File::create(path).unwrap();
        let scale = |name: &str, len: usize| {
            let d = file.new_dataset::<f64>().shape(len).create(name).unwrap();
            super::super::set_scale(&d, name).unwrap();
            d
        };
        let (x, y, c) = (scale("x", 3), scale("y", 2), scale("c", 4));
        let a = file.new_dataset::<f64>().shape((3, 2)).create("a").unwrap();
        let b = file.new_dataset::<f64>().shape((3, 2)).create("b").unwrap();
        let t = file.new_dataset::<u8>().shape((3, 4)).create("t").unwrap();
        let u = file.new_dataset::<f64>().shape(3).create("u").unwrap();
        super::super::attach_scale(&t, &c, 1, "c").unwrap();
        super::super::attach_scale(&u, &x, 0, "x").unwrap();
        // `a` on `x` twice: listed once on `a`, twice on `x`, as H5DSattach_scale leaves them.
        let attachments = [
            (&a, &x, 0),
            (&a, &y, 1),
            (&b, &x, 0),
            (&a, &x, 0),
            (&b, &y, 1),
            (&t, &x, 0),
        ];
        if together {
            attach_all(&attachments).unwrap();
        } else {
            for (d, s, k) in attachments {
                super::super::attach_scale(d, s, k, "").unwrap();
            }
        }
        file
    }

    #[test]
    fn scales_attached_together_read_as_attached_one_at_a_time() {
        let dir = tempfile::tempdir().unwrap();
        let one = build(&dir.path().join("one.h5"), false);
        let all = build(&dir.path().join("all.h5"), true);
        let (datas, scales) = (["a", "b", "t", "u"], ["x", "y", "c"]);
        let expected = seen(&one, &datas, &scales);
        assert!(
            expected.iter().any(|l| l.starts_with(
                r#"x: 5 in REFERENCE_LIST [("u", 0), ("a", 0), ("b", 0), ("a", 0), ("t", 0)]"#
            )),
            "{expected:?}"
        );
        assert_eq!(seen(&all, &datas, &scales), expected);
        // HDF5's own functions go on from the lists written together: detaching `b` from `x`,
        // attaching `y` to `t`'s second dimension.
        for file in [&one, &all] {
            let (b, x) = (file.dataset("b").unwrap(), file.dataset("x").unwrap());
            let r = hdf5::sync::sync(|| unsafe { H5DSdetach_scale(b.id(), x.id(), 0) });
            assert!(r >= 0);
            let (t, y) = (file.dataset("t").unwrap(), file.dataset("y").unwrap());
            let r = hdf5::sync::sync(|| unsafe { H5DSattach_scale(t.id(), y.id(), 1) });
            assert!(r >= 0);
        }
        assert_eq!(seen(&all, &datas, &scales), seen(&one, &datas, &scales));
    }
}
