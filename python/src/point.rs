//! One scene, run in this process exactly as `chainsweep point` runs a grid point.
//!
//! The scene is the JSON of a sweep file's `base` (chain presets, defaults, `integrator: auto`),
//! with the `record` and `limits` blocks beside it. The runner makes it a sweep of one point
//! without axes ([`Sweep::of_scene`]), normalised as a sweep file's base, identifies it ([`Grid`]'s
//! run hash) and runs it under panic protection with its failure limits
//! ([`exec::execute_stoppable`]): the numbers are bitwise those of `chainsweep point` for the same
//! scene. The run goes on a thread of its own while this one checks Python's signals every
//! [`SIGNAL_INTERVAL`]: Ctrl-C (a notebook's interrupt) stops it within a step and raises
//! `KeyboardInterrupt`.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use pyo3::intern;
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::Value;

use chainsweep::engine;
use chainsweep::error::{Error, Result};
use chainsweep::exec;
use chainsweep::grid::Grid;
use chainsweep::identity::hex;
use chainsweep::numerics::auto as pilot;
use chainsweep::record::columns::{ColumnData, Fill, PointOutcome, Presence, COLUMNS};
use chainsweep::record::{RunRecord, INT_FILL};
use chainsweep::sweep::auto::AutoChoice;
use chainsweep::sweep::Sweep;
use chainsweep_solver::Scene;

/// A finished point: the scene as run (defaults filled in, `auto` resolved), its identity, the
/// failure limit and the run's record.
struct PointRun {
    scene: Scene,
    hash: String,
    energy_drift_limit: Option<f64>,
    auto: Option<AutoChoice>,
    record: RunRecord,
    /// Whether the scene may integrate only the moving part of its chain (its grid's flag).
    moving_part: bool,
}

/// Normalises and runs one scene (see the module docs). Errors are input errors naming the field
/// (`base.…`, `record.…`, `limits.…` as in a sweep file; the validation of the built scene names
/// scene fields without the `base.` prefix).
fn run_point(
    scene: Value,
    record: Option<Value>,
    limits: Option<Value>,
    stop: Arc<AtomicBool>,
) -> Result<Option<PointRun>> {
    let (mut sweep, base) = Sweep::of_scene(scene, record, limits)?;
    // The grid's one point is the scene run: read from its JSON once, by the normalisation.
    let (mut grid, mut scene) = match Grid::with_first_scene(&sweep, Some(base)) {
        Ok(expanded) => expanded,
        Err(e) => {
            // Where the scene itself is at fault, its own error, naming its fields without the
            // `base.` prefix (looked for only now: a valid scene is parsed and built once less).
            let base: Scene = chainsweep::sweep::from_value_at(sweep.base.clone(), "base")?;
            base.validate()
                .map_err(|e| Error::input(e.field.clone(), e.message.clone()))?;
            return Err(e);
        }
    };
    exec::install_panic_hook();
    if let Some(spec) = sweep.auto {
        // As `chainsweep point` without `-o`: the pilot runs on the one point there is.
        let pool = engine::thread_pool(engine::all_cpus())?;
        let choice = pilot::resolve(&sweep, &grid, &spec, &pool, |_| {})?;
        sweep.apply_auto(choice);
        (grid, scene) = Grid::with_first_scene(&sweep, None)?;
    }
    let hash = grid.hashes[0];
    let Some(record) = exec::execute_stoppable(&scene, hash, &sweep.limits, stop) else {
        return Ok(None);
    };
    Ok(Some(PointRun {
        scene,
        hash: hex(&hash),
        energy_drift_limit: sweep.limits.energy_drift_max,
        auto: sweep.auto_choice.clone(),
        record,
        moving_part: grid.moving_part,
    }))
}

/// How often Python's signals are checked while a point runs.
const SIGNAL_INTERVAL: Duration = Duration::from_millis(50);

fn parse_json(text: &str, what: &str) -> Result<Value> {
    serde_json::from_str(text).map_err(|e| Error::input(what, format!("not valid JSON: {e}")))
}

/// Little-endian float64 bytes of `xs`, for `numpy.frombuffer` (bitwise, NaN included).
fn f64_bytes<'py>(py: Python<'py>, xs: &[f64]) -> Bound<'py, PyBytes> {
    let mut b = Vec::with_capacity(8 * xs.len());
    for x in xs {
        b.extend_from_slice(&x.to_le_bytes());
    }
    PyBytes::new(py, &b)
}

