//! The reader: an output file's records read back (for resume, `merge` and `status`), column by
//! column as [`COLUMNS`] defines them, every point checked against its checksum.
//!
//! A damaged file is read as far as it can be: a column HDF5 cannot read, or a point whose values
//! do not match its `summary_checksum`, damages only the points concerned
//! ([`FileRecords::damage`]), each with the reason; the others are served as stored. Only a file
//! whose points cannot be told apart (no readable `status` or `run_hash`) fails to open. Numeric
//! columns are read without HDF5's Fletcher-32 check, so that a damaged chunk costs the points
//! whose checksums fail, not every point of the chunk.

use std::path::Path;
use std::sync::OnceLock;

use chainsweep_solver::observe::probes::History;
use hdf5::{Dataset, File};

use super::arrays::ArrayReader;
use super::scales;
use super::write::{coord_of, Coord};
use super::{
    column_text_checksum, header_checksum, passes_filter_check, read_attr_str, read_text,
    read_unchecked, run_group_name_in, ARRAYS_LAYOUT, LAYOUT_VERSION, UNNAMED_PENDING_LAYOUT,
};
use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::grid::Grid;
use chainsweep_sweep::identity::RunHash;
use chainsweep_sweep::record::columns::{
    distinct_units, history_checksum, split_name, Column, ColumnData, Dtype, Table, Units, COLUMNS,
    HARMONIC,
};
use chainsweep_sweep::record::{
    RunArrays, RunRecord, VerifyInfo, STATUS_FAILED, STATUS_OK, STATUS_PENDING, STATUS_UNSETTLED,
};
use chainsweep_sweep::sweep::Sweep;

/// The first layout whose files carry checksums.
pub const CHECKED_LAYOUT: i64 = 3;

/// A point of a file, read back.
#[derive(Debug, Clone, PartialEq)]
pub enum PointRead {
    /// Not run (or not in this file's shard).
    Pending,
    /// A finished run (ok or failed), its stored values checked.
    Run(Box<RunRecord>),
    /// Its stored values cannot be trusted: why.
    Damaged(String),
}

