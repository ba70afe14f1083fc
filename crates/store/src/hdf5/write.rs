//! The writer: the output file of a sweep from the records of its finished runs, in grid order.
//!
//! The file is a pure function of the sweep, the grid and the records (apart from the
//! `created_utc` and `command_line` attributes and the `wall_time_s` dataset), which is what makes
//! files bitwise equal whatever the number of jobs, the finishing order or the sharding.

use std::path::Path;

use hdf5::{Dataset, File};
use serde_json::Value;

use super::arrays::ArrayWriter;
use super::scales;
use super::search::{self, SearchTables};
use super::{
    attach_scale, attr_scalar, attr_str, attr_vec, char_dataset, checked_column, checked_dataset,
    column_text_checksum, dimension_only, header_checksum, number_dimensions, set_scale, Counts,
    Provenance, Text, CONVENTIONS, LAYOUT_VERSION,
};
use chainsweep_sweep::error::{Error, Result};
use chainsweep_sweep::grid::{Grid, Shard};
use chainsweep_sweep::identity::{hex, TIGHTENING};
use chainsweep_sweep::record::columns::{
    distinct_units, split_name, Column, ColumnData, Fill, FillValue, PointOutcome, Presence, Table,
    Units, COLUMNS, HARMONIC,
};
use chainsweep_sweep::record::{RunRecord, VerifyInfo, VERIFY_OK};
use chainsweep_sweep::sweep::auto::AutoChoice;
use chainsweep_sweep::sweep::Sweep;

/// Long name of the steady state's `harmonic` coordinate.
pub const HARMONIC_LONG_NAME: &str =
    "harmonic k of the steady state (frequency k times steady_frequency_hz)";
/// What a written file holds: the counts of its points, and its summary columns (every point's
/// values and checksums, as a reader reads them back).
pub struct Written {
    /// The state of the points.
    pub counts: Counts,
    /// Every summary column of the file, in memory.
    pub table: Table,
}

/// The columns a file of `grid` has.
pub fn presence(grid: &Grid) -> Presence {
    Presence {
        probes: grid.probes.len(),
        moving_part: grid.moving_part,
        run_groups: grid.has_run_arrays(),
        spectrum: grid.spectrum,
        harmonics: grid.steady_harmonics,
        energy_ledger: grid.energy_ledger,
    }
}

