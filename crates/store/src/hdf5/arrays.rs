//! The runs' arrays (layout 5): every run's histories and minimum overlaps as one chunked,
//! checksummed dataset per quantity over the grid's dimensions, so that h5py reads one run, one
//! probe across every run or a time window across every run with one slice, and xarray opens
//! them lazily (`xr.open_dataset(path, chunks={})`):
//!
//! - `history` over (grid…, `probe`, `time_s`): each probe's samples, NaN (its fill value and
//!   `_FillValue`) after a run's end and for failed and pending runs. Where the probes' units
//!   differ, one dataset per unit (`history_N`, `history_m_per_s`: [`split_name`]), NaN at the
//!   probes of the others, as the summaries in the probes' unit are stored.
//! - `history_samples` over (grid…): how many samples each run recorded (−1: none).
//! - the time axis: where every point samples at the same interval, the coordinate `time_s`
//!   (`i · interval`), stored once; otherwise the dimension is `sample` (a dimension without a
//!   variable) and `time_s` a variable over (grid…, `sample`) with each run's own instants.
//! - `min_overlap_m` over (grid…, `contact`), NaN beyond a run's contacts and for failed and
//!   pending runs, on the coordinate `contact` (1, 2, …).
//! - the energy flow (`record.energy_flow`): `energy_passed_max_j` and `energy_passed_final_j`
//!   over (grid…, `contact`), `max_kinetic_energy_j` over (grid…, `particle`), NaN beyond a run's
//!   contacts or particles and for failed and pending runs.
//! - the space–time fields (`record.fields`): `field_contact_force` over (grid…, `field_time_s`,
//!   `contact`), `field_displacement` and `field_velocity` over (grid…, `field_time_s`,
//!   `particle`), NaN after a run's end, beyond its contacts or particles and for failed and
//!   pending runs; the coordinate `field_time_s` (`i · record.fields.interval_s`, the same at
//!   every point), `particle` (1, 2, …) and `field_samples` over (grid…) (−1: none).
//!
//! The last dimension of each (time, sample, contact) can grow while the file is written (a run
//! longer than the grid foresaw, as a searched duration gives). Chunks: every probe, the time
//! axis whole up to [`ARRAY_CHUNK_BYTES`], and up to [`RUNS_PER_CHUNK`] runs along the grid's
//! last dimension; the time series checksummed (Fletcher-32) and not compressed, the per-run
//! arrays also shuffled and deflated ([`ChunkFilters`]), chosen by measurement
//! (docs/PERFORMANCE.md). A damaged chunk costs the runs it holds, which the
//! reader reports (never serves) and a resume computes again.
//!
//! The writer writes each run's rows as the run comes ([`ArrayWriter::write`]), in grid order,
//! so that a chunk's runs fill it in the chunk cache before it is compressed once; the reader
//! ([`ArrayReader`]) keeps its datasets open, so reading the runs in grid order decompresses
//! each chunk once.

mod reader;

pub use reader::ArrayReader;

use hdf5::{Dataset, Extent, Extents, File, Hyperslab, SliceOrIndex};
use ndarray::{ArrayD, ArrayView, IxDyn};

use super::write::{DimScale, ProbeScale};
use super::{
    attach_scale, attr_scalar, attr_str, checked_dataset, dimension_only, filled_checked_dataset,
    read_unchecked, set_scale,
};
use chainsweep_solver::observe::flow::EnergyFlow;
use chainsweep_solver::observe::grid_instant;
use chainsweep_solver::observe::probes::{FieldQuantity, FieldSeries, Fields, History};
use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::grid::{multi_index, Grid};
use chainsweep_sweep::record::columns::{
    distinct_units, field_name, split_name, CONTACT, ENERGY_FLOW, ENERGY_FLOW_COMMENTS,
    FIELD_SAMPLES, FIELD_TIME, HISTORY, HISTORY_SAMPLES, MIN_OVERLAP, PARTICLE, SAMPLE, TIME,
};
use chainsweep_sweep::record::{RunArrays, RunRecord, INT_FILL};

/// Long name of the histories.
pub const HISTORY_LONG_NAME: &str =
    "history of each probe, sampled every record.history_interval_s";