/// A sweep file's records read back from an HDF5 file.
pub struct FileRecords {
    /// The `sweep` root attribute (the sweep file's text; empty when it cannot be read).
    pub sweep_text: String,
    /// The `verify_fraction` root attribute (0 in files without it).
    pub verify_fraction: f64,
    /// The `shard` root attribute (`K/N`).
    pub shard: String,
    /// The `layout_version` root attribute (1 in files without it).
    pub layout_version: i64,
    /// What is wrong with the attributes that say what the file is (its sweep, shard, shape):
    /// they do not match their checksum, or cannot be read. Its points may still be sound: a
    /// caller that knows the sweep checks them by their run hashes.
    pub header_damage: Option<String>,
    file: File,
    /// Every summary column the file has.
    table: Table,
    /// The datasets each column of [`COLUMNS`] was read from (none where the file has none).
    column_names: Vec<Vec<String>>,
    /// Columns HDF5 could not read, with the error.
    unreadable: Vec<(&'static str, String)>,
    /// Per point: why its values cannot be trusted.
    damage: Vec<Option<String>>,
    /// The runs' arrays (layout 5 and later), opened at the first run read: or why they cannot
    /// be.
    arrays: OnceLock<std::result::Result<ArrayReader, String>>,
}

fn read_column(d: &Dataset, dtype: Dtype) -> Result<ColumnData> {
    Ok(match dtype {
        Dtype::F64 => ColumnData::F64(read_unchecked(d)?),
        Dtype::I64 => ColumnData::I64(read_unchecked(d)?),
        Dtype::U8 => ColumnData::U8(read_unchecked(d)?),
        Dtype::U64 => ColumnData::U64(read_unchecked(d)?),
        Dtype::Str => ColumnData::Str(read_text(d)?),
    })
}

/// The datasets holding column `c` in `file`: the one named like it, or, for a column in the
/// probes' unit in a file whose probes' units differ, one per unit ([`split_name`]) with the units
/// of the probes (`probe_units`). Empty where the file has none of them.
fn column_datasets(file: &File, c: &Column) -> Result<(Vec<String>, Vec<String>)> {
    if file.link_exists(c.name) || c.units != Units::OfProbes || !file.link_exists("probe_units") {
        let names = if file.link_exists(c.name) {
            vec![c.name.to_string()]
        } else {
            Vec::new()
        };
        return Ok((names, Vec::new()));
    }
    let units = read_text(&file.dataset("probe_units").map_err(crate::h5)?)?;
    let names: Vec<String> = distinct_units(&units)
        .iter()
        .map(|u| split_name(c.name, u))
        .collect();
    if !names.iter().any(|n| file.link_exists(n)) {
        return Ok((Vec::new(), Vec::new()));
    }
    Ok((names, units))
}

/// Column `c` of `file` as its datasets hold it ([`column_datasets`]): a column split by unit
/// takes each probe's values from the dataset of its unit.
fn read_column_of(
    file: &File,
    c: &Column,
    names: &[String],
    units: &[String],
    nh: usize,
) -> Result<ColumnData> {
    if units.is_empty() {
        return read_column(&file.dataset(&names[0]).map_err(crate::h5)?, c.dtype);
    }
    let np = units.len();
    // Values per probe: one per harmonic in the steady state's amplitudes.
    let per = if c.per_harmonic { nh.max(1) } else { 1 };
    let mut out: Option<Vec<f64>> = None;
    for (name, u) in names.iter().zip(distinct_units(units)) {
        let part: Vec<f64> = read_unchecked(&file.dataset(name).map_err(crate::h5)?)?;
        let out = out.get_or_insert_with(|| vec![f64::NAN; part.len()]);
        if part.len() != out.len() || part.len() % np != 0 {
            return Err(Error::Other(format!(
                "{name} holds the wrong number of values"
            )));
        }
        for (k, x) in part.iter().enumerate() {
            if units[k / per % np] == u {
                out[k] = *x;
            }
        }
    }
    Ok(ColumnData::F64(out.unwrap_or_default()))
}

fn column_len(d: &ColumnData) -> usize {
    match d {
        ColumnData::F64(v) => v.len(),
        ColumnData::I64(v) => v.len(),
        ColumnData::U8(v) => v.len(),
        ColumnData::U64(v) => v.len(),
        ColumnData::Str(v) => v.len(),
    }
}

/// An HDF5 error as a reader reports it: the library's message without its error stack.
fn brief(e: &Error) -> String {
    let t = e.to_string();
    t.lines().next().unwrap_or("").to_string()
}

impl FileRecords {
    /// Opens a file and reads and checks its columns. An error only when HDF5 cannot open it or
    /// its points cannot be told apart (`status` or `run_hash` unreadable); other damage is kept
    /// per point ([`FileRecords::damage`]) and in [`FileRecords::header_damage`].
    pub fn open(path: &Path) -> Result<FileRecords> {
        FileRecords::read(path, false)
            .map_err(|e| e.hdf5_context(|| format!("reading {}", path.display())))
    }

    /// [`FileRecords::open`] of a file whose bytes are known to be exactly those published (their
    /// SHA-256 the one its snapshot recorded when it was written from checked records): its
    /// points' values are not checked against their checksums again (every other check is made).
    pub fn open_as_published(path: &Path) -> Result<FileRecords> {
        FileRecords::read(path, true)
            .map_err(|e| e.hdf5_context(|| format!("reading {}", path.display())))
    }

