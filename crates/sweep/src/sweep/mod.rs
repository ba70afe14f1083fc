//! Sweep files: parsing and validation.
//!
//! A sweep file is JSON with these top-level fields (unknown fields are refused):
//!
//! - `description` (optional string);
//! - `base`: a scene as the solver reads it (`chain`, `physics`, `striker_velocity_m_s`,
//!   `duration_s`, `integrator`, `max_steps`); `chain` may start from a preset,
//!   `{"preset": "chain_055", "cylinders": 50, …overrides}`; the integrator may be
//!   `{"method": "auto", "target_rel_error": 1e-6}` (see [`auto`]), which stands for one
//!   concrete setting chosen before the sweep runs;
//! - `record`: the solver's record block (probes, histories, intervals, …): exactly what is stored;
//! - `axes`: the grid dimensions; each is an axis `{"field": "physics.damping_kg_s", "values": […]}`
//!   or `{"field": …, "range": {"start": …, "stop": …, "step": …}}` (or `"num"` instead of `"step"`),
//!   with an optional `"name"`, or a zipped group `{"zip": [axis, axis, …]}` whose axes advance
//!   together;
//! - `limits`: `{"energy_drift_max": 1e-3, "max_run_seconds": 600}`: the largest relative energy
//!   drift a run may have before it counts as failed (`null`: no limit), and the wall time after
//!   which a run is given up and recorded as failed (not part of a run's identity: a run that
//!   finished is the same run whatever the limit);
//! - `search` (optional): a search over continuous fields run at every point of the axes (which
//!   may then be empty), see [`search`].
//! - `continuation` (optional): `{"axis": NAME, "direction": "up" | "down"}`, each point of that
//!   dimension starting from the final state of the point before it ([`Continuation`]).
//! - `periodic` (optional): the branch of periodic orbits of the driven scene continued in one
//!   field at every point of the axes, see [`periodic`].
//!
//! Every grid point is built into a solver [`Scene`] and validated before anything runs; errors name
//! the field (`base.…` or `axes[i].values[j]`) and what is allowed.
//!
//! Its parts: the sweep file's model as written and the reading of its JSON (`file`), the axes
//! and their expansion into the grid's dimensions (`axes`), and dotted field paths into the base
//! scene (`paths`).

pub mod auto;
mod axes;
pub mod data_files;
pub mod diagnose;
pub mod ensemble;
pub mod expr;
mod file;
pub mod fit;
mod paths;
pub mod periodic;
mod recording;
pub mod schema;
pub mod search;

use serde_json::{Map, Value};

use chainsweep_solver::{ChainSpec, Scene};

use crate::error::{Error, Result};
use auto::{AutoChoice, AutoSpec};
use search::SearchSpec;

pub(crate) use axes::check_name;
use axes::{check_field, check_names_and_fields, parse_dims, raw_axes};
use file::{
    parse_without_duplicate_keys, read_json, ContinuationFile, Direction, LimitsFile, SweepFile,
};
use paths::join_path;
pub use paths::{
    check_settable, field_name, from_ref_at, from_value_at, human_name, lookup, set_path,
    split_path, units_of,
};

/// Largest number of grid points a sweep may have.
pub const MAX_GRID_POINTS: usize = 10_000_000;

/// Largest sweep file read, bytes (16 MiB): a grid of a million listed values fits several times
/// over, and the text, its parsed tree and the grid stay far below a machine's memory.
pub const MAX_SWEEP_FILE_BYTES: u64 = 16 * 1024 * 1024;

