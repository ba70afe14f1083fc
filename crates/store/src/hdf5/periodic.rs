//! The output file of a sweep with a `periodic` block: at every point of the sweep's axes, one
//! branch of periodic orbits over one more dimension, `branch_point` (each branch's points in
//! order along it, padded where a branch has fewer).
//!
//! Over (axes…, `branch_point`): the continued field, named like it (a coordinate, NaN where no
//! point), `point_kind` (flags: regular, start, end, fold, branch point, period doubling,
//! Neimark–Sacker), `stability` (flags), `largest_multiplier`, `arclength`, `newton_iterations`,
//! `period_maps`, `monodromy_method` (flags), `orbit_residual`; with `multiplier` after them,
//! `multiplier_real` and `multiplier_imag` (the Floquet multipliers, largest modulus first);
//! with `particle`, `orbit_position_m` and `orbit_velocity_m_s` (the orbit's state at `t = 0`);
//! with `probe` (and `harmonic`), each probe's `orbit_amplitude` and `orbit_phase_rad` per
//! harmonic, `orbit_mean`, `orbit_rms`, `orbit_max` and `orbit_settledness` over two orbit
//! periods, one variable per unit where the probes' units differ (`orbit_amplitude_N`, …: NaN at
//! the probes of other units). Over the axes: `branch_status` (flags), `branch_points`,
//! `branch_period_maps` and `branch_end` (why the branch ended, in a sentence).
//!
//! Every numeric dataset is chunked with the Fletcher-32 filter: a damaged chunk is a read error,
//! never a wrong number.

use std::path::Path;

use hdf5::{Dataset, File};

use super::write::{coordinate_names, write_coordinates, write_probe_scale, write_sweep_attrs};
use super::{
    attach_scale, attr_str, attr_vec, char_dataset, checked_dataset, filled_checked_dataset,
    number_dimensions, read_text, set_scale, Provenance, Text,
};
use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::grid::Grid;
use chainsweep_sweep::record::columns::unit_suffix;
use chainsweep_sweep::sweep::Sweep;

/// A branch not computed (yet).
pub const BRANCH_PENDING: u8 = 0;
/// A branch that ended (at the end of its range, at its step or point limit).
pub const BRANCH_OK: u8 = 1;
/// A branch without a first orbit.
pub const BRANCH_FAILED: u8 = 2;
const BRANCH_FLAGS: &[u8] = &[BRANCH_PENDING, BRANCH_OK, BRANCH_FAILED];
const BRANCH_MEANINGS: &str = "pending ended failed";

/// `point_kind`'s flag meanings, in the order of their values from 1 (0: no point), as
/// [`chainsweep_solver::periodic::PointKind::ALL`] lists the kinds.
const KIND_MEANINGS: &str =
    "none regular start end fold branch_point period_doubling neimark_sacker";
const STABILITY_MEANINGS: &str = "none stable unstable";
const METHOD_MEANINGS: &str = "none variational finite_difference";

/// One orbit of a branch, as stored.
#[derive(Debug, Clone, Default)]
pub struct StoredPoint {
    /// The continued field's value.
    pub parameter: f64,
    /// `point_kind` (1 + the kind's code).
    pub kind: u8,
    /// `stability`: 1 stable, 2 unstable.
    pub stability: u8,
    /// Largest modulus of the multipliers.
    pub largest_multiplier: f64,
    /// The multipliers, largest modulus first.
    pub multipliers: Vec<(f64, f64)>,
    /// Positions at `t = 0`, m.
    pub position_m: Vec<f64>,
    /// Velocities at `t = 0`, m/s.
    pub velocity_m_s: Vec<f64>,
    /// Scaled arclength from the start.
    pub arclength: f64,
    /// Newton iterations.
    pub iterations: i64,
    /// Period maps of the point's last solve.
    pub maps: i64,
    /// `monodromy_method`: 1 variational, 2 finite differences.
    pub method: u8,
    /// Scaled residual.
    pub residual: f64,
    /// Per probe and harmonic (probe-major): amplitude and phase.
    pub amplitude: Vec<f64>,
    /// As `amplitude`.
    pub phase_rad: Vec<f64>,
    /// Per probe.
    pub mean: Vec<f64>,
    /// Per probe.
    pub rms: Vec<f64>,
    /// Per probe.
    pub max: Vec<f64>,
    /// Per probe.
    pub settledness: Vec<f64>,
}

