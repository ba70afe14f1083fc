//! The damage check of an output file (`status --check`): every point checked against its
//! checksum, the runs' arrays too when asked.

use std::path::Path;

use crate::record::STATUS_OK;
use crate::store::hdf5::FileRecords;

/// What a reader of an output file (h5py, xarray) would be served: which of its points hold
/// values that do not match their checksums, read as the file stands (no snapshot).
#[derive(Debug, Clone, Default)]
pub struct FileCheck {
    /// Whether the file carries checksums (layout 3 and later).
    pub checked: bool,
    /// Why it cannot be read at all.
    pub file: Option<String>,
    /// What is wrong with its header, coordinates or probes.
    pub header: Option<String>,
    /// Damaged points: flat index, axis values (when the file's sweep can be read), why.
    pub damaged: Vec<(usize, String, String)>,
    /// Summary columns HDF5 cannot read: name, why, and whether it holds a value per probe.
    pub unreadable: Vec<(String, String, bool)>,
}

/// Checks every value of the output file `path` as it stands (its histories too with
/// `histories`), for a reader that takes the file as it is (`chainsweep.open`).
pub fn check_file(path: &Path, histories: bool) -> FileCheck {
    let mut c = FileCheck::default();
    if !crate::store::hdf5::is_hdf5(path) {
        c.file = Some("it does not start with the HDF5 signature".into());
        return c;
    }
    let recs = match FileRecords::open(path) {
        Ok(r) => r,
        Err(e) => {
            c.file = Some(format!("HDF5 cannot read it: {e}"));
            return c;
        }
    };
    c.checked = recs.checked();
    c.header = recs.header_damage.clone();
    c.unreadable = recs
        .unreadable()
        .iter()
        .map(|(n, e)| {
            let per_probe = crate::record::columns::column(n).is_some_and(|c| c.per_probe);
            (n.to_string(), e.clone(), per_probe)
        })
        .collect();
    // The file's own sweep and grid (from its checked header) label its points.
    let labelled = c
        .header
        .is_none()
        .then(|| crate::store::published::own_sweep_and_grid(&recs));
    let labelled = labelled.flatten();
    if let Some((sweep, grid)) = &labelled {
        let coords = recs.coordinate_damage(sweep, grid);
        if !coords.is_empty() {
            c.header = Some(coords.join("; "));
        }
    } else if c.header.is_none() {
        c.header = Some("its sweep cannot be expanded into a grid of its points".into());
    }
    let label = |i: usize| match &labelled {
        Some((sweep, grid)) if grid.searched.is_some() || sweep.search.is_none() => {
            grid.point_label(sweep, i)
        }
        _ => String::new(),
    };
    for i in 0..recs.len() {
        let why = match recs.damage(i) {
            Some(why) => Some(why.to_string()),
            None => match &labelled {
                Some((_, grid))
                    if histories && grid.has_run_arrays() && recs.status(i) == STATUS_OK =>
                {
                    match recs.record(i, grid.hashes[i], grid) {
                        crate::store::hdf5::read::PointRead::Damaged(why) => Some(why),
                        _ => None,
                    }
                }
                _ => None,
            },
        };
        if let Some(why) = why {
            c.damaged.push((i, label(i), why));
        }
    }
    c
}