/// The text of the sweep file at `path`, refusing before reading anything that is not a regular
/// file (`/dev/zero`, a FIFO, a directory) or is larger than [`MAX_SWEEP_FILE_BYTES`]; the read
/// itself is bounded too (a file that grows meanwhile cannot exhaust memory). The error says why.
pub fn read_sweep_text(path: &str) -> std::result::Result<String, String> {
    use std::io::Read;
    use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};

    let kind = |t: std::fs::FileType| {
        if t.is_dir() {
            "a directory"
        } else if t.is_fifo() {
            "a FIFO (named pipe)"
        } else if t.is_char_device() {
            "a character device"
        } else if t.is_block_device() {
            "a block device"
        } else if t.is_socket() {
            "a socket"
        } else {
            "not a regular file"
        }
    };
    let check = |meta: &std::fs::Metadata| {
        if !meta.is_file() {
            return Err(format!(
                "the sweep file is {}: a sweep file must be a regular file",
                kind(meta.file_type())
            ));
        }
        if meta.len() > MAX_SWEEP_FILE_BYTES {
            return Err(format!(
                "the sweep file has {} bytes, more than the limit of {MAX_SWEEP_FILE_BYTES} bytes (16 MiB)",
                meta.len()
            ));
        }
        Ok(())
    };
    let cannot = |e: std::io::Error| format!("cannot read the sweep file: {e}");
    // Checked before opening: opening a FIFO would wait for a writer.
    check(&std::fs::metadata(path).map_err(cannot)?)?;
    // Non-blocking, and checked again on what was opened, in case the path changed in between.
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(O_NONBLOCK)
        .open(path)
        .map_err(cannot)?;
    check(&file.metadata().map_err(cannot)?)?;
    let mut bytes = Vec::new();
    file.take(MAX_SWEEP_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(cannot)?;
    if bytes.len() as u64 > MAX_SWEEP_FILE_BYTES {
        return Err(format!(
            "the sweep file grew beyond the limit of {MAX_SWEEP_FILE_BYTES} bytes (16 MiB) while it was read"
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "the sweep file is not UTF-8 text (invalid byte at offset {})",
            e.utf8_error().valid_up_to()
        )
    })
}

/// `O_NONBLOCK` of Linux (the only platform chainsweep builds for), without a libc dependency.
const O_NONBLOCK: i32 = 0o4000;

/// Default limit on the relative energy drift of a run.
pub const DEFAULT_ENERGY_DRIFT_MAX: f64 = 1e-3;

/// One axis: a scene field and the values it takes.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// Coordinate name (dataset name in the HDF5 file).
    pub name: String,
    /// Dotted path of the scene field the axis sets, e.g. `physics.damping_kg_s`.
    pub field: String,
    /// Values, in order.
    pub values: Vec<Value>,
    /// Unit, derived from the field name's suffix (`kg/s` for `…_kg_s`, `1` when none).
    pub units: String,
    /// Path of the axis in the sweep file, e.g. `axes[1]` or `axes[2].zip[0]`.
    pub origin: String,
}

/// One grid dimension: one axis, or several zipped axes of equal length.
#[derive(Debug, Clone, PartialEq)]
pub struct Dim {
    /// Dimension name (the first axis's name).
    pub name: String,
    /// The axes advancing along this dimension.
    pub axes: Vec<Axis>,
}

impl Dim {
    /// Number of points along this dimension.
    pub fn len(&self) -> usize {
        self.axes[0].values.len()
    }

    /// Whether the dimension has no points (never true for a parsed sweep).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Limits that decide whether a run counts as failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest relative energy drift; `None`: no limit.
    pub energy_drift_max: Option<f64>,
    /// Wall time after which a run is given up and recorded as failed, s.
    pub max_run_seconds: f64,
}

/// Default wall-time limit of one run, s (`limits.max_run_seconds`): ten minutes, a thousand
/// times what a run of the paper's chains takes (0.01–1 s), so that no sound run meets it while a
/// run that cannot end (a scene whose steps are held far below its time scales) costs a sweep at
/// most ten minutes of one worker.
pub const DEFAULT_MAX_RUN_SECONDS: f64 = 600.0;

/// Largest `limits.max_run_seconds`: a week, as long as any batch system lets one job run.
pub const MAX_RUN_SECONDS: f64 = 7.0 * 24.0 * 3600.0;