/// One branch, as stored.
#[derive(Debug, Clone, Default)]
pub struct StoredBranch {
    /// `branch_status`.
    pub status: u8,
    /// Why it ended.
    pub end: String,
    /// Period maps of the whole continuation.
    pub maps: i64,
    /// Its points in order.
    pub points: Vec<StoredPoint>,
}

/// What a periodic sweep's file holds besides the sweep's own coordinates.
pub struct PeriodicTables<'a> {
    /// The continued field's name (its coordinate), dotted path and unit.
    pub name: &'a str,
    /// Dotted path.
    pub field: &'a str,
    /// Unit.
    pub units: &'a str,
    /// The sweep's `periodic` block in a sentence (the root attribute `periodic`).
    pub description: String,
    /// Particles of the chain.
    pub particles: usize,
    /// Multipliers per orbit.
    pub multipliers: usize,
    /// Harmonics analysed per probe.
    pub harmonics: usize,
    /// One branch per grid point, in grid order.
    pub branches: &'a [StoredBranch],
}

fn attach(d: &Dataset, scales: &[(&Dataset, &str)]) -> Result<()> {
    for (k, (s, name)) in scales.iter().enumerate() {
        attach_scale(d, s, k, name)?;
    }
    Ok(())
}

/// An integer dimension scale `0..n` (or `1..=n` with `from_one`) named `name`.
fn index_scale(
    file: &File,
    name: &str,
    n: usize,
    from_one: bool,
    long_name: &str,
) -> Result<Dataset> {
    let ids: Vec<i64> = (0..n as i64).map(|i| i + i64::from(from_one)).collect();
    let d = checked_dataset(file, name, &[n], &ids)?;
    set_scale(&d, name)?;
    attr_str(&d, "units", "1")?;
    attr_str(&d, "long_name", long_name)?;
    Ok(d)
}