/// The summary columns of the one run, each filled from the run's record exactly as the output
/// file fills it (the runner's column table, [`COLUMNS`]): name → a number, `None` (an integer's
/// fill), a text, or a list per probe. Checksums and verification columns are files' only.
fn columns<'py>(
    py: Python<'py>,
    run: &PointRun,
    moving_part: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let n_probes = run.scene.record.probes.len();
    let presence = Presence {
        probes: n_probes,
        moving_part,
        run_groups: false,
        spectrum: run.scene.record.spectrum.is_some(),
        harmonics: run
            .scene
            .record
            .steady_state
            .as_ref()
            .map_or(0, |s| s.harmonics as usize),
        energy_ledger: run.scene.record.energy_ledger,
    };
    let outcome = PointOutcome {
        hash_hex: &run.hash,
        record: Some(&run.record),
        verify: None,
    };
    // The names as Python strings, made once (a run's answer is a few dozen names).
    static NAMES: PyOnceLock<Vec<Py<PyString>>> = PyOnceLock::new();
    let names = NAMES.get_or_init(py, || {
        COLUMNS
            .iter()
            .map(|c| PyString::intern(py, c.name).unbind())
            .collect()
    });
    let d = PyDict::new(py);
    for (c, name) in COLUMNS
        .iter()
        .zip(names)
        .filter(|(c, _)| c.is_written(presence))
    {
        if matches!(
            c.fill,
            Fill::Verified | Fill::VerifyMax | Fill::VerifyProbe(_) | Fill::SummaryChecksum
        ) {
            continue;
        }
        let mut data = c.empty(1, n_probes, presence.harmonics);
        c.fill_point(&mut data, 0, n_probes, presence.harmonics, &outcome);
        let one = |v: Bound<'py, PyAny>| -> PyResult<Bound<'py, PyAny>> {
            if c.per_probe {
                Ok(v)
            } else {
                v.get_item(0)
            }
        };
        let value = match data {
            // Over (probe, harmonic): a list per probe.
            ColumnData::F64(x) if c.per_harmonic => PyList::new(
                py,
                x.chunks(presence.harmonics.max(1))
                    .map(|h| PyList::new(py, h))
                    .collect::<PyResult<Vec<_>>>()?,
            )?
            .into_any(),
            ColumnData::F64(x) => one(PyList::new(py, x)?.into_any())?,
            ColumnData::I64(x) => one(PyList::new(
                py,
                x.into_iter().map(|n| (n != INT_FILL).then_some(n)),
            )?
            .into_any())?,
            ColumnData::U8(x) => one(PyList::new(py, x)?.into_any())?,
            ColumnData::U64(_) => continue,
            ColumnData::Str(x) => one(PyList::new(py, x)?.into_any())?,
        };
        d.set_item(name.bind(py), value)?;
    }
    Ok(d)
}

/// An argument of [`run_scene`]: JSON text, or the value itself read from plain Python values.
enum Json {
    Text(String),
    Value(Value),
}

impl Json {
    /// `None` where `obj` is neither text nor plain values.
    fn of(obj: &Bound<'_, PyAny>) -> Option<Json> {
        match obj.cast::<PyString>() {
            Ok(text) => text.to_str().ok().map(|t| Json::Text(t.to_string())),
            Err(_) => plain_json(obj, 0).map(Json::Value),
        }
    }

    fn value(self, what: &str) -> Result<Value> {
        match self {
            Json::Text(text) => parse_json(&text, what),
            Json::Value(value) => Ok(value),
        }
    }
}

/// An optional argument: `Some(None)` where it is not given, `None` where it is given and
/// neither text nor plain values.
fn optional_json(arg: Option<&Bound<'_, PyAny>>) -> Option<Option<Json>> {
    match arg {
        None => Some(None),
        Some(obj) => Json::of(obj).map(Some),
    }
}

/// How deep [`plain_json`] reads nested dicts and lists (serde_json's own limit on parsing text).
const MAX_PLAIN_DEPTH: usize = 128;