/// A parsed, validated sweep.
#[derive(Debug, Clone)]
pub struct Sweep {
    /// The sweep file's text, exactly as read.
    pub text: String,
    /// Description.
    pub description: String,
    /// The base scene, normalised (every default filled in), record block included.
    pub base: Value,
    /// Grid dimensions, outermost first.
    pub dims: Vec<Dim>,
    /// Failure limits.
    pub limits: Limits,
    /// The `integrator: auto` request of the base scene, if any. Until it is resolved
    /// ([`Sweep::apply_auto`]) `base` holds a stand-in integrator ([`AutoSpec::placeholder`]),
    /// good for validation only.
    pub auto: Option<AutoSpec>,
    /// What `auto` chose, once resolved (`base.integrator` is then the chosen setting).
    pub auto_choice: Option<AutoChoice>,
    /// The search run at every point of the axes, when the sweep has one ([`search`]).
    pub search: Option<SearchSpec>,
    /// Continuation along one dimension, when the sweep asks for it ([`Continuation`]).
    pub continuation: Option<Continuation>,
    /// The ensemble drawn at every point of the axes, when the sweep has one ([`ensemble`]): its
    /// samples are the last dimension, `member`.
    pub ensemble: Option<ensemble::EnsembleSpec>,
    /// The ensemble's round whose samples `dims` holds (0 until an adaptive ensemble grows).
    pub ensemble_round: usize,
    /// The branch of periodic orbits continued at every point of the axes, when the sweep has
    /// one ([`periodic`]).
    pub periodic: Option<periodic::PeriodicSpec>,
}

/// Continuation along a dimension of the grid: each point starts from the final state of the
/// point before it along that dimension (the other coordinates the same), in the direction
/// given, instead of from its excitation's initial state; the first point of each line starts as
/// any run does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Continuation {
    /// The dimension (index into [`Sweep::dims`]).
    pub dim: usize,
    /// Whether the line runs from the dimension's last value to its first.
    pub downwards: bool,
}

impl Continuation {
    /// The point before `point` on its line (flat indices over `shape`), or `None` for a line's
    /// first point.
    pub fn predecessor(&self, shape: &[usize], point: usize) -> Option<usize> {
        let stride: usize = shape[self.dim + 1..].iter().product();
        let k = (point / stride) % shape[self.dim];
        if self.downwards {
            (k + 1 < shape[self.dim]).then(|| point + stride)
        } else {
            (k > 0).then(|| point - stride)
        }
    }
}

/// Checks `continuation` against the dimensions; errors name `continuation.…`.
fn parse_continuation(
    c: Option<ContinuationFile>,
    dims: &[Dim],
    has_search: bool,
) -> Result<Option<Continuation>> {
    let Some(c) = c else {
        return Ok(None);
    };
    let input = |field: &str, message: String| Error::Input {
        file: None,
        field: field.to_string(),
        message,
    };
    if has_search {
        return Err(input(
            "continuation",
            "a sweep with a search cannot continue along an axis (a search's points are not ordered); remove one".into(),
        ));
    }
    let names: Vec<&str> = dims.iter().map(|d| d.name.as_str()).collect();
    let dim = names.iter().position(|&n| n == c.axis).ok_or_else(|| {
        input(
            "continuation.axis",
            format!(
                "must name a dimension of the grid ({}), got {:?}",
                if names.is_empty() {
                    "the sweep has none".to_string()
                } else {
                    names.join(", ")
                },
                c.axis
            ),
        )
    })?;
    Ok(Some(Continuation {
        dim,
        downwards: c.direction == Direction::Down,
    }))
}

/// The first of a non-empty list of errors.
fn first(errors: Vec<Error>) -> Error {
    errors
        .into_iter()
        .next()
        .expect("a failed check names at least one error")
}

