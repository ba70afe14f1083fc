//! Running one scene: the solver under [`guarded`] (`catch_unwind`), its output checked and turned
//! into a [`RunRecord`].
//!
//! A run fails, with its reason recorded, when the solver panics, returns an error (invalid
//! scene, NaN or infinite state, step budget exceeded, step size collapsed), produces a non-finite
//! number in what is stored, or exceeds the sweep's energy-drift limit.

use std::cell::RefCell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;
use std::time::Instant;

use std::time::Duration;

use chainsweep_solver::{run_until, RunError, RunOutput, Scene};

use crate::identity::RunHash;
use crate::record::RunRecord;
use crate::sweep::Limits;

thread_local! {
    /// `Some("")` while a [`guarded`] call runs on this thread; the panic hook fills in the
    /// message of a panic there.
    static LAST_PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

static HOOK: Once = Once::new();

/// Installs (once per process) a panic hook that records the message and location of a panic
/// inside [`guarded`] for the failed run's reason, instead of printing it over the progress
/// display. Panics elsewhere are printed as usual.
pub fn install_panic_hook() {
    HOOK.call_once(|| {
        let default = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            let msg = payload_text(info.payload());
            let loc = info
                .location()
                .map(|l| format!(" at {}:{}", l.file(), l.line()))
                .unwrap_or_default();
            let in_run = LAST_PANIC.with(|p| {
                let mut p = p.borrow_mut();
                if p.as_deref() == Some("") {
                    *p = Some(format!("panic{loc}: {msg}"));
                    true
                } else {
                    false
                }
            });
            if !in_run {
                default(info);
            }
        }));
    });
}

fn payload_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_string()
    }
}

/// Runs `f`, turning a panic into `Err` with its message and location (`panic at
/// src/x.rs:12: what`): the one place where runs are isolated from each other. Calls may nest.
pub fn guarded<T>(f: impl FnOnce() -> T) -> std::result::Result<T, String> {
    install_panic_hook();
    let outer = LAST_PANIC.with(|p| p.borrow_mut().replace(String::new()));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    let recorded = LAST_PANIC.with(|p| std::mem::replace(&mut *p.borrow_mut(), outer));
    result.map_err(|payload| {
        recorded
            .filter(|m| !m.is_empty())
            .unwrap_or_else(|| format!("panic: {}", payload_text(payload.as_ref())))
    })
}

/// Environment variable naming grid points (flat indices, comma separated) whose run panics on
/// purpose: a testing aid for the end-to-end tests (the library's tests use an executor instead).
pub const INJECT_PANIC_ENV: &str = "CHAINSWEEP_INJECT_PANIC";

fn injected_panic(index: usize) -> bool {
    std::env::var(INJECT_PANIC_ENV)
        .map(|v| v.split(',').any(|s| s.trim().parse::<usize>() == Ok(index)))
        .unwrap_or(false)
}

/// Runs the scene of grid point `index` and records the outcome.
pub fn execute(scene: &Scene, hash: RunHash, limits: &Limits, index: usize) -> RunRecord {
    execute_inner(scene, hash, limits, Some(index))
}

/// Runs the scene of grid point `index` on a continuation axis (its `continuation` set): its
/// record under `hash`, and its final state when it succeeded (what the next point on the axis
/// starts from).
pub fn execute_continued(
    scene: &Scene,
    hash: RunHash,
    limits: &Limits,
    index: Option<usize>,
) -> (RunRecord, Option<Vec<f64>>) {
    let (result, wall) = run_bounded(scene, (limits.max_run_seconds, SWEEP_LIMIT), index);
    match result {
        Err(reason) => (RunRecord::failed(hash, reason, wall), None),
        Ok(mut out) => {
            let state = out.final_state.take();
            let record = record_of(scene, hash, limits, out, wall);
            let state = state.filter(|_| record.ok);
            (record, state)
        }
    }
}