    fn read(path: &Path, as_published: bool) -> Result<FileRecords> {
        let file = File::open(path).map_err(crate::h5)?;
        // The root's attributes listed once: a list that cannot be read is a damaged file, not
        // one of an early layout without them (which would have its runs taken as unchecked).
        let root_attrs = file.attr_names().map_err(|e| {
            Error::Other(format!(
                "its attributes cannot be listed ({})",
                brief(&crate::h5(e))
            ))
        })?;
        let has_attr = |name: &str| root_attrs.iter().any(|x| x == name);
        let layout_version = if has_attr("layout_version") {
            file.attr("layout_version")
                .map_err(crate::h5)?
                .read_scalar::<i64>()
                .map_err(crate::h5)?
        } else {
            1
        };
        if layout_version > LAYOUT_VERSION {
            return Err(Error::Other(format!(
                "the file has layout version {layout_version}, this chainsweep reads versions up to {LAYOUT_VERSION}: it was made by a newer chainsweep"
            )));
        }
        let mut header_damage = None;
        let mut attr = |name: &str| match read_attr_str(&file, name) {
            Ok(t) => t,
            Err(e) => {
                header_damage.get_or_insert(format!(
                    "its `{name}` attribute cannot be read ({})",
                    brief(&e)
                ));
                String::new()
            }
        };
        let sweep_text = attr("sweep");
        let shard = attr("shard");
        let verify_fraction = if has_attr("verify_fraction") {
            file.attr("verify_fraction")
                .and_then(|a| a.read_scalar::<f64>())
                .unwrap_or(f64::NAN)
        } else {
            0.0
        };
        let mut unreadable = Vec::new();
        // The steady state's harmonics: the length of their coordinate (0 without).
        let nh = if file.link_exists(HARMONIC) {
            file.dataset(HARMONIC).map_or(0, |d| d.size())
        } else {
            0
        };
        let mut columns = Vec::with_capacity(COLUMNS.len());
        let mut column_names = Vec::with_capacity(COLUMNS.len());
        for c in COLUMNS {
            let mut read_names = Vec::new();
            let read = column_datasets(&file, c).and_then(|(names, units)| {
                if names.is_empty() && !c.required {
                    return Ok(None);
                }
                read_names = if names.is_empty() {
                    vec![c.name.to_string()]
                } else {
                    names
                };
                read_column_of(&file, c, &read_names, &units, nh).map(Some)
            });
            column_names.push(read_names);
            columns.push(match read {
                Ok(d) => d,
                Err(e) => {
                    unreadable.push((c.name, brief(&e)));
                    None
                }
            });
        }
        let at = |name: &str| {
            COLUMNS
                .iter()
                .position(|c| c.name == name)
                .expect("a column")
        };
        let n = match (&columns[at("status")], &columns[at("run_hash")]) {
            (Some(s), Some(h)) if column_len(s) == column_len(h) => column_len(s),
            _ => {
                let why = unreadable
                    .iter()
                    .map(|(name, e)| format!("`{name}`: {e}"))
                    .collect::<Vec<_>>()
                    .join("; ");
                return Err(Error::Other(format!(
                    "its points cannot be told apart: the `status` and `run_hash` datasets cannot be read ({why})"
                )));
            }
        };
        // Probes: the width of the per-probe columns.
        let np = COLUMNS
            .iter()
            .zip(&columns)
            .find_map(|(c, d)| {
                d.as_ref()
                    .filter(|_| c.per_probe && !c.per_harmonic)
                    .map(column_len)
            })
            .map_or(0, |len| len.checked_div(n).unwrap_or(0));
        // A column of the wrong length is damaged (its shape was): left out, like an unreadable one.
        for (c, d) in COLUMNS.iter().zip(columns.iter_mut()) {
            let want = n * c.width(np, nh);
            if d.as_ref().is_some_and(|d| column_len(d) != want) {
                unreadable.push((c.name, "holds the wrong number of values".to_string()));
                *d = None;
            }
        }
        let table = Table { n, np, nh, columns };
        let mut recs = FileRecords {
            sweep_text,
            verify_fraction,
            shard,
            layout_version,
            header_damage,
            file,
            table,
            column_names,
            unreadable,
            damage: vec![None; n],
            arrays: OnceLock::new(),
        };
        recs.check_points(as_published);
        Ok(recs)
    }

