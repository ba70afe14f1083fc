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
//!
//! Every grid point is built into a solver [`Scene`] and validated before anything runs; errors name
//! the field (`base.…` or `axes[i].values[j]`) and what is allowed.

pub mod auto;
pub mod diagnose;
pub mod ensemble;
pub mod expr;
pub mod fit;
mod recording;
pub mod schema;
pub mod search;

use serde::Deserialize;
use serde_json::{Map, Value};

use chainsweep_solver::{ChainSpec, Scene};

use crate::error::{Error, Result};
use crate::record::columns::reserved_names;
use auto::{AutoChoice, AutoSpec};
use search::SearchSpec;

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

/// `continuation` as written.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct ContinuationFile {
    /// The name of the dimension along which each point starts from the final state of the one
    /// before it.
    axis: String,
    /// `up` (from the dimension's first value to its last, the default) or `down`.
    #[serde(default)]
    direction: Direction,
}

/// The direction of a continuation.
#[derive(Deserialize, schemars::JsonSchema, Default, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
enum Direction {
    /// From the dimension's first value to its last.
    #[default]
    Up,
    /// From the dimension's last value to its first.
    Down,
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

/// A chainsweep sweep file: a base scene, what to record, the axes of its grid, failure limits
/// and an optional search.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(title = "chainsweep sweep file")]
struct SweepFile {
    /// The JSON Schema the file follows (for editors); not read otherwise.
    #[serde(default, rename = "$schema")]
    #[allow(dead_code)]
    schema: Option<String>,
    /// What the sweep is for.
    #[serde(default)]
    description: String,
    /// The scene every grid point starts from.
    #[schemars(with = "schema::BaseScene")]
    base: Map<String, Value>,
    /// What is recorded, the same for every run.
    #[serde(default)]
    #[schemars(with = "Option<chainsweep_solver::RecordSpec>")]
    record: Option<Map<String, Value>>,
    /// The grid's dimensions.
    #[serde(default)]
    axes: Vec<AxisFile>,
    /// When a run counts as failed.
    #[serde(default)]
    limits: Option<LimitsFile>,
    /// A search over continuous fields at every point of the axes.
    #[serde(default)]
    search: Option<search::SearchFile>,
    /// An ensemble: scene fields drawn from distributions at every point of the axes, and the
    /// statistics (or sensitivities) of chosen summaries over them.
    #[serde(default)]
    ensemble: Option<ensemble::EnsembleFile>,
    /// Continuation along one dimension: each point starts from the final state of the one
    /// before it (hysteresis, bistability).
    #[serde(default)]
    continuation: Option<ContinuationFile>,
}

/// When a run counts as failed.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct LimitsFile {
    /// The largest relative energy drift of a run (null: no limit).
    #[serde(default = "default_drift")]
    energy_drift_max: Option<f64>,
    /// The wall time, s, after which a run is given up and recorded as failed.
    #[serde(default = "default_max_run_seconds")]
    max_run_seconds: Option<f64>,
}

fn default_max_run_seconds() -> Option<f64> {
    Some(DEFAULT_MAX_RUN_SECONDS)
}

fn default_drift() -> Option<f64> {
    Some(DEFAULT_ENERGY_DRIFT_MAX)
}

/// A grid dimension: an axis `{field, values | range, name?}` or a group of axes that advance
/// together, `{zip: [axis, …]}`.
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("oneOf" = [
    {"required": ["field", "values"], "not": {"anyOf": [{"required": ["range"]}, {"required": ["zip"]}]}},
    {"required": ["field", "range"], "not": {"anyOf": [{"required": ["values"]}, {"required": ["zip"]}]}},
    {"required": ["zip"], "not": {"anyOf": [{"required": ["field"]}, {"required": ["values"]}, {"required": ["range"]}]}}
]))]
struct AxisFile {
    /// The axis's name in the output (default: the field's last part).
    #[serde(default)]
    name: Option<String>,
    /// The scene field the axis sets, as a dotted path (`physics.damping_kg_s`).
    #[serde(default)]
    field: Option<String>,
    /// The values the field takes.
    #[serde(default)]
    #[schemars(length(min = 1))]
    values: Option<Vec<Value>>,
    /// Evenly spaced values.
    #[serde(default)]
    range: Option<RangeFile>,
    /// Axes that advance together (all of one length).
    #[serde(default)]
    #[schemars(length(min = 1))]
    zip: Option<Vec<AxisFile>>,
}