/// Runs the scene of a single point (not a grid's: `chainsweep.run`) and records the outcome, or
/// `None` when `stop` was set before it ended (an interrupt: nothing is recorded).
pub fn execute_stoppable(
    scene: &Scene,
    hash: RunHash,
    limits: &Limits,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Option<RunRecord> {
    let start = Instant::now();
    let limit = (limits.max_run_seconds, SWEEP_LIMIT);
    let deadline = start + Duration::from_secs_f64(limit.0);
    let result = guarded(|| {
        if injected_panic(0) {
            panic!("injected panic for grid point 0 ({INJECT_PANIC_ENV})");
        }
        chainsweep_solver::scene::solve::run_stoppable(scene, Some(deadline), Some(stop))
    });
    let wall = start.elapsed().as_secs_f64();
    match result {
        Ok(Err(RunError::Stopped { .. })) => None,
        Ok(Ok(out)) => Some(record_of(scene, hash, limits, out, wall)),
        Ok(Err(e)) => Some(RunRecord::failed(
            hash,
            failure_reason(scene, limit, &e),
            wall,
        )),
        Err(reason) => Some(RunRecord::failed(hash, reason, wall)),
    }
}

/// Runs a verification scene and records the outcome under `hash`.
pub fn execute_verification(scene: &Scene, hash: RunHash, limits: &Limits) -> RunRecord {
    execute_inner(scene, hash, limits, None)
}

/// Runs a pilot scene of `integrator: auto`; the record carries no hash.
pub fn execute_pilot(scene: &Scene, limits: &Limits) -> RunRecord {
    execute_inner(scene, [0u8; 32], limits, None)
}

/// Runs `scene` under [`guarded`], stopped once it has run `limit.0` seconds: its output and wall
/// time, or why it failed. A run stopped at the limit says how far it got and, in parentheses,
/// `limit.1`: the setting that set the limit (such as `--max-run-seconds`).
pub fn run_guarded(
    scene: &Scene,
    limit: (f64, &str),
) -> (std::result::Result<RunOutput, String>, f64) {
    run_bounded(scene, limit, None)
}

/// [`run_guarded`], with the injected panic of grid point `index` (the end-to-end tests' aid).
fn run_bounded(
    scene: &Scene,
    (limit_s, setting): (f64, &str),
    index: Option<usize>,
) -> (std::result::Result<RunOutput, String>, f64) {
    let start = Instant::now();
    let deadline = start + Duration::from_secs_f64(limit_s);
    let result = guarded(|| {
        if let Some(i) = index.filter(|&i| injected_panic(i)) {
            panic!("injected panic for grid point {i} ({INJECT_PANIC_ENV})");
        }
        run_until(scene, Some(deadline))
    })
    .and_then(|r| r.map_err(|e| failure_reason(scene, (limit_s, setting), &e)));
    (result, start.elapsed().as_secs_f64())
}

/// What a sweep's run stopped at its wall-time limit says of the limit.
const SWEEP_LIMIT: &str =
    "limits.max_run_seconds; raise it and run again with --retry-failed to finish this run";

fn execute_inner(scene: &Scene, hash: RunHash, limits: &Limits, index: Option<usize>) -> RunRecord {
    let (result, wall) = run_bounded(scene, (limits.max_run_seconds, SWEEP_LIMIT), index);
    match result {
        Err(reason) => RunRecord::failed(hash, reason, wall),
        Ok(out) => record_of(scene, hash, limits, out, wall),
    }
}

/// Why a run failed, in words: the solver's reason, or for a run stopped at its wall-time limit
/// how far it got and the setting of the limit.
fn failure_reason(scene: &Scene, (limit_s, setting): (f64, &str), e: &RunError) -> String {
    match e {
        RunError::Deadline {
            t_s,
            steps,
            rejected,
        } => format!(
            "wall-time limit {limit_s} s reached at t = {t_s:.3e} s of {:.3e} s after {steps} steps ({rejected} rejected attempts) ({setting})",
            scene.duration_s
        ),
        other => other.to_string(),
    }
}

/// Checks a finished run's output and turns it into its record: failed when a stored number is
/// not finite or the energy drift exceeds the limit.
fn record_of(
    scene: &Scene,
    hash: RunHash,
    limits: &Limits,
    out: RunOutput,
    wall: f64,
) -> RunRecord {
    let bad = non_finite(scene, &out);
    if !bad.is_empty() {
        return RunRecord::failed(hash, format!("non-finite result: {}", bad.join(", ")), wall);
    }
    if let Some(limit) = limits.energy_drift_max {
        if out.energy_drift_max > limit {
            return RunRecord::failed(
                hash,
                format!(
                    "energy drift {:.3e} exceeds the limit {limit:.3e} (limits.energy_drift_max)",
                    out.energy_drift_max
                ),
                wall,
            );
        }
    }
    // The whole chain's length: the run validated the scene already, so this cannot fail; if it
    // did, how much was integrated is simply not known.
    let integrated = match out.active_particles {
        Some(k) => Some((true, k as u64)),
        None => scene
            .validate()
            .ok()
            .map(|chain| (false, chain.n_particles() as u64)),
    };
    RunRecord {
        hash,
        ok: true,
        reason: String::new(),
        steps: out.stats.steps,
        rejected: out.stats.rejected,
        rhs_evals: out.stats.rhs_evals,
        events: out.stats.events,
        t_end_s: out.t_end_s,
        energy_drift_max: out.energy_drift_max,
        energy_drift_final: out.energy_drift_final,
        momentum_residual_max: out.momentum_residual_max,
        impact_energy_j: out.impact_energy_j,
        wall_time_s: wall,
        max_overlap_m: out.max_overlap_m,
        warnings: out.warnings.join("\n"),
        integrated_particles: integrated.map(|(_, n)| n),
        moving_part: integrated.map(|(moving, _)| moving),
        probes: out.probes,
        min_overlap_m: out.min_overlap_m,
        history: out.history,
        fields: out.fields,
        energy_flow: out.energy_flow,
        spectrum: out.spectrum,
        steady_state: out.steady_state,
        energy_ledger: scene.record.energy_ledger.then(|| {
            [
                crate::record::ledger_terms(&out.initial_energy),
                crate::record::ledger_terms(&out.final_energy),
            ]
        }),
    }
}

/// The stored numbers of a run's output that are not finite, in words.
fn non_finite(scene: &Scene, out: &RunOutput) -> Vec<String> {
    let mut bad: Vec<String> = Vec::new();
    for (name, x) in [
        ("t_end_s", out.t_end_s),
        ("energy_drift_max", out.energy_drift_max),
        ("energy_drift_final", out.energy_drift_final),
        ("momentum_residual_max", out.momentum_residual_max),
        ("max_overlap_m", out.max_overlap_m),
    ] {
        if !x.is_finite() {
            bad.push(format!("{name} = {x}"));
        }
    }
    for (p, s) in scene.record.probes.iter().zip(&out.probes) {
        if !s.record_max.is_finite() {
            bad.push(format!("{} record maximum = {}", p.name(), s.record_max));
        }
    }
    if let Some(h) = &out.history {
        for (p, series) in scene.record.probes.iter().zip(&h.values) {
            if let Some(x) = series.iter().find(|x| !x.is_finite()) {
                bad.push(format!("{} history holds {x}", p.name()));
            }
        }
    }
    if let Some(s) = &out.spectrum {
        // The gap's edges and the band top are NaN where there is none; the frequencies never.
        for (name, x) in [
            ("lowest_frequency_hz", s.lowest_frequency_hz),
            ("highest_frequency_hz", s.highest_frequency_hz),
        ] {
            if !x.is_finite() {
                bad.push(format!("{name} = {x}"));
            }
        }
    }
    if let Some(m) = &out.min_overlap_m {
        if m.iter().any(|x| !x.is_finite()) {
            bad.push("min_overlap_m holds a non-finite value".to_string());
        }
    }
    if let Some(f) = &out.energy_flow {
        let all = f
            .energy_passed_max_j
            .iter()
            .chain(&f.energy_passed_final_j)
            .chain(&f.max_kinetic_energy_j);
        if let Some(x) = all.into_iter().find(|x| !x.is_finite()) {
            bad.push(format!("the energy flow holds {x}"));
        }
    }
    if let Some(f) = &out.fields {
        // (Stored fields are NaN only beyond a run's end and its contacts or particles.)
        for s in &f.series {
            if let Some(x) = s.values.iter().find(|x| !x.is_finite()) {
                bad.push(format!("the {} field holds {x}", s.quantity.name()));
            }
        }
    }
    bad
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_its_message_and_location() {
        let r: std::result::Result<(), String> = guarded(|| panic!("boom {}", 7));
        let msg = r.unwrap_err();
        assert!(msg.starts_with("panic at "), "{msg}");
        assert!(msg.ends_with(": boom 7"), "{msg}");
        assert_eq!(guarded(|| 3), Ok(3));
    }

    #[test]
    fn guarded_calls_nest() {
        let outer = guarded(|| {
            let inner: std::result::Result<(), String> = guarded(|| panic!("inner"));
            assert!(inner.unwrap_err().ends_with(": inner"));
            panic!("outer");
        });
        assert!(outer.unwrap_err().ends_with(": outer"));
    }
}
