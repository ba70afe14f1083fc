//! `--json`: what `validate`, `status` and `run --dry-run` print, as one JSON object on stdout
//! for scripts (the shapes are documented in docs/REFERENCE.md, "Machine-readable output").
//!
//! Every object carries `"chainsweep": JSON_VERSION` (the version of these shapes: a field is
//! only ever added under the same version) and `"kind"`. Counts are numbers, points are flat
//! grid indices (row-major, as `run --dry-run` lists them) with their axis values.

use std::path::Path;

use serde_json::{json, Map, Value};

use chainsweep::engine::inspect::{DryRun, SearchDryRun};
use chainsweep::engine::periodic::{PeriodicDryRun, PeriodicStatus};
use chainsweep::engine::status::{FileStatus, SearchLine, ShardSetStatus, SweepStatus};
use chainsweep::engine::DamageReport;
use chainsweep::error::Error;
use chainsweep::grid::{multi_index, Grid};
use chainsweep::identity::hex;
use chainsweep::store::hdf5::Counts;
use chainsweep::sweep::Sweep;

/// The version of the shapes printed by `--json`.
pub const JSON_VERSION: u32 = 1;

/// Most points listed by `run --dry-run --json` (the first ones; `points_listed` says how many).
pub const MOST_LISTED_POINTS: usize = 100_000;

/// Prints `value` on stdout.
pub fn print(value: &Value) {
    outln!(
        "{}",
        serde_json::to_string_pretty(value).expect("a JSON value prints")
    );
}

fn head(kind: &str) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert("chainsweep".into(), json!(JSON_VERSION));
    m.insert("kind".into(), json!(kind));
    m
}

fn path_text(p: &Path) -> Value {
    json!(p.display().to_string())
}

fn health(h: &chainsweep::engine::run::Health) -> Value {
    json!({
        "failed": h.failed,
        "over_limit": h.over_limit,
        "unsettled": h.unsettled,
        "nan_leading_peak": h.nan_leading,
        "verified": h.verified,
        "largest_verified_error": h.worst_verified.map(|(e, i)| json!({"bound": e, "point": i})),
    })
}

fn counts(c: &Counts) -> Value {
    json!({"ok": c.ok, "unsettled": c.unsettled, "failed": c.failed, "pending": c.pending})
}

/// A grid point: its flat index, and its axis values by axis name.
fn point(sweep: &Sweep, shape: &[usize], index: usize) -> Value {
    let mi = multi_index(shape, index);
    let mut values = Map::new();
    for (d, dim) in sweep.dims.iter().enumerate() {
        for a in &dim.axes {
            if let Some(v) = mi.get(d).and_then(|&j| a.values.get(j)) {
                values.insert(a.name.clone(), v.clone());
            }
        }
    }
    json!({"point": index, "index": mi, "values": values})
}