/// Evenly spaced values: `step` (stop included when reached) or `num` (both ends included).
#[derive(Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
#[schemars(extend("oneOf" = [{"required": ["step"]}, {"required": ["num"]}]))]
struct RangeFile {
    /// The first value.
    start: serde_json::Number,
    /// The last value (reached by `num`; by `step` when it divides the span).
    stop: serde_json::Number,
    /// The spacing, with the sign of stop − start.
    #[serde(default)]
    step: Option<serde_json::Number>,
    /// The number of values.
    #[serde(default)]
    #[schemars(range(min = 1))]
    num: Option<u64>,
}

/// The first of a non-empty list of errors.
fn first(errors: Vec<Error>) -> Error {
    errors
        .into_iter()
        .next()
        .expect("a failed check names at least one error")
}

/// Deserialises `value` as `T`, naming the failing field (prefixed by `prefix`) on error
/// ([`from_ref_at`] of it).
pub fn from_value_at<T: serde::de::DeserializeOwned>(value: Value, prefix: &str) -> Result<T> {
    from_ref_at(&value, prefix)
}

/// [`from_value_at`] reading a borrowed value (no copy of it is made). Read plainly first, and
/// again tracking the path only when that fails (tracking it costs a third of a grid's expansion).
pub fn from_ref_at<'de, T: serde::de::Deserialize<'de>>(
    value: &'de Value,
    prefix: &str,
) -> Result<T> {
    if let Ok(t) = T::deserialize(value) {
        return Ok(t);
    }
    serde_path_to_error::deserialize::<_, T>(value).map_err(|e| {
        let path = e.path().to_string();
        let field = join_path(prefix, if path == "." { "" } else { &path });
        Error::input(field, e.into_inner().to_string())
    })
}

fn join_path(prefix: &str, path: &str) -> String {
    match (prefix.is_empty(), path.is_empty()) {
        (true, _) => path.to_string(),
        (false, true) => prefix.to_string(),
        (false, false) if path.starts_with('[') => format!("{prefix}{path}"),
        (false, false) => format!("{prefix}.{path}"),
    }
}

/// The unit suffixes of field names and the unit each says (longest first where one ends
/// another: `_kg_s` before `_s`).
const UNIT_SUFFIXES: &[(&str, &str)] = &[
    ("_kg_m3", "kg/m^3"),
    ("_m_s2", "m/s^2"),
    ("_kg_s", "kg/s"),
    ("_m_s", "m/s"),
    ("_pa", "Pa"),
    ("_hz", "Hz"),
    ("_rad", "rad"),
    ("_kg", "kg"),
    ("_s", "s"),
    ("_m", "m"),
    ("_n", "N"),
    ("_j", "J"),
];

/// Unit of a field from its name's suffix (`damping_kg_s` → `kg/s`, `frequency_hz` → `Hz`).
pub fn units_of(field: &str) -> String {
    let last = field.rsplit('.').next().unwrap_or(field);
    UNIT_SUFFIXES
        .iter()
        .find(|(suffix, _)| last.ends_with(suffix))
        .map_or("1", |(_, unit)| unit)
        .to_string()
}

/// A coordinate's name as a plot labels it: its unit suffix left out (the unit is its own
/// attribute) and words apart (`damping_kg_s` → `damping`, `mass_ratio` → `mass ratio`).
pub fn human_name(name: &str) -> String {
    let stem = UNIT_SUFFIXES
        .iter()
        .find_map(|(suffix, _)| name.strip_suffix(suffix).filter(|s| !s.is_empty()))
        .unwrap_or(name);
    stem.replace('_', " ")
}