/// Writes the output file of a periodic sweep to `path`.
pub fn write_file(
    path: &Path,
    sweep: &Sweep,
    grid: &Grid,
    prov: &Provenance,
    t: &PeriodicTables<'_>,
) -> Result<()> {
    let write = || -> Result<()> {
        let file = super::create_file(path)?;
        write_sweep_attrs(&file, sweep, grid, None, prov)?;
        attr_str(&file, "periodic", &t.description)?;
        attr_str(&file, "periodic_field", t.field)?;
        // The branches counted as a sweep's runs are: ended ok, failed, pending.
        let count = |status: u8| t.branches.iter().filter(|b| b.status == status).count() as i64;
        super::attr_scalar(&file, "n_runs", t.branches.len() as i64)?;
        super::attr_scalar(&file, "n_ok", count(BRANCH_OK))?;
        super::attr_scalar(&file, "n_failed", count(BRANCH_FAILED))?;
        super::attr_scalar(&file, "n_pending", count(BRANCH_PENDING))?;
        let (dims, mut text_scales) = write_coordinates(&file, sweep)?;
        let probe_scale = write_probe_scale(&file, grid)?;
        if let Some(p) = &probe_scale {
            text_scales.push(("probe".to_string(), p.strlen.clone()));
        }
        let npoints = t
            .branches
            .iter()
            .map(|b| b.points.len())
            .max()
            .unwrap_or(0)
            .max(1);
        let point_scale = index_scale(
            &file,
            "branch_point",
            npoints,
            false,
            "point along the branch, in order",
        )?;
        let particle = index_scale(
            &file,
            "particle",
            t.particles,
            true,
            "particle (1 at the top)",
        )?;
        let multiplier = index_scale(
            &file,
            "multiplier",
            t.multipliers.max(1),
            false,
            "Floquet multiplier, largest modulus first",
        )?;
        let harmonic = index_scale(
            &file,
            "harmonic",
            t.harmonics.max(1),
            true,
            "harmonic of the orbit's frequency",
        )?;

        let outer: Vec<(&Dataset, &str)> =
            dims.iter().map(|d| (&d.scale, d.name.as_str())).collect();
        let outer_shape: Vec<usize> = sweep.dims.iter().map(|d| d.len()).collect();
        let branches = t.branches.len();
        let mut point_shape = outer_shape.clone();
        point_shape.push(npoints);
        let mut point_scales = outer.clone();
        point_scales.push((&point_scale, "branch_point"));
        let mut coordinates: Vec<&str> = coordinate_names(&dims, &[]);
        coordinates.push(t.name);
        let coordinates = coordinates.join(" ");

        // A value per point, padded with `fill`.
        let per_point = |get: &dyn Fn(&StoredPoint) -> f64| -> Vec<f64> {
            let mut v = vec![f64::NAN; branches * npoints];
            for (b, branch) in t.branches.iter().enumerate() {
                for (k, p) in branch.points.iter().enumerate() {
                    v[b * npoints + k] = get(p);
                }
            }
            v
        };
        let per_point_u8 = |get: &dyn Fn(&StoredPoint) -> u8| -> Vec<u8> {
            let mut v = vec![0u8; branches * npoints];
            for (b, branch) in t.branches.iter().enumerate() {
                for (k, p) in branch.points.iter().enumerate() {
                    v[b * npoints + k] = get(p);
                }
            }
            v
        };
        let per_point_i64 = |get: &dyn Fn(&StoredPoint) -> i64| -> Vec<i64> {
            let mut v = vec![-1i64; branches * npoints];
            for (b, branch) in t.branches.iter().enumerate() {
                for (k, p) in branch.points.iter().enumerate() {
                    v[b * npoints + k] = get(p);
                }
            }
            v
        };
        let float = |name: &str,
                     data: &[f64],
                     shape: &[usize],
                     scales: &[(&Dataset, &str)],
                     units: Option<&str>,
                     long_name: &str,
                     comment: &str|
         -> Result<Dataset> {
            let d = filled_checked_dataset(&file, name, shape, data, f64::NAN)?;
            attach(&d, scales)?;
            if let Some(u) = units {
                attr_str(&d, "units", u)?;
            }
            attr_str(&d, "long_name", long_name)?;
            if !comment.is_empty() {
                attr_str(&d, "comment", comment)?;
            }
            Ok(d)
        };
        let flags = |name: &str,
                     data: &[u8],
                     shape: &[usize],
                     scales: &[(&Dataset, &str)],
                     meanings: &str,
                     long_name: &str|
         -> Result<Dataset> {
            let d = checked_dataset(&file, name, shape, data)?;
            attach(&d, scales)?;
            let values: Vec<u8> = (0..meanings.split(' ').count() as u8).collect();
            attr_vec(&d, "flag_values", &values)?;
            attr_str(&d, "flag_meanings", meanings)?;
            attr_str(&d, "long_name", long_name)?;
            Ok(d)
        };

        // The continued field: a coordinate of everything over the points.
        let d = float(
            t.name,
            &per_point(&|p| p.parameter),
            &point_shape,
            &point_scales,
            Some(t.units),
            &chainsweep_sweep::sweep::human_name(t.name),
            &format!("{} at each point of the branch", t.field),
        )?;
        attr_str(&d, "field", t.field)?;
        let d = flags(
            "point_kind",
            &per_point_u8(&|p| p.kind),
            &point_shape,
            &point_scales,
            KIND_MEANINGS,
            "what the point is",
        )?;
        attr_str(&d, "coordinates", &coordinates)?;
        attr_str(&d, "comment", "a fold (saddle-node) where the branch turns back, a branch point where another branch crosses, a period doubling where a multiplier passes -1, a Neimark-Sacker point where a complex pair leaves the unit circle: located, not stepped to")?;
        let d = flags(
            "stability",
            &per_point_u8(&|p| p.stability),
            &point_shape,
            &point_scales,
            STABILITY_MEANINGS,
            "stability of the orbit",
        )?;
        attr_str(&d, "coordinates", &coordinates)?;
        attr_str(
            &d,
            "comment",
            "stable where every Floquet multiplier lies inside the unit circle",
        )?;
        for (name, get, long_name, comment) in [
            (
                "largest_multiplier",
                (&|p: &StoredPoint| p.largest_multiplier) as &dyn Fn(&StoredPoint) -> f64,
                "largest Floquet multiplier modulus",
                "above 1: unstable",
            ),
            (
                "arclength",
                &|p: &StoredPoint| p.arclength,
                "arclength",
                "scaled arclength along the branch from its start",
            ),
            (
                "orbit_residual",
                &|p: &StoredPoint| p.residual,
                "orbit residual",
                "max |P(x) - x| / scale of the converged orbit, P the period map",
            ),
        ] {
            let d = float(
                name,
                &per_point(get),
                &point_shape,
                &point_scales,
                Some("1"),
                long_name,
                comment,
            )?;
            attr_str(&d, "coordinates", &coordinates)?;
        }
        for (name, get, long_name) in [
            (
                "newton_iterations",
                (&|p: &StoredPoint| p.iterations) as &dyn Fn(&StoredPoint) -> i64,
                "Newton iterations of the orbit",
            ),
            (
                "period_maps",
                &|p: &StoredPoint| p.maps,
                "period maps integrated for the orbit's last solve",
            ),
        ] {
            let d = filled_checked_dataset(&file, name, &point_shape, &per_point_i64(get), -1i64)?;
            attach(&d, &point_scales)?;
            attr_str(&d, "units", "1")?;
            attr_str(&d, "long_name", long_name)?;
            attr_str(&d, "coordinates", &coordinates)?;
        }
        let d = flags(
            "monodromy_method",
            &per_point_u8(&|p| p.method),
            &point_shape,
            &point_scales,
            METHOD_MEANINGS,
            "how the monodromy matrix was computed",
        )?;
        attr_str(&d, "coordinates", &coordinates)?;

        // Over (…, branch_point, inner): the multipliers, the state, the probes.
        let inner = |n: usize, get: &dyn Fn(&StoredPoint) -> Vec<f64>| -> Vec<f64> {
            let mut v = vec![f64::NAN; branches * npoints * n];
            for (b, branch) in t.branches.iter().enumerate() {
                for (k, p) in branch.points.iter().enumerate() {
                    let row = get(p);
                    let at = (b * npoints + k) * n;
                    v[at..at + row.len().min(n)].copy_from_slice(&row[..row.len().min(n)]);
                }
            }
            v
        };
        let nm = t.multipliers.max(1);
        let mut shape = point_shape.clone();
        shape.push(nm);
        let mut scales = point_scales.clone();
        scales.push((&multiplier, "multiplier"));
        for (name, part, long_name) in [
            ("multiplier_real", 0, "Floquet multiplier, real part"),
            ("multiplier_imag", 1, "Floquet multiplier, imaginary part"),
        ] {
            let data = inner(nm, &|p| {
                p.multipliers
                    .iter()
                    .map(|m| if part == 0 { m.0 } else { m.1 })
                    .collect()
            });
            let d = float(name, &data, &shape, &scales, Some("1"), long_name, "")?;
            attr_str(&d, "coordinates", &coordinates)?;
        }
        let mut shape = point_shape.clone();
        shape.push(t.particles);
        let mut scales = point_scales.clone();
        scales.push((&particle, "particle"));
        for (name, units, get, long_name) in [
            (
                "orbit_position_m",
                "m",
                (&|p: &StoredPoint| p.position_m.clone()) as &dyn Fn(&StoredPoint) -> Vec<f64>,
                "position at the orbit's start",
            ),
            (
                "orbit_velocity_m_s",
                "m/s",
                &|p: &StoredPoint| p.velocity_m_s.clone(),
                "velocity at the orbit's start",
            ),
        ] {
            let d = float(name, &inner(t.particles, get), &shape, &scales, Some(units), long_name, "the orbit's state at t = 0 (the drive's phase at its start); positions from the undeformed chain, positive towards the wall")?;
            attr_str(&d, "coordinates", &coordinates)?;
        }
        if let Some(ps) = &probe_scale {
            let np = grid.probes.len();
            let units = &ps.units;
            let mixed = units.iter().any(|u| u != &units[0]);
            let mut distinct: Vec<&String> = Vec::new();
            for u in units {
                if !distinct.contains(&u) {
                    distinct.push(u);
                }
            }
            let nh = t.harmonics.max(1);
            let mut probe_shape = point_shape.clone();
            probe_shape.push(np);
            let mut probe_scales = point_scales.clone();
            probe_scales.push((&ps.scale, "probe"));
            let mut harmonic_shape = probe_shape.clone();
            harmonic_shape.push(nh);
            let mut harmonic_scales = probe_scales.clone();
            harmonic_scales.push((&harmonic, "harmonic"));
            let masked = |data: Vec<f64>, width: usize, unit: &str| -> Vec<f64> {
                let mut v = data;
                for (i, x) in v.iter_mut().enumerate() {
                    if units[(i / width) % np] != *unit {
                        *x = f64::NAN;
                    }
                }
                v
            };
            for (name, long_name, get, width) in [
                (
                    "orbit_amplitude",
                    "amplitude of each harmonic over the orbit",
                    (&|p: &StoredPoint| p.amplitude.clone()) as &dyn Fn(&StoredPoint) -> Vec<f64>,
                    nh,
                ),
                (
                    "orbit_mean",
                    "mean over the orbit",
                    &|p: &StoredPoint| p.mean.clone(),
                    1,
                ),
                (
                    "orbit_rms",
                    "root mean square over the orbit",
                    &|p: &StoredPoint| p.rms.clone(),
                    1,
                ),
                (
                    "orbit_max",
                    "largest value over the orbit",
                    &|p: &StoredPoint| p.max.clone(),
                    1,
                ),
            ] {
                let data = inner(np * width, get);
                let (shape, scales) = if width > 1 {
                    (&harmonic_shape, &harmonic_scales)
                } else {
                    (&probe_shape, &probe_scales)
                };
                for unit in &distinct {
                    let (vname, values) = if mixed {
                        (
                            format!("{name}_{}", unit_suffix(unit)),
                            masked(data.clone(), width, unit),
                        )
                    } else {
                        (name.to_string(), data.clone())
                    };
                    let d = float(&vname, &values, shape, scales, Some(unit), long_name, "over two orbit periods from the orbit's start, with the definitions of record.steady_state")?;
                    attr_str(&d, "coordinates", &coordinates)?;
                    if !mixed {
                        break;
                    }
                }
            }
            let d = float(
                "orbit_phase_rad",
                &inner(np * nh, &|p| p.phase_rad.clone()),
                &harmonic_shape,
                &harmonic_scales,
                Some("rad"),
                "phase of each harmonic over the orbit",
                "of A cos(2 pi k f t + phase), t from the orbit's start",
            )?;
            attr_str(&d, "coordinates", &coordinates)?;
            let d = float("orbit_settledness", &inner(np, &|p| p.settledness.clone()), &probe_shape, &probe_scales, Some("1"), "change between the orbit's two periods", "record.steady_state's settledness over two periods of the orbit: rounding for a periodic orbit")?;
            attr_str(&d, "coordinates", &coordinates)?;
        }

        // Per branch.
        let status: Vec<u8> = t.branches.iter().map(|b| b.status).collect();
        let d = checked_dataset(&file, "branch_status", &outer_shape, &status)?;
        attach(&d, &outer)?;
        attr_vec(&d, "flag_values", BRANCH_FLAGS)?;
        attr_str(&d, "flag_meanings", BRANCH_MEANINGS)?;
        attr_str(&d, "long_name", "how each branch ended")?;
        for (name, get, long_name) in [
            (
                "branch_points",
                (&|b: &StoredBranch| b.points.len() as i64) as &dyn Fn(&StoredBranch) -> i64,
                "points of each branch",
            ),
            (
                "branch_period_maps",
                &|b: &StoredBranch| b.maps,
                "period maps integrated for each branch",
            ),
        ] {
            let v: Vec<i64> = t.branches.iter().map(get).collect();
            let d = filled_checked_dataset(&file, name, &outer_shape, &v, -1i64)?;
            attach(&d, &outer)?;
            attr_str(&d, "units", "1")?;
            attr_str(&d, "long_name", long_name)?;
        }
        let reasons: Vec<String> = t.branches.iter().map(|b| b.end.clone()).collect();
        let d = char_dataset(
            &file,
            "branch_end",
            &outer_shape,
            &reasons,
            None,
            Text::Free,
        )?
        .data;
        attach(&d, &outer)?;
        attr_str(&d, "long_name", "why each branch ended, in a sentence")?;
        number_dimensions(&file, &text_scales)?;
        file.flush().map_err(crate::h5)?;
        drop(dims);
        drop(probe_scale);
        file.close().map_err(crate::h5)?;
        Ok(())
    };
    write().map_err(|e| e.hdf5_context(|| format!("writing {}", path.display())))
}