    /// Finds every damaged point: a status outside the known codes, and (layout 3 and later) a
    /// point whose values do not match its `summary_checksum` (not computed again with
    /// `as_published`, see [`FileRecords::open_as_published`]); checks the header.
    fn check_points(&mut self, as_published: bool) {
        let unreadable = self
            .unreadable
            .iter()
            .map(|(name, e)| format!("`{name}` cannot be read: {e}"))
            .collect::<Vec<_>>()
            .join("; ");
        let checked = self.layout_version >= CHECKED_LAYOUT;
        let sums = checked && !(as_published && self.unreadable.is_empty());
        let pending =
            (self.layout_version >= UNNAMED_PENDING_LAYOUT).then(|| self.table.pending_checksum());
        for i in 0..self.table.n {
            let st = self.table.status(i);
            let why = if ![STATUS_PENDING, STATUS_OK, STATUS_FAILED, STATUS_UNSETTLED].contains(&st)
            {
                Some(format!(
                    "its status code {st} is none of 0 (pending), 1 (ok), 2 (failed), 3 (unsettled)"
                ))
            } else if sums && !self.table.checks_out(i, pending) {
                Some(if unreadable.is_empty() {
                    "its stored values do not match their checksum (summary_checksum)".to_string()
                } else {
                    unreadable.clone()
                })
            } else {
                None
            };
            self.damage[i] = why;
        }
        if checked && self.header_damage.is_none() {
            let stored = self
                .file
                .attr("header_checksum")
                .and_then(|a| a.read_scalar::<u64>());
            self.header_damage = match (stored, header_checksum(&self.file)) {
                (Ok(want), Ok(got)) if want == got => None,
                (Ok(_), Ok(_)) => Some(
                    "its header (its sweep, dimensions, units and the other text attributes) does not match its checksum (header_checksum)"
                        .to_string(),
                ),
                (Err(e), _) => Some(format!(
                    "its header checksum cannot be read ({})",
                    brief(&crate::h5(e))
                )),
                (_, Err(e)) => Some(format!("its header cannot be read ({})", brief(&e))),
            };
        }
        if checked && self.header_damage.is_none() {
            self.header_damage = self.column_attr_damage();
        }
        if checked && self.header_damage.is_none() {
            self.header_damage = self.structure_damage();
        }
        if checked && self.header_damage.is_none() {
            self.header_damage = self.scales_damage();
        }
    }

    /// What is wrong with the dimension scales of the file's datasets: a `DIMENSION_LIST` that
    /// cannot be read (its lists lie in the global heap, which neither HDF5 nor the file's
    /// checksums cover), or one naming an object that is not a dataset of the file's root whose
    /// first dimension is as long as that dimension and whose `REFERENCE_LIST` lists it there.
    /// h5py and xarray read these lists to label every variable, so a damaged one is reported
    /// here rather than met there.
    /// Every object and attribute a reader meets at the root, opened: each dataset's header,
    /// type and shape and each of its attributes, and the root's attributes, as h5py, xarray and
    /// netCDF read them; one that HDF5 cannot read (its metadata checksum fails) is damage,
    /// reported here rather than met there.
    fn structure_damage(&self) -> Option<String> {
        let names = match self.file.member_names() {
            Ok(n) => n,
            Err(e) => {
                return Some(format!(
                    "its members cannot be listed ({})",
                    brief(&crate::h5(e))
                ))
            }
        };
        let attrs_of = |loc: &hdf5::Location, what: &str| -> Option<String> {
            let names = match loc.attr_names() {
                Ok(n) => n,
                Err(e) => {
                    return Some(format!(
                        "the attributes of {what} cannot be listed ({})",
                        brief(&crate::h5(e))
                    ))
                }
            };
            for a in names {
                if let Err(e) = loc.attr(&a).and_then(|x| x.dtype().map(|_| x)) {
                    return Some(format!(
                        "the attribute `{a}` of {what} cannot be read ({})",
                        brief(&crate::h5(e))
                    ));
                }
            }
            None
        };
        if let Some(why) = attrs_of(&self.file, "the file") {
            return Some(why);
        }
        // (The columns' own datasets are checked where they are read: one that cannot be read
        // is damage of each of its points, which the intact others are served beside.)
        let columns: std::collections::HashSet<&str> = self
            .column_names
            .iter()
            .flatten()
            .map(String::as_str)
            .chain(COLUMNS.iter().map(|c| c.name))
            .collect();
        for name in names {
            if columns.contains(name.as_str()) || self.file.group(&name).is_ok() {
                continue; // (and the run groups of early layouts: checked run by run)
            }
            let what = format!("`{name}`");
            let ds = match self.file.dataset(&name) {
                Ok(d) => d,
                Err(e) => {
                    return Some(format!(
                        "{what} cannot be opened ({})",
                        brief(&crate::h5(e))
                    ))
                }
            };
            if let Err(e) = ds.dtype() {
                return Some(format!(
                    "the type of {what} cannot be read ({})",
                    brief(&crate::h5(e))
                ));
            }
            if let Some(why) = attrs_of(&ds, &what) {
                return Some(why);
            }
        }
        None
    }