/// Long name of the minimum overlaps.
pub const MIN_OVERLAP_LONG_NAME: &str = "minimum overlap of each contact over the run";
/// Long name of the contact coordinate: short, as a plot's axis label (a plot adds the unit).
pub const CONTACT_LONG_NAME: &str = "contact";
/// What the contact coordinate counts (its `comment`).
pub const CONTACT_COMMENT: &str = "contact j, between particles j and j+1 (the last one: the wall)";
/// Long name of the particle coordinate.
pub const PARTICLE_LONG_NAME: &str = "particle";
/// What the particle coordinate counts (its `comment`).
pub const PARTICLE_COMMENT: &str = "particle i (1: the striker, when there is one)";
/// Long name of the fields' time coordinate.
pub const FIELD_TIME_LONG_NAME: &str = "time";
/// What the fields' time coordinate is (its `comment`).
pub const FIELD_TIME_COMMENT: &str = "time of the field samples, every record.fields.interval_s";

/// Long name of the field of `quantity`: short, as a plot's label (a plot adds the unit).
pub fn field_long_name(quantity: FieldQuantity) -> &'static str {
    match quantity {
        FieldQuantity::ContactForce => "contact force",
        FieldQuantity::Displacement => "displacement",
        FieldQuantity::Velocity => "velocity",
    }
}

/// What the field of `quantity` holds (its `comment`).
pub fn field_comment(quantity: FieldQuantity) -> &'static str {
    match quantity {
        FieldQuantity::ContactForce => {
            "total force of every contact, sampled every record.fields.interval_s"
        }
        FieldQuantity::Displacement => {
            "dynamic displacement of every particle, sampled every record.fields.interval_s"
        }
        FieldQuantity::Velocity => {
            "velocity of every particle, sampled every record.fields.interval_s"
        }
    }
}

/// Bytes of one chunk at most (unless one run's one time sample of every probe is more): 256
/// KiB, whose 8 runs × 4 probes × 1 001 samples of the measured sweep read at 620 MB/s with h5py
/// and fit HDF5's default chunk cache (1 MiB) with room to spare.
pub const ARRAY_CHUNK_BYTES: usize = 256 << 10;
/// Runs in one chunk at most: more makes one run's slice decompress more of its neighbours.
pub const RUNS_PER_CHUNK: usize = 8;
/// Time samples in one chunk at least, whatever the probes.
pub const MIN_TIME_CHUNK: usize = 1024;
/// Deflate level of the per-run arrays (after the byte shuffle): level 1 gave nearly level 4's
/// size at a fraction of its time. (With zlib-ng, level 1 is its quick strategy: level 2 was 6 %
/// smaller but h5py decompressed it 40 % slower, and files are read more often than written.)
pub const ARRAY_DEFLATE_LEVEL: u8 = 1;

/// How a dataset's chunks are filtered: always checksummed (Fletcher-32, which the reader checks
/// on every chunk), compressed or not.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChunkFilters {
    /// Byte shuffle, deflate [`ARRAY_DEFLATE_LEVEL`], Fletcher-32: the per-run arrays (minimum
    /// overlaps, energy flow), a few values a run, read whole, and histories split by unit.
    Compressed,
    /// Fletcher-32 only: the time series (histories of one unit, their per-run instants,
    /// fields), the bulk of a file and what users read in large slices. Inflating is what bounds
    /// their reading: stock h5py read a 2 511-run sweep's histories at 364 MB/s deflated and
    /// 1 740 MB/s checksummed only, for a file about twice the size (docs/PERFORMANCE.md,
    /// `scripts/bench_history_filters.py`).
    ChecksumOnly,
}

/// The chunk of an array over (grid `shape`…, `inner`…) whose inner dimensions are taken whole
/// (the caller bounds them): up to [`RUNS_PER_CHUNK`] runs along the grid's last dimension,
/// while the chunk stays within [`ARRAY_CHUNK_BYTES`].
fn run_chunk(shape: &[usize], inner: &[usize]) -> Vec<usize> {
    let per_run = inner.iter().product::<usize>().max(1) * 8;
    let runs = (ARRAY_CHUNK_BYTES / per_run).clamp(1, RUNS_PER_CHUNK);
    let mut chunk: Vec<usize> = shape.iter().map(|_| 1).collect();
    if let (Some(c), Some(&n)) = (chunk.last_mut(), shape.last()) {
        *c = runs.min(n.max(1));
    }
    chunk.extend(inner.iter().map(|&n| n.max(1)));
    chunk
}

