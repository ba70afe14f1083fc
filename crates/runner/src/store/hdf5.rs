//! The HDF5 file: assembled from run records in grid order, and read back for merging.
//!
//! Layout (see `README-sweeps.md`): root attributes describing the sweep; one coordinate dataset
//! per axis (an HDF5 dimension scale); per-run summaries as arrays shaped like the grid (plus a
//! `probe` dimension where there is one value per probe), with the scales attached; histories
//! under `runs/<flat index>/` in chunked, deflate-compressed datasets.
//!
//! The writer is a pure function of the sweep, the grid and the records (apart from the
//! `created_utc` and `command_line` attributes and the `wall_time_s` dataset), which is what makes
//! files bitwise equal whatever the number of jobs, the finishing order or the sharding.

use std::ffi::CString;
use std::path::Path;

use chainsweep_solver::probes::{History, ProbeSummary};
use hdf5::types::VarLenUnicode;
use hdf5::{Dataset, File, Group, H5Type, Location};
use serde_json::Value;

use crate::error::{Error, Result};
use crate::grid::{multi_index, Grid, Shard};
use crate::identity::{hex, RunHash, TIGHTENING};
use crate::record::{
    RunRecord, VerifyInfo, INT_FILL, STATUS_FAILED, STATUS_OK, STATUS_PENDING, VERIFY_FAILED,
    VERIFY_NONE, VERIFY_OK,
};
use crate::sweep::auto::AutoChoice;
use crate::sweep::Sweep;

/// Deflate level of history datasets.
pub const DEFLATE_LEVEL: u8 = 4;

/// Largest chunk of a history dataset, in samples.
pub const HISTORY_CHUNK: usize = 16384;

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
    let r = hdf5::sync::sync(|| unsafe { ds::H5DSset_scale(scale.id(), c.as_ptr()) });
    if r < 0 {
        return Err(Error::Other(format!("H5DSset_scale({name}) failed")));
    }
    Ok(())
}