fn dims(sweep: &Sweep) -> Value {
    Value::Array(
        sweep
            .dims
            .iter()
            .map(|d| {
                json!({
                    "name": d.name,
                    "length": d.len(),
                    "axes": d.axes.iter().map(|a| json!({
                        "name": a.name, "field": a.field, "units": a.units, "values": a.values,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect(),
    )
}

fn warnings(sweep: &Sweep, grid: &Grid) -> Value {
    json!({
        "points": grid.warned_points,
        "listed": grid.warnings.iter().flat_map(|(i, ws)| ws.iter().map(move |w| {
            let mut p = point(sweep, &grid.shape, *i);
            p["warning"] = json!(w);
            p
        })).collect::<Vec<_>>(),
    })
}

fn record(grid: &Grid) -> Value {
    json!({
        "probes": grid.probes.iter().map(|p| p.name()).collect::<Vec<_>>(),
        "history": grid.history,
        "max_history_samples": grid.max_history_samples,
        "min_overlap": grid.min_overlap,
        "energy_flow": grid.energy_flow,
        "fields": grid.fields.as_ref().map(|f| json!({
            "quantities": f.quantities.iter().map(|q| q.name()).collect::<Vec<_>>(),
            "interval_s": f.interval_s,
            "max_samples": grid.max_field_samples,
        })),
    })
}

/// `validate --json` of a valid sweep file.
pub fn validated(file: &Path, sweep: &Sweep, grid: &Grid, pilots: Option<Vec<usize>>) -> Value {
    let mut m = head("validate");
    m.insert("file".into(), path_text(file));
    m.insert("valid".into(), json!(true));
    m.insert("errors".into(), json!([]));
    m.insert("points".into(), json!(grid.len()));
    m.insert("shape".into(), json!(grid.shape));
    m.insert("dims".into(), dims(sweep));
    m.insert("record".into(), record(grid));
    m.insert("warnings".into(), warnings(sweep, grid));
    if let Some(spec) = sweep.auto {
        m.insert(
            "integrator_auto".into(),
            json!({
                "target_rel_error": spec.target_rel_error,
                "pilot_points": pilots,
            }),
        );
    }
    Value::Object(m)
}

/// `validate --json` of an invalid sweep file: every error found.
pub fn invalid(file: &Path, errors: &[Error]) -> Value {
    let mut m = head("validate");
    m.insert("file".into(), path_text(file));
    m.insert("valid".into(), json!(false));
    let list: Vec<Value> = errors
        .iter()
        .map(|e| match e {
            Error::Input { field, message, .. } => json!({"field": field, "message": message}),
            other => json!({"field": "", "message": other.to_string()}),
        })
        .collect();
    m.insert("errors".into(), Value::Array(list));
    Value::Object(m)
}

/// An ensemble's outcome and statistics (NaN as null).
fn ensemble(e: &Option<chainsweep::engine::status::EnsembleStatus>) -> Value {
    let Some(e) = e else { return Value::Null };
    let n = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let est = |x: &chainsweep::uq::stats::Estimate| json!({"value": n(x.value), "lower": n(x.lower), "upper": n(x.upper)});
    let statistics: Vec<Value> = e
        .statistics
        .iter()
        .map(|st| {
            let points: Vec<Value> = st
                .points
                .iter()
                .map(|p| {
                    json!({
                        "at": p.label,
                        "samples": p.n,
                        "mean": est(&p.mean),
                        "sd": est(&p.sd),
                        "quantiles": p.quantiles.iter().map(|(q, x)| json!({"probability": q, "estimate": est(x)})).collect::<Vec<_>>(),
                        "sensitivity": p.sensitivity.iter().map(|(i, a, b)| if e.design == "morris" {
                            json!({"input": i, "mu_star": est(a), "sigma": n(b.value)})
                        } else {
                            json!({"input": i, "first_order": est(a), "total": est(b)})
                        }).collect::<Vec<_>>(),
                    })
                })
                .collect();
            json!({"name": st.name, "units": st.units, "points": points})
        })
        .collect();
    json!({
        "design": e.design,
        "round": e.outcome.round,
        "samples": e.outcome.samples,
        "runs": e.outcome.runs,
        "stopped_by": e.outcome.stopped_by,
        "worst_width_over_tolerance": n(e.outcome.worst_ratio),
        "statistics": statistics,
    })
}

fn searches(lines: &Option<Vec<SearchLine>>) -> Value {
    match lines {
        None => Value::Null,
        Some(lines) => Value::Array(
            lines
                .iter()
                .map(|l| {
                    let answers: Vec<Value> = l
                        .answers
                        .iter()
                        .map(|a| {
                            let fields: Map<String, Value> = a
                                .fields
                                .iter()
                                .enumerate()
                                .map(|(k, (n, x, u))| {
                                    let mut v = json!({"value": x, "uncertainty": u});
                                    // A fit's intervals (NaN, not computed, as null).
                                    if let Some([lin, prof]) = a.intervals.get(k) {
                                        let num = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
                                        v["linear_95"] = json!([num(lin[0]), num(lin[1])]);
                                        v["profile_95"] = json!([num(prof[0]), num(prof[1])]);
                                    }
                                    (n.clone(), v)
                                })
                                .collect();
                            json!({"item": a.item, "fields": fields, "objective": a.objective, "status": a.status})
                        })
                        .collect();
                    json!({"at": l.label, "status": l.status, "runs": l.runs, "note": l.note, "answers": answers})
                })
                .collect(),
        ),
    }
}

fn damage(d: &DamageReport) -> Value {
    let lost = |runs: &[chainsweep::engine::LostRun]| -> Vec<Value> {
        runs.iter()
            .map(|r| json!({"point": r.point, "at": r.label, "why": r.why}))
            .collect()
    };
    json!({
        "any": d.any(),
        "file": d.file,
        "header": d.header,
        "snapshot": d.snapshot,
        "restored": lost(&d.restored),
        "lost": lost(&d.lost),
        "unchecked": d.unchecked,
    })
}

/// `status FILE.h5 --json`.
pub fn file_status(file: &Path, s: &FileStatus, exit_code: i32) -> Value {
    let mut m = head("status_file");
    m.insert("file".into(), path_text(file));
    m.insert("points".into(), json!(s.total));
    m.insert("shape".into(), json!(s.shape));
    m.insert("shard".into(), json!(s.shard));
    m.insert("counts".into(), counts(&s.counts));
    m.insert("finished_since_written".into(), json!(s.newer));
    m.insert("writer_pid".into(), json!(s.writer));
    m.insert("other_shards_runs".into(), json!(s.other_shards));
    m.insert("other_engine_runs".into(), json!(s.other_engine));
    m.insert(
        "failures".into(),
        Value::Array(
            s.failures
                .iter()
                .map(|(i, reason)| {
                    json!({"point": i, "index": multi_index(&s.shape, *i), "at": s.labels.get(i), "reason": reason})
                })
                .collect(),
        ),
    );
    m.insert(
        "leading_pulse_not_passed".into(),
        json!({"runs": s.unpassed.len(), "points": s.unpassed}),
    );
    m.insert(
        "unsettled".into(),
        json!({"runs": s.unsettled.len(), "points": s.unsettled}),
    );
    m.insert("health".into(), health(&s.health));
    m.insert("searches".into(), searches(&s.searches));
    m.insert("ensemble".into(), ensemble(&s.ensemble));
    m.insert("damage".into(), damage(&s.damage));
    m.insert("exit_code".into(), json!(exit_code));
    Value::Object(m)
}

/// `status SWEEP.json --json`.
pub fn sweep_status(
    file: &Path,
    sweep: &Sweep,
    grid: &Grid,
    s: &SweepStatus,
    exit_code: i32,
) -> Value {
    let mut m = head("status_sweep");
    m.insert("sweep".into(), path_text(file));
    m.insert("output".into(), path_text(&s.output));
    m.insert("writer_pid".into(), json!(s.writer));
    m.insert("points".into(), json!(s.points));
    m.insert("shape".into(), json!(grid.shape));
    m.insert(
        "counts".into(),
        s.counts.as_ref().map_or(Value::Null, counts),
    );
    m.insert(
        "integrator_auto".into(),
        match (&sweep.auto, &s.auto) {
            (Some(spec), choice) => json!({
                "target_rel_error": spec.target_rel_error,
                "chosen": choice.as_ref().map(|c| serde_json::to_value(c.integrator).expect("an integrator serialises")),
            }),
            (None, _) => Value::Null,
        },
    );
    m.insert(
        "failures".into(),
        Value::Array(
            s.failures
                .iter()
                .map(|f| {
                    let mut p = point(sweep, &grid.shape, f.point);
                    p["reason"] = json!(f.reason);
                    p
                })
                .collect(),
        ),
    );
    m.insert(
        "leading_pulse_not_passed".into(),
        json!({"runs": s.unpassed.len(), "points": s.unpassed}),
    );
    m.insert(
        "unsettled".into(),
        json!({"runs": s.unsettled.len(), "points": s.unsettled}),
    );
    m.insert("health".into(), health(&s.health));
    m.insert(
        "ignored".into(),
        Value::Array(s.ignored.iter().map(|p| path_text(p)).collect()),
    );
    m.insert("searches".into(), searches(&s.searches));
    m.insert("ensemble".into(), ensemble(&s.ensemble));
    m.insert("damage".into(), damage(&s.damage));
    m.insert("exit_code".into(), json!(exit_code));
    Value::Object(m)
}

/// `status` of shard files or a shard folder, `--json`; `resubmit`: the command that runs
/// only the shards to run again (when the SLURM job files are known).
pub fn shard_set(set: &ShardSetStatus, resubmit: Option<String>, exit_code: i32) -> Value {
    let mut m = head("status_shards");
    m.insert("shards".into(), json!(set.n));
    m.insert(
        "list".into(),
        Value::Array(
            set.shards
                .iter()
                .map(|e| {
                    json!({
                        "shard": e.k,
                        "array_task": e.k - 1,
                        "state": e.state.name(),
                        "file": e.file.as_deref().map(path_text),
                        "counts": e.counts.as_ref().map(counts),
                        "writer_pid": e.writer,
                    })
                })
                .collect(),
        ),
    );
    let to_run = set.to_run();
    m.insert(
        "to_run".into(),
        json!({
            "shards": to_run,
            "array_tasks": to_run.iter().map(|k| k - 1).collect::<Vec<_>>(),
            "resubmit": resubmit,
        }),
    );
    m.insert("exit_code".into(), json!(exit_code));
    Value::Object(m)
}

/// `run --dry-run --json` of a grid sweep.
pub fn dry_run(
    sweep: &Sweep,
    grid: &Grid,
    points: &[usize],
    output: &Path,
    shard: Option<chainsweep::grid::Shard>,
    d: &DryRun,
) -> Value {
    let mut m = head("dry_run");
    m.insert("output".into(), path_text(output));
    m.insert("points".into(), json!(grid.len()));
    m.insert("shape".into(), json!(grid.shape));
    m.insert("shard".into(), json!(shard.map(|s| s.to_string())));
    m.insert("shard_points".into(), json!(points.len()));
    m.insert("dims".into(), dims(sweep));
    m.insert("record".into(), record(grid));
    m.insert(
        "integrator_auto".into(),
        sweep.auto_choice.as_ref().map_or(Value::Null, |c| {
            json!({
                "target_rel_error": c.target_rel_error,
                "chosen": serde_json::to_value(c.integrator).expect("an integrator serialises"),
            })
        }),
    );
    m.insert("warnings".into(), warnings(sweep, grid));
    m.insert(
        "runs".into(),
        json!({"done": d.ok, "failed": d.failed, "to_run": points.len() - d.ok - d.failed}),
    );
    m.insert(
        "size_bytes".into(),
        json!({
            "per_run_summaries": d.size.summary,
            "per_run_histories_uncompressed": d.size.history,
            "per_run_fields_uncompressed": d.size.fields,
            "total_estimate": d.size.total(points.len()),
        }),
    );
    m.insert("cost".into(), cost(d.cost.as_ref()));
    let listed = &points[..points.len().min(MOST_LISTED_POINTS)];
    m.insert("points_listed".into(), json!(listed.len()));
    m.insert(
        "list".into(),
        Value::Array(
            listed
                .iter()
                .map(|&i| {
                    let mut p = point(sweep, &grid.shape, i);
                    let h = grid.hashes[i];
                    p["run_hash"] = json!(hex(&h));
                    p["stored"] = match d.stored.get(&h) {
                        Some(true) => json!("ok"),
                        Some(false) => json!("failed"),
                        None => Value::Null,
                    };
                    p
                })
                .collect(),
        ),
    );
    Value::Object(m)
}

fn cost(c: Option<&chainsweep::engine::inspect::CostEstimate>) -> Value {
    c.map_or(Value::Null, |c| {
        json!({
            "cpu_seconds": c.cpu_seconds,
            "runs": c.runs,
            "relative_accuracy": c.accuracy,
            "pilot_points": c.pilot_points,
            "pilot_cpu_seconds": c.per_run,
            "extrapolated": c.extrapolated,
        })
    })
}

/// `run --dry-run --json` of a sweep with a search.
/// `run --dry-run --json` of a sweep with a `periodic` block.
pub fn dry_run_periodic(sweep: &Sweep, output: &Path, d: &PeriodicDryRun) -> Value {
    let mut m = head("dry_run_periodic");
    m.insert("output".into(), path_text(output));
    m.insert(
        "periodic".into(),
        json!(sweep.periodic.as_ref().map(|p| p.describe())),
    );
    m.insert("dims".into(), dims(sweep));
    m.insert("branches".into(), json!(d.branches));
    m.insert("branches_ended".into(), json!(d.ended));
    m.insert("max_points".into(), json!(d.max_points));
    m.insert(
        "pilot".into(),
        json!({
            "from": d.from,
            "monodromy": d.monodromy,
            "settle_seconds": d.settle_seconds,
            "map_seconds_with_monodromy": d.seconds_per_map.0,
            "map_seconds": d.seconds_per_map.1,
        }),
    );
    m.insert("most_cpu_seconds".into(), json!(d.most_cpu_seconds));
    Value::Object(m)
}

/// `status --json` of a periodic sweep's output file.
pub fn periodic_status(file: &Path, s: &PeriodicStatus, exit_code: i32) -> Value {
    let mut m = head("status_periodic");
    m.insert("file".into(), path_text(file));
    m.insert("counts".into(), counts(&s.counts));
    let branches: Vec<Value> = s
        .branches
        .iter()
        .map(|b| {
            json!({
                "state": b.state,
                "points": b.points,
                "special": b.special.iter().map(|(k, at)| json!({"kind": k, "at": at})).collect::<Vec<_>>(),
                "end": b.end,
            })
        })
        .collect();
    m.insert("branches".into(), json!(branches));
    m.insert("damage".into(), json!(s.damage));
    m.insert("exit_code".into(), json!(exit_code));
    Value::Object(m)
}

pub fn dry_run_search(sweep: &Sweep, grid: &Grid, output: &Path, d: &SearchDryRun) -> Value {
    let mut m = head("dry_run_search");
    m.insert("output".into(), path_text(output));
    m.insert(
        "search".into(),
        json!(sweep.search.as_ref().map(|s| s.describe())),
    );
    m.insert("dims".into(), dims(sweep));
    m.insert("record".into(), record(grid));
    m.insert("searches".into(), json!(d.searches));
    m.insert(
        "runs".into(),
        json!({
            "most": d.most_runs,
            "first_scans": d.first_scan_runs,
            "stored": d.stored_runs,
        }),
    );
    m.insert("searches_ended".into(), json!(d.finished));
    m.insert("cost".into(), cost(d.cost.as_ref()));
    Value::Object(m)
}