/// The chunk of a history dataset over (grid `shape`…, `probes`, `width` samples).
pub fn history_chunk(shape: &[usize], probes: usize, width: usize) -> Vec<usize> {
    let time = width
        .min((ARRAY_CHUNK_BYTES / 8 / probes.max(1)).max(MIN_TIME_CHUNK))
        .max(1);
    run_chunk(shape, &[probes, time])
}

/// The chunk of a field dataset over (grid `shape`…, `samples`, `width`): up to
/// [`ARRAY_CHUNK_BYTES`] of every contact or particle (as many as fit) over as many instants as
/// fit beside them.
pub fn field_chunk(shape: &[usize], samples: usize, width: usize) -> Vec<usize> {
    let most = ARRAY_CHUNK_BYTES / 8;
    let width = width.clamp(1, most);
    let time = (most / width).clamp(1, samples.max(1));
    run_chunk(shape, &[time, width])
}

/// A float array over (grid…, …) whose last dimension can grow, chunked `chunk` and filtered
/// `filters`, NaN where nothing is written (its fill value and `_FillValue`).
fn growing_dataset(
    file: &File,
    name: &str,
    shape: &[usize],
    chunk: Vec<usize>,
    filters: ChunkFilters,
) -> Result<Dataset> {
    growing_dataset_in(file, name, shape, chunk, 1, filters)
}

/// A per-run array over (grid `shape`…, `width`): a run's minimum overlaps or energy flow,
/// compressed (a few values a run, read whole).
fn per_run_dataset(file: &File, name: &str, shape: &[usize], width: usize) -> Result<Dataset> {
    let mut full = shape.to_vec();
    full.push(width);
    growing_dataset(
        file,
        name,
        &full,
        run_chunk(shape, &[width]),
        ChunkFilters::Compressed,
    )
}

/// [`growing_dataset`] whose last `growing` dimensions can grow.
fn growing_dataset_in(
    file: &File,
    name: &str,
    shape: &[usize],
    chunk: Vec<usize>,
    growing: usize,
    filters: ChunkFilters,
) -> Result<Dataset> {
    let first_growing = shape.len() - growing;
    let extents: Vec<Extent> = shape
        .iter()
        .enumerate()
        .map(|(k, &n)| {
            if k >= first_growing {
                Extent::resizable(n)
            } else {
                Extent::fixed(n)
            }
        })
        .collect();
    let mut builder = file.new_dataset::<f64>().chunk(chunk);
    if filters == ChunkFilters::Compressed {
        builder = builder.shuffle().deflate(ARRAY_DEFLATE_LEVEL);
    }
    let d = builder
        .fletcher32()
        .fill_value(f64::NAN)
        .shape(Extents::Simple(extents.into()))
        .create(name)
        .map_err(crate::h5)?;
    attr_scalar(&d, "_FillValue", f64::NAN)?;
    Ok(d)
}

/// The selection of run `index`'s rows: its grid point, then `inner` (counts from 0).
fn run_rows(shape: &[usize], index: usize, inner: &[usize]) -> Hyperslab {
    let mut sel: Vec<SliceOrIndex> = multi_index(shape, index)
        .into_iter()
        .map(SliceOrIndex::Index)
        .collect();
    sel.extend(inner.iter().map(|&count| SliceOrIndex::SliceCount {
        start: 0,
        step: 1,
        count,
        block: 1,
    }));
    Hyperslab::from(sel)
}