    fn scales_damage(&self) -> Option<String> {
        let names = match self.file.member_names() {
            Ok(n) => n,
            Err(e) => {
                return Some(format!(
                    "its members cannot be listed ({})",
                    brief(&crate::h5(e))
                ))
            }
        };
        // Every dataset of the root with its reference and shape.
        let mut datasets = Vec::with_capacity(names.len());
        for name in names {
            // (Not a dataset: the runs' groups of an older layout. A dataset HDF5 cannot open is
            // the other checks' to report: a summary column that cannot be read costs its
            // points, not the whole file.)
            let Ok(d) = self.file.dataset(&name) else {
                continue;
            };
            let r = match scales::object_ref(&d) {
                Ok(r) => r,
                Err(e) => return Some(format!("`{name}` cannot be read ({})", brief(&e))),
            };
            datasets.push((name, d, r));
        }
        // What each scale's REFERENCE_LIST says it labels, `(scale, dataset, dimension)`: it lies
        // in the scale's object header, which HDF5 checksums, so a list of a dataset's scales
        // must agree with it (a damaged one could otherwise name another scale of the same
        // length).
        let mut labelled = Vec::new();
        for (name, d, r) in &datasets {
            match scales::reference_list(d) {
                Ok(Some(entries)) => labelled.extend(
                    entries
                        .into_iter()
                        .map(|e| (*r, e.dataset, e.dimension as usize)),
                ),
                Ok(None) => {}
                Err(e) => {
                    return Some(format!(
                        "what the dimension scale `{name}` labels cannot be read ({})",
                        brief(&e)
                    ))
                }
            }
        }
        for (name, d, data_ref) in &datasets {
            let lists = match scales::dimension_list(d) {
                Ok(Some(lists)) => lists,
                Ok(None) => continue,
                Err(e) => {
                    return Some(format!(
                        "the dimension scales of `{name}` cannot be read ({})",
                        brief(&e)
                    ))
                }
            };
            let shape = d.shape();
            for (k, list) in lists.iter().enumerate() {
                let extent = shape.get(k).copied().unwrap_or(1);
                for r in list {
                    let scale = datasets.iter().find(|(_, _, sr)| sr == r);
                    // (A text coordinate is a scale of its first dimension.)
                    if !scale.is_some_and(|(_, s, _)| s.shape().first() == Some(&extent))
                        || !labelled.contains(&(*r, *data_ref, k))
                    {
                        return Some(format!(
                            "the dimension scales of `{name}` name no scale of its dimension {k} ({extent} long) that lists it"
                        ));
                    }
                }
            }
        }
        None
    }