/// Writes the HDF5 file of a sweep to `path` from the records `get(index)` returns for every grid
/// point (`None`: pending), in grid order, with the verification outcome `get_verify(index,
/// record)` of each finished point. `points` are the points of this run (its shard): the counts
/// are theirs. `shard` and `verify_fraction` (0 when `--verify` was not given) are recorded as
/// attributes.
#[allow(clippy::too_many_arguments)]
pub fn write_file(
    path: &Path,
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    shard: Option<Shard>,
    prov: &Provenance,
    verify_fraction: f64,
    get: impl FnMut(usize) -> Result<Option<RunRecord>>,
    get_verify: impl FnMut(usize, &RunRecord) -> Result<VerifyInfo>,
    search: Option<&SearchTables>,
    ensemble: Option<&dyn Fn() -> super::fit::EnsembleTables>,
) -> Result<Written> {
    let write = move || -> Result<Written> {
        let file = super::create_file(path)?;
        write_sweep_attrs(&file, sweep, grid, shard, prov)?;
        let mut arrays = ArrayWriter::create(&file, grid)?;
        let table = fill_columns(grid, points, &mut arrays, get, get_verify)?;
        write_outcome_attrs(&file, points, &table, verify_fraction)?;
        if let Some(c) = &sweep.auto_choice {
            write_auto_attrs(&file, c)?;
        }
        let (dims, mut text_scales) = write_coordinates(&file, sweep)?;
        let probe_scale = write_probe_scale(&file, grid)?;
        if let Some(p) = &probe_scale {
            text_scales.push(("probe".to_string(), p.strlen.clone()));
        }
        let mut extra_coordinates = Vec::new();
        if let Some(t) = search {
            let scale = |name: &str| {
                dims.iter()
                    .find(|d| d.name == name)
                    .map(|d| &d.scale)
                    .ok_or_else(|| Error::Other(format!("no dimension `{name}` for the search")))
            };
            let outer = t
                .outer
                .dims
                .iter()
                .map(|(name, _)| Ok((scale(name)?, name.as_str())))
                .collect::<Result<Vec<_>>>()?;
            search::write(&file, t, &outer, scale("evaluation")?)?;
            if let Some(f) = &t.fit {
                super::fit::write(&file, f, &outer, &t.outer.shape())?;
            }
            extra_coordinates = search::coordinate_names(t);
        }
        if let Some(tables) = ensemble {
            // Computed now that every record has passed through `get`.
            let e = tables();
            // Over the ordinary axes: every dimension but the last, `member`.
            let ordinary = &sweep.dims[..sweep.dims.len() - 1];
            let outer = ordinary
                .iter()
                .map(|d| {
                    dims.iter()
                        .find(|s| s.name == d.name)
                        .map(|s| (&s.scale, d.name.as_str()))
                        .ok_or_else(|| {
                            Error::Other(format!("no dimension `{}` for the ensemble", d.name))
                        })
                })
                .collect::<Result<Vec<_>>>()?;
            let shape: Vec<usize> = ordinary.iter().map(|d| d.len()).collect();
            super::fit::write(&file, &e.tables, &outer, &shape)?;
            for (name, value) in &e.attrs {
                attr_str(&file, name, value)?;
            }
        }
        let coordinates = coordinate_names(&dims, &extra_coordinates);
        let written = write_columns(
            &file,
            &table.table,
            &dims,
            probe_scale.as_ref(),
            &coordinates,
        )?;
        arrays.finish(&file, &dims, probe_scale.as_ref(), &coordinates)?;
        number_dimensions(&file, &text_scales)?;
        // Last: over every text attribute written above.
        let mut sums = serde_json::Map::new();
        for (name, d) in written {
            let sum = column_text_checksum(&d)?;
            sums.insert(name, Value::from(sum.to_string()));
        }
        attr_str(
            &file,
            "column_checksums",
            &serde_json::to_string(&sums).expect("json"),
        )?;
        attr_scalar(&file, "header_checksum", header_checksum(&file)?)?;
        file.flush().map_err(crate::h5)?;
        drop(dims);
        drop(probe_scale);
        file.close().map_err(crate::h5)?;
        Ok(Written {
            counts: table.counts,
            table: table.table,
        })
    };
    write().map_err(|e| e.hdf5_context(|| format!("writing {}", path.display())))
}

/// Root attributes describing the sweep and the engine.
pub(super) fn write_sweep_attrs(
    file: &File,
    sweep: &Sweep,
    grid: &Grid,
    shard: Option<Shard>,
    prov: &Provenance,
) -> Result<()> {
    attr_str(file, "Conventions", CONVENTIONS)?;
    attr_str(file, "sweep", &sweep.text)?;
    attr_str(file, "description", &sweep.description)?;
    attr_str(
        file,
        "base_scene",
        &serde_json::to_string(&sweep.base).expect("json"),
    )?;
    attr_str(file, "engine", "chainsweep")?;
    attr_str(file, "engine_version", chainsweep_sweep::ENGINE_VERSION)?;
    attr_scalar(file, "layout_version", LAYOUT_VERSION)?;
    attr_str(file, "solver_version", chainsweep_sweep::SOLVER_VERSION)?;
    attr_scalar(
        file,
        "numerics_version",
        chainsweep_sweep::NUMERICS_VERSION as i64,
    )?;
    attr_str(file, "git_revision", chainsweep_sweep::git_revision())?;
    attr_str(file, "created_utc", &prov.created_utc)?;
    attr_str(file, "command_line", &prov.command_line)?;
    let shard = shard.unwrap_or(Shard { k: 1, n: 1 });
    attr_str(file, "shard", &shard.to_string())?;
    let (dims, shape) = header_values(sweep, grid);
    attr_str(file, "dimensions", &dims)?;
    attr_vec(file, "grid_shape", &shape)?;
    attr_scalar(
        file,
        "energy_drift_limit",
        sweep.limits.energy_drift_max.unwrap_or(f64::NAN),
    )?;
    Ok(())
}