/// Writes `values` (row-major, of shape `inner`) as run `index`'s rows of `d`.
fn write_rows(
    d: &Dataset,
    shape: &[usize],
    index: usize,
    inner: &[usize],
    values: &[f64],
) -> Result<()> {
    if inner.contains(&0) {
        return Ok(());
    }
    let view = ArrayView::from_shape(IxDyn(inner), values)
        .map_err(|e| Error::Other(format!("run {index}'s rows of {}: {e}", d.name())))?;
    d.write_slice(view, run_rows(shape, index, inner))
        .map_err(crate::h5)?;
    Ok(())
}

/// Reads run `index`'s rows of `d` (of shape `inner`), checked (Fletcher-32).
fn read_rows(d: &Dataset, shape: &[usize], index: usize, inner: &[usize]) -> Result<Vec<f64>> {
    if inner.contains(&0) {
        return Ok(Vec::new());
    }
    let a: ArrayD<f64> = d
        .read_slice(run_rows(shape, index, inner))
        .map_err(crate::h5)?;
    Ok(a.into_raw_vec_and_offset().0)
}

/// The datasets of the histories: one per distinct unit of the probes where their units differ
/// (named [`split_name`]), else one named [`HISTORY`]; each with its unit and which probes it
/// holds.
fn history_parts(grid: &Grid) -> Vec<(String, String, Vec<bool>)> {
    let units: Vec<String> = grid.probes.iter().map(|p| p.unit().to_string()).collect();
    let distinct = distinct_units(&units);
    if distinct.len() <= 1 {
        let unit = distinct.first().map_or("1", |u| u).to_string();
        return vec![(HISTORY.to_string(), unit, vec![true; units.len()])];
    }
    distinct
        .iter()
        .map(|&u| {
            (
                split_name(HISTORY, u),
                u.to_string(),
                units.iter().map(|x| x == u).collect(),
            )
        })
        .collect()
}

/// The writer of a file's arrays.
pub(super) struct ArrayWriter {
    shape: Vec<usize>,
    history: Option<HistoryWriter>,
    min_overlap: Option<PerElementWriter>,
    /// The energy flow's three variables, in [`ENERGY_FLOW`]'s order.
    flow: Vec<PerElementWriter>,
    fields: Option<FieldWriter>,
}

struct FieldPart {
    quantity: FieldQuantity,
    data: Dataset,
    /// Contacts or particles: the dataset's current width.
    width: usize,
}

struct FieldWriter {
    parts: Vec<FieldPart>,
    /// Samples of every point (INT_FILL: none).
    samples: Vec<i64>,
    /// The time axis's current length.
    length: usize,
    /// The interval every point shares.
    interval: f64,
}