    /// What is wrong with the text attributes of the readable summary columns (units, long
    /// names, coordinates) against `column_checksums`. (A column that cannot be read costs its
    /// points already.)
    fn column_attr_damage(&self) -> Option<String> {
        let sums: serde_json::Map<String, serde_json::Value> =
            read_attr_str(&self.file, "column_checksums")
                .ok()
                .and_then(|t| serde_json::from_str(&t).ok())?;
        let mut bad = Vec::new();
        for (names, data) in self.column_names.iter().zip(&self.table.columns) {
            if data.is_none() {
                continue;
            }
            for name in names {
                let want = sums.get(name).and_then(|v| v.as_str());
                // (Opened again rather than kept open from its reading: an open dataset keeps
                // the chunks it read in its cache, 17 MB more at the end of the 100 000-run
                // summary sweep.)
                let got = self
                    .file
                    .dataset(name)
                    .map_err(crate::h5)
                    .and_then(|d| column_text_checksum(&d))
                    .map(|x| x.to_string());
                if want.is_none() || got.ok().as_deref() != want {
                    bad.push(name.clone());
                }
            }
        }
        (!bad.is_empty()).then(|| {
            format!(
                "the attributes (units, long name, coordinates) of {} do not match their checksums (column_checksums)",
                bad.iter().map(|n| format!("`{n}`")).collect::<Vec<_>>().join(", ")
            )
        })
    }

    /// The columns HDF5 could not read, with why.
    pub fn unreadable(&self) -> &[(&'static str, String)] {
        &self.unreadable
    }

    /// Whether the file carries checksums (layout 3 and later): its values are verified.
    pub fn checked(&self) -> bool {
        self.layout_version >= CHECKED_LAYOUT
    }

    /// Number of grid points in the file.
    pub fn len(&self) -> usize {
        self.table.n
    }

    /// Whether the file has no grid points.
    pub fn is_empty(&self) -> bool {
        self.table.n == 0
    }

    /// Probes per point.
    pub fn probes(&self) -> usize {
        self.table.np
    }

    /// The summary columns as read.
    pub fn table(&self) -> &Table {
        &self.table
    }

    /// Status code of point `i` ([`chainsweep_sweep::record::STATUS_OK`], [`STATUS_FAILED`] or
    /// [`STATUS_PENDING`]; a damaged point may hold any other).
    pub fn status(&self, i: usize) -> u8 {
        self.table.status(i)
    }

    /// Why point `i`'s summaries cannot be trusted (`None`: they match their checksum, or the
    /// file has none).
    pub fn damage(&self, i: usize) -> Option<&str> {
        self.damage[i].as_deref()
    }

    /// The points whose summaries cannot be trusted, with why.
    pub fn damaged(&self) -> impl Iterator<Item = (usize, &str)> + '_ {
        self.damage
            .iter()
            .enumerate()
            .filter_map(|(i, d)| d.as_deref().map(|d| (i, d)))
    }

    /// Why point `i` failed (empty unless it did).
    pub fn reason(&self, i: usize) -> &str {
        self.table.str_at("reason", i)
    }

    /// Run hash (hex) stored for point `i`.
    pub fn hash_hex(&self, i: usize) -> &str {
        self.table.str_at("run_hash", i)
    }

    /// The verification outcome stored for point `i`.
    pub fn verify_info(&self, i: usize) -> VerifyInfo {
        self.table.verify_info(i)
    }

    /// Point `i` read back under the run hash `hash` (the one the file stores there): its record
    /// with its run group, checked; `Damaged` when its summaries or its run group are damaged.
    /// `grid`: the file's grid (for what its runs record).
    pub fn record(&self, i: usize, hash: RunHash, grid: &Grid) -> PointRead {
        if let Some(why) = &self.damage[i] {
            return PointRead::Damaged(why.clone());
        }
        let whole_chain = (!grid.moving_part).then(|| u64::from(grid.particles[i]));
        let Some(mut rec) = self.table.record(i, hash, whole_chain) else {
            return PointRead::Pending;
        };
        if rec.ok && grid.has_run_arrays() {
            match self.read_group(i, grid, self.table.checksum_at("history_checksum", i)) {
                Ok((history, min_overlap, fields, flow)) => {
                    rec.history = history;
                    rec.min_overlap_m = min_overlap;
                    rec.fields = fields;
                    rec.energy_flow = flow;
                }
                Err(why) => return PointRead::Damaged(why),
            }
        }
        PointRead::Run(Box::new(rec))
    }