/// The `dimensions` (JSON list of names) and `grid_shape` root attributes of a file of `grid`.
pub fn header_values(sweep: &Sweep, grid: &Grid) -> (String, Vec<i64>) {
    let dims: Vec<&str> = sweep.dims.iter().map(|d| d.name.as_str()).collect();
    let shape: Vec<i64> = grid.shape.iter().map(|&x| x as i64).collect();
    (serde_json::to_string(&dims).expect("json"), shape)
}

/// Every column's values, and the counts of the points.
struct Filled {
    table: Table,
    counts: Counts,
    n_verified: usize,
}

/// Reads every point's record (and verification outcome) once, in grid order, into the columns;
/// writes the runs' arrays (histories, minimum overlaps) on the way.
fn fill_columns(
    grid: &Grid,
    points: &[usize],
    arrays: &mut ArrayWriter,
    mut get: impl FnMut(usize) -> Result<Option<RunRecord>>,
    mut get_verify: impl FnMut(usize, &RunRecord) -> Result<VerifyInfo>,
) -> Result<Filled> {
    let n = grid.len();
    let mut table = Table::empty(n, presence(grid));
    let mut counts = Counts::default();
    let mut n_verified = 0;
    let mut in_points = vec![false; n];
    for &i in points {
        in_points[i] = true;
    }
    for (i, &in_run) in in_points.iter().enumerate() {
        let record = get(i)?;
        // Only a point that holds a run names it (pending points and a search's points without
        // a run store no run hash).
        let hash_hex = match record {
            Some(_) => hex(&grid.hashes[i]),
            None => String::new(),
        };
        if in_run && record.is_none() {
            counts.pending += 1;
        }
        let verify = match &record {
            Some(rec) if rec.hash != grid.hashes[i] => {
                return Err(Error::Other(format!(
                    "record for point {i} has the wrong run hash"
                )))
            }
            Some(rec) => Some(get_verify(i, rec)?),
            None => None,
        };
        let outcome = PointOutcome {
            hash_hex: &hash_hex,
            record: record.as_ref(),
            verify: verify.as_ref(),
        };
        table.fill_point(i, &outcome);
        n_verified += verify.as_ref().is_some_and(|v| v.status == VERIFY_OK) as usize;
        match &record {
            Some(rec) if rec.ok => {
                if rec.unsettled() {
                    counts.unsettled += usize::from(in_run);
                } else {
                    counts.ok += usize::from(in_run);
                }
                arrays.write(i, rec)?;
            }
            Some(_) => counts.failed += usize::from(in_run),
            None => {}
        }
    }
    Ok(Filled {
        table,
        counts,
        n_verified,
    })
}