/// The JSON value of plain Python values: a dict with text keys, a list or tuple, text, a bool,
/// an integer within 64 bits, a finite float, `None`. It is the value their JSON text (Python's
/// `json.dumps`) parses to, read without writing and parsing that text. `None` for anything else
/// (numpy values, NaN and infinities, other keys, nesting deeper than [`MAX_PLAIN_DEPTH`]).
fn plain_json(obj: &Bound<'_, PyAny>, depth: usize) -> Option<Value> {
    if depth > MAX_PLAIN_DEPTH {
        return None;
    }
    if obj.is_none() {
        return Some(Value::Null);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Some(Value::Bool(b.is_true()));
    }
    if obj.cast::<PyInt>().is_ok() {
        return match obj.extract::<i64>() {
            Ok(i) => Some(Value::from(i)),
            Err(_) => obj.extract::<u64>().ok().map(Value::from),
        };
    }
    if let Ok(x) = obj.cast::<PyFloat>() {
        return serde_json::Number::from_f64(x.value()).map(Value::Number);
    }
    if let Ok(text) = obj.cast::<PyString>() {
        return text.to_str().ok().map(|t| Value::String(t.to_string()));
    }
    if let Ok(dict) = obj.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, v) in dict.iter() {
            let key = k.cast::<PyString>().ok()?.to_str().ok()?.to_string();
            map.insert(key, plain_json(&v, depth + 1)?);
        }
        return Some(Value::Object(map));
    }
    let items = |seq: &mut dyn Iterator<Item = Bound<'_, PyAny>>| {
        seq.map(|v| plain_json(&v, depth + 1))
            .collect::<Option<Vec<_>>>()
            .map(Value::Array)
    };
    if let Ok(list) = obj.cast::<PyList>() {
        return items(&mut list.iter());
    }
    if let Ok(tuple) = obj.cast::<PyTuple>() {
        return items(&mut tuple.iter());
    }
    None
}