    /// Histories and minimum overlaps of point `i` (from the runs' arrays, or in layouts 4 and
    /// earlier its group under `runs/`), checked against `checksum` (its `history_checksum`, or
    /// the snapshot's) in files that carry checksums; why not when they cannot be read or do not
    /// match.
    pub fn read_group(
        &self,
        i: usize,
        grid: &Grid,
        checksum: u64,
    ) -> std::result::Result<RunArrays, String> {
        if self.layout_version >= ARRAYS_LAYOUT {
            let arrays = self
                .arrays
                .get_or_init(|| {
                    ArrayReader::open(&self.file, grid).map_err(|e| {
                        format!(
                            "its histories and minimum overlaps cannot be opened ({})",
                            brief(&e)
                        )
                    })
                })
                .as_ref()
                .map_err(String::clone)?;
            // (Fields and the energy flow are named only where the grid records them.)
            let what = match (grid.fields.is_some(), grid.energy_flow) {
                (false, false) => "histories or minimum overlaps",
                (true, false) => "histories, minimum overlaps or fields",
                (false, true) => "histories, minimum overlaps or energy flow",
                (true, true) => "histories, minimum overlaps, fields or energy flow",
            };
            let (history, min_overlap, fields, flow) = arrays
                .read(i)
                .map_err(|e| format!("its {what} cannot be read ({})", brief(&e)))?;
            if history_checksum(
                history.as_ref(),
                min_overlap.as_deref(),
                fields.as_ref(),
                flow.as_ref(),
            ) != checksum
            {
                return Err(format!(
                    "its {what} do not match their checksum (history_checksum)"
                ));
            }
            return Ok((history, min_overlap, fields, flow));
        }
        let name = run_group_name_in(self.layout_version, grid.len(), i);
        let path = format!("runs/{name}");
        let read = || -> Result<(Option<History>, Option<Vec<f64>>)> {
            let g = self.file.group(&path).map_err(crate::h5)?;
            let history = if grid.history {
                let time_s = g
                    .dataset("time_s")
                    .map_err(crate::h5)?
                    .read_raw::<f64>()
                    .map_err(crate::h5)?;
                let mut values = Vec::with_capacity(grid.probes.len());
                for p in &grid.probes {
                    values.push(
                        g.dataset(&p.name())
                            .map_err(crate::h5)?
                            .read_raw::<f64>()
                            .map_err(crate::h5)?,
                    );
                }
                Some(History { time_s, values })
            } else {
                None
            };
            let min_overlap = if grid.min_overlap {
                Some(
                    g.dataset("min_overlap_m")
                        .map_err(crate::h5)?
                        .read_raw::<f64>()
                        .map_err(crate::h5)?,
                )
            } else {
                None
            };
            Ok((history, min_overlap))
        };
        let (history, min_overlap) =
            read().map_err(|e| format!("its group {path} cannot be read ({})", brief(&e)))?;
        if self.checked()
            && history_checksum(history.as_ref(), min_overlap.as_deref(), None, None) != checksum
        {
            return Err(format!(
                "its group {path} (histories, minimum overlaps) does not match its checksum (history_checksum)"
            ));
        }
        // (Run groups, layouts 4 and earlier, never held fields or the energy flow.)
        Ok((history, min_overlap, None, None))
    }

    /// The `auto` root attribute (what `integrator: auto` chose, JSON), when the file has one.
    pub fn auto_text(&self) -> Option<String> {
        let has = self
            .file
            .attr_names()
            .is_ok_and(|a| a.iter().any(|x| x == "auto"));
        has.then(|| read_attr_str(&self.file, "auto").ok())
            .flatten()
    }