/// Whether the file at `path` opens and is a periodic sweep's (its root attribute `periodic`).
pub fn is_periodic(path: &Path) -> bool {
    File::open(path).is_ok_and(|f| f.attr("periodic").is_ok())
}

/// One branch as `status` reads it: its `branch_status`, its points, the `point_kind` of each
/// (padded with 0) and why it ended.
pub type BranchSummary = (u8, i64, Vec<u8>, String);

/// What `status` shows of a periodic sweep's file: per branch, its status, points, special
/// points by kind and why it ended; `None` for a file of another kind.
pub fn read_summary(path: &Path) -> Result<Option<Vec<BranchSummary>>> {
    if !is_periodic(path) {
        return Ok(None);
    }
    let file = File::open(path).map_err(crate::h5)?;
    let status: Vec<u8> = file
        .dataset("branch_status")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let points: Vec<i64> = file
        .dataset("branch_points")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let kinds: Vec<u8> = file
        .dataset("point_kind")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let ends = read_text(&file.dataset("branch_end").map_err(crate::h5)?)?;
    let n = status.len().max(1);
    let per = kinds.len() / n;
    if status.len() != points.len() || status.len() != ends.len() {
        return Err(Error::Other(format!(
            "{}: the branch tables disagree in length",
            path.display()
        )));
    }
    Ok(Some(
        (0..status.len())
            .map(|b| {
                (
                    status[b],
                    points[b],
                    kinds[b * per..(b + 1) * per].to_vec(),
                    ends[b].clone(),
                )
            })
            .collect(),
    ))
}