/// Attaches dimension scale `scale` to dimension `dim` of `data`, and labels the dimension.
fn attach_scale(data: &Dataset, scale: &Dataset, dim: usize, label: &str) -> Result<()> {
    let c = CString::new(label).map_err(|_| Error::Other(format!("bad label {label:?}")))?;
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

/// Values of one coordinate, typed for HDF5.
enum Coord {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Str(Vec<String>),
}

fn coord_of(values: &[Value]) -> Coord {
    if values.iter().all(|v| v.is_i64()) {
        Coord::I64(values.iter().map(|v| v.as_i64().expect("i64")).collect())
    } else if values.iter().all(|v| v.is_number()) {
        Coord::F64(values.iter().map(|v| v.as_f64().expect("number")).collect())
    } else if values.iter().all(|v| v.is_boolean()) {
        Coord::Bool(values.iter().map(|v| v.as_bool().expect("bool")).collect())
    } else if values.iter().all(|v| v.is_string()) {
        Coord::Str(
            values
                .iter()
                .map(|v| v.as_str().expect("str").to_string())
                .collect(),
        )
    } else {
        Coord::Str(values.iter().map(|v| v.to_string()).collect())
    }
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

fn write_history_series(g: &Group, name: &str, data: &[f64], units: &str) -> Result<Dataset> {
    let n = data.len();
    let d = g
        .new_dataset::<f64>()
        .chunk(n.clamp(1, HISTORY_CHUNK))
        .shuffle()
        .deflate(DEFLATE_LEVEL)
        .shape(n)
        .create(name)?;
    if n > 0 {
        d.write_raw(data)?;
    }
    attr_str(&d, "units", units)?;
    Ok(d)
}

fn write_run_group(
    runs: &Group,
    grid: &Grid,
    sweep: &Sweep,
    index: usize,
    rec: &RunRecord,
) -> Result<()> {
    let g = runs.create_group(&run_group_name(grid.len(), index))?;
    attr_str(&g, "run_hash", &hex(&rec.hash))?;
    let mi: Vec<i64> = multi_index(&grid.shape, index)
        .iter()
        .map(|&x| x as i64)
        .collect();
    attr_vec(&g, "grid_index", &mi)?;
    attr_scalar(&g, "flat_index", index as i64)?;
    for (d, dim) in sweep.dims.iter().enumerate() {
        for axis in &dim.axes {
            let v = &axis.values[mi[d] as usize];
            if let Some(i) = v.as_i64() {
                attr_scalar(&g, &axis.name, i)?;
            } else if let Some(x) = v.as_f64() {
                attr_scalar(&g, &axis.name, x)?;
            } else if let Some(s) = v.as_str() {
                attr_str(&g, &axis.name, s)?;
            } else {
                attr_str(&g, &axis.name, &v.to_string())?;
            }
        }
    }
    if let Some(h) = &rec.history {
        let t = write_history_series(&g, "time_s", &h.time_s, "s")?;
        set_scale(&t, "time_s")?;
        for (p, series) in grid.probes.iter().zip(&h.values) {
            let d = write_history_series(&g, &p.name(), series, p.unit())?;
            attr_str(
                &d,
                "probe",
                &serde_json::to_string(p).expect("probe serialises"),
            )?;
            attach_scale(&d, &t, 0, "time_s")?;
        }
    }
    if let Some(m) = &rec.min_overlap_m {
        let d = dataset(&g, "min_overlap_m", &[m.len()], m)?;
        attr_str(&d, "units", "m")?;
        attr_str(
            &d,
            "long_name",
            "minimum overlap of each contact over the run (contact j at index j-1)",
        )?;
    }
    Ok(())
}

/// Writes the HDF5 file of a sweep to `path` from the records `get(index)` returns for the points
/// in `points` (others are pending), in grid order, with the verification outcome
/// `get_verify(index, record)` of each finished point. `shard` and `verify_fraction` (0 when
/// `--verify` was not given) are recorded as attributes.
#[allow(clippy::too_many_arguments)]
pub fn write_file(
    path: &Path,
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    shard: Option<Shard>,
    prov: &Provenance,
    verify_fraction: f64,
    mut get: impl FnMut(usize) -> Result<Option<RunRecord>>,
    mut get_verify: impl FnMut(usize, &RunRecord) -> Result<VerifyInfo>,
) -> Result<Counts> {
    let n = grid.len();
    let np = grid.probes.len();
    let file = File::with_options()
        .with_fcpl(|p| p.obj_track_times(false))
        .create(path)?;

    // Root attributes.
    attr_str(&file, "sweep", &sweep.text)?;
    attr_str(&file, "description", &sweep.description)?;
    attr_str(
        &file,
        "base_scene",
        &serde_json::to_string(&sweep.base).expect("json"),
    )?;
    attr_str(&file, "engine", "chainsweep")?;
    attr_str(&file, "engine_version", crate::ENGINE_VERSION)?;
    attr_str(&file, "solver_version", crate::SOLVER_VERSION)?;
    attr_scalar(&file, "numerics_version", crate::NUMERICS_VERSION as i64)?;
    attr_str(&file, "git_revision", crate::GIT_REVISION)?;
    attr_str(&file, "created_utc", &prov.created_utc)?;
    attr_str(&file, "command_line", &prov.command_line)?;
    let shard = shard.unwrap_or(Shard { k: 1, n: 1 });
    attr_str(&file, "shard", &shard.to_string())?;
    let dims: Vec<&str> = sweep.dims.iter().map(|d| d.name.as_str()).collect();
    attr_str(
        &file,
        "dimensions",
        &serde_json::to_string(&dims).expect("json"),
    )?;
    let shape_i: Vec<i64> = grid.shape.iter().map(|&x| x as i64).collect();
    attr_vec(&file, "grid_shape", &shape_i)?;
    attr_scalar(
        &file,
        "energy_drift_limit",
        sweep.limits.energy_drift_max.unwrap_or(f64::NAN),
    )?;

    // Per-point arrays.
    let nan = f64::NAN;
    let mut status = vec![STATUS_PENDING; n];
    let mut reason = vec![String::new(); n];
    let mut run_hash = vec![String::new(); n];
    let mut scal: Vec<Vec<f64>> = vec![vec![nan; n]; 7];
    let mut ints: Vec<Vec<i64>> = vec![vec![INT_FILL; n]; 4];
    let mut psum: Vec<Vec<f64>> = vec![vec![nan; n * np]; 4];
    let mut warnings = vec![String::new(); n];
    let mut verified = vec![VERIFY_NONE; n];
    let mut verr: Vec<Vec<f64>> = vec![vec![nan; n * np]; 3];
    let mut verr_max = vec![nan; n];
    let mut n_verified = 0usize;
    for (i, h) in grid.hashes.iter().enumerate() {
        run_hash[i] = hex(h);
    }
    let needs_runs = grid.history || grid.min_overlap;
    let runs = if needs_runs {
        Some(file.create_group("runs")?)
    } else {
        None
    };
    let mut counts = Counts::default();
    let mut in_points = vec![false; n];
    for &i in points {
        in_points[i] = true;
    }
    for i in 0..n {
        if !in_points[i] {
            continue;
        }
        let Some(rec) = get(i)? else {
            counts.pending += 1;
            continue;
        };
        if rec.hash != grid.hashes[i] {
            return Err(Error::Other(format!(
                "record for point {i} has the wrong run hash"
            )));
        }
        scal[5][i] = rec.wall_time_s;
        let v = get_verify(i, &rec)?;
        verified[i] = v.status;
        if v.status == VERIFY_OK {
            n_verified += 1;
            verr_max[i] = v.max_error();
            for (p, e) in v.errors.iter().enumerate().take(np) {
                for k in 0..3 {
                    verr[k][i * np + p] = e[k];
                }
            }
        }
        if !rec.ok {
            status[i] = STATUS_FAILED;
            reason[i] = rec.reason.clone();
            counts.failed += 1;
            continue;
        }
        status[i] = STATUS_OK;
        counts.ok += 1;
        for (k, x) in [
            rec.t_end_s,
            rec.energy_drift_max,
            rec.energy_drift_final,
            rec.momentum_residual_max,
            rec.impact_energy_j,
        ]
        .into_iter()
        .enumerate()
        {
            scal[k][i] = x;
        }
        scal[6][i] = rec.max_overlap_m;
        warnings[i] = rec.warnings.clone();
        ints[0][i] = rec.steps as i64;
        ints[1][i] = rec.rejected as i64;
        ints[2][i] = rec.rhs_evals as i64;
        ints[3][i] = rec.events as i64;
        for (p, s) in rec.probes.iter().enumerate().take(np) {
            for (k, x) in [
                s.leading_peak,
                s.leading_peak_time_s,
                s.record_max,
                s.record_max_time_s,
            ]
            .into_iter()
            .enumerate()
            {
                psum[k][i * np + p] = x;
            }
        }
        if let Some(runs) = &runs {
            write_run_group(runs, grid, sweep, i, &rec)?;
        }
    }
    attr_scalar(&file, "n_runs", points.len() as i64)?;
    attr_scalar(&file, "n_ok", counts.ok as i64)?;
    attr_scalar(&file, "n_failed", counts.failed as i64)?;
    attr_scalar(&file, "n_pending", counts.pending as i64)?;
    attr_scalar(&file, "verify_fraction", verify_fraction)?;
    attr_str(&file, "verify_tightening", TIGHTENING)?;
    attr_scalar(&file, "n_verified", n_verified as i64)?;
    if let Some(c) = &sweep.auto_choice {
        write_auto_attrs(&file, c)?;
    }

    // Coordinates (dimension scales).
    let mut scales: Vec<Vec<(Dataset, String)>> = Vec::new();
    for dim in &sweep.dims {
        let mut here = Vec::new();
        for axis in &dim.axes {
            let shape = [axis.values.len()];
            let d = match coord_of(&axis.values) {
                Coord::F64(v) => dataset(&file, &axis.name, &shape, &v)?,
                Coord::I64(v) => dataset(&file, &axis.name, &shape, &v)?,
                Coord::Bool(v) => dataset(&file, &axis.name, &shape, &v)?,
                Coord::Str(v) => str_dataset(&file, &axis.name, &shape, &v)?,
            };
            attr_str(&d, "units", &axis.units)?;
            attr_str(&d, "field", &axis.field)?;
            attr_str(&d, "dimension", &dim.name)?;
            set_scale(&d, &axis.name)?;
            here.push((d, dim.name.clone()));
        }
        scales.push(here);
    }
    let probe_scale = if np > 0 {
        let names: Vec<String> = grid.probes.iter().map(|p| p.name()).collect();
        let d = str_dataset(&file, "probe", &[np], &names)?;
        let json: Vec<String> = grid
            .probes
            .iter()
            .map(|p| serde_json::to_string(p).expect("probe serialises"))
            .collect();
        attr_str(&d, "long_name", "probe (as in the record block)")?;
        attr_str(&d, "probes_json", &format!("[{}]", json.join(",")))?;
        set_scale(&d, "probe")?;
        let units: Vec<String> = grid.probes.iter().map(|p| p.unit().to_string()).collect();
        let u = str_dataset(&file, "probe_units", &[np], &units)?;
        attach_scale(&u, &d, 0, "probe")?;
        Some((d, units))
    } else {
        None
    };

    let attach_grid = |d: &Dataset| -> Result<()> {
        for (k, here) in scales.iter().enumerate() {
            for (s, label) in here {
                attach_scale(d, s, k, label)?;
            }
        }
        Ok(())
    };
    let shape = grid.shape.clone();
    let scalar_names: [(&str, &str, &str); 7] = [
        ("t_end_s", "s", "time the run reached"),
        (
            "energy_drift_max",
            "1",
            "largest |E(t) - E(0)| over the run, relative to the impact energy",
        ),
        (
            "energy_drift_final",
            "1",
            "|E(t_end) - E(0)| relative to the impact energy",
        ),
        (
            "momentum_residual_max",
            "1",
            "largest momentum-balance residual, relative to the striker momentum",
        ),
        ("impact_energy_j", "J", "striker kinetic energy"),
        (
            "wall_time_s",
            "s",
            "wall-clock time of the run (kept for failed runs)",
        ),
        (
            "max_overlap_m",
            "m",
            "largest contact overlap over the run (at step ends)",
        ),
    ];
    for ((name, units, long), data) in scalar_names.iter().zip(&scal) {
        let d = dataset(&file, name, &shape, data)?;
        attr_str(&d, "units", units)?;
        attr_str(&d, "long_name", long)?;
        attach_grid(&d)?;
    }
    let int_names: [(&str, &str); 4] = [
        ("steps", "accepted integrator steps"),
        ("rejected_steps", "rejected step attempts"),
        ("rhs_evals", "right-hand-side evaluations"),
        (
            "events",
            "steps retaken to end on a contact opening or closing (located events)",
        ),
    ];
    for ((name, long), data) in int_names.iter().zip(&ints) {
        let d = dataset(&file, name, &shape, data)?;
        attr_str(&d, "units", "1")?;
        attr_str(&d, "long_name", long)?;
        attr_scalar(&d, "fill_value", INT_FILL)?;
        attach_grid(&d)?;
    }
    let d = dataset(&file, "status", &shape, &status)?;
    attr_vec(
        &d,
        "flag_values",
        &[STATUS_PENDING, STATUS_OK, STATUS_FAILED],
    )?;
    attr_str(&d, "flag_meanings", "pending ok failed")?;
    attach_grid(&d)?;
    let d = str_dataset(&file, "reason", &shape, &reason)?;
    attr_str(
        &d,
        "long_name",
        "why the run failed (empty unless status == 2)",
    )?;
    attach_grid(&d)?;
    let d = str_dataset(&file, "warnings", &shape, &warnings)?;
    attr_str(
        &d,
        "long_name",
        "physical-validity warnings of the run, one per line (empty when none)",
    )?;
    attach_grid(&d)?;
    let d = dataset(&file, "verified", &shape, &verified)?;
    attr_vec(&d, "flag_values", &[VERIFY_NONE, VERIFY_OK, VERIFY_FAILED])?;
    attr_str(
        &d,
        "flag_meanings",
        "not_verified verified verification_failed",
    )?;
    attr_str(
        &d,
        "long_name",
        "whether the point was re-run at a tighter setting (run --verify)",
    )?;
    attach_grid(&d)?;
    let d = dataset(&file, "verify_rel_error_max", &shape, &verr_max)?;
    attr_str(&d, "units", "1")?;
    attr_str(
        &d,
        "long_name",
        "largest verify_rel_error_* over the probes (NaN where not verified)",
    )?;
    attach_grid(&d)?;
    let d = str_dataset(&file, "run_hash", &shape, &run_hash)?;
    attr_str(
        &d,
        "long_name",
        "SHA-256 identity of the run: numerics version, solver version, limits, full scene",
    )?;
    attach_grid(&d)?;

    if let Some((pscale, units)) = &probe_scale {
        let mut pshape = shape.clone();
        pshape.push(np);
        let same_units = units.iter().all(|u| u == &units[0]);
        let pnames: [(&str, bool, &str); 4] = [
            (
                "leading_peak",
                false,
                "peak of the leading pulse (first excursion), refined between samples",
            ),
            ("leading_peak_time_s", true, "time of the leading peak"),
            (
                "record_max",
                false,
                "maximum over the whole record, refined between samples",
            ),
            ("record_max_time_s", true, "time of the record maximum"),
        ];
        for ((name, is_time, long), data) in pnames.iter().zip(&psum) {
            let d = dataset(&file, name, &pshape, data)?;
            let u = if *is_time {
                "s"
            } else if same_units {
                units[0].as_str()
            } else {
                "see probe_units"
            };
            attr_str(&d, "units", u)?;
            attr_str(&d, "long_name", long)?;
            attach_grid(&d)?;
            attach_scale(&d, pscale, shape.len(), "probe")?;
        }
        let vnames: [(&str, &str); 3] = [
            (
                "verify_rel_error_leading_peak",
                "relative error of leading_peak against the verification run",
            ),
            (
                "verify_rel_error_leading_peak_time",
                "relative error of leading_peak_time_s against the verification run",
            ),
            (
                "verify_rel_error_record_max",
                "relative error of record_max against the verification run",
            ),
        ];
        for ((name, long), data) in vnames.iter().zip(&verr) {
            let d = dataset(&file, name, &pshape, data)?;
            attr_str(&d, "units", "1")?;
            attr_str(&d, "long_name", long)?;
            attach_grid(&d)?;
            attach_scale(&d, pscale, shape.len(), "probe")?;
        }
    }
    file.flush()?;
    drop(scales);
    drop(probe_scale);
    drop(runs);
    file.close()?;
    Ok(counts)
}

/// A sweep file's records read back from an HDF5 file (for `merge`).
pub struct FileRecords {
    /// The `sweep` root attribute (the sweep file's text).
    pub sweep_text: String,
    /// The file.
    file: File,
    status: Vec<u8>,
    reason: Vec<String>,
    run_hash: Vec<String>,
    scal: Vec<Vec<f64>>,
    ints: Vec<Vec<i64>>,
    psum: Vec<Vec<f64>>,
    warnings: Vec<String>,
    verified: Vec<u8>,
    verr: Vec<Vec<f64>>,
    /// The `verify_fraction` root attribute (0 in files without it).
    pub verify_fraction: f64,
    /// The `shard` root attribute (`K/N`).
    pub shard: String,
    n: usize,
}

fn read_attr_str(loc: &Location, name: &str) -> Result<String> {
    let v: VarLenUnicode = loc.attr(name)?.read_scalar()?;
    Ok(v.as_str().to_string())
}

/// Writes what `integrator: auto` chose as root attributes: `auto` (the whole record as JSON,
/// every candidate of the pilot included), `auto_target_rel_error`, `auto_safety_factor`,
/// `auto_method`, `auto_setting` (JSON of the chosen integrator), `auto_pilot_points` (flat
/// indices), `auto_pilot_references` (JSON list), `auto_pilot_errors`, `auto_pilot_rhs_evals`
/// (of the chosen setting, per pilot point) and `auto_pilot_cost_rhs_evals` (the whole pilot).
fn write_auto_attrs(file: &File, c: &AutoChoice) -> Result<()> {
    attr_str(file, "auto", &c.to_json())?;
    attr_scalar(file, "auto_target_rel_error", c.target_rel_error)?;
    attr_scalar(file, "auto_safety_factor", c.safety_factor)?;
    attr_str(file, "auto_method", c.integrator.method_name())?;
    attr_str(
        file,
        "auto_setting",
        &serde_json::to_string(&c.integrator).expect("json"),
    )?;
    let pts: Vec<i64> = c.pilot_points.iter().map(|&i| i as i64).collect();
    attr_vec(file, "auto_pilot_points", &pts)?;
    attr_str(
        file,
        "auto_pilot_references",
        &serde_json::to_string(&c.pilot_references).expect("json"),
    )?;
    attr_vec(file, "auto_pilot_errors", &c.pilot_errors)?;
    let ev: Vec<i64> = c.pilot_rhs_evals.iter().map(|&e| e as i64).collect();
    attr_vec(file, "auto_pilot_rhs_evals", &ev)?;
    attr_scalar(
        file,
        "auto_pilot_cost_rhs_evals",
        c.pilot_cost_rhs_evals as i64,
    )?;
    Ok(())
}

/// Reads what `integrator: auto` chose from an output file's `auto` attribute (`None` when the
/// file has none).
pub fn read_auto_choice(path: &Path) -> Result<Option<AutoChoice>> {
    let f = File::open(path)?;
    if !f.attr_names()?.iter().any(|a| a == "auto") {
        return Ok(None);
    }
    AutoChoice::from_json(&read_attr_str(&f, "auto")?).map(Some)
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
    let f = File::open(path)?;
    read_attr_str(&f, "sweep")
}

fn read_strs(f: &File, name: &str) -> Result<Vec<String>> {
    let v: Vec<VarLenUnicode> = f.dataset(name)?.read_raw()?;
    Ok(v.iter().map(|s| s.as_str().to_string()).collect())
}

impl FileRecords {
    /// Opens a file and reads its per-point arrays.
    pub fn open(path: &Path) -> Result<FileRecords> {
        let file = File::open(path)?;
        let sweep_text = read_attr_str(&file, "sweep")?;
        let shard = read_attr_str(&file, "shard")?;
        let status: Vec<u8> = file.dataset("status")?.read_raw()?;
        let n = status.len();
        let reason = read_strs(&file, "reason")?;
        let run_hash = read_strs(&file, "run_hash")?;
        let mut scal = Vec::new();
        for name in [
            "t_end_s",
            "energy_drift_max",
            "energy_drift_final",
            "momentum_residual_max",
            "impact_energy_j",
            "wall_time_s",
        ] {
            scal.push(file.dataset(name)?.read_raw::<f64>()?);
        }
        // Fields added with numerics version 2 (absent from older files).
        scal.push(if file.link_exists("max_overlap_m") {
            file.dataset("max_overlap_m")?.read_raw::<f64>()?
        } else {
            vec![f64::NAN; n]
        });
        let mut ints = Vec::new();
        for name in ["steps", "rejected_steps", "rhs_evals"] {
            ints.push(file.dataset(name)?.read_raw::<i64>()?);
        }
        ints.push(if file.link_exists("events") {
            file.dataset("events")?.read_raw::<i64>()?
        } else {
            vec![0; n]
        });
        let warnings = if file.link_exists("warnings") {
            read_strs(&file, "warnings")?
        } else {
            vec![String::new(); n]
        };
        let verified: Vec<u8> = if file.link_exists("verified") {
            file.dataset("verified")?.read_raw()?
        } else {
            vec![VERIFY_NONE; n]
        };
        let mut verr = Vec::new();
        if file.link_exists("verify_rel_error_leading_peak") {
            for name in [
                "verify_rel_error_leading_peak",
                "verify_rel_error_leading_peak_time",
                "verify_rel_error_record_max",
            ] {
                verr.push(file.dataset(name)?.read_raw::<f64>()?);
            }
        }
        let verify_fraction = if file.attr_names()?.iter().any(|a| a == "verify_fraction") {
            file.attr("verify_fraction")?.read_scalar::<f64>()?
        } else {
            0.0
        };
        let mut psum = Vec::new();
        if file.link_exists("leading_peak") {
            for name in [
                "leading_peak",
                "leading_peak_time_s",
                "record_max",
                "record_max_time_s",
            ] {
                psum.push(file.dataset(name)?.read_raw::<f64>()?);
            }
        }
        Ok(FileRecords {
            sweep_text,
            file,
            status,
            reason,
            run_hash,
            scal,
            ints,
            psum,
            warnings,
            verified,
            verr,
            verify_fraction,
            shard,
            n,
        })
    }

    /// Status code of point `i` ([`STATUS_OK`], [`STATUS_FAILED`] or [`STATUS_PENDING`]).
    pub fn status(&self, i: usize) -> u8 {
        self.status[i]
    }

    /// Why point `i` failed (empty unless it did).
    pub fn reason(&self, i: usize) -> &str {
        &self.reason[i]
    }

    /// The verification outcome stored for point `i` (`np` probes).
    pub fn verify_info(&self, i: usize, np: usize) -> VerifyInfo {
        let status = self.verified[i];
        if status != VERIFY_OK || self.verr.len() < 3 {
            return VerifyInfo {
                status,
                errors: vec![[f64::NAN; 3]; np],
            };
        }
        VerifyInfo {
            status,
            errors: (0..np)
                .map(|p| {
                    [
                        self.verr[0][i * np + p],
                        self.verr[1][i * np + p],
                        self.verr[2][i * np + p],
                    ]
                })
                .collect(),
        }
    }

    /// Number of grid points in the file.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the file has no grid points.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Run hash (hex) stored for point `i`.
    pub fn hash_hex(&self, i: usize) -> &str {
        &self.run_hash[i]
    }

    /// The record of point `i`, or `None` if it is pending in this file.
    pub fn record(&self, i: usize, hash: RunHash, grid: &Grid) -> Result<Option<RunRecord>> {
        let st = self.status[i];
        if st == STATUS_PENDING {
            return Ok(None);
        }
        let wall = self.scal[5][i];
        if st == STATUS_FAILED {
            return Ok(Some(RunRecord::failed(hash, self.reason[i].clone(), wall)));
        }
        let np = grid.probes.len();
        let probes = (0..np)
            .map(|p| ProbeSummary {
                leading_peak: self.psum[0][i * np + p],
                leading_peak_time_s: self.psum[1][i * np + p],
                record_max: self.psum[2][i * np + p],
                record_max_time_s: self.psum[3][i * np + p],
            })
            .collect();
        let mut history = None;
        let mut min_overlap_m = None;
        if grid.history || grid.min_overlap {
            let g = self
                .file
                .group(&format!("runs/{}", run_group_name(grid.len(), i)))?;
            if grid.history {
                let time_s = g.dataset("time_s")?.read_raw::<f64>()?;
                let mut values = Vec::with_capacity(np);
                for p in &grid.probes {
                    values.push(g.dataset(&p.name())?.read_raw::<f64>()?);
                }
                history = Some(History { time_s, values });
            }
            if grid.min_overlap {
                min_overlap_m = Some(g.dataset("min_overlap_m")?.read_raw::<f64>()?);
            }
        }
        Ok(Some(RunRecord {
            hash,
            ok: true,
            reason: String::new(),
            steps: self.ints[0][i] as u64,
            rejected: self.ints[1][i] as u64,
            rhs_evals: self.ints[2][i] as u64,
            events: self.ints[3][i] as u64,
            t_end_s: self.scal[0][i],
            energy_drift_max: self.scal[1][i],
            energy_drift_final: self.scal[2][i],
            momentum_residual_max: self.scal[3][i],
            impact_energy_j: self.scal[4][i],
            wall_time_s: wall,
            max_overlap_m: self.scal[6][i],
            warnings: self.warnings[i].clone(),
            probes,
            min_overlap_m,
            history,
        }))
    }
}