/// The name a field goes by where none is given: its path's last part that is not an index
/// (`chain.mass_factors.3` → `mass_factors`).
pub fn field_name(field: &str) -> String {
    split_path(field)
        .into_iter()
        .rev()
        .find(|s| s.parse::<usize>().is_err())
        .unwrap_or_default()
}

/// Splits a dotted field path into segments; `a.b[2].c` and `a.b.2.c` are the same path.
pub fn split_path(path: &str) -> Vec<String> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let mut rest = part;
        if let Some(i) = rest.find('[') {
            out.push(rest[..i].to_string());
            rest = &rest[i..];
            while let Some(stripped) = rest.strip_prefix('[') {
                match stripped.find(']') {
                    Some(j) => {
                        out.push(stripped[..j].to_string());
                        rest = &stripped[j + 1..];
                    }
                    None => {
                        out.push(stripped.to_string());
                        rest = "";
                    }
                }
            }
            if !rest.is_empty() {
                out.push(rest.to_string());
            }
        } else {
            out.push(rest.to_string());
        }
    }
    out
}

fn describe_keys(v: &Value) -> String {
    match v {
        Value::Object(m) => {
            let keys: Vec<&str> = m.keys().map(|k| k.as_str()).collect();
            format!("the fields there are: {}", keys.join(", "))
        }
        Value::Array(a) => format!(
            "it is a list of {} entries (indices 0..{})",
            a.len(),
            a.len()
        ),
        _ => "it is a plain value with no fields".to_string(),
    }
}

/// Finds the value at `path` in `root`, or explains where the path stops existing.
pub fn lookup<'a>(root: &'a Value, path: &str) -> std::result::Result<&'a Value, String> {
    let mut cur = root;
    let mut walked = String::new();
    for seg in split_path(path) {
        let next = match cur {
            Value::Object(m) => m.get(&seg),
            Value::Array(a) => seg.parse::<usize>().ok().and_then(|i| a.get(i)),
            _ => None,
        };
        match next {
            Some(n) => {
                cur = n;
                if !walked.is_empty() {
                    walked.push('.');
                }
                walked.push_str(&seg);
            }
            None => {
                let at = if walked.is_empty() {
                    "the scene".to_string()
                } else {
                    format!("`{walked}`")
                };
                return Err(format!(
                    "`{path}` is not a field of the base scene: `{seg}` does not exist in {at}; {}",
                    describe_keys(cur)
                ));
            }
        }
    }
    Ok(cur)
}

/// Checks that an axis can set `path` in `root`: along it every existing value is an object (a
/// missing key is created when values are applied: the normalised base leaves out fields that hold
/// their defaults) or a list that has the index. Whether the field exists in the scene is then
/// decided at every grid point, which names the axis and the allowed fields.
pub fn check_settable(root: &Value, path: &str) -> std::result::Result<(), String> {
    let mut cur = root;
    for seg in split_path(path) {
        cur = match cur {
            Value::Object(m) => match m.get(&seg) {
                Some(next) => next,
                None => return Ok(()),
            },
            Value::Null => return Ok(()),
            Value::Array(a) => match seg.parse::<usize>().ok().and_then(|i| a.get(i)) {
                Some(next) => next,
                None => return lookup(root, path).map(|_| ()),
            },
            _ => return lookup(root, path).map(|_| ()),
        };
    }
    Ok(())
}