/// Reads every dataset of the file at `path` with HDF5's checks on: the error names the first
/// that fails its Fletcher-32 checksum.
pub fn check_every_dataset(path: &Path) -> Result<()> {
    let file = File::open(path).map_err(crate::h5)?;
    for name in file.member_names().map_err(crate::h5)? {
        if let Ok(d) = file.dataset(&name) {
            super::passes_filter_check(&d)?;
        }
    }
    Ok(())
}

/// The continued field's values over (axes…, `branch_point`), in order, read with the checks on.
pub fn read_parameter(path: &Path) -> Result<Vec<f64>> {
    let file = File::open(path).map_err(crate::h5)?;
    let name = super::read_attr_str(&file, "periodic_field")?;
    // The coordinate is named after the field's `name`: the variable whose `field` attribute
    // is the continued field and whose last dimension is `branch_point`.
    for member in file.member_names().map_err(crate::h5)? {
        if let Ok(d) = file.dataset(&member) {
            let is_it = d
                .attr("field")
                .ok()
                .and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>().ok())
                .is_some_and(|f| f.as_str() == name);
            if is_it && d.ndim() >= 1 && d.dtype().is_ok_and(|t| t.size() == 8) {
                let v: Vec<f64> = d.read_raw().map_err(crate::h5)?;
                if v.len() != d.size() || member == "branch_point" {
                    continue;
                }
                return Ok(v);
            }
        }
    }
    Err(Error::Other(format!(
        "{}: no coordinate of the continued field {name}",
        path.display()
    )))
}