/// Overlays `over` onto `base`: objects merge key by key, anything else replaces. An object with a
/// single key replacing an object with a different single key (an enum variant) replaces it whole.
fn merge(base: &mut Value, over: Value) {
    match (base, over) {
        (Value::Object(b), Value::Object(o)) => {
            let variant_swap = b.len() == 1 && o.len() == 1 && b.keys().next() != o.keys().next();
            if variant_swap {
                *b = o;
                return;
            }
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (b, o) => *b = o,
    }
}

/// Chain presets a sweep's `base.chain.preset` may name.
pub const CHAIN_PRESETS: &[&str] = &["chain_055", "chain_098"];

fn expand_chain_preset(chain: &mut Value) -> Result<()> {
    let Value::Object(m) = chain else {
        return Ok(());
    };
    let Some(preset) = m.remove("preset") else {
        return Ok(());
    };
    let cylinders = match m.get("cylinders") {
        None => 50,
        Some(v) => v.as_u64().map(|c| c as usize).ok_or_else(|| {
            Error::input(
                "base.chain.cylinders",
                format!("must be a non-negative integer, got {v}"),
            )
        })?,
    };
    let spec = match preset.as_str() {
        Some("chain_055") => ChainSpec::chain_055(cylinders),
        Some("chain_098") => ChainSpec::chain_098(cylinders),
        _ => {
            return Err(Error::input(
                "base.chain.preset",
                format!(
                    "unknown preset {preset}; allowed values: {}",
                    CHAIN_PRESETS.join(", ")
                ),
            ))
        }
    };
    let mut expanded = serde_json::to_value(spec).expect("ChainSpec serialises");
    merge(&mut expanded, Value::Object(std::mem::take(m)));
    *chain = expanded;
    Ok(())
}

/// The base scene normalised: chain presets expanded, `integrator: auto` replaced by its
/// stand-in (the request returned), the top-level record block put in, and every default filled
/// in by the solver, which validates it. Returned as JSON and as the scene read from it (which
/// reads back from that JSON as itself).
///
/// `every`: the errors are every one found in the scene ([`diagnose`]), else the first alone.
fn normalise_base(
    base: Map<String, Value>,
    record: Option<Map<String, Value>>,
    every: bool,
) -> std::result::Result<(Value, Scene, Option<AutoSpec>), Vec<Error>> {
    let mut base = Value::Object(base);
    let mut errors = Vec::new();
    if let Some(chain) = base.get_mut("chain") {
        if let Err(e) = expand_chain_preset(chain) {
            errors.push(e);
        }
    }
    // `integrator: auto` is resolved later; a concrete stand-in validates the rest.
    let auto = match base.get("integrator").map(AutoSpec::from_integrator) {
        Some(Ok(auto)) => auto,
        Some(Err(e)) => {
            errors.push(e);
            None
        }
        None => None,
    };
    if !errors.is_empty() && !every {
        errors.truncate(1);
        return Err(errors);
    }
    if let Some(a) = &auto {
        base["integrator"] =
            serde_json::to_value(a.placeholder()).expect("IntegratorSpec serialises");
    }
    if let Some(record) = record {
        if base.get("record").is_some() {
            errors.push(Error::input(
                "base.record",
                "give the record block once, at the top level (`record`), not inside `base`",
            ));
            return Err(errors);
        }
        base.as_object_mut()
            .expect("object")
            .insert("record".into(), Value::Object(record));
    }
    if !errors.is_empty() {
        // The chain or the integrator could not be read: the scene's other fields still can.
        let fields = base.as_object_mut().expect("object");
        for e in &errors {
            if let Error::Input { field, .. } = e {
                for part in ["chain", "integrator"] {
                    if field.starts_with(&format!("base.{part}")) {
                        fields.remove(part);
                    }
                }
            }
        }
    }
    // The record block is written at the top level: its errors are named there.
    let at_top = |e: Error| match e {
        Error::Input {
            file,
            field,
            message,
        } => Error::Input {
            file,
            field: match field.strip_prefix("base.record") {
                Some(rest) => format!("record{rest}"),
                None => field,
            },
            message,
        },
        other => other,
    };
    let scene: Option<Scene> = if every {
        let mut found = Vec::new();
        let scene = diagnose::from_value_collecting(base, "base", &mut found);
        errors.extend(found.into_iter().map(at_top).filter(|e| {
            // A chain or integrator already reported and taken out is not missing as well.
            !matches!(e, Error::Input { field, message, .. } if field == "base"
                && (message.contains("`chain`") || message.contains("`integrator`")))
        }));
        scene
    } else {
        match from_value_at(base, "base") {
            Ok(scene) => Some(scene),
            Err(e) => return Err(vec![at_top(e)]),
        }
    };
    match scene {
        Some(scene) if errors.is_empty() => Ok((
            serde_json::to_value(&scene).expect("Scene serialises"),
            scene,
            auto,
        )),
        _ => Err(errors),
    }
}

/// The failure limits (the default energy-drift limit when the file gives none).
fn parse_limits(limits: Option<LimitsFile>) -> Result<Limits> {
    let Some(l) = limits else {
        return Ok(Limits {
            energy_drift_max: Some(DEFAULT_ENERGY_DRIFT_MAX),
            max_run_seconds: DEFAULT_MAX_RUN_SECONDS,
        });
    };
    if let Some(x) = l.energy_drift_max {
        if !(x.is_finite() && x > 0.0) {
            return Err(Error::input(
                "limits.energy_drift_max",
                format!("must be a finite number > 0 or null (no limit), got {x}"),
            ));
        }
    }
    let max_run_seconds = l.max_run_seconds.unwrap_or(f64::NAN);
    if !(max_run_seconds > 0.0 && max_run_seconds <= MAX_RUN_SECONDS) {
        let got = match l.max_run_seconds {
            Some(x) => x.to_string(),
            None => "null (every run needs a limit)".to_string(),
        };
        return Err(Error::input(
            "limits.max_run_seconds",
            format!(
                "must be a number of seconds in (0, {MAX_RUN_SECONDS}] (at most a week; default {DEFAULT_MAX_RUN_SECONDS}), got {got}"
            ),
        ));
    }
    Ok(Limits {
        energy_drift_max: l.energy_drift_max,
        max_run_seconds,
    })
}

/// `text` with the files it names read into it (recorded drives, fit data, a fit's result for an
/// ensemble's inputs), their paths relative to `dir`; `None` when it names none.
pub(crate) fn inline_files(text: &str, dir: &std::path::Path) -> Result<Option<String>> {
    let inlined = recording::inline_text(text, dir)?;
    let text_1 = inlined.as_deref().unwrap_or(text);
    let with_data = fit::inline_text(text_1, dir)?;
    let text_2 = with_data.as_deref().unwrap_or(text_1);
    let with_fit = ensemble::inline_text(text_2, dir)?;
    Ok(with_fit.or(with_data).or(inlined))
}

impl Sweep {
    /// Parses and checks a sweep file's text: syntax, unknown fields, types, axes. Grid points
    /// are checked by [`crate::grid::Grid::new`].
    pub fn parse(text: &str) -> Result<Sweep> {
        Sweep::parse_in(text, std::path::Path::new("."))
    }

    /// [`Sweep::parse`] for a sweep file in folder `dir`, from which the relative paths it names
    /// (recorded drives, fit data, a fit's result for an ensemble) are read.
    pub fn parse_in(text: &str, dir: &std::path::Path) -> Result<Sweep> {
        let inlined = inline_files(text, dir)?;
        let text = inlined.as_deref().unwrap_or(text);
        let mut file = read_json(text)?;
        let derived = expr::extract(&mut file.base, &raw_axes(text))?;
        let (mut base, _, auto) = normalise_base(file.base, file.record, false).map_err(first)?;
        let limits = parse_limits(file.limits)?;
        let mut dims = parse_dims(
            file.axes,
            &base,
            auto.is_some(),
            file.search.is_some() || file.ensemble.is_some() || file.periodic.is_some(),
            false,
        )
        .map_err(first)?;
        expr::apply(&derived, &mut base, &mut dims)?;
        check_names_and_fields(&dims)?;
        let continuation = parse_continuation(file.continuation, &dims, file.search.is_some())?;
        let search = file
            .search
            .map(|s| search::parse(s, &base, &mut dims))
            .transpose()?;
        if file.ensemble.is_some() && search.is_some() {
            return Err(Error::input(
                "ensemble",
                "a sweep has a search or an ensemble, not both: run the search, then an ensemble around its answer",
            ));
        }
        let other_goal = if search.is_some() {
            Some("search")
        } else if file.ensemble.is_some() {
            Some("ensemble")
        } else if continuation.is_some() {
            Some("continuation")
        } else {
            None
        };
        let periodic = periodic::parse(file.periodic, &mut base, &dims, other_goal)?;
        let ensemble = file
            .ensemble
            .map(|e| ensemble::parse(e, &mut base, &mut dims))
            .transpose()?;
        Ok(Sweep {
            periodic,
            ensemble,
            ensemble_round: 0,
            continuation,
            text: text.to_string(),
            description: file.description,
            base,
            dims,
            limits,
            auto,
            auto_choice: None,
            search,
        })
    }

    /// One scene as a sweep of a single point without axes (what the Python package's
    /// `chainsweep.run` runs): `base` normalised and checked exactly as a sweep file's `base` is
    /// (presets, defaults, `integrator: auto`), with its `record` and `limits` blocks. Its grid
    /// ([`crate::grid::Grid::new`]) has the one point, the base scene itself, which is returned
    /// beside the sweep as read (for [`crate::grid::Grid::with_first_scene`]). Errors name fields
    /// as in a sweep file (`base.…`, `record.…`, `limits.…`).
    pub fn of_scene(
        base: Value,
        record: Option<Value>,
        limits: Option<Value>,
    ) -> Result<(Sweep, Scene)> {
        let mut file = Map::new();
        file.insert("base".into(), base);
        if let Some(r) = record {
            file.insert("record".into(), r);
        }
        if let Some(l) = limits {
            file.insert("limits".into(), l);
        }
        let text = serde_json::to_string(&file).expect("JSON serialises");
        // Each block read from the value itself (its text, parsed again, gives the same value: a
        // map has no duplicate keys to refuse) and moved, not copied: an object is taken as it
        // is, anything else gets the error a sweep file's block gets.
        let base: Map<String, Value> = match file.remove("base") {
            Some(Value::Object(m)) => m,
            other => from_value_at(other.unwrap_or_default(), "base")?,
        };
        let record: Option<Map<String, Value>> = match file.remove("record") {
            Some(Value::Object(m)) => Some(m),
            other => from_value_at(other.unwrap_or_default(), "record")?,
        };
        let limits: Option<LimitsFile> =
            from_value_at(file.remove("limits").unwrap_or_default(), "limits")?;
        // A derived field of one scene reads no axis: a constant.
        let mut base = base;
        let derived = expr::extract(&mut base, &[])?;
        let (mut base, mut scene, auto) = normalise_base(base, record, false).map_err(first)?;
        if !derived.is_empty() {
            expr::apply(&derived, &mut base, &mut [])?;
            scene = from_ref_at(&base, "base")?;
        }
        if recording::resolve(&mut base, std::path::Path::new("."))? {
            // The samples read in are the scene's now.
            scene = from_ref_at(&base, "base")?;
        }
        let limits = parse_limits(limits)?;
        let sweep = Sweep {
            text,
            description: String::new(),
            base,
            dims: Vec::new(),
            limits,
            auto,
            auto_choice: None,
            search: None,
            continuation: None,
            ensemble: None,
            ensemble_round: 0,
            periodic: None,
        };
        Ok((sweep, scene))
    }

    /// Whether the base integrator is `auto` and not resolved yet: the scenes of the grid hold a
    /// stand-in integrator and must not be run.
    pub fn auto_unresolved(&self) -> bool {
        self.auto.is_some() && self.auto_choice.is_none()
    }

    /// Resolves `integrator: auto` with `choice`: every grid point's scene gets the chosen
    /// integrator (rebuild the [`crate::grid::Grid`] afterwards: its run hashes change).
    pub fn apply_auto(&mut self, choice: AutoChoice) {
        self.base["integrator"] =
            serde_json::to_value(choice.integrator).expect("IntegratorSpec serialises");
        self.auto_choice = Some(choice);
    }

    /// The checks of a sweep read to be run that its parse leaves out, as they may take a while
    /// (and a file's stored sweep text, read back by `status` or `report`, was checked when it
    /// ran): every value an ensemble may draw is one the scene takes.
    pub fn check_draws(&self) -> Result<()> {
        match &self.ensemble {
            Some(e) => e.check_reach(&self.base),
            None => Ok(()),
        }
    }

    /// Reads and parses a sweep file (through [`read_sweep_text`]: a regular file of at most
    /// [`MAX_SWEEP_FILE_BYTES`]).
    pub fn load(path: &str) -> Result<Sweep> {
        let text = read_sweep_text(path).map_err(|message| Error::Input {
            file: Some(path.to_string()),
            field: String::new(),
            message,
        })?;
        let dir = std::path::Path::new(path)
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(std::path::Path::new("."));
        Sweep::parse_in(&text, dir).map_err(|e| e.in_file(path))
    }

    /// Shape of the grid, outermost dimension first.
    pub fn shape(&self) -> Vec<usize> {
        self.dims.iter().map(|d| d.len()).collect()
    }

    /// Number of grid points.
    pub fn n_points(&self) -> usize {
        self.shape().iter().product()
    }

    /// Its ensemble when that is adaptive (a statistic with a tolerance): it runs in rounds.
    pub fn adaptive_ensemble(&self) -> Option<&ensemble::EnsembleSpec> {
        self.ensemble.as_ref().filter(|e| e.adaptive())
    }

    /// The sweep with its ensemble's samples of round `k` (itself when it has no ensemble).
    pub fn at_ensemble_round(&self, k: usize) -> Sweep {
        let mut s = self.clone();
        if let Some(e) = &self.ensemble {
            let last = s.dims.len() - 1;
            s.dims[last] = e.dim(k);
            s.ensemble_round = k;
        }
        s
    }

    /// The sweep whose grid has `points` points: itself, or its ensemble at the round that has
    /// them (a published file of an adaptive ensemble holds its last round).
    pub fn with_points(&self, points: usize) -> Option<Sweep> {
        if self.n_points() == points {
            return Some(self.clone());
        }
        let e = self.ensemble.as_ref()?;
        let outer = e.outer_points.max(1);
        (points % outer == 0)
            .then(|| e.round_of_samples(points / outer))
            .flatten()
            .map(|k| self.at_ensemble_round(k))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The scene `of_scene` hands the grid is the one the grid would read from the normalised
    /// base: its JSON reads back as itself (so a scene run from Python is identified and run as
    /// `chainsweep point` runs the same base), for the base of every sweep file of the project.
    #[test]
    fn scene_of_a_one_point_sweep_reads_back_as_itself() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sweeps");
        let mut files = Vec::new();
        for dir in [root.clone(), root.join("examples"), root.join("stress")] {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.extension().is_some_and(|e| e == "json") {
                    files.push(path);
                }
            }
        }
        let mut checked = 0;
        for path in &files {
            let text = std::fs::read_to_string(path).unwrap();
            // A base whose derived fields read axes is no scene on its own.
            if text.contains("\"expr\"") {
                continue;
            }
            let file: Value = serde_json::from_str(&text).unwrap();
            let part = |k: &str| file.get(k).cloned();
            let (sweep, scene) =
                Sweep::of_scene(part("base").unwrap(), part("record"), part("limits"))
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let again: Scene = from_ref_at(&sweep.base, "").unwrap();
            assert_eq!(again, scene, "{}", path.display());
            assert_eq!(
                serde_json::to_string(&again).unwrap(),
                serde_json::to_string(&scene).unwrap(),
                "{}",
                path.display()
            );
            checked += 1;
        }
        assert!(checked >= 40, "only {checked} sweep files checked");
    }
}