/// Root attributes counting the points and the verified points.
fn write_outcome_attrs(
    file: &File,
    points: &[usize],
    table: &Filled,
    verify_fraction: f64,
) -> Result<()> {
    attr_scalar(file, "n_runs", points.len() as i64)?;
    attr_scalar(file, "n_ok", table.counts.ok as i64)?;
    attr_scalar(file, "n_failed", table.counts.failed as i64)?;
    attr_scalar(file, "n_pending", table.counts.pending as i64)?;
    attr_scalar(file, "n_unsettled", table.counts.unsettled as i64)?;
    attr_scalar(file, "verify_fraction", verify_fraction)?;
    attr_str(file, "verify_tightening", TIGHTENING)?;
    attr_scalar(file, "n_verified", table.n_verified as i64)?;
    Ok(())
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

/// Values of one coordinate, typed for HDF5.
pub(super) enum Coord {
    F64(Vec<f64>),
    I64(Vec<i64>),
    Bool(Vec<bool>),
    Str(Vec<String>),
}

pub(super) fn coord_of(values: &[Value]) -> Coord {
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

/// A grid dimension as written: its one dimension scale and the names of the coordinates on it
/// that are not that scale (the other axes of a zipped group), and whether the scale is a text
/// coordinate (which every variable on the dimension lists in its `coordinates`: CF takes a
/// coordinate variable for a number, and a text one for a label the variables name).
pub(super) struct DimScale {
    pub(super) scale: Dataset,
    pub(super) name: String,
    len: usize,
    others: Vec<String>,
    text: bool,
}

/// An axis's coordinate dataset: numbers (integers, floats) as they are, booleans as bytes 0
/// (false) and 1 (true) with the attribute `dtype = "bool"` (netCDF has no boolean type and CF no
/// enumeration: HDF5's boolean enumeration is invisible to `ncdump`; xarray reads such bytes back
/// as booleans, as it writes them), anything else as text (netCDF `char`s, [`char_dataset`]); the
/// scale of dimension `scale` when given; with the characters' dimension of a text one.
fn write_axis(
    file: &File,
    name: &str,
    values: &[Value],
    scale: Option<&str>,
) -> Result<(Dataset, Option<String>)> {
    let shape = [values.len()];
    let d = match coord_of(values) {
        Coord::F64(v) => checked_dataset(file, name, &shape, &v)?,
        Coord::I64(v) => checked_dataset(file, name, &shape, &v)?,
        Coord::Bool(v) => {
            let bytes: Vec<i8> = v.iter().map(|&b| i8::from(b)).collect();
            let d = checked_dataset(file, name, &shape, &bytes)?;
            attr_str(&d, "dtype", "bool")?;
            d
        }
        Coord::Str(v) => {
            let c = char_dataset(file, name, &shape, &v, scale, Text::Names)?;
            return Ok((c.data, Some(c.strlen)));
        }
    };
    if let Some(dim) = scale {
        set_scale(&d, dim)?;
    }
    Ok((d, None))
}

/// The coordinate of every axis, and the one dimension scale of every dimension: the axis named
/// like the dimension, else (a zipped group with a name of its own) a netCDF dimension without a
/// variable. The zipped group's other axes get the scale attached, which makes them coordinates
/// on the dimension. Also the text coordinates that are a dimension's scale, with the dimensions
/// of their characters (for [`number_dimensions`]).
pub(super) fn write_coordinates(
    file: &File,
    sweep: &Sweep,
) -> Result<(Vec<DimScale>, Vec<TextScale>)> {
    let mut dims = Vec::new();
    let mut text_scales = Vec::new();
    for dim in &sweep.dims {
        let mut scale = None;
        let mut axes = Vec::new();
        for axis in &dim.axes {
            let own = axis.name == dim.name;
            let (d, strlen) = write_axis(
                file,
                &axis.name,
                &axis.values,
                own.then_some(dim.name.as_str()),
            )?;
            attr_str(&d, "units", &axis.units)?;
            attr_str(&d, "field", &axis.field)?;
            attr_str(&d, "dimension", &dim.name)?;
            // What a plot labels it with: its name in words, without the unit (which `units`
            // gives); the field it sets is the `field` attribute.
            attr_str(
                &d,
                "long_name",
                &chainsweep_sweep::sweep::human_name(&axis.name),
            )?;
            if own {
                if let Some(strlen) = &strlen {
                    text_scales.push((axis.name.clone(), strlen.clone()));
                }
                scale = Some((d, strlen.is_some()));
            } else {
                axes.push((d, axis.name.as_str(), strlen));
            }
        }
        // What netCDF-4 writes for a dimension without a variable: an unwritten float dataset of
        // the dimension's length, named like the dimension.
        let (scale, text) = match scale {
            Some(s) => s,
            None => (dimension_only(file, &dim.name, dim.len())?, false),
        };
        for (d, _, _) in &axes {
            attach_scale(d, &scale, 0, &dim.name)?;
        }
        dims.push(DimScale {
            scale,
            name: dim.name.clone(),
            len: dim.len(),
            others: axes.iter().map(|(_, name, _)| name.to_string()).collect(),
            text,
        });
    }
    Ok((dims, text_scales))
}

/// A text coordinate that is its dimension's scale: its name, and the dimension of its characters.
type TextScale = (String, String);

/// The `probe` coordinate as written: its dimension scale (netCDF `char`s, the probe names), the
/// probes' units, and the dimension of its characters.
pub(super) struct ProbeScale {
    pub(super) scale: Dataset,
    pub(super) units: Vec<String>,
    pub(super) strlen: String,
}

/// The `probe` coordinate (a dimension scale) and `probe_units`, when there are probes; with
/// the probes' units.
pub(super) fn write_probe_scale(file: &File, grid: &Grid) -> Result<Option<ProbeScale>> {
    let np = grid.probes.len();
    if np == 0 {
        return Ok(None);
    }
    let names: Vec<String> = grid.probes.iter().map(|p| p.name()).collect();
    let probe = char_dataset(file, "probe", &[np], &names, Some("probe"), Text::Names)?;
    let d = probe.data;
    let json: Vec<String> = grid
        .probes
        .iter()
        .map(|p| serde_json::to_string(p).expect("probe serialises"))
        .collect();
    attr_str(&d, "long_name", "probe (as in the record block)")?;
    attr_str(&d, "probes_json", &format!("[{}]", json.join(",")))?;
    let units: Vec<String> = grid.probes.iter().map(|p| p.unit().to_string()).collect();
    let u = char_dataset(file, "probe_units", &[np], &units, None, Text::Names)?;
    attach_scale(&u.data, &d, 0, "probe")?;
    attr_str(&u.data, "long_name", "unit of each probe's values")?;
    Ok(Some(ProbeScale {
        scale: d,
        units,
        strlen: probe.strlen,
    }))
}

/// What a variable over the grid lists in its `coordinates`: the coordinates on the grid's
/// dimensions that are no dimension scale (a zipped group's other axes, a search's fields), and
/// the text coordinates (labels to CF).
pub(super) fn coordinate_names<'a>(dims: &'a [DimScale], extra: &'a [String]) -> Vec<&'a str> {
    dims.iter()
        .flat_map(|d| d.others.iter().map(String::as_str))
        .chain(extra.iter().map(String::as_str))
        .chain(dims.iter().filter(|d| d.text).map(|d| d.name.as_str()))
        .collect()
}

/// Every column of [`COLUMNS`] as a dataset with its attributes and dimension scales (the
/// per-probe ones only when there are probes, those of the moving part only when some point of
/// the grid integrates only its moving part), and the coordinates that are no dimension scale —
/// and the text coordinates, which are labels to CF — in its `coordinates` attribute. A column in
/// the probes' unit is written once per unit where the probes' units differ ([`split_name`]).
/// Returns the datasets written with their names, still open (for `column_checksums`: a
/// dataset opened again by name costs HDF5 a lookup and a new header read, each time).
fn write_columns(
    file: &File,
    table: &Table,
    dims: &[DimScale],
    probe_scale: Option<&ProbeScale>,
    others: &[&str],
) -> Result<Vec<(String, Dataset)>> {
    let shape: Vec<usize> = dims.iter().map(|d| d.len).collect();
    let mut written = Vec::new();
    // The steady state's harmonics, a coordinate (1, 2, …) of the columns over them.
    let nh = table.nh;
    let harmonic = match probe_scale {
        Some(_) if nh > 0 => {
            let k: Vec<i64> = (1..=nh as i64).collect();
            let h = checked_dataset(file, HARMONIC, &[nh], &k)?;
            attr_str(&h, "units", "1")?;
            attr_str(&h, "long_name", HARMONIC_LONG_NAME)?;
            set_scale(&h, HARMONIC)?;
            Some(h)
        }
        _ => None,
    };
    // The grid's scale of each dimension, and every column's scales (the column's index in
    // `written`, the scale, the dimension), attached once all columns are written.
    let grid_scales: Vec<(&Dataset, usize)> = dims
        .iter()
        .enumerate()
        .map(|(k, d)| (&d.scale, k))
        .collect();
    let mut scales: Vec<(usize, &Dataset, usize)> = Vec::new();
    for (c, data) in COLUMNS.iter().zip(&table.columns) {
        let Some(data) = data else {
            continue;
        };
        if c.per_probe {
            let Some(p) = probe_scale else {
                continue;
            };
            let np = p.units.len();
            let mut pshape = shape.clone();
            pshape.push(np);
            // Values per probe: one, or one per harmonic (the last dimension).
            let per = if c.per_harmonic {
                pshape.push(nh);
                nh
            } else {
                1
            };
            let mut coords = others.to_vec();
            coords.extend(["probe", "probe_units"]);
            let units = distinct_units(&p.units);
            let parts: Vec<(String, ColumnData, Option<&str>)> = match (c.units, data) {
                (Units::OfProbes, ColumnData::F64(v)) if units.len() > 1 => units
                    .iter()
                    .map(|&u| {
                        let mut part = v.clone();
                        for (k, x) in part.iter_mut().enumerate() {
                            if p.units[k / per % np] != u {
                                *x = f64::NAN;
                            }
                        }
                        (split_name(c.name, u), ColumnData::F64(part), Some(u))
                    })
                    .collect(),
                (Units::OfProbes, _) => vec![(c.name.to_string(), data.clone(), Some(units[0]))],
                _ => vec![(c.name.to_string(), data.clone(), None)],
            };
            let split = parts.len() > 1;
            for (name, part, unit) in &parts {
                let d = write_column(file, c, name, &pshape, part, *unit, split)?;
                let column = written.len();
                scales.extend(grid_scales.iter().map(|&(s, k)| (column, s, k)));
                scales.push((column, &p.scale, shape.len()));
                if let (true, Some(h)) = (c.per_harmonic, &harmonic) {
                    scales.push((column, h, shape.len() + 1));
                }
                attr_str(&d, "coordinates", &coords.join(" "))?;
                written.push((name.clone(), d));
            }
        } else {
            let d = write_column(file, c, c.name, &shape, data, None, false)?;
            let column = written.len();
            scales.extend(grid_scales.iter().map(|&(s, k)| (column, s, k)));
            if !others.is_empty() {
                attr_str(&d, "coordinates", &others.join(" "))?;
            }
            written.push((c.name.to_string(), d));
        }
    }
    // Every column's scales at once, in the order named above.
    let attachments: Vec<(&Dataset, &Dataset, usize)> = scales
        .iter()
        .map(|&(column, s, k)| (&written[column].1, s, k))
        .collect();
    scales::attach_all(&attachments)?;
    Ok(written)
}

/// One column's dataset `name` and attributes (`unit`: the probes' unit, for [`Units::OfProbes`];
/// `split`: the dataset holds the values of the probes of that unit only, [`split_name`]). The
/// chunks that hold nothing but the fill value are left unwritten.
#[allow(clippy::too_many_arguments)]
fn write_column(
    file: &File,
    c: &Column,
    name: &str,
    shape: &[usize],
    data: &ColumnData,
    unit: Option<&str>,
    split: bool,
) -> Result<Dataset> {
    let d = match (data, c.fill_value()) {
        (ColumnData::F64(v), Some(FillValue::F64(fill))) => {
            checked_column(file, name, shape, v, Some(fill))?
        }
        (ColumnData::I64(v), Some(FillValue::I64(fill))) => {
            checked_column(file, name, shape, v, Some(fill))?
        }
        (ColumnData::F64(v), _) => checked_column(file, name, shape, v, None)?,
        (ColumnData::I64(v), _) => checked_column(file, name, shape, v, None)?,
        (ColumnData::U8(v), _) => checked_column(file, name, shape, v, None)?,
        (ColumnData::U64(v), _) => checked_column(file, name, shape, v, None)?,
        (ColumnData::Str(v), _) => {
            let text = if matches!(c.fill, Fill::RunHash) {
                Text::Names
            } else {
                Text::Free
            };
            char_dataset(file, name, shape, v, None, text)?.data
        }
    };
    if let Some((values, meanings)) = c.flags {
        attr_vec(&d, "flag_values", values)?;
        attr_str(&d, "flag_meanings", meanings)?;
    }
    match (c.units, unit) {
        (Units::None, _) => {}
        (Units::Fixed(u), _) | (Units::OfProbes, Some(u)) => attr_str(&d, "units", u)?,
        (Units::OfProbes, None) => {
            return Err(Error::Other(format!("column {name} has no unit")));
        }
    }
    if c.long_name {
        attr_str(&d, "long_name", &c.label())?;
        match unit {
            Some(u) if split => attr_str(
                &d,
                "comment",
                &format!(
                    "{} (the probes measured in {u}; NaN at the others)",
                    c.description
                ),
            )?,
            _ => attr_str(&d, "comment", c.description)?,
        }
    }
    Ok(d)
}