/// Sets the value at `path` in `root` (checked by [`check_settable`]), creating the objects
/// missing along it.
pub fn set_path(root: &mut Value, path: &str, value: Value) {
    // An axis that sets no field (a fit's data sets, a search's evaluations) sets nothing.
    if path.is_empty() {
        return;
    }
    let mut cur = root;
    for seg in split_path(path) {
        if cur.is_null() {
            *cur = Value::Object(Map::new());
        }
        cur = match cur {
            Value::Object(m) => m.entry(seg).or_insert(Value::Null),
            Value::Array(a) => {
                let i: usize = seg.parse().expect("path checked at parse time");
                &mut a[i]
            }
            _ => unreachable!("path checked at parse time"),
        };
    }
    *cur = value;
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

/// The `axes` list of a sweep file's text as JSON (empty where it has none or does not read).
fn raw_axes(text: &str) -> Vec<Value> {
    let stripped = text.strip_prefix('\u{feff}').unwrap_or(text);
    serde_json::from_str::<Value>(stripped)
        .ok()
        .and_then(|v| v.get("axes").and_then(Value::as_array).cloned())
        .unwrap_or_default()
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

/// A range value: integers stay integers; floats are rounded to 15 significant digits, so that
/// `0.1 + 2 × 0.1` is 0.3 and not 0.30000000000000004.
fn num_to_value(x: f64, as_int: bool) -> Value {
    if as_int {
        Value::from(x.round() as i64)
    } else {
        let rounded: f64 = format!("{x:.14e}").parse().unwrap_or(x);
        Value::from(rounded)
    }
}

fn expand_range(r: &RangeFile, origin: &str) -> Result<Vec<Value>> {
    let start = r.start.as_f64().unwrap_or(f64::NAN);
    let stop = r.stop.as_f64().unwrap_or(f64::NAN);
    for (name, v) in [("start", start), ("stop", stop)] {
        if !v.is_finite() {
            return Err(Error::input(
                format!("{origin}.range.{name}"),
                "must be a finite number",
            ));
        }
    }
    let ints = r.start.is_i64() && r.stop.is_i64();
    match (&r.step, r.num) {
        (Some(_), Some(_)) | (None, None) => Err(Error::input(
            format!("{origin}.range"),
            "give exactly one of `step` (spacing, stop included when reached) or `num` (number of evenly spaced values, both ends included)",
        )),
        (Some(step_n), None) => {
            let step = step_n.as_f64().unwrap_or(f64::NAN);
            if !(step.is_finite() && step != 0.0) || (stop - start) * step < 0.0 {
                return Err(Error::input(
                    format!("{origin}.range.step"),
                    format!("must be a finite non-zero number with the sign of stop - start, got {step_n}"),
                ));
            }
            let ints = ints && step_n.is_i64();
            let span = (stop - start) / step;
            // Counted in floating point and checked before it becomes an integer: a tiny step
            // gives a count far beyond any integer (a cast would saturate, and + 1 wrap to 0).
            let count = (span + 1e-9 * span.abs().max(1.0)).floor() + 1.0;
            if count.is_nan() || count > MAX_GRID_POINTS as f64 {
                return Err(Error::input(
                    format!("{origin}.range.step"),
                    format!(
                        "gives {} values from {} to {} in steps of {step_n}; a range may give at most {MAX_GRID_POINTS} (make the step larger)",
                        crate::error::number_text(span.abs().floor() + 1.0),
                        crate::error::number_text(start),
                        crate::error::number_text(stop)
                    ),
                ));
            }
            let n = count as u64;
            Ok((0..n).map(|i| num_to_value(start + i as f64 * step, ints)).collect())
        }
        (None, Some(num)) => {
            if num == 0 || num > MAX_GRID_POINTS as u64 {
                return Err(Error::input(
                    format!("{origin}.range.num"),
                    format!("must be a whole number from 1 to {MAX_GRID_POINTS}, got {num}"),
                ));
            }
            if num == 1 {
                return Ok(vec![num_to_value(start, ints)]);
            }
            let ints = ints && (r.stop.as_i64().unwrap_or(0) - r.start.as_i64().unwrap_or(0)) % (num as i64 - 1) == 0;
            let last = (num - 1) as f64;
            Ok((0..num)
                .map(|i| {
                    let x = if i == num - 1 {
                        stop
                    } else {
                        start + (stop - start) * (i as f64 / last)
                    };
                    num_to_value(x, ints)
                })
                .collect())
        }
    }
}

fn parse_axis(a: AxisFile, origin: &str, base: &Value, auto: bool) -> Result<Axis> {
    if a.zip.is_some() {
        return Err(Error::input(
            format!("{origin}.zip"),
            "zipped groups cannot be nested",
        ));
    }
    let field = a.field.ok_or_else(|| {
        Error::input(
            format!("{origin}.field"),
            "missing: an axis needs `field` (the dotted path of a scene field, e.g. physics.damping_kg_s)",
        )
    })?;
    if auto && split_path(&field)[0] == "integrator" {
        return Err(Error::input(
            format!("{origin}.field"),
            format!("`{field}`: the base integrator is `auto`, which chooses one setting for the whole grid; an axis may not set integrator fields (give a fixed integrator in `base` to sweep over integrator settings)"),
        ));
    }
    check_settable(base, &field).map_err(|m| Error::input(format!("{origin}.field"), m))?;
    let values = match (a.values, a.range) {
        (Some(v), None) => {
            if v.is_empty() {
                return Err(Error::input(format!("{origin}.values"), "must hold at least one value"));
            }
            v
        }
        (None, Some(r)) => expand_range(&r, origin)?,
        _ => {
            return Err(Error::input(
                origin.to_string(),
                "give exactly one of `values` (a list) or `range` ({start, stop, step} or {start, stop, num})",
            ))
        }
    };
    let name = a
        .name
        .unwrap_or_else(|| split_path(&field).last().cloned().unwrap_or_default());
    Ok(Axis {
        units: units_of(&field),
        name,
        field,
        values,
        origin: origin.to_string(),
    })
}

/// The key of the innermost `"key": value` pair that starts before line `line`, column `column`
/// (1-based): names the field where a syntax error sits.
fn field_near(text: &str, offset: usize) -> Option<String> {
    let mut prefix = &text[..offset];
    while let Some(colon) = prefix.rfind(':') {
        let before = prefix[..colon].trim_end();
        if let Some(body) = before.strip_suffix('"') {
            if let Some(start) = body.rfind('"') {
                return Some(body[start + 1..].to_string());
            }
        }
        prefix = &prefix[..colon];
    }
    None
}

/// The byte offset in `text` of serde_json's (1-based line, byte column) position, moved back to
/// the start of the character it falls in: a column may point inside a multi-byte character
/// (typographic quotes, `µ`), and slicing there would panic.
fn error_offset(text: &str, line: usize, column: usize) -> usize {
    let mut offset = 0;
    for (i, l) in text.split_inclusive('\n').enumerate() {
        if i + 1 == line {
            offset += column.min(l.len());
            break;
        }
        offset += l.len();
    }
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

/// What to add to serde_json's message so that the user sees the cause.
fn syntax_hint(text: &str, offset: usize, error: &serde_json::Error) -> Option<String> {
    if error.classify() == serde_json::error::Category::Eof {
        return Some("the file ends before its JSON is complete: is it truncated?".into());
    }
    // The offending token starts at or shortly before the reported position.
    let start = text[..offset]
        .char_indices()
        .rev()
        .take(12)
        .last()
        .map_or(offset, |(i, _)| i);
    let mut end = (offset + 16).min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let near = &text[start..end];
    let out_of_range = error.to_string().starts_with("number out of range");
    if out_of_range
        || ["NaN", "Infinity", "inf", "nan"]
            .iter()
            .any(|w| near.contains(w))
    {
        return Some("numbers must be finite: NaN and infinities are not JSON".into());
    }
    let bad = text[offset..].chars().next()?;
    if matches!(bad, '\u{201c}' | '\u{201d}' | '\u{2018}' | '\u{2019}') {
        return Some(format!(
            "`{bad}` is a typographic quote: JSON strings take plain double quotes (\")"
        ));
    }
    if !bad.is_ascii() {
        return Some(format!(
            "`{bad}` (U+{:04X}) cannot stand there: outside strings JSON is plain ASCII (units belong in field names, not after numbers)",
            bad as u32
        ));
    }
    None
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= 64
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        && !name.starts_with(|c: char| c.is_ascii_digit())
}

/// JSON text as a [`Value`], refusing an object that repeats a key: serde_json keeps the last
/// one silently, so `"gravity": true, "gravity": false` would run without gravity unnoticed.
fn parse_without_duplicate_keys(text: &str) -> serde_json::Result<Value> {
    use serde::de::{DeserializeSeed, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};

    struct Strict;

    impl<'de> DeserializeSeed<'de> for Strict {
        type Value = Value;
        fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<Value, D::Error> {
            d.deserialize_any(self)
        }
    }

    impl<'de> Visitor<'de> for Strict {
        type Value = Value;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a JSON value")
        }
        fn visit_bool<E>(self, b: bool) -> std::result::Result<Value, E> {
            Ok(Value::Bool(b))
        }
        fn visit_i64<E>(self, n: i64) -> std::result::Result<Value, E> {
            Ok(Value::from(n))
        }
        fn visit_u64<E>(self, n: u64) -> std::result::Result<Value, E> {
            Ok(Value::from(n))
        }
        fn visit_f64<E: serde::de::Error>(self, x: f64) -> std::result::Result<Value, E> {
            serde_json::Number::from_f64(x)
                .map(Value::Number)
                .ok_or_else(|| E::custom("numbers must be finite"))
        }
        fn visit_str<E>(self, s: &str) -> std::result::Result<Value, E> {
            Ok(Value::String(s.to_owned()))
        }
        fn visit_string<E>(self, s: String) -> std::result::Result<Value, E> {
            Ok(Value::String(s))
        }
        fn visit_unit<E>(self) -> std::result::Result<Value, E> {
            Ok(Value::Null)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<Value, A::Error> {
            let mut items = Vec::new();
            while let Some(v) = seq.next_element_seed(Strict)? {
                items.push(v);
            }
            Ok(Value::Array(items))
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<Value, A::Error> {
            let mut object = Map::new();
            while let Some(key) = map.next_key::<String>()? {
                if object.contains_key(&key) {
                    return Err(A::Error::custom(format!(
                        "duplicate key `{key}` (each key may appear once in an object)"
                    )));
                }
                let value = map.next_value_seed(Strict)?;
                object.insert(key, value);
            }
            Ok(Value::Object(object))
        }
    }

    let mut de = serde_json::Deserializer::from_str(text);
    let value = Strict.deserialize(&mut de)?;
    de.end()?;
    Ok(value)
}

/// The sweep file's JSON, refusing unknown fields; a syntax error names the field near it.
fn read_json(text: &str) -> Result<SweepFile> {
    // Editors on Windows may start a UTF-8 file with a byte-order mark, which JSON does not allow.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let raw: Value = parse_without_duplicate_keys(text).map_err(|e| {
        let offset = error_offset(text, e.line(), e.column());
        let field = match e.classify() {
            serde_json::error::Category::Eof => String::new(),
            _ => field_near(text, offset).unwrap_or_default(),
        };
        let message = match syntax_hint(text, offset, &e) {
            Some(hint) => format!("not valid JSON: {e} ({hint})"),
            None => format!("not valid JSON: {e}"),
        };
        Error::input(field, message)
    })?;
    from_value_at(raw, "")
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

/// The grid's dimensions from the `axes` list: one per axis or zipped group.
/// The grid's dimensions; `every`: the errors are those of every axis (each read on its own),
/// else the first alone.
fn parse_dims(
    axes: Vec<AxisFile>,
    base: &Value,
    auto: bool,
    search: bool,
    every: bool,
) -> std::result::Result<Vec<Dim>, Vec<Error>> {
    if axes.is_empty() && !search {
        return Err(vec![Error::input(
            "axes",
            "at least one axis is required (a single run is an axis with one value), unless the sweep has a `search` or an `ensemble`",
        )]);
    }
    let mut dims = Vec::new();
    let mut errors = Vec::new();
    for (i, mut a) in axes.into_iter().enumerate() {
        let origin = format!("axes[{i}]");
        let dim = match a.zip.take() {
            Some(zip) => parse_zip(a, zip, &origin, base, auto),
            None => parse_axis(a, &origin, base, auto).map(|axis| Dim {
                name: axis.name.clone(),
                axes: vec![axis],
            }),
        };
        match dim {
            Ok(d) => dims.push(d),
            Err(e) if every => errors.push(e),
            Err(e) => return Err(vec![e]),
        }
    }
    if errors.is_empty() {
        Ok(dims)
    } else {
        Err(errors)
    }
}

/// A zipped group `group` (its `zip` list taken out as `zip`) at `origin`: axes of equal length.
fn parse_zip(
    group: AxisFile,
    zip: Vec<AxisFile>,
    origin: &str,
    base: &Value,
    auto: bool,
) -> Result<Dim> {
    if group.field.is_some() || group.values.is_some() || group.range.is_some() {
        return Err(Error::input(
            origin,
            "a zipped group holds only `zip` (a list of axes) and an optional `name`",
        ));
    }
    if zip.is_empty() {
        return Err(Error::input(
            format!("{origin}.zip"),
            "must hold at least one axis",
        ));
    }
    let mut axes = Vec::new();
    for (j, z) in zip.into_iter().enumerate() {
        axes.push(parse_axis(z, &format!("{origin}.zip[{j}]"), base, auto)?);
    }
    let n = axes[0].values.len();
    for ax in &axes[1..] {
        if ax.values.len() != n {
            return Err(Error::input(
                format!("{}.values", ax.origin),
                format!(
                    "zipped axes advance together and need equal lengths: this one has {}, `{}` has {n}",
                    ax.values.len(),
                    axes[0].name
                ),
            ));
        }
    }
    let name = group.name.unwrap_or_else(|| axes[0].name.clone());
    Ok(Dim { name, axes })
}

/// Names and fields must be distinct, names usable as dataset names and not reserved; checked
/// dimension by dimension.
fn check_names_and_fields(dims: &[Dim]) -> Result<()> {
    let mut names: Vec<(&str, &str)> = Vec::new();
    let mut fields: Vec<(&str, &str)> = Vec::new();
    for d in dims {
        let mut all: Vec<(&str, &str)> = d
            .axes
            .iter()
            .map(|a| (a.name.as_str(), a.origin.as_str()))
            .collect();
        if d.axes.len() > 1 && !d.axes.iter().any(|a| a.name == d.name) {
            all.push((d.name.as_str(), ""));
        }
        for (name, origin) in all {
            check_name(name, origin, &names)?;
            names.push((name, origin));
        }
        for a in &d.axes {
            check_field(a, &fields)?;
            fields.push((a.field.as_str(), a.origin.as_str()));
        }
    }
    Ok(())
}

/// `name` (of the axis at `origin`, or of a zipped dimension when `origin` is empty) is usable,
/// not reserved, and not among `taken`.
pub(crate) fn check_name(name: &str, origin: &str, taken: &[(&str, &str)]) -> Result<()> {
    let at = if origin.is_empty() {
        "axes".to_string()
    } else {
        format!("{origin}.name")
    };
    if !valid_name(name) {
        return Err(Error::input(
            at,
            format!("`{name}` is not a usable name: letters, digits, `_` and `-`, not starting with a digit, at most 64 characters"),
        ));
    }
    let reserved = reserved_names();
    if reserved.contains(&name) {
        return Err(Error::input(
            at,
            format!(
                "`{name}` is a reserved dataset name; reserved: {}",
                reserved.join(", ")
            ),
        ));
    }
    if let Some((_, other)) = taken.iter().find(|(n, _)| *n == name) {
        return Err(Error::input(
            at,
            format!("name `{name}` is already used by {other}"),
        ));
    }
    Ok(())
}

/// The field of axis `a` overlaps none of the fields `taken` (a field, or one inside it).
fn check_field(a: &Axis, taken: &[(&str, &str)]) -> Result<()> {
    let segs = split_path(&a.field);
    for (f, other) in taken {
        let o = split_path(f);
        let overlap = segs.len().min(o.len());
        if segs[..overlap] == o[..overlap] {
            return Err(Error::input(
                format!("{}.field", a.origin),
                format!(
                    "`{}` overlaps `{f}` set by {other}; each field may be set by one axis only",
                    a.field
                ),
            ));
        }
    }
    Ok(())
}

impl Sweep {
    /// Parses and checks a sweep file's text: syntax, unknown fields, types, axes. Grid points
    /// are checked by [`crate::grid::Grid::new`].
    pub fn parse(text: &str) -> Result<Sweep> {
        Sweep::parse_in(text, std::path::Path::new("."))
    }

    /// [`Sweep::parse`] for a sweep file in folder `dir`, from which the relative paths it names
    /// (recorded drives) are read.
    pub fn parse_in(text: &str, dir: &std::path::Path) -> Result<Sweep> {
        let inlined = recording::inline_text(text, dir)?;
        let text = inlined.as_deref().unwrap_or(text);
        let with_data = fit::inline_text(text, dir)?;
        let text = with_data.as_deref().unwrap_or(text);
        let with_fit = ensemble::inline_text(text, dir)?;
        let text = with_fit.as_deref().unwrap_or(text);
        let mut file = read_json(text)?;
        let derived = expr::extract(&mut file.base, &raw_axes(text))?;
        let (mut base, _, auto) = normalise_base(file.base, file.record, false).map_err(first)?;
        let limits = parse_limits(file.limits)?;
        let mut dims = parse_dims(
            file.axes,
            &base,
            auto.is_some(),
            file.search.is_some() || file.ensemble.is_some(),
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
        let ensemble = file
            .ensemble
            .map(|e| ensemble::parse(e, &mut base, &mut dims))
            .transpose()?;
        Ok(Sweep {
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
    #[test]
    fn a_fields_name_says_its_unit_and_its_words() {
        assert_eq!(
            units_of("excitation.drive.force_n.harmonic.frequency_hz"),
            "Hz"
        );
        assert_eq!(units_of("physics.damping_kg_s"), "kg/s");
        assert_eq!(units_of("striker_velocity_m_s"), "m/s");
        assert_eq!(
            units_of("chain.cylinder.mass.heavy_cylinders.mass_ratio"),
            "1"
        );
        assert_eq!(human_name("damping_kg_s"), "damping");
        assert_eq!(human_name("frequency_hz"), "frequency");
        assert_eq!(human_name("mass_ratio"), "mass ratio");
        assert_eq!(human_name("seed"), "seed");
    }

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

    #[test]
    fn units_follow_suffixes() {
        assert_eq!(units_of("physics.damping_kg_s"), "kg/s");
        assert_eq!(units_of("striker_velocity_m_s"), "m/s");
        assert_eq!(units_of("duration_s"), "s");
        assert_eq!(units_of("chain.cylinders"), "1");
        assert_eq!(units_of("chain.cylinder.density_kg_m3"), "kg/m^3");
    }

    #[test]
    fn paths_split_on_dots_and_brackets() {
        assert_eq!(
            split_path("record.probes[1].cylinder"),
            vec!["record", "probes", "1", "cylinder"]
        );
        assert_eq!(split_path("a.b"), vec!["a", "b"]);
    }

    #[test]
    fn ranges_include_their_ends() {
        let r = RangeFile {
            start: 0.into(),
            stop: 100.into(),
            step: Some(10.into()),
            num: None,
        };
        let v = expand_range(&r, "axes[0]").unwrap();
        assert_eq!(v.len(), 11);
        assert_eq!(v[10], Value::from(100));
        let r = RangeFile {
            start: serde_json::Number::from_f64(0.1).unwrap(),
            stop: serde_json::Number::from_f64(1.0).unwrap(),
            step: None,
            num: Some(10),
        };
        let v = expand_range(&r, "axes[0]").unwrap();
        assert_eq!(v.len(), 10);
        assert_eq!(v[9].as_f64(), Some(1.0));
        assert_eq!(v[0].as_f64(), Some(0.1));
    }
}