/// The name of a `point_kind` flag value.
pub fn kind_name(flag: u8) -> &'static str {
    KIND_MEANINGS
        .split(' ')
        .nth(flag as usize)
        .unwrap_or("unknown")
}

/// What a report draws of a periodic sweep's file, read with the checks on.
#[derive(Debug, Clone)]
pub struct BranchTables {
    /// The sweep file's text.
    pub sweep_text: String,
    /// The continued field's name (its coordinate) and unit.
    pub name: String,
    /// Its unit.
    pub units: String,
    /// Branches (grid points) and points per branch (the `branch_point` dimension).
    pub branches: usize,
    /// Points per branch in the file.
    pub per_branch: usize,
    /// The continued field, `point_kind`, `stability` and `largest_multiplier` over (branch,
    /// point).
    pub parameter: Vec<f64>,
    /// As `parameter`.
    pub kind: Vec<u8>,
    /// As `parameter`.
    pub stability: Vec<u8>,
    /// As `parameter`.
    pub largest_multiplier: Vec<f64>,
    /// Probe names and units.
    pub probes: Vec<(String, String)>,
    /// Each probe's fundamental amplitude over (branch, point, probe), in its own unit.
    pub amplitude: Vec<f64>,
}

/// The tables of the periodic sweep's file `path` a report draws.
pub fn read_tables(path: &Path) -> Result<BranchTables> {
    let file = File::open(path).map_err(crate::h5)?;
    let sweep_text = super::read_attr_str(&file, "sweep")?;
    let field = super::read_attr_str(&file, "periodic_field")?;
    let status: Vec<u8> = file
        .dataset("branch_status")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let branches = status.len();
    let kind: Vec<u8> = file
        .dataset("point_kind")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let per_branch = kind.len() / branches.max(1);
    let parameter = read_parameter(path)?;
    let stability: Vec<u8> = file
        .dataset("stability")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let largest_multiplier: Vec<f64> = file
        .dataset("largest_multiplier")
        .map_err(crate::h5)?
        .read_raw()
        .map_err(crate::h5)?;
    let name = file
        .member_names()
        .map_err(crate::h5)?
        .into_iter()
        .find(|m| {
            file.dataset(m).ok().is_some_and(|d| {
                d.attr("field")
                    .ok()
                    .and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>().ok())
                    .is_some_and(|f| f.as_str() == field)
                    && d.size() == kind.len()
            })
        })
        .unwrap_or_else(|| field.clone());
    let units = file
        .dataset(&name)
        .ok()
        .and_then(|d| d.attr("units").ok())
        .and_then(|a| a.read_scalar::<hdf5::types::VarLenUnicode>().ok())
        .map(|u| u.as_str().to_string())
        .unwrap_or_default();
    let (mut probes, mut amplitude) = (Vec::new(), Vec::new());
    if let Ok(d) = file.dataset("probe") {
        let names = read_text(&d)?;
        let units = read_text(&file.dataset("probe_units").map_err(crate::h5)?)?;
        let np = names.len();
        amplitude = vec![f64::NAN; branches * per_branch * np];
        let mut distinct: Vec<&String> = Vec::new();
        for u in &units {
            if !distinct.contains(&u) {
                distinct.push(u);
            }
        }
        let datasets: Vec<String> = if distinct.len() > 1 {
            distinct
                .iter()
                .map(|u| format!("orbit_amplitude_{}", unit_suffix(u)))
                .collect()
        } else {
            vec!["orbit_amplitude".to_string()]
        };
        for name in datasets {
            let d = file.dataset(&name).map_err(crate::h5)?;
            let values: Vec<f64> = d.read_raw().map_err(crate::h5)?;
            let harmonics = values.len() / (branches * per_branch * np).max(1);
            for (i, a) in amplitude.iter_mut().enumerate() {
                let v = values[i * harmonics];
                if v.is_finite() {
                    *a = v;
                }
            }
        }
        probes = names.into_iter().zip(units).collect();
    }
    Ok(BranchTables {
        sweep_text,
        name,
        units,
        branches,
        per_branch,
        parameter,
        kind,
        stability,
        largest_multiplier,
        probes,
        amplitude,
    })
}