/// Runs one scene (`scene`: a sweep file's `base`; `record`, `limits`: its blocks, or `None`) with
/// the GIL released, and returns everything the run recorded as a dict of plain Python values
/// (histories as little-endian float64 bytes). Each argument is JSON text or plain values (see
/// [`plain_json`]); an argument that holds anything else returns `None` and runs nothing: the
/// caller writes it as JSON text, which converts what it can and names what it cannot. Raises
/// `chainsweep.InputError` for bad input; a failed run is returned with `ok` false and its
/// `reason`.
#[pyfunction]
#[pyo3(signature = (scene, record=None, limits=None))]
pub fn run_scene<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    record: Option<&Bound<'py, PyAny>>,
    limits: Option<&Bound<'py, PyAny>>,
) -> PyResult<Option<Bound<'py, PyDict>>> {
    let (Some(scene), Some(record), Some(limits)) = (
        Json::of(scene),
        optional_json(record),
        optional_json(limits),
    ) else {
        return Ok(None);
    };
    let stop = Arc::new(AtomicBool::new(false));
    let runner_stop = Arc::clone(&stop);
    let (tx, rx) = mpsc::channel::<Result<Option<PointRun>>>();
    let runner = std::thread::spawn(move || {
        let outcome = (|| {
            let scene = scene.value("scene")?;
            let record = record.map(|r| r.value("record")).transpose()?;
            let limits = limits.map(|l| l.value("limits")).transpose()?;
            run_point(scene, record, limits, runner_stop)
        })();
        let _ = tx.send(outcome);
    });
    // (A receiver is not `Sync`; the wait below borrows it from a thread without the GIL.)
    let rx = std::sync::Mutex::new(rx);
    let mut interrupt: Option<PyErr> = None;
    let outcome = loop {
        match py.detach(|| {
            rx.lock()
                .expect("only this thread locks it")
                .recv_timeout(SIGNAL_INTERVAL)
        }) {
            Ok(r) => break r,
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                break Err(Error::Other(
                    "the run's thread ended without a result (a panic outside the run)".into(),
                ))
            }
        }
        if interrupt.is_none() {
            if let Err(e) = py.check_signals() {
                stop.store(true, Ordering::SeqCst);
                interrupt = Some(e);
            }
        }
    };
    let _ = runner.join();
    if let Some(e) = interrupt {
        return Err(e);
    }
    let run = match outcome.map_err(|e| crate::py_error(py, &e, "scene"))? {
        Some(run) => run,
        None => unreachable!("a run stops early only when interrupted"),
    };
    let rec = &run.record;
    let probes = &run.scene.record.probes;
    let d = PyDict::new(py);
    d.set_item(
        intern!(py, "scene"),
        serde_json::to_string(&run.scene).expect("Scene serialises"),
    )?;
    d.set_item(
        intern!(py, "integrator"),
        serde_json::to_string(&run.scene.integrator).expect("IntegratorSpec serialises"),
    )?;
    d.set_item(intern!(py, "run_hash"), &run.hash)?;
    d.set_item(intern!(py, "energy_drift_limit"), run.energy_drift_limit)?;
    d.set_item(
        intern!(py, "auto"),
        run.auto.as_ref().map(AutoChoice::to_json),
    )?;
    d.set_item(
        intern!(py, "auto_setting"),
        run.auto
            .as_ref()
            .map(|c| serde_json::to_string(&c.integrator).expect("IntegratorSpec serialises")),
    )?;
    d.set_item(intern!(py, "ok"), rec.ok)?;
    d.set_item(intern!(py, "reason"), &rec.reason)?;
    // Kept as a sweep file keeps them: only for a scene that can integrate only the moving part
    // of its chain (elsewhere they would repeat the chain's length).
    let moving_part = run.moving_part;
    d.set_item(intern!(py, "moving_part_recorded"), moving_part)?;
    d.set_item(intern!(py, "columns"), columns(py, &run, moving_part)?)?;
    d.set_item(
        intern!(py, "probe"),
        PyList::new(py, probes.iter().map(|p| p.name()))?,
    )?;
    d.set_item(
        intern!(py, "probe_units"),
        PyList::new(py, probes.iter().map(|p| p.unit()))?,
    )?;
    d.set_item(
        intern!(py, "probes_json"),
        serde_json::to_string(probes).expect("probes serialise"),
    )?;
    match &rec.history {
        Some(h) => {
            d.set_item(intern!(py, "time_s"), f64_bytes(py, &h.time_s))?;
            let series: Vec<Bound<'py, PyBytes>> =
                h.values.iter().map(|v| f64_bytes(py, v)).collect();
            d.set_item(intern!(py, "history"), PyList::new(py, series)?)?;
        }
        None => {
            d.set_item(intern!(py, "time_s"), py.None())?;
            d.set_item(intern!(py, "history"), py.None())?;
        }
    }
    match &rec.min_overlap_m {
        Some(m) => d.set_item(intern!(py, "min_overlap_m"), f64_bytes(py, m))?,
        None => d.set_item(intern!(py, "min_overlap_m"), py.None())?,
    }
    match &rec.energy_flow {
        Some(f) => {
            d.set_item(
                intern!(py, "energy_passed_max_j"),
                f64_bytes(py, &f.energy_passed_max_j),
            )?;
            d.set_item(
                intern!(py, "energy_passed_final_j"),
                f64_bytes(py, &f.energy_passed_final_j),
            )?;
            d.set_item(
                intern!(py, "max_kinetic_energy_j"),
                f64_bytes(py, &f.max_kinetic_energy_j),
            )?;
        }
        None => {
            for name in [
                intern!(py, "energy_passed_max_j"),
                intern!(py, "energy_passed_final_j"),
                intern!(py, "max_kinetic_energy_j"),
            ] {
                d.set_item(name, py.None())?;
            }
        }
    }
    match &rec.fields {
        Some(f) => {
            d.set_item(intern!(py, "field_time_s"), f64_bytes(py, &f.time_s))?;
            let series: Vec<(&str, usize, Bound<'py, PyBytes>)> = f
                .series
                .iter()
                .map(|s| (s.quantity.name(), s.width, f64_bytes(py, &s.values)))
                .collect();
            d.set_item(intern!(py, "fields"), PyList::new(py, series)?)?;
        }
        None => {
            d.set_item(intern!(py, "field_time_s"), py.None())?;
            d.set_item(intern!(py, "fields"), py.None())?;
        }
    }
    d.set_item(
        intern!(py, "fields_recorded"),
        run.scene
            .record
            .fields
            .as_ref()
            .map(|f| f.quantities.iter().map(|q| q.name()).collect::<Vec<_>>()),
    )?;
    d.set_item(intern!(py, "history_recorded"), run.scene.record.history)?;
    d.set_item(
        intern!(py, "min_overlap_recorded"),
        run.scene.record.min_overlap,
    )?;
    d.set_item(
        intern!(py, "energy_flow_recorded"),
        run.scene.record.energy_flow,
    )?;
    Ok(Some(d))
}