impl FieldWriter {
    fn create(file: &File, grid: &Grid) -> Result<Option<FieldWriter>> {
        let Some(spec) = &grid.fields else {
            return Ok(None);
        };
        let shape = &grid.shape;
        let length = grid.max_field_samples.max(1);
        let parts = spec
            .quantities
            .iter()
            .map(|&quantity| {
                let width = if quantity.per_contact() {
                    grid.max_contacts
                } else {
                    grid.max_particles
                }
                .max(1);
                let mut full = shape.clone();
                full.extend([length, width]);
                let data = growing_dataset_in(
                    file,
                    field_name(quantity),
                    &full,
                    field_chunk(shape, length, width),
                    2,
                    ChunkFilters::ChecksumOnly,
                )?;
                Ok(FieldPart {
                    quantity,
                    data,
                    width,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Some(FieldWriter {
            parts,
            samples: vec![INT_FILL; grid.len()],
            length,
            interval: spec.interval_s,
        }))
    }

    fn write(&mut self, shape: &[usize], index: usize, f: &Fields) -> Result<()> {
        let len = f.time_s.len();
        let quantities: Vec<FieldQuantity> = f.series.iter().map(|s| s.quantity).collect();
        let wanted: Vec<FieldQuantity> = self.parts.iter().map(|p| p.quantity).collect();
        if quantities != wanted {
            return Err(Error::Other(format!(
                "run {index}'s fields hold {quantities:?}, the file {wanted:?}"
            )));
        }
        if let Some(k) = (0..len).find(|&k| {
            f.time_s[k].to_bits() != grid_instant(0.0, k as u64, self.interval).to_bits()
        }) {
            return Err(Error::Other(format!(
                "run {index}'s field sample {k} is at {:e} s, not at {k} × the interval {:e} s the file's one time axis holds",
                f.time_s[k], self.interval
            )));
        }
        if len > self.length {
            self.length = len;
        }
        for (p, s) in self.parts.iter_mut().zip(&f.series) {
            if s.values.len() != len * s.width {
                return Err(Error::Other(format!(
                    "run {index}'s {} field holds {} values for {len} instants of {}",
                    s.quantity.name(),
                    s.values.len(),
                    s.width
                )));
            }
            p.width = p.width.max(s.width);
            let have = p.data.shape();
            let g = shape.len();
            if have[g] < self.length || have[g + 1] < p.width {
                let mut want = shape.to_vec();
                want.extend([self.length.max(have[g]), p.width.max(have[g + 1])]);
                p.data.resize(want).map_err(crate::h5)?;
            }
            write_rows(&p.data, shape, index, &[len, s.width], &s.values)?;
        }
        self.samples[index] = len as i64;
        Ok(())
    }
}

struct HistoryPart {
    data: Dataset,
    unit: String,
    holds: Vec<bool>,
}

struct HistoryWriter {
    parts: Vec<HistoryPart>,
    probes: usize,
    /// Samples of every point (INT_FILL: none).
    samples: Vec<i64>,
    /// The time axis's current length.
    width: usize,
    /// The interval every point shares (the time axis stored once), else `None`.
    interval: Option<f64>,
    /// Every run's instants, where the intervals differ.
    run_time: Option<Dataset>,
    buf: Vec<f64>,
}

/// The writer of a variable with one value per contact or particle of each run (the minimum
/// overlaps, the energy flow's).
struct PerElementWriter {
    data: Dataset,
    width: usize,
    buf: Vec<f64>,
}

impl PerElementWriter {
    /// Writes the run at flat index `index`, widening the variable to its values.
    fn write(&mut self, shape: &[usize], index: usize, values: &[f64]) -> Result<()> {
        if values.len() > self.width {
            self.width = values.len();
            let mut s = shape.to_vec();
            s.push(self.width);
            self.data.resize(s).map_err(crate::h5)?;
        }
        self.buf.clear();
        self.buf.extend_from_slice(values);
        write_rows(&self.data, shape, index, &[values.len()], &self.buf)
    }
}

impl ArrayWriter {
    /// Creates the arrays `grid`'s runs record in `file` (none: nothing is created).
    pub fn create(file: &File, grid: &Grid) -> Result<ArrayWriter> {
        let shape = grid.shape.clone();
        let history = if grid.history {
            let probes = grid.probes.len();
            let width = grid.max_history_samples.max(1);
            let mut full = shape.clone();
            full.extend([probes, width]);
            let parts = if probes == 0 {
                Vec::new()
            } else {
                let parts = history_parts(grid);
                // Split by unit, each part is NaN at the other units' probes: compressed, those
                // cost next to nothing, and long runs of one value inflate quickly.
                let filters = if parts.len() > 1 {
                    ChunkFilters::Compressed
                } else {
                    ChunkFilters::ChecksumOnly
                };
                parts
                    .into_iter()
                    .map(|(name, unit, holds)| {
                        let data = growing_dataset(
                            file,
                            &name,
                            &full,
                            history_chunk(&shape, probes, width),
                            filters,
                        )?;
                        Ok(HistoryPart { data, unit, holds })
                    })
                    .collect::<Result<Vec<_>>>()?
            };
            let run_time = match grid.history_interval_s {
                Some(_) => None,
                None => {
                    let mut s = shape.clone();
                    s.push(width);
                    // (Chunked as one probe's history: the probes' dimension left out.)
                    let mut chunk = history_chunk(&shape, 1, width);
                    chunk.remove(shape.len());
                    Some(growing_dataset(
                        file,
                        TIME,
                        &s,
                        chunk,
                        ChunkFilters::ChecksumOnly,
                    )?)
                }
            };
            Some(HistoryWriter {
                parts,
                probes,
                samples: vec![INT_FILL; grid.len()],
                width,
                interval: grid.history_interval_s,
                run_time,
                buf: Vec::new(),
            })
        } else {
            None
        };
        let min_overlap = if grid.min_overlap {
            let width = grid.max_contacts.max(1);
            let data = per_run_dataset(file, MIN_OVERLAP, &shape, width)?;
            Some(PerElementWriter {
                data,
                width,
                buf: Vec::new(),
            })
        } else {
            None
        };
        let mut flow = Vec::new();
        if grid.energy_flow {
            for (name, per_contact, _) in ENERGY_FLOW {
                let width = if per_contact {
                    grid.max_contacts
                } else {
                    grid.max_particles
                }
                .max(1);
                let data = per_run_dataset(file, name, &shape, width)?;
                flow.push(PerElementWriter {
                    data,
                    width,
                    buf: Vec::new(),
                });
            }
        }
        let fields = FieldWriter::create(file, grid)?;
        Ok(ArrayWriter {
            shape,
            history,
            min_overlap,
            flow,
            fields,
        })
    }

    /// Writes the arrays of the successful run at flat index `index`.
    pub fn write(&mut self, index: usize, rec: &RunRecord) -> Result<()> {
        let shape = &self.shape;
        if let (Some(w), Some(h)) = (&mut self.history, &rec.history) {
            let len = h.time_s.len();
            if h.values.len() != w.probes || h.values.iter().any(|v| v.len() != len) {
                return Err(Error::Other(format!(
                    "run {index}'s history holds {} series for {} probes, or series of other lengths than its {len} instants",
                    h.values.len(),
                    w.probes
                )));
            }
            if len > w.width {
                w.width = len;
                for p in &w.parts {
                    let mut s = shape.clone();
                    s.extend([w.probes, len]);
                    p.data.resize(s).map_err(crate::h5)?;
                }
                if let Some(t) = &w.run_time {
                    let mut s = shape.clone();
                    s.push(len);
                    t.resize(s).map_err(crate::h5)?;
                }
            }
            match (w.interval, &w.run_time) {
                (Some(dt), _) => {
                    // The one time axis holds these instants: a run sampled elsewhere would be
                    // stored wrong, so it is an error, never a silent shift.
                    if let Some(k) = (0..len).find(|&k| {
                        h.time_s[k].to_bits() != grid_instant(0.0, k as u64, dt).to_bits()
                    }) {
                        return Err(Error::Other(format!(
                            "run {index}'s history sample {k} is at {:e} s, not at {k} × the interval {dt:e} s the file's one time axis holds",
                            h.time_s[k]
                        )));
                    }
                }
                (None, Some(t)) => write_rows(t, shape, index, &[len], &h.time_s)?,
                (None, None) => unreachable!("a time variable where the intervals differ"),
            }
            for p in &w.parts {
                w.buf.clear();
                for (k, series) in h.values.iter().enumerate() {
                    if p.holds[k] {
                        w.buf.extend_from_slice(series);
                    } else {
                        w.buf.extend(std::iter::repeat(f64::NAN).take(len));
                    }
                }
                write_rows(&p.data, shape, index, &[w.probes, len], &w.buf)?;
            }
            w.samples[index] = len as i64;
        }
        if let (Some(w), Some(m)) = (&mut self.min_overlap, &rec.min_overlap_m) {
            w.write(shape, index, m)?;
        }
        if let Some(f) = &rec.energy_flow {
            let values = [
                &f.energy_passed_max_j,
                &f.energy_passed_final_j,
                &f.max_kinetic_energy_j,
            ];
            for (w, v) in self.flow.iter_mut().zip(values) {
                w.write(shape, index, v)?;
            }
        }
        if let (Some(w), Some(f)) = (&mut self.fields, &rec.fields) {
            w.write(shape, index, f)?;
        }
        Ok(())
    }

    /// Writes what the arrays need once every run is written: the time axis (or the samples'
    /// dimension), `history_samples`, the contacts' coordinate, and every dimension scale and
    /// attribute (`coordinates`: the grid's coordinates that are no dimension scale, and its
    /// text coordinates).
    pub fn finish(
        self,
        file: &File,
        dims: &[DimScale],
        probe: Option<&ProbeScale>,
        coordinates: &[&str],
    ) -> Result<()> {
        let g = self.shape.len();
        let attach_grid = |d: &Dataset| -> Result<()> {
            for (k, dim) in dims.iter().enumerate() {
                attach_scale(d, &dim.scale, k, &dim.name)?;
            }
            Ok(())
        };
        let listed = |extra: &[&str]| -> String {
            coordinates
                .iter()
                .chain(extra)
                .copied()
                .collect::<Vec<_>>()
                .join(" ")
        };
        if let Some(w) = self.history {
            let (axis, axis_name) = match w.interval {
                Some(dt) => {
                    let t: Vec<f64> = (0..w.width)
                        .map(|k| grid_instant(0.0, k as u64, dt))
                        .collect();
                    let d = checked_dataset(file, TIME, &[w.width], &t)?;
                    attr_str(&d, "units", "s")?;
                    // (No `axis = "T"`: CF's time coordinates count from a reference date.)
                    attr_str(&d, "long_name", "time")?;
                    set_scale(&d, TIME)?;
                    (d, TIME)
                }
                None => (dimension_only(file, SAMPLE, w.width)?, SAMPLE),
            };
            let mut extra: Vec<&str> = Vec::new();
            if let Some(t) = &w.run_time {
                attach_grid(t)?;
                attach_scale(t, &axis, g, axis_name)?;
                attr_str(t, "units", "s")?;
                attr_str(
                    t,
                    "long_name",
                    "time of each history sample of the run (NaN after its end)",
                )?;
                if !coordinates.is_empty() {
                    attr_str(t, "coordinates", &listed(&[]))?;
                }
                extra.push(TIME);
            }
            let split = w.parts.len() > 1;
            for p in &w.parts {
                attach_grid(&p.data)?;
                if let Some(probe) = probe {
                    attach_scale(&p.data, &probe.scale, g, "probe")?;
                }
                attach_scale(&p.data, &axis, g + 1, axis_name)?;
                attr_str(&p.data, "units", &p.unit)?;
                let long_name = if split {
                    format!(
                        "{HISTORY_LONG_NAME} (the probes measured in {}; NaN at the others)",
                        p.unit
                    )
                } else {
                    HISTORY_LONG_NAME.to_string()
                };
                attr_str(&p.data, "long_name", &long_name)?;
                let mut with = vec!["probe", "probe_units"];
                with.extend(&extra);
                attr_str(&p.data, "coordinates", &listed(&with))?;
            }
            let d =
                filled_checked_dataset(file, HISTORY_SAMPLES, &self.shape, &w.samples, INT_FILL)?;
            attach_grid(&d)?;
            attr_str(&d, "units", "1")?;
            attr_str(
                &d,
                "long_name",
                "number of history samples the run recorded (its history is NaN after them)",
            )?;
            if !coordinates.is_empty() {
                attr_str(&d, "coordinates", &listed(&[]))?;
            }
        }
        // The contacts' coordinate, shared by the minimum overlaps and the contact forces' field
        // (both as wide as the widest chain's contacts), and the particles'.
        let field_parts = self.fields.as_ref().map_or(&[][..], |f| &f.parts[..]);
        let width_of = |contacts: bool| {
            field_parts
                .iter()
                .filter(|p| p.quantity.per_contact() == contacts)
                .map(|p| p.width)
                .max()
        };
        let flow_width = |contacts: bool| {
            ENERGY_FLOW
                .iter()
                .zip(&self.flow)
                .filter(|((_, per_contact, _), _)| *per_contact == contacts)
                .map(|(_, w)| w.width)
                .max()
        };
        let widest = |a: Option<usize>, b: Option<usize>| match (a, b) {
            (Some(x), Some(y)) => Some(x.max(y)),
            (x, y) => x.or(y),
        };
        let contact_width = widest(
            widest(self.min_overlap.as_ref().map(|w| w.width), width_of(true)),
            flow_width(true),
        );
        let particle_width = widest(width_of(false), flow_width(false));
        let coordinate =
            |name: &str, width: usize, long_name: &str, comment: &str| -> Result<Dataset> {
                let k: Vec<i64> = (1..=width as i64).collect();
                let c = checked_dataset(file, name, &[width], &k)?;
                attr_str(&c, "units", "1")?;
                attr_str(&c, "long_name", long_name)?;
                attr_str(&c, "comment", comment)?;
                set_scale(&c, name)?;
                Ok(c)
            };
        let contact = contact_width
            .map(|w| coordinate(CONTACT, w, CONTACT_LONG_NAME, CONTACT_COMMENT))
            .transpose()?;
        let particle = particle_width
            .map(|w| coordinate(PARTICLE, w, PARTICLE_LONG_NAME, PARTICLE_COMMENT))
            .transpose()?;
        // A variable with one value per contact or particle: as wide as its coordinate, on it.
        let per_element = |w: &PerElementWriter,
                           per_contact: bool,
                           units: &str,
                           long_name: &str,
                           comment: Option<&str>|
         -> Result<()> {
            let (scale, dim, width) = if per_contact {
                (contact.as_ref(), CONTACT, contact_width)
            } else {
                (particle.as_ref(), PARTICLE, particle_width)
            };
            let (scale, width) = (scale.expect("made above"), width.expect("made above"));
            if width > w.width {
                let mut s = self.shape.clone();
                s.push(width);
                w.data.resize(s).map_err(crate::h5)?;
            }
            attach_grid(&w.data)?;
            attach_scale(&w.data, scale, g, dim)?;
            attr_str(&w.data, "units", units)?;
            attr_str(&w.data, "long_name", long_name)?;
            if let Some(comment) = comment {
                attr_str(&w.data, "comment", comment)?;
            }
            if !coordinates.is_empty() {
                attr_str(&w.data, "coordinates", &listed(&[]))?;
            }
            Ok(())
        };
        if let Some(w) = &self.min_overlap {
            per_element(w, true, "m", MIN_OVERLAP_LONG_NAME, None)?;
        }
        for (((_, per_contact, long_name), comment), w) in
            ENERGY_FLOW.iter().zip(ENERGY_FLOW_COMMENTS).zip(&self.flow)
        {
            per_element(w, *per_contact, "J", long_name, Some(comment))?;
        }
        if let Some(w) = self.fields {
            let t: Vec<f64> = (0..w.length)
                .map(|k| grid_instant(0.0, k as u64, w.interval))
                .collect();
            let time = checked_dataset(file, FIELD_TIME, &[w.length], &t)?;
            attr_str(&time, "units", "s")?;
            attr_str(&time, "long_name", FIELD_TIME_LONG_NAME)?;
            attr_str(&time, "comment", FIELD_TIME_COMMENT)?;
            set_scale(&time, FIELD_TIME)?;
            for p in &w.parts {
                let (scale, name, width) = if p.quantity.per_contact() {
                    (contact.as_ref(), CONTACT, contact_width)
                } else {
                    (particle.as_ref(), PARTICLE, particle_width)
                };
                let (scale, width) = (scale.expect("made above"), width.expect("made above"));
                let mut s = self.shape.clone();
                s.extend([w.length, width]);
                if p.data.shape() != s {
                    p.data.resize(s).map_err(crate::h5)?;
                }
                attach_grid(&p.data)?;
                attach_scale(&p.data, &time, g, FIELD_TIME)?;
                attach_scale(&p.data, scale, g + 1, name)?;
                attr_str(&p.data, "units", p.quantity.unit())?;
                attr_str(&p.data, "long_name", field_long_name(p.quantity))?;
                attr_str(&p.data, "comment", field_comment(p.quantity))?;
                if !coordinates.is_empty() {
                    attr_str(&p.data, "coordinates", &listed(&[]))?;
                }
            }
            let d = filled_checked_dataset(file, FIELD_SAMPLES, &self.shape, &w.samples, INT_FILL)?;
            attach_grid(&d)?;
            attr_str(&d, "units", "1")?;
            attr_str(
                &d,
                "long_name",
                "number of field samples the run recorded (its fields are NaN after them)",
            )?;
            if !coordinates.is_empty() {
                attr_str(&d, "coordinates", &listed(&[]))?;
            }
        }
        Ok(())
    }
}