    /// What is wrong with the coordinates and probes of the file against those of its sweep
    /// (`sweep`, `grid`: the file's, from its checked sweep text): each axis's values and the probe
    /// names and units are functions of the sweep, so a coordinate that differs is damaged; and
    /// every dataset (but the runs' arrays, checked as each run is read) whose chunks fail HDF5's
    /// own check, as h5py and xarray would find them.
    pub fn coordinate_damage(&self, sweep: &Sweep, grid: &Grid) -> Vec<String> {
        let mut out = Vec::new();
        for dim in &sweep.dims {
            for axis in &dim.axes {
                let same = (|| -> Result<bool> {
                    let d = self.file.dataset(&axis.name).map_err(crate::h5)?;
                    Ok(match coord_of(&axis.values) {
                        Coord::F64(v) => {
                            read_unchecked::<f64>(&d)?
                                .iter()
                                .zip(&v)
                                .all(|(a, b)| a.to_bits() == b.to_bits())
                                && d.size() == v.len()
                        }
                        Coord::I64(v) => read_unchecked::<i64>(&d)? == v,
                        Coord::Bool(v) => {
                            read_unchecked::<u8>(&d)?
                                == v.iter().map(|&b| b as u8).collect::<Vec<_>>()
                        }
                        Coord::Str(v) => read_text(&d)? == v,
                    })
                })();
                match same {
                    Ok(true) => {}
                    Ok(false) => out.push(format!(
                        "the coordinate `{}` does not hold the values its sweep gives it",
                        axis.name
                    )),
                    Err(e) => out.push(format!(
                        "the coordinate `{}` cannot be read ({})",
                        axis.name,
                        brief(&e)
                    )),
                }
            }
        }
        // Every other dataset but the runs' arrays (checked run by run as they are read): a
        // chunk whose checksum (Fletcher-32) is damaged though its values are intact would be
        // refused by h5py and xarray, so it is damage too, which the next `run` repairs. (Where
        // points are damaged already, the datasets over the grid are left to them: a damaged
        // value fails both its point's checksum and its chunk's, and costs its point only.)
        let points_damaged = self.damage.iter().any(Option::is_some);
        if let Ok(names) = self.file.member_names() {
            for name in names {
                let over_points = chainsweep_sweep::record::columns::is_column_dataset(&name)
                    || name == chainsweep_sweep::record::columns::HISTORY_SAMPLES
                    || name == chainsweep_sweep::record::columns::FIELD_SAMPLES;
                if matches!(name.as_str(), "runs" | "history" | "min_overlap_m")
                    || chainsweep_sweep::record::columns::FIELD_NAMES.contains(&name.as_str())
                    || chainsweep_sweep::record::columns::ENERGY_FLOW
                        .iter()
                        .any(|(flow, _, _)| *flow == name)
                    || name.starts_with("history_") && name != "history_samples"
                    || name == "time_s" && self.file.dataset(&name).is_ok_and(|d| d.ndim() > 1)
                    || over_points && points_damaged
                {
                    continue;
                }
                let Ok(d) = self.file.dataset(&name) else {
                    continue;
                };
                if d.is_chunked() && passes_filter_check(&d).is_err() {
                    out.push(format!(
                        "the dataset `{name}` fails HDF5's check (Fletcher-32): h5py and xarray refuse it"
                    ));
                }
            }
        }
        if !grid.probes.is_empty() {
            let names: Vec<String> = grid.probes.iter().map(|p| p.name()).collect();
            let units: Vec<String> = grid.probes.iter().map(|p| p.unit().to_string()).collect();
            for (name, want) in [("probe", names), ("probe_units", units)] {
                let got = self
                    .file
                    .dataset(name)
                    .map_err(crate::h5)
                    .and_then(|d| read_text(&d));
                match got {
                    Ok(v) if v == want => {}
                    Ok(_) => out.push(format!(
                        "the coordinate `{name}` does not hold the probes of its sweep"
                    )),
                    Err(e) => out.push(format!(
                        "the coordinate `{name}` cannot be read ({})",
                        brief(&e)
                    )),
                }
            }
        }
        out
    }

    /// Whether point `i` holds the run hash `hash`.
    pub fn holds(&self, i: usize, hash: &RunHash) -> bool {
        chainsweep_sweep::identity::is_hex_of(self.hash_hex(i), hash)
    }
}
